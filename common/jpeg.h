/* SPDX-License-Identifier: MIT */
/*
 * JPEG in memory: a header parser that needs no library (so JPEG files can be
 * stored as MJPEG frames in any build), and a decoder/encoder on libjpeg that
 * returns SP_EDISABLED naming `-Djpeg` in builds without it.
 */
#ifndef SUNPROBE_COMMON_JPEG_H
#define SUNPROBE_COMMON_JPEG_H

#include <stddef.h>
#include <stdint.h>

#include "sunprobe/sp_frame.h"

typedef struct sp_jpeg_header {
    uint32_t width, height;
    int components; /* 1 gray, 3 colour, 4 CMYK/YCCK */
    int progressive;
} sp_jpeg_header;

/*
 * Walks the markers from SOI to the first SOS and reads the frame header.
 * Returns 0, SP_EFORMAT when the data does not start like a JPEG, SP_ECORRUPT
 * for a broken marker structure or zero sizes, SP_ETRUNCATED when it ends first.
 * `data` is borrowed for the call. Always available (no libjpeg needed).
 */
int sp_jpeg_parse_header(const uint8_t *data, size_t size, sp_jpeg_header *out);

/* 1 when this build decodes and encodes JPEG (libjpeg found), else 0. */
int sp_jpeg_available(void);

/*
 * Decodes a JPEG into a caller buffer as SP_PIXFMT_RGB24 or SP_PIXFMT_GRAY8,
 * rows `dst_stride` bytes apart; dst_size must hold (height-1)*dst_stride plus
 * one packed row. The image must be exactly width x height (from the header
 * or the frame that carried it), else SP_ECORRUPT. Corrupt or truncated data
 * gives SP_ECORRUPT (the decoder's warnings count as errors: a half-grey frame
 * is worse than none), 4-component JPEGs SP_EUNSUPPORTED, a short dst -EINVAL.
 * Without libjpeg: SP_EDISABLED.
 */
int sp_jpeg_decode(const uint8_t *data, size_t size, enum sp_pixfmt out_format, uint32_t width,
                   uint32_t height, uint8_t *dst, size_t dst_size, uint32_t dst_stride);

/* A growing output buffer the encoder reuses across calls; free with sp_jpeg_buffer_free. */
typedef struct sp_jpeg_buffer {
    uint8_t *data;
    size_t size; /* bytes of the last encoded image */
    size_t cap;
} sp_jpeg_buffer;

/*
 * Encodes packed RGB24 rows (`stride` bytes apart) at quality 1..100 (4:2:0
 * chroma, baseline) into buf, growing it as needed. Returns 0, -EINVAL for bad
 * arguments, -ENOMEM, or SP_EDISABLED without libjpeg.
 */
int sp_jpeg_encode_rgb24(const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, int quality,
                         sp_jpeg_buffer *buf);
void sp_jpeg_buffer_free(sp_jpeg_buffer *buf);

#endif
