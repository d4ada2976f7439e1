/* SPDX-License-Identifier: MIT */
/* Internal: the C face of the libcamera C++ shim; sp_camera_libcamera_ops wraps it. Only with HAVE_LIBCAMERA. */
#ifndef SUNPROBE_DEVICE_LIBCAMERA_SHIM_H
#define SUNPROBE_DEVICE_LIBCAMERA_SHIM_H

#include <stddef.h>
#include <stdint.h>

#include "sunprobe/sp_camera.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sp_lc_camera sp_lc_camera;

int sp_lc_enumerate(sp_camera_desc *out, size_t max, size_t *count);
int sp_lc_modes(const char *id, sp_camera_mode *out, size_t max, size_t *count);
int sp_lc_claims(const char *device);
/* Acquires and configures the camera; the caller owns *out (sp_lc_close). */
int sp_lc_open(sp_lc_camera **out, const sp_camera_settings *s, sp_camera_info *info);
int sp_lc_start(sp_lc_camera *cam);
int sp_lc_next(sp_lc_camera *cam, int timeout_ms, sp_frame **out);
int sp_lc_stop(sp_lc_camera *cam);
uint64_t sp_lc_dropped(sp_lc_camera *cam);
void sp_lc_close(sp_lc_camera *cam);

#ifdef __cplusplus
}
#endif
#endif
