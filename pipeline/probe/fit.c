/* SPDX-License-Identifier: MIT */
/*
 * Bounded sampling and robust fits for the probe. The scale model (eq. 3.7)
 * h = a x + b y + c is fitted to person observations by RANSAC on relative
 * residuals |h - fit| / h (minimal samples, deterministic seed), refined by
 * IRLS with Tukey's biweight (scale from the MAD). The positions are checked
 * first: people seen at one place or along one line constrain only part of
 * the model, and the fit says which instead of inventing the rest.
 */
#include "probe_internal.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

uint64_t probe_rand(uint64_t *state)
{
    uint64_t x = *state ? *state : 0x9E3779B97F4A7C15ull;
    x ^= x >> 12;
    x ^= x << 25;
    x ^= x >> 27;
    *state = x;
    return x * 0x2545F4914F6CDD1Dull;
}

int reservoir_open(probe_reservoir *r, unsigned cap, unsigned stride, uint64_t seed)
{
    memset(r, 0, sizeof(*r));
    if (!cap || !stride)
        return -EINVAL;
    r->v = malloc((size_t)cap * stride * sizeof(float));
    if (!r->v)
        return -ENOMEM;
    r->cap = cap;
    r->stride = stride;
    r->rng = seed * 0x9E3779B97F4A7C15ull + 1;
    return 0;
}

void reservoir_close(probe_reservoir *r)
{
    free(r->v);
    memset(r, 0, sizeof(*r));
}

/* Algorithm R: every record seen so far is kept with the same probability cap / seen. */
void reservoir_add(probe_reservoir *r, const float *rec)
{
    r->seen++;
    size_t slot;
    if (r->n < r->cap) {
        slot = r->n++;
    } else {
        slot = (size_t)(probe_rand(&r->rng) % r->seen);
        if (slot >= r->cap)
            return;
    }
    memcpy(r->v + slot * r->stride, rec, r->stride * sizeof(float));
}

/* Gaussian elimination with partial pivoting on a p x p system (p <= 3); -1 when singular. */
static int solve_small(unsigned p, const double *A_in, const double *b_in, double *x)
{
    double A[9], b[3], scale = 0;
    memcpy(A, A_in, p * p * sizeof(double));
    memcpy(b, b_in, p * sizeof(double));
    for (unsigned i = 0; i < p * p; i++)
        scale = fabs(A[i]) > scale ? fabs(A[i]) : scale;
    if (!(scale > 0) || !isfinite(scale))
        return -1;
    for (unsigned col = 0; col < p; col++) {
        unsigned piv = col;
        for (unsigned r = col + 1; r < p; r++)
            if (fabs(A[r * p + col]) > fabs(A[piv * p + col]))
                piv = r;
        if (fabs(A[piv * p + col]) <= 1e-12 * scale)
            return -1;
        for (unsigned c = 0; c < p; c++) {
            double t = A[col * p + c];
            A[col * p + c] = A[piv * p + c];
            A[piv * p + c] = t;
        }
        double t = b[col];
        b[col] = b[piv];
        b[piv] = t;
        for (unsigned r = col + 1; r < p; r++) {
            double f = A[r * p + col] / A[col * p + col];
            for (unsigned c = col; c < p; c++)
                A[r * p + c] -= f * A[col * p + c];
            b[r] -= f * b[col];
        }
    }
    for (unsigned r = p; r-- > 0;) {
        double s = b[r];
        for (unsigned c = r + 1; c < p; c++)
            s -= A[r * p + c] * x[c];
        x[r] = s / A[r * p + r];
        if (!isfinite(x[r]))
            return -1;
    }
    return 0;
}

int probe_solve3(const double A[9], const double b[3], double x[3])
{
    return solve_small(3, A, b, x);
}

/* Median of values in [0, inf) to 1/2000 resolution from a fixed histogram (no allocation). */
#define MED_BINS 2001
typedef struct med_hist {
    uint32_t bin[MED_BINS];
    uint32_t n;
} med_hist;

static void med_add(med_hist *m, double v)
{
    if (!(v >= 0))
        return;
    double b = v * (MED_BINS - 1);
    m->bin[b < MED_BINS - 1 ? (size_t)b : MED_BINS - 1]++;
    m->n++;
}

static double med_value(const med_hist *m)
{
    if (!m->n)
        return (double)NAN;
    uint64_t half = (m->n + 1) / 2, acc = 0;
    for (size_t i = 0; i < MED_BINS; i++) {
        acc += m->bin[i];
        if (acc >= half)
            return ((double)i + 0.5) / (MED_BINS - 1);
    }
    return 1.0;
}

/* The model being fitted: which regressors, in normalised coordinates. */
typedef struct fit_ctx {
    const float *rec;
    unsigned n, stride, p;   /* p = 1 (constant), 2 (along a line), 3 (plane) */
    double sx, sy;           /* normalisation: u = x * sx, v = y * sy */
    double mx, my, dx, dy;   /* p = 2: t = ((x - mx) dx + (y - my) dy) * sx */
} fit_ctx;

static void design(const fit_ctx *f, unsigned i, double phi[3])
{
    const float *r = f->rec + (size_t)i * f->stride;
    if (f->p == 3) {
        phi[0] = (double)r[0] * f->sx, phi[1] = (double)r[1] * f->sy, phi[2] = 1;
    } else if (f->p == 2) {
        phi[0] = (((double)r[0] - f->mx) * f->dx + ((double)r[1] - f->my) * f->dy) * f->sx, phi[1] = 1;
    } else {
        phi[0] = 1;
    }
}

static double rel_residual(const fit_ctx *f, unsigned i, const double *beta)
{
    double phi[3], pred = 0, h = (double)f->rec[(size_t)i * f->stride + 2];
    design(f, i, phi);
    for (unsigned k = 0; k < f->p; k++)
        pred += phi[k] * beta[k];
    return h > 0 ? (h - pred) / h : (double)INFINITY;
}

/* Weighted least squares on relative residuals: minimises sum w_i ((h_i - phi_i beta) / h_i)^2. */
static int weighted_solve(const fit_ctx *f, const double *w, double *beta)
{
    double A[9] = { 0 }, b[3] = { 0 };
    for (unsigned i = 0; i < f->n; i++) {
        double h = (double)f->rec[(size_t)i * f->stride + 2], phi[3];
        if (!(h > 0) || !(w[i] > 0))
            continue;
        double wi = w[i] / (h * h);
        design(f, i, phi);
        for (unsigned r = 0; r < f->p; r++) {
            for (unsigned c = 0; c < f->p; c++)
                A[r * f->p + c] += wi * phi[r] * phi[c];
            b[r] += wi * phi[r] * h;
        }
    }
    return solve_small(f->p, A, b, beta);
}

#define RANSAC_ITERS 256
#define RANSAC_TOL 0.08 /* relative: people differ in height by about this much */

static int ransac(const fit_ctx *f, uint64_t *rng, double *best)
{
    unsigned best_count = 0;
    for (unsigned it = 0; it < RANSAC_ITERS; it++) {
        double A[9], b[3], beta[3], phi[3];
        unsigned idx[3];
        for (unsigned k = 0; k < f->p; k++) {
            idx[k] = (unsigned)(probe_rand(rng) % f->n);
            design(f, idx[k], phi);
            memcpy(A + k * f->p, phi, f->p * sizeof(double));
            b[k] = (double)f->rec[(size_t)idx[k] * f->stride + 2];
        }
        if (solve_small(f->p, A, b, beta))
            continue; /* repeated or collinear sample */
        unsigned count = 0;
        for (unsigned i = 0; i < f->n; i++)
            count += fabs(rel_residual(f, i, beta)) < RANSAC_TOL;
        if (count > best_count) {
            best_count = count;
            memcpy(best, beta, f->p * sizeof(double));
        }
    }
    return best_count >= f->p ? 0 : -1;
}

/* Tukey IRLS from beta; the scale is 1.4826 MAD of the relative residuals (at least 1%). */
static int irls(const fit_ctx *f, double *beta, double *w, double *scale_out)
{
    double scale = 0.01;
    for (int it = 0; it < 12; it++) {
        med_hist *mh = calloc(1, sizeof(*mh));
        if (!mh)
            return -ENOMEM;
        for (unsigned i = 0; i < f->n; i++)
            med_add(mh, fabs(rel_residual(f, i, beta)));
        double mad = med_value(mh);
        free(mh);
        scale = 1.4826 * mad > 0.01 ? 1.4826 * mad : 0.01;
        double c = 4.685 * scale;
        for (unsigned i = 0; i < f->n; i++) {
            double u = rel_residual(f, i, beta) / c;
            w[i] = fabs(u) < 1 ? (1 - u * u) * (1 - u * u) : 0;
        }
        double next[3];
        if (weighted_solve(f, w, next))
            return -1;
        double change = 0;
        for (unsigned k = 0; k < f->p; k++)
            change += fabs(next[k] - beta[k]);
        memcpy(beta, next, f->p * sizeof(double));
        if (change < 1e-9)
            break;
    }
    *scale_out = scale;
    return 0;
}

/* Position spread in normalised coordinates: mean, principal direction, sqrt of the eigenvalues. */
static void spread(const fit_ctx *f, double *mx, double *my, double *dx, double *dy, double *s1, double *s2)
{
    double sx = 0, sy = 0, cxx = 0, cxy = 0, cyy = 0;
    for (unsigned i = 0; i < f->n; i++)
        sx += (double)f->rec[(size_t)i * f->stride], sy += (double)f->rec[(size_t)i * f->stride + 1];
    *mx = sx / f->n, *my = sy / f->n;
    for (unsigned i = 0; i < f->n; i++) {
        const float *r = f->rec + (size_t)i * f->stride;
        double u = ((double)r[0] - *mx) * f->sx, v = ((double)r[1] - *my) * f->sy;
        cxx += u * u, cxy += u * v, cyy += v * v;
    }
    cxx /= f->n, cxy /= f->n, cyy /= f->n;
    double tr = cxx + cyy, det = cxx * cyy - cxy * cxy, disc = sqrt(fmax(tr * tr / 4 - det, 0));
    double l1 = tr / 2 + disc, l2 = fmax(tr / 2 - disc, 0);
    *s1 = sqrt(fmax(l1, 0)), *s2 = sqrt(l2);
    /* eigenvector of l1 in pixel units (the normalisation is isotropic per axis) */
    double ex = cxy, ey = l1 - cxx;
    if (fabs(ex) + fabs(ey) < 1e-15)
        ex = cxx >= cyy ? 1 : 0, ey = cxx >= cyy ? 0 : 1;
    double ux = ex / f->sx, uy = ey / f->sy, len = hypot(ux, uy);
    *dx = len > 0 ? ux / len : 1, *dy = len > 0 ? uy / len : 0;
}

#define MIN_SPREAD 0.01 /* of the image size: closer than this counts as one place or one line */

static void finish_stats(const fit_ctx *f, const double *beta, double scale, sp_probe_plane *out)
{
    med_hist *mh = calloc(1, sizeof(*mh));
    unsigned inl = 0;
    for (unsigned i = 0; i < f->n; i++) {
        double r = fabs(rel_residual(f, i, beta));
        if (r < 4.685 * scale) {
            inl++;
            if (mh)
                med_add(mh, r);
        }
    }
    out->n_inliers = inl;
    out->residual_rel = mh ? med_value(mh) : (double)NAN;
    free(mh);
}

static int robust(fit_ctx *f, uint64_t *rng, double *beta, double *scale)
{
    double *w = malloc(f->n * sizeof(double));
    if (!w)
        return -ENOMEM;
    int ret = ransac(f, rng, beta);
    if (ret) { /* every sample degenerate: start from plain least squares */
        for (unsigned i = 0; i < f->n; i++)
            w[i] = 1;
        ret = weighted_solve(f, w, beta);
    }
    if (!ret)
        ret = irls(f, beta, w, scale);
    free(w);
    return ret;
}

void plane_fit(const float *rec, unsigned n, unsigned stride, uint32_t width, uint32_t height, uint64_t *rng,
               sp_probe_plane *out)
{
    unsigned holdout_n = out->holdout_n;
    double holdout_err = out->holdout_error_rel;
    memset(out, 0, sizeof(*out));
    out->holdout_n = holdout_n, out->holdout_error_rel = holdout_err;
    out->n_observations = n;
    out->residual_rel = (double)NAN;
    if (n == 0) {
        out->status = SP_PROBE_PLANE_NONE;
        snprintf(out->note, sizeof(out->note), "no person was observed: the scale cannot be estimated");
        return;
    }
    fit_ctx f = { rec, n, stride, 3, 1.0 / width, 1.0 / height, 0, 0, 1, 0 };
    double s1, s2, beta[3] = { 0, 0, 0 }, scale = 0.01;
    spread(&f, &f.mx, &f.my, &f.dx, &f.dy, &s1, &s2);
    out->line_x = f.mx, out->line_y = f.my, out->line_dx = f.dx, out->line_dy = f.dy;
    f.p = n < 3 || s1 < MIN_SPREAD ? 1 : s2 < MIN_SPREAD ? 2 : 3;
    if (robust(&f, rng, beta, &scale)) {
        out->status = SP_PROBE_PLANE_NONE;
        snprintf(out->note, sizeof(out->note), "the robust fit failed on %u observations", n);
        return;
    }
    finish_stats(&f, beta, scale, out);
    if (f.p == 3) {
        out->status = SP_PROBE_PLANE_OK;
        out->a = beta[0] * f.sx, out->b = beta[1] * f.sy, out->c = beta[2];
        snprintf(out->note, sizeof(out->note), "fitted on %u observations (%u inliers), median relative residual %.3f",
                 n, out->n_inliers, out->residual_rel);
    } else if (f.p == 2) {
        out->status = SP_PROBE_PLANE_LINE;
        double s = beta[0] * f.sx;
        out->a = s * f.dx, out->b = s * f.dy, out->c = beta[1] - s * (f.mx * f.dx + f.my * f.dy);
        out->line_tol = fmax(8.0, 3.0 * s2 * fmax(width, height));
        snprintf(out->note, sizeof(out->note),
                 "people were seen only along the line through (%.0f, %.0f) with direction (%.2f, %.2f): "
                 "the height change across it cannot be estimated", f.mx, f.my, f.dx, f.dy);
    } else {
        out->status = SP_PROBE_PLANE_ONE_POINT;
        out->c = beta[0];
        out->line_dx = out->line_dy = 0;
        out->line_tol = fmax(8.0, 3.0 * s1 * fmax(width, height));
        snprintf(out->note, sizeof(out->note),
                 "people were seen only near (%.0f, %.0f) (%u observations): the height is known there, "
                 "its change with position cannot be estimated", f.mx, f.my, n);
    }
}

double sp_probe_plane_height(const sp_probe_plane *pl, double x, double y)
{
    if (!pl || !isfinite(x) || !isfinite(y))
        return (double)NAN;
    double h = pl->a * x + pl->b * y + pl->c;
    switch (pl->status) {
    case SP_PROBE_PLANE_OK:
        break;
    case SP_PROBE_PLANE_LINE: {
        /* distance from the line: the model says nothing across it */
        double d = fabs((x - pl->line_x) * pl->line_dy - (y - pl->line_y) * pl->line_dx);
        if (d > pl->line_tol)
            return (double)NAN;
        break;
    }
    case SP_PROBE_PLANE_ONE_POINT:
        if (hypot(x - pl->line_x, y - pl->line_y) > pl->line_tol)
            return (double)NAN;
        break;
    default:
        return (double)NAN;
    }
    return isfinite(h) && h > 0 ? h : (double)NAN;
}

double plane_median_error(const sp_probe_plane *pl, const float *rec, unsigned n, unsigned stride)
{
    med_hist *mh = calloc(1, sizeof(*mh));
    if (!mh)
        return (double)NAN;
    for (unsigned i = 0; i < n; i++) {
        const float *r = rec + (size_t)i * stride;
        double pred = sp_probe_plane_height(pl, r[0], r[1]);
        if (isfinite(pred) && r[2] > 0.0f)
            med_add(mh, fabs((double)r[2] - pred) / (double)r[2]);
    }
    double m = med_value(mh);
    free(mh);
    return m;
}
