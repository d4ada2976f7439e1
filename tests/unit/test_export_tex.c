/* SPDX-License-Identifier: MIT */
/*
 * The exported albedo texture (export/gltf_tex.c, EXPORT.md "Textures"): the fit's coarse linear map
 * resampled to the asked size with a Mitchell filter in linear light: the size, the mean colour kept
 * when enlarging and shrinking, a constant kept exactly, an edge that gets in-between values (not
 * nearest-neighbour), and the extremes (a 1 x 1 map, black and white).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "export/gltf_internal.h"
#include "sunprobe/sp_math.h"

/* An asset holding only what the albedo needs: w x h linear RGB from fill(x, y, c). */
static void make_asset(sp_face_asset *a, int w, int h, double (*fill)(int, int, int, int, int))
{
    memset(a, 0, sizeof(*a));
    a->tex_width = w, a->tex_height = h;
    a->albedo = malloc((size_t)w * h * 3 * sizeof(float));
    a->displacement = calloc((size_t)w * h, sizeof(float));
    for (int y = 0; a->albedo && y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++)
                a->albedo[((size_t)y * w + x) * 3 + c] = (float)fill(x, y, c, w, h);
}

static void free_asset(sp_face_asset *a)
{
    free(a->albedo);
    free(a->displacement);
}

static double noise(int x, int y, int c, int w, int h)
{
    (void)w, (void)h;
    uint32_t k = (uint32_t)x * 73856093u ^ (uint32_t)y * 19349663u ^ (uint32_t)c * 83492791u;
    k ^= k >> 13, k *= 0x5bd1e995u, k ^= k >> 15;
    return (double)(k % 10001u) / 10000.0; /* 0..1, black and white included */
}

static double step_edge(int x, int y, int c, int w, int h)
{
    (void)y, (void)c, (void)h;
    return x < w / 2 ? 0.1 : 0.8;
}

static double stripes(int x, int y, int c, int w, int h)
{
    (void)y, (void)c, (void)w, (void)h;
    return x % 4 == 0 ? 1.0 : 0.0; /* mean 0.25; point samples between the lines see none */
}

static double constant(int x, int y, int c, int w, int h)
{
    (void)x, (void)y, (void)w, (void)h;
    return 0.2 + 0.1 * c;
}

/* Builds the texture at longest edge size and returns its mean linear colour (decoded sRGB). */
static int texture(const sp_face_asset *a, int size, sp_export_textures *t, double mean[3])
{
    int ret = sp_export_textures_build(t, a, size, SP_FACE_LEFT_OUT_SPECULAR | SP_FACE_LEFT_OUT_DISPLACEMENT);
    CHECK_EQ_INT(ret, 0);
    size_t n = ret ? 0 : (size_t)t->albedo.width * (size_t)t->albedo.height;
    for (int c = 0; c < 3; c++) {
        double s = 0.0;
        for (size_t i = 0; i < n; i++)
            s += sp_srgb_decode(t->albedo.pixels[i * 3 + (size_t)c] / 255.0);
        mean[c] = n ? s / (double)n : (double)NAN;
    }
    return ret;
}

static double map_mean(const sp_face_asset *a, int c)
{
    double s = 0.0;
    size_t n = (size_t)a->tex_width * a->tex_height;
    for (size_t i = 0; i < n; i++)
        s += (double)a->albedo[i * 3 + (size_t)c];
    return s / (double)n;
}

static void check_mean(int w, int h, int size, int want_w, int want_h, double (*fill)(int, int, int, int, int))
{
    sp_face_asset a;
    sp_export_textures t;
    double mean[3];
    make_asset(&a, w, h, fill);
    if (texture(&a, size, &t, mean) == 0) {
        CHECK_MSG(t.albedo.width == want_w && t.albedo.height == want_h, "%dx%d at %d: %dx%d, want %dx%d", w, h, size,
                  t.albedo.width, t.albedo.height, want_w, want_h);
        for (int c = 0; c < 3; c++) /* 8-bit sRGB rounding is ~0.2 % of a mid grey */
            CHECK_MSG(fabs(mean[c] - map_mean(&a, c)) < 0.004, "%dx%d -> %d: channel %d mean %.5f, map %.5f", w, h,
                      size, c, mean[c], map_mean(&a, c));
    }
    sp_export_textures_free(&t);
    free_asset(&a);
}

int main(void)
{
    sp_export_settings s;
    sp_export_default_settings(&s);
    CHECK_EQ_INT(s.texture_size, 512);
    check_mean(128, 64, 512, 512, 256, noise);    /* an ICT map (two tiles wide), the default size */
    check_mean(96, 48, 1024, 1024, 512, noise);   /* --texture-size 1024 */
    check_mean(48, 48, 512, 512, 512, noise);     /* the coarsest fit */
    check_mean(2048, 1024, 512, 512, 256, noise); /* shrinking */
    check_mean(2048, 64, 512, 512, 16, stripes);  /* shrinking fine lines: an area filter keeps their mean */

    sp_face_asset a;
    sp_export_textures t;
    double mean[3];
    make_asset(&a, 37, 23, constant); /* a constant stays that constant, texel for texel, at odd ratios */
    if (texture(&a, 512, &t, mean) == 0) {
        int bad = 0;
        for (size_t i = 0; i < (size_t)t.albedo.width * t.albedo.height * 3; i++)
            bad += t.albedo.pixels[i] != (uint8_t)lround(255.0 * sp_srgb_encode(0.2 + 0.1 * (double)(i % 3)));
        CHECK_MSG(bad == 0, "%d texels of a constant map changed", bad);
    }
    sp_export_textures_free(&t);
    free_asset(&a);

    make_asset(&a, 1, 1, constant); /* 1 x 1 */
    if (texture(&a, 512, &t, mean) == 0)
        CHECK(t.albedo.width == 512 && t.albedo.height == 512 && fabs(mean[0] - 0.2) < 0.003);
    sp_export_textures_free(&t);
    free_asset(&a);

    make_asset(&a, 16, 8, step_edge); /* not nearest: the edge gets values between its two sides */
    if (texture(&a, 512, &t, mean) == 0) {
        int between = 0;
        uint8_t lo = (uint8_t)lround(255.0 * sp_srgb_encode(0.1)), hi = (uint8_t)lround(255.0 * sp_srgb_encode(0.8));
        for (int x = 0; x < t.albedo.width; x++) {
            uint8_t v = t.albedo.pixels[(size_t)x * 3];
            between += v > lo + 2 && v + 2 < hi;
        }
        CHECK_MSG(between >= 8, "%d texels of a row between the edge's sides (nearest would give 0)", between);
    }
    sp_export_textures_free(&t);
    free_asset(&a);
    return check_exit();
}
