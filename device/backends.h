/* SPDX-License-Identifier: MIT */
/* Internal: the camera and IMU backend tables the registries list, and helpers they share. */
#ifndef SUNPROBE_DEVICE_BACKENDS_H
#define SUNPROBE_DEVICE_BACKENDS_H

#include <stddef.h>

#include "sp_config.h"
#include "sunprobe/sp_camera.h"
#include "sunprobe/sp_imu_device.h"

extern const sp_camera_ops sp_camera_fake_ops;
#if HAVE_V4L2
extern const sp_camera_ops sp_camera_v4l2_ops;
#endif
#if HAVE_LIBCAMERA
extern const sp_camera_ops sp_camera_libcamera_ops;
#endif

extern const sp_imu_ops sp_imu_fake_ops;
extern const sp_imu_ops sp_imu_iio_ops;

/* Copies a string into a fixed buffer, always NUL-terminated, truncating. */
void sp_dev_copy_string(char *dst, size_t size, const char *src);

#endif
