/* SPDX-License-Identifier: MIT */
/*
 * PNG through libpng (built when libpng is found): the decoder behind sp_png_decode_rgba and the
 * row-by-row writer behind sp_png_stream_* (and so sp_png_write / sp_png_encode). libpng reads every
 * valid PNG, interlaced ones included, and its default adaptive row filters make files about a third
 * smaller than the minimal writer's filter-less rows; the minimal reader and writer in png_read.c and
 * png.c remain for builds without it. Errors come back through setjmp: each function that calls into
 * libpng sets its own jump point and keeps what it must free in memory the jump does not clobber.
 */
#include <errno.h>
#include <png.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/file_util.h"
#include "png.h"
#include "png_read.h"
#include "sunprobe/sp_common.h"

/* ---- reading ---- */

typedef struct png_source {
    const uint8_t *data;
    size_t size, pos;
    int error; /* the sunprobe code of the first failure */
} png_source;

static void source_read(png_structp png, png_bytep out, size_t n)
{
    png_source *src = png_get_io_ptr(png);
    if (n > src->size - src->pos) {
        src->error = SP_ETRUNCATED;
        png_error(png, "truncated");
    }
    memcpy(out, src->data + src->pos, n);
    src->pos += n;
}

static void read_failed(png_structp png, png_const_charp msg)
{
    png_source *src = png_get_error_ptr(png);
    if (!src->error) /* libpng says only "Out of memory" for allocations; everything else is bad data */
        src->error = strstr(msg, "memory") ? -ENOMEM : SP_ECORRUPT;
    png_longjmp(png, 1);
}

static void no_warning(png_structp png, png_const_charp msg)
{
    (void)png, (void)msg; /* ancillary-chunk complaints change no pixel */
}

/* The transformations that turn any colour type and depth into 8-bit RGBA, as the minimal reader does. */
static void want_rgba8(png_structp png, png_infop info)
{
    int color = png_get_color_type(png, info), depth = png_get_bit_depth(png, info);
    if (depth == 16)
        png_set_strip_16(png); /* the high byte, as the minimal reader takes */
    if (color == PNG_COLOR_TYPE_PALETTE)
        png_set_palette_to_rgb(png);
    if (color == PNG_COLOR_TYPE_GRAY && depth < 8)
        png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS))
        png_set_tRNS_to_alpha(png);
    if (color == PNG_COLOR_TYPE_GRAY || color == PNG_COLOR_TYPE_GRAY_ALPHA)
        png_set_gray_to_rgb(png);
    png_set_filler(png, 0xff, PNG_FILLER_AFTER); /* no effect where alpha is already there */
    png_set_interlace_handling(png);
}

int sp_png_decode_rgba(const uint8_t *data, size_t size, uint8_t **rgba, uint32_t *width, uint32_t *height)
{
    if (!data || !rgba || !width || !height)
        return -EINVAL;
    if (size < 8 || png_sig_cmp(data, 0, 8))
        return SP_EFORMAT;
    png_source src = { .data = data, .size = size };
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &src, read_failed, no_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!info) {
        png_destroy_read_struct(&png, NULL, NULL);
        return -ENOMEM;
    }
    uint8_t *volatile out = NULL;
    png_bytep *volatile rows = NULL;
    int ret = 0;
    if (setjmp(png_jmpbuf(png))) {
        ret = src.error ? src.error : SP_ECORRUPT;
        goto done;
    }
    png_set_read_fn(png, &src, source_read);
    png_set_user_limits(png, 0x7fffffff, 0x7fffffff); /* the side and area limits below are this reader's */
    png_read_info(png, info);
    uint32_t w = png_get_image_width(png, info), h = png_get_image_height(png, info);
    if (w > SP_PNG_MAX_SIDE || h > SP_PNG_MAX_SIDE || (uint64_t)w * h > SP_PNG_MAX_PIXELS) {
        ret = -E2BIG;
        goto done;
    }
    want_rgba8(png, info);
    png_read_update_info(png, info);
    if (png_get_rowbytes(png, info) != (size_t)w * 4) {
        ret = SP_ECORRUPT;
        goto done;
    }
    out = malloc((size_t)w * h * 4);
    rows = malloc(sizeof(png_bytep) * h);
    if (!out || !rows) {
        ret = -ENOMEM;
        goto done;
    }
    for (uint32_t y = 0; y < h; y++)
        rows[y] = out + (size_t)y * w * 4;
    png_read_image(png, rows);
    png_read_end(png, NULL); /* to IEND: checks the last CRC and that nothing is cut off */
    *rgba = out;
    *width = w;
    *height = h;
    out = NULL;
done:
    free(out);
    free(rows);
    png_destroy_read_struct(&png, &info, NULL);
    return ret;
}

/* ---- writing ---- */

struct sp_png_stream {
    png_structp png;
    png_infop info;
    FILE *f;
    uint32_t height, rows_done, row_bytes;
    int error; /* the first failure; every call after it returns it */
};

static void sink_write(png_structp png, png_bytep data, size_t n)
{
    sp_png_stream *s = png_get_io_ptr(png);
    if (fwrite(data, 1, n, s->f) != n) {
        s->error = sp_write_error();
        png_error(png, "write");
    }
}

static void sink_flush(png_structp png)
{
    (void)png; /* the caller's atomic file flushes and syncs once, at the end */
}

static void write_failed(png_structp png, png_const_charp msg)
{
    sp_png_stream *s = png_get_error_ptr(png);
    if (!s->error)
        s->error = strstr(msg, "memory") ? -ENOMEM : -EIO;
    png_longjmp(png, 1);
}

int sp_png_stream_open(sp_png_stream **out, FILE *f, uint32_t width, uint32_t height, int channels)
{
    static const int color_type[5] = { 0, PNG_COLOR_TYPE_GRAY, 0, PNG_COLOR_TYPE_RGB, PNG_COLOR_TYPE_RGBA };
    if (!out || !f || !width || !height || (channels != 1 && channels != 3 && channels != 4) ||
        width > 0x7fffffffu / 4 || height > 0x7fffffffu)
        return -EINVAL;
    sp_png_stream *s = calloc(1, sizeof(*s));
    if (!s)
        return -ENOMEM;
    *s = (sp_png_stream){ .f = f, .height = height, .row_bytes = width * (uint32_t)channels };
    s->png = png_create_write_struct(PNG_LIBPNG_VER_STRING, s, write_failed, no_warning);
    s->info = s->png ? png_create_info_struct(s->png) : NULL;
    *out = s;
    if (!s->info) {
        s->error = -ENOMEM;
    } else if (!setjmp(png_jmpbuf(s->png))) {
        png_set_write_fn(s->png, s, sink_write, sink_flush);
        png_set_user_limits(s->png, 0x7fffffff, 0x7fffffff);
        png_set_IHDR(s->png, s->info, width, height, 8, color_type[channels], PNG_INTERLACE_NONE,
                     PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
        png_write_info(s->png, s->info);
    }
    int ret = s->error;
    if (ret)
        sp_png_stream_finish(out);
    return ret;
}

int sp_png_stream_rows(sp_png_stream *s, const uint8_t *rows, uint32_t n, uint32_t stride)
{
    if (!s || !rows || n > s->height - s->rows_done || stride < s->row_bytes)
        return -EINVAL;
    if (s->error || setjmp(png_jmpbuf(s->png)))
        return s->error;
    for (uint32_t y = 0; y < n; y++, s->rows_done++)
        png_write_row(s->png, rows + (size_t)y * stride);
    return 0;
}

int sp_png_stream_finish(sp_png_stream **sp)
{
    sp_png_stream *s = sp ? *sp : NULL;
    if (!s)
        return 0;
    if (!s->error && s->rows_done != s->height)
        s->error = -EINVAL;
    if (!s->error && !setjmp(png_jmpbuf(s->png)))
        png_write_end(s->png, NULL);
    int ret = s->error;
    png_destroy_write_struct(&s->png, &s->info);
    free(s);
    *sp = NULL;
    return ret;
}
