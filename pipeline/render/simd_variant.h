/* SPDX-License-Identifier: MIT */
/*
 * The float kernels (shade_simd.c, surf_simd.c, simd_kernels.c) are built
 * once for the baseline instruction set and, on x86-64, once more with
 * -mavx2 -mfma -DSP_SIMD_VARIANT=avx2 (pipeline/meson.build), where
 * vec_simd.h's vectors have 8 lanes. In that second build every entry point
 * gets the suffix _avx2, so both sets link into one program and
 * simd_kernels.h picks one per CPU. Included first by the kernel headers.
 */
#ifndef SUNPROBE_RENDER_SIMD_VARIANT_H
#define SUNPROBE_RENDER_SIMD_VARIANT_H

#define SIMD_STR_(x) #x
#define SIMD_STR(x) SIMD_STR_(x)

#ifdef SP_SIMD_VARIANT
#define SIMD_CAT_(name, v) name##_##v
#define SIMD_CAT(name, v) SIMD_CAT_(name, v)
#define SIMD_NAME(name) SIMD_CAT(name, SP_SIMD_VARIANT)
/* shade_simd.h */
#define simd_exp2f SIMD_NAME(simd_exp2f)
#define simd_log2f SIMD_NAME(simd_log2f)
#define simd_frame_init SIMD_NAME(simd_frame_init)
#define simd_batch_pad SIMD_NAME(simd_batch_pad)
#define simd_shade_forward SIMD_NAME(simd_shade_forward)
#define simd_shade_backward SIMD_NAME(simd_shade_backward)
/* surf_simd.h */
#define surf_gather SIMD_NAME(surf_gather)
#define surf_shadow SIMD_NAME(surf_shadow)
#define surf_gather_texels SIMD_NAME(surf_gather_texels)
#define surf_scatter SIMD_NAME(surf_scatter)
#define surf_batch_pad SIMD_NAME(surf_batch_pad)
#define surf_forward_a SIMD_NAME(surf_forward_a)
#define surf_forward_b SIMD_NAME(surf_forward_b)
#define surf_backward SIMD_NAME(surf_backward)
#define surf_resolve_l2 SIMD_NAME(surf_resolve_l2)
#endif

#endif
