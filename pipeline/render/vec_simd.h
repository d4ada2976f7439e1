/* SPDX-License-Identifier: MIT */
/*
 * Private helpers of the float SoA kernels (shade_simd.c, surf_simd.c): a
 * float vector type (GCC vector extensions: 4 lanes for SSE2 / NEON, 8 in
 * the AVX2 build of simd_variant.h) or plain float with SP_SIMD_SCALAR /
 * other compilers, loads, stores, lane selects
 * and call-free exp2 / log2 / 1/sqrt. Static inline: include only from
 * *_simd.c files.
 */
#ifndef SUNPROBE_RENDER_VEC_SIMD_H
#define SUNPROBE_RENDER_VEC_SIMD_H

#include <stdint.h>
#include <string.h>

#define LN2 0.69314718f
#define LOG2E 1.44269504f

#if defined(__GNUC__) && !defined(SP_SIMD_SCALAR) /* SP_SIMD_SCALAR: force the fallback (tests) */
#if defined(__AVX2__)
#define LANES 8
#else
#define LANES 4
#endif
typedef float vf __attribute__((vector_size(4 * LANES)));
typedef int32_t vi __attribute__((vector_size(4 * LANES)));
/* double vectors of the same width (the shadow lookup): their comparison masks and 32-bit integers per lane */
#define DLANES (LANES / 2)
typedef double vd __attribute__((vector_size(8 * DLANES)));
typedef int64_t vdm __attribute__((vector_size(8 * DLANES)));
typedef int32_t vdi __attribute__((vector_size(4 * DLANES)));
#define AS_VI(x) ((vi)(x))
#define AS_VF(x) ((vf)(x))
#define CVT_I(x) __builtin_convertvector((x), vi)
#define CVT_F(x) __builtin_convertvector((x), vf)
#define MASK(c) (c) /* vector comparisons give -1 / 0 per lane */
#else
#define LANES 1
typedef float vf;
typedef int32_t vi;
static inline vi as_vi(vf x)
{
    vi r;
    memcpy(&r, &x, sizeof(r));
    return r;
}
static inline vf as_vf(vi x)
{
    vf r;
    memcpy(&r, &x, sizeof(r));
    return r;
}
#define AS_VI(x) as_vi(x)
#define AS_VF(x) as_vf(x)
#define CVT_I(x) ((vi)(x))
#define CVT_F(x) ((vf)(x))
#define MASK(c) (-(vi)(c))
#endif

static inline vf ld(const float *p)
{
    vf v;
    memcpy(&v, p, sizeof(v));
    return v;
}

static inline void st(float *p, vf v)
{
    memcpy(p, &v, sizeof(v));
}

static inline vi ldi(const int32_t *p)
{
    vi v;
    memcpy(&v, p, sizeof(v));
    return v;
}

static inline void sti(int32_t *p, vi v)
{
    memcpy(p, &v, sizeof(v));
}

static inline vf splat(float x)
{
    return (vf){0} + x;
}

#ifdef DLANES
static inline vd ldd(const double *p)
{
    vd v;
    memcpy(&v, p, sizeof(v));
    return v;
}

/* m ? a : b per double lane */
static inline vd seld(vdm m, vd a, vd b)
{
    return (vd)(((vdm)a & m) | ((vdm)b & ~m));
}
#endif

/* m ? a : b per lane (m all ones or zero) */
static inline vf sel(vi m, vf a, vf b)
{
    return AS_VF((AS_VI(a) & m) | (AS_VI(b) & ~m));
}

static inline vf vmin(vf a, vf b)
{
    return sel(MASK(a < b), a, b);
}

static inline vf vmax(vf a, vf b)
{
    return sel(MASK(a > b), a, b);
}

/* 2^x, x clamped to [-126, 126] (so the scale is a normal float and the result finite). */
static inline vf v_exp2(vf x)
{
    x = vmin(vmax(x, splat(-126.0f)), splat(126.0f));
    vf xr = x + splat(0.5f);
    vi t = CVT_I(xr); /* truncation toward 0; floor for negative xr below */
    vf tf = CVT_F(t);
    t = t + MASK(tf > xr); /* the mask is -1 where truncation rounded up */
    tf = CVT_F(t);
    vf f = x - tf; /* [-0.5, 0.5] */
    /* Taylor series of e^(f ln 2) to f^6: relative error < 1.3e-7 on [-0.5, 0.5] */
    vf p = splat(1.5403530e-4f);
    p = p * f + splat(1.3333558e-3f);
    p = p * f + splat(9.6181291e-3f);
    p = p * f + splat(5.5504109e-2f);
    p = p * f + splat(2.4022651e-1f);
    p = p * f + splat(6.9314718e-1f);
    p = p * f + splat(1.0f);
    vi bits = (t + 127) << 23;
    return p * AS_VF(bits);
}

/* log2(x) for x in [1e-30, 1] (callers clamp); relative error ~1e-7 away from x = 1. */
static inline vf v_log2(vf x)
{
    vi bits = AS_VI(x);
    vi e = ((bits >> 23) & 255) - 127;
    vf m = AS_VF((bits & 0x7fffff) | 0x3f800000); /* [1, 2) */
    vi big = MASK(m > splat(1.41421356f));
    m = sel(big, m * splat(0.5f), m);
    e = e - big; /* big is -1 where m was halved */
    vf t = (m - splat(1.0f)) / (m + splat(1.0f)); /* |t| < 0.172 */
    vf t2 = t * t;
    /* 2 / ln 2 * atanh(t), odd series to t^9 */
    vf s = splat(2.0f * LOG2E / 9.0f);
    s = s * t2 + splat(2.0f * LOG2E / 7.0f);
    s = s * t2 + splat(2.0f * LOG2E / 5.0f);
    s = s * t2 + splat(2.0f * LOG2E / 3.0f);
    s = s * t2 + splat(2.0f * LOG2E);
    return CVT_F(e) + s * t;
}

/* 1 / sqrt(x) for x in [1e-24, 1e24]: bit estimate + 3 Newton steps (sqrtf would call libm for errno). */
static inline vf v_rsqrt(vf x)
{
    vf y = AS_VF(0x5f3759df - (AS_VI(x) >> 1));
    for (int k = 0; k < 3; k++)
        y = y * (1.5f - 0.5f * x * y * y);
    return y;
}

static inline vf zero_v(void)
{
    return splat(0.0f);
}

/* Sum of the lanes in double (the kernels' per-batch frame sums). */
static inline double lane_sum(vf v)
{
    float t[LANES];
    memcpy(t, &v, sizeof(t));
    double s = 0.0;
    for (int k = 0; k < LANES; k++)
        s += (double)t[k];
    return s;
}

#endif
