/* SPDX-License-Identifier: MIT */
/*
 * PNG reader: any PNG (gray, gray+alpha, RGB, RGBA, palette; 1..16 bits) decoded
 * to 8-bit RGBA (16-bit samples keep their high byte; no gamma conversion).
 * Decoded by libpng where it is built (png_libpng.c), interlaced images included.
 * Without libpng a minimal decoder reads non-interlaced PNGs, inflating through
 * zlib when built with it; without zlib too, only stored (uncompressed) deflate
 * blocks, which is what this project's own writer produces in such builds, and
 * anything compressed gives SP_EDISABLED with a message naming -Dzlib.
 */
#ifndef SUNPROBE_EXPORT_PNG_READ_H
#define SUNPROBE_EXPORT_PNG_READ_H

#include <stddef.h>
#include <stdint.h>
#include "common/private_api.h"

#define SP_PNG_MAX_SIDE 16384u       /* pixels a side the reader accepts */
#define SP_PNG_MAX_PIXELS (1u << 28) /* and in all */

/*
 * Decodes `size` bytes (borrowed) into *rgba (malloc'd, width*height*4 bytes,
 * the caller frees). Returns 0; SP_EFORMAT for data that is not a PNG;
 * SP_ECORRUPT for a bad checksum, structure or stream; SP_ETRUNCATED when it
 * ends early; SP_EUNSUPPORTED for interlaced images without libpng; -E2BIG beyond 16384 pixels
 * a side or 2^28 pixels; SP_EDISABLED as above.
 */
SP_PRIVATE int sp_png_decode_rgba(const uint8_t *data, size_t size, uint8_t **rgba, uint32_t *width, uint32_t *height);
/* Reads and decodes a file (`path` borrowed); -errno when it cannot be read. */
SP_PRIVATE int sp_png_read_rgba(const char *path, uint8_t **rgba, uint32_t *width, uint32_t *height);
/* 1 when the PNG carries alpha (gray + alpha, RGBA, or a tRNS chunk), 0 when not, SP_EFORMAT when not a PNG. */
SP_PRIVATE int sp_png_has_alpha(const uint8_t *data, size_t size);

/*
 * A PNG or (where libjpeg is built) JPEG file, told apart by content, as RGB24 into *rgb (malloc'd,
 * width*height*3 bytes, the caller frees); alpha is dropped. The PNG reader's errors, the JPEG
 * decoder's (SP_EDISABLED without libjpeg), or -errno.
 */
SP_PRIVATE int sp_image_read_rgb8(const char *path, uint8_t **rgb, uint32_t *width, uint32_t *height);
#endif
