/* SPDX-License-Identifier: MIT */
/*
 * surf_gather's body (surf_simd.h), inline, in two steps for the fit_float
 * sweep (fused.c): gather_cover decides each sample's coverage and records
 * it, gather_lanes then fills the batch lanes, two samples at a time on
 * vectors of two doubles. Every value written is the same bits as the
 * one-sample scalar code (gather_lane). Private to pipeline/render.
 */
#ifndef SUNPROBE_RENDER_SURF_GATHER_H
#define SUNPROBE_RENDER_SURF_GATHER_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "pipeline/render/raster.h"
#include "pipeline/render/shade_simd.h"
#include "pipeline/render/shading.h"
#include "pipeline/render/surf_simd.h"
#include "pipeline/render/vec3.h"

/*
 * The gather's frame constants, copied into a local once per chunk: the
 * batch stores (double, int32, float) may alias the shade_ctx and mesh
 * fields for the compiler, which then reloaded them every sample. ks, s:
 * the float values per cluster, converted once.
 */
typedef struct gather_frame {
    const double *tri_k, *pd;
    const float *ndf, *uvs;
    const uint32_t *tri_v, *tri_uv;
    const uint8_t *cl;            /* cluster map; NULL: cluster 0 everywhere */
    int cl_w, cl_h;
    double cl_wd, cl_hd, cl_w1, cl_h1; /* (double)w, (double)h, (double)(w - 1), (double)(h - 1) */
    double eye[3];
    float ks[SP_RENDER_CLUSTERS + 1], s[SP_RENDER_CLUSTERS + 1]; /* [cl + 1]: b->ks, b->s of cluster cl (-1: 0, 1) */
} gather_frame;

static inline void gather_frame_init(gather_frame *f, const shade_ctx *ctx)
{
    const sp_mesh *mesh = ctx->sc->mesh;
    const sp_render_cluster_map *cm = &ctx->sc->clusters;
    f->tri_k = ctx->geo->tri_k, f->pd = ctx->geo->pd, f->ndf = ctx->geo->ndf;
    f->uvs = mesh->uvs, f->tri_v = mesh->tri_vertices, f->tri_uv = mesh->tri_uvs;
    f->cl = cm->data, f->cl_w = cm->width, f->cl_h = cm->height;
    f->cl_wd = (double)cm->width, f->cl_hd = (double)cm->height;
    f->cl_w1 = (double)(cm->width - 1), f->cl_h1 = (double)(cm->height - 1);
    for (int a = 0; a < 3; a++)
        f->eye[a] = ctx->eye[a];
    f->ks[0] = 0.0f, f->s[0] = 1.0f;
    for (int c = 0; c < SP_RENDER_CLUSTERS; c++)
        f->ks[c + 1] = (float)ctx->ks[c], f->s[c + 1] = (float)ctx->s[c];
}

/* tex_nearest_u8 (texture.c), the same arithmetic, inline (one call per sample otherwise); n1 = (double)(n - 1). */
static inline int gather_nearest_i(double x, int n, double n1)
{
    return !(x > 0.0) ? 0 : (x >= n1 ? n - 1 : (int)x);
}

/* The cluster at uv as shade_geometry: nearest id, -1 (no specular) for ids >= SP_RENDER_CLUSTERS. */
static inline int gather_cluster_at(const gather_frame *f, double u, double v)
{
    if (!f->cl)
        return 0;
    int i = gather_nearest_i(u * f->cl_wd, f->cl_w, f->cl_w1);
    int j = gather_nearest_i((1.0 - v) * f->cl_hd, f->cl_h, f->cl_h1);
    uint8_t id = f->cl[(size_t)j * (size_t)f->cl_w + (size_t)i];
    return id < SP_RENDER_CLUSTERS ? (int)id : -1;
}

/*
 * Covered samples of a chunk, recorded by gather_cover (scalar: the
 * coverage decision) and turned into batch lanes by gather_lanes, two
 * lanes at a time where GCC vector extensions exist.
 */
typedef struct gather_rec {
    int32_t tri[SIMD_BATCH];
    double d0[SIMD_BATCH], d1[SIMD_BATCH]; /* sample ray (d0, d1, 1) */
    double w[3][SIMD_BATCH], wsum[SIMD_BATCH]; /* raster_weights */
} gather_rec;

/*
 * The coverage test of surf_gather for the ray (d0, d1, 1) (raster_sample_ray's): 0 for a degenerate hit
 * (uncovered, as shade_geometry); else records the sample as lane i of rec and returns 1.
 */
static inline int gather_cover(const gather_frame *f, double d0, double d1, int32_t tri, gather_rec *rec, int i)
{
    double d[3] = {d0, d1, 1.0}, w[3];
    double wsum = raster_weights(f->tri_k + (size_t)tri * 9, d, w);
    if (!(fabs(wsum) > 0.0) || !isfinite(wsum))
        return 0;
    rec->tri[i] = tri, rec->d0[i] = d0, rec->d1[i] = d1, rec->wsum[i] = wsum;
    rec->w[0][i] = w[0], rec->w[1][i] = w[1], rec->w[2][i] = w[2];
    return 1;
}

/* |1 / sum w| beyond float range only for sub-micron slivers: clamped so the adjoint stays finite */
static inline double gather_iw(double inv_wsum)
{
    return inv_wsum < -1e30 ? -1e30 : (inv_wsum > 1e30 ? 1e30 : inv_wsum);
}

/* The cluster of lane i (uv) into the batch: cluster, ks, s. */
static inline void gather_put_cluster(const gather_frame *f, double u, double v, simd_batch *b, int i)
{
    int cl = gather_cluster_at(f, u, v);
    b->surf.cluster[i] = cl;
    b->ks[i] = f->ks[cl + 1];
    b->s[i] = f->s[cl + 1];
}

/*
 * Lane i of rec into lane i of b: barycentrics, vertex data, hit point and UV in shade_geometry's double
 * arithmetic (the shadow lookup is in surf_shadow), cluster.
 */
static inline void gather_lane(const gather_frame *f, const gather_rec *rec, simd_batch *b, int i)
{
    surf_batch *s = &b->surf;
    const uint32_t *tv = f->tri_v + (size_t)rec->tri[i] * 3, *tu = f->tri_uv + (size_t)rec->tri[i] * 3;
    double inv_wsum = 1.0 / rec->wsum[i], p[3] = {0.0, 0.0, 0.0}, uv[2] = {0.0, 0.0}, lam[3], uvd[3][2];
    for (int v = 0; v < 3; v++) {
        const float *uvp = f->uvs + (size_t)tu[v] * 2;
        uvd[v][0] = (double)uvp[0], uvd[v][1] = (double)uvp[1];
        lam[v] = rec->w[v][i] * inv_wsum;
        v3_axpy(lam[v], f->pd + (size_t)tv[v] * 3, p);
        uv[0] += lam[v] * uvd[v][0];
        uv[1] += lam[v] * uvd[v][1];
    }
    for (int v = 0; v < 3; v++) {
        s->vtx[v][i] = (int32_t)tv[v];
        s->lam[v][i] = (float)lam[v];
        for (int a = 0; a < 3; a++) { /* relative to p: the kernel's dot products then cancel less */
            s->dp[v][a][i] = (float)(f->pd[(size_t)tv[v] * 3 + (size_t)a] - p[a]);
            s->nd[v][a][i] = f->ndf[(size_t)tv[v] * 3 + (size_t)a];
        }
        s->uvv[v][0][i] = (float)(uvd[v][0] - uv[0]);
        s->uvv[v][1][i] = (float)(uvd[v][1] - uv[1]);
        s->ev[v][i] = (float)(f->eye[v] - p[v]);
    }
    s->d0[i] = (float)rec->d0[i], s->d1[i] = (float)rec->d1[i], s->iw[i] = (float)gather_iw(inv_wsum);
    s->u[i] = (float)uv[0], s->v[i] = (float)uv[1];
    gather_put_cluster(f, uv[0], uv[1], b, i);
    for (int a = 0; a < 3; a++)
        s->pw[a][i] = p[a];
}

#if defined(__GNUC__) && !defined(SP_SIMD_SCALAR)
/*
 * Lanes i and i + 1 at once: gather_lane's expressions on vectors of two
 * doubles (SSE2 / NEON), one lane per sample - per lane the same IEEE
 * operations, so the same bits, and each float output is one conversion and
 * one 8-byte store for both samples.
 */
typedef double gather_v2d __attribute__((vector_size(16)));
typedef float gather_v2f __attribute__((vector_size(8)));

static inline gather_v2d g2_load(const double *a)
{
    gather_v2d r;
    memcpy(&r, a, sizeof(r));
    return r;
}

static inline void g2_store(double *a, gather_v2d x)
{
    memcpy(a, &x, sizeof(x));
}

static inline void g2_store_f(float *a, gather_v2d x)
{
    gather_v2f r = __builtin_convertvector(x, gather_v2f);
    memcpy(a, &r, sizeof(r));
}

__attribute__((always_inline)) static inline void gather_pair(const gather_frame *f, const gather_rec *rec,
                                                              simd_batch *b, int i)
{
    surf_batch *s = &b->surf;
    const uint32_t *tv[2], *tu[2];
    const double *pd[2][3];
    const float *nd[2][3];
    for (int l = 0; l < 2; l++) {
        tv[l] = f->tri_v + (size_t)rec->tri[i + l] * 3, tu[l] = f->tri_uv + (size_t)rec->tri[i + l] * 3;
        for (int v = 0; v < 3; v++)
            pd[l][v] = f->pd + (size_t)tv[l][v] * 3, nd[l][v] = f->ndf + (size_t)tv[l][v] * 3;
    }
    gather_v2d inv_wsum = 1.0 / g2_load(rec->wsum + i), lam[3], p[3] = {{0.0}, {0.0}, {0.0}}, uv[2] = {{0.0}, {0.0}};
    gather_v2d uvd[3][2];
    for (int v = 0; v < 3; v++) {
        const float *uv0 = f->uvs + (size_t)tu[0][v] * 2, *uv1 = f->uvs + (size_t)tu[1][v] * 2;
        uvd[v][0] = (gather_v2d){(double)uv0[0], (double)uv1[0]};
        uvd[v][1] = (gather_v2d){(double)uv0[1], (double)uv1[1]};
        lam[v] = g2_load(rec->w[v] + i) * inv_wsum;
        for (int a = 0; a < 3; a++)
            p[a] += lam[v] * (gather_v2d){pd[0][v][a], pd[1][v][a]};
        uv[0] += lam[v] * uvd[v][0];
        uv[1] += lam[v] * uvd[v][1];
    }
    for (int v = 0; v < 3; v++) {
        s->vtx[v][i] = (int32_t)tv[0][v], s->vtx[v][i + 1] = (int32_t)tv[1][v];
        g2_store_f(s->lam[v] + i, lam[v]);
        for (int a = 0; a < 3; a++) {
            g2_store_f(s->dp[v][a] + i, (gather_v2d){pd[0][v][a], pd[1][v][a]} - p[a]);
            s->nd[v][a][i] = nd[0][v][a], s->nd[v][a][i + 1] = nd[1][v][a];
        }
        g2_store_f(s->uvv[v][0] + i, uvd[v][0] - uv[0]);
        g2_store_f(s->uvv[v][1] + i, uvd[v][1] - uv[1]);
        g2_store_f(s->ev[v] + i, f->eye[v] - p[v]);
    }
    g2_store_f(s->d0 + i, g2_load(rec->d0 + i));
    g2_store_f(s->d1 + i, g2_load(rec->d1 + i));
    g2_store_f(s->iw + i, (gather_v2d){gather_iw(inv_wsum[0]), gather_iw(inv_wsum[1])});
    g2_store_f(s->u + i, uv[0]);
    g2_store_f(s->v + i, uv[1]);
    for (int l = 0; l < 2; l++)
        gather_put_cluster(f, uv[0][l], uv[1][l], b, i + l);
    for (int a = 0; a < 3; a++)
        g2_store(s->pw[a] + i, p[a]);
}
#else
static inline void gather_pair(const gather_frame *f, const gather_rec *rec, simd_batch *b, int i)
{
    gather_lane(f, rec, b, i);
    gather_lane(f, rec, b, i + 1);
}
#endif

/* Lanes [0, n) of rec into b (surf_gather's outputs). */
static inline void gather_lanes(const gather_frame *f, const gather_rec *rec, simd_batch *b, int n)
{
    int i = 0;
    for (; i + 1 < n; i += 2)
        gather_pair(f, rec, b, i);
    if (i < n)
        gather_lane(f, rec, b, i);
}

/* surf_gather: sample (sx, sy) on triangle tri into lane i (surf_simd.h). */
static inline int surf_gather_at(const shade_ctx *ctx, int sx, int sy, int32_t tri, simd_batch *b, int i)
{
    gather_frame f;
    gather_rec rec;
    gather_frame_init(&f, ctx);
    double d[3];
    raster_sample_ray(ctx->cam, sx, sy, d);
    if (!gather_cover(&f, d[0], d[1], tri, &rec, i))
        return 0;
    gather_lane(&f, &rec, b, i);
    return 1;
}

#endif
