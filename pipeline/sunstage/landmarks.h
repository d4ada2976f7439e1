/* SPDX-License-Identifier: MIT */
/*
 * 68-point landmarks on the frames a phone gives (landmarks.c): faces from
 * 40 px to the full frame, side- and back-lit, turned. dlib places the points;
 * this layer picks the scale, normalises the lighting dlib sees, tracks the face
 * from frame to frame and rejects placements by a measured confidence.
 */
#ifndef SUNPROBE_SUNSTAGE_LANDMARKS_H
#define SUNPROBE_SUNSTAGE_LANDMARKS_H

#include <stdint.h>
#include "common/private_api.h"

typedef enum ss_lm_source {
    SS_LM_NONE = 0,     /* no landmarks for this frame */
    SS_LM_TRACKED = 1,  /* placed from the previous frame's landmarks */
    SS_LM_DETECTED = 2, /* placed from a face detection near the previous face */
    SS_LM_SEARCHED = 3, /* placed from a detection in the whole frame */
} ss_lm_source;

typedef struct ss_lm_result {
    ss_lm_source source;
    double lm[136];  /* x, y in the frame's pixels, Multi-PIE order (valid unless source is SS_LM_NONE) */
    double drift;    /* placing again from the placed points moves them by this much (over the eyes' distance) */
    double score;    /* the detector's score when a detection placed them, else NAN */
    double rejected_drift; /* the drift of a placement rejected on this frame (NAN when none was) */
} ss_lm_result;

typedef struct ss_lm_settings {
    const char *model_path; /* dlib 68-point shape predictor (NULL: the Debian libdlib-data path) */
    double max_drift;       /* reject placements that drift more (default 0.06 of the inter-ocular distance) */
    int normalise;          /* 1: stretch the face's grey levels before dlib sees them (default 1) */
    int track;              /* 1: seed each frame from the previous one (default 1) */
    int model_offsets;      /* 1: move dlib's points onto the face model's landmark vertices (default 1) */
} ss_lm_settings;

typedef struct ss_lm_tracker ss_lm_tracker;

SP_PRIVATE void ss_lm_default_settings(ss_lm_settings *s);
/* 0; -ENOENT / SP_ECORRUPT for the model file (named in the log); SP_EDISABLED in a build without dlib. */
SP_PRIVATE int ss_lm_tracker_open(ss_lm_tracker **t, const ss_lm_settings *s);
SP_PRIVATE void ss_lm_tracker_close(ss_lm_tracker **t);
/* Landmarks on one w x h RGB24 frame (borrowed); frames in capture order. 0 (found or not: out->source), or an error. */
SP_PRIVATE int ss_lm_tracker_frame(ss_lm_tracker *t, const uint8_t *rgb24, int w, int h, ss_lm_result *out);
/*
 * dlib places the 300-W annotation's points; the fit aligns the face model's
 * landmark vertices, which differ (a jaw contour against fixed jaw vertices,
 * inner lips, nostrils). Adds the mean offset from one to the other, measured
 * on synthetic renders of the model (tools/bench/landmark_offsets.c), in the
 * face's own frame (eye line, inter-ocular distance).
 */
void ss_lm_apply_offsets(double lm[136]);
/* The detector box learned so far against the points' box: side ratio, centre offset over the side; n detections. */
void ss_lm_tracker_box_relation(const ss_lm_tracker *t, double *side, double *dx, double *dy, int *n);
/* Distance between the outer eye corners (points 36 and 45): the scale landmark errors are quoted in. */
double ss_lm_interocular(const double lm[136]);

#endif
