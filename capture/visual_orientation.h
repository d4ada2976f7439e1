/* SPDX-License-Identifier: MIT */
/*
 * Camera orientation from the video alone, for captures without an IMU
 * (ORIENTATION.md, "Without an IMU"). A selfie turn moves the camera on a
 * circle of arm's length, small against the distance of the background, so the
 * background moves by a rotation only: corners tracked from frame to frame give
 * each step's rotation (a two-point RANSAC, then least squares). The person
 * moves with the camera, so of two well-supported motions the one that is not
 * the identity is the world's. The chain drifts; when the turn comes back to
 * where it started, the first frame is matched again and the difference is
 * spread over the turn (loop closure). World up is the accelerometer's when
 * the capture has one, else the turn's axis (a person turns about the
 * vertical), else the first frame's up when the turn is too short to say;
 * the result reports which. The heading is relative: world +x is
 * the first frame's forward direction on the horizon.
 *
 * Memory: one frame in grey at the capture's size, the first, the last and the
 * current one and a mask at the working size (a 1920-px video is tracked at
 * 480 px), and 72 bytes per frame.
 */
#ifndef SUNPROBE_CAPTURE_VISUAL_ORIENTATION_H
#define SUNPROBE_CAPTURE_VISUAL_ORIENTATION_H

#include <stddef.h>
#include <stdint.h>

#include "common/private_api.h"
#include "sunprobe/sp_frame.h"
#include "sunprobe/sp_math.h"

typedef struct sp_vo_settings {
    uint32_t width, height; /* the capture's frame size */
    double fx, fy, cx, cy;  /* its intrinsics, pixels */
} sp_vo_settings;

typedef struct sp_vo_result {
    uint64_t frames;
    uint64_t coasted;      /* frames whose step had too few background tracks: the last step repeated */
    double median_inliers; /* tracks agreeing with each step's rotation, median over the steps */
    double turn_deg;       /* the sum of the step rotations */
    int loop_closed;       /* the first frame was found again */
    uint64_t loop_frame;   /* ... at this frame */
    unsigned loop_inliers;
    double loop_correction_deg; /* the drift the closure removed */
    int up_from_gravity;        /* world up is the accelerometer's (sp_vo_gravity on half the frames or more) */
    int up_from_turn;           /* else: world up is the turn's axis (else the first frame's up) */
    double turn_axis_share;     /* how much of the rotation is about that axis (0..1) */
    double axis_to_gravity_deg; /* with both: the angle between the turn's axis and the accelerometer's up; NaN */
} sp_vo_result;

typedef struct sp_vo sp_vo;

/* -EINVAL for a size or intrinsics that are not usable. */
int sp_vo_open(sp_vo **out, const sp_vo_settings *s);
/*
 * One frame, in capture order (borrowed), with the face's 68 landmarks (x, y in capture pixels,
 * Multi-PIE order) when known, else NULL: the person around them is no background. SP_EMODULE
 * without OpenCV; -EINVAL for another size.
 */
int sp_vo_push(sp_vo *v, const sp_frame *frame, const float *landmarks);
/*
 * The accelerometer's up at the last pushed frame: the specific force it measures (m/s^2, pointing up at
 * rest), in camera axes. Optional; with it on half the frames or more, world up is gravity's rather than
 * the turn's axis. -EINVAL before a frame or for a vector that is not finite or under 1 m/s^2.
 */
int sp_vo_gravity(sp_vo *v, sp_vec3 up_in_camera);
/*
 * Closes the loop and sets world up; *r says how it went. SP_ENODATA when the
 * background could not be tracked (over a fifth of the steps coasted, or no
 * step found a rotation): the orientations are then not to be used.
 */
int sp_vo_finish(sp_vo *v, sp_vo_result *r);
/* Camera-to-world of frame i (0-based, in push order; world z up, camera x right, y down, z forward)
   after sp_vo_finish; *tracked is 0 for a coasted frame. -ERANGE past the end. */
int sp_vo_camera(const sp_vo *v, size_t i, sp_quat *camera_to_world, int *tracked);
void sp_vo_close(sp_vo **v);

#endif
