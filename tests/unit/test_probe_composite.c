/* SPDX-License-Identifier: MIT */
/*
 * Compositing on hand-made maps: occlusion (eq. 3.2) hides what stands behind
 * an occluder and nothing else, lighting (eq. 3.4) scales the brightness, the
 * shadow darkens lit ground by the ratio and pre-existing shadow not at all,
 * height from the plane or the override, back-to-front order, bad arguments.
 * Also the PNG reader (filters, palettes, 16 bits, damage; interlaced images
 * through libpng; works without zlib through stored blocks) and the PFM round trip.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "sp_config.h"
#if HAVE_LIBPNG
#include <png.h>
#endif
#include "export/png.h"
#include "export/png_read.h"
#include "export/probe_dir.h"
#include "sunprobe/sp_probe.h"

enum { W = 100, H = 80 };

static float occ[W * H], light[W * H * 3];
static uint8_t bg[W * H * 3], img[W * H * 3];
static uint8_t cut[20 * 10 * 4];

static void setup(void)
{
    for (int i = 0; i < W * H; i++) {
        int x = i % W;
        occ[i] = x >= 40 && x <= 45 ? 50.0f : -1.0f; /* a pole whose foot is at row 50 */
        for (int c = 0; c < 3; c++)
            light[3 * i + c] = x < 30 ? 0.5f : 1.0f; /* the left: in shadow */
    }
    memset(bg, 100, sizeof(bg));
    for (int i = 0; i < 20 * 10; i++) { /* a 10x20 opaque cut-out, colour 200 */
        memset(cut + 4 * i, 200, 3);
        cut[4 * i + 3] = 255;
    }
}

static uint8_t px(int x, int y)
{
    return img[(y * W + x) * 3];
}

static sp_composite_object object_at(double x, double y, double height_px)
{
    return (sp_composite_object){ cut, 10, 20, 40, x, y, height_px, 1.0 };
}

static void test_occlusion(void)
{
    sp_probe_maps m = { W, H, bg, occ, NULL };
    sp_probe_plane pl = { .status = SP_PROBE_PLANE_OK, .a = 0, .b = 0.5, .c = 0 }; /* h = y / 2 */
    sp_composite_settings s;
    sp_composite_default_settings(&s);
    sp_composite_report rep;
    /* behind the pole (row 40 <= 50): the pole's columns keep the background */
    memcpy(img, bg, sizeof(img));
    sp_composite_object o = object_at(42, 40, 0);
    CHECK(sp_composite(&m, &pl, NULL, &s, &o, 1, img, W * 3, &rep) == 0);
    CHECK_NEAR(rep.height_px, 20.0, 1e-9);
    CHECK(px(42, 30) == 100 && px(38, 30) == 200 && px(46, 30) == 200);
    CHECK(rep.pixels_hidden > 0 && rep.pixels_drawn > 0);
    /* in front (row 70 > 50): drawn over the pole */
    memcpy(img, bg, sizeof(img));
    o = object_at(42, 70, 0);
    CHECK(sp_composite(&m, &pl, NULL, &s, &o, 1, img, W * 3, &rep) == 0);
    CHECK(px(42, 60) == 200 && rep.pixels_hidden == 0);
    CHECK(px(42, 30) == 100); /* 35 px tall: rows 36..70 */
    /* occlusion off */
    memcpy(img, bg, sizeof(img));
    o = object_at(42, 40, 0);
    s.occlusion = 0;
    CHECK(sp_composite(&m, &pl, NULL, &s, &o, 1, img, W * 3, &rep) == 0);
    CHECK(px(42, 30) == 200 && rep.pixels_hidden == 0);
}

static void test_lighting_and_height(void)
{
    sp_probe_maps m = { W, H, bg, NULL, light };
    sp_composite_settings s;
    sp_composite_default_settings(&s);
    sp_composite_report rep;
    memcpy(img, bg, sizeof(img));
    sp_composite_object o[2] = { object_at(15, 60, 30), object_at(70, 60, 30) };
    CHECK(sp_composite(&m, NULL, NULL, &s, o, 2, img, W * 3, &rep) == 0);
    CHECK_MSG(abs(px(15, 50) - 100) <= 1, "shadowed side %d", px(15, 50)); /* 200 * 0.5 */
    CHECK(px(70, 50) == 200);
    CHECK(px(70, 29) == 100 && px(70, 32) == 200); /* 30 px tall: rows 31..60, soft edges */
    /* scale relative to a person */
    sp_probe_plane pl = { .status = SP_PROBE_PLANE_OK, .a = 0, .b = 0, .c = 40 };
    memcpy(img, bg, sizeof(img));
    o[0] = object_at(70, 60, 0);
    o[0].height_scale = 0.5;
    CHECK(sp_composite(&m, &pl, NULL, &s, o, 1, img, W * 3, &rep) == 0);
    CHECK_NEAR(rep.height_px, 20.0, 1e-9);
    /* no plane, no override: nothing drawn */
    sp_probe_plane none = { .status = SP_PROBE_PLANE_NONE };
    memcpy(img, bg, sizeof(img));
    CHECK(sp_composite(&m, &none, NULL, &s, o, 1, img, W * 3, &rep) == SP_ENODATA);
    CHECK(memcmp(img, bg, sizeof(img)) == 0);
}

static void test_shadow(void)
{
    sp_probe_maps m = { W, H, bg, NULL, light };
    sp_probe_shadow sh = { .present = 1, .ox = { 1.0, 0, 0 }, .oy = { 0.3, 0, 0 }, .ratio = { 0.5, 0.5, 0.5 } };
    sp_composite_settings s;
    sp_composite_default_settings(&s);
    sp_composite_report rep;
    /* lit ground: the shadow to the lower right halves the background */
    memcpy(img, bg, sizeof(img));
    sp_composite_object o = object_at(50, 40, 20);
    CHECK(sp_composite(&m, NULL, &sh, &s, &o, 1, img, W * 3, &rep) == 0);
    CHECK(rep.shadow_pixels > 0);
    CHECK_MSG(px(62, 43) == 50, "shadow pixel %d", px(62, 43)); /* t = 0.5: x + 10, y + 3 */
    CHECK(px(50, 70) == 100);
    /* already in shadow (lighting 0.5 = the ratio): not darkened again */
    memcpy(img, bg, sizeof(img));
    o = object_at(5, 40, 20);
    CHECK(sp_composite(&m, NULL, &sh, &s, &o, 1, img, W * 3, &rep) == 0);
    CHECK(px(17, 43) == 100);
    /* shadows off */
    memcpy(img, bg, sizeof(img));
    o = object_at(50, 40, 20);
    s.shadow = 0;
    CHECK(sp_composite(&m, NULL, &sh, &s, &o, 1, img, W * 3, &rep) == 0 && rep.shadow_pixels == 0);
}

/*
 * Without a sun model, the contact shadow: the ground around the foot darkened by the profile at its
 * normalised distance (ellipse semi-axes 0.25 h across, a third of that deep), nothing beyond 1.75; not with a sun model
 * (its cast shadow holds the contact), not with shadows off.
 */
static void test_contact(void)
{
    sp_probe_maps m = { W, H, bg, NULL, NULL };
    sp_probe_shadow sh = { .contact_present = 1, .contact = { 0.2, 0.4, 0.6, 0.8, 0.9, 0.95 } };
    sp_composite_settings s;
    sp_composite_default_settings(&s);
    sp_composite_report rep;
    memcpy(img, bg, sizeof(img));
    sp_composite_object o = object_at(50, 60, 40); /* 20 px wide: columns 40-59, rows up to 60 */
    CHECK(sp_composite(&m, NULL, &sh, &s, &o, 1, img, W * 3, &rep) == 0);
    CHECK(rep.contact_pixels > 0 && rep.shadow_pixels == 0);
    /* linear between the rings' centres (a ring's own value would give 40 and 60): (50, 61), rho = 0.304,
       between 0.125 (0.2) and 0.375 (0.4); (50, 62), rho = 0.602, between 0.375 (0.4) and 0.625 (0.6) */
    CHECK_MSG(abs(px(50, 61) - 34) <= 1, "just below the foot %d", px(50, 61));
    CHECK_MSG(abs(px(50, 62) - 58) <= 1, "below the foot %d", px(50, 62));
    /* (64, 61): rho = 1.48, between 1.375 (0.95) and the reference at 1.75 (1) */
    CHECK_MSG(abs(px(64, 61) - 96) <= 1, "beside the foot %d", px(64, 61));
    CHECK(px(50, 70) == 100 && px(75, 60) == 100);
    /* a sun model: its shadow instead; shadows off: nothing */
    sh.present = 1, sh.ox[0] = 1.0, sh.oy[0] = 0.3, sh.ratio[0] = sh.ratio[1] = sh.ratio[2] = 0.5;
    memcpy(img, bg, sizeof(img));
    CHECK(sp_composite(&m, NULL, &sh, &s, &o, 1, img, W * 3, &rep) == 0 && rep.contact_pixels == 0);
    sh.present = 0, s.shadow = 0;
    memcpy(img, bg, sizeof(img));
    CHECK(sp_composite(&m, NULL, &sh, &s, &o, 1, img, W * 3, &rep) == 0 && rep.contact_pixels == 0);
    CHECK(px(50, 62) == 100);
    /* a profile out of range from a caller: clamped, never wrapped to bright */
    s.shadow = 1, sh.contact[0] = sh.contact[1] = -3;
    memcpy(img, bg, sizeof(img));
    CHECK(sp_composite(&m, NULL, &sh, &s, &o, 1, img, W * 3, &rep) == 0 && px(50, 61) == 0);
    /* ground the occlusion map hides: an occluder whose foot is below the object's (nearer) hides it */
    static float near[W * H];
    for (int i = 0; i < W * H; i++)
        near[i] = i % W >= 60 && i % W <= 70 ? 75.0f : -1.0f;
    sp_probe_maps mo = { W, H, bg, near, NULL };
    sh.contact[0] = 0.2, sh.contact[1] = 0.4;
    memcpy(img, bg, sizeof(img));
    CHECK(sp_composite(&mo, NULL, &sh, &s, &o, 1, img, W * 3, &rep) == 0);
    CHECK(px(64, 61) == 100 && px(50, 62) < 70);
}

static void test_order_and_args(void)
{
    sp_probe_maps m = { W, H, bg, NULL, NULL };
    sp_composite_report rep;
    uint8_t red[20 * 10 * 4];
    for (int i = 0; i < 200; i++)
        red[4 * i] = 250, red[4 * i + 1] = 0, red[4 * i + 2] = 0, red[4 * i + 3] = 255;
    /* the nearer (larger row) object is drawn last whatever the order given */
    sp_composite_object o[2] = { object_at(50, 60, 30), { red, 10, 20, 40, 50, 50, 30, 1 } };
    memcpy(img, bg, sizeof(img));
    CHECK(sp_composite(&m, NULL, NULL, NULL, o, 2, img, W * 3, &rep) == 0);
    CHECK(px(50, 45) == 200);
    sp_composite_object bad = object_at(W + 5, 10, 10);
    CHECK(sp_composite(&m, NULL, NULL, NULL, &bad, 1, img, W * 3, &rep) == -EINVAL);
    bad = object_at(10, NAN, 10);
    CHECK(sp_composite(&m, NULL, NULL, NULL, &bad, 1, img, W * 3, &rep) == -EINVAL);
    bad = object_at(10, 10, -1);
    CHECK(sp_composite(&m, NULL, NULL, NULL, &bad, 1, img, W * 3, &rep) == -EINVAL);
    CHECK(sp_composite(&m, NULL, NULL, NULL, o, 1, img, W * 2, &rep) == -EINVAL);
    uint8_t clear[4 * 4 * 4] = { 0 };
    sp_composite_object empty = { clear, 4, 4, 16, 10, 10, 10, 1 };
    CHECK(sp_composite(&m, NULL, NULL, NULL, &empty, 1, img, W * 3, &rep) == SP_ENODATA);
    CHECK(sp_composite(&m, NULL, NULL, NULL, NULL, 0, img, W * 3, &rep) == 0);
    /* a huge cut-out squeezed to 3 px and a tiny one blown up: finite, inside the image */
    static uint8_t big[400 * 300 * 4];
    memset(big, 255, sizeof(big));
    sp_composite_object o2[2] = { { big, 300, 400, 1200, 20, 20, 3, 1 }, { cut, 10, 20, 40, 80, 79, 79, 1 } };
    CHECK(sp_composite(&m, NULL, NULL, NULL, o2, 2, img, W * 3, &rep) == 0);
}

/* ---- PNG reader ---- */

static uint32_t crc32_of(const uint8_t *p, size_t n, uint32_t crc)
{
    crc = ~crc;
    while (n--) {
        crc ^= *p++;
        for (int k = 0; k < 8; k++)
            crc = crc & 1 ? 0xEDB88320u ^ (crc >> 1) : crc >> 1;
    }
    return ~crc;
}

static size_t put_chunk(uint8_t *out, const char *type, const uint8_t *d, uint32_t n)
{
    out[0] = (uint8_t)(n >> 24), out[1] = (uint8_t)(n >> 16), out[2] = (uint8_t)(n >> 8), out[3] = (uint8_t)n;
    memcpy(out + 4, type, 4);
    if (n)
        memcpy(out + 8, d, n);
    uint32_t c = crc32_of(out + 4, 4 + n, 0);
    out[8 + n] = (uint8_t)(c >> 24), out[9 + n] = (uint8_t)(c >> 16), out[10 + n] = (uint8_t)(c >> 8);
    out[11 + n] = (uint8_t)c;
    return 12 + n;
}

/* A PNG from raw filtered scanlines in one stored deflate block (readable with and without zlib). */
static size_t make_png(uint8_t *out, uint32_t w, uint32_t h, int depth, int color, const uint8_t *raw, size_t raw_n,
                       const uint8_t *plte, uint32_t plte_n, const uint8_t *trns, uint32_t trns_n)
{
    static const uint8_t sig[8] = { 0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n' };
    uint8_t ihdr[13] = { (uint8_t)(w >> 24), (uint8_t)(w >> 16), (uint8_t)(w >> 8), (uint8_t)w,
                         (uint8_t)(h >> 24), (uint8_t)(h >> 16), (uint8_t)(h >> 8), (uint8_t)h,
                         (uint8_t)depth,     (uint8_t)color,     0, 0, 0 };
    static uint8_t z[70000];
    size_t zn = 0;
    uint32_t a = 1, b = 0;
    z[zn++] = 0x78, z[zn++] = 0x01, z[zn++] = 1;
    z[zn++] = (uint8_t)raw_n, z[zn++] = (uint8_t)(raw_n >> 8), z[zn++] = (uint8_t)~raw_n, z[zn++] = (uint8_t)(~raw_n >> 8);
    memcpy(z + zn, raw, raw_n);
    zn += raw_n;
    for (size_t i = 0; i < raw_n; i++)
        a = (a + raw[i]) % 65521, b = (b + a) % 65521;
    z[zn++] = (uint8_t)(b >> 8), z[zn++] = (uint8_t)b, z[zn++] = (uint8_t)(a >> 8), z[zn++] = (uint8_t)a;
    size_t n = 8;
    memcpy(out, sig, 8);
    n += put_chunk(out + n, "IHDR", ihdr, 13);
    if (plte)
        n += put_chunk(out + n, "PLTE", plte, plte_n);
    if (trns)
        n += put_chunk(out + n, "tRNS", trns, trns_n);
    n += put_chunk(out + n, "IDAT", z, (uint32_t)zn);
    n += put_chunk(out + n, "IEND", NULL, 0);
    return n;
}

static void test_png_filters(void)
{
    /* 3x2 RGB, second row equal to the first: filters Sub, Up, Average, Paeth all decode to it */
    static const uint8_t pix[9] = { 10, 20, 30, 40, 60, 90, 250, 5, 128 };
    for (int f = 1; f <= 4; f++) {
        uint8_t raw[2 * 10], out[512];
        raw[0] = 0;
        memcpy(raw + 1, pix, 9);
        raw[10] = (uint8_t)f;
        for (int i = 0; i < 9; i++) {
            int a = i >= 3 ? pix[i - 3] : 0, b = pix[i], c = i >= 3 ? pix[i - 3] : 0, pred = 0;
            if (f == 1)
                pred = a;
            else if (f == 2)
                pred = b;
            else if (f == 3)
                pred = (a + b) / 2;
            else {
                int p = a + b - c, pa = abs(p - a), pb = abs(p - b), pc = abs(p - c);
                pred = pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
            }
            raw[11 + i] = (uint8_t)(pix[i] - pred);
        }
        size_t n = make_png(out, 3, 2, 8, 2, raw, sizeof(raw), NULL, 0, NULL, 0);
        uint8_t *rgba = NULL;
        uint32_t w = 0, h = 0;
        CHECK_MSG(sp_png_decode_rgba(out, n, &rgba, &w, &h) == 0, "filter %d", f);
        for (int i = 0; rgba && i < 3; i++)
            CHECK_MSG(!memcmp(rgba + 12 + 4 * i, pix + 3 * i, 3) && rgba[12 + 4 * i + 3] == 255, "filter %d px %d", f, i);
        free(rgba);
    }
}

static void test_png_kinds(void)
{
    uint8_t out[512], *rgba = NULL;
    uint32_t w, h;
    /* 2-bit palette with transparency: 4 pixels, indices 0..3 */
    uint8_t raw1[2] = { 0, 0x1B };
    uint8_t plte[12] = { 255, 0, 0, 0, 255, 0, 0, 0, 255, 9, 9, 9 }, trns[2] = { 255, 0 };
    size_t n = make_png(out, 4, 1, 2, 3, raw1, 2, plte, 12, trns, 2);
    CHECK(sp_png_decode_rgba(out, n, &rgba, &w, &h) == 0 && w == 4 && h == 1);
    CHECK(rgba && rgba[0] == 255 && rgba[3] == 255 && rgba[5] == 255 && rgba[7] == 0 && rgba[14] == 9);
    free(rgba), rgba = NULL;
    /* 16-bit gray + alpha */
    uint8_t raw2[5] = { 0, 0x80, 0x00, 0xFF, 0xFF };
    n = make_png(out, 1, 1, 16, 4, raw2, 5, NULL, 0, NULL, 0);
    CHECK(sp_png_decode_rgba(out, n, &rgba, &w, &h) == 0 && rgba && rgba[0] == 128 && rgba[2] == 128 && rgba[3] == 255);
    free(rgba), rgba = NULL;
    /* damage: bad CRC, truncation, not a PNG, interlaced, a palette image without palette */
    uint8_t raw3[4] = { 0, 1, 2, 3 };
    n = make_png(out, 1, 1, 8, 2, raw3, 4, NULL, 0, NULL, 0);
    out[20] ^= 1;
    CHECK(sp_png_decode_rgba(out, n, &rgba, &w, &h) == SP_ECORRUPT);
    out[20] ^= 1;
    CHECK(sp_png_decode_rgba(out, n - 15, &rgba, &w, &h) == SP_ETRUNCATED);
    CHECK(sp_png_decode_rgba((const uint8_t *)"GIF89a........", 14, &rgba, &w, &h) == SP_EFORMAT);
    out[8 + 8 + 12] = 1; /* interlace byte of IHDR, then fix its CRC */
    uint32_t c = crc32_of(out + 12, 17, 0);
    out[29] = (uint8_t)(c >> 24), out[30] = (uint8_t)(c >> 16), out[31] = (uint8_t)(c >> 8), out[32] = (uint8_t)c;
#if HAVE_LIBPNG /* a 1x1 image's single Adam7 pass is the same bytes as the plain image */
    CHECK(sp_png_decode_rgba(out, n, &rgba, &w, &h) == 0 && w == 1 && h == 1 && rgba && rgba[0] == 1 && rgba[1] == 2 &&
          rgba[2] == 3 && rgba[3] == 255);
    free(rgba), rgba = NULL;
#else
    CHECK(sp_png_decode_rgba(out, n, &rgba, &w, &h) == SP_EUNSUPPORTED);
#endif
    n = make_png(out, 4, 1, 2, 3, raw1, 2, NULL, 0, NULL, 0);
    CHECK(sp_png_decode_rgba(out, n, &rgba, &w, &h) == SP_ECORRUPT);
    CHECK(sp_png_read_rgba("/nonexistent/x.png", &rgba, &w, &h) == -ENOENT);
}

#if HAVE_LIBPNG
static void append_bytes(png_structp png, png_bytep data, size_t n)
{
    FILE *f = png_get_io_ptr(png);
    fwrite(data, 1, n, f);
}

static void no_flush(png_structp png)
{
    (void)png;
}

/* An Adam7-interlaced RGB image (what a user's cut-out editor may save) decodes to its pixels. */
static void test_png_interlaced(void)
{
    enum { IW = 13, IH = 11 };
    uint8_t pix[IH][IW * 3];
    for (int y = 0; y < IH; y++)
        for (int x = 0; x < IW * 3; x++)
            pix[y][x] = (uint8_t)(x * 7 + y * 31);
    char *buf = NULL;
    size_t n = 0;
    FILE *f = open_memstream(&buf, &n);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
    png_infop info = png_create_info_struct(png);
    CHECK(f && png && info);
    if (!f || !png || !info || setjmp(png_jmpbuf(png)))
        return;
    png_set_write_fn(png, f, append_bytes, no_flush);
    png_set_IHDR(png, info, IW, IH, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_ADAM7, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    png_bytep rows[IH];
    for (int y = 0; y < IH; y++)
        rows[y] = pix[y];
    png_write_image(png, rows);
    png_write_end(png, NULL);
    png_destroy_write_struct(&png, &info);
    fclose(f);
    CHECK(n > 33 && buf[8 + 8 + 12] == 1); /* the IHDR says Adam7 */
    uint8_t *rgba = NULL;
    uint32_t w = 0, h = 0;
    CHECK_EQ_INT(sp_png_decode_rgba((const uint8_t *)buf, n, &rgba, &w, &h), 0);
    CHECK(w == IW && h == IH);
    int same = rgba != NULL;
    for (int i = 0; same && i < IW * IH; i++)
        same = !memcmp(rgba + 4 * i, &pix[i / IW][3 * (i % IW)], 3) && rgba[4 * i + 3] == 255;
    CHECK(same);
    free(rgba);
    free(buf);
}
#endif

/* What the project's writer produces reads back exactly, in every channel layout. */
static void test_png_roundtrip(void)
{
    char path[] = "/tmp/sp-probe-png-XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0);
    close(fd);
    uint8_t pix[7 * 5 * 4];
    for (int i = 0; i < (int)sizeof(pix); i++)
        pix[i] = (uint8_t)(i * 37 + 11);
    for (int ch = 1; ch <= 4; ch++) {
        if (ch == 2)
            continue;
        CHECK(sp_png_write(path, pix, 7, 5, 7 * (uint32_t)ch, ch) == 0);
        uint8_t *rgba = NULL;
        uint32_t w = 0, h = 0;
        int ret = sp_png_read_rgba(path, &rgba, &w, &h);
        CHECK_MSG(ret == 0 && w == 7 && h == 5, "channels %d: %s", ch, sp_strerror(ret));
        for (int i = 0; rgba && i < 35; i++) {
            const uint8_t *s = pix + i * ch;
            uint8_t want[4] = { s[0], ch >= 3 ? s[1] : s[0], ch >= 3 ? s[2] : s[0], ch == 4 ? s[3] : 255 };
            CHECK_MSG(!memcmp(rgba + 4 * i, want, 4), "channels %d pixel %d", ch, i);
        }
        free(rgba);
    }
    unlink(path);
}

static void test_pfm(void)
{
    char path[] = "/tmp/sp-probe-pfm-XXXXXX";
    int fd = mkstemp(path);
    CHECK(fd >= 0);
    close(fd);
    float v[6 * 4 * 3];
    for (int i = 0; i < 72; i++)
        v[i] = (float)i * 0.25f - 3.0f;
    for (int ch = 1; ch <= 3; ch += 2) {
        CHECK(sp_pfm_write(path, v, 6, 4, ch) == 0);
        float *r = NULL;
        uint32_t w, h;
        int c;
        CHECK(sp_pfm_read(path, &r, &w, &h, &c) == 0 && w == 6 && h == 4 && c == ch);
        CHECK(r && !memcmp(r, v, 24 * (size_t)ch * sizeof(float)));
        free(r);
    }
    FILE *f = fopen(path, "wb");
    fputs("PF\n6 4\n-1.0\n1234", f);
    fclose(f);
    float *r = NULL;
    uint32_t w, h;
    int c;
    CHECK(sp_pfm_read(path, &r, &w, &h, &c) == SP_ETRUNCATED);
    f = fopen(path, "wb");
    fputs("P6\n6 4\n255\n", f);
    fclose(f);
    CHECK(sp_pfm_read(path, &r, &w, &h, &c) == SP_EFORMAT);
    v[3] = NAN;
    CHECK(sp_pfm_write(path, v, 6, 4, 1) == 0);
    CHECK(sp_pfm_read(path, &r, &w, &h, &c) == SP_ECORRUPT);
    CHECK(sp_pfm_write(path, v, 6, 4, 2) == -EINVAL);
    unlink(path);
}

int main(void)
{
    setup();
    test_occlusion();
    test_lighting_and_height();
    test_shadow();
    test_contact();
    test_order_and_args();
    test_png_filters();
    test_png_kinds();
#if HAVE_LIBPNG
    test_png_interlaced();
#endif
    test_png_roundtrip();
    test_pfm();
    return check_exit();
}
