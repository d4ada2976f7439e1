/* SPDX-License-Identifier: MIT */
/* common/pixconv and common/jpeg: known colours, odd sizes, padded strides, truncation, corrupt JPEG. */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "common/jpeg.h"
#include "common/pixconv.h"
#include "fixture_jpeg.h"
#include "sunprobe/sp_frame.h"

/* Exactly rounded BT.601 limited-range conversion, the reference the fixed point must match within 1. */
static int ref_channel(double v)
{
    double r = floor(v + 0.5);
    return r < 0 ? 0 : r > 255 ? 255 : (int)r;
}

static void ref_yuv(int y, int u, int v, int out[3])
{
    double c = (y - 16) * 255.0 / 219.0, d = (u - 128) * 255.0 / 224.0, e = (v - 128) * 255.0 / 224.0;
    double kr = 0.299, kb = 0.114, kg = 1.0 - kr - kb;
    out[0] = ref_channel(c + 2.0 * (1.0 - kr) * e);
    out[1] = ref_channel(c - 2.0 * kb * (1.0 - kb) / kg * d - 2.0 * kr * (1.0 - kr) / kg * e);
    out[2] = ref_channel(c + 2.0 * (1.0 - kb) * d);
}

static int convert_one_yuyv(int y, int u, int v, uint8_t rgb[3])
{
    uint8_t px[4] = { (uint8_t)y, (uint8_t)u, (uint8_t)y, (uint8_t)v };
    sp_pixconv_src src = { SP_PIXFMT_YUYV, 1, 1, 4, px, sizeof(px) };
    return sp_pixconv_to_rgb24(&src, rgb, 3, 3);
}

static void test_known_colours(void)
{
    uint8_t rgb[3];
    CHECK_EQ_INT(convert_one_yuyv(16, 128, 128, rgb), 0);
    CHECK(rgb[0] == 0 && rgb[1] == 0 && rgb[2] == 0);
    CHECK_EQ_INT(convert_one_yuyv(235, 128, 128, rgb), 0);
    CHECK(rgb[0] == 255 && rgb[1] == 255 && rgb[2] == 255);
    CHECK_EQ_INT(convert_one_yuyv(126, 128, 128, rgb), 0); /* (126-16)*255/219 = 128.08 */
    CHECK(rgb[0] == 128 && rgb[1] == 128 && rgb[2] == 128);
    /* BT.601 limited-range primaries (rounded YUV codes), each within 2 of the pure colour */
    static const int prim[3][6] = { { 81, 90, 240, 255, 0, 0 }, { 145, 54, 34, 0, 255, 0 },
                                    { 41, 240, 110, 0, 0, 255 } };
    for (int i = 0; i < 3; i++) {
        CHECK_EQ_INT(convert_one_yuyv(prim[i][0], prim[i][1], prim[i][2], rgb), 0);
        for (int c = 0; c < 3; c++)
            CHECK_MSG(abs(rgb[c] - prim[i][3 + c]) <= 2, "primary %d channel %d = %d", i, c, rgb[c]);
    }
    /* super-black/super-white and extreme chroma clamp instead of wrapping */
    CHECK_EQ_INT(convert_one_yuyv(0, 0, 0, rgb), 0);
    CHECK(rgb[0] == 0 && rgb[2] == 0);
    CHECK_EQ_INT(convert_one_yuyv(255, 255, 255, rgb), 0);
    CHECK(rgb[0] == 255 && rgb[2] == 255);
}

static void test_fixed_point_vs_reference(void)
{
    int worst = 0;
    for (int y = 0; y < 256; y += 3)
        for (int u = 0; u < 256; u += 5)
            for (int v = 0; v < 256; v += 7) {
                uint8_t rgb[3];
                int ref[3];
                convert_one_yuyv(y, u, v, rgb);
                ref_yuv(y, u, v, ref);
                for (int c = 0; c < 3; c++)
                    if (abs(rgb[c] - ref[c]) > worst)
                        worst = abs(rgb[c] - ref[c]);
            }
    CHECK_MSG(worst <= 1, "fixed point differs from exact rounding by %d", worst);
}

/* Deterministic test pattern so every pixel of every format differs from its neighbours. */
static uint8_t pat(uint32_t x, uint32_t y, unsigned k)
{
    return (uint8_t)(x * 37u + y * 101u + k * 59u + 16u);
}

static void test_yuyv_odd(void)
{
    const uint32_t w = 5, h = 3, stride = 16; /* min stride is 12 for width 5 */
    uint8_t img[16 * 3];
    memset(img, 0xEE, sizeof(img));
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t p = 0; p < 3; p++)
            for (unsigned k = 0; k < 4; k++)
                img[y * stride + p * 4 + k] = pat(p, y, k);
    uint32_t dst_stride = 19;
    uint8_t dst[19 * 3 + 1];
    memset(dst, 0xAA, sizeof(dst));
    sp_pixconv_src src = { SP_PIXFMT_YUYV, w, h, stride, img, (h - 1) * stride + 12 };
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&src, dst, (h - 1) * dst_stride + w * 3, dst_stride), 0);
    for (uint32_t y = 0; y < h; y++) {
        for (uint32_t x = 0; x < w; x++) {
            const uint8_t *pair = img + y * stride + (x / 2) * 4;
            int ref[3];
            ref_yuv(pair[(x & 1) * 2], pair[1], pair[3], ref);
            for (int c = 0; c < 3; c++)
                CHECK(abs(dst[y * dst_stride + x * 3 + c] - ref[c]) <= 1);
        }
        for (uint32_t x = w * 3; x < dst_stride && y + 1 < h; x++)
            CHECK_MSG(dst[y * dst_stride + x] == 0xAA, "padding written at row %u byte %u", y, x);
    }
    CHECK(dst[(h - 1) * dst_stride + w * 3] == 0xAA);

    uint8_t gray[5 * 3];
    CHECK_EQ_INT(sp_pixconv_to_gray8(&src, gray, sizeof(gray), w), 0);
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            int luma = img[y * stride + (x / 2) * 4 + (x & 1) * 2];
            CHECK(abs(gray[y * w + x] - ref_channel((luma - 16) * 255.0 / 219.0)) <= 1);
        }
    /* one byte short of the last row */
    src.size--;
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&src, dst, sizeof(dst), dst_stride), SP_ETRUNCATED);
    src.size++;
    src.stride = 11;
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&src, dst, sizeof(dst), dst_stride), -EINVAL);
}

static void test_nv12_odd(void)
{
    const uint32_t w = 7, h = 5, stride = 10; /* chroma rows: 3 */
    uint8_t img[10 * 8];
    memset(img, 0xEE, sizeof(img));
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++)
            img[y * stride + x] = pat(x, y, 0);
    for (uint32_t y = 0; y < 3; y++)
        for (uint32_t x = 0; x < 8; x++)
            img[(h + y) * stride + x] = pat(x, y, 1);
    uint8_t dst[7 * 3 * 5];
    sp_pixconv_src src = { SP_PIXFMT_NV12, w, h, stride, img, 7 * stride + 8 };
    CHECK_EQ_INT(sp_pixconv_src_min_size(&src), 7 * stride + 8);
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&src, dst, sizeof(dst), w * 3), 0);
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            const uint8_t *c = img + (h + y / 2) * stride + (x / 2) * 2;
            int ref[3];
            ref_yuv(img[y * stride + x], c[0], c[1], ref);
            for (int k = 0; k < 3; k++)
                CHECK_MSG(abs(dst[(y * w + x) * 3 + k] - ref[k]) <= 1, "nv12 %u,%u", x, y);
        }
    src.size--;
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&src, dst, sizeof(dst), w * 3), SP_ETRUNCATED);
    /* with stride == odd width the last V byte would lie outside the row: refused */
    src.stride = 7;
    src.size = sizeof(img);
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&src, dst, sizeof(dst), w * 3), -EINVAL);
}

static void test_rgb_gray(void)
{
    const uint32_t w = 3, h = 2, stride = 13;
    static const uint8_t colours[6][3] = { { 255, 255, 255 }, { 0, 0, 0 }, { 255, 0, 0 },
                                           { 0, 255, 0 },     { 0, 0, 255 }, { 10, 200, 30 } };
    uint8_t img[13 * 2];
    memset(img, 0x55, sizeof(img));
    for (uint32_t i = 0; i < 6; i++)
        memcpy(img + (i / 3) * stride + (i % 3) * 3, colours[i], 3);
    sp_pixconv_src src = { SP_PIXFMT_RGB24, w, h, stride, img, stride + 9 };
    uint8_t gray[2 * 4];
    memset(gray, 0xAA, sizeof(gray));
    CHECK_EQ_INT(sp_pixconv_to_gray8(&src, gray, sizeof(gray), 4), 0);
    static const uint8_t expect[6] = { 255, 0, 76, 150, 29, 124 }; /* 0.299 R + 0.587 G + 0.114 B, rounded */
    for (uint32_t i = 0; i < 6; i++)
        CHECK_MSG(gray[(i / 3) * 4 + i % 3] == expect[i], "gray %u = %u", i, gray[(i / 3) * 4 + i % 3]);
    CHECK(gray[3] == 0xAA);

    uint8_t rgb[3 * 3 * 2];
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&src, rgb, sizeof(rgb), 9), 0);
    for (uint32_t i = 0; i < 6; i++)
        CHECK(memcmp(rgb + (i / 3) * 9 + (i % 3) * 3, colours[i], 3) == 0);
    /* dst one byte short */
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&src, rgb, sizeof(rgb) - 1, 9), -EINVAL);
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&src, rgb, sizeof(rgb), 8), -EINVAL);

    /* gray -> rgb replicates, gray -> gray copies rows */
    uint8_t g[2 * 5] = { 0, 1, 2, 9, 9, 250, 251, 252, 9, 9 };
    sp_pixconv_src gs = { SP_PIXFMT_GRAY8, 3, 2, 5, g, 8 };
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&gs, rgb, sizeof(rgb), 9), 0);
    CHECK(rgb[9 + 3] == 251 && rgb[9 + 4] == 251 && rgb[9 + 5] == 251 && rgb[2] == 0);
    uint8_t g2[6];
    CHECK_EQ_INT(sp_pixconv_to_gray8(&gs, g2, sizeof(g2), 3), 0);
    CHECK(g2[3] == 250 && g2[5] == 252);
    gs.size = 7;
    CHECK_EQ_INT(sp_pixconv_to_gray8(&gs, g2, sizeof(g2), 3), SP_ETRUNCATED);

    sp_pixconv_src bad = { (enum sp_pixfmt)99, 3, 2, 9, img, sizeof(img) };
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&bad, rgb, sizeof(rgb), 9), SP_EUNSUPPORTED);
    bad.format = SP_PIXFMT_RGB24;
    bad.width = 0;
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&bad, rgb, sizeof(rgb), 9), -EINVAL);
}

static void test_frame_wrapper(void)
{
    sp_frame_pool *pool = NULL;
    sp_frame *f = NULL;
    CHECK_EQ_INT(sp_frame_pool_open(&pool, 1, 64), 0);
    CHECK_EQ_INT(sp_frame_pool_get(pool, &f), 0);
    f->format = SP_PIXFMT_YUYV;
    f->width = 2;
    f->height = 1;
    f->stride = 4;
    f->bytes_used = 4;
    const uint8_t px[4] = { 235, 128, 16, 128 };
    memcpy(f->data, px, 4);
    uint8_t rgb[6];
    CHECK_EQ_INT(sp_pixconv_frame_to_rgb24(f, rgb, sizeof(rgb), 6), 0);
    CHECK(rgb[0] == 255 && rgb[1] == 255 && rgb[2] == 255 && rgb[3] == 0 && rgb[5] == 0);
    uint8_t gray[2];
    CHECK_EQ_INT(sp_pixconv_frame_to_gray8(f, gray, sizeof(gray), 2), 0);
    CHECK(gray[0] == 255 && gray[1] == 0);
    f->bytes_used = 3;
    CHECK_EQ_INT(sp_pixconv_frame_to_rgb24(f, rgb, sizeof(rgb), 6), SP_ETRUNCATED);
    CHECK_EQ_INT(sp_pixconv_frame_to_rgb24(NULL, rgb, sizeof(rgb), 6), -EINVAL);
    sp_frame_unref(&f);
    sp_frame_pool_close(&pool);
}

/* Four flat quadrants, so JPEG round trips can be checked away from the edges. */
static void make_quadrants(uint8_t *rgb, uint32_t w, uint32_t h, uint32_t stride)
{
    static const uint8_t q[4][3] = { { 200, 30, 40 }, { 30, 180, 60 }, { 40, 50, 220 }, { 128, 128, 128 } };
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++)
            memcpy(rgb + y * stride + x * 3, q[(y >= h / 2) * 2 + (x >= w / 2)], 3);
}

static void test_jpeg_round_trip(const uint8_t *rgb, uint32_t w, uint32_t h, sp_jpeg_buffer *jb)
{
    sp_jpeg_header hdr;
    CHECK_EQ_INT(sp_jpeg_parse_header(jb->data, jb->size, &hdr), 0);
    CHECK(hdr.width == w && hdr.height == h && hdr.components == 3 && !hdr.progressive);
    uint32_t stride = w * 3 + 5;
    uint8_t *out = calloc((size_t)h * stride, 1);
    uint8_t *gray = calloc((size_t)h * (w + 3), 1);
    uint8_t *ref_gray = calloc((size_t)h * w, 1);
    sp_pixconv_src src = { SP_PIXFMT_MJPEG, w, h, 0, jb->data, jb->size };
    sp_pixconv_src raw = { SP_PIXFMT_RGB24, w, h, w * 3, rgb, (size_t)w * h * 3 };
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&src, out, (size_t)h * stride, stride), 0);
    CHECK_EQ_INT(sp_pixconv_to_gray8(&src, gray, (size_t)h * (w + 3), w + 3), 0);
    CHECK_EQ_INT(sp_pixconv_to_gray8(&raw, ref_gray, (size_t)h * w, w), 0);
    int worst = 0, worst_gray = 0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            /* skip 8 pixels around the quadrant borders: chroma subsampling and ringing live there */
            if (abs((int)x - (int)(w / 2)) < 8 || abs((int)y - (int)(h / 2)) < 8)
                continue;
            for (int c = 0; c < 3; c++) {
                int d = abs(out[y * stride + x * 3 + c] - rgb[(y * w + x) * 3 + c]);
                worst = d > worst ? d : worst;
            }
            int dg = abs(gray[y * (w + 3) + x] - ref_gray[y * w + x]);
            worst_gray = dg > worst_gray ? dg : worst_gray;
        }
    CHECK_MSG(worst <= 6, "JPEG colour error %d", worst);
    CHECK_MSG(worst_gray <= 4, "JPEG gray error %d", worst_gray);
    /* a frame that claims another size is refused */
    src.width = w + 1;
    CHECK_EQ_INT(sp_pixconv_to_rgb24(&src, out, (size_t)h * stride, stride), SP_ECORRUPT);
    free(out);
    free(gray);
    free(ref_gray);
}

static void test_jpeg_corrupt(const uint8_t *jpg, size_t n, uint32_t w, uint32_t h)
{
    uint8_t *copy = malloc(n);
    uint8_t *out = malloc((size_t)w * h * 3);
    /* truncated anywhere: refused (inside the scan the decoder would otherwise pad with grey) */
    for (size_t cut = 0; cut < n - 2; cut += (n / 40) + 1)
        CHECK_MSG(sp_jpeg_decode(jpg, cut, SP_PIXFMT_RGB24, w, h, out, (size_t)w * h * 3, w * 3) == SP_ECORRUPT,
                  "cut at %zu", cut);
    /* not a JPEG */
    memset(copy, 0x42, n);
    CHECK_EQ_INT(sp_jpeg_decode(copy, n, SP_PIXFMT_RGB24, w, h, out, (size_t)w * h * 3, w * 3), SP_ECORRUPT);
    CHECK_EQ_INT(sp_jpeg_parse_header(copy, n, &(sp_jpeg_header){ 0 }), SP_EFORMAT);
    /* a bogus Huffman table: libjpeg's error exit must come back to us, not exit() */
    memcpy(copy, jpg, n);
    size_t dht = 0;
    for (size_t i = 2; i + 4 < n && !dht; i++)
        if (copy[i] == 0xFF && copy[i + 1] == 0xC4)
            dht = i;
    CHECK(dht != 0);
    memset(copy + dht + 5, 0xFF, 16); /* code counts far beyond 256 symbols */
    CHECK_EQ_INT(sp_jpeg_decode(copy, n, SP_PIXFMT_RGB24, w, h, out, (size_t)w * h * 3, w * 3), SP_ECORRUPT);
    /* random damage in the entropy-coded data: any result but a crash; most are caught */
    unsigned seed = 12345, caught = 0;
    for (int t = 0; t < 200; t++) {
        memcpy(copy, jpg, n);
        for (int k = 0; k < 4; k++) {
            seed = seed * 1103515245u + 12345u;
            copy[n / 2 + (seed >> 8) % (n / 2 - 2)] = (uint8_t)(seed >> 20);
        }
        int rc = sp_jpeg_decode(copy, n, SP_PIXFMT_RGB24, w, h, out, (size_t)w * h * 3, w * 3);
        CHECK(rc == 0 || rc == SP_ECORRUPT);
        caught += rc == SP_ECORRUPT;
    }
    CHECK_MSG(caught > 0, "no damaged JPEG was detected");
    free(copy);
    free(out);
}

/* The library-free header parser on a real file and on every truncation of it. */
static void test_jpeg_header(void)
{
    sp_jpeg_header hdr;
    CHECK_EQ_INT(sp_jpeg_parse_header(fixture_jpeg, sizeof(fixture_jpeg), &hdr), 0);
    CHECK(hdr.width == FIXTURE_JPEG_W && hdr.height == FIXTURE_JPEG_H && hdr.components == 3 && !hdr.progressive);
    size_t sos = 0;
    for (size_t i = 2; i + 1 < sizeof(fixture_jpeg) && !sos; i++)
        if (fixture_jpeg[i] == 0xFF && fixture_jpeg[i + 1] == 0xDA)
            sos = i;
    CHECK(sos > 0);
    for (size_t n = 0; n < sos + 4; n++) { /* the header ends inside the SOS segment */
        int rc = sp_jpeg_parse_header(fixture_jpeg, n, &hdr);
        CHECK_MSG(rc == SP_ETRUNCATED, "length %zu: %d", n, rc);
    }
    uint8_t copy[sizeof(fixture_jpeg)];
    memcpy(copy, fixture_jpeg, sizeof(copy));
    copy[1] = 0xD9;
    CHECK_EQ_INT(sp_jpeg_parse_header(copy, sizeof(copy), &hdr), SP_EFORMAT);
    memcpy(copy, fixture_jpeg, sizeof(copy));
    copy[2] = 0x00; /* a marker byte expected */
    CHECK_EQ_INT(sp_jpeg_parse_header(copy, sizeof(copy), &hdr), SP_ECORRUPT);
    memcpy(copy, fixture_jpeg, sizeof(copy));
    for (size_t i = 2; i + 9 < sizeof(copy); i++)
        if (copy[i] == 0xFF && copy[i + 1] == 0xC0) {
            copy[i + 7] = 0; /* width 0 */
            copy[i + 8] = 0;
            break;
        }
    CHECK_EQ_INT(sp_jpeg_parse_header(copy, sizeof(copy), &hdr), SP_ECORRUPT);
    CHECK_EQ_INT(sp_jpeg_parse_header(NULL, 4, &hdr), -EINVAL);
}

static void test_jpeg(void)
{
    const uint32_t w = 61, h = 37; /* odd, not multiples of the 16x16 MCU */
    uint8_t *rgb = malloc((size_t)w * h * 3);
    make_quadrants(rgb, w, h, w * 3);
    sp_jpeg_buffer jb = { 0 };
    int rc = sp_jpeg_encode_rgb24(rgb, w, h, w * 3, 95, &jb);
    if (!sp_jpeg_available()) {
        CHECK_EQ_INT(rc, SP_EDISABLED);
        /* the header parser needs no library */
        sp_jpeg_header hdr;
        uint8_t soi_eoi[4] = { 0xFF, 0xD8, 0xFF, 0xD9 };
        CHECK_EQ_INT(sp_jpeg_parse_header(soi_eoi, 4, &hdr), SP_ECORRUPT);
        uint8_t out[3];
        CHECK_EQ_INT(sp_jpeg_decode(soi_eoi, 4, SP_PIXFMT_RGB24, 1, 1, out, 3, 3), SP_ECORRUPT);
        uint8_t *px = malloc(FIXTURE_JPEG_W * FIXTURE_JPEG_H * 3);
        sp_pixconv_src src = { SP_PIXFMT_MJPEG, FIXTURE_JPEG_W, FIXTURE_JPEG_H, 0, fixture_jpeg, sizeof(fixture_jpeg) };
        CHECK_EQ_INT(sp_pixconv_to_rgb24(&src, px, FIXTURE_JPEG_W * FIXTURE_JPEG_H * 3, FIXTURE_JPEG_W * 3),
                     SP_EDISABLED);
        free(px);
        free(rgb);
        fprintf(stderr, "note: built without libjpeg, JPEG decode/encode checked as disabled only\n");
        return;
    }
    CHECK_EQ_INT(rc, 0);
    CHECK(jb.size > 100 && jb.size <= jb.cap);
    test_jpeg_round_trip(rgb, w, h, &jb);
    test_jpeg_corrupt(jb.data, jb.size, w, h);
    /* bad arguments */
    CHECK_EQ_INT(sp_jpeg_encode_rgb24(rgb, w, h, w * 3, 0, &jb), -EINVAL);
    CHECK_EQ_INT(sp_jpeg_encode_rgb24(rgb, w, h, w * 3 - 1, 90, &jb), -EINVAL);
    /* buffer reuse: a bigger image grows it, a smaller one reuses it */
    uint32_t bw = 300, bh = 200;
    uint8_t *big = malloc((size_t)bw * bh * 3);
    for (size_t i = 0; i < (size_t)bw * bh * 3; i++)
        big[i] = (uint8_t)((i * 2654435761u) >> 13); /* noise compresses badly: forces growth */
    CHECK_EQ_INT(sp_jpeg_encode_rgb24(big, bw, bh, bw * 3, 100, &jb), 0);
    CHECK(jb.size > 16384);
    sp_jpeg_header hdr;
    CHECK_EQ_INT(sp_jpeg_parse_header(jb.data, jb.size, &hdr), 0);
    CHECK(hdr.width == bw && hdr.height == bh);
    uint8_t *back = malloc((size_t)bw * bh * 3);
    CHECK_EQ_INT(sp_jpeg_decode(jb.data, jb.size, SP_PIXFMT_RGB24, bw, bh, back, (size_t)bw * bh * 3, bw * 3), 0);
    free(back);
    free(big);
    sp_jpeg_buffer_free(&jb);
    CHECK(jb.data == NULL && jb.cap == 0);
    free(rgb);
}

int main(void)
{
    test_known_colours();
    test_fixed_point_vs_reference();
    test_yuyv_odd();
    test_nv12_odd();
    test_rgb_gray();
    test_frame_wrapper();
    test_jpeg_header();
    test_jpeg();
    return check_exit();
}
