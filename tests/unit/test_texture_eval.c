/* SPDX-License-Identifier: MIT */
/*
 * The texture benchmark's measures (tools/bench/texture_eval.c) on images whose
 * answer is known: a verbatim crop of the exemplar, the same with noise, a 2 x 2
 * tiling of it, steps laid along tile borders, and a colour inversion. The
 * issue-22 figures rest on these, so each must be able to fail.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "tools/bench/texture_eval.h"

static tev_image alloc_image(int w, int h)
{
    tev_image im = { calloc((size_t)w * h * 3, sizeof(float)), w, h };
    return im;
}

/* w x h from ex at (x0, y0), wrapping, plus uniform noise of half-width amp (a fixed sequence). */
static tev_image copy_of(const tev_image *ex, int x0, int y0, int w, int h, float amp)
{
    tev_image out = alloc_image(w, h);
    uint32_t r = 12345u;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++) {
                r = r * 1664525u + 1013904223u;
                float noise = amp * ((float)(r >> 8) / 8388608.0f - 1.0f);
                out.px[3 * ((size_t)y * w + x) + c] =
                    ex->px[3 * ((size_t)((y0 + y) % ex->h) * ex->w + (x0 + x) % ex->w) + c] + noise;
            }
    return out;
}

static void test_coherence(void)
{
    tev_image ex;
    CHECK_EQ_INT(tev_procedural(&ex, TEV_STONES, 64, 64, 3), 0);
    tev_image same = copy_of(&ex, 8, 8, 48, 48, 0.0f), light = copy_of(&ex, 8, 8, 48, 48, 0.02f),
              heavy = copy_of(&ex, 8, 8, 48, 48, 0.08f);
    double c0 = tev_coherence(&same, &ex, 7, 5), c1 = tev_coherence(&light, &ex, 7, 5),
           c2 = tev_coherence(&heavy, &ex, 7, 5), c2_dense = tev_coherence(&heavy, &ex, 7, 1);
    printf("coherence: verbatim %.4f, noise 0.02 %.3f, noise 0.08 %.3f (every pixel %.3f)\n", c0, c1, c2, c2_dense);
    CHECK_MSG(c0 < 1e-6, "a verbatim crop is not coherent: %g", c0);
    CHECK_MSG(c1 > 0.05 && c2 > 1.5 * c1, "noise does not raise the distance: %.3f then %.3f", c1, c2);
    /* the jittered samples stand for all patches: uniform noise gives every patch about the same distance */
    CHECK_MSG(fabs(c2 - c2_dense) < 0.05 * c2_dense, "sampled %.3f against every patch %.3f", c2, c2_dense);
    tev_free(&same), tev_free(&light), tev_free(&heavy), tev_free(&ex);
}

static void test_repetition(void)
{
    tev_image ex;
    CHECK_EQ_INT(tev_procedural(&ex, TEV_BLOBS, 64, 64, 5), 0);
    tev_image crop = copy_of(&ex, 8, 8, 48, 48, 0.0f), tiled = copy_of(&ex, 0, 0, 128, 128, 0.0f),
              noisy = copy_of(&ex, 8, 8, 48, 48, 0.05f);
    double rc = tev_repetition(&crop, &ex), rt = tev_repetition(&tiled, &ex), rn = tev_repetition(&noisy, &ex);
    printf("repetition: 48 x 48 crop %.3f (its area %.3f), 2 x 2 tiling %.3f, noisy crop %.3f\n", rc,
           48.0 * 48.0 / (64.0 * 64.0), rt, rn);
    CHECK_MSG(rc > 0.5 && rc <= 48.0 * 48.0 / (64.0 * 64.0) + 1e-9, "crop: %.3f", rc);
    CHECK_MSG(rt > 0.9 && rt <= 1.0 + 1e-9, "a tiling copies the whole exemplar: %.3f", rt);
    CHECK_MSG(rn < 0.01, "noise breaks every verbatim match: %.3f", rn);
    tev_free(&crop), tev_free(&tiled), tev_free(&noisy), tev_free(&ex);
}

static void test_seams_and_statistics(void)
{
    tev_image ex;
    CHECK_EQ_INT(tev_procedural(&ex, TEV_BLOBS, 128, 128, 9), 0);
    tev_image plain = copy_of(&ex, 0, 0, 128, 128, 0.0f), stepped = copy_of(&ex, 0, 0, 128, 128, 0.0f),
              inverse = copy_of(&ex, 0, 0, 128, 128, 0.0f);
    for (size_t i = 0; i < (size_t)128 * 128; i++) {
        int tx = (int)(i % 128) / 16, ty = (int)(i / 128) / 16;
        for (int c = 0; c < 3; c++) {
            stepped.px[3 * i + c] += 0.05f * (float)((tx * 5 + ty * 3) % 4); /* a brightness per 16 x 16 tile */
            inverse.px[3 * i + c] = 1.0f - inverse.px[3 * i + c];
        }
    }
    double s0 = tev_seam_ratio(&plain, 16), s1 = tev_seam_ratio(&stepped, 16);
    double h0 = tev_histogram_distance(&plain, &ex), h1 = tev_histogram_distance(&inverse, &ex);
    double a0 = tev_autocorr_distance(&plain, &ex, 8), a1 = tev_autocorr_distance(&stepped, &ex, 8);
    printf(
        "seams %.2f plain, %.2f with a step at every tile border; histogram %.3f, inverted %.3f; autocorrelation %.4f, "
        "with the step %.4f\n",
        s0, s1, h0, h1, a0, a1);
    CHECK_MSG(s0 > 0.7 && s0 < 1.3, "a seamless image shows a seam: %.2f", s0);
    CHECK_MSG(s1 > 3.0, "steps along the tile borders are not seen: %.2f", s1);
    /* the control at the tile centres: no seam on either image, the borders' steps only among its neighbours */
    double c0 = tev_seam_ratio_at(&plain, 8, 16), c1 = tev_seam_ratio_at(&stepped, 8, 16);
    printf("at the tile centres: seams %.2f plain, %.2f stepped\n", c0, c1);
    CHECK_MSG(c0 > 0.7 && c0 < 1.3, "a seamless image shows a seam at its tile centres: %.2f", c0);
    CHECK_MSG(c1 < 1.0, "the tile centres of the stepped image show a seam: %.2f", c1);
    CHECK_MSG(tev_seam_ratio_at(&stepped, 16, 16) == s1, "the borders' ratio differs from tev_seam_ratio's");
    CHECK_MSG(h0 < 1e-12 && h1 > 0.5, "histogram distances %.3f and %.3f", h0, h1);
    CHECK_MSG(a0 < 1e-12 && a1 > a0, "autocorrelation distances %.4f and %.4f", a0, a1);
    tev_free(&plain), tev_free(&stepped), tev_free(&inverse), tev_free(&ex);
}

int main(void)
{
    test_coherence();
    test_repetition();
    test_seams_and_statistics();
    return check_exit();
}
