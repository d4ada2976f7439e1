/* SPDX-License-Identifier: MIT */
/* PNG writer: 8-bit gray, RGB or RGBA; deflate via zlib when built with it, stored blocks otherwise. */
#ifndef SUNPROBE_EXPORT_PNG_H
#define SUNPROBE_EXPORT_PNG_H

#include <stddef.h>
#include <stdint.h>

/*
 * Writes `path` atomically (temporary file, then rename). channels: 1, 3 or 4;
 * stride in bytes. Returns 0 or a negative errno.
 */
int sp_png_write(const char *path, const uint8_t *pixels, uint32_t width, uint32_t height,
                 uint32_t stride, int channels);
/* The same PNG into a malloc'd buffer (*out, caller frees); 0, -EINVAL or -ENOMEM. */
int sp_png_encode(const uint8_t *pixels, uint32_t width, uint32_t height, uint32_t stride, int channels,
                  uint8_t **out, size_t *out_size);

#endif
