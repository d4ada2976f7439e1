/* SPDX-License-Identifier: MIT */
/*
 * What the albedo map needs beyond the data: a prior toward each texel's
 * neighbours (so texels between the fit's pixel samples interpolate instead of
 * falling to the map's mean: the dot grid), and a fill for texels no keyframe
 * saw, by push-pull from the observed ones (a confidence-weighted image
 * pyramid: pushed down to 1x1, pulled back up), smooth and in the skin's colour.
 */
#include "pipeline/sunstage/sunstage_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The k-th smallest of v[0..n) (quickselect; v is reordered). */
static double kth_smallest(double *v, size_t n, size_t k)
{
    size_t lo = 0, hi = n - 1;
    while (lo < hi) {
        double pivot = v[lo + (hi - lo) / 2];
        size_t i = lo, j = hi;
        while (i <= j) {
            while (v[i] < pivot)
                i++;
            while (v[j] > pivot)
                j--;
            if (i <= j) {
                double t = v[i];
                v[i] = v[j], v[j] = t;
                i++;
                if (j == 0)
                    break;
                j--;
            }
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            break;
    }
    return v[k];
}

double ss_albedo_typical_weight(const double *den, const uint8_t *seen, size_t n_texels)
{
    double *v = malloc(sizeof(double) * (n_texels ? n_texels : 1));
    if (!v)
        return 0.0;
    size_t m = 0;
    for (size_t t = 0; t < n_texels; t++)
        if (seen[t] && den[t * 3] > 0.0)
            v[m++] = den[t * 3];
    double med = m ? kth_smallest(v, m, m / 2) : 0.0;
    free(v);
    return med;
}

void ss_albedo_neighbours(const float *albedo, int w, int h, size_t t3, double out[3])
{
    size_t t = t3 / 3;
    int x = (int)(t % (size_t)w), y = (int)(t / (size_t)w);
    int xs[4] = { x > 0 ? x - 1 : x + 1, x + 1 < w ? x + 1 : x - 1, x, x };
    int ys[4] = { y, y, y > 0 ? y - 1 : y + 1, y + 1 < h ? y + 1 : y - 1 };
    for (int ch = 0; ch < 3; ch++) {
        double s = 0.0;
        for (int k = 0; k < 4; k++) {
            int xx = xs[k] < 0 ? 0 : (xs[k] >= w ? w - 1 : xs[k]), yy = ys[k] < 0 ? 0 : (ys[k] >= h ? h - 1 : ys[k]);
            s += (double)albedo[((size_t)yy * (size_t)w + (size_t)xx) * 3 + (size_t)ch];
        }
        out[ch] = 0.25 * s;
    }
}

/* One pyramid level: values (premultiplied by weight) and weights. */
typedef struct level {
    int w, h;
    double *vw, *c;
} level;

int ss_albedo_fill_unobserved(float *albedo, int w, int h, const uint8_t *observed)
{
    int nl = 1;
    for (int lw = w, lh = h; lw > 1 || lh > 1; lw = (lw + 1) / 2, lh = (lh + 1) / 2)
        nl++;
    level *L = calloc((size_t)nl, sizeof(level));
    int ret = L ? 0 : -ENOMEM;
    for (int l = 0, lw = w, lh = h; !ret && l < nl; l++, lw = (lw + 1) / 2, lh = (lh + 1) / 2) {
        L[l].w = lw;
        L[l].h = lh;
        L[l].vw = calloc((size_t)lw * (size_t)lh * 3, sizeof(double));
        L[l].c = calloc((size_t)lw * (size_t)lh, sizeof(double));
        if (!L[l].vw || !L[l].c)
            ret = -ENOMEM;
    }
    if (ret)
        goto done;
    for (size_t i = 0; i < (size_t)w * (size_t)h; i++) {
        L[0].c[i] = observed[i] ? 1.0 : 0.0;
        for (int ch = 0; ch < 3; ch++)
            L[0].vw[i * 3 + (size_t)ch] = L[0].c[i] * (double)albedo[i * 3 + (size_t)ch];
    }
    /* push: each coarser texel sums its children (weights capped at 1: a fully observed parent is data) */
    for (int l = 1; l < nl; l++)
        for (int y = 0; y < L[l - 1].h; y++)
            for (int x = 0; x < L[l - 1].w; x++) {
                size_t f = (size_t)y * (size_t)L[l - 1].w + (size_t)x, p = (size_t)(y / 2) * (size_t)L[l].w + (size_t)(x / 2);
                L[l].c[p] += 0.25 * L[l - 1].c[f];
                for (int ch = 0; ch < 3; ch++)
                    L[l].vw[p * 3 + (size_t)ch] += 0.25 * L[l - 1].vw[f * 3 + (size_t)ch];
            }
    /* pull: a texel keeps its own share c and takes the rest (1 - c) from its parent's normalised value */
    for (int l = nl - 2; l >= 0; l--)
        for (int y = 0; y < L[l].h; y++)
            for (int x = 0; x < L[l].w; x++) {
                size_t f = (size_t)y * (size_t)L[l].w + (size_t)x, p = (size_t)(y / 2) * (size_t)L[l + 1].w + (size_t)(x / 2);
                double pc = L[l + 1].c[p], c = fmin(1.0, L[l].c[f]);
                for (int ch = 0; ch < 3; ch++) {
                    double parent = pc > 1e-12 ? L[l + 1].vw[p * 3 + (size_t)ch] / pc : 0.0;
                    double own = L[l].c[f] > 1e-12 ? L[l].vw[f * 3 + (size_t)ch] / L[l].c[f] : 0.0;
                    L[l].vw[f * 3 + (size_t)ch] = c * own + (1.0 - c) * parent;
                }
                L[l].c[f] = 1.0;
            }
    for (size_t i = 0; i < (size_t)w * (size_t)h; i++)
        if (!observed[i])
            for (int ch = 0; ch < 3; ch++)
                albedo[i * 3 + (size_t)ch] = (float)L[0].vw[i * 3 + (size_t)ch];
done:
    for (int l = 0; L && l < nl; l++) {
        free(L[l].vw);
        free(L[l].c);
    }
    free(L);
    return ret;
}
