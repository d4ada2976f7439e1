/* SPDX-License-Identifier: MIT */
#include "pipeline/render/tonemap.h"

#include <math.h>
#include <stddef.h>

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
        g = exp(log(y) * (1.0 / TONEMAP_GAMMA)); /* y in [1e-6, 1): cheaper than pow, same to an ulp or two */
        dg = g / (TONEMAP_GAMMA * y);
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
