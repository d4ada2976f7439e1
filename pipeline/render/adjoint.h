/* SPDX-License-Identifier: MIT */
/*
 * Reverse-mode derivative of one shaded sample: from dL/d(linear radiance of
 * the sample) back to albedo texels, SH coefficients, material, sun, camera
 * and per-vertex accumulators (displaced positions, normals, camera-space
 * positions). Visibility switches (which triangle, which shadow texel) are
 * held fixed: see RENDERER.md.
 */
#ifndef SUNPROBE_RENDER_ADJOINT_H
#define SUNPROBE_RENDER_ADJOINT_H

#include "pipeline/render/shading.h"

typedef struct shade_acc {
    double *g_albedo;              /* 3 per texel, NULL to skip */
    double *g_pd, *g_nd, *g_xc;    /* 3 per vertex */
    double gY[3][ENV_SH_N];        /* SH coefficients before the clamped-cosine weights (envlight.h) */
    double g_ks[SP_RENDER_CLUSTERS], g_s[SP_RENDER_CLUSTERS];
    double g_l[3];                 /* unit sun direction */
    double g_I;                    /* sun irradiance */
    double g_eye[3];               /* camera centre */
    double g_fx, g_fy, g_cx, g_cy;
} shade_acc;

/* Local adjoints of one sample's surface quantities (albedo, unit normal, point, unit view direction). */
typedef struct sample_grad {
    double a[3], n[3], p[3], v[3];
} sample_grad;

/*
 * The geometric tail of shade_backward: view vector, albedo splat and UV,
 * interpolation and barycentrics, from the sample's local adjoints sg (the
 * float kernels' path in fused.c; sg is consumed).
 */
void shade_backward_surface(const shade_ctx *ctx, const shade_rec *rec, sample_grad *sg, shade_acc *acc);

/* Adds the sample's contribution given gc = dL/d(rec's linear RGB). */
void shade_backward(const shade_ctx *ctx, const shade_rec *rec, const double gc[3], shade_acc *acc);

#endif
