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

/* dY_j/dn of the polynomials above (radial parts vanish after the normal's projection). */
static void sh_grad(const double n[3], double g[ENV_SH_N][3])
{
    double x = n[0], y = n[1], z = n[2];
    memset(g, 0, sizeof(double) * ENV_SH_N * 3);
    g[1][1] = K1;
    g[2][2] = K1;
    g[3][0] = K1;
    g[4][0] = K2 * y;
    g[4][1] = K2 * x;
    g[5][1] = K2 * z;
    g[5][2] = K2 * y;
    g[6][2] = 6.0 * K3 * z;
    g[7][0] = K2 * z;
    g[7][2] = K2 * x;
    g[8][0] = 2.0 * K4 * x;
    g[8][1] = -2.0 * K4 * y;
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
}

void env_irradiance(const env_sh *sh, const double n[3], double E[3], double dEdn[3][3])
{
    double y[ENV_SH_N];
    env_sh_eval(n, y);
    double g[ENV_SH_N][3];
    if (dEdn)
        sh_grad(n, g);
    for (int c = 0; c < 3; c++) {
        double e = 0.0;
        for (int k = 0; k < ENV_SH_N; k++)
            e += conv_a[k] * sh->L[c][k] * y[k];
        E[c] = e > 0.0 ? e : 0.0;
        if (!dEdn)
            continue;
        dEdn[c][0] = dEdn[c][1] = dEdn[c][2] = 0.0;
        if (!(e > 0.0))
            continue;
        for (int k = 1; k < ENV_SH_N; k++) {
            double a = conv_a[k] * sh->L[c][k];
            dEdn[c][0] += a * g[k][0];
            dEdn[c][1] += a * g[k][1];
            dEdn[c][2] += a * g[k][2];
        }
    }
}

void env_irradiance_backward_L(const double n[3], const double E[3], const double gE[3],
                               double gL[3][ENV_SH_N])
{
    double y[ENV_SH_N];
    env_sh_eval(n, y);
    for (int c = 0; c < 3; c++) {
        if (!(E[c] > 0.0) || gE[c] == 0.0)
            continue;
        for (int k = 0; k < ENV_SH_N; k++)
            gL[c][k] += gE[c] * conv_a[k] * y[k];
    }
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
