/* SPDX-License-Identifier: MIT */
/*
 * Environment lighting: the equirectangular map projected onto real spherical
 * harmonics up to order 2 (per-texel solid angles) and evaluated as irradiance
 * with the clamped-cosine kernel. Linear in the texels, so gradients are exact.
 */
#ifndef SUNPROBE_RENDER_ENVLIGHT_H
#define SUNPROBE_RENDER_ENVLIGHT_H

#define ENV_SH_N 9
#define ENV_TEXELS (SP_RENDER_ENV_H * SP_RENDER_ENV_W)

#include "sunprobe/sp_render.h"

typedef struct env_sh {
    double L[3][ENV_SH_N]; /* radiance coefficients per channel */
    double C[3][ENV_SH_N]; /* the same times the clamped-cosine weights A_l: irradiance coefficients */
} env_sh;

/* basis[t * 9 + j] = Y_j(centre direction of texel t) * solid angle of texel t. */
void env_basis_init(double *basis);
/* Centre direction of texel (row, col) as a unit world vector. */
void env_texel_dir(int row, int col, double dir[3]);
/* Projects an RGB map (NULL = black) onto the basis. */
void env_project(const double *basis, const float *env, env_sh *sh);
/* Y_j(n) for j < 9; n unit. */
void env_sh_eval(const double n[3], double y[ENV_SH_N]);
/*
 * Irradiance E[c] = max(0, sum_j A_j L[c][j] Y_j(n)) at normal n. Optional
 * outputs: dEdn (row c = dE[c]/dn, 0 where the clamp is active) and y (the
 * basis values Y_j(n), for env_irradiance_backward_L).
 */
void env_irradiance(const env_sh *sh, const double n[3], double E[3], double dEdn[3][3], double y[ENV_SH_N]);
/*
 * Adjoint w.r.t. the coefficients, in two steps: per sample
 * gY[c][j] += gE[c] y[j] for unclamped channels (E[c] > 0), then once
 * gL[c][j] = A_j gY[c][j] (env_weights_backward).
 */
void env_irradiance_backward_L(const double y[ENV_SH_N], const double E[3], const double gE[3],
                               double gY[3][ENV_SH_N]);
void env_weights_backward(const double gY[3][ENV_SH_N], double gL[3][ENV_SH_N]);
/* Adjoint of env_project: genv[t * 3 + c] += sum_j gL[c][j] basis[t * 9 + j]. */
void env_project_backward(const double *basis, const double gL[3][ENV_SH_N], double *genv);

#endif
