/* SPDX-License-Identifier: MIT */
/*
 * PNG writer: 8-bit gray, RGB or RGBA. Through libpng where it is built (its default adaptive row
 * filters and deflate level); otherwise a minimal writer: rows unfiltered, deflate via zlib when built
 * with it, stored blocks without.
 */
#ifndef SUNPROBE_EXPORT_PNG_H
#define SUNPROBE_EXPORT_PNG_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "common/private_api.h"

/*
 * Writes `path` atomically (temporary file, then rename). channels: 1, 3 or 4;
 * stride in bytes. Returns 0 or a negative errno.
 */
SP_PRIVATE int sp_png_write(const char *path, const uint8_t *pixels, uint32_t width, uint32_t height,
                 uint32_t stride, int channels);
/* The same PNG into a malloc'd buffer (*out, caller frees); 0, -EINVAL or -ENOMEM. */
int sp_png_encode(const uint8_t *pixels, uint32_t width, uint32_t height, uint32_t stride, int channels,
                  uint8_t **out, size_t *out_size);

/*
 * A PNG written row by row to a stream the caller opened (and closes), so an
 * image never has to be whole in memory: the deflate state and one IDAT buffer
 * are all it keeps.
 */
typedef struct sp_png_stream sp_png_stream;
/* Writes the signature and header to f (borrowed until finish). 0, -EINVAL, -ENOMEM or a write error. */
SP_PRIVATE int sp_png_stream_open(sp_png_stream **out, FILE *f, uint32_t width, uint32_t height, int channels);
/* Appends n rows (stride bytes apart, borrowed). -EINVAL past the height; a write error (-ENOSPC...) as is. */
SP_PRIVATE int sp_png_stream_rows(sp_png_stream *s, const uint8_t *rows, uint32_t n, uint32_t stride);
/* Ends the stream (every row written: 0; else -EINVAL) and frees *s; accepts NULL. */
SP_PRIVATE int sp_png_stream_finish(sp_png_stream **s);

#endif
