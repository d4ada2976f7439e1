/* SPDX-License-Identifier: MIT */
/*
 * Reference photometric solver: Adam on every parameter through the renderer's
 * adjoint and the face model's adjoint, as in the thesis (chapter 4): sun
 * direction and intensity, environment map, albedo, displacement, specular
 * intensity and exponent per cluster, identity, scale, per-frame expression and
 * pose. Loss per keyframe: masked display-space L2 + an image-gradient term
 * (our substitute for the VGG perceptual loss: no VGG weights offline) +
 * landmarks (Huber), plus environment L2 and smoothness and displacement
 * smoothness. Full-batch steps over the keyframe reservoir.
 */
#include "pipeline/sunstage/sunstage_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>

#include "common/clock.h"

#define MOD "sunstage"
#define W_GRAD 0.5    /* image-gradient loss weight */
#define W_LM 1e-5     /* landmark Huber loss weight per px^2 */
#define W_ENV_L2 1e-4
#define W_ENV_SMOOTH 1e-3
#define W_DISP_SMOOTH 1e3
#define B1 0.9
#define B2 0.999

typedef struct adam_vec {
    size_t n;
    double *m, *v, *g;
} adam_vec;

static int adam_vec_init(adam_vec *a, size_t n)
{
    a->n = n;
    a->m = calloc(n ? n : 1, sizeof(double));
    a->v = calloc(n ? n : 1, sizeof(double));
    a->g = calloc(n ? n : 1, sizeof(double));
    return a->m && a->v && a->g ? 0 : -ENOMEM;
}

static void adam_vec_free(adam_vec *a)
{
    free(a->m);
    free(a->v);
    free(a->g);
}

/* One Adam step on x (doubles or floats) with bias correction at step t; clears the gradient. */
static void adam_update(adam_vec *a, double *xd, float *xf, double lr, int t, double lo, double hi)
{
    double c1 = 1.0 - pow(B1, t), c2 = 1.0 - pow(B2, t);
    for (size_t i = 0; i < a->n; i++) {
        double g = isfinite(a->g[i]) ? a->g[i] : 0.0;
        a->m[i] = B1 * a->m[i] + (1.0 - B1) * g;
        a->v[i] = B2 * a->v[i] + (1.0 - B2) * g * g;
        double step = lr * (a->m[i] / c1) / (sqrt(a->v[i] / c2) + 1e-12);
        double x = (xd ? xd[i] : (double)xf[i]) - step;
        x = x < lo ? lo : (x > hi ? hi : x);
        if (xd)
            xd[i] = x;
        else
            xf[i] = (float)x;
        a->g[i] = 0.0;
    }
}

typedef struct adam_ctx {
    sp_sunstage *ss;
    ss_scene sc;
    int idx[64], nf;
    adam_vec albedo, disp, env, sun, logI, ks, logs, id, scale;
    adam_vec frame[64]; /* exp, rotvec, t per frame */
    double logI_x, logs_x[SP_RENDER_CLUSTERS];
    int no_sun; /* lighting unobservable or overcast: sun, its shadows and specular stay off */
    int refine; /* geometry and displacement only (after the fast solver): appearance and light frozen */
    double *gpos, *gcam, *gid, *gexp;
    float *dimg, *mask;
} adam_ctx;

/* Adds the image-gradient loss and its derivative (into d) over pixel pairs inside the mask. */
static double gradient_loss(const float *img, const float *tgt, const float *mask, int w, int h, float *d)
{
    double m = 0.0, L = 0.0;
    for (int i = 0; i < w * h; i++)
        m += (double)mask[i];
    if (!(m > 0.0))
        return 0.0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int p = y * w + x;
            for (int dir = 0; dir < 2; dir++) {
                int q = dir ? (y + 1 < h ? p + w : -1) : (x + 1 < w ? p + 1 : -1);
                if (q < 0 || !(mask[p] > 0.0f) || !(mask[q] > 0.0f))
                    continue;
                for (int c = 0; c < 3; c++) {
                    double r = ((double)img[q * 3 + c] - (double)img[p * 3 + c]) - ((double)tgt[q * 3 + c] - (double)tgt[p * 3 + c]);
                    L += W_GRAD * r * r / m;
                    d[q * 3 + c] += (float)(2.0 * W_GRAD * r / m);
                    d[p * 3 + c] -= (float)(2.0 * W_GRAD * r / m);
                }
            }
        }
    return L;
}

/* Landmark Huber loss of frame f, adding its gradient to the face grads. */
static double landmark_loss(adam_ctx *a, const ss_frame *f, const sp_face_params *p, double *gshared, double *gframe)
{
    sp_sunstage *ss = a->ss;
    const sp_face_model *m = ss->model;
    uint32_t nc = sp_face_model_n_params(m);
    double uv[136];
    double *jac = malloc(sizeof(double) * 136 * nc);
    if (!jac)
        return 0.0;
    double L = 0.0;
    if (sp_face_model_project_landmarks(m, p, &f->cam, uv, NULL, jac) >= 0)
        for (int k = 0; k < 136; k++) {
            double r = uv[k] - f->lm[k], ar = fabs(r);
            L += W_LM * (ar > 1.0 ? 2.0 * ar - 1.0 : r * r);
            double dr = W_LM * (ar > 1.0 ? 2.0 * (r > 0 ? 1.0 : -1.0) : 2.0 * r);
            for (uint32_t j = 0; j < nc; j++) {
                double g = dr * jac[(size_t)k * nc + j];
                if (j < m->n_id)
                    gshared[j] += g;
                else if (j < m->n_id + m->n_exp + 6)
                    gframe[j - m->n_id] += g;
                else
                    gshared[m->n_id] += g;
            }
        }
    free(jac);
    return L;
}

/* Silhouette loss of frame f (outline re-chosen at the current pose), adding its gradient to the face grads. */
static double silhouette_loss(adam_ctx *a, ss_frame *f, const sp_face_params *p, double *gshared, double *gframe)
{
    sp_sunstage *ss = a->ss;
    const sp_face_model *m = ss->model;
    const double W_SIL = W_LM * ss->set.silhouette_weight; /* relative to the landmarks, as in stage 1 */
    if (!f->sil_ok || !f->sil || !(W_SIL > 0.0))
        return 0.0;
    uint32_t nc = sp_face_model_n_params(m);
    int cap = SS_SIL_CAP(ss->W, ss->H);
    uint32_t *idx = malloc(sizeof(uint32_t) * (size_t)cap);
    double *r = malloc(sizeof(double) * (size_t)cap), *jac = malloc(sizeof(double) * (size_t)cap * nc);
    double L = 0.0;
    int n = idx && r && jac ? ss_silhouette_vertices(m, ss->scalp, p, &f->cam, ss->W, ss->H, idx, cap, a->gcam) : 0;
    if (n > 0 && ss_silhouette_residuals(m, p, &f->cam, idx, n, f->sil, ss->W, ss->H, r, jac) == 0)
        for (int j = 0; j < n; j++) {
            if (r[j] >= SS_SIL_MAX) { /* truncated: constant cost, no pull */
                L += W_SIL * SS_SIL_HUBER * (2.0 * SS_SIL_MAX - SS_SIL_HUBER);
                continue;
            }
            double h = r[j] > SS_SIL_HUBER;
            L += W_SIL * (h ? SS_SIL_HUBER * (2.0 * r[j] - SS_SIL_HUBER) : r[j] * r[j]);
            double dr = W_SIL * (h ? 2.0 * SS_SIL_HUBER : 2.0 * r[j]);
            for (uint32_t k = 0; k < nc; k++) {
                double g = dr * jac[(size_t)j * nc + k];
                if (k < m->n_id)
                    gshared[k] += g;
                else if (k < m->n_id + m->n_exp + 6)
                    gframe[k - m->n_id] += g;
                else
                    gshared[m->n_id] += g;
            }
        }
    free(idx);
    free(r);
    free(jac);
    return L;
}

static int frame_step(adam_ctx *a, int fi, double *loss)
{
    sp_sunstage *ss = a->ss;
    const sp_face_model *m = ss->model;
    ss_frame *f = &ss->res.slots[a->idx[fi]];
    sp_render_scene scene;
    sp_render_outputs o;
    /*
     * Not sp_render_fit_l2: the mask comes from this render (its triangle ids
     * and coverage), and the image-gradient loss needs the finished image and
     * its own adjoint, so the fused pass would need a second sp_render_backward
     * and cost more than this (bench_render: fit 20 ms + adjoint 11 ms > 24 ms).
     */
    int ret = ss_scene_setup(&a->sc, ss, f, &scene);
    if (ret || (ret = sp_render(a->sc.r, &scene, &o)))
        return ret;
    ss_scene_mask(&a->sc, &o, f->rgb, a->mask);
    double L;
    if ((ret = sp_render_l2_loss(o.image, f->rgb, a->mask, ss->W, ss->H, &L, a->dimg)))
        return ret;
    L += gradient_loss(o.image, f->rgb, a->mask, ss->W, ss->H, a->dimg);
    sp_render_grads g;
    memset(&g, 0, sizeof(g));
    g.albedo = a->albedo.g;
    g.displacement = a->disp.g;
    g.env = a->env.g;
    g.positions = a->gpos;
    memset(a->gpos, 0, sizeof(double) * 3 * m->mesh.n_vertices);
    if ((ret = sp_render_backward(a->sc.r, &scene, a->dimg, &g)))
        return ret;
    for (int k = 0; k < 3; k++)
        a->sun.g[k] += g.sun_dir[k];
    a->logI.g[0] += g.sun_intensity * scene.sun_intensity;
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++) {
        a->ks.g[k] += g.ks[k];
        a->logs.g[k] += g.shininess[k] * ss->fit.shin[k];
    }
    const double *R = f->R_c2w; /* world gradient back into the camera frame: R^T g */
    for (uint32_t i = 0; i < m->mesh.n_vertices; i++) {
        const double *gw = a->gpos + (size_t)i * 3;
        for (int c = 0; c < 3; c++)
            a->gcam[(size_t)i * 3 + (size_t)c] = R[c] * gw[0] + R[3 + c] * gw[1] + R[6 + c] * gw[2];
    }
    sp_face_params p;
    ss_frame_params(ss, f, &p);
    sp_face_grad fg = { .id = a->gid, .exp = a->gexp };
    if ((ret = sp_face_model_eval_adjoint(m, &p, a->gcam, &fg)))
        return ret;
    double *gf = a->frame[fi].g;
    for (uint32_t k = 0; k < m->n_id; k++)
        a->id.g[k] += fg.id[k];
    for (uint32_t k = 0; k < m->n_exp; k++)
        gf[k] += fg.exp[k];
    for (int k = 0; k < 3; k++) {
        gf[m->n_exp + (uint32_t)k] += fg.rotvec[k];
        gf[m->n_exp + 3 + (uint32_t)k] += fg.t[k];
    }
    a->scale.g[0] += fg.s;
    double gsh[256];
    memset(gsh, 0, sizeof(gsh));
    L += landmark_loss(a, f, &p, gsh, gf);
    L += silhouette_loss(a, f, &p, gsh, gf); /* uses gcam as scratch: the face adjoint is done with it */
    for (uint32_t k = 0; k < m->n_id && k < 255; k++)
        a->id.g[k] += gsh[k];
    a->scale.g[0] += gsh[m->n_id < 255 ? m->n_id : 255];
    *loss += L;
    return 0;
}

/* Environment L2 and 4-neighbour smoothness; displacement smoothness; identity prior. */
static double regularisers(adam_ctx *a)
{
    sp_sunstage *ss = a->ss;
    double L = 0.0;
    for (int i = 0; i < SP_RENDER_ENV_H; i++)
        for (int j = 0; j < SP_RENDER_ENV_W; j++)
            for (int c = 0; c < 3; c++) {
                int p = (i * SP_RENDER_ENV_W + j) * 3 + c;
                int q = (i * SP_RENDER_ENV_W + (j + 1) % SP_RENDER_ENV_W) * 3 + c;
                double e = ss->fit.env[p], d = ss->fit.env[p] - ss->fit.env[q];
                L += W_ENV_L2 * e * e + W_ENV_SMOOTH * d * d;
                a->env.g[p] += 2.0 * W_ENV_L2 * e + 2.0 * W_ENV_SMOOTH * d;
                a->env.g[q] -= 2.0 * W_ENV_SMOOTH * d;
                if (i + 1 < SP_RENDER_ENV_H) {
                    int r = p + SP_RENDER_ENV_W * 3;
                    double dv = ss->fit.env[p] - ss->fit.env[r];
                    L += W_ENV_SMOOTH * dv * dv;
                    a->env.g[p] += 2.0 * W_ENV_SMOOTH * dv;
                    a->env.g[r] -= 2.0 * W_ENV_SMOOTH * dv;
                }
            }
    for (int y = 0; y < ss->fit.th; y++)
        for (int x = 0; x + 1 < ss->fit.tw; x++) {
            int p = y * ss->fit.tw + x;
            double d = ss->fit.disp[p] - ss->fit.disp[p + 1];
            L += W_DISP_SMOOTH * d * d;
            a->disp.g[p] += 2.0 * W_DISP_SMOOTH * d;
            a->disp.g[p + 1] -= 2.0 * W_DISP_SMOOTH * d;
        }
    for (uint32_t k = 0; k < ss->model->n_id; k++) {
        L += 1e-4 * ss->fit.id[k] * ss->fit.id[k];
        a->id.g[k] += 2e-4 * ss->fit.id[k];
    }
    return L;
}

/* The thesis-like schedule: lighting and albedo first, geometry joins after a warm-up, rates decay late. */
static void apply(adam_ctx *a, int t, int total)
{
    sp_sunstage *ss = a->ss;
    const sp_face_model *m = ss->model;
    double decay = t > total * 2 / 3 ? 0.3 : 1.0;
    int geo = a->refine || t > total / 4;
    if (a->refine) {
        memset(a->albedo.g, 0, sizeof(double) * a->albedo.n);
        memset(a->env.g, 0, sizeof(double) * a->env.n);
    } else {
        adam_update(&a->albedo, NULL, ss->fit.albedo, 0.02 * decay, t, 0.0, 4.0);
        adam_update(&a->env, NULL, ss->fit.env, 0.02 * decay, t, 0.0, 1e3);
    }
    if (a->no_sun || a->refine) { /* the sun's unknowns stay where they are: no sun, no specular */
        memset(a->sun.g, 0, sizeof(double) * 3);
        a->logI.g[0] = 0.0;
        memset(a->ks.g, 0, sizeof(double) * a->ks.n);
        memset(a->logs.g, 0, sizeof(double) * a->logs.n);
    } else {
        adam_update(&a->sun, ss->fit.sun_dir, NULL, 0.03 * decay, t, -2.0, 2.0);
        double n = sqrt(ss->fit.sun_dir[0] * ss->fit.sun_dir[0] + ss->fit.sun_dir[1] * ss->fit.sun_dir[1] +
                        ss->fit.sun_dir[2] * ss->fit.sun_dir[2]);
        for (int k = 0; k < 3; k++)
            ss->fit.sun_dir[k] = n > 1e-9 ? ss->fit.sun_dir[k] / n : (k == 2);
        adam_update(&a->logI, &a->logI_x, NULL, 0.03 * decay, t, -10.0, 5.0);
        ss->fit.sun_I = exp(a->logI_x);
        adam_update(&a->ks, ss->fit.ks, NULL, 0.01 * decay, t, 0.0, SS_KS_MAX);
        adam_update(&a->logs, a->logs_x, NULL, 0.03 * decay, t, 0.0, log(SP_RENDER_SHININESS_MAX));
        for (int k = 0; k < SP_RENDER_CLUSTERS; k++)
            ss->fit.shin[k] = exp(a->logs_x[k]);
    }
    if (!geo) {
        for (size_t i = 0; i < a->disp.n; i++)
            a->disp.g[i] = 0.0;
        memset(a->id.g, 0, sizeof(double) * a->id.n);
        a->scale.g[0] = 0.0;
        for (int fi = 0; fi < a->nf; fi++)
            memset(a->frame[fi].g, 0, sizeof(double) * a->frame[fi].n);
        return;
    }
    double gl = a->refine ? 0.1 * decay : decay; /* refinement: small steps around a converged fit */
    adam_update(&a->disp, NULL, ss->fit.disp, 2e-5 * decay, t, -0.005, 0.005);
    adam_update(&a->id, ss->fit.id, NULL, 0.01 * gl, t, -5.0, 5.0);
    adam_update(&a->scale, &ss->fit.scale, NULL, 0.001 * gl, t, 0.7, 1.4);
    for (int fi = 0; fi < a->nf; fi++) {
        ss_frame *f = &ss->res.slots[a->idx[fi]];
        double x[64];
        uint32_t ne = m->n_exp < 52 ? m->n_exp : 52;
        memcpy(x, f->exp, sizeof(double) * ne);
        memcpy(x + ne, f->rotvec, sizeof(f->rotvec));
        memcpy(x + ne + 3, f->t_face, sizeof(f->t_face));
        adam_update(&a->frame[fi], x, NULL, 1e-3 * gl, t, -1e3, 1e3);
        for (uint32_t k = 0; k < ne; k++)
            f->exp[k] = x[k] < 0.0 ? 0.0 : (x[k] > 1.0 ? 1.0 : x[k]);
        memcpy(f->rotvec, x + ne, sizeof(f->rotvec));
        memcpy(f->t_face, x + ne + 3, sizeof(f->t_face));
    }
}

static int adam_alloc(adam_ctx *a)
{
    sp_sunstage *ss = a->ss;
    const sp_face_model *m = ss->model;
    size_t nt = (size_t)ss->fit.tw * (size_t)ss->fit.th;
    int ret = adam_vec_init(&a->albedo, nt * 3) | adam_vec_init(&a->disp, nt) |
              adam_vec_init(&a->env, SP_RENDER_ENV_FLOATS) | adam_vec_init(&a->sun, 3) | adam_vec_init(&a->logI, 1) |
              adam_vec_init(&a->ks, SP_RENDER_CLUSTERS) | adam_vec_init(&a->logs, SP_RENDER_CLUSTERS) |
              adam_vec_init(&a->id, m->n_id) | adam_vec_init(&a->scale, 1);
    for (int fi = 0; fi < a->nf; fi++)
        ret |= adam_vec_init(&a->frame[fi], (m->n_exp < 52 ? m->n_exp : 52) + 6);
    a->gpos = malloc(sizeof(double) * 3 * m->mesh.n_vertices);
    a->gcam = malloc(sizeof(double) * 6 * m->mesh.n_vertices); /* 6: silhouette scratch too */
    a->gid = calloc(m->n_id + 1, sizeof(double));
    a->gexp = calloc(m->n_exp + 1, sizeof(double));
    a->dimg = malloc(sizeof(float) * (size_t)ss->W * (size_t)ss->H * 3);
    a->mask = malloc(sizeof(float) * (size_t)ss->W * (size_t)ss->H);
    if (ret || !a->gpos || !a->gcam || !a->gid || !a->gexp || !a->dimg || !a->mask)
        return -ENOMEM;
    return 0;
}

static void adam_free(adam_ctx *a)
{
    adam_vec *v[] = { &a->albedo, &a->disp, &a->env, &a->sun, &a->logI, &a->ks, &a->logs, &a->id, &a->scale };
    for (size_t i = 0; i < sizeof(v) / sizeof(v[0]); i++)
        adam_vec_free(v[i]);
    for (int fi = 0; fi < a->nf; fi++)
        adam_vec_free(&a->frame[fi]);
    free(a->gpos);
    free(a->gcam);
    free(a->gid);
    free(a->gexp);
    free(a->dimg);
    free(a->mask);
    ss_scene_close(&a->sc);
}

static int adam_loop(adam_ctx *a, sp_sunstage_callback cb, void *user)
{
    sp_sunstage *ss = a->ss;
    int total = ss->set.adam_iterations;
    for (int t = 1; t <= total; t++) {
        double loss = 0.0;
        for (int fi = 0; fi < a->nf; fi++) {
            int ret = frame_step(a, fi, &loss);
            if (ret)
                return ret;
        }
        loss = loss / a->nf + regularisers(a);
        apply(a, t, total);
        double el = (double)(sp_clock_monotonic_ns() - ss->fit.t0) * 1e-9;
        int stop = ss->set.time_budget_s > 0.0 && el > ss->set.time_budget_s;
        if (t % 10 == 0 || t == total || stop) {
            double ho = NAN, tr = NAN;
            if (t % 50 == 0 || t == total || stop)
                ss_evaluate(ss, &a->sc, &tr, &ho);
            if (isfinite(tr))
                ss->fit.train_psnr = tr;
            if (isfinite(ho))
                ss->fit.heldout_psnr = ho;
            sp_sunstage_progress p = { "photometric", t, total, el, loss, ho };
            if (cb && cb(user, &p))
                break;
        }
        if (stop)
            break;
    }
    return 0;
}

int ss_fit_adam(sp_sunstage *ss, sp_sunstage_callback cb, void *user)
{
    adam_ctx *a = calloc(1, sizeof(*a));
    if (!a)
        return -ENOMEM;
    a->ss = ss;
    a->nf = ss_list_frames(ss, 0, a->idx, 64);
    int ret = ss_scene_open(&a->sc, ss);
    if (!ret)
        ret = adam_alloc(a);
    if (!ret) { /* the driver ran the overcast check first (sun_dropped) */
        a->no_sun = ss->fit.unobservable || ss->fit.sun_dropped;
        double d[3] = { 0.3, 0.3, 0.9 }; /* a generic high sun: the reference has no search */
        memcpy(ss->fit.sun_dir, d, sizeof(d));
        ss->fit.sun_I = a->no_sun ? 0.0 : 2.0;
        a->logI_x = log(2.0);
        for (int k = 0; k < SP_RENDER_CLUSTERS; k++) {
            ss->fit.ks[k] = a->no_sun ? 0.0 : 0.05;
            ss->fit.shin[k] = 16.0;
            a->logs_x[k] = log(16.0);
        }
        ret = adam_loop(a, cb, user);
        if (a->no_sun)
            ss->fit.sun_I = 0.0;
    }
    adam_free(a);
    free(a);
    sp_log(SP_LOG_INFO, MOD, "adam: sun (%.3f %.3f %.3f) I %.3f, train %.2f dB", ss->fit.sun_dir[0], ss->fit.sun_dir[1],
           ss->fit.sun_dir[2], ss->fit.sun_I, ss->fit.train_psnr);
    return ret;
}

/* Per-frame geometry, shared shape and displacement: saved or restored (dir = 1). */
typedef struct geo_state {
    double *v;
    float *disp;
} geo_state;

static void geo_io(sp_sunstage *ss, const int *idx, int nf, geo_state *g, int dir)
{
    const sp_face_model *m = ss->model;
    double *p = g->v;
    for (int fi = 0; fi < nf; fi++) {
        ss_frame *f = &ss->res.slots[idx[fi]];
        double *fields[3] = { f->exp, f->rotvec, f->t_face };
        size_t sizes[3] = { m->n_exp, 3, 3 };
        for (int k = 0; k < 3; k++) {
            memcpy(dir ? fields[k] : p, dir ? p : fields[k], sizeof(double) * sizes[k]);
            p += sizes[k];
        }
    }
    memcpy(dir ? ss->fit.id : p, dir ? p : ss->fit.id, sizeof(double) * m->n_id);
    p += m->n_id;
    memcpy(dir ? &ss->fit.scale : p, dir ? p : &ss->fit.scale, sizeof(double));
    size_t nt = (size_t)ss->fit.tw * (size_t)ss->fit.th;
    memcpy(dir ? ss->fit.disp : g->disp, dir ? g->disp : ss->fit.disp, sizeof(float) * nt);
}

static int refine_loop(adam_ctx *a, int steps)
{
    for (int t = 1; t <= steps; t++) {
        double loss = 0.0;
        for (int fi = 0; fi < a->nf; fi++) {
            int ret = frame_step(a, fi, &loss);
            if (ret)
                return ret;
        }
        regularisers(a);
        apply(a, t, steps);
    }
    return 0;
}

int ss_refine_geometry(sp_sunstage *ss, int steps)
{
    adam_ctx *a = calloc(1, sizeof(*a));
    if (!a)
        return -ENOMEM;
    a->ss = ss;
    a->nf = ss_list_frames(ss, 0, a->idx, 64);
    a->refine = 1;
    a->no_sun = 1; /* the sun's unknowns stay as the fast solver left them */
    const sp_face_model *m = ss->model;
    geo_state g = { malloc(sizeof(double) * ((size_t)a->nf * (m->n_exp + 6) + m->n_id + 1)),
                    malloc(sizeof(float) * (size_t)ss->fit.tw * (size_t)ss->fit.th) };
    int ret = g.v && g.disp ? ss_scene_open(&a->sc, ss) : -ENOMEM;
    if (!ret)
        ret = adam_alloc(a);
    double tr0 = NAN, ho0 = NAN, tr1 = NAN, ho1 = NAN;
    if (!ret) {
        geo_io(ss, a->idx, a->nf, &g, 0);
        ss_evaluate(ss, &a->sc, &tr0, &ho0);
        ret = refine_loop(a, steps);
    }
    if (!ret) {
        ss_evaluate(ss, &a->sc, &tr1, &ho1);
        /* keep it only where it pays off: the held-out PSNR (training when there is none) must rise, training not fall */
        int have_ho = isfinite(ho0) && isfinite(ho1);
        int better = (have_ho ? ho1 > ho0 + 0.05 : tr1 > tr0 + 0.05) && !(tr1 < tr0 - 0.05);
        if (!better) {
            geo_io(ss, a->idx, a->nf, &g, 1);
            snprintf(ss->fit.disp_note, sizeof(ss->fit.disp_note),
                     "photometric refinement of geometry and displacement (%d steps) did not pay off (train %.2f -> "
                     "%.2f dB, held-out %.2f -> %.2f dB): reverted",
                     steps, tr0, tr1, ho0, ho1);
            sp_log(SP_LOG_INFO, MOD, "%s", ss->fit.disp_note);
        } else {
            ss->fit.train_psnr = tr1;
            ss->fit.heldout_psnr = ho1;
            sp_log(SP_LOG_INFO, MOD, "photometric refinement (%d steps): train %.2f -> %.2f dB, held-out %.2f -> %.2f dB",
                   steps, tr0, tr1, ho0, ho1);
        }
    }
    adam_free(a);
    free(a);
    free(g.v);
    free(g.disp);
    return ret;
}
