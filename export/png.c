/* SPDX-License-Identifier: MIT */
#include "png.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sp_config.h"
#include "common/file_util.h"
#if HAVE_ZLIB
#include <zlib.h>
#endif

#include "common/atomic_file.h"

#if HAVE_LIBPNG
/* The whole PNG stream to f through the row writer; 0 or a negative errno. */
static int png_emit(FILE *f, const uint8_t *pixels, uint32_t width, uint32_t height, uint32_t stride, int channels)
{
    sp_png_stream *s = NULL;
    int ret = sp_png_stream_open(&s, f, width, height, channels);
    if (!ret)
        ret = sp_png_stream_rows(s, pixels, height, stride);
    int end = sp_png_stream_finish(&s);
    return ret ? ret : end;
}

#else /* the minimal writer: filter-less rows, deflate through zlib or stored blocks */
static uint32_t crc_table[256];

static void crc_init(void)
{
    for (uint32_t n = 0; n < 256; n++) {
        uint32_t c = n;
        for (int k = 0; k < 8; k++)
            c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        crc_table[n] = c;
    }
}

static uint32_t png_crc(uint32_t crc, const uint8_t *p, size_t n)
{
    crc = ~crc;
    while (n--)
        crc = crc_table[(crc ^ *p++) & 0xff] ^ (crc >> 8);
    return ~crc;
}

static void put_be32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24);
    p[1] = (uint8_t)(v >> 16);
    p[2] = (uint8_t)(v >> 8);
    p[3] = (uint8_t)v;
}

static int write_chunk(FILE *f, const char type[4], const uint8_t *data, size_t n)
{
    uint8_t hdr[8];
    put_be32(hdr, (uint32_t)n);
    memcpy(hdr + 4, type, 4);
    uint32_t crc = png_crc(png_crc(0, hdr + 4, 4), data, n);
    uint8_t tail[4];
    put_be32(tail, crc);
    if (fwrite(hdr, 1, 8, f) != 8 || (n && fwrite(data, 1, n, f) != n) || fwrite(tail, 1, 4, f) != 4)
        return sp_write_error();
    return 0;
}

/* zlib stream of stored (uncompressed) deflate blocks, for builds without zlib. */
static uint8_t *deflate_stored(const uint8_t *raw, size_t n, size_t *out_n)
{
    size_t blocks = n / 65535 + 1;
    uint8_t *out = malloc(2 + blocks * 5 + n + 4);
    if (!out)
        return NULL;
    size_t o = 0;
    out[o++] = 0x78;
    out[o++] = 0x01;
    uint32_t a = 1, b = 0;
    size_t pos = 0;
    do {
        size_t len = n - pos > 65535 ? 65535 : n - pos;
        out[o++] = pos + len == n ? 1 : 0;
        out[o++] = (uint8_t)len;
        out[o++] = (uint8_t)(len >> 8);
        out[o++] = (uint8_t)~len;
        out[o++] = (uint8_t)(~len >> 8);
        memcpy(out + o, raw + pos, len);
        for (size_t i = 0; i < len; i++) {
            a = (a + raw[pos + i]) % 65521;
            b = (b + a) % 65521;
        }
        o += len;
        pos += len;
    } while (pos < n);
    put_be32(out + o, (b << 16) | a);
    *out_n = o + 4;
    return out;
}

static uint8_t *compress_rows(const uint8_t *raw, size_t n, size_t *out_n)
{
#if HAVE_ZLIB
    uLongf cap = compressBound((uLong)n);
    uint8_t *out = malloc(cap);
    if (out && compress2(out, &cap, raw, (uLong)n, 6) == Z_OK) {
        *out_n = cap;
        return out;
    }
    free(out);
#endif
    return deflate_stored(raw, n, out_n);
}

/* Writes the whole PNG stream to f; 0 or a negative errno. */
static int png_emit(FILE *f, const uint8_t *pixels, uint32_t width, uint32_t height, uint32_t stride,
                    int channels)
{
    static const uint8_t color_type[5] = { 0, 0, 0, 2, 6 };
    if (!crc_table[1])
        crc_init();
    size_t row = (size_t)width * (size_t)channels;
    size_t raw_n = (row + 1) * height;
    uint8_t *raw = malloc(raw_n);
    if (!raw)
        return -ENOMEM;
    for (uint32_t y = 0; y < height; y++) {
        raw[y * (row + 1)] = 0; /* filter: none */
        memcpy(raw + y * (row + 1) + 1, pixels + (size_t)y * stride, row);
    }
    size_t z_n = 0;
    uint8_t *z = compress_rows(raw, raw_n, &z_n);
    free(raw);
    if (!z)
        return -ENOMEM;
    static const uint8_t sig[8] = { 0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n' };
    uint8_t ihdr[13];
    put_be32(ihdr, width);
    put_be32(ihdr + 4, height);
    ihdr[8] = 8;
    ihdr[9] = color_type[channels];
    ihdr[10] = ihdr[11] = ihdr[12] = 0;
    int ret = 0;
    if (fwrite(sig, 1, 8, f) != 8 || write_chunk(f, "IHDR", ihdr, 13) || write_chunk(f, "IDAT", z, z_n) ||
        write_chunk(f, "IEND", NULL, 0))
        ret = sp_write_error();
    free(z);
    return ret;
}

#endif

static int png_args_ok(const uint8_t *pixels, uint32_t width, uint32_t height, uint32_t stride, int channels)
{
    return pixels && width && height && (channels == 1 || channels == 3 || channels == 4) &&
           stride >= width * (uint32_t)channels;
}

int sp_png_write(const char *path, const uint8_t *pixels, uint32_t width, uint32_t height,
                 uint32_t stride, int channels)
{
    if (!path || !png_args_ok(pixels, width, height, stride, channels))
        return -EINVAL;
    sp_atomic_file af;
    int ret = sp_atomic_file_open(&af, path);
    if (ret)
        return ret;
    ret = png_emit(af.file, pixels, width, height, stride, channels);
    return sp_atomic_file_finish(&af, ret);
}

int sp_png_encode(const uint8_t *pixels, uint32_t width, uint32_t height, uint32_t stride, int channels,
                  uint8_t **out, size_t *out_size)
{
    if (!out || !out_size || !png_args_ok(pixels, width, height, stride, channels))
        return -EINVAL;
    char *buf = NULL;
    size_t n = 0;
    FILE *f = open_memstream(&buf, &n);
    if (!f)
        return -ENOMEM;
    int ret = png_emit(f, pixels, width, height, stride, channels);
    if (fclose(f) && !ret)
        ret = -ENOMEM;
    if (ret) {
        free(buf);
        return ret;
    }
    *out = (uint8_t *)buf;
    *out_size = n;
    return 0;
}

#if !HAVE_LIBPNG /* with libpng the stream is png_libpng.c's */
struct sp_png_stream {
    FILE *f;
    uint32_t width, height, rows_done, row_bytes;
    int error;
    uint8_t *buf;   /* IDAT payload being gathered */
    size_t used;
#if HAVE_ZLIB
    z_stream z;
#else
    uint32_t adler_a, adler_b;
#endif
};

#define STREAM_IDAT 65536

static int stream_flush(sp_png_stream *s)
{
    int ret = s->used ? write_chunk(s->f, "IDAT", s->buf, s->used) : 0;
    s->used = 0;
    return ret;
}

#if HAVE_ZLIB
/* Feeds n bytes through deflate, writing an IDAT whenever the buffer fills. */
static int stream_put(sp_png_stream *s, const uint8_t *p, size_t n, int flush)
{
    s->z.next_in = (Bytef *)(uintptr_t)p;
    s->z.avail_in = (uInt)n;
    for (;;) {
        s->z.next_out = s->buf + s->used;
        s->z.avail_out = (uInt)(STREAM_IDAT - s->used);
        int zr = deflate(&s->z, flush);
        s->used = STREAM_IDAT - s->z.avail_out;
        if (zr == Z_STREAM_ERROR)
            return -EIO;
        if (s->used == STREAM_IDAT) {
            int ret = stream_flush(s);
            if (ret)
                return ret;
            continue;
        }
        if (flush == Z_FINISH ? zr == Z_STREAM_END : s->z.avail_in == 0)
            return 0;
    }
}
#else
/* A stored deflate block per row; the zlib header went first, the final empty block and Adler-32 go last. */
static int stream_put(sp_png_stream *s, const uint8_t *p, size_t n, int last)
{
    uint8_t hdr[5] = { (uint8_t)(last ? 1 : 0), (uint8_t)n, (uint8_t)(n >> 8), (uint8_t)~n, (uint8_t)(~n >> 8) };
    if (s->used + 5 + n + 4 > STREAM_IDAT) {
        int ret = stream_flush(s);
        if (ret)
            return ret;
    }
    memcpy(s->buf + s->used, hdr, 5);
    memcpy(s->buf + s->used + 5, p, n);
    s->used += 5 + n;
    for (size_t i = 0; i < n; i++) {
        s->adler_a = (s->adler_a + p[i]) % 65521;
        s->adler_b = (s->adler_b + s->adler_a) % 65521;
    }
    if (last) {
        put_be32(s->buf + s->used, (s->adler_b << 16) | s->adler_a);
        s->used += 4;
    }
    return 0;
}
#endif

int sp_png_stream_open(sp_png_stream **out, FILE *f, uint32_t width, uint32_t height, int channels)
{
    static const uint8_t color_type[5] = { 0, 0, 0, 2, 6 };
    /* stored blocks hold a row of at most 65535 bytes; zlib has no such limit */
    if (!out || !f || !width || !height || (channels != 1 && channels != 3 && channels != 4) ||
        width > 0x7fffffffu / 4 || (!HAVE_ZLIB && (size_t)width * channels + 1 > 65535))
        return -EINVAL;
    if (!crc_table[1])
        crc_init();
    sp_png_stream *s = calloc(1, sizeof(*s));
    if (!s || !(s->buf = malloc(STREAM_IDAT))) {
        free(s);
        return -ENOMEM;
    }
    *s = (sp_png_stream){ .f = f, .width = width, .height = height, .row_bytes = width * (uint32_t)channels,
                          .buf = s->buf };
#if HAVE_ZLIB
    if (deflateInit(&s->z, 6) != Z_OK) {
        free(s->buf), free(s);
        return -ENOMEM;
    }
#else
    s->adler_a = 1;
    s->buf[s->used++] = 0x78, s->buf[s->used++] = 0x01;
#endif
    static const uint8_t sig[8] = { 0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n' };
    uint8_t ihdr[13] = { 0 };
    put_be32(ihdr, width);
    put_be32(ihdr + 4, height);
    ihdr[8] = 8;
    ihdr[9] = color_type[channels];
    int ret = fwrite(sig, 1, 8, f) != 8 ? sp_write_error() : write_chunk(f, "IHDR", ihdr, 13);
    *out = s;
    if (ret)
        sp_png_stream_finish(out);
    return ret;
}

int sp_png_stream_rows(sp_png_stream *s, const uint8_t *rows, uint32_t n, uint32_t stride)
{
    if (!s || !rows || n > s->height - s->rows_done || stride < s->row_bytes)
        return -EINVAL;
    uint8_t filter = 0;
    for (uint32_t y = 0; y < n && !s->error; y++) {
#if HAVE_ZLIB
        s->error = stream_put(s, &filter, 1, Z_NO_FLUSH);
        if (!s->error)
            s->error = stream_put(s, rows + (size_t)y * stride, s->row_bytes, Z_NO_FLUSH);
#else
        uint8_t line[65536];
        line[0] = filter;
        memcpy(line + 1, rows + (size_t)y * stride, s->row_bytes);
        s->error = stream_put(s, line, s->row_bytes + 1, 0);
#endif
        s->rows_done++;
    }
    return s->error;
}

int sp_png_stream_finish(sp_png_stream **sp)
{
    sp_png_stream *s = sp ? *sp : NULL;
    if (!s)
        return 0;
    int ret = s->error ? s->error : s->rows_done == s->height ? 0 : -EINVAL;
#if HAVE_ZLIB
    if (!ret)
        ret = stream_put(s, NULL, 0, Z_FINISH);
    deflateEnd(&s->z);
#else
    if (!ret)
        ret = stream_put(s, NULL, 0, 1);
#endif
    if (!ret)
        ret = stream_flush(s);
    if (!ret)
        ret = write_chunk(s->f, "IEND", NULL, 0);
    free(s->buf), free(s);
    *sp = NULL;
    return ret;
}
#endif
