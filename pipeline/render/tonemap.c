/* SPDX-License-Identifier: MIT */
#include "pipeline/render/tonemap.h"

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

/* 2^(-e/11) for e = -21 .. 0: the exponent part of y^(-1/11). */
static const double rroot11_pow2[22] = {
    3.7557236426468257, 3.5263650199840848, 3.3110131195392429, 3.1088125635418389, 2.9189602113628923,
    2.7407019694402477, 2.5733297960188635, 2.4161788888088944, 2.2686250443909253, 2.1300821788799253,
    2.0,                1.8778618213234126, 1.7631825099920424, 1.6555065597696215, 1.5544062817709192,
    1.4594801056814461, 1.3703509847201236, 1.2866648980094317, 1.2080894444044472, 1.1343125221954626,
    1.0650410894399627, 1.0};

/*
 * g = y^(1/2.2) = y r^6 and its slope g / (2.2 y) = r^6 / 2.2, with r = y^(-1/11), for y in
 * [TONEMAP_TOE, 1). A table (exponent) times a quartic (mantissa, relative error < 9e-6) starts r;
 * two division-free Newton steps on r^-11 = y (error 6 e^2 each: 5e-10, then below rounding)
 * make it accurate to an ulp or two, so the slope is the derivative of the returned value.
 * ~35 flops and no division or libm call (glibc log + exp plus a division cost more).
 */
static double gamma_encode(double y, double *slope)
{
    uint64_t bits;
    memcpy(&bits, &y, sizeof(bits));
    int e = (int)((bits >> 52) & 0x7ff) - 1023;
    bits = (bits & ((UINT64_C(1) << 52) - 1)) | (UINT64_C(1023) << 52);
    double m;
    memcpy(&m, &bits, sizeof(m)); /* y = m 2^e, m in [1, 2) */
    e = e < -21 ? -21 : (e > 0 ? 0 : e);
    double t = m - 1.5;
    double r = rroot11_pow2[e + 21] *
               (0.96381061188428752 +
                t * (-0.058352506328353995 +
                     t * (0.021206757350074424 + t * (-0.010813746003653594 + t * 0.0056204656980558985))));
    for (int it = 0; it < 2; it++) {
        double r2 = r * r, r4 = r2 * r2, r11 = r4 * r4 * r2 * r;
        r = r * (12.0 - y * r11) * (1.0 / 11.0);
    }
    double r2 = r * r, r6 = r2 * r2 * r2;
    *slope = r6 * (1.0 / TONEMAP_GAMMA);
    return y * r6;
}

double tonemap_eval(double x, double *deriv)
{
    if (!(x > 0.0)) { /* negative, zero or NaN: black, flat */
        if (deriv)
            *deriv = 0.0;
        return 0.0;
    }
    if (isinf(x)) {
        if (deriv)
            *deriv = 0.0;
        return 1.0;
    }
    double inv = 1.0 / (1.0 + x); /* x may be huge: inv underflows gracefully to 0 */
    double y = x * inv;
    double dy = inv * inv;
    double g, dg;
    if (y >= TONEMAP_TOE) {
        if (y < 1.0) {
            g = gamma_encode(y, &dg);
        } else { /* x so large that y rounds to 1 */
            g = 1.0;
            dg = 1.0 / TONEMAP_GAMMA;
        }
    } else {
        dg = pow(TONEMAP_TOE, 1.0 / TONEMAP_GAMMA - 1.0);
        g = y * dg;
    }
    if (deriv)
        *deriv = dg * dy;
    return g;
}

double tonemap_deriv(double x, double g)
{
    if (!(x > 0.0) || isinf(x))
        return 0.0;
    double inv = 1.0 / (1.0 + x);
    double y = x * inv;
    double dg = y >= TONEMAP_TOE ? g / (TONEMAP_GAMMA * y) : pow(TONEMAP_TOE, 1.0 / TONEMAP_GAMMA - 1.0);
    return dg * inv * inv;
}
