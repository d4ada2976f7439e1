/* SPDX-License-Identifier: MIT */
/* PSNR and SSIM inside a mask (image_metrics.h). SSIM's local moments come from a separable Gaussian blur. */
#include "image_metrics.h"

#include <math.h>
#include <stdlib.h>

#define SSIM_RADIUS 5   /* 11 x 11 window */
#define SSIM_SIGMA 1.5
#define SSIM_C1 (0.01 * 0.01)
#define SSIM_C2 (0.03 * 0.03)

double sp_psnr_masked(const float *a, const float *b, const uint8_t *mask, int width, int height)
{
    double se = 0.0;
    size_t n = 0, npx = (size_t)width * (size_t)height;
    for (size_t i = 0; i < npx; i++) {
        if (mask && !mask[i])
            continue;
        for (int c = 0; c < 3; c++) {
            double d = (double)a[i * 3 + (size_t)c] - (double)b[i * 3 + (size_t)c];
            se += d * d;
        }
        n += 3;
    }
    if (!n)
        return NAN;
    if (se == 0.0)
        return INFINITY;
    return -10.0 * log10(se / (double)n);
}

/*
 * One 1-D Gaussian pass over `lines` lines of `len` samples: sample i of line l at
 * l * line_step + i * step. Borders are clamped (normalised by the weights inside).
 */
static void blur_pass(const double *src, double *dst, int lines, int len, size_t line_step, size_t step,
                      const double *k)
{
    for (int l = 0; l < lines; l++)
        for (int i = 0; i < len; i++) {
            double s = 0.0, ws = 0.0;
            for (int d = -SSIM_RADIUS; d <= SSIM_RADIUS; d++) {
                int j = i + d;
                if (j < 0 || j >= len)
                    continue;
                s += k[d + SSIM_RADIUS] * src[(size_t)l * line_step + (size_t)j * step];
                ws += k[d + SSIM_RADIUS];
            }
            dst[(size_t)l * line_step + (size_t)i * step] = s / ws;
        }
}

/* Separable Gaussian blur of one plane: rows, then columns. */
static void blur(const double *src, double *tmp, double *dst, int w, int h, const double *k)
{
    blur_pass(src, tmp, h, w, (size_t)w, 1, k);
    blur_pass(tmp, dst, w, h, 1, (size_t)w, k);
}

double sp_ssim_masked(const float *a, const float *b, const uint8_t *mask, int width, int height)
{
    size_t npx = (size_t)width * (size_t)height;
    double *buf = malloc(sizeof(double) * npx * 11);
    if (!buf || width < 1 || height < 1) {
        free(buf);
        return NAN;
    }
    double *pa = buf, *pb = buf + npx, *paa = buf + 2 * npx, *pbb = buf + 3 * npx, *pab = buf + 4 * npx;
    double *ma = buf + 5 * npx, *mb = buf + 6 * npx, *maa = buf + 7 * npx, *mbb = buf + 8 * npx,
           *mab = buf + 9 * npx, *tmp = buf + 10 * npx;
    double k[2 * SSIM_RADIUS + 1];
    for (int d = -SSIM_RADIUS; d <= SSIM_RADIUS; d++)
        k[d + SSIM_RADIUS] = exp(-0.5 * (double)(d * d) / (SSIM_SIGMA * SSIM_SIGMA));
    double sum = 0.0;
    size_t n = 0;
    for (int c = 0; c < 3; c++) {
        for (size_t i = 0; i < npx; i++) {
            pa[i] = (double)a[i * 3 + (size_t)c];
            pb[i] = (double)b[i * 3 + (size_t)c];
            paa[i] = pa[i] * pa[i];
            pbb[i] = pb[i] * pb[i];
            pab[i] = pa[i] * pb[i];
        }
        blur(pa, tmp, ma, width, height, k);
        blur(pb, tmp, mb, width, height, k);
        blur(paa, tmp, maa, width, height, k);
        blur(pbb, tmp, mbb, width, height, k);
        blur(pab, tmp, mab, width, height, k);
        for (size_t i = 0; i < npx; i++) {
            if (mask && !mask[i])
                continue;
            double va = fmax(0.0, maa[i] - ma[i] * ma[i]), vb = fmax(0.0, mbb[i] - mb[i] * mb[i]);
            double cov = mab[i] - ma[i] * mb[i];
            sum += ((2.0 * ma[i] * mb[i] + SSIM_C1) * (2.0 * cov + SSIM_C2)) /
                   ((ma[i] * ma[i] + mb[i] * mb[i] + SSIM_C1) * (va + vb + SSIM_C2));
            n++;
        }
    }
    free(buf);
    return n ? sum / (double)n : (double)NAN;
}
