/* SPDX-License-Identifier: MIT */
/*
 * Display transform: Reinhard y = x / (1 + x) on the exposed linear value
 * (x clamped >= 0), then gamma y^(1/2.2). Below TONEMAP_TOE the gamma curve is
 * replaced by the straight line through 0 and (TONEMAP_TOE, TONEMAP_TOE^(1/2.2)),
 * so the derivative stays finite at black (exact above the toe, continuous everywhere).
 */
#ifndef SUNPROBE_RENDER_TONEMAP_H
#define SUNPROBE_RENDER_TONEMAP_H

#define TONEMAP_GAMMA 2.2
#define TONEMAP_TOE 1e-6

/* Display value of exposed linear radiance x; *deriv (if non-NULL) gets d/dx. */
double tonemap_eval(double x, double *deriv);
/* d/dx of the display value, given x and its display value g = tonemap_eval(x) (no pow needed). */
double tonemap_deriv(double x, double g);

#endif
