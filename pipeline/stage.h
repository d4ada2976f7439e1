/* SPDX-License-Identifier: MIT */
/*
 * The one stage contract and the one driver loop (data flow: pipeline/STREAM.md).
 *
 * A stage consumes the event stream: it is opened with its own settings, gets
 * one event at a time (a non-blocking step), is finished at the end of the
 * stream and closed. sp_stage_run streams a capture through a stage: it opens
 * the replay, puts the orientation tagger in front of a stage that wants tagged
 * frames, and loops. Every command and benchmark that streams a capture uses it.
 */
#ifndef SUNPROBE_PIPELINE_STAGE_H
#define SUNPROBE_PIPELINE_STAGE_H

#include <signal.h>
#include <stdio.h>

#include "sunprobe/sp_meta.h"
#include "sunprobe/sp_replay.h"
#include "sunprobe/sp_source.h"
#include "sunprobe/sp_tagger.h"
#include "common/private_api.h"

typedef struct sp_stage_ops {
    const char *name;
    const char *description;
    int wants_tags; /* 1: frames must come through the orientation tagger (ev->tags set) */
    int writes_output; /* 1: sp_stage_options.output_path names a file it writes; 0: it has none */
    /* settings: the stage's own struct, named beside its ops in stages/stages.h; borrowed for the call */
    int (*open)(void **ctx, const void *settings);
    /* One step; the event is borrowed (take a frame reference to keep it). */
    int (*push)(void *ctx, const sp_event *ev);
    /* End of stream: flush and write outputs, and a short summary to `summary` (never NULL). */
    int (*finish)(void *ctx, FILE *summary);
    void (*close)(void *ctx);
} sp_stage_ops;

/* An open stage. ctx is the stage's own object (documented with its ops). */
typedef struct sp_stage {
    const sp_stage_ops *ops;
    void *ctx;
} sp_stage;

SP_PRIVATE int sp_stage_open(sp_stage *st, const sp_stage_ops *ops, const void *settings);
/* Closes an open (or never opened, zeroed) stage. */
SP_PRIVATE void sp_stage_close(sp_stage *st);

/* NULL-terminated registry of the stages `sunprobe replay --stage` runs. */
SP_PRIVATE const sp_stage_ops *const *sp_stage_registry(void);
SP_PRIVATE const sp_stage_ops *sp_stage_find(const char *name);

typedef struct sp_run_settings {
    sp_replay_settings replay;   /* with a tagger, the pool gets tagger.max_waiting frames more */
    sp_tagger_settings tagger;
    uint64_t max_frames;         /* end the stream after this many frames (then finish); 0: all */
    volatile sig_atomic_t *stop; /* non-zero (a signal handler sets it): stop before the next event, no
                                    finish; may be NULL */
    int finish;                  /* call the stage's finish at the end of the stream; default 1 */
    FILE *summary;               /* where finish writes its summary; default stdout */
    int progress;                /* 1 on, 0 off, -1 on a terminal (default) */
    const char *progress_label;  /* default "frames" */
    uint64_t progress_total;     /* frames expected, 0 when unknown */
} sp_run_settings;

enum sp_run_failure {
    SP_RUN_OK = 0,
    SP_RUN_FAILED_OPEN,   /* the capture could not be opened */
    SP_RUN_FAILED_SOURCE, /* reading it failed part way (-EAGAIN: the stage holds every frame) */
    SP_RUN_FAILED_STAGE,  /* the stage refused an event */
    SP_RUN_FAILED_FINISH, /* the stage's finish failed */
};

typedef struct sp_run_stats {
    uint64_t events, frames;     /* handed to the stage */
    int stopped;                 /* ended by `stop`: finish was not called */
    enum sp_run_failure failed_in;
    double seconds;              /* wall time of the loop */
    sp_replay_stats replay;
    int tagged;                  /* the tagger ran: `tagger` holds its counters */
    sp_tagger_stats tagger;
    sp_capture_meta meta;        /* the metadata as the last META event left it */
} sp_run_stats;

SP_PRIVATE void sp_run_default_settings(sp_run_settings *s);
/*
 * Streams the capture at `path` (borrowed) through the open stage. Returns 0 at
 * the end of the stream (or when stopped), else the first error; out (may be
 * NULL) says where it failed and what was read.
 */
SP_PRIVATE int sp_stage_run(const char *path, const sp_stage *stage, const sp_run_settings *s, sp_run_stats *out);

#endif
