/* SPDX-License-Identifier: MIT */
#include "png_read.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/file_util.h"
#include "common/jpeg.h"
#include "sp_config.h"
#include "sunprobe/sp_common.h"
#if HAVE_ZLIB
#include <zlib.h>
#endif

static uint32_t get_be32(const uint8_t *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}

#if !HAVE_LIBPNG /* the minimal decoder; with libpng sp_png_decode_rgba is png_libpng.c's */
typedef struct png_info {
    uint32_t width, height;
    int depth, color, interlace;
    uint8_t palette[256][4];
    unsigned n_palette;
    uint16_t trns_gray, trns_rgb[3];
    int has_trns;
} png_info;

static uint32_t crc_update(uint32_t crc, const uint8_t *p, size_t n)
{
    static uint32_t table[256];
    if (!table[1])
        for (uint32_t i = 0; i < 256; i++) {
            uint32_t c = i;
            for (int k = 0; k < 8; k++)
                c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
            table[i] = c;
        }
    crc = ~crc;
    while (n--)
        crc = table[(crc ^ *p++) & 0xff] ^ (crc >> 8);
    return ~crc;
}

static int channels_of(int color)
{
    switch (color) {
    case 0: return 1;
    case 2: return 3;
    case 3: return 1;
    case 4: return 2;
    case 6: return 4;
    default: return 0;
    }
}

static int parse_ihdr(const uint8_t *d, uint32_t len, png_info *info)
{
    if (len != 13)
        return SP_ECORRUPT;
    info->width = get_be32(d);
    info->height = get_be32(d + 4);
    info->depth = d[8], info->color = d[9], info->interlace = d[12];
    int ok_depth = info->color == 0 ? (info->depth == 1 || info->depth == 2 || info->depth == 4 || info->depth == 8 ||
                                       info->depth == 16)
                   : info->color == 3 ? (info->depth == 1 || info->depth == 2 || info->depth == 4 || info->depth == 8)
                                      : (info->depth == 8 || info->depth == 16);
    if (!channels_of(info->color) || !ok_depth || d[10] != 0 || d[11] != 0 || info->interlace > 1 ||
        !info->width || !info->height)
        return SP_ECORRUPT;
    if (info->width > SP_PNG_MAX_SIDE || info->height > SP_PNG_MAX_SIDE ||
        (uint64_t)info->width * info->height > SP_PNG_MAX_PIXELS)
        return -E2BIG;
    return info->interlace ? SP_EUNSUPPORTED : 0;
}

static void parse_plte_trns(const char *type, const uint8_t *d, uint32_t len, png_info *info)
{
    if (!memcmp(type, "PLTE", 4)) {
        info->n_palette = len / 3 > 256 ? 256 : len / 3;
        for (unsigned i = 0; i < info->n_palette; i++) {
            memcpy(info->palette[i], d + 3 * i, 3);
            info->palette[i][3] = 255;
        }
    } else if (!memcmp(type, "tRNS", 4)) {
        info->has_trns = 1;
        if (info->color == 3)
            for (uint32_t i = 0; i < len && i < 256; i++)
                info->palette[i][3] = d[i];
        else if (info->color == 0 && len >= 2)
            info->trns_gray = (uint16_t)(d[0] << 8 | d[1]);
        else if (info->color == 2 && len >= 6)
            for (int c = 0; c < 3; c++)
                info->trns_rgb[c] = (uint16_t)(d[2 * c] << 8 | d[2 * c + 1]);
    }
}

/* Walks the chunks: IHDR, palette, and the concatenated IDAT payload (malloc'd into *z). */
static int read_chunks(const uint8_t *data, size_t size, png_info *info, uint8_t **z, size_t *z_n)
{
    static const uint8_t sig[8] = { 0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n' };
    if (size < 8 || memcmp(data, sig, 8))
        return SP_EFORMAT;
    size_t pos = 8, cap = 0;
    int seen_ihdr = 0, ret = 0;
    while (!ret) {
        if (size - pos < 12)
            return SP_ETRUNCATED;
        uint32_t len = get_be32(data + pos);
        const char *type = (const char *)data + pos + 4;
        if (len > 0x7fffffffu || size - pos - 12 < len)
            return SP_ETRUNCATED;
        const uint8_t *d = data + pos + 8;
        if (crc_update(crc_update(0, (const uint8_t *)type, 4), d, len) != get_be32(d + len))
            return SP_ECORRUPT;
        pos += 12 + (size_t)len;
        if (!seen_ihdr) {
            if (memcmp(type, "IHDR", 4))
                return SP_ECORRUPT;
            seen_ihdr = 1;
            ret = parse_ihdr(d, len, info);
        } else if (!memcmp(type, "IDAT", 4)) {
            if (*z_n + len > cap) {
                cap = (*z_n + len) * 2;
                uint8_t *nz = realloc(*z, cap);
                if (!nz)
                    return -ENOMEM;
                *z = nz;
            }
            memcpy(*z + *z_n, d, len);
            *z_n += len;
        } else if (!memcmp(type, "IEND", 4)) {
            break;
        } else {
            parse_plte_trns(type, d, len, info);
        }
    }
    if (!ret && !*z_n)
        ret = SP_ECORRUPT;
    if (!ret && info->color == 3 && !info->n_palette)
        ret = SP_ECORRUPT;
    return ret;
}

#if !HAVE_ZLIB
/* Stored deflate blocks only; anything compressed needs zlib. */
static int inflate_stored(const uint8_t *z, size_t n, uint8_t *out, size_t out_n)
{
    if (n < 6 || (z[0] & 0x0f) != 8 || ((z[0] << 8) | z[1]) % 31)
        return SP_ECORRUPT;
    size_t pos = 2, o = 0;
    for (int last = 0; !last;) {
        if (pos + 5 > n)
            return SP_ETRUNCATED;
        last = z[pos] & 1;
        if (z[pos] & 6) {
            sp_log(SP_LOG_ERROR, "png", "compressed PNG data needs zlib: build with -Dzlib=enabled");
            return SP_EDISABLED;
        }
        size_t len = (size_t)z[pos + 1] | (size_t)z[pos + 2] << 8;
        if ((len ^ ((size_t)z[pos + 3] | (size_t)z[pos + 4] << 8)) != 0xffff)
            return SP_ECORRUPT;
        pos += 5;
        if (pos + len > n || o + len > out_n)
            return pos + len > n ? SP_ETRUNCATED : SP_ECORRUPT;
        memcpy(out + o, z + pos, len);
        o += len;
        pos += len;
    }
    return o == out_n ? 0 : SP_ETRUNCATED;
}
#endif

static int inflate_all(const uint8_t *z, size_t n, uint8_t *out, size_t out_n)
{
#if HAVE_ZLIB
    z_stream s;
    memset(&s, 0, sizeof(s));
    if (inflateInit(&s) != Z_OK)
        return -ENOMEM;
    s.next_in = (Bytef *)(uintptr_t)z;
    s.avail_in = (uInt)n;
    s.next_out = out;
    s.avail_out = (uInt)out_n;
    int rc = inflate(&s, Z_FINISH);
    size_t got = out_n - s.avail_out;
    inflateEnd(&s);
    if (rc == Z_STREAM_END && got == out_n)
        return 0;
    return rc == Z_BUF_ERROR || (rc == Z_STREAM_END && got < out_n) ? SP_ETRUNCATED : SP_ECORRUPT;
#else
    return inflate_stored(z, n, out, out_n);
#endif
}

static uint8_t paeth(int a, int b, int c)
{
    int p = a + b - c, pa = abs(p - a), pb = abs(p - b), pc = abs(p - c);
    return (uint8_t)(pa <= pb && pa <= pc ? a : pb <= pc ? b : c);
}

/* Undoes the per-row filters in place; rows are 1 + row_bytes long, bpp bytes per pixel (at least 1). */
static int unfilter(uint8_t *raw, uint32_t rows, size_t row_bytes, size_t bpp)
{
    for (uint32_t y = 0; y < rows; y++) {
        uint8_t *r = raw + (size_t)y * (row_bytes + 1), *cur = r + 1;
        const uint8_t *prev = y ? raw + (size_t)(y - 1) * (row_bytes + 1) + 1 : NULL;
        for (size_t i = 0; i < row_bytes; i++) {
            int a = i >= bpp ? cur[i - bpp] : 0, b = prev ? prev[i] : 0, c = prev && i >= bpp ? prev[i - bpp] : 0;
            switch (r[0]) {
            case 0: break;
            case 1: cur[i] = (uint8_t)(cur[i] + a); break;
            case 2: cur[i] = (uint8_t)(cur[i] + b); break;
            case 3: cur[i] = (uint8_t)(cur[i] + ((a + b) >> 1)); break;
            case 4: cur[i] = (uint8_t)(cur[i] + paeth(a, b, c)); break;
            default: return SP_ECORRUPT;
            }
        }
    }
    return 0;
}

/* Sample i of a row as a 16-bit value (sub-byte depths unpacked, big-endian 16-bit). */
static unsigned sample_at(const uint8_t *row, size_t i, int depth)
{
    if (depth == 16)
        return (unsigned)row[2 * i] << 8 | row[2 * i + 1];
    if (depth == 8)
        return row[i];
    size_t bit = i * (size_t)depth;
    return (row[bit / 8] >> (8 - depth - bit % 8)) & ((1u << depth) - 1);
}

static uint8_t to8(unsigned v, int depth)
{
    return depth == 16 ? (uint8_t)(v >> 8) : (uint8_t)(v * 255u / ((1u << depth) - 1));
}

static void convert_row(const png_info *info, const uint8_t *row, uint8_t *out)
{
    int ch = channels_of(info->color), d = info->depth;
    for (uint32_t x = 0; x < info->width; x++, out += 4) {
        unsigned s[4] = { 0 };
        for (int c = 0; c < ch; c++)
            s[c] = sample_at(row, (size_t)x * ch + c, d);
        if (info->color == 3) {
            const uint8_t *p = s[0] < info->n_palette ? info->palette[s[0]] : info->palette[0];
            memcpy(out, p, 4);
            continue;
        }
        int gray = ch <= 2;
        for (int c = 0; c < 3; c++)
            out[c] = to8(s[gray ? 0 : c], d);
        out[3] = ch == 2 ? to8(s[1], d) : ch == 4 ? to8(s[3], d) : 255;
        if (info->has_trns && ((info->color == 0 && s[0] == info->trns_gray) ||
                               (info->color == 2 && s[0] == info->trns_rgb[0] && s[1] == info->trns_rgb[1] &&
                                s[2] == info->trns_rgb[2])))
            out[3] = 0;
    }
}

int sp_png_decode_rgba(const uint8_t *data, size_t size, uint8_t **rgba, uint32_t *width, uint32_t *height)
{
    if (!data || !rgba || !width || !height)
        return -EINVAL;
    png_info info;
    memset(&info, 0, sizeof(info));
    uint8_t *z = NULL, *raw = NULL, *out = NULL;
    size_t z_n = 0;
    int ret = read_chunks(data, size, &info, &z, &z_n);
    size_t bits = (size_t)info.width * (size_t)channels_of(info.color) * (size_t)info.depth;
    size_t row_bytes = (bits + 7) / 8, bpp = (size_t)channels_of(info.color) * (size_t)info.depth / 8;
    if (!ret) {
        raw = malloc((row_bytes + 1) * info.height);
        out = malloc((size_t)info.width * info.height * 4);
        ret = raw && out ? inflate_all(z, z_n, raw, (row_bytes + 1) * info.height) : -ENOMEM;
    }
    if (!ret)
        ret = unfilter(raw, info.height, row_bytes, bpp ? bpp : 1);
    for (uint32_t y = 0; !ret && y < info.height; y++)
        convert_row(&info, raw + (size_t)y * (row_bytes + 1) + 1, out + (size_t)y * info.width * 4);
    free(z);
    free(raw);
    if (ret) {
        free(out);
        return ret;
    }
    *rgba = out;
    *width = info.width;
    *height = info.height;
    return 0;
}

#endif

int sp_png_read_rgba(const char *path, uint8_t **rgba, uint32_t *width, uint32_t *height)
{
    if (!path)
        return -EINVAL;
    FILE *f = fopen(path, "rb");
    if (!f)
        return -errno;
    uint8_t *buf = NULL;
    size_t n = 0, cap = 0;
    int ret = 0;
    for (;;) {
        if (n == cap) {
            cap = cap ? cap * 2 : 65536;
            uint8_t *nb = cap <= ((size_t)1 << 31) ? realloc(buf, cap) : NULL;
            if (!nb) {
                ret = -ENOMEM;
                break;
            }
            buf = nb;
        }
        size_t got = fread(buf + n, 1, cap - n, f);
        n += got;
        if (got == 0) {
            ret = ferror(f) ? -EIO : 0;
            break;
        }
    }
    fclose(f);
    if (!ret)
        ret = sp_png_decode_rgba(buf, n, rgba, width, height);
    free(buf);
    return ret;
}

int sp_png_has_alpha(const uint8_t *data, size_t size)
{
    static const uint8_t sig[8] = { 0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n' };
    if (!data || size < 33 || memcmp(data, sig, 8) || memcmp(data + 12, "IHDR", 4))
        return SP_EFORMAT;
    if (data[25] == 4 || data[25] == 6) /* gray + alpha, RGBA */
        return 1;
    for (size_t p = 8; p + 12 <= size;) { /* a tRNS chunk before the image data gives the others alpha */
        uint32_t len = get_be32(data + p);
        if (!memcmp(data + p + 4, "tRNS", 4))
            return 1;
        if (!memcmp(data + p + 4, "IDAT", 4) || len > size - p - 12)
            break;
        p += 12 + (size_t)len;
    }
    return 0;
}

int sp_image_read_rgb8(const char *path, uint8_t **rgb, uint32_t *width, uint32_t *height)
{
    if (!path || !rgb || !width || !height)
        return -EINVAL;
    *rgb = NULL;
    void *data = NULL;
    size_t size = 0;
    int ret = sp_read_whole_file(path, (size_t)1 << 28, &data, &size);
    if (ret)
        return ret;
    sp_jpeg_header jh;
    if (!sp_jpeg_parse_header(data, size, &jh)) {
        size_t n = (size_t)jh.width * jh.height * 3;
        *width = jh.width, *height = jh.height;
        *rgb = malloc(n);
        ret = *rgb ? sp_jpeg_decode(data, size, SP_PIXFMT_RGB24, jh.width, jh.height, *rgb, n, jh.width * 3)
                   : -ENOMEM;
    } else {
        uint8_t *rgba = NULL;
        ret = sp_png_decode_rgba(data, size, &rgba, width, height);
        *rgb = ret ? NULL : malloc((size_t)*width * *height * 3);
        if (!ret && !*rgb)
            ret = -ENOMEM;
        for (size_t i = 0; !ret && i < (size_t)*width * *height; i++)
            memcpy(*rgb + 3 * i, rgba + 4 * i, 3);
        free(rgba);
    }
    free(data);
    if (ret) {
        free(*rgb);
        *rgb = NULL;
    }
    return ret;
}
