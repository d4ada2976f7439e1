/* SPDX-License-Identifier: MIT */
/* Internal: V4L2 fourcc <-> sp_pixfmt, kept apart so it is testable without a device. */
#ifndef SUNPROBE_DEVICE_V4L2_FORMATS_H
#define SUNPROBE_DEVICE_V4L2_FORMATS_H

#include <stddef.h>
#include <stdint.h>

#include "sunprobe/sp_frame.h"

/* The sunprobe format of a V4L2 fourcc, SP_PIXFMT_NONE when it has none. */
enum sp_pixfmt sp_v4l2_to_pixfmt(uint32_t fourcc);
/* The fourccs that carry a sunprobe format (MJPEG has two), best first; returns how many were written. */
size_t sp_v4l2_from_pixfmt(enum sp_pixfmt fmt, uint32_t *fourccs, size_t max);

#endif
