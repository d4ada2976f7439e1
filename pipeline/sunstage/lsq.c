/* SPDX-License-Identifier: MIT */
/* Small dense solves for the fitter (normal equations) and the display transform it inverts. */
#include "pipeline/sunstage/sunstage_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

int ss_cholesky_solve(double *A, double *b, int n)
{
    for (int j = 0; j < n; j++) {
        double d = A[j * n + j];
        for (int k = 0; k < j; k++)
            d -= A[j * n + k] * A[j * n + k];
        if (!(d > 1e-300) || !isfinite(d))
            return -EDOM;
        d = sqrt(d);
        A[j * n + j] = d;
        for (int i = j + 1; i < n; i++) {
            double s = A[i * n + j];
            for (int k = 0; k < j; k++)
                s -= A[i * n + k] * A[j * n + k];
            A[i * n + j] = s / d;
        }
    }
    for (int i = 0; i < n; i++) { /* L y = b */
        double s = b[i];
        for (int k = 0; k < i; k++)
            s -= A[i * n + k] * b[k];
        b[i] = s / A[i * n + i];
    }
    for (int i = n - 1; i >= 0; i--) { /* L^T x = y */
        double s = b[i];
        for (int k = i + 1; k < n; k++)
            s -= A[k * n + i] * b[k];
        b[i] = s / A[i * n + i];
    }
    return 0;
}

/* Solves the normal equations restricted to the free set; others stay 0. */
static int solve_free(const double *A, const double *b, int n, const uint8_t *fixed, double *x, double *work)
{
    int m = 0;
    int map[64];
    for (int i = 0; i < n; i++)
        if (!fixed[i])
            map[m++] = i;
    double *Ar = work, *br = work + (size_t)m * (size_t)m;
    double tr = 0.0;
    for (int i = 0; i < m; i++)
        tr += A[map[i] * n + map[i]];
    double ridge = 1e-10 * (tr > 0.0 ? tr / (m > 0 ? m : 1) : 1.0) + 1e-300;
    for (int i = 0; i < m; i++) {
        for (int j = 0; j < m; j++)
            Ar[i * m + j] = A[map[i] * n + map[j]];
        Ar[i * m + i] += ridge;
        br[i] = b[map[i]];
    }
    int ret = ss_cholesky_solve(Ar, br, m);
    for (int i = 0; i < n; i++)
        x[i] = 0.0;
    if (ret)
        return ret;
    for (int i = 0; i < m; i++)
        x[map[i]] = br[i];
    return 0;
}

int ss_nnls(const double *A, const double *b, int n, double *x)
{
    if (n <= 0 || n > 64)
        return -EINVAL;
    uint8_t fixed[64] = { 0 };
    double *work = malloc(sizeof(double) * (size_t)(n * n + n));
    if (!work)
        return -ENOMEM;
    int ret = 0;
    for (int pass = 0; pass <= n; pass++) {
        ret = solve_free(A, b, n, fixed, x, work);
        if (ret)
            break;
        int changed = 0;
        for (int i = 0; i < n; i++)
            if (!fixed[i] && x[i] < 0.0) {
                fixed[i] = 1;
                x[i] = 0.0;
                changed = 1;
            }
        if (!changed)
            break;
    }
    free(work);
    return ret;
}

/* Substitutes x_s = k x_0 into the normal equations (A, b): the congruence, then s's row and column cleared. */
static void tie_to_first(double *A, double *b, int n, int s, double k)
{
    double diag = A[s * n + s] > 0.0 ? A[s * n + s] : 1.0; /* kept for s's own row: the ridge scales with the trace */
    for (int j = 0; j < n; j++)
        A[j] += k * A[s * n + j];
    for (int i = 0; i < n; i++)
        A[i * n] += k * A[i * n + s];
    b[0] += k * b[s];
    for (int j = 0; j < n; j++)
        A[s * n + j] = A[j * n + s] = 0.0;
    A[s * n + s] = diag;
    b[s] = 0.0;
}

int ss_nnls_capped(double *A, double *b, int n, int first, int count, double cap, double *x)
{
    if (n <= 0 || n > 64 || first < 1 || count < 0 || first + count > n || !(cap >= 0.0))
        return -EINVAL;
    uint8_t tied[64] = { 0 };
    int more = 1, ret = 0;
    while (more && !(ret = ss_nnls(A, b, n, x))) {
        more = 0;
        for (int s = first; s < first + count; s++)
            if (!tied[s] && x[s] > cap * x[0]) {
                tie_to_first(A, b, n, s, cap);
                tied[s] = more = 1;
            }
    }
    for (int s = first; !ret && s < first + count; s++)
        if (tied[s])
            x[s] = cap * x[0];
    return ret;
}

#define GAMMA 2.2
#define TOE 1e-6

double ss_tonemap(double x)
{
    if (!(x > 0.0))
        return 0.0;
    double y = x / (1.0 + x);
    return y >= TOE ? pow(y, 1.0 / GAMMA) : y * pow(TOE, 1.0 / GAMMA - 1.0);
}

/* Inverse of ss_tonemap for g in [0, 0.995]; *dg_dx gets the forward slope at the result. */
double ss_tonemap_inverse(double g, double *dg_dx)
{
    double gc = g < 0.0 ? 0.0 : (g > 0.995 ? 0.995 : g);
    double toe_g = pow(TOE, 1.0 / GAMMA);
    double y = gc >= toe_g ? pow(gc, GAMMA) : gc / pow(TOE, 1.0 / GAMMA - 1.0);
    double x = y / (1.0 - y);
    if (dg_dx) {
        double dy_dx = 1.0 / ((1.0 + x) * (1.0 + x));
        double dg_dy = y >= TOE && y > 0.0 ? gc / (GAMMA * y) : pow(TOE, 1.0 / GAMMA - 1.0);
        *dg_dx = dg_dy * dy_dx;
    }
    return x;
}
