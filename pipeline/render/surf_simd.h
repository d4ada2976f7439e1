/* SPDX-License-Identifier: MIT */
/*
 * Float structure-of-arrays surface kernels for settings.fit_float: the
 * per-sample surface reconstruction (interpolated and normalised shading
 * normal, view direction, bilinear albedo) and its adjoint (normalisations,
 * UV derivative of the albedo lookup, perspective barycentrics and the
 * sample ray) over a batch of up to SIMD_BATCH samples, lane i of a
 * surf_batch (b->surf) pairing with lane i of its simd_batch b. The caller gathers the
 * per-sample vertex data (scalar), runs the kernels, and scatters the
 * per-vertex and per-texel adjoints (scalar). Decisions that switch
 * discretely (coverage, shadow texel, cluster) stay with the caller in
 * double, so they match the double path exactly. See OPTIMISATION-LOG.md "Fourth pass".
 */
#ifndef SUNPROBE_RENDER_SURF_SIMD_H
#define SUNPROBE_RENDER_SURF_SIMD_H

#include "pipeline/render/simd_variant.h" /* first: the AVX2 build renames the entry points */

#include <stdint.h>

#define SIMD_BATCH 64 /* samples per batch; a multiple of the lane count */

struct simd_batch;
struct shade_ctx;
struct shade_acc;

/* The surface part of a simd_batch (embedded in it: b->surf). */
typedef struct surf_batch {
    /* caller bookkeeping for the scatter and the resolve */
    int32_t vtx[3][SIMD_BATCH];            /* vertex ids */
    int32_t cluster[SIMD_BATCH];           /* -1: no specular */
    int32_t pix[SIMD_BATCH];               /* pixel index */
    int32_t samp[SIMD_BATCH];              /* sample index (where surf_shadow writes the shadow texel) */
    double pw[3][SIMD_BATCH];              /* world hit point (double: the shadow lookup) */
    /* gathered by the caller (lanes [0, n) of the paired simd_batch) */
    float d0[SIMD_BATCH], d1[SIMD_BATCH];  /* sample ray (d0, d1, 1), camera space */
    float lam[3][SIMD_BATCH];              /* perspective barycentrics */
    float iw[SIMD_BATCH];                  /* 1 / sum of the edge functions */
    float dp[3][3][SIMD_BATCH];            /* [vertex][axis]: displaced vertex minus the hit point (world) */
    float nd[3][3][SIMD_BATCH];            /* [vertex][axis]: displaced unit vertex normals */
    float uvv[3][2][SIMD_BATCH];           /* [vertex][u, v]: vertex UVs */
    float ev[3][SIMD_BATCH];               /* eye - p */
    float u[SIMD_BATCH], v[SIMD_BATCH];    /* interpolated UV */
    float dz[3][SIMD_BATCH];               /* d(shadow sigmoid argument)/dp; 0 without a map */
    /* surf_forward_a: bilinear footprint (texel indices are pixel indices, not times channels) */
    int32_t tidx[4][SIMD_BATCH];
    float fx[SIMD_BATCH], fy[SIMD_BATCH], dfx[SIMD_BATCH], dfy[SIMD_BATCH];
    float imlen[SIMD_BATCH], ievlen[SIMD_BATCH]; /* 1 / |m|, 1 / |eye - p| (0 when degenerate) */
    /* gathered by the caller between surf_forward_a and surf_forward_b: the 4 albedo texels */
    float tex[4][3][SIMD_BATCH];
    /* S = 1 resolve (surf_resolve_l2): pixel target and mask in, display value out */
    float tgt[3][SIMD_BATCH], msk[SIMD_BATCH], img[3][SIMD_BATCH];
    /* surf_backward outputs, per sample, ready to add (surf_scatter) */
    float gpv[3][3][SIMD_BATCH];           /* [vertex][axis]: dL/d(displaced world vertex), camera-space part folded in */
    float gmv[3][3][SIMD_BATCH];           /* [vertex][axis]: dL/d(displaced unit vertex normal) */
    float gal[4][3][SIMD_BATCH];           /* [texel][channel]: dL/d(albedo texel tidx) */
} surf_batch;

/*
 * Frame-wide sums of surf_backward (double): camera centre and intrinsics,
 * and the pose through the camera-space vertices (x = R p + t: dL/dR =
 * sum dL/dx p^T, dL/dt = sum dL/dx; their R^T dL/dx is in gpv instead of a
 * per-vertex camera-space accumulator).
 */
typedef struct surf_acc {
    double g_eye[3];
    double g_fx, g_fy, g_cx, g_cy;
    double g_R[9], g_t[3];
} surf_acc;

/* Frame constants. */
typedef struct surf_frame {
    int tex_w, tex_h;       /* albedo size */
    double inv_fx, inv_fy;
    float R[9];             /* camera rotation (row-major) */
    float eye[3];           /* camera centre, world */
    float exposure;
    float toe_slope;        /* TONEMAP_TOE^(1 / TONEMAP_GAMMA - 1): the tone map's linear toe */
    float two_over_norm;    /* 2 / max(sum of the mask, 1e-12) */
} surf_frame;

/* Frame sums of surf_resolve_l2. */
typedef struct resolve_acc {
    double loss;            /* sum of m (image - target)^2 */
    double g_exposure;
} resolve_acc;

/*
 * Sample (sx, sy) on triangle tri (ctx: the frame, as for shade_geometry)
 * into lane i of b and b->surf: ray, barycentrics, vertex data, UV,
 * cluster (ks, s), hit point (pw). The hit point, UV and cluster are
 * computed in double with shade_geometry's arithmetic, so coverage, shadow
 * texels and clusters match the double path exactly. Returns 0 for a
 * degenerate hit (uncovered, as shade_geometry), 1 otherwise. The body is
 * surf_gather_at in surf_gather.h (inlined into the fused sweep).
 */
int surf_gather(const struct shade_ctx *ctx, int sx, int sy, int32_t tri, struct simd_batch *b, int i);
/*
 * After surf_forward_a: the shadow lookup (b->z, b->surf.dz) of lanes whose
 * float n.l is positive (the test simd_shade_forward makes: elsewhere the
 * sun term and its adjoint vanish, so V is not needed: z = -1e30, dz = 0);
 * writes each lane's shadow texel, -1 for skipped lanes, to
 * texels[b->surf.samp[i]] (texels may be NULL). l: the unit sun direction
 * (the simd_frame's).
 */
void surf_shadow(const struct shade_ctx *ctx, const float l[3], struct simd_batch *b, int32_t *texels);
/* The four albedo texels of lanes [0, b->n) (after surf_forward_a); albedo: 3 floats per texel. */
void surf_gather_texels(struct simd_batch *b, const float *albedo);
/*
 * Adds the adjoints of lanes [0, b->n) with a nonzero gc (after
 * simd_shade_backward and surf_backward) to acc: per-vertex g_pd (the
 * camera-space part included: acc->g_xc is not touched) and g_nd, albedo
 * texels (if acc->g_albedo), ks and shininess per cluster (shininess not
 * where ctx->s_clamped).
 */
void surf_scatter(const struct shade_ctx *ctx, const struct simd_batch *b, struct shade_acc *acc);
/* Zeroes the gathered inputs of lanes [n, next multiple of the lane count) (texels included). */
void surf_batch_pad(surf_batch *s, int n);
/*
 * Normal n = normalize(sum lam_i nd_i) and view v = normalize(ev) into
 * b->n*, b->v*; the albedo footprint of (u, v) into b->surf (clamp to
 * edge, as tex_lookup_init).
 */
void surf_forward_a(const surf_frame *f, struct simd_batch *b);
/* Albedo from the gathered texels into b->a. */
void surf_forward_b(struct simd_batch *b);
/*
 * From the shading adjoint in b (ga, gn, gv, gV, dVdz) to b->surf.gpv,
 * gmv, gal; adds the camera sums to acc. Lanes with gc = 0 give zeros.
 */
void surf_backward(const surf_frame *f, struct simd_batch *b, surf_acc *acc);

/*
 * Supersample 1: lane i is pixel s->pix[i], fully covered. Tone-maps the
 * radiance b->rad (tonemap_eval in float: exp2 / log2 polynomials) into
 * s->img, adds the masked L2 term of (img - tgt) and the exposure gradient
 * to acc, and writes dL/d(radiance) into b->gc (0 in lanes past b->n).
 */
void surf_resolve_l2(const surf_frame *f, struct simd_batch *b, resolve_acc *acc);

#endif
