/* SPDX-License-Identifier: MIT */
/* PSNR and SSIM inside a mask: exact values on known cases, extremes, symmetry, masks. */
#include "common/image_metrics.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../common/check.h"

#define W 40
#define H 30

static float a[W * H * 3], b[W * H * 3];
static uint8_t mask[W * H];

static double lcg(unsigned *s)
{
    *s = *s * 1664525u + 1013904223u;
    return (double)(*s >> 8) / 16777216.0;
}

int main(void)
{
    unsigned seed = 7;
    for (int i = 0; i < W * H * 3; i++)
        a[i] = (float)lcg(&seed);
    memcpy(b, a, sizeof(a));
    /* identical: PSNR +inf, SSIM 1 */
    CHECK(isinf(sp_psnr_masked(a, b, NULL, W, H)) && sp_psnr_masked(a, b, NULL, W, H) > 0);
    CHECK_NEAR(sp_ssim_masked(a, b, NULL, W, H), 1.0, 1e-12);
    /* a constant offset of 0.1 everywhere: MSE 0.01, PSNR exactly 20 dB */
    for (int i = 0; i < W * H * 3; i++)
        b[i] = a[i] + 0.1f;
    CHECK_NEAR(sp_psnr_masked(a, b, NULL, W, H), 20.0, 1e-4);
    /* SSIM: a brightness offset keeps the structure (< 1, but close); noise lowers it more; symmetric */
    double s_off = sp_ssim_masked(a, b, NULL, W, H);
    for (int i = 0; i < W * H * 3; i++)
        b[i] = a[i] + 0.3f * (float)(lcg(&seed) - 0.5);
    double s_noise = sp_ssim_masked(a, b, NULL, W, H), s_rev = sp_ssim_masked(b, a, NULL, W, H);
    CHECK_MSG(s_off > 0.9 && s_off < 1.0, "offset SSIM %.4f", s_off);
    CHECK_MSG(s_noise < s_off && s_noise > 0.0, "noise SSIM %.4f", s_noise);
    CHECK_NEAR(s_noise, s_rev, 1e-12);
    /* a mask selects: errors only outside it do not count */
    memcpy(b, a, sizeof(a));
    memset(mask, 0, sizeof(mask));
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W / 2; x++)
            mask[y * W + x] = 1;
    for (int y = 0; y < H; y++)
        for (int x = W / 2; x < W; x++)
            for (int c = 0; c < 3; c++)
                b[(y * W + x) * 3 + c] = 0.0f;
    CHECK(isinf(sp_psnr_masked(a, b, mask, W, H)));
    CHECK(sp_ssim_masked(a, b, mask, W, H) > sp_ssim_masked(a, b, NULL, W, H));
    /* empty mask: NaN, not 0 or inf */
    memset(mask, 0, sizeof(mask));
    CHECK(isnan(sp_psnr_masked(a, b, mask, W, H)));
    CHECK(isnan(sp_ssim_masked(a, b, mask, W, H)));
    /* extremes: black against white, constant images (zero variance), a 1x1 image */
    for (int i = 0; i < W * H * 3; i++) {
        a[i] = 0.0f;
        b[i] = 1.0f;
    }
    CHECK_NEAR(sp_psnr_masked(a, b, NULL, W, H), 0.0, 1e-12);
    double s_bw = sp_ssim_masked(a, b, NULL, W, H);
    CHECK_MSG(isfinite(s_bw) && s_bw >= 0.0 && s_bw < 0.01, "black/white SSIM %.6f", s_bw);
    CHECK_NEAR(sp_ssim_masked(a, a, NULL, W, H), 1.0, 1e-12);
    CHECK_NEAR(sp_ssim_masked(a, a, NULL, 1, 1), 1.0, 1e-12);
    CHECK(isnan(sp_ssim_masked(a, b, NULL, 0, 0)));
    return check_exit();
}
