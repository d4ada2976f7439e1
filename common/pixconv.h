/* SPDX-License-Identifier: MIT */
/*
 * Pixel conversion of any sp_pixfmt to packed RGB24 or GRAY8 in a caller buffer.
 *
 * YUV (YUYV, NV12) is BT.601 limited range (Y 16..235, U/V 16..240 around 128):
 *   R = 1.16438 (Y-16)                  + 1.59603 (V-128)
 *   G = 1.16438 (Y-16) - 0.39176 (U-128) - 0.81297 (V-128)
 *   B = 1.16438 (Y-16) + 2.01723 (U-128)
 * computed in 16.16 fixed point with each coefficient rounded to the nearest
 * 1/65536, the result rounded half up and clamped to 0..255; it is within 1 of
 * the exactly rounded value. Chroma is taken from the pixel's own 2x1 (YUYV)
 * or 2x2 (NV12) block, no interpolation. Gray from YUV is the luma expanded
 * to full range, round((Y-16) * 255/219); gray from RGB is the BT.601 luma
 * 0.299 R + 0.587 G + 0.114 B, same fixed point. MJPEG goes through common/jpeg
 * (SP_EDISABLED without libjpeg: build with -Djpeg=enabled).
 */
#ifndef SUNPROBE_COMMON_PIXCONV_H
#define SUNPROBE_COMMON_PIXCONV_H

#include <stddef.h>
#include <stdint.h>

#include "sunprobe/sp_frame.h"
#include "common/private_api.h"

/* A borrowed image to convert. */
typedef struct sp_pixconv_src {
    enum sp_pixfmt format;
    uint32_t width, height;
    uint32_t stride;     /* bytes per row of the first plane (NV12's UV plane shares it); unused for MJPEG */
    const uint8_t *data; /* borrowed for the call */
    size_t size;         /* bytes readable at data (the JPEG size for MJPEG) */
} sp_pixconv_src;

/*
 * Bytes an uncompressed image needs: (rows-1)*stride plus one packed row, where
 * NV12 has height + ceil(height/2) rows. 0 for MJPEG or invalid geometry
 * (stride below the minimum; for NV12 the minimum is the width rounded up to
 * even, since the last chroma pair of an odd row spans one byte past it).
 */
size_t sp_pixconv_src_min_size(const sp_pixconv_src *src);

/*
 * Converts src into dst (rows dst_stride bytes apart, dst_size bytes writable).
 * Returns 0; -EINVAL for bad geometry or a dst too small (it must hold
 * (height-1)*dst_stride plus one packed row); SP_ETRUNCATED when src->size is
 * short; SP_EUNSUPPORTED for an unknown format; for MJPEG SP_ECORRUPT when the
 * JPEG is damaged or not src->width x src->height, SP_EDISABLED without libjpeg.
 */
SP_PRIVATE int sp_pixconv_to_rgb24(const sp_pixconv_src *src, uint8_t *dst, size_t dst_size, uint32_t dst_stride);
int sp_pixconv_to_gray8(const sp_pixconv_src *src, uint8_t *dst, size_t dst_size, uint32_t dst_stride);

/* The same for a frame (its bytes_used bytes); the frame is borrowed for the call. */
SP_PRIVATE int sp_pixconv_frame_to_rgb24(const sp_frame *frame, uint8_t *dst, size_t dst_size, uint32_t dst_stride);
int sp_pixconv_frame_to_gray8(const sp_frame *frame, uint8_t *dst, size_t dst_size, uint32_t dst_stride);

#endif
