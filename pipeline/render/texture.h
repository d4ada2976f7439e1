/* SPDX-License-Identifier: MIT */
/* UV-space texture access for the renderer: bilinear sample, its UV derivative and its adjoint splat. */
#ifndef SUNPROBE_RENDER_TEXTURE_H
#define SUNPROBE_RENDER_TEXTURE_H

#include <stddef.h>
#include <stdint.h>

#include "pipeline/render/vec3.h"

/*
 * One bilinear footprint: four texel indices (pixel index, not times channels)
 * with weights and the weights' derivatives w.r.t. u and v (0 where clamped).
 */
typedef struct tex_lookup {
    size_t idx[4];
    double wt[4];
    double dwdu[4], dwdv[4];
} tex_lookup;

/* Hot per-sample helpers, inline so the shading and adjoint loops can fold channels = 3. */
/* Continuous texel coordinate x in [0, n-1] (texel centres at integers) and its scale d x / d(uv). */
static inline void tex_axis(double coord, int n, double scale, int *i0, int *i1, double *f, double *dfd)
{
    double x = coord;
    *dfd = scale;
    if (!(x > 0.0)) { /* also catches NaN */
        x = 0.0;
        *dfd = 0.0;
    } else if (x >= (double)(n - 1)) {
        x = (double)(n - 1);
        *dfd = 0.0;
    }
    int i = ifloor(x); /* x is in [0, n - 1] here */
    if (i > n - 1)
        i = n - 1;
    *i0 = i;
    *i1 = i + 1 < n ? i + 1 : n - 1;
    *f = x - (double)i;
}

/* Footprint of (u, v) on a width x height texture; clamp to edge, finite for any input. */
static inline void tex_lookup_init(tex_lookup *t, int width, int height, double u, double v)
{
    int x0, x1, y0, y1;
    double fx, fy, dfx, dfy;
    tex_axis(u * width - 0.5, width, (double)width, &x0, &x1, &fx, &dfx);
    tex_axis((1.0 - v) * height - 0.5, height, -(double)height, &y0, &y1, &fy, &dfy);
    size_t w = (size_t)width;
    t->idx[0] = (size_t)y0 * w + (size_t)x0;
    t->idx[1] = (size_t)y0 * w + (size_t)x1;
    t->idx[2] = (size_t)y1 * w + (size_t)x0;
    t->idx[3] = (size_t)y1 * w + (size_t)x1;
    t->wt[0] = (1.0 - fx) * (1.0 - fy);
    t->wt[1] = fx * (1.0 - fy);
    t->wt[2] = (1.0 - fx) * fy;
    t->wt[3] = fx * fy;
    t->dwdu[0] = -(1.0 - fy) * dfx;
    t->dwdu[1] = (1.0 - fy) * dfx;
    t->dwdu[2] = -fy * dfx;
    t->dwdu[3] = fy * dfx;
    t->dwdv[0] = -(1.0 - fx) * dfy;
    t->dwdv[1] = -fx * dfy;
    t->dwdv[2] = (1.0 - fx) * dfy;
    t->dwdv[3] = fx * dfy;
}

/* out[c] = sum_k wt[k] data[idx[k] * channels + c] */
static inline void tex_sample(const tex_lookup *t, const float *data, int channels, double *out)
{
    if (channels == 3) { /* the albedo hot path, unrolled */
        const float *a = data + t->idx[0] * 3, *b = data + t->idx[1] * 3;
        const float *c = data + t->idx[2] * 3, *d = data + t->idx[3] * 3;
        for (int k = 0; k < 3; k++)
            out[k] = t->wt[0] * (double)a[k] + t->wt[1] * (double)b[k] + t->wt[2] * (double)c[k] +
                     t->wt[3] * (double)d[k];
        return;
    }
    for (int c = 0; c < channels; c++) {
        double s = 0.0;
        for (int k = 0; k < 4; k++)
            s += t->wt[k] * (double)data[t->idx[k] * (size_t)channels + (size_t)c];
        out[c] = s;
    }
}

/* d out[c] / du and / dv */
static inline void tex_sample_duv(const tex_lookup *t, const float *data, int channels, double *du, double *dv)
{
    if (channels == 3) {
        const float *p[4] = {data + t->idx[0] * 3, data + t->idx[1] * 3, data + t->idx[2] * 3, data + t->idx[3] * 3};
        for (int c = 0; c < 3; c++) {
            double x0 = (double)p[0][c], x1 = (double)p[1][c], x2 = (double)p[2][c], x3 = (double)p[3][c];
            du[c] = t->dwdu[0] * x0 + t->dwdu[1] * x1 + t->dwdu[2] * x2 + t->dwdu[3] * x3;
            dv[c] = t->dwdv[0] * x0 + t->dwdv[1] * x1 + t->dwdv[2] * x2 + t->dwdv[3] * x3;
        }
        return;
    }
    for (int c = 0; c < channels; c++) {
        double su = 0.0, sv = 0.0;
        for (int k = 0; k < 4; k++) {
            double x = (double)data[t->idx[k] * (size_t)channels + (size_t)c];
            su += t->dwdu[k] * x;
            sv += t->dwdv[k] * x;
        }
        du[c] = su;
        dv[c] = sv;
    }
}

/* Adjoint of tex_sample w.r.t. the texels: grad[idx[k] * channels + c] += wt[k] g[c]. */
static inline void tex_splat(const tex_lookup *t, double *grad, int channels, const double *g)
{
    for (int k = 0; k < 4; k++) {
        double w = t->wt[k];
        if (w == 0.0)
            continue;
        double *dst = grad + t->idx[k] * (size_t)channels;
        if (channels == 3) {
            dst[0] += w * g[0], dst[1] += w * g[1], dst[2] += w * g[2];
            continue;
        }
        for (int c = 0; c < channels; c++)
            dst[c] += w * g[c];
    }
}

/* Nearest texel of a uint8 map (row 0 at v = 1). */
uint8_t tex_nearest_u8(const uint8_t *data, int width, int height, double u, double v);

#endif
