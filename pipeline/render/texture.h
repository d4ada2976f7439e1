/* SPDX-License-Identifier: MIT */
/* UV-space texture access for the renderer: bilinear sample, its UV derivative and its adjoint splat. */
#ifndef SUNPROBE_RENDER_TEXTURE_H
#define SUNPROBE_RENDER_TEXTURE_H

#include <stddef.h>
#include <stdint.h>

/*
 * One bilinear footprint: four texel indices (pixel index, not times channels)
 * with weights and the weights' derivatives w.r.t. u and v (0 where clamped).
 */
typedef struct tex_lookup {
    size_t idx[4];
    double wt[4];
    double dwdu[4], dwdv[4];
} tex_lookup;

/* Footprint of (u, v) on a width x height texture; clamp to edge, finite for any input. */
void tex_lookup_init(tex_lookup *t, int width, int height, double u, double v);
/* out[c] = sum_k wt[k] data[idx[k] * channels + c] */
void tex_sample(const tex_lookup *t, const float *data, int channels, double *out);
/* d out[c] / du and / dv */
void tex_sample_duv(const tex_lookup *t, const float *data, int channels, double *du, double *dv);
/* Adjoint of tex_sample w.r.t. the texels: grad[idx[k] * channels + c] += wt[k] g[c]. */
void tex_splat(const tex_lookup *t, double *grad, int channels, const double *g);
/* Nearest texel of a uint8 map (row 0 at v = 1). */
uint8_t tex_nearest_u8(const uint8_t *data, int width, int height, double u, double v);

#endif
