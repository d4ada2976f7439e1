/* SPDX-License-Identifier: MIT */
/*
 * Float structure-of-arrays shading kernels (settings.fit_float): the per-sample sun Lambert + normalised
 * Blinn-Phong, the soft-shadow sigmoid and the SH ambient term, and their
 * adjoint, over a batch of up to SIMD_BATCH covered samples. Written with
 * GCC vector extensions (4 float lanes: SSE2 / NEON; 8 in the AVX2 build, simd_kernels.h) and a scalar fallback;
 * no libm calls (polynomial exp2 / log2 with explicit exponent clamps).
 * The surface reconstruction and its adjoint are in surf_simd.h; texel and
 * vertex gathers / scatters stay with the caller. See RENDERER.md "Memory and speed".
 */
#ifndef SUNPROBE_RENDER_SHADE_SIMD_H
#define SUNPROBE_RENDER_SHADE_SIMD_H

#include "pipeline/render/simd_variant.h" /* first: the AVX2 build renames the entry points */

#include "pipeline/render/envlight.h"
#include "pipeline/render/surf_simd.h" /* SIMD_BATCH, surf_batch */

/* Frame constants in float. */
typedef struct simd_frame {
    float l[3];               /* unit sun direction */
    float I;                  /* sun irradiance */
    float C[3][ENV_SH_N];     /* SH irradiance coefficients (env_sh.C) */
} simd_frame;

/*
 * One batch. The caller fills n and the inputs of samples [0, n); the kernels
 * treat lanes up to the next multiple of the lane count (simd_batch_pad zeroes them).
 */
typedef struct simd_batch {
    int n;
    /* inputs: unit normal, unit view direction, albedo, lobe (ks = 0: no specular; s >= 1), shadow */
    float nx[SIMD_BATCH], ny[SIMD_BATCH], nz[SIMD_BATCH];
    float vx[SIMD_BATCH], vy[SIMD_BATCH], vz[SIMD_BATCH];
    float a[3][SIMD_BATCH];
    float ks[SIMD_BATCH], s[SIMD_BATCH];
    float z[SIMD_BATCH];      /* V = 1 - sigmoid(z) (soft shadow argument k (d - b ds)); -1e30: unshadowed */
    /* forward results */
    float rad[3][SIMD_BATCH]; /* a / pi (E + I max(n.l, 0) V) + specular */
    float V[SIMD_BATCH], dVdz[SIMD_BATCH];
    /* intermediates for the adjoint */
    float nl[SIMD_BATCH], P[SIMD_BATCH], lnh[SIMD_BATCH], nh[SIMD_BATCH], nhok[SIMD_BATCH];
    float hx[SIMD_BATCH], hy[SIMD_BATCH], hz[SIMD_BATCH], hlen[SIMD_BATCH];
    float e[3][SIMD_BATCH];   /* SH irradiance before the clamp at 0 */
    /* adjoint input: dL/d(rad) per sample */
    float gc[3][SIMD_BATCH];
    /* adjoint outputs per sample: w.r.t. albedo, normal, view direction, V, ks, s */
    float ga[3][SIMD_BATCH], gn[3][SIMD_BATCH], gv[3][SIMD_BATCH];
    float gV[SIMD_BATCH], gks[SIMD_BATCH], gs[SIMD_BATCH];
    surf_batch surf;          /* fit_float's surface reconstruction and its adjoint (surf_simd.h) */
} simd_batch;

/* Frame-wide adjoint sums (double): sun direction, irradiance, SH (gY as env_irradiance_backward_L). */
typedef struct simd_acc {
    double gl[3], gI, gY[3][ENV_SH_N];
} simd_acc;

void simd_frame_init(simd_frame *f, const double l[3], double I, const env_sh *sh);
/* Zeroes the inputs of lanes [n, next multiple of the lane count). */
void simd_batch_pad(simd_batch *b);
void simd_shade_forward(const simd_frame *f, simd_batch *b);
/* Needs the forward's intermediates in b and b->gc; adds the frame sums to acc. */
void simd_shade_backward(const simd_frame *f, simd_batch *b, simd_acc *acc);

/* The kernels' exp2 / log2 on one value (for tests): |x| clamped to 126; x in [1e-30, 1]. */
float simd_exp2f(float x);
float simd_log2f(float x);

#endif
