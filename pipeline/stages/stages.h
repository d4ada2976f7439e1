/* SPDX-License-Identifier: MIT */
/* The built-in stages and their settings (the contract: pipeline/stage.h). */
#ifndef SUNPROBE_PIPELINE_STAGES_H
#define SUNPROBE_PIPELINE_STAGES_H

#include <stdint.h>

#include "pipeline/stage.h"
#include "sunprobe/sp_face_model.h"
#include "sunprobe/sp_probe.h"
#include "sunprobe/sp_sunstage.h"
#include "common/private_api.h"

/* Settings of the replay stages (null, stats, orientation, landmarks). */
typedef struct sp_stage_options {
    const char *output_path; /* stage-specific output file (CSV), may be NULL; stages write it under a
                                temporary name and commit it only when finish succeeds (atomic_file.h) */
} sp_stage_options;

extern const sp_stage_ops sp_stage_null;
extern const sp_stage_ops sp_stage_stats;
extern const sp_stage_ops sp_stage_orientation; /* tagged: writes the tagger's orientation per frame */
extern const sp_stage_ops sp_stage_landmarks;   /* the landmark tracker on every frame */
/* The landmark tracker on one frame of any format, through an RGB24 buffer grown as needed (*rgb, malloc'd). */
struct ss_lm_tracker;
struct ss_lm_result;
int sp_stage_frame_landmarks(struct ss_lm_tracker *t, const sp_frame *f, uint8_t **rgb, size_t *rgb_size,
                             struct ss_lm_result *r);
extern SP_PRIVATE const sp_stage_ops sp_stage_video_orientation; /* orientation from the video alone (no IMU) */
/* After that stage finished (ctx: its sp_stage.ctx): a frame's camera-to-world by sequence, shaped as
   sp_tagger_settings.orientation_for; SP_ENODATA for a frame it has not, or only coasted through. */
SP_PRIVATE int sp_video_orientation_for(void *ctx, uint64_t sequence, int64_t timestamp_ns, sp_quat *camera_to_world);
/* How the tracking went (valid once finish ran, also when it failed). */
struct sp_vo_result;
SP_PRIVATE int sp_video_orientation_result(void *ctx, struct sp_vo_result *out);

/* "fit": the SunStage front end (tagged frames into the keyframe reservoir); ctx is the sp_sunstage. */
typedef struct sp_fit_stage_settings {
    sp_sunstage_settings fit;
    const sp_face_model *model; /* borrowed; must outlive the stage */
} sp_fit_stage_settings;
extern SP_PRIVATE const sp_stage_ops sp_stage_fit;

/* "probe": People as Scene Probes on the frames of stream 0 (untagged: a static camera needs no orientation). */
typedef struct sp_probe_stage_settings {
    sp_probe_settings probe;
    uint32_t width, height;     /* the capture's frame size */
    /* called after each probed frame (index counts from 0), may be NULL; non-zero stops the stream */
    int (*on_frame)(void *user, const sp_probe *probe, const sp_frame *frame, uint64_t index);
    void *user;
} sp_probe_stage_settings;
extern SP_PRIVATE const sp_stage_ops sp_stage_probe;
/* The probe of an open "probe" stage (borrowed from the stage). */
SP_PRIVATE sp_probe *sp_probe_stage_probe(const sp_stage *st);

#endif
