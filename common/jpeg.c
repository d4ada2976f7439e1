/* SPDX-License-Identifier: MIT */
/* JPEG header parsing (always) and libjpeg decode/encode behind HAVE_JPEG. */
#include "jpeg.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "sp_config.h"
#include "sunprobe/sp_common.h"

#if HAVE_JPEG
#include <setjmp.h>
#include <stdio.h> /* jpeglib.h uses FILE and size_t without including them */

#include <jpeglib.h>
#endif

static uint32_t be16(const uint8_t *p)
{
    return (uint32_t)p[0] << 8 | p[1];
}

/* SOF0..SOF15 except DHT (C4), JPG (C8) and DAC (CC), which share the range. */
static int is_sof(uint8_t m)
{
    return m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC;
}

static int read_sof(const uint8_t *seg, uint32_t len, uint8_t marker, sp_jpeg_header *out)
{
    if (len < 8)
        return SP_ECORRUPT;
    out->height = be16(seg + 3);
    out->width = be16(seg + 5);
    out->components = seg[7];
    out->progressive = marker == 0xC2 || marker == 0xC6 || marker == 0xCA || marker == 0xCE;
    if (out->width == 0 || out->height == 0) /* height 0 means "see DNL": not produced by cameras */
        return SP_ECORRUPT;
    if (out->components != 1 && out->components != 3 && out->components != 4)
        return SP_ECORRUPT;
    if (len < 8u + 3u * (uint32_t)out->components)
        return SP_ECORRUPT;
    return 0;
}

int sp_jpeg_parse_header(const uint8_t *data, size_t size, sp_jpeg_header *out)
{
    if (!data || !out)
        return -EINVAL;
    memset(out, 0, sizeof(*out));
    if (size < 2 || data[0] != 0xFF || data[1] != 0xD8)
        return size < 2 ? SP_ETRUNCATED : SP_EFORMAT;
    size_t pos = 2;
    int have_sof = 0;
    for (;;) {
        if (pos >= size)
            return SP_ETRUNCATED;
        if (data[pos] != 0xFF)
            return SP_ECORRUPT;
        while (pos < size && data[pos] == 0xFF) /* fill bytes before a marker */
            pos++;
        if (pos >= size)
            return SP_ETRUNCATED;
        uint8_t marker = data[pos++];
        if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7))
            continue; /* standalone markers */
        if (marker == 0xD8 || marker == 0xD9 || marker == 0x00)
            return SP_ECORRUPT; /* SOI again, EOI or a stuffed byte before any scan */
        if (pos + 2 > size)
            return SP_ETRUNCATED;
        uint32_t len = be16(data + pos);
        if (len < 2)
            return SP_ECORRUPT;
        if (pos + len > size)
            return SP_ETRUNCATED;
        if (marker == 0xDA)
            return have_sof ? 0 : SP_ECORRUPT;
        if (is_sof(marker)) {
            if (have_sof)
                return SP_ECORRUPT;
            int rc = read_sof(data + pos, len, marker, out);
            if (rc)
                return rc;
            have_sof = 1;
        }
        pos += len;
    }
}

#if HAVE_JPEG

int sp_jpeg_available(void)
{
    return 1;
}

/* libjpeg's default error_exit calls exit(): jump back to the caller instead. */
typedef struct jerr_ctx {
    struct jpeg_error_mgr pub;
    jmp_buf jump;
    int warned;
    char message[JMSG_LENGTH_MAX];
} jerr_ctx;

static void on_error_exit(j_common_ptr c)
{
    jerr_ctx *e = (jerr_ctx *)c->err;
    c->err->format_message(c, e->message);
    longjmp(e->jump, 1);
}

static void on_emit_message(j_common_ptr c, int level)
{
    jerr_ctx *e = (jerr_ctx *)c->err;
    if (level < 0 && !e->warned) { /* warnings mean damaged data; trace messages are ignored */
        c->err->format_message(c, e->message);
        e->warned = 1;
    }
}

static void on_output_message(j_common_ptr c)
{
    (void)c; /* never print from a library */
}

static struct jpeg_error_mgr *jerr_init(jerr_ctx *e)
{
    memset(e, 0, sizeof(*e));
    jpeg_std_error(&e->pub);
    e->pub.error_exit = on_error_exit;
    e->pub.emit_message = on_emit_message;
    e->pub.output_message = on_output_message;
    return &e->pub;
}

/* Source manager over a memory block; running out marks the data truncated. */
typedef struct mem_src {
    struct jpeg_source_mgr pub;
    int truncated;
} mem_src;

static const JOCTET fake_eoi[2] = { 0xFF, JPEG_EOI };

static void src_init(j_decompress_ptr c)
{
    (void)c;
}

static boolean src_fill(j_decompress_ptr c)
{
    mem_src *s = (mem_src *)c->src;
    s->truncated = 1;
    s->pub.next_input_byte = fake_eoi;
    s->pub.bytes_in_buffer = sizeof(fake_eoi);
    return TRUE;
}

static void src_skip(j_decompress_ptr c, long n)
{
    mem_src *s = (mem_src *)c->src;
    if (n <= 0)
        return;
    if ((size_t)n > s->pub.bytes_in_buffer) {
        s->pub.bytes_in_buffer = 0; /* the next read calls src_fill */
        return;
    }
    s->pub.next_input_byte += n;
    s->pub.bytes_in_buffer -= (size_t)n;
}

static void src_term(j_decompress_ptr c)
{
    (void)c;
}

static void src_setup(mem_src *s, const uint8_t *data, size_t size)
{
    memset(s, 0, sizeof(*s));
    s->pub.init_source = src_init;
    s->pub.fill_input_buffer = src_fill;
    s->pub.skip_input_data = src_skip;
    s->pub.resync_to_restart = jpeg_resync_to_restart;
    s->pub.term_source = src_term;
    s->pub.next_input_byte = data;
    s->pub.bytes_in_buffer = size;
}

static int decode_rows(const uint8_t *data, size_t size, int channels, uint32_t width, uint32_t height,
                       uint8_t *dst, uint32_t dst_stride)
{
    struct jpeg_decompress_struct cinfo;
    jerr_ctx jerr;
    mem_src src;
    memset(&cinfo, 0, sizeof(cinfo));
    cinfo.err = jerr_init(&jerr);
    if (setjmp(jerr.jump)) {
        sp_log(SP_LOG_DEBUG, "jpeg", "decode failed: %s", jerr.message);
        jpeg_destroy_decompress(&cinfo);
        return SP_ECORRUPT;
    }
    jpeg_create_decompress(&cinfo);
    src_setup(&src, data, size);
    cinfo.src = &src.pub;
    jpeg_read_header(&cinfo, TRUE);
    cinfo.out_color_space = channels == 1 ? JCS_GRAYSCALE : JCS_RGB;
    jpeg_start_decompress(&cinfo);
    if (cinfo.output_width != width || cinfo.output_height != height || cinfo.output_components != channels) {
        jpeg_destroy_decompress(&cinfo);
        return SP_ECORRUPT;
    }
    while (cinfo.output_scanline < cinfo.output_height) {
        JSAMPROW row = dst + (size_t)cinfo.output_scanline * dst_stride;
        if (jpeg_read_scanlines(&cinfo, &row, 1) != 1)
            break; /* only a suspending source returns 0; ours never suspends */
    }
    int bad = cinfo.output_scanline < cinfo.output_height;
    if (!bad)
        jpeg_finish_decompress(&cinfo);
    bad = bad || jerr.warned || src.truncated;
    if (jerr.warned)
        sp_log(SP_LOG_DEBUG, "jpeg", "damaged data: %s", jerr.message);
    jpeg_destroy_decompress(&cinfo);
    return bad ? SP_ECORRUPT : 0;
}

#else /* !HAVE_JPEG */

int sp_jpeg_available(void)
{
    return 0;
}

static int jpeg_disabled(void)
{
    static int said; /* once per process: callers report the failure in their own words */
    if (!said) {
        said = 1;
        sp_log(SP_LOG_INFO, "jpeg", "JPEG decoding/encoding needs libjpeg: rebuild with -Djpeg=enabled");
    }
    return SP_EDISABLED;
}

#endif

int sp_jpeg_decode(const uint8_t *data, size_t size, enum sp_pixfmt out_format, uint32_t width,
                   uint32_t height, uint8_t *dst, size_t dst_size, uint32_t dst_stride)
{
    if (!data || !dst || width == 0 || height == 0)
        return -EINVAL;
    if (out_format != SP_PIXFMT_RGB24 && out_format != SP_PIXFMT_GRAY8)
        return -EINVAL;
    uint64_t row = (uint64_t)width * (out_format == SP_PIXFMT_RGB24 ? 3u : 1u);
    if (dst_stride < row || dst_size < (uint64_t)(height - 1) * dst_stride + row)
        return -EINVAL;
    sp_jpeg_header hdr;
    if (sp_jpeg_parse_header(data, size, &hdr) != 0)
        return SP_ECORRUPT;
    if (hdr.width != width || hdr.height != height)
        return SP_ECORRUPT;
    if (hdr.components == 4)
        return SP_EUNSUPPORTED;
#if HAVE_JPEG
    return decode_rows(data, size, out_format == SP_PIXFMT_RGB24 ? 3 : 1, width, height, dst, dst_stride);
#else
    return jpeg_disabled();
#endif
}

#if HAVE_JPEG

/* Destination manager that grows an sp_jpeg_buffer; out of memory jumps out through the error manager. */
typedef struct mem_dst {
    struct jpeg_destination_mgr pub;
    sp_jpeg_buffer *buf;
    jerr_ctx *jerr;
    int nomem;
} mem_dst;

static void dst_grow(mem_dst *d, size_t want)
{
    uint8_t *p = realloc(d->buf->data, want);
    if (!p) {
        d->nomem = 1;
        longjmp(d->jerr->jump, 1);
    }
    d->buf->data = p;
    d->buf->cap = want;
}

static void dst_init(j_compress_ptr c)
{
    mem_dst *d = (mem_dst *)c->dest;
    if (d->buf->cap < 16384)
        dst_grow(d, 16384);
    d->pub.next_output_byte = d->buf->data;
    d->pub.free_in_buffer = d->buf->cap;
}

static boolean dst_empty(j_compress_ptr c)
{
    mem_dst *d = (mem_dst *)c->dest;
    size_t used = d->buf->cap; /* libjpeg asks only when the whole buffer is full */
    if (used > SIZE_MAX / 2) {
        d->nomem = 1;
        longjmp(d->jerr->jump, 1);
    }
    dst_grow(d, used * 2);
    d->pub.next_output_byte = d->buf->data + used;
    d->pub.free_in_buffer = d->buf->cap - used;
    return TRUE;
}

static void dst_term(j_compress_ptr c)
{
    mem_dst *d = (mem_dst *)c->dest;
    d->buf->size = d->buf->cap - d->pub.free_in_buffer;
}

static int encode_rows(const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, int quality,
                       sp_jpeg_buffer *buf)
{
    struct jpeg_compress_struct cinfo;
    jerr_ctx jerr;
    mem_dst dst = { .buf = buf, .jerr = &jerr };
    memset(&cinfo, 0, sizeof(cinfo));
    cinfo.err = jerr_init(&jerr);
    if (setjmp(jerr.jump)) {
        if (!dst.nomem)
            sp_log(SP_LOG_ERROR, "jpeg", "encode failed: %s", jerr.message);
        jpeg_destroy_compress(&cinfo);
        return dst.nomem ? -ENOMEM : -EIO;
    }
    jpeg_create_compress(&cinfo);
    dst.pub.init_destination = dst_init;
    dst.pub.empty_output_buffer = dst_empty;
    dst.pub.term_destination = dst_term;
    cinfo.dest = &dst.pub;
    cinfo.image_width = width;
    cinfo.image_height = height;
    cinfo.input_components = 3;
    cinfo.in_color_space = JCS_RGB;
    jpeg_set_defaults(&cinfo);
    jpeg_set_quality(&cinfo, quality, TRUE);
    jpeg_start_compress(&cinfo, TRUE);
    while (cinfo.next_scanline < cinfo.image_height) {
        JSAMPROW row = (JSAMPROW)(rgb + (size_t)cinfo.next_scanline * stride);
        jpeg_write_scanlines(&cinfo, &row, 1);
    }
    jpeg_finish_compress(&cinfo);
    jpeg_destroy_compress(&cinfo);
    return 0;
}

#endif

int sp_jpeg_encode_rgb24(const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, int quality,
                         sp_jpeg_buffer *buf)
{
    if (!rgb || !buf || width == 0 || height == 0 || quality < 1 || quality > 100)
        return -EINVAL;
    /* JPEG stores 16-bit sizes; 65500 is libjpeg's own limit */
    if (width > 65500 || height > 65500 || stride < (uint64_t)width * 3)
        return -EINVAL;
    buf->size = 0;
#if HAVE_JPEG
    return encode_rows(rgb, width, height, stride, quality, buf);
#else
    return jpeg_disabled();
#endif
}

void sp_jpeg_buffer_free(sp_jpeg_buffer *buf)
{
    if (!buf)
        return;
    free(buf->data);
    memset(buf, 0, sizeof(*buf));
}
