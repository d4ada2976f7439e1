/* SPDX-License-Identifier: MIT */
/*
 * Stage 1, coarse alignment: Levenberg-Marquardt (damped Gauss-Newton) on the
 * 68 projected landmarks of every keyframe with Huber weights (a smooth stand-in
 * for the thesis' L1), shared identity and scale, per-frame expression, rotation
 * and translation of the face in the camera frame. Priors keep identity near the
 * mean (unit Gaussian), expressions in [0, 1] and small, and the scale near 1.
 */
#include "pipeline/sunstage/landmarks.h"
#include "pipeline/sunstage/sunstage_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/clock.h"

/*
 * "px" below is a reference pixel: a pixel of the frame scaled to REF_WIDTH wide (the default fit width),
 * whatever the fit resolution or crop. Image residuals are converted to it (frame_unit), so the balance of
 * data, robust thresholds and priors does not move with the resolution: measured in fit pixels, a 256 px
 * fit weighed the priors 4x less and fitted a smaller head than the same capture at 128 px.
 */
#define REF_WIDTH 128.0
#define HUBER_PX 1.0
#define W_JAW 0.5     /* jaw contour landmarks slide along the silhouette: trust them less */
#define W_BROW 0.25   /* brows mark where the hair grows, which is the person's, not the skull's (SUNSTAGE.md) */
#define W_ID 1.0      /* px^2 per unit identity coefficient squared */
#define W_EXP 4.0
#define W_SCALE 400.0 /* (s - 1)^2 weight: a 5 % scale change costs 1 px^2 */

typedef struct align_ctx {
    sp_sunstage *ss;
    const int *idx;
    int n, shared, n_id, n_exp, ns, np, P;
    double *uv, *jac, *JtJ, *Jtr, *save;
    ss_frame *one; /* a frame outside the reservoir (n = 1), or NULL */
    double w_jaw;  /* trust in the jaw contour's points (W_JAW; 0 leaves them out) */
    int use_sil, sil_cap;
    uint32_t *sil_idx; /* n * sil_cap outline vertices, chosen at each Jacobian evaluation */
    int *sil_n;
    double *sil_r, *sil_jac, *sil_work;
} align_ctx;

static ss_frame *frame_at(const align_ctx *a, int fi)
{
    return a->one ? a->one : &a->ss->res.slots[a->idx[fi]];
}

/* Reference pixels per fit pixel of frame f: exactly 1 for a whole-frame fit REF_WIDTH wide. */
static double frame_unit(const sp_sunstage *ss, const ss_frame *f)
{
    if (ss->set.face_crop && ss->fe.cap_w > 0 && f->win.s > 0.0) /* the crop's pixels across the whole frame */
        return REF_WIDTH / ((double)ss->fe.cap_w * f->win.s);
    return REF_WIDTH / (double)ss->W;
}

/* How much landmark k (the 68-point scheme: jaw 0-16, brows 17-26) is trusted against the others. */
static double lm_trust(const align_ctx *a, int k)
{
    return k <= 16 ? a->w_jaw : k <= 26 ? W_BROW : 1.0;
}

/* Landmark weight for the point residual (du, dv): Huber on its length times the point's trust. */
static double lm_weight(const align_ctx *a, int k, double du, double dv)
{
    double r = hypot(du, dv);
    return lm_trust(a, k) * (r > HUBER_PX ? HUBER_PX / r : 1.0);
}

static double huber_cost(double r)
{
    return r > HUBER_PX ? HUBER_PX * (2.0 * r - HUBER_PX) : r * r;
}

/* Silhouette residuals of frame fi (outline re-chosen when with_jac), added to cost and normal equations. */
static double silhouette_term(align_ctx *a, int fi, ss_frame *f, const sp_face_params *p, const int *col,
                              int with_jac)
{
    const sp_face_model *m = a->ss->model;
    /* px^2 per outline vertex, in reference pixels; finer rows give more outline vertices, each weighs less */
    const double u = frame_unit(a->ss, f), W_SIL = a->ss->set.silhouette_weight * u;
    if (!a->use_sil || !f->sil_ok || !f->sil || !(W_SIL > 0.0))
        return 0.0;
    uint32_t *idx = a->sil_idx + (size_t)fi * (size_t)a->sil_cap;
    if (with_jac)
        a->sil_n[fi] = ss_silhouette_vertices(m, a->ss->scalp, p, &f->cam, a->ss->W, a->ss->H, idx, a->sil_cap,
                                              a->sil_work);
    int n = a->sil_n[fi];
    if (n <= 0 || ss_silhouette_residuals(m, p, &f->cam, idx, n, f->sil, a->ss->W, a->ss->H, a->sil_r,
                                          with_jac ? a->sil_jac : NULL))
        return 0.0;
    uint32_t nc = sp_face_model_n_params(m);
    double cost = 0.0;
    for (int j = 0; j < n; j++) {
        double r = u * a->sil_r[j], rc = r < SS_SIL_MAX ? r : SS_SIL_MAX;
        cost += W_SIL * (rc > SS_SIL_HUBER ? SS_SIL_HUBER * (2.0 * rc - SS_SIL_HUBER) : rc * rc);
        if (!with_jac || r >= SS_SIL_MAX)
            continue; /* truncated: an outlier has no pull */
        double w = W_SIL * (r > SS_SIL_HUBER ? SS_SIL_HUBER / r : 1.0);
        double wr = w * u, wj = w * u * u; /* the Jacobian is per fit pixel: u J per reference pixel */
        const double *J = a->sil_jac + (size_t)j * nc;
        for (uint32_t i = 0; i < nc; i++) {
            if (col[i] < 0 || J[i] == 0.0)
                continue;
            a->Jtr[col[i]] += wr * J[i] * r;
            for (uint32_t k = 0; k < nc; k++)
                if (col[k] >= 0)
                    a->JtJ[(size_t)col[i] * (size_t)a->P + (size_t)col[k]] += wj * J[i] * J[k];
        }
    }
    return cost;
}

/* Robust cost of every frame plus priors; jac != NULL also accumulates the normal equations. */
static double evaluate(align_ctx *a, int with_jac)
{
    sp_sunstage *ss = a->ss;
    const sp_face_model *m = ss->model;
    double cost = 0.0;
    uint32_t nc = sp_face_model_n_params(m);
    if (with_jac) {
        memset(a->JtJ, 0, sizeof(double) * (size_t)a->P * (size_t)a->P);
        memset(a->Jtr, 0, sizeof(double) * (size_t)a->P);
    }
    int *col = malloc(sizeof(int) * nc);
    if (!col)
        return NAN;
    for (int fi = 0; fi < a->n; fi++) {
        ss_frame *f = frame_at(a, fi);
        sp_face_params p;
        ss_frame_params(a->ss, f, &p);
        if (sp_face_model_project_landmarks(m, &p, &f->cam, a->uv, NULL, with_jac ? a->jac : NULL) < 0) {
            free(col);
            return NAN;
        }
        int base = a->ns + fi * a->np;
        for (uint32_t j = 0; j < nc; j++) { /* Jacobian column -> parameter index, -1 = fixed */
            int jj = (int)j;
            if (jj < a->n_id)
                col[j] = a->shared ? jj : -1;
            else if (jj < a->n_id + a->n_exp + 6)
                col[j] = base + (jj - a->n_id);
            else
                col[j] = a->shared ? a->n_id : -1;
        }
        const double u = frame_unit(ss, f);
        for (int k = 0; k < 68; k++) {
            double du = u * (a->uv[2 * k] - f->lm[2 * k]), dv = u * (a->uv[2 * k + 1] - f->lm[2 * k + 1]);
            double w = lm_weight(a, k, du, dv), wr = w * u, wj = w * u * u; /* the Jacobian is per fit pixel */
            cost += lm_trust(a, k) * huber_cost(hypot(du, dv));
            if (!with_jac)
                continue;
            for (int c = 0; c < 2; c++) {
                const double *J = a->jac + (size_t)(2 * k + c) * nc;
                double r = c ? dv : du;
                for (uint32_t i = 0; i < nc; i++) {
                    if (col[i] < 0 || J[i] == 0.0)
                        continue;
                    a->Jtr[col[i]] += wr * J[i] * r;
                    for (uint32_t j = 0; j < nc; j++)
                        if (col[j] >= 0)
                            a->JtJ[(size_t)col[i] * (size_t)a->P + (size_t)col[j]] += wj * J[i] * J[j];
                }
            }
        }
        cost += silhouette_term(a, fi, f, &p, col, with_jac);
        for (int e = 0; e < a->n_exp; e++) {
            cost += W_EXP * f->exp[e] * f->exp[e];
            if (with_jac) {
                a->JtJ[(size_t)(base + e) * (size_t)a->P + (size_t)(base + e)] += W_EXP;
                a->Jtr[base + e] += W_EXP * f->exp[e];
            }
        }
    }
    free(col);
    if (a->shared) {
        for (int i = 0; i < a->n_id; i++) {
            cost += W_ID * ss->fit.id[i] * ss->fit.id[i];
            if (with_jac) {
                a->JtJ[(size_t)i * (size_t)a->P + (size_t)i] += W_ID;
                a->Jtr[i] += W_ID * ss->fit.id[i];
            }
        }
        cost += W_SCALE * (ss->fit.scale - 1.0) * (ss->fit.scale - 1.0);
        if (with_jac) {
            a->JtJ[(size_t)a->n_id * (size_t)a->P + (size_t)a->n_id] += W_SCALE;
            a->Jtr[a->n_id] += W_SCALE * (ss->fit.scale - 1.0);
        }
    }
    return cost;
}

/* Reads (dir = 0) or writes (dir = 1) the parameter vector x. */
static void params_io(align_ctx *a, double *x, int dir)
{
    sp_sunstage *ss = a->ss;
    if (a->shared)
        for (int i = 0; i <= a->n_id; i++) {
            double *v = i < a->n_id ? &ss->fit.id[i] : &ss->fit.scale;
            if (dir)
                *v = x[i];
            else
                x[i] = *v;
        }
    for (int fi = 0; fi < a->n; fi++) {
        ss_frame *f = frame_at(a, fi);
        double *b = x + a->ns + fi * a->np;
        for (int e = 0; e < a->np; e++) {
            double *v = e < a->n_exp ? &f->exp[e] : (e < a->n_exp + 3 ? &f->rotvec[e - a->n_exp] : &f->t_face[e - a->n_exp - 3]);
            if (dir)
                *v = b[e];
            else
                b[e] = *v;
        }
    }
}

/* Frontal start: face turned towards the camera (180 deg about x), depth from the landmark spread. */
static void init_frame(align_ctx *a, ss_frame *f)
{
    const sp_face_model *m = a->ss->model;
    double mu[2] = { 0, 0 }, mm[2] = { 0, 0 }, ru = 0.0, rm = 0.0;
    for (int k = 0; k < 68; k++) {
        const float *v = m->mesh.positions + (size_t)m->landmarks[k] * 3;
        mu[0] += f->lm[2 * k] / 68.0;
        mu[1] += f->lm[2 * k + 1] / 68.0;
        mm[0] += (double)v[0] / 68.0;
        mm[1] += (double)v[1] / 68.0;
    }
    for (int k = 0; k < 68; k++) {
        const float *v = m->mesh.positions + (size_t)m->landmarks[k] * 3;
        ru += hypot(f->lm[2 * k] - mu[0], f->lm[2 * k + 1] - mu[1]);
        rm += hypot((double)v[0] - mm[0], (double)v[1] - mm[1]);
    }
    double z = ru > 1e-6 ? f->cam.fx * rm / ru : 0.5;
    z = z < 0.05 ? 0.05 : (z > 20.0 ? 20.0 : z);
    f->rotvec[0] = M_PI;
    f->rotvec[1] = f->rotvec[2] = 0.0;
    /* model (x, y) maps to camera (x, -y) under the flip */
    f->t_face[0] = (mu[0] - f->cam.cx) * z / f->cam.fx - mm[0];
    f->t_face[1] = (mu[1] - f->cam.cy) * z / f->cam.fy + mm[1];
    f->t_face[2] = z;
}

static void clamp_params(align_ctx *a)
{
    sp_sunstage *ss = a->ss;
    ss->fit.scale = ss->fit.scale < 0.7 ? 0.7 : (ss->fit.scale > 1.4 ? 1.4 : ss->fit.scale);
    for (int fi = 0; fi < a->n; fi++) {
        ss_frame *f = frame_at(a, fi);
        for (int e = 0; e < a->n_exp; e++)
            f->exp[e] = f->exp[e] < 0.0 ? 0.0 : (f->exp[e] > 1.0 ? 1.0 : f->exp[e]);
        f->t_face[2] = f->t_face[2] < 0.05 ? 0.05 : f->t_face[2];
    }
}

static int lm_iterate(align_ctx *a, int iterations, double *cost_out)
{
    double mu = 1e-3, cost = evaluate(a, 0);
    double *A = malloc(sizeof(double) * (size_t)a->P * ((size_t)a->P + 2));
    if (!A)
        return -ENOMEM;
    double *b = A + (size_t)a->P * (size_t)a->P, *x0 = b + a->P;
    for (int it = 0; it < iterations && isfinite(cost); it++) {
        double jc = evaluate(a, 1); /* the silhouette outline is re-chosen here: its cost is the reference */
        if (!isfinite(jc))
            break;
        cost = jc;
        params_io(a, x0, 0);
        int accepted = 0;
        for (int tries = 0; tries < 8 && !accepted; tries++) {
            memcpy(A, a->JtJ, sizeof(double) * (size_t)a->P * (size_t)a->P);
            for (int i = 0; i < a->P; i++) {
                A[(size_t)i * (size_t)a->P + (size_t)i] *= 1.0 + mu;
                A[(size_t)i * (size_t)a->P + (size_t)i] += 1e-9;
                b[i] = -a->Jtr[i];
            }
            if (ss_cholesky_solve(A, b, a->P) == 0) {
                for (int i = 0; i < a->P; i++)
                    a->save[i] = x0[i] + b[i];
                params_io(a, a->save, 1);
                clamp_params(a);
                double c = evaluate(a, 0);
                if (isfinite(c) && c < cost) {
                    accepted = 1;
                    mu = fmax(mu * 0.3, 1e-7);
                    double gain = cost - c;
                    cost = c;
                    if (gain < 1e-6 * cost)
                        it = iterations;
                    break;
                }
            }
            params_io(a, x0, 1);
            mu *= 10.0;
        }
        if (!accepted)
            break;
    }
    free(A);
    *cost_out = cost;
    return 0;
}

/* Buffers of the silhouette term; 1 when some frame has a skin-mask boundary and memory was found. */
static int sil_alloc(align_ctx *a)
{
    const sp_face_model *m = a->ss->model;
    int any = 0;
    for (int fi = 0; fi < a->n; fi++)
        any |= frame_at(a, fi)->sil_ok;
    if (!any)
        return 0;
    a->sil_cap = SS_SIL_CAP(a->ss->W, a->ss->H);
    a->sil_idx = malloc(sizeof(uint32_t) * (size_t)a->sil_cap * (size_t)a->n);
    a->sil_n = calloc((size_t)a->n, sizeof(int));
    a->sil_r = malloc(sizeof(double) * (size_t)a->sil_cap);
    a->sil_jac = malloc(sizeof(double) * (size_t)a->sil_cap * sp_face_model_n_params(m));
    a->sil_work = malloc(sizeof(double) * 6 * m->mesh.n_vertices);
    return a->sil_idx && a->sil_n && a->sil_r && a->sil_jac && a->sil_work;
}

static double align(sp_sunstage *ss, const int *idx, ss_frame *one, int n, int shared, int iterations, double w_jaw)
{
    align_ctx a = { .ss = ss, .idx = idx, .n = n, .shared = shared, .one = one, .w_jaw = w_jaw };
    const sp_face_model *m = ss->model;
    a.n_id = (int)m->n_id;
    a.n_exp = (int)m->n_exp;
    a.ns = shared ? a.n_id + 1 : 0;
    a.np = a.n_exp + 6;
    a.P = a.ns + n * a.np;
    size_t nc = sp_face_model_n_params(m);
    a.uv = malloc(sizeof(double) * 136);
    a.jac = malloc(sizeof(double) * 136 * nc);
    a.JtJ = malloc(sizeof(double) * (size_t)a.P * (size_t)a.P);
    a.Jtr = malloc(sizeof(double) * (size_t)a.P);
    a.save = malloc(sizeof(double) * (size_t)a.P);
    double rms = -ENOMEM;
    if (!a.uv || !a.jac || !a.JtJ || !a.Jtr || !a.save)
        goto done;
    for (int fi = 0; fi < n; fi++) {
        ss_frame *f = frame_at(&a, fi);
        if (f->t_face[2] == 0.0)
            init_frame(&a, f);
    }
    double cost;
    int ret = lm_iterate(&a, iterations, &cost);
    if (!ret && !one && sil_alloc(&a)) { /* landmarks first, then landmarks + silhouette from a close start */
        a.use_sil = 1;
        ret = lm_iterate(&a, iterations / 2 > 4 ? iterations / 2 : 4, &cost);
    }
    if (ret) {
        rms = ret;
        goto done;
    }
    /* plain RMS landmark error in pixels for the report */
    double se = 0.0;
    for (int fi = 0; fi < n; fi++) {
        ss_frame *f = frame_at(&a, fi);
        sp_face_params p;
        ss_frame_params(ss, f, &p);
        sp_face_model_project_landmarks(m, &p, &f->cam, a.uv, NULL, NULL);
        for (int k = 0; k < 136; k++)
            se += (a.uv[k] - f->lm[k]) * (a.uv[k] - f->lm[k]);
    }
    rms = sqrt(se / (68.0 * n));
done:
    free(a.uv);
    free(a.jac);
    free(a.JtJ);
    free(a.Jtr);
    free(a.save);
    free(a.sil_idx);
    free(a.sil_n);
    free(a.sil_r);
    free(a.sil_jac);
    free(a.sil_work);
    return rms;
}

double ss_align_landmarks(sp_sunstage *ss, const int *idx, int n, int shared, int iterations)
{
    return align(ss, idx, NULL, n, shared, iterations, W_JAW);
}

double ss_align_one(sp_sunstage *ss, ss_frame *f, int iterations)
{
    return align(ss, NULL, f, 1, 0, iterations, W_JAW);
}

/*
 * Every tracked frame, not only the keyframes: the fitted head's pose and expression from that frame's
 * landmarks (identity and scale as fitted, warm-started from the frame before), and the model's landmark
 * vertices projected back into the capture. The jaw's points are left out here: they mark the face's
 * contour, which slides over the jaw as the head turns and moves to shadow edges under a low sun, while the
 * model's jaw points are fixed vertices that the known head and the rest of the face already place
 * (SUNSTAGE.md, "Fitted landmarks"). The keyframes' own fit keeps them at W_JAW, with the silhouette.
 */
int ss_fit_logged_landmarks(sp_sunstage *ss, sp_sunstage_callback cb, void *user)
{
    const ss_frontend *fe = &ss->fe;
    free(ss->fit.lm_fitted);
    ss->fit.lm_fitted = NULL;
    if (!fe->lm_n)
        return 0;
    float *out = malloc(sizeof(float) * SS_LM_FITTED_FLOATS * fe->lm_n);
    double *exp = calloc(ss->model->n_exp + 1, sizeof(double));
    if (!out || !exp) {
        free(out);
        free(exp);
        return -ENOMEM;
    }
    ss_frame f;
    memset(&f, 0, sizeof(f));
    f.exp = exp;
    int warm = 0, fitted = 0;
    int64_t t0 = sp_clock_monotonic_ns();
    for (size_t i = 0; i < fe->lm_n; i++)
        out[SS_LM_FITTED_FLOATS * i] =
            NAN; /* RMS residual in capture pixels; NaN: no landmarks on this frame (or stopped) */
    int stop = 0;
    for (size_t i = 0; i < fe->lm_n && !stop; i++) {
        const ss_lm_entry *e = &fe->lm_log[i];
        float *o = out + SS_LM_FITTED_FLOATS * i;
        if (cb && i % 32 == 0) { /* a long capture takes a while: progress, and Ctrl-C stops here */
            sp_sunstage_progress pr = { "landmarks",   (int)i,
                                        (int)fe->lm_n, (double)(sp_clock_monotonic_ns() - ss->fit.t0) * 1e-9,
                                        NAN,           NAN };
            stop = cb(user, &pr) != 0;
        }
        if (e->source <= SS_LM_NONE || e->source > SS_LM_SEARCHED) {
            warm = 0;
            continue;
        }
        double cap[136];
        for (int k = 0; k < 136; k++)
            cap[k] = (double)e->lm[k];
        ss_window win;
        ss_window_of(ss, cap, &win);
        ss_window_landmarks(&win, cap, f.lm);
        ss_window_camera(ss, &win, &f.cam);
        f.win = win; /* frame_unit reads it in face-crop mode */
        if (!warm) { /* a fresh start (align's own) after a frame without a face */
            f.t_face[2] = 0.0;
            memset(exp, 0, sizeof(double) * ss->model->n_exp);
        }
        double rms = align(ss, NULL, &f, 1, 0, 20, 0.0);
        sp_face_params p;
        ss_frame_params(ss, &f, &p);
        double uv[136];
        if (rms < 0.0 || sp_face_model_project_landmarks(ss->model, &p, &f.cam, uv, NULL, NULL) != 68) {
            warm = 0;
            continue;
        }
        o[0] = (float)(rms / win.s);
        for (int k = 0; k < 68; k++) {
            o[1 + 2 * k] = (float)((uv[2 * k] + 0.5) / win.s - 0.5 + win.x0);
            o[2 + 2 * k] = (float)((uv[2 * k + 1] + 0.5) / win.s - 0.5 + win.y0);
        }
        warm = 1, fitted++;
    }
    free(exp);
    ss->fit.lm_fitted = out;
    sp_log(SP_LOG_INFO, "sunstage", "fitted landmarks: the model aligned to %d of %zu tracked frames in %.2f s", fitted,
           fe->lm_n, (double)(sp_clock_monotonic_ns() - t0) * 1e-9);
    return 0;
}
