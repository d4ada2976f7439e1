/* SPDX-License-Identifier: MIT */
/* `sunprobe check`: a capture's fitness for a SunStage fit, measured in one pass (check_capture.c). */
#ifndef SUNPROBE_TOOLS_CHECK_CAPTURE_H
#define SUNPROBE_TOOLS_CHECK_CAPTURE_H

#include <stddef.h>
#include <stdio.h>

#include "sunprobe/sp_capture.h"

/* The turn `sunprobe check` asks for before it says ok (README "check"). */
#define SP_CHECK_GOOD_TURN_DEG 300

typedef struct sp_check_report {
    size_t frames, undecodable, gyro_samples;
    double duration_s, fps, max_gap_s;  /* from the frames' timestamps (fps: 1 / median interval) */
    double clipped_share;               /* frames with more than 5 % of pixels at 250 or above */
    double sharpness;                   /* median Laplacian energy / mean^2 (for comparing captures of one scene) */
    double blurred_share, blur_max_px;  /* frames whose gyro x shutter x focal exceeds 1 px at 128 px wide (NaN unknown) */
    double gyro_hz, imu_coverage;       /* gyro rate; share of frames inside the gyro log's span */
    double turn_deg, turn_range_deg;    /* net turn about gravity from first to last frame; its range */
    double light_modulation;            /* the face's (else the centre's) brightness: first harmonic over yaw / mean; NaN unknown */
    int light_from_face;                /* 1: measured in the landmarks' box (faces on most frames), 0: the frame's centre */
    double face_share;                  /* frames with landmarks (side data, else dlib), NaN when not looked for */
    size_t face_skipped;                /* live: sampled frames whose face was not looked for, the check being behind */
    /* without gyroscope samples, `check` tracks the background as the fit would (video_orientation.h) */
    int video_checked, video_ok, video_loop_closed;
    size_t video_frames, video_coasted;
} sp_check_report;

/*
 * Reads the capture at path (borrowed) into r; find_faces: run the fit's landmark tracker (dlib) on
 * frames without landmark side data. 0, or a negative error (the file, not the verdict).
 */
int sp_check_capture(const char *path, int find_faces, sp_check_report *r);

/*
 * The same measurements chunk by chunk, for a capture still being written (`record`'s live check):
 * open, feed every chunk in file order, ask for the report over what was fed so far as often as
 * wanted. face_interval_s: the landmark tracker runs on frames at least this many seconds apart (0:
 * every frame), so a live check keeps up with the camera.
 */
typedef struct sp_check_scan sp_check_scan;
int sp_check_scan_open(sp_check_scan **out, int find_faces, double face_interval_s);
int sp_check_scan_chunk(sp_check_scan *s, const sp_chunk *ch);
int sp_check_scan_report(sp_check_scan *s, sp_check_report *r);
/* While paused, frames due for the landmark tracker are counted as skipped instead (a live check
 * that has fallen behind the camera catches up); side data is still used. */
void sp_check_scan_pause_faces(sp_check_scan *s, int paused);
void sp_check_scan_close(sp_check_scan **s);

/* The verdict on a report, one line per item ("ok  ", "warn" or "FAIL", the item, what to re-shoot) to
 * out; counts fails and warnings. */
typedef struct sp_check_verdicts {
    int fails, warns;
} sp_check_verdicts;
void sp_check_judge(const sp_check_report *r, FILE *out, sp_check_verdicts *v);

#endif
