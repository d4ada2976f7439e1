/* SPDX-License-Identifier: MIT */
/*
 * Inline double 3-vector helpers shared by the renderer's modules (internal),
 * plus min/max/floor without libm calls (x86-64's baseline has no rounding
 * instruction, so floor() and fmin() are function calls in hot loops).
 */
#ifndef SUNPROBE_RENDER_VEC3_H
#define SUNPROBE_RENDER_VEC3_H

#include <math.h>

static inline double dmin(double a, double b)
{
    return a < b ? a : b;
}

static inline double dmax(double a, double b)
{
    return a > b ? a : b;
}

/*
 * double -> float that flushes magnitudes below 1e-30 to 0: float subnormals
 * (e.g. a sharp specular lobe's tail) cost ~100 cycles per operation on x86.
 */
static inline float to_float(double x)
{
    return (x < 1e-30 && x > -1e-30) ? 0.0f : (float)x;
}

/* floor / ceil as int for |x| < 2^31 (callers clamp first). */
static inline int ifloor(double x)
{
    int i = (int)x;
    return i - (x < (double)i);
}

static inline int iceil(double x)
{
    int i = (int)x;
    return i + (x > (double)i);
}

/* Integer range [*lo, *hi] of the integers in [a, b] clipped to [0, n-1]; empty when *lo > *hi. */
static inline void int_range(double a, double b, int n, int *lo, int *hi)
{
    *lo = a <= 0.0 ? 0 : (a > (double)n ? n : iceil(a));
    *hi = b >= (double)(n - 1) ? n - 1 : (b < 0.0 ? -1 : ifloor(b));
}

static inline double v3_dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline void v3_cross(const double a[3], const double b[3], double out[3])
{
    double x = a[1] * b[2] - a[2] * b[1];
    double y = a[2] * b[0] - a[0] * b[2];
    double z = a[0] * b[1] - a[1] * b[0];
    out[0] = x;
    out[1] = y;
    out[2] = z;
}

static inline void v3_sub(const double a[3], const double b[3], double out[3])
{
    out[0] = a[0] - b[0];
    out[1] = a[1] - b[1];
    out[2] = a[2] - b[2];
}

/* out += s * a */
static inline void v3_axpy(double s, const double a[3], double out[3])
{
    out[0] += s * a[0];
    out[1] += s * a[1];
    out[2] += s * a[2];
}

static inline void v3_scale(const double a[3], double s, double out[3])
{
    out[0] = a[0] * s;
    out[1] = a[1] * s;
    out[2] = a[2] * s;
}

static inline void v3_zero(double a[3])
{
    a[0] = a[1] = a[2] = 0.0;
}

static inline void v3_from_float(const float *f, double out[3])
{
    out[0] = (double)f[0];
    out[1] = (double)f[1];
    out[2] = (double)f[2];
}

static inline double v3_norm(const double a[3])
{
    return sqrt(v3_dot(a, a));
}

/* Below this length a vector counts as zero and normalises to zero (its gradient too). */
#define V3_TINY 1e-30

/* out = a / |a|; returns |a|, and zero output for a tiny or non-finite a. */
static inline double v3_normalize(const double a[3], double out[3])
{
    double len = v3_norm(a);
    if (!(len > V3_TINY) || !isfinite(len)) {
        v3_zero(out);
        return 0.0;
    }
    v3_scale(a, 1.0 / len, out);
    return len;
}

/* Adjoint of n = a / |a|: adds (I - n n^T) g / |a| to ga; nothing for a zero-length a. */
static inline void v3_normalize_backward(const double n[3], double len, const double g[3], double ga[3])
{
    if (!(len > V3_TINY))
        return;
    double gn = v3_dot(n, g);
    double inv = 1.0 / len;
    ga[0] += (g[0] - n[0] * gn) * inv;
    ga[1] += (g[1] - n[1] * gn) * inv;
    ga[2] += (g[2] - n[2] * gn) * inv;
}

/* y = M x and y = M^T x for a row-major 3x3 matrix. */
static inline void m3_mul(const double m[9], const double x[3], double y[3])
{
    double a = m[0] * x[0] + m[1] * x[1] + m[2] * x[2];
    double b = m[3] * x[0] + m[4] * x[1] + m[5] * x[2];
    double c = m[6] * x[0] + m[7] * x[1] + m[8] * x[2];
    y[0] = a;
    y[1] = b;
    y[2] = c;
}

static inline void m3_tmul(const double m[9], const double x[3], double y[3])
{
    double a = m[0] * x[0] + m[3] * x[1] + m[6] * x[2];
    double b = m[1] * x[0] + m[4] * x[1] + m[7] * x[2];
    double c = m[2] * x[0] + m[5] * x[1] + m[8] * x[2];
    y[0] = a;
    y[1] = b;
    y[2] = c;
}

#endif
