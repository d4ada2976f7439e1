/* SPDX-License-Identifier: MIT */
#include "pipeline/render/adjoint.h"

#include <math.h>
#include <string.h>

#include "pipeline/render/render_internal.h"
#include "pipeline/render/tonemap.h"
#include "pipeline/render/vec3.h"

static void specular_backward(const shade_ctx *ctx, const shade_rec *rec, double gs, double *g_nl, double *g_I,
                              double *g_V, sample_grad *sg, shade_acc *acc)
{
    int cl = rec->cluster;
    double ks = ctx->ks[cl], s = ctx->s[cl], I = ctx->sun_I;
    double f = (s + 2.0) / (2.0 * SHADE_PI), P = rec->bl.P, nl = rec->nl, V = rec->V;
    acc->g_ks[cl] += gs * f * P * nl * I * V;
    if (!ctx->s_clamped[cl])
        acc->g_s[cl] += gs * ks * P * nl * I * V * (1.0 / (2.0 * SHADE_PI) + f * rec->bl.log_nh);
    double k = gs * ks * f;
    *g_nl += k * P * I * V;
    *g_I += k * P * nl * V;
    *g_V += k * P * nl * I;
    if (rec->bl.nh_clamped)
        return;
    /* d(nh^s)/d(nh) = s nh^(s-1) = s P / nh, nh >= SHADE_NH_MIN here */
    double g_nh = k * nl * I * V * s * P / rec->bl.nh;
    v3_axpy(g_nh, rec->bl.h, sg->n);
    double g_h[3], g_hs[3] = {0, 0, 0};
    v3_scale(rec->n, g_nh, g_h);
    v3_normalize_backward(rec->bl.h, rec->bl.hlen, g_h, g_hs);
    v3_axpy(1.0, g_hs, acc->g_l);
    v3_axpy(1.0, g_hs, sg->v);
}

static void sun_backward(const shade_ctx *ctx, const shade_rec *rec, const double gc[3], sample_grad *sg,
                         shade_acc *acc)
{
    if (!(rec->nl > 0.0)) /* max(n.l, 0) is flat here: nothing depends on the sun */
        return;
    double I = ctx->sun_I, nl = rec->nl, V = rec->V;
    double sd = 0.0;
    for (int c = 0; c < 3; c++) {
        sg->a[c] += gc[c] * I * nl * V / SHADE_PI;
        sd += gc[c] * rec->a[c] / SHADE_PI;
    }
    double g_nl = sd * I * V, g_V = sd * I * nl, g_I = sd * nl * V;
    if (rec->spec_on)
        specular_backward(ctx, rec, gc[0] + gc[1] + gc[2], &g_nl, &g_I, &g_V, sg, acc);
    v3_axpy(g_nl, ctx->sun_l, sg->n);
    v3_axpy(g_nl, rec->n, acc->g_l);
    acc->g_I += g_I;
    v3_axpy(g_V, rec->shadow.dVdp, sg->p);
}

/* Interpolation (p, m, uv) and the perspective barycentrics back to vertices and the ray. */
static void bary_backward(const shade_ctx *ctx, const shade_rec *rec, const sample_grad *sg, const double g_uv[2],
                          shade_acc *acc)
{
    const render_geom *g = ctx->geo;
    const sp_mesh *mesh = ctx->sc->mesh;
    double g_m[3] = {0, 0, 0}, g_lam[3], dot = 0.0;
    v3_normalize_backward(rec->n, rec->mlen, sg->n, g_m);
    for (int i = 0; i < 3; i++) {
        size_t v = rec->vi[i];
        const float *uv = mesh->uvs + (size_t)rec->ui[i] * 2;
        g_lam[i] = v3_dot(sg->p, g->pd + v * 3) + v3_dot(g_m, g->nd + v * 3) + g_uv[0] * (double)uv[0] +
                   g_uv[1] * (double)uv[1];
        v3_axpy(rec->lam[i], sg->p, acc->g_pd + v * 3);
        v3_axpy(rec->lam[i], g_m, acc->g_nd + v * 3);
        dot += rec->lam[i] * g_lam[i];
    }
    double gw[3], inv_wsum = 1.0 / rec->wsum;
    for (int j = 0; j < 3; j++)
        gw[j] = (g_lam[j] - dot) * inv_wsum;
    /* w0 = [d, B, C], w1 = [d, C, A], w2 = [d, A, B] */
    const double *A = g->xc + (size_t)rec->vi[0] * 3, *B = g->xc + (size_t)rec->vi[1] * 3,
                 *C = g->xc + (size_t)rec->vi[2] * 3, *d = rec->d;
    /* dw0/dB = C x d, dw0/dC = d x B, and cyclically; grouped as d x (...) */
    double q[3], t[3];
    for (int i = 0; i < 3; i++)
        q[i] = gw[1] * C[i] - gw[2] * B[i];
    v3_cross(d, q, t), v3_axpy(1.0, t, acc->g_xc + (size_t)rec->vi[0] * 3);
    for (int i = 0; i < 3; i++)
        q[i] = gw[2] * A[i] - gw[0] * C[i];
    v3_cross(d, q, t), v3_axpy(1.0, t, acc->g_xc + (size_t)rec->vi[1] * 3);
    for (int i = 0; i < 3; i++)
        q[i] = gw[0] * B[i] - gw[1] * A[i];
    v3_cross(d, q, t), v3_axpy(1.0, t, acc->g_xc + (size_t)rec->vi[2] * 3);
    const double *k = g->tri_k + (size_t)rec->tri * 9; /* B x C, C x A, A x B */
    double gd[3] = {0, 0, 0};
    v3_axpy(gw[0], k, gd);
    v3_axpy(gw[1], k + 3, gd);
    v3_axpy(gw[2], k + 6, gd);
    /* d = ((u - cx) / fx, (v - cy) / fy, 1) */
    const raster_camera *cam = ctx->cam;
    acc->g_fx -= gd[0] * d[0] * cam->inv_fx;
    acc->g_cx -= gd[0] * cam->inv_fx;
    acc->g_fy -= gd[1] * d[1] * cam->inv_fy;
    acc->g_cy -= gd[1] * cam->inv_fy;
}

void shade_backward(const shade_ctx *ctx, const shade_rec *rec, const double gc[3], shade_acc *acc)
{
    sample_grad sg;
    memset(&sg, 0, sizeof(sg));
    /* ambient: a / pi * E(n), E from the SH irradiance */
    double gE[3], dEdn_own[3][3], E_own[3], y_own[ENV_SH_N];
    const double(*dEdn)[3] = rec->dEdn;
    const double *E = rec->E, *y = rec->y;
    if (!rec->have_dE) { /* the classic backward: the forward kept only E */
        env_irradiance(&ctx->sh, rec->n, E_own, dEdn_own, y_own);
        dEdn = (const double(*)[3])dEdn_own;
        E = E_own;
        y = y_own;
    }
    for (int c = 0; c < 3; c++) {
        sg.a[c] += gc[c] * E[c] / SHADE_PI;
        gE[c] = gc[c] * rec->a[c] / SHADE_PI;
        v3_axpy(gE[c], dEdn[c], sg.n);
    }
    env_irradiance_backward_L(y, E, gE, acc->gY);
    sun_backward(ctx, rec, gc, &sg, acc);
    shade_backward_surface(ctx, rec, &sg, acc);
}

void shade_backward_surface(const shade_ctx *ctx, const shade_rec *rec, sample_grad *sg, shade_acc *acc)
{
    /* v = normalize(eye - p) */
    double g_ev[3] = {0, 0, 0};
    v3_normalize_backward(rec->v, rec->evlen, sg->v, g_ev);
    v3_axpy(-1.0, g_ev, sg->p);
    v3_axpy(1.0, g_ev, acc->g_eye);
    const sp_render_texture *at = &ctx->sc->albedo;
    if (acc->g_albedo)
        tex_splat(&rec->alb, acc->g_albedo, 3, sg->a);
    double du[3], dv[3], g_uv[2];
    tex_sample_duv(&rec->alb, at->data, 3, du, dv);
    g_uv[0] = v3_dot(sg->a, du);
    g_uv[1] = v3_dot(sg->a, dv);
    bary_backward(ctx, rec, sg, g_uv, acc);
}

/* dL/d(per-sample linear radiance) for pixel i: tone map and exposure; adds to the exposure gradient. */
int render_pixel_adjoint(const sp_renderer *r, const sp_render_scene *sc, const float dl[3], size_t i, double gc[3],
                         double *g_exposure)
{
    double e = sc->exposure, any = 0.0;
    double inv_s2 = 1.0 / (double)(r->set.supersample * r->set.supersample);
    for (int c = 0; c < 3; c++) {
        double g = (double)dl[c];
        if (g == 0.0) {
            gc[c] = 0.0;
            continue;
        }
        double rad = r->radiance64[i * 3 + (size_t)c];
        double gx = g * tonemap_deriv(e * rad, r->image64[i * 3 + (size_t)c]);
        *g_exposure += gx * rad;
        gc[c] = gx * e * inv_s2;
        any += fabs(gc[c]);
    }
    return any > 0.0;
}

static void samples_backward(sp_renderer *r, const shade_ctx *ctx, const float *dL, shade_acc *acc,
                             double *g_exposure)
{
    int S = r->set.supersample;
    for (int py = 0; py < r->set.height; py++) {
        for (int px = 0; px < r->set.width; px++) {
            size_t i = (size_t)py * (size_t)r->set.width + (size_t)px;
            double gc[3];
            if (!render_pixel_adjoint(r, ctx->sc, dL + i * 3, i, gc, g_exposure))
                continue;
            for (int j = 0; j < S; j++)
                for (int k = 0; k < S; k++) {
                    int sx = px * S + k, sy = py * S + j;
                    int32_t tri = r->tri_id[(size_t)sy * (size_t)r->sw + (size_t)sx];
                    shade_rec rec;
                    if (tri < 0 || !shade_geometry(ctx, sx, sy, tri, &rec))
                        continue;
                    shade_sun_replay(ctx, &rec, r->sun_cache + (size_t)sy * (size_t)r->sw + (size_t)sx);
                    shade_backward(ctx, &rec, gc, acc);
                }
        }
    }
}

/* Camera-space adjoints -> displaced world positions and the pose; the eye's adjoint -> the pose. */
static void camera_backward(sp_renderer *r, const sp_render_scene *sc, const shade_acc *acc, sp_render_grads *gr)
{
    render_geom *g = &r->geo;
    const double *R = sc->camera.R, *t = sc->camera.t;
    double gt[3], gR[9]; /* local sums (the same additions in the same order): g_pd may alias gr's doubles */
    memcpy(gt, gr->camera_t, sizeof(gt));
    memcpy(gR, gr->camera_R, sizeof(gR));
    for (uint32_t v = 0; v < sc->mesh->n_vertices; v++) {
        const double *gx = g->g_xc + (size_t)v * 3, *pd = g->pd + (size_t)v * 3;
        double tmp[3];
        m3_tmul(R, gx, tmp);
        v3_axpy(1.0, tmp, g->g_pd + (size_t)v * 3);
        for (int i = 0; i < 3; i++) {
            gt[i] += gx[i];
            for (int k = 0; k < 3; k++)
                gR[i * 3 + k] += gx[i] * pd[k];
        }
    }
    memcpy(gr->camera_t, gt, sizeof(gt));
    memcpy(gr->camera_R, gR, sizeof(gR));
    /* eye = -R^T t */
    double rg[3];
    m3_mul(R, acc->g_eye, rg);
    for (int i = 0; i < 3; i++) {
        gr->camera_t[i] -= rg[i];
        for (int k = 0; k < 3; k++)
            gr->camera_R[i * 3 + k] -= t[i] * acc->g_eye[k];
    }
    gr->fx += acc->g_fx;
    gr->fy += acc->g_fy;
    gr->cx += acc->g_cx;
    gr->cy += acc->g_cy;
}

static void scalars_backward(const shade_ctx *ctx, const shade_acc *acc, sp_render_grads *gr)
{
    for (int c = 0; c < SP_RENDER_CLUSTERS; c++) {
        gr->ks[c] += acc->g_ks[c];
        gr->shininess[c] += acc->g_s[c];
    }
    v3_normalize_backward(ctx->sun_l, ctx->sun_len, acc->g_l, gr->sun_dir);
    gr->sun_intensity += acc->g_I;
}

void render_backward_begin(sp_renderer *r, const sp_render_scene *sc, sp_render_grads *gr, shade_ctx *ctx,
                           shade_acc *acc)
{
    render_geom *g = &r->geo;
    size_t nv3 = (size_t)sc->mesh->n_vertices * 3;
    memset(g->g_pd, 0, nv3 * sizeof(double));
    memset(g->g_nd, 0, nv3 * sizeof(double));
    memset(g->g_xc, 0, nv3 * sizeof(double));
    *ctx = r->ctx;
    ctx->sc = sc;
    ctx->geo = g;
    ctx->cam = &r->cam;
    ctx->sm = NULL; /* the forward's shadow lookups come from r->sun_cache (classic) or the sample record */
    memset(acc, 0, sizeof(*acc));
    acc->g_albedo = gr->albedo;
    acc->g_pd = g->g_pd;
    acc->g_nd = g->g_nd;
    acc->g_xc = g->g_xc;
}

void render_backward_finish(sp_renderer *r, const sp_render_scene *sc, const shade_ctx *ctx, const shade_acc *acc,
                            double g_exposure, sp_render_grads *gr)
{
    render_geom *g = &r->geo;
    gr->exposure += g_exposure;
    camera_backward(r, sc, acc, gr);
    if (gr->positions || gr->displacement)
        geom_backward(g, sc->mesh, &sc->displacement, gr->positions, sc->displacement.data ? gr->displacement : NULL);
    if (gr->env) {
        double gL[3][ENV_SH_N];
        env_weights_backward(acc->gY, gL);
        env_project_backward(r->env_basis, gL, gr->env);
    }
    scalars_backward(ctx, acc, gr);
}

int render_backward_pass(sp_renderer *r, const sp_render_scene *sc, const float *dL, sp_render_grads *gr)
{
    shade_ctx ctx;
    shade_acc acc;
    render_backward_begin(r, sc, gr, &ctx, &acc);
    double g_exposure = 0.0;
    samples_backward(r, &ctx, dL, &acc, &g_exposure);
    render_backward_finish(r, sc, &ctx, &acc, g_exposure, gr);
    return 0;
}
