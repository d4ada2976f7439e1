/* SPDX-License-Identifier: MIT */
/*
 * surf_gather's body (surf_simd.h), inline: the fit_float sweep (fused.c)
 * calls it once per covered sample, and a call per sample reloaded the
 * frame constants and paid the call. Private to pipeline/render.
 */
#ifndef SUNPROBE_RENDER_SURF_GATHER_H
#define SUNPROBE_RENDER_SURF_GATHER_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "pipeline/render/raster.h"
#include "pipeline/render/shade_simd.h"
#include "pipeline/render/shading.h"
#include "pipeline/render/surf_simd.h"
#include "pipeline/render/vec3.h"

/* tex_nearest_u8 (texture.c), the same arithmetic, inline (one call per sample otherwise). */
static inline int gather_nearest_i(double x, int n)
{
    return !(x > 0.0) ? 0 : (x >= (double)(n - 1) ? n - 1 : (int)x);
}

static inline uint8_t gather_nearest_u8(const uint8_t *data, int width, int height, double u, double v)
{
    int i = gather_nearest_i(u * width, width), j = gather_nearest_i((1.0 - v) * height, height);
    return data[(size_t)j * (size_t)width + (size_t)i];
}

/* The cluster at uv as shade_geometry: nearest id, -1 (no specular) for ids >= SP_RENDER_CLUSTERS. */
static inline int gather_cluster_at(const shade_ctx *ctx, const double uv[2])
{
    const sp_render_cluster_map *cm = &ctx->sc->clusters;
    if (!cm->data)
        return 0;
    uint8_t id = gather_nearest_u8(cm->data, cm->width, cm->height, uv[0], uv[1]);
    return id < SP_RENDER_CLUSTERS ? (int)id : -1;
}

/*
 * surf_gather. The hit point, UV and cluster use shade_geometry's double arithmetic (the shadow lookup is in
 * surf_shadow). always_inline: GCC keeps a function this size out of line otherwise (then no gain).
 */
__attribute__((always_inline)) static inline int surf_gather_at(const shade_ctx *ctx, int sx, int sy, int32_t tri,
                                                                simd_batch *b, int i)
{
    const sp_mesh *mesh = ctx->sc->mesh;
    const render_geom *g = ctx->geo;
    surf_batch *s = &b->surf;
    const double *k = g->tri_k + (size_t)tri * 9;
    double d[3], w[3];
    raster_sample_ray(ctx->cam, sx, sy, d);
    double wsum = raster_weights(k, d, w);
    if (!(fabs(wsum) > 0.0) || !isfinite(wsum))
        return 0;
    double inv_wsum = 1.0 / wsum, p[3] = {0.0, 0.0, 0.0}, uv[2] = {0.0, 0.0}, lam[3];
    size_t vid[3];
    const float *uvp[3];
    for (int v = 0; v < 3; v++) {
        vid[v] = mesh->tri_vertices[(size_t)tri * 3 + (size_t)v];
        uvp[v] = mesh->uvs + (size_t)mesh->tri_uvs[(size_t)tri * 3 + (size_t)v] * 2;
        lam[v] = w[v] * inv_wsum;
        v3_axpy(lam[v], g->pd + vid[v] * 3, p);
        uv[0] += lam[v] * (double)uvp[v][0];
        uv[1] += lam[v] * (double)uvp[v][1];
    }
    for (int v = 0; v < 3; v++) {
        s->vtx[v][i] = (int32_t)vid[v];
        s->lam[v][i] = (float)lam[v];
        for (int a = 0; a < 3; a++) { /* relative to p: the kernel's dot products then cancel less */
            s->dp[v][a][i] = (float)(g->pd[vid[v] * 3 + (size_t)a] - p[a]);
            s->nd[v][a][i] = g->ndf[vid[v] * 3 + (size_t)a];
        }
        s->uvv[v][0][i] = (float)((double)uvp[v][0] - uv[0]);
        s->uvv[v][1][i] = (float)((double)uvp[v][1] - uv[1]);
        s->ev[v][i] = (float)(ctx->eye[v] - p[v]);
    }
    /* |1 / sum w| beyond float range only for sub-micron slivers: clamped so the adjoint stays finite */
    double iw = inv_wsum < -1e30 ? -1e30 : (inv_wsum > 1e30 ? 1e30 : inv_wsum);
    s->d0[i] = (float)d[0], s->d1[i] = (float)d[1], s->iw[i] = (float)iw;
    s->u[i] = (float)uv[0], s->v[i] = (float)uv[1];
    int cl = gather_cluster_at(ctx, uv);
    s->cluster[i] = cl;
    b->ks[i] = cl >= 0 ? (float)ctx->ks[cl] : 0.0f;
    b->s[i] = cl >= 0 ? (float)ctx->s[cl] : 1.0f;
    for (int a = 0; a < 3; a++)
        s->pw[a][i] = p[a];
    return 1;
}

#endif
