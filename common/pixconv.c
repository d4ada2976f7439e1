/* SPDX-License-Identifier: MIT */
/* Row converters from each pixel format to RGB24 and GRAY8; constants and rounding in pixconv.h. */
#include "pixconv.h"

#include <errno.h>
#include <string.h>

#include "jpeg.h"
#include "sunprobe/sp_common.h"

/* BT.601 limited range in 16.16 fixed point (coefficients rounded to nearest). */
enum {
    K_Y = 76309,  /* 255/219 */
    K_RV = 104597, /* 1.59603 */
    K_GU = 25675,  /* 0.39176 */
    K_GV = 53279,  /* 0.81297 */
    K_BU = 132201, /* 2.01723 */
    L_R = 19595,   /* 0.299 */
    L_G = 38470,   /* 0.587 */
    L_B = 7471,    /* 0.114; the three sum to 65536 so white stays 255 */
    HALF = 32768,
};

static inline uint8_t fix_to_u8(int32_t v)
{
    v += HALF;
    if (v < 0)
        return 0;
    v >>= 16;
    return v > 255 ? 255 : (uint8_t)v;
}

static inline void yuv_to_rgb(int y, int u, int v, uint8_t *out)
{
    int32_t c = K_Y * (y - 16), d = u - 128, e = v - 128;
    out[0] = fix_to_u8(c + K_RV * e);
    out[1] = fix_to_u8(c - K_GU * d - K_GV * e);
    out[2] = fix_to_u8(c + K_BU * d);
}

static inline uint8_t y_to_gray(int y)
{
    return fix_to_u8(K_Y * (y - 16));
}

typedef void (*row_fn)(const sp_pixconv_src *src, uint32_t y, uint8_t *out);

static const uint8_t *row_ptr(const sp_pixconv_src *s, size_t row)
{
    return s->data + row * s->stride;
}

static void gray_to_rgb_row(const sp_pixconv_src *s, uint32_t y, uint8_t *out)
{
    const uint8_t *in = row_ptr(s, y);
    for (uint32_t x = 0; x < s->width; x++, out += 3)
        out[0] = out[1] = out[2] = in[x];
}

static void rgb_to_rgb_row(const sp_pixconv_src *s, uint32_t y, uint8_t *out)
{
    memcpy(out, row_ptr(s, y), (size_t)s->width * 3);
}

static void yuyv_to_rgb_row(const sp_pixconv_src *s, uint32_t y, uint8_t *out)
{
    const uint8_t *in = row_ptr(s, y);
    for (uint32_t x = 0; x < s->width; x++, out += 3) {
        const uint8_t *pair = in + (size_t)(x >> 1) * 4;
        yuv_to_rgb(pair[(x & 1) * 2], pair[1], pair[3], out);
    }
}

static void nv12_to_rgb_row(const sp_pixconv_src *s, uint32_t y, uint8_t *out)
{
    const uint8_t *luma = row_ptr(s, y);
    const uint8_t *uv = row_ptr(s, (size_t)s->height + y / 2);
    for (uint32_t x = 0; x < s->width; x++, out += 3) {
        const uint8_t *c = uv + (size_t)(x >> 1) * 2;
        yuv_to_rgb(luma[x], c[0], c[1], out);
    }
}

static void gray_to_gray_row(const sp_pixconv_src *s, uint32_t y, uint8_t *out)
{
    memcpy(out, row_ptr(s, y), s->width);
}

static void rgb_to_gray_row(const sp_pixconv_src *s, uint32_t y, uint8_t *out)
{
    const uint8_t *in = row_ptr(s, y);
    for (uint32_t x = 0; x < s->width; x++, in += 3)
        out[x] = fix_to_u8(L_R * in[0] + L_G * in[1] + L_B * in[2]);
}

static void yuyv_to_gray_row(const sp_pixconv_src *s, uint32_t y, uint8_t *out)
{
    const uint8_t *in = row_ptr(s, y);
    for (uint32_t x = 0; x < s->width; x++)
        out[x] = y_to_gray(in[(size_t)x * 2]);
}

static void nv12_to_gray_row(const sp_pixconv_src *s, uint32_t y, uint8_t *out)
{
    const uint8_t *in = row_ptr(s, y);
    for (uint32_t x = 0; x < s->width; x++)
        out[x] = y_to_gray(in[x]);
}

static uint32_t min_stride(enum sp_pixfmt fmt, uint32_t width)
{
    if (fmt == SP_PIXFMT_NV12) /* the last chroma pair of an odd width ends one byte past width */
        return width > UINT32_MAX - 1 ? 0 : (width + 1) & ~1u;
    return sp_pixfmt_min_stride(fmt, width);
}

size_t sp_pixconv_src_min_size(const sp_pixconv_src *src)
{
    if (!src || src->width == 0 || src->height == 0)
        return 0;
    uint32_t row = min_stride(src->format, src->width);
    if (row == 0 || src->stride < row)
        return 0;
    uint64_t rows = src->height;
    if (src->format == SP_PIXFMT_NV12)
        rows += (src->height + 1ull) / 2;
    uint64_t need = (rows - 1) * src->stride + row; /* < 2^32 * 2^33: no overflow */
    return need > SIZE_MAX ? 0 : (size_t)need;
}

/* dst must hold (height-1)*dst_stride + width*channels bytes. */
static int check_dst(uint32_t width, uint32_t height, unsigned channels, size_t dst_size, uint32_t dst_stride)
{
    uint64_t row = (uint64_t)width * channels;
    if (dst_stride < row)
        return -EINVAL;
    if ((uint64_t)dst_size < (uint64_t)(height - 1) * dst_stride + row)
        return -EINVAL;
    return 0;
}

static int convert(const sp_pixconv_src *src, const row_fn fns[SP_PIXFMT_COUNT], enum sp_pixfmt out_fmt,
                   uint8_t *dst, size_t dst_size, uint32_t dst_stride)
{
    if (!src || !dst || !src->data || src->width == 0 || src->height == 0)
        return -EINVAL;
    if ((unsigned)src->format >= SP_PIXFMT_COUNT || src->format == SP_PIXFMT_NONE)
        return SP_EUNSUPPORTED;
    int rc = check_dst(src->width, src->height, out_fmt == SP_PIXFMT_RGB24 ? 3 : 1, dst_size, dst_stride);
    if (rc)
        return rc;
    if (src->format == SP_PIXFMT_MJPEG)
        return sp_jpeg_decode(src->data, src->size, out_fmt, src->width, src->height, dst, dst_size, dst_stride);
    size_t need = sp_pixconv_src_min_size(src);
    if (need == 0)
        return -EINVAL;
    if (src->size < need)
        return SP_ETRUNCATED;
    row_fn fn = fns[src->format];
    for (uint32_t y = 0; y < src->height; y++)
        fn(src, y, dst + (size_t)y * dst_stride);
    return 0;
}

static const row_fn to_rgb[SP_PIXFMT_COUNT] = {
    [SP_PIXFMT_GRAY8] = gray_to_rgb_row,
    [SP_PIXFMT_RGB24] = rgb_to_rgb_row,
    [SP_PIXFMT_YUYV] = yuyv_to_rgb_row,
    [SP_PIXFMT_NV12] = nv12_to_rgb_row,
};

static const row_fn to_gray[SP_PIXFMT_COUNT] = {
    [SP_PIXFMT_GRAY8] = gray_to_gray_row,
    [SP_PIXFMT_RGB24] = rgb_to_gray_row,
    [SP_PIXFMT_YUYV] = yuyv_to_gray_row,
    [SP_PIXFMT_NV12] = nv12_to_gray_row,
};

int sp_pixconv_to_rgb24(const sp_pixconv_src *src, uint8_t *dst, size_t dst_size, uint32_t dst_stride)
{
    return convert(src, to_rgb, SP_PIXFMT_RGB24, dst, dst_size, dst_stride);
}

int sp_pixconv_to_gray8(const sp_pixconv_src *src, uint8_t *dst, size_t dst_size, uint32_t dst_stride)
{
    return convert(src, to_gray, SP_PIXFMT_GRAY8, dst, dst_size, dst_stride);
}

static int frame_src(const sp_frame *frame, sp_pixconv_src *src)
{
    if (!frame || !frame->data)
        return -EINVAL;
    *src = (sp_pixconv_src){
        .format = frame->format,
        .width = frame->width,
        .height = frame->height,
        .stride = frame->stride,
        .data = frame->data,
        /* pool frames know their capacity; a frame built on the stack may leave it 0 */
        .size = frame->capacity && frame->bytes_used > frame->capacity ? frame->capacity : frame->bytes_used,
    };
    return 0;
}

int sp_pixconv_frame_to_rgb24(const sp_frame *frame, uint8_t *dst, size_t dst_size, uint32_t dst_stride)
{
    sp_pixconv_src src;
    int rc = frame_src(frame, &src);
    return rc ? rc : sp_pixconv_to_rgb24(&src, dst, dst_size, dst_stride);
}

int sp_pixconv_frame_to_gray8(const sp_frame *frame, uint8_t *dst, size_t dst_size, uint32_t dst_stride)
{
    sp_pixconv_src src;
    int rc = frame_src(frame, &src);
    return rc ? rc : sp_pixconv_to_gray8(&src, dst, dst_size, dst_stride);
}
