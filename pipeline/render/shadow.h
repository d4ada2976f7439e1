/* SPDX-License-Identifier: MIT */
/*
 * Sun shadow map: an orthographic N x N depth image along the sun direction,
 * framed by a sphere (centre c, radius r). Map coordinates of a world point p:
 *   texel x = ((p - c).e1 / r + 1) N / 2 - 0.5   (texel centres at integers)
 *   texel y = ((p - c).e2 / r + 1) N / 2 - 0.5
 *   depth   = offset + (c - p).l / r              (bounding radii; grows away from the sun)
 * Lookups interpolate depth bilinearly and compare softly:
 *   V = 1 - sigmoid(k (d_hit - b d_map)).
 */
#ifndef SUNPROBE_RENDER_SHADOW_H
#define SUNPROBE_RENDER_SHADOW_H

#include <stdint.h>

#include "sunprobe/sp_mesh.h"

/* Depth stored in texels no triangle covers: far behind anything inside the frame. */
#define SHADOW_EMPTY_DEPTH 100.0

typedef struct shadow_frame {
    double l[3], e1[3], e2[3]; /* unit direction towards the sun and the map's axes */
    double c[3], r, offset;
    double scale; /* texels per metre: N / (2 r) */
    int n;
} shadow_frame;

typedef struct shadow_map {
    shadow_frame f;
    int n;
    float *depth;     /* n * n */
    double *proj;     /* 3 per vertex scratch: map x, y, depth */
    uint32_t cap_v;
    int valid;        /* holds a rendered map that REUSE may use */
} shadow_map;

typedef struct shadow_sample {
    double V;         /* visibility in [0, 1] */
    double dVdp[3];   /* dV/d(world point), map contents held constant */
    int32_t texel;    /* footprint id, -1 outside the map */
} shadow_sample;

int shadow_map_init(shadow_map *m, int n);
int shadow_map_reserve(shadow_map *m, uint32_t n_vertices);
void shadow_map_free(shadow_map *m);

/* Bounding sphere of the AABB of n points (3 doubles each); r > 0 always. */
void shadow_bounds(const double *pts, uint32_t n, double c[3], double *r);
/* Frame for sun direction l (unit), sphere (c, r) and depth offset. */
void shadow_frame_init(shadow_frame *f, const double l[3], const double c[3], double r, double offset, int n);
/* Renders the mesh (positions pts, 3 doubles per vertex) into the map with frame m->f. */
void shadow_map_render(shadow_map *m, const double *pts, const sp_mesh *mesh);
/* Soft visibility at world point p with sharpness k and multiplicative bias b. */
void shadow_eval(const shadow_map *m, double k, double b, const double p[3], shadow_sample *out);
/*
 * shadow_eval without the sigmoid, for the float kernels (shade_simd.h):
 * *z = k (d - b ds) with V = 1 - sigmoid(z), dzdp = dz/dp, and the texel.
 * Outside the map: *z = -1e30 (V = 1), dzdp = 0, texel -1.
 */
void shadow_eval_z(const shadow_map *m, double k, double b, const double p[3], double *z, double dzdp[3],
                   int32_t *texel);
/*
 * shadow_eval_z (the same arithmetic, so the same z, dz/dp and texel) of lanes i in [0, n) with lit[i] > 0 at
 * world points (p[0][i], p[1][i], p[2][i]), rounded to float, z clamped to +-1e30 (NaN stays NaN); other lanes get
 * z = -1e30, dz = 0 and texel -1. For the fit_float batches (surf_shadow): one call per batch.
 */
void shadow_eval_z_lanes(const shadow_map *m, double k, double b, int n, const double *const p[3], const float *lit,
                         float *z, float *const dz[3], int32_t *texel);
/*
 * Visibility of a sun disk of angular radius atan(tan_r) at world point p with normal nrm (forward only):
 * percentage-closer soft shadows. The mean depth of the blockers found over the widest penumbra gives the
 * penumbra's width, (d_receiver - d_blocker) tan_r N / 2 texels (at most N / 8), and V is the mean of the
 * soft test over SOFT_TAPS points of that disk against the receiver's own plane. A penumbra under half a
 * texel, or no blocker, gives shadow_eval's V exactly.
 */
#define SOFT_TAPS 16
double shadow_soft_eval(const shadow_map *m, double k, double b, const double p[3], const double nrm[3], double tan_r);
/* sigmoid(x) = 1 / (1 + exp(-x)) via exp(-|x|), and its derivative; finite for any finite x. */
double shadow_sigmoid(double x, double *deriv);

#endif
