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
    raster_tri_weights(g->xc + (size_t)rec->vi[0] * 3, g->xc + (size_t)rec->vi[1] * 3,
                       g->xc + (size_t)rec->vi[2] * 3, rec->d, rec->w, &rec->wsum);
    if (!(fabs(rec->wsum) > 0.0) || !isfinite(rec->wsum))
        return 0;
    v3_zero(rec->p);
    v3_zero(rec->m);
    rec->uv[0] = rec->uv[1] = 0.0;
    for (int i = 0; i < 3; i++) {
        double l = rec->w[i] / rec->wsum;
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
    return 1;
}

void shade_ambient(const shade_ctx *ctx, shade_rec *rec)
{
    env_irradiance(&ctx->sh, rec->n, rec->E, NULL);
    for (int c = 0; c < 3; c++)
        rec->amb[c] = rec->a[c] / SHADE_PI * rec->E[c];
}

/* (n.h)^s into b->P for light l, exponent s; P = 0 when l + v vanishes (l opposite the view). */
static void blinn(const shade_rec *rec, const double l[3], double s, blinn_state *b)
{
    for (int i = 0; i < 3; i++)
        b->hs[i] = l[i] + rec->v[i];
    b->hlen = v3_normalize(b->hs, b->h);
    b->nh_clamped = 1;
    b->nh = SHADE_NH_MIN;
    b->P = 0.0;
    if (!(b->hlen > 1e-12))
        return;
    double nh = v3_dot(rec->n, b->h);
    b->nh_clamped = !(nh >= SHADE_NH_MIN && nh <= 1.0);
    b->nh = nh < SHADE_NH_MIN ? SHADE_NH_MIN : (nh > 1.0 ? 1.0 : nh);
    /* s >= 1 and nh in (0, 1]: the exponent is <= 0, so exp never overflows */
    b->P = exp(s * log(b->nh));
}

void shade_sun(const shade_ctx *ctx, shade_rec *rec, const double l[3], double I, const shadow_map *sm)
{
    rec->nl = v3_dot(rec->n, l);
    rec->V = 1.0;
    rec->spec_on = 0;
    v3_zero(rec->shadow.dVdp);
    rec->shadow.texel = -1;
    if (sm) {
        shadow_eval(sm, ctx->shadow_k, ctx->shadow_b, rec->p, &rec->shadow);
        rec->V = rec->shadow.V;
    }
    if (!(rec->nl > 0.0))
        return;
    double lit = I * rec->nl * rec->V;
    for (int c = 0; c < 3; c++)
        rec->diff[c] += rec->a[c] / SHADE_PI * lit;
    if (rec->cluster < 0 || ctx->ks[rec->cluster] == 0.0)
        return;
    rec->spec_on = 1;
    double s = ctx->s[rec->cluster];
    blinn(rec, l, s, &rec->bl);
    rec->spec += ctx->ks[rec->cluster] * (s + 2.0) / (2.0 * SHADE_PI) * rec->bl.P * lit;
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
