/* SPDX-License-Identifier: MIT */
#include "pipeline/render/shading.h"

#include <math.h>
#include <string.h>

#include "pipeline/render/vec3.h"

int shade_geometry(const shade_ctx *ctx, int sx, int sy, int32_t tri, shade_rec *rec)
{
    const sp_mesh *mesh = ctx->sc->mesh;
    const render_geom *g = ctx->geo;
    rec->tri = tri;
    rec->sx = sx;
    rec->sy = sy;
    for (int i = 0; i < 3; i++) {
        rec->vi[i] = mesh->tri_vertices[(size_t)tri * 3 + (size_t)i];
        rec->ui[i] = mesh->tri_uvs[(size_t)tri * 3 + (size_t)i];
    }
    raster_sample_ray(ctx->cam, sx, sy, rec->d);
    rec->wsum = raster_weights(g->tri_k + (size_t)tri * 9, rec->d, rec->w);
    if (!(fabs(rec->wsum) > 0.0) || !isfinite(rec->wsum))
        return 0;
    v3_zero(rec->p);
    v3_zero(rec->m);
    rec->uv[0] = rec->uv[1] = 0.0;
    double inv_wsum = 1.0 / rec->wsum; /* finite and nonzero: checked above */
    for (int i = 0; i < 3; i++) {
        double l = rec->w[i] * inv_wsum;
        rec->lam[i] = l;
        v3_axpy(l, g->pd + (size_t)rec->vi[i] * 3, rec->p);
        v3_axpy(l, g->nd + (size_t)rec->vi[i] * 3, rec->m);
        const float *uv = mesh->uvs + (size_t)rec->ui[i] * 2;
        rec->uv[0] += l * (double)uv[0];
        rec->uv[1] += l * (double)uv[1];
    }
    rec->mlen = v3_normalize(rec->m, rec->n);
    v3_sub(ctx->eye, rec->p, rec->ev);
    rec->evlen = v3_normalize(rec->ev, rec->v);
    const sp_render_texture *at = &ctx->sc->albedo;
    tex_lookup_init(&rec->alb, at->width, at->height, rec->uv[0], rec->uv[1]);
    tex_sample(&rec->alb, at->data, 3, rec->a);
    const sp_render_cluster_map *cm = &ctx->sc->clusters;
    rec->cluster = 0;
    if (cm->data) {
        uint8_t id = tex_nearest_u8(cm->data, cm->width, cm->height, rec->uv[0], rec->uv[1]);
        rec->cluster = id < SP_RENDER_CLUSTERS ? (int)id : -1;
    }
    for (int c = 0; c < 3; c++)
        rec->diff[c] = rec->amb[c] = rec->fill[c] = 0.0;
    rec->spec = 0.0;
    rec->nl = 0.0;
    rec->V = 1.0;
    rec->spec_on = 0;
    rec->have_dE = 0;
    return 1;
}

void shade_ambient(const shade_ctx *ctx, shade_rec *rec)
{
    env_irradiance(&ctx->sh, rec->n, rec->E, NULL, NULL);
    for (int c = 0; c < 3; c++)
        rec->amb[c] = rec->a[c] / SHADE_PI * rec->E[c];
}

void shade_ambient_full(const shade_ctx *ctx, shade_rec *rec)
{
    env_irradiance(&ctx->sh, rec->n, rec->E, rec->dEdn, rec->y);
    rec->have_dE = 1;
    for (int c = 0; c < 3; c++)
        rec->amb[c] = rec->a[c] / SHADE_PI * rec->E[c];
}

/* Half vector and clamped n.h for light l; 0 when l + v vanishes (l opposite the view). */
static int blinn_half(const shade_rec *rec, const double l[3], blinn_state *b)
{
    for (int i = 0; i < 3; i++)
        b->hs[i] = l[i] + rec->v[i];
    b->hlen = v3_normalize(b->hs, b->h);
    b->nh_clamped = 1;
    b->nh = SHADE_NH_MIN;
    b->P = 0.0;
    b->log_nh = log(SHADE_NH_MIN);
    if (!(b->hlen > 1e-12))
        return 0;
    double nh = v3_dot(rec->n, b->h);
    b->nh_clamped = !(nh >= SHADE_NH_MIN && nh <= 1.0);
    b->nh = nh < SHADE_NH_MIN ? SHADE_NH_MIN : (nh > 1.0 ? 1.0 : nh);
    return 1;
}

/* (n.h)^s into b->P for light l, exponent s. */
static void blinn(const shade_rec *rec, const double l[3], double s, blinn_state *b)
{
    if (!blinn_half(rec, l, b))
        return;
    /* s >= 1 and nh in (0, 1]: the exponent is <= 0, so exp never overflows; a lobe tail below
     * 1e-30 is flushed to 0 so no subnormal (slow) arithmetic follows */
    b->log_nh = log(b->nh);
    double e = s * b->log_nh;
    b->P = e > -69.0 ? exp(e) : 0.0;
}

/* Lambert + normalised Blinn-Phong of the sun given rec->nl and rec->V; lobe from rec->bl. */
static void sun_terms(const shade_ctx *ctx, shade_rec *rec, double I)
{
    double lit = I * rec->nl * rec->V;
    for (int c = 0; c < 3; c++)
        rec->diff[c] += rec->a[c] / SHADE_PI * lit;
    if (rec->spec_on) {
        double s = ctx->s[rec->cluster];
        rec->spec += ctx->ks[rec->cluster] * (s + 2.0) / (2.0 * SHADE_PI) * rec->bl.P * lit;
    }
}

static int spec_active(const shade_ctx *ctx, const shade_rec *rec)
{
    return rec->cluster >= 0 && ctx->ks[rec->cluster] != 0.0;
}

void shade_sun(const shade_ctx *ctx, shade_rec *rec, const double l[3], double I, const shadow_map *sm,
               sun_cache *store)
{
    rec->nl = v3_dot(rec->n, l);
    rec->V = 1.0;
    rec->spec_on = 0;
    v3_zero(rec->shadow.dVdp);
    rec->shadow.texel = -1;
    rec->bl.P = 0.0;
    rec->bl.log_nh = 0.0;
    if (ctx->soft_sin > 0.0) { /* a soft sun: its disk sets gradually (C1 quadratic across |n.l| < sin r) */
        double sr = ctx->soft_sin, c = rec->nl;
        rec->nl = c >= sr ? c : (c > -sr ? (c + sr) * (c + sr) / (4.0 * sr) : 0.0);
        if (sm)
            rec->V = shadow_soft_eval(sm, ctx->shadow_k, ctx->shadow_b, rec->p, rec->n, ctx->soft_tan);
    } else if (sm) {
        shadow_eval(sm, ctx->shadow_k, ctx->shadow_b, rec->p, &rec->shadow);
        rec->V = rec->shadow.V;
    }
    if (rec->nl > 0.0) {
        rec->spec_on = spec_active(ctx, rec);
        if (rec->spec_on)
            blinn(rec, l, ctx->s[rec->cluster], &rec->bl);
        sun_terms(ctx, rec, I);
    }
    if (store) {
        store->V = to_float(rec->V);
        for (int i = 0; i < 3; i++)
            store->dVdp[i] = to_float(rec->shadow.dVdp[i]);
        store->P = to_float(rec->bl.P);
        store->log_nh = to_float(rec->bl.log_nh);
    }
}

void shade_sun_replay(const shade_ctx *ctx, shade_rec *rec, const sun_cache *c)
{
    rec->nl = v3_dot(rec->n, ctx->sun_l);
    rec->V = (double)c->V;
    for (int i = 0; i < 3; i++)
        rec->shadow.dVdp[i] = (double)c->dVdp[i];
    rec->spec_on = 0;
    if (!(rec->nl > 0.0))
        return;
    rec->spec_on = spec_active(ctx, rec);
    if (rec->spec_on) {
        blinn_half(rec, ctx->sun_l, &rec->bl);
        rec->bl.P = (double)c->P;
        rec->bl.log_nh = (double)c->log_nh;
    }
    sun_terms(ctx, rec, ctx->sun_I);
}

void shade_fill(const shade_ctx *ctx, shade_rec *rec)
{
    const sp_render_scene *sc = ctx->sc;
    for (int j = 0; j < sc->n_lights; j++) {
        const sp_render_light *lt = &sc->lights[j];
        double dir[3], scale = 1.0;
        if (lt->type == SP_RENDER_LIGHT_POINT) {
            double to[3];
            v3_sub(lt->vec, rec->p, to);
            double dist = v3_normalize(to, dir);
            if (!(dist > 1e-6))
                continue;
            scale = 1.0 / (dist * dist);
        } else if (!(v3_normalize(lt->vec, dir) > 0.0)) {
            continue;
        }
        double nl = v3_dot(rec->n, dir);
        if (!(nl > 0.0))
            continue;
        double spec = 0.0;
        if (rec->cluster >= 0 && ctx->ks[rec->cluster] > 0.0) {
            double s = ctx->s[rec->cluster];
            blinn_state b;
            blinn(rec, dir, s, &b);
            spec = ctx->ks[rec->cluster] * (s + 2.0) / (2.0 * SHADE_PI) * b.P;
        }
        for (int c = 0; c < 3; c++)
            rec->fill[c] += lt->rgb[c] * scale * nl * (rec->a[c] / SHADE_PI + spec);
    }
}
