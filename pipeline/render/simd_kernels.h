/* SPDX-License-Identifier: MIT */
/*
 * The fit_float sweep's kernels as a table, one per instruction set the
 * program carries (simd_variant.h): "base" (SSE2 on x86-64, NEON on
 * aarch64, 4 lanes) always, "avx2" (AVX2 + FMA, 8 lanes) on x86-64 builds
 * with HAVE_SIMD_AVX2. Each set computes every lane with the same
 * arithmetic; only the per-batch sums (lane_sum) add in another order.
 * Private to pipeline/render.
 */
#ifndef SUNPROBE_RENDER_SIMD_KERNELS_H
#define SUNPROBE_RENDER_SIMD_KERNELS_H

#include <stdint.h>

#include "pipeline/render/shade_simd.h"
#include "pipeline/render/surf_simd.h"

typedef struct simd_kernels {
    const char *name; /* "base", "avx2" */
    int lanes;
    void (*batch_pad)(simd_batch *b);
    void (*surf_batch_pad)(surf_batch *s, int n);
    void (*surf_forward_a)(const surf_frame *f, simd_batch *b);
    void (*surf_shadow)(const struct shade_ctx *ctx, const float l[3], simd_batch *b, int32_t *texels);
    void (*surf_gather_texels)(simd_batch *b, const float *albedo);
    void (*surf_forward_b)(simd_batch *b);
    void (*shade_forward)(const simd_frame *f, simd_batch *b);
    void (*resolve_l2)(const surf_frame *f, simd_batch *b, resolve_acc *acc);
    void (*shade_backward)(const simd_frame *f, simd_batch *b, simd_acc *acc);
    void (*surf_backward)(const surf_frame *f, simd_batch *b, surf_acc *acc);
    void (*surf_scatter)(const struct shade_ctx *ctx, const simd_batch *b, struct shade_acc *acc);
} simd_kernels;

/* The set named name if this program has it and this CPU can run it, else NULL. */
const simd_kernels *simd_kernels_by_name(const char *name);
/*
 * The fastest set this CPU runs, or the one the environment variable
 * SP_RENDER_SIMD names ("base": compare or test the baseline kernels on a
 * CPU with a faster set; an unknown or unavailable name is logged and ignored).
 */
const simd_kernels *simd_kernels_select(void);

#endif
