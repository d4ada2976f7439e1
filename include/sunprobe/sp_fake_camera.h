/* SPDX-License-Identifier: MIT */
/*
 * The fake camera: test-pattern frames at a configurable size, rate and pixel
 * format, always built. Its "panorama" pattern draws what a camera turning in
 * place would see (a sky and a horizon of coloured posts), given its yaw.
 */
#ifndef SUNPROBE_SP_FAKE_CAMERA_H
#define SUNPROBE_SP_FAKE_CAMERA_H

#include <stdint.h>

#include "sp_common.h"
#include "sp_frame.h"

#ifdef __cplusplus
extern "C" {
#endif

enum sp_fake_pattern {
    SP_FAKE_PATTERN_BARS = 0,     /* colour bars with a moving block: fixed camera */
    SP_FAKE_PATTERN_PANORAMA = 1, /* a horizon seen by a camera at the yaw given per frame */
};

typedef struct sp_fake_camera_settings {
    uint32_t width, height;  /* default 640x480 */
    double fps;              /* default 30 */
    enum sp_pixfmt format;   /* GRAY8, RGB24, YUYV or NV12; default YUYV */
    enum sp_fake_pattern pattern;
    double hfov_deg;         /* horizontal field of view for the panorama; default 65 */
    unsigned pool_frames;    /* default 4 */
} sp_fake_camera_settings;

typedef struct sp_fake_camera sp_fake_camera;

SP_API void sp_fake_camera_default_settings(sp_fake_camera_settings *s);
SP_API int sp_fake_camera_open(sp_fake_camera **out, const sp_fake_camera_settings *s);
SP_API void sp_fake_camera_close(sp_fake_camera **cam);
/*
 * Renders frame number `sequence` (timestamp = start + sequence / fps) seen at
 * `yaw_rad` (panorama) into a pooled frame the caller then owns. -EAGAIN when
 * the caller holds every pooled frame.
 */
SP_API int sp_fake_camera_frame(sp_fake_camera *cam, uint64_t sequence, int64_t timestamp_ns, double yaw_rad,
                                sp_frame **out);

#ifdef __cplusplus
}
#endif
#endif
