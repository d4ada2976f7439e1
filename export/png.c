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
