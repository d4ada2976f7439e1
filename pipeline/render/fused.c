/* SPDX-License-Identifier: MIT */
/*
 * The fused fitting step (sp_render_fit_l2): one sweep over pixels that
 * shades a pixel's samples, resolves and tone-maps the pixel, takes the
 * pixel-local L2 loss and its gradient, and runs the adjoint of the samples
 * while their surface reconstruction is still in the sample records. Compared
 * with sp_render + sp_render_l2_loss + sp_render_backward it saves the second
 * surface reconstruction and SH evaluation per sample, the decomposition
 * buffers and two full-image sweeps. The arithmetic and its order match the
 * classic path, so the loss is bit-identical.
 */
#include "sunprobe/sp_render.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <string.h>

#include "pipeline/render/adjoint.h"
#include "pipeline/render/render_internal.h"
#include "pipeline/render/shade_simd.h"
#include "pipeline/render/tonemap.h"
#include "pipeline/render/vec3.h"

typedef struct fused_state {
    const float *target, *mask;
    double norm;           /* max(sum of the mask, 1e-12), as sp_render_l2_loss */
    double bg_img[3], bg_deriv[3]; /* display value of an uncovered pixel and its tone-map slope */
    double bg_rad[3];      /* its radiance, 0 + 1 * background as resolve_pixel sums it */
    float bg_rad_f[3], bg_img_f[3]; /* the float outputs of the above */
    double inv_s2;         /* 1 / S^2 */
    double loss_sum;
    double g_exposure;
    shade_ctx ctx;         /* adjoint's copy of the frame constants */
    shade_acc acc;
    int want_grads;
    simd_frame sf;         /* fit_float: the frame constants in float */
    simd_acc sacc;         /* and the kernels' frame sums */
} fused_state;

/* Shades the S x S samples of pixel (px, py) into r->recs; returns how many; adds them to rad and coverage. */
static int shade_pixel(sp_renderer *r, int px, int py, double rad[3])
{
    const shade_ctx *ctx = &r->ctx;
    int S = r->set.supersample, n = 0;
    double w = 1.0 / (double)(S * S);
    size_t p = (size_t)py * (size_t)r->set.width + (size_t)px;
    r->coverage[p] = 0.0f;
    for (int j = 0; j < S; j++)
        for (int k = 0; k < S; k++) {
            int sx = px * S + k, sy = py * S + j;
            size_t s = (size_t)sy * (size_t)r->sw + (size_t)sx;
            r->shadow_texel[s] = -1;
            shade_rec *rec = r->recs + n;
            if (r->tri_id[s] < 0) {
                r->depth[s] = 0.0f;
                continue;
            }
            if (!shade_geometry(ctx, sx, sy, r->tri_id[s], rec)) { /* degenerate hit: uncovered, as sp_render */
                r->tri_id[s] = -1;
                r->depth[s] = 0.0f;
                continue;
            }
            shade_ambient_full(ctx, rec);
            shade_sun(ctx, rec, ctx->sun_l, ctx->sun_I, ctx->sm, r->sun_cache + s);
            r->shadow_texel[s] = rec->shadow.texel;
            for (int c = 0; c < 3; c++) { /* the order of sp_render's accumulate_base / accumulate_sun */
                rad[c] += w * (rec->amb[c] + rec->fill[c]);
                rad[c] += w * (rec->diff[c] + rec->spec);
            }
            r->coverage[p] += (float)w;
            n++;
        }
    return n;
}

/*
 * Resolves pixel p from its sample sum, adds its loss term and returns
 * dL/d(display value) in dl and the tone map's slope at the pixel in tm_d.
 */
static void resolve_pixel(sp_renderer *r, const sp_render_scene *sc, fused_state *st, size_t p, double rad[3],
                          float dl[3], double tm_d[3])
{
    double bgw = 1.0 - (double)r->coverage[p];
    double m = st->mask ? (double)st->mask[p] : 1.0;
    for (int c = 0; c < 3; c++) {
        size_t i = p * 3 + (size_t)c;
        if (bgw > 0.0)
            rad[c] += bgw * sc->background[c];
        r->radiance64[i] = rad[c];
        if (bgw == 1.0) {
            r->image64[i] = st->bg_img[c];
            tm_d[c] = st->bg_deriv[c];
        } else {
            r->image64[i] = tonemap_eval(sc->exposure * rad[c], &tm_d[c]);
        }
        r->radiance[i] = to_float(rad[c]);
        r->image[i] = to_float(r->image64[i]);
        double d = (double)r->image[i] - (double)st->target[i];
        st->loss_sum += m * d * d; /* sp_render_l2_loss's order: the same sum bit for bit */
        dl[c] = to_float(2.0 * m * d / st->norm);
    }
}

/* render_pixel_adjoint with the slope the forward tone map returned (the same formula, no second pass). */
static int pixel_grad(const sp_render_scene *sc, const fused_state *st, const float dl[3], const double rad[3],
                      const double tm_d[3], double gc[3], double *g_exposure)
{
    double e = sc->exposure, any = 0.0;
    for (int c = 0; c < 3; c++) {
        double g = (double)dl[c];
        gc[c] = 0.0;
        if (g == 0.0)
            continue;
        double gx = g * tm_d[c];
        *g_exposure += gx * rad[c];
        gc[c] = gx * e * st->inv_s2;
        any += fabs(gc[c]);
    }
    return any > 0.0;
}

/*
 * resolve_pixel + pixel_grad for a pixel without covered samples (about half
 * of a portrait frame): the radiance, display value and slope are the
 * background's, precomputed once; only the loss term and the exposure
 * gradient depend on the pixel. Same arithmetic as the general path.
 */
static void background_pixel(sp_renderer *r, fused_state *st, size_t p)
{
    double m = st->mask ? (double)st->mask[p] : 1.0;
    for (int c = 0; c < 3; c++) {
        size_t i = p * 3 + (size_t)c;
        r->radiance64[i] = st->bg_rad[c];
        r->image64[i] = st->bg_img[c];
        r->radiance[i] = st->bg_rad_f[c];
        r->image[i] = st->bg_img_f[c];
        double d = (double)st->bg_img_f[c] - (double)st->target[i];
        st->loss_sum += m * d * d;
        if (!st->want_grads)
            continue;
        double g = (double)to_float(2.0 * m * d / st->norm);
        if (g != 0.0)
            st->g_exposure += g * st->bg_deriv[c] * st->bg_rad[c];
    }
}

static void fused_sweep(sp_renderer *r, const sp_render_scene *sc, fused_state *st)
{
    for (int py = 0; py < r->set.height; py++)
        for (int px = 0; px < r->set.width; px++) {
            size_t p = (size_t)py * (size_t)r->set.width + (size_t)px;
            double rad[3] = {0.0, 0.0, 0.0}, gc[3], tm_d[3];
            float dl[3];
            int n = shade_pixel(r, px, py, rad);
            if (n == 0) {
                background_pixel(r, st, p);
                continue;
            }
            resolve_pixel(r, sc, st, p, rad, dl, tm_d);
            if (!st->want_grads || !pixel_grad(sc, st, dl, rad, tm_d, gc, &st->g_exposure))
                continue;
            for (int k = 0; k < n; k++)
                shade_backward(&st->ctx, r->recs + k, gc, &st->acc);
        }
}

/*
 * fit_float path: the sample's kernel inputs into lane i of batch b. Until
 * the forward kernel ran, rec->shadow.dVdp holds dz/dp (shadow_eval_z).
 */
static void load_sample(const shade_ctx *ctx, shade_rec *rec, simd_batch *b, int i)
{
    double z = -1e30;
    v3_zero(rec->shadow.dVdp);
    rec->shadow.texel = -1;
    if (ctx->sm)
        shadow_eval_z(ctx->sm, ctx->shadow_k, ctx->shadow_b, rec->p, &z, rec->shadow.dVdp, &rec->shadow.texel);
    z = z < -1e30 ? -1e30 : (z > 1e30 ? 1e30 : z); /* NaN stays NaN: the kernel's clamps map it to a bound */
    b->nx[i] = (float)rec->n[0], b->ny[i] = (float)rec->n[1], b->nz[i] = (float)rec->n[2];
    b->vx[i] = (float)rec->v[0], b->vy[i] = (float)rec->v[1], b->vz[i] = (float)rec->v[2];
    for (int c = 0; c < 3; c++)
        b->a[c][i] = (float)rec->a[c];
    int cl = rec->cluster;
    b->ks[i] = cl >= 0 ? (float)ctx->ks[cl] : 0.0f;
    b->s[i] = cl >= 0 ? (float)ctx->s[cl] : 1.0f;
    b->z[i] = (float)z;
}

/*
 * fit_float: reconstructs the covered samples of pixels px0, px0 + 1, ... of
 * row py into r->recs and the batch until the next pixel would overflow it
 * (S^2 <= SIMD_BATCH, so at least one pixel); returns the end pixel and the
 * sample count in *n_out; at most SIMD_BATCH pixels. r->row_first[i] is
 * pixel px0 + i's first record.
 */
static int gather_chunk(sp_renderer *r, int py, int px0, int *n_out)
{
    const shade_ctx *ctx = &r->ctx;
    int S = r->set.supersample, n = 0, px = px0;
    double w = 1.0 / (double)(S * S);
    /* at most SIMD_BATCH pixels (row_first's size), covered or not */
    for (; px < r->set.width && px - px0 < SIMD_BATCH && (n == 0 || n + S * S <= SIMD_BATCH); px++) {
        size_t p = (size_t)py * (size_t)r->set.width + (size_t)px;
        r->row_first[px - px0] = n;
        r->coverage[p] = 0.0f;
        for (int j = 0; j < S; j++)
            for (int k = 0; k < S; k++) {
                int sx = px * S + k, sy = py * S + j;
                size_t s = (size_t)sy * (size_t)r->sw + (size_t)sx;
                r->shadow_texel[s] = -1;
                if (r->tri_id[s] < 0 || !shade_geometry(ctx, sx, sy, r->tri_id[s], r->recs + n)) {
                    r->tri_id[s] = -1; /* negative already, or a degenerate hit: uncovered, as sp_render */
                    r->depth[s] = 0.0f;
                    continue;
                }
                load_sample(ctx, r->recs + n, r->batches, n);
                r->shadow_texel[s] = r->recs[n].shadow.texel;
                r->coverage[p] += (float)w;
                n++;
            }
    }
    r->row_first[px - px0] = n;
    *n_out = n;
    return px;
}

/* Sample k's radiance into rad (weight w); finishes dV/dp and the sun cache the classic adjoint may replay. */
static void take_sample(sp_renderer *r, int k, double w, double rad[3])
{
    const simd_batch *b = r->batches + k / SIMD_BATCH;
    int i = k % SIMD_BATCH;
    shade_rec *rec = r->recs + k;
    for (int c = 0; c < 3; c++)
        rad[c] += w * (double)b->rad[c][i];
    sun_cache *sc = r->sun_cache + (size_t)rec->sy * (size_t)r->sw + (size_t)rec->sx;
    sc->V = b->V[i];
    for (int d = 0; d < 3; d++) {
        rec->shadow.dVdp[d] *= (double)b->dVdz[i];
        sc->dVdp[d] = to_float(rec->shadow.dVdp[d]);
    }
    sc->P = b->P[i];
    sc->log_nh = b->P[i] > 0.0f ? b->lnh[i] : 0.0f;
}

/* fit_float: resolves pixels [px0, px1) of row py, their loss and dL/d(sample radiance) into the batch's gc. */
static void resolve_chunk(sp_renderer *r, const sp_render_scene *sc, fused_state *st, int py, int px0, int px1)
{
    double w = st->inv_s2;
    for (int px = px0; px < px1; px++) {
        size_t p = (size_t)py * (size_t)r->set.width + (size_t)px;
        int k0 = r->row_first[px - px0], k1 = r->row_first[px - px0 + 1];
        if (k0 == k1) {
            background_pixel(r, st, p);
            continue;
        }
        double rad[3] = {0.0, 0.0, 0.0}, gc[3] = {0.0, 0.0, 0.0}, tm_d[3];
        float dl[3];
        for (int k = k0; k < k1; k++)
            take_sample(r, k, w, rad);
        resolve_pixel(r, sc, st, p, rad, dl, tm_d);
        if (st->want_grads && !pixel_grad(sc, st, dl, rad, tm_d, gc, &st->g_exposure))
            gc[0] = gc[1] = gc[2] = 0.0;
        for (int k = k0; k < k1; k++)
            for (int c = 0; c < 3; c++)
                r->batches[k / SIMD_BATCH].gc[c][k % SIMD_BATCH] = to_float(gc[c]);
    }
}

/* fit_float: the kernel's per-sample adjoints through the surface, in double. */
static void scatter_chunk(sp_renderer *r, fused_state *st, int n)
{
    for (int k = 0; k < n; k++) {
        const simd_batch *b = r->batches + k / SIMD_BATCH;
        int i = k % SIMD_BATCH;
        if (b->gc[0][i] == 0.0f && b->gc[1][i] == 0.0f && b->gc[2][i] == 0.0f)
            continue;
        const shade_rec *rec = r->recs + k;
        sample_grad sg;
        for (int d = 0; d < 3; d++) {
            sg.a[d] = (double)b->ga[d][i];
            sg.n[d] = (double)b->gn[d][i];
            sg.v[d] = (double)b->gv[d][i];
            sg.p[d] = (double)b->gV[i] * rec->shadow.dVdp[d];
        }
        int cl = rec->cluster;
        if (cl >= 0) {
            st->acc.g_ks[cl] += (double)b->gks[i];
            if (!st->ctx.s_clamped[cl])
                st->acc.g_s[cl] += (double)b->gs[i];
        }
        shade_backward_surface(&st->ctx, rec, &sg, &st->acc);
    }
}

static void fused_sweep_float(sp_renderer *r, const sp_render_scene *sc, fused_state *st)
{
    simd_batch *b = r->batches;
    simd_frame_init(&st->sf, r->ctx.sun_l, r->ctx.sun_I, &r->ctx.sh);
    for (int py = 0; py < r->set.height; py++)
        for (int px0 = 0, px1; px0 < r->set.width; px0 = px1) {
            px1 = gather_chunk(r, py, px0, &b->n);
            simd_batch_pad(b);
            simd_shade_forward(&st->sf, b);
            resolve_chunk(r, sc, st, py, px0, px1);
            if (!st->want_grads)
                continue;
            simd_shade_backward(&st->sf, b, &st->sacc);
            scatter_chunk(r, st, b->n);
        }
    for (int c = 0; c < 3; c++) {
        st->acc.g_l[c] += st->sacc.gl[c];
        for (int j = 0; j < ENV_SH_N; j++)
            st->acc.gY[c][j] += st->sacc.gY[c][j];
    }
    st->acc.g_I += st->sacc.gI;
}

static int fit_args_ok(const sp_renderer *r, const sp_render_scene *sc, const float *target, const double *loss)
{
    return r && sc && target && loss;
}

int sp_render_fit_l2(sp_renderer *r, const sp_render_scene *sc, const float *target, const float *mask,
                     double *loss, sp_render_grads *grads, sp_render_outputs *out)
{
    if (!fit_args_ok(r, sc, target, loss))
        return -EINVAL;
    int n_sun = 1;
    int err = render_begin(r, sc, 1, &n_sun);
    if (err)
        return err;
    fused_state st;
    memset(&st, 0, sizeof(st));
    st.target = target;
    st.mask = mask;
    double msum = 0.0;
    for (size_t p = 0; p < r->npix; p++)
        msum += mask ? (double)mask[p] : 1.0;
    st.norm = msum > 1e-12 ? msum : 1e-12;
    for (int c = 0; c < 3; c++) {
        st.bg_rad[c] = 0.0 + 1.0 * sc->background[c];
        st.bg_img[c] = tonemap_eval(sc->exposure * st.bg_rad[c], &st.bg_deriv[c]);
        st.bg_rad_f[c] = to_float(st.bg_rad[c]);
        st.bg_img_f[c] = to_float(st.bg_img[c]);
    }
    st.inv_s2 = 1.0 / (double)(r->set.supersample * r->set.supersample);
    r->ctx.sm = render_prepare_shadow(r, sc, r->ctx.sun_l, 0);
    r->out_diffuse = r->out_specular = r->out_ambient = r->out_fill = NULL;
    r->out_visibility = r->out_normal = r->out_albedo = NULL;
    st.want_grads = grads != NULL;
    if (grads)
        render_backward_begin(r, sc, grads, &st.ctx, &st.acc);
    if (r->set.fit_float)
        fused_sweep_float(r, sc, &st);
    else
        fused_sweep(r, sc, &st);
    if (grads)
        render_backward_finish(r, sc, &st.ctx, &st.acc, st.g_exposure, grads);
    *loss = st.loss_sum / st.norm;
    if (out)
        render_fill_outputs(r, out);
    render_end(r, sc, n_sun);
    return 0;
}
