/* SPDX-License-Identifier: MIT */
/*
 * Pipeline stages that `sunprobe replay` can stream a capture through. A stage
 * sees every event once, in timestamp order, and keeps bounded state.
 */
#ifndef SUNPROBE_PIPELINE_STAGE_H
#define SUNPROBE_PIPELINE_STAGE_H

#include <stdio.h>

#include "sunprobe/sp_source.h"

typedef struct sp_stage_options {
    const char *output_path; /* stage-specific output file, may be NULL */
} sp_stage_options;

typedef struct sp_stage_ops {
    const char *name;
    const char *description;
    int (*open)(void **ctx, const sp_stage_options *options);
    /* One step; the event is borrowed (take a frame reference to keep it). */
    int (*process)(void *ctx, const sp_event *ev);
    /* End of stream: write outputs and print a short summary to `summary`. */
    int (*finish)(void *ctx, FILE *summary);
    void (*close)(void *ctx);
} sp_stage_ops;

/* NULL-terminated registry of built-in stages. */
const sp_stage_ops *const *sp_stage_registry(void);
const sp_stage_ops *sp_stage_find(const char *name);

#endif
