/* SPDX-License-Identifier: MIT */
#include "pipeline/render/simd_kernels.h"

#include <stdlib.h>
#include <string.h>

#include "pipeline/render/vec_simd.h"
#include "sp_config.h"
#include "sunprobe/sp_common.h"

/* This build's table: simd_kernels_base, or simd_kernels_<variant> (simd_variant.h). */
#ifdef SP_SIMD_VARIANT
#define THIS_TABLE SIMD_NAME(simd_kernels)
#define THIS_NAME SIMD_STR(SP_SIMD_VARIANT)
#else
#define THIS_TABLE simd_kernels_base
#define THIS_NAME "base"
#endif

extern const simd_kernels THIS_TABLE;
const simd_kernels THIS_TABLE = {
    .name = THIS_NAME,
    .lanes = LANES,
    .batch_pad = simd_batch_pad,
    .surf_batch_pad = surf_batch_pad,
    .surf_forward_a = surf_forward_a,
    .surf_shadow = surf_shadow,
    .surf_gather_texels = surf_gather_texels,
    .surf_forward_b = surf_forward_b,
    .shade_forward = simd_shade_forward,
    .resolve_l2 = surf_resolve_l2,
    .shade_backward = simd_shade_backward,
    .surf_backward = surf_backward,
    .surf_scatter = surf_scatter,
};

#ifndef SP_SIMD_VARIANT
#if HAVE_SIMD_AVX2
extern const simd_kernels simd_kernels_avx2;

static int cpu_runs_avx2(void)
{
    __builtin_cpu_init(); /* checks the OS saves the AVX state too */
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}
#endif

const simd_kernels *simd_kernels_by_name(const char *name)
{
    if (!name)
        return NULL;
    if (!strcmp(name, "base"))
        return &simd_kernels_base;
#if HAVE_SIMD_AVX2
    if (!strcmp(name, "avx2") && cpu_runs_avx2())
        return &simd_kernels_avx2;
#endif
    return NULL;
}

const simd_kernels *simd_kernels_select(void)
{
    const char *want = getenv("SP_RENDER_SIMD");
    if (want && *want) {
        const simd_kernels *k = simd_kernels_by_name(want);
        if (k)
            return k;
        sp_log(SP_LOG_WARN, "render", "SP_RENDER_SIMD=%s: no such kernel set in this build or CPU; ignored", want);
    }
    const simd_kernels *best = simd_kernels_by_name("avx2");
    return best ? best : &simd_kernels_base;
}

const char *sp_render_kernel_set(void)
{
    return simd_kernels_select()->name;
}
#endif
