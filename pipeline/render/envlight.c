/* SPDX-License-Identifier: MIT */
#include "pipeline/render/envlight.h"

#include <math.h>
#include <string.h>

#define PI 3.14159265358979323846

/* Real SH normalisation constants, order <= 2. */
#define K0 0.28209479177387814 /* 1 / (2 sqrt(pi)) */
#define K1 0.48860251190291992 /* sqrt(3 / (4 pi)) */
#define K2 1.09254843059207907 /* sqrt(15 / (4 pi)) */
#define K3 0.31539156525252005 /* sqrt(5 / (16 pi)) */
#define K4 0.54627421529603953 /* sqrt(15 / (16 pi)) */

/* Clamped-cosine convolution weights A_l per coefficient. */
static const double conv_a[ENV_SH_N] = {
    PI, 2.0 * PI / 3.0, 2.0 * PI / 3.0, 2.0 * PI / 3.0,
    PI / 4.0, PI / 4.0, PI / 4.0, PI / 4.0, PI / 4.0,
};

void env_sh_eval(const double n[3], double y[ENV_SH_N])
{
    double x = n[0], yy = n[1], z = n[2];
    y[0] = K0;
    y[1] = K1 * yy;
    y[2] = K1 * z;
    y[3] = K1 * x;
    y[4] = K2 * x * yy;
    y[5] = K2 * yy * z;
    y[6] = K3 * (3.0 * z * z - 1.0);
    y[7] = K2 * x * z;
    y[8] = K4 * (x * x - yy * yy);
}

void env_texel_dir(int row, int col, double dir[3])
{
    double theta = ((double)row + 0.5) * PI / SP_RENDER_ENV_H;
    double phi = ((double)col + 0.5) * 2.0 * PI / SP_RENDER_ENV_W;
    dir[0] = sin(theta) * cos(phi);
    dir[1] = sin(theta) * sin(phi);
    dir[2] = cos(theta);
}

void env_basis_init(double *basis)
{
    double dphi = 2.0 * PI / SP_RENDER_ENV_W;
    for (int i = 0; i < SP_RENDER_ENV_H; i++) {
        /* exact solid angle of the latitude band slice */
        double t0 = (double)i * PI / SP_RENDER_ENV_H, t1 = (double)(i + 1) * PI / SP_RENDER_ENV_H;
        double domega = dphi * (cos(t0) - cos(t1));
        for (int j = 0; j < SP_RENDER_ENV_W; j++) {
            double d[3], y[ENV_SH_N];
            env_texel_dir(i, j, d);
            env_sh_eval(d, y);
            double *b = basis + ((size_t)i * SP_RENDER_ENV_W + (size_t)j) * ENV_SH_N;
            for (int k = 0; k < ENV_SH_N; k++)
                b[k] = y[k] * domega;
        }
    }
}

void env_project(const double *basis, const float *env, env_sh *sh)
{
    memset(sh, 0, sizeof(*sh));
    if (!env)
        return;
    for (int t = 0; t < ENV_TEXELS; t++) {
        const double *b = basis + (size_t)t * ENV_SH_N;
        for (int c = 0; c < 3; c++) {
            double v = (double)env[t * 3 + c];
            for (int k = 0; k < ENV_SH_N; k++)
                sh->L[c][k] += v * b[k];
        }
    }
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < ENV_SH_N; k++)
            sh->C[c][k] = conv_a[k] * sh->L[c][k];
}

void env_irradiance(const env_sh *sh, const double n[3], double E[3], double dEdn[3][3], double y[ENV_SH_N])
{
    double yy[ENV_SH_N];
    double *b = y ? y : yy;
    env_sh_eval(n, b);
    double x = n[0], ny = n[1], z = n[2];
    for (int c = 0; c < 3; c++) {
        const double *C = sh->C[c];
        double e = C[0] * b[0] + C[1] * b[1] + C[2] * b[2] + C[3] * b[3] + C[4] * b[4] + C[5] * b[5] +
                   C[6] * b[6] + C[7] * b[7] + C[8] * b[8];
        E[c] = e > 0.0 ? e : 0.0;
        if (!dEdn)
            continue;
        if (!(e > 0.0)) {
            dEdn[c][0] = dEdn[c][1] = dEdn[c][2] = 0.0;
            continue;
        }
        /* gradients of the basis polynomials; radial parts vanish after the normal's projection */
        dEdn[c][0] = K1 * C[3] + K2 * (C[4] * ny + C[7] * z) + 2.0 * K4 * C[8] * x;
        dEdn[c][1] = K1 * C[1] + K2 * (C[4] * x + C[5] * z) - 2.0 * K4 * C[8] * ny;
        dEdn[c][2] = K1 * C[2] + K2 * (C[5] * ny + C[7] * x) + 6.0 * K3 * C[6] * z;
    }
}

void env_irradiance_backward_L(const double y[ENV_SH_N], const double E[3], const double gE[3],
                               double gY[3][ENV_SH_N])
{
    for (int c = 0; c < 3; c++) {
        if (!(E[c] > 0.0))
            continue;
        double g = gE[c];
        double *o = gY[c];
        o[0] += g * y[0], o[1] += g * y[1], o[2] += g * y[2];
        o[3] += g * y[3], o[4] += g * y[4], o[5] += g * y[5];
        o[6] += g * y[6], o[7] += g * y[7], o[8] += g * y[8];
    }
}

void env_weights_backward(const double gY[3][ENV_SH_N], double gL[3][ENV_SH_N])
{
    for (int c = 0; c < 3; c++)
        for (int k = 0; k < ENV_SH_N; k++)
            gL[c][k] = conv_a[k] * gY[c][k];
}

void env_project_backward(const double *basis, const double gL[3][ENV_SH_N], double *genv)
{
    for (int t = 0; t < ENV_TEXELS; t++) {
        const double *b = basis + (size_t)t * ENV_SH_N;
        for (int c = 0; c < 3; c++) {
            double s = 0.0;
            for (int k = 0; k < ENV_SH_N; k++)
                s += gL[c][k] * b[k];
            genv[t * 3 + c] += s;
        }
    }
}
