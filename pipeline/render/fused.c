/* SPDX-License-Identifier: MIT */
/*
 * The fused fitting step (sp_render_fit_l2): one sweep over pixels that
 * shades a pixel's samples, resolves and tone-maps the pixel, takes the
 * pixel-local L2 loss and its gradient, and runs the adjoint of the samples
 * while their surface reconstruction is still in the sample records. Compared
 * with sp_render + sp_render_l2_loss + sp_render_backward it saves the second
 * surface reconstruction and SH evaluation per sample, the decomposition
 * buffers and two full-image sweeps. The arithmetic and its order match the
 * classic path, so the loss is bit-identical. settings.fit_float runs the
 * same sweep on batches of samples through the float SoA kernels
 * (surf_simd.h, shade_simd.h; OPTIMISATION-LOG.md "Fourth pass").
 */
#include "sunprobe/sp_render.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <string.h>

#include "pipeline/render/adjoint.h"
#include "pipeline/render/render_internal.h"
#include "pipeline/render/shade_simd.h"
#include "pipeline/render/simd_kernels.h"
#include "pipeline/render/surf_gather.h"
#include "pipeline/render/surf_simd.h"
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
    surf_frame sfr;        /* fit_float: the surface / resolve kernels' constants */
    resolve_acc racc;      /* and the S = 1 resolve's frame sums */
    surf_acc surfacc;      /* and the surface adjoint's (the pose sums go to grads after the finish) */
    double bg_md[3];       /* fit_float: sum over uncovered pixels of m (display - target) */
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
 * fit_float: gathers the covered samples of pixels px0, px0 + 1, ... of row
 * py into the batch until the next pixel would overflow it (S^2 <=
 * SIMD_BATCH, so at least one pixel); returns the end pixel; sets b->n. At
 * most SIMD_BATCH pixels; r->row_first[i] is pixel px0 + i's first lane.
 */
static int gather_chunk(sp_renderer *r, int py, int px0, simd_batch *b)
{
    gather_frame f;
    gather_rec rec;
    gather_frame_init(&f, &r->ctx);
    const double *dx = r->geo.col_dx, *dy = r->geo.col_dx + r->cam.sample_width; /* the rasteriser's rays */
    int S = r->set.supersample, n = 0, px = px0;
    float w = 1.0f / (float)(S * S);
    for (; px < r->set.width && px - px0 < SIMD_BATCH && (n == 0 || n + S * S <= SIMD_BATCH); px++) {
        size_t p = (size_t)py * (size_t)r->set.width + (size_t)px;
        r->row_first[px - px0] = n;
        r->coverage[p] = 0.0f;
        for (int j = 0; j < S; j++)
            for (int k = 0; k < S; k++) {
                int sx = px * S + k, sy = py * S + j;
                size_t s = (size_t)sy * (size_t)r->sw + (size_t)sx;
                r->shadow_texel[s] = -1;
                int32_t tri = r->tri_id[s];
                if (tri < 0 || !gather_cover(&f, dx[sx], dy[sy], tri, &rec, n)) {
                    r->tri_id[s] = -1; /* negative already, or a degenerate hit: uncovered, as sp_render */
                    r->depth[s] = 0.0f;
                    continue;
                }
                b->surf.pix[n] = (int32_t)p;
                b->surf.samp[n] = (int32_t)s;
                r->coverage[p] += w;
                n++;
            }
    }
    r->row_first[px - px0] = n;
    gather_lanes(&f, &rec, b, n);
    b->n = n;
    return px;
}

/* fit_float: an uncovered pixel's loss terms (they depend only on target and mask) into acc (loss, then the
 * three sums of m (display - target) for the exposure gradient at the end); outputs if asked. */
static inline void background_pixel_f(sp_renderer *r, const fused_state *st, size_t p, int want_out, double acc[4])
{
    double m = st->mask ? (double)st->mask[p] : 1.0;
    const float *t = st->target + p * 3;
    for (int c = 0; c < 3; c++) {
        double d = (double)st->bg_img_f[c] - (double)t[c], md = m * d;
        acc[0] += md * d;
        acc[1 + c] += md;
    }
    if (want_out)
        for (int c = 0; c < 3; c++) {
            r->radiance[p * 3 + (size_t)c] = st->bg_rad_f[c];
            r->image[p * 3 + (size_t)c] = st->bg_img_f[c];
        }
}

static void background_add(fused_state *st, const double acc[4])
{
    st->loss_sum += acc[0];
    for (int c = 0; c < 3; c++)
        st->bg_md[c] += acc[1 + c];
}

/* fit_float, S = 1 (sample = pixel): gather_chunk without the pixel bookkeeping; uncovered pixels' loss terms inline. */
static int gather_chunk_s1(sp_renderer *r, fused_state *st, int py, int px, simd_batch *b, int want_out)
{
    gather_frame f;
    gather_rec rec;
    gather_frame_init(&f, &r->ctx);
    int n = 0, W = r->set.width;
    /* the rays: the rasteriser's table (raster_sample_ray's values, the ones coverage was decided with) */
    const double *dx = r->geo.col_dx, dy = r->geo.col_dx[r->cam.sample_width + py];
    double acc[4] = {0.0, 0.0, 0.0, 0.0};
    for (; px < W && n < SIMD_BATCH; px++) {
        size_t p = (size_t)py * (size_t)W + (size_t)px;
        int32_t tri = r->tri_id[p];
        r->shadow_texel[p] = -1;
        if (tri >= 0 && gather_cover(&f, dx[px], dy, tri, &rec, n)) {
            b->surf.pix[n] = b->surf.samp[n] = (int32_t)p;
            n++;
            r->coverage[p] = 1.0f;
            continue;
        }
        r->tri_id[p] = -1; /* negative already, or a degenerate hit: uncovered, as sp_render */
        r->depth[p] = 0.0f;
        r->coverage[p] = 0.0f;
        background_pixel_f(r, st, p, want_out, acc);
    }
    background_add(st, acc);
    gather_lanes(&f, &rec, b, n);
    b->n = n;
    return px;
}

/* fit_float, S = 1: every lane is one fully covered pixel; float tone map, loss and gc in surf_resolve_l2. */
static void resolve_chunk_s1(sp_renderer *r, fused_state *st, simd_batch *b, int want_out)
{
    surf_batch *s = &b->surf;
    for (int i = 0; i < b->n; i++) {
        size_t p = (size_t)s->pix[i];
        const float *t = st->target + p * 3;
        s->tgt[0][i] = t[0], s->tgt[1][i] = t[1], s->tgt[2][i] = t[2];
        s->msk[i] = st->mask ? st->mask[p] : 1.0f;
    }
    r->simd->resolve_l2(&st->sfr, b, &st->racc);
    if (!want_out)
        return;
    for (int i = 0; i < b->n; i++)
        for (int c = 0; c < 3; c++) {
            size_t q = (size_t)s->pix[i] * 3 + (size_t)c;
            r->image[q] = s->img[c][i];
            r->radiance[q] = b->rad[c][i];
        }
}

/* fit_float, S > 1: pixels [px0, px1) of row py resolved in double (resolve_pixel without the double twins). */
static void resolve_chunk(sp_renderer *r, const sp_render_scene *sc, fused_state *st, simd_batch *b, int py,
                          int px0, int px1, int want_out)
{
    for (int px = px0; px < px1; px++) {
        size_t p = (size_t)py * (size_t)r->set.width + (size_t)px;
        int k0 = r->row_first[px - px0], k1 = r->row_first[px - px0 + 1];
        if (k0 == k1) {
            double acc[4] = {0.0, 0.0, 0.0, 0.0};
            background_pixel_f(r, st, p, want_out, acc);
            background_add(st, acc);
            continue;
        }
        double rad[3] = {0.0, 0.0, 0.0}, gc[3] = {0.0, 0.0, 0.0}, tm_d[3];
        double bgw = 1.0 - (double)r->coverage[p], m = st->mask ? (double)st->mask[p] : 1.0;
        float dl[3];
        for (int c = 0; c < 3; c++) {
            for (int k = k0; k < k1; k++)
                rad[c] += st->inv_s2 * (double)b->rad[c][k];
            rad[c] += bgw * sc->background[c];
            float img = to_float(tonemap_eval(sc->exposure * rad[c], &tm_d[c]));
            double d = (double)img - (double)st->target[p * 3 + (size_t)c];
            st->loss_sum += m * d * d;
            dl[c] = to_float(2.0 * m * d / st->norm);
            if (want_out) {
                r->image[p * 3 + (size_t)c] = img;
                r->radiance[p * 3 + (size_t)c] = to_float(rad[c]);
            }
        }
        if (st->want_grads && !pixel_grad(sc, st, dl, rad, tm_d, gc, &st->g_exposure))
            gc[0] = gc[1] = gc[2] = 0.0;
        for (int k = k0; k < k1; k++)
            for (int c = 0; c < 3; c++)
                b->gc[c][k] = (float)gc[c];
    }
}

static void surf_frame_setup(const sp_renderer *r, const sp_render_scene *sc, fused_state *st)
{
    surf_frame *f = &st->sfr;
    f->tex_w = sc->albedo.width;
    f->tex_h = sc->albedo.height;
    f->inv_fx = r->cam.inv_fx;
    f->inv_fy = r->cam.inv_fy;
    for (int k = 0; k < 9; k++)
        f->R[k] = (float)sc->camera.R[k];
    for (int k = 0; k < 3; k++)
        f->eye[k] = (float)r->ctx.eye[k];
    f->exposure = (float)sc->exposure;
    f->toe_slope = (float)pow(TONEMAP_TOE, 1.0 / TONEMAP_GAMMA - 1.0);
    f->two_over_norm = (float)(2.0 / st->norm);
}

/*
 * fit_float: chunks of a row, each one batch: gather (scalar), surface and
 * shading kernels, resolve + loss, adjoint kernels, scatter (scalar). Writes
 * image and radiance only when the caller asked for outputs; never the
 * double twins or the sun cache (sp_render_backward is refused after it).
 */
static void fused_sweep_float(sp_renderer *r, const sp_render_scene *sc, fused_state *st, int want_out)
{
    simd_batch *b = r->batches;
    const simd_kernels *k = r->simd;
    int s1 = r->set.supersample == 1;
    surf_acc *sacc = &st->surfacc;
    simd_frame_init(&st->sf, r->ctx.sun_l, r->ctx.sun_I, &r->ctx.sh);
    surf_frame_setup(r, sc, st);
    for (int py = 0; py < r->set.height; py++)
        for (int px0 = 0, px1; px0 < r->set.width; px0 = px1) {
            px1 = s1 ? gather_chunk_s1(r, st, py, px0, b, want_out) : gather_chunk(r, py, px0, b);
            if (b->n == 0) {
                if (!s1)
                    resolve_chunk(r, sc, st, b, py, px0, px1, want_out);
                continue;
            }
            k->batch_pad(b);
            k->surf_batch_pad(&b->surf, b->n);
            k->surf_forward_a(&st->sfr, b);
            k->surf_shadow(&r->ctx, st->sf.l, b, r->shadow_texel);
            k->surf_gather_texels(b, sc->albedo.data);
            k->surf_forward_b(b);
            k->shade_forward(&st->sf, b);
            if (s1)
                resolve_chunk_s1(r, st, b, want_out);
            else
                resolve_chunk(r, sc, st, b, py, px0, px1, want_out);
            if (!st->want_grads)
                continue;
            k->shade_backward(&st->sf, b, &st->sacc);
            k->surf_backward(&st->sfr, b, sacc);
            k->surf_scatter(&st->ctx, b, &st->acc);
        }
    for (int c = 0; c < 3; c++) {
        st->acc.g_l[c] += st->sacc.gl[c];
        st->acc.g_eye[c] += sacc->g_eye[c];
        for (int j = 0; j < ENV_SH_N; j++)
            st->acc.gY[c][j] += st->sacc.gY[c][j];
        /* uncovered pixels: sum_p to_float(2 m d / norm) ~ 2 / norm sum_p m d */
        st->g_exposure += 2.0 / st->norm * st->bg_md[c] * st->bg_deriv[c] * st->bg_rad[c];
    }
    st->acc.g_I += st->sacc.gI;
    st->acc.g_fx += sacc->g_fx, st->acc.g_fy += sacc->g_fy, st->acc.g_cx += sacc->g_cx, st->acc.g_cy += sacc->g_cy;
    st->loss_sum += st->racc.loss;
    st->g_exposure += st->racc.g_exposure;
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
    int err = render_begin(r, sc, 1, !r->set.fit_float, &n_sun);
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
        fused_sweep_float(r, sc, &st, out != NULL);
    else
        fused_sweep(r, sc, &st);
    if (grads)
        render_backward_finish(r, sc, &st.ctx, &st.acc, st.g_exposure, grads);
    if (grads && r->set.fit_float) /* the camera-space vertex adjoints, folded into the kernels' pose sums */
        for (int k = 0; k < 9; k++) {
            grads->camera_R[k] += st.surfacc.g_R[k];
            if (k < 3)
                grads->camera_t[k] += st.surfacc.g_t[k];
        }
    *loss = st.loss_sum / st.norm;
    if (out) {
        render_fill_outputs(r, out);
        if (r->set.fit_float)
            out->bary = NULL; /* not computed (render_begin) */
    }
    render_end(r, sc, n_sun);
    if (r->set.fit_float)
        r->have_render = 0; /* no double twins or sun cache: sp_render_backward needs an sp_render first */
    return 0;
}
