/* SPDX-License-Identifier: MIT */
#include "pipeline/render/geometry.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline/render/texture.h"
#include "pipeline/render/vec3.h"

void geom_free(render_geom *g)
{
    double **d[] = {&g->p0, &g->h, &g->m0, &g->n0, &g->pd, &g->md, &g->nd, &g->xc,
                    &g->g_pd, &g->g_nd, &g->g_xc, &g->g_n0, &g->g_h, &g->g_m, &g->im0, &g->imd};
    for (size_t i = 0; i < sizeof(d) / sizeof(d[0]); i++) {
        free(*d[i]);
        *d[i] = NULL;
    }
    free(g->ndf);
    free(g->tri_k);
    free(g->xs);
    free(g->col_dx);
    free(g->key_pos);
    free(g->key_tv);
    free(g->key_tuv);
    free(g->copy_head);
    free(g->copy_next);
    free(g->copy_uv);
    free(g->copy_count);
    memset(g, 0, sizeof(*g));
}

int geom_reserve_raster(render_geom *g, int n)
{
    if (g->col_dx && n <= g->cap_cols)
        return 0;
    free(g->col_dx);
    g->cap_cols = 0;
    g->col_dx = calloc((size_t)(n > 0 ? n : 0) + 1, sizeof(double));
    if (!g->col_dx)
        return -ENOMEM;
    g->cap_cols = n;
    return 0;
}

int geom_reserve(render_geom *g, uint32_t n_vertices, uint32_t n_triangles)
{
    if (n_vertices <= g->cap_v && n_triangles <= g->cap_t && g->p0)
        return 0;
    uint32_t nv = n_vertices > g->cap_v ? n_vertices : g->cap_v;
    uint32_t nt = n_triangles > g->cap_t ? n_triangles : g->cap_t;
    geom_free(g);
    size_t v3 = (size_t)nv * 3 + 3, v1 = (size_t)nv + 1, c = (size_t)nt * 3 + 1;
    double **d3[] = {&g->p0, &g->m0, &g->n0, &g->pd, &g->md, &g->nd, &g->xc,
                     &g->g_pd, &g->g_nd, &g->g_xc, &g->g_n0, &g->g_m};
    int ok = 1;
    for (size_t i = 0; i < sizeof(d3) / sizeof(d3[0]); i++)
        ok &= (*d3[i] = calloc(v3, sizeof(double))) != NULL;
    ok &= (g->h = calloc(v1, sizeof(double))) != NULL;
    ok &= (g->g_h = calloc(v1, sizeof(double))) != NULL;
    ok &= (g->im0 = calloc(v1, sizeof(double))) != NULL;
    ok &= (g->imd = calloc(v1, sizeof(double))) != NULL;
    ok &= (g->ndf = calloc(v3, sizeof(float))) != NULL;
    ok &= (g->key_pos = calloc(v3, sizeof(float))) != NULL;
    ok &= (g->key_tv = calloc(c, sizeof(uint32_t))) != NULL;
    ok &= (g->key_tuv = calloc(c, sizeof(uint32_t))) != NULL;
    ok &= (g->copy_head = calloc(v1, sizeof(int32_t))) != NULL;
    ok &= (g->copy_count = calloc(v1, sizeof(uint32_t))) != NULL;
    ok &= (g->copy_next = calloc(c, sizeof(int32_t))) != NULL;
    ok &= (g->copy_uv = calloc(c, sizeof(uint32_t))) != NULL;
    ok &= (g->tri_k = calloc((size_t)nt * 9 + 9, sizeof(double))) != NULL;
    ok &= (g->xs = calloc((size_t)nv * 2 + 2, sizeof(double))) != NULL;
    if (!ok) {
        geom_free(g);
        return -ENOMEM;
    }
    g->cap_v = nv;
    g->cap_t = nt;
    return 0;
}

/* Distinct (vertex, UV) pairs as short per-vertex lists; seams give a vertex 2-3 copies. */
static void build_uv_copies(render_geom *g, const sp_mesh *mesh)
{
    for (uint32_t v = 0; v < mesh->n_vertices; v++) {
        g->copy_head[v] = -1;
        g->copy_count[v] = 0;
    }
    int32_t used = 0;
    for (size_t k = 0; k < (size_t)mesh->n_triangles * 3; k++) {
        uint32_t v = mesh->tri_vertices[k], uv = mesh->tri_uvs[k];
        int32_t e = g->copy_head[v];
        while (e >= 0 && g->copy_uv[e] != uv)
            e = g->copy_next[e];
        if (e >= 0)
            continue;
        g->copy_uv[used] = uv;
        g->copy_next[used] = g->copy_head[v];
        g->copy_head[v] = used++;
        g->copy_count[v]++;
    }
}

/*
 * m = sum over incident faces of (B - A) x (C - A) (twice the area times the
 * unit normal); n = m / |m| (v3_normalize's arithmetic); im = 1 / |m|, 0 where
 * v3_normalize returns a zero normal.
 */
static void vertex_normals(const double *pos, const sp_mesh *mesh, double *m, double *n, double *im)
{
    size_t nv = mesh->n_vertices;
    memset(m, 0, nv * 3 * sizeof(double));
    for (uint32_t t = 0; t < mesh->n_triangles; t++) {
        const uint32_t *tv = mesh->tri_vertices + (size_t)t * 3;
        const double *a = pos + (size_t)tv[0] * 3, *b = pos + (size_t)tv[1] * 3, *c = pos + (size_t)tv[2] * 3;
        double u[3], w[3], f[3];
        v3_sub(b, a, u);
        v3_sub(c, a, w);
        v3_cross(u, w, f);
        for (int k = 0; k < 3; k++)
            v3_axpy(1.0, f, m + (size_t)tv[k] * 3);
    }
    for (size_t v = 0; v < nv; v++) {
        double len = v3_normalize(m + v * 3, n + v * 3);
        im[v] = len > 0.0 ? 1.0 / len : 0.0;
    }
}

/*
 * Adjoint of vertex_normals: g_n (per vertex) -> g_pos (added). The normal
 * step is v3_normalize_backward with the forward's 1 / |m| (same arithmetic,
 * no sqrt or division per vertex).
 */
static void vertex_normals_backward(const double *pos, const sp_mesh *mesh, const double *im, const double *n,
                                    const double *g_n, double *g_m, double *g_pos)
{
    size_t nv = mesh->n_vertices;
    for (size_t v = 0; v < nv; v++) {
        const double *nv3 = n + v * 3, *g = g_n + v * 3;
        double *ga = g_m + v * 3, inv = im[v];
        double gn = v3_dot(nv3, g);
        for (int k = 0; k < 3; k++)
            ga[k] = inv > 0.0 ? 0.0 + (g[k] - nv3[k] * gn) * inv : 0.0;
    }
    for (uint32_t t = 0; t < mesh->n_triangles; t++) {
        const uint32_t *tv = mesh->tri_vertices + (size_t)t * 3;
        double gf[3] = {0, 0, 0};
        for (int k = 0; k < 3; k++)
            v3_axpy(1.0, g_m + (size_t)tv[k] * 3, gf);
        if (gf[0] == 0.0 && gf[1] == 0.0 && gf[2] == 0.0)
            continue;
        const double *a = pos + (size_t)tv[0] * 3, *b = pos + (size_t)tv[1] * 3, *c = pos + (size_t)tv[2] * 3;
        double u[3], w[3], gu[3], gw[3];
        v3_sub(b, a, u);
        v3_sub(c, a, w);
        v3_cross(w, gf, gu); /* f = u x w: dL/du = w x gf, dL/dw = gf x u */
        v3_cross(gf, u, gw);
        v3_axpy(1.0, gu, g_pos + (size_t)tv[1] * 3);
        v3_axpy(1.0, gw, g_pos + (size_t)tv[2] * 3);
        v3_axpy(-1.0, gu, g_pos + (size_t)tv[0] * 3);
        v3_axpy(-1.0, gw, g_pos + (size_t)tv[0] * 3);
    }
}

static void displacement(render_geom *g, const sp_mesh *mesh, const sp_render_texture *disp)
{
    for (uint32_t v = 0; v < mesh->n_vertices; v++) {
        double sum = 0.0;
        if (disp->data && g->copy_count[v]) {
            for (int32_t e = g->copy_head[v]; e >= 0; e = g->copy_next[e]) {
                const float *uv = mesh->uvs + (size_t)g->copy_uv[e] * 2;
                tex_lookup tl;
                double s;
                tex_lookup_init(&tl, disp->width, disp->height, (double)uv[0], (double)uv[1]);
                tex_sample(&tl, disp->data, 1, &s);
                sum += s;
            }
            sum /= (double)g->copy_count[v];
        }
        g->h[v] = sum;
        for (int k = 0; k < 3; k++)
            g->pd[v * 3 + k] = g->p0[v * 3 + k] + sum * g->n0[v * 3 + k];
    }
}

/* memcmp / memcpy that accept the NULL arrays of an empty mesh (n = 0). */
static int bytes_equal(const void *a, const void *b, size_t n)
{
    return n == 0 || memcmp(a, b, n) == 0;
}

static void bytes_copy(void *dst, const void *src, size_t n)
{
    if (n)
        memcpy(dst, src, n);
}

int geom_mesh_unchanged(const render_geom *g, const sp_mesh *mesh)
{
    size_t n3 = (size_t)mesh->n_triangles * 3;
    return g->key_valid && g->key_nv == mesh->n_vertices && g->key_nt == mesh->n_triangles &&
           g->key_nuv == mesh->n_uvs &&
           bytes_equal(g->key_pos, mesh->positions, (size_t)mesh->n_vertices * 3 * sizeof(float)) &&
           bytes_equal(g->key_tv, mesh->tri_vertices, n3 * sizeof(uint32_t)) &&
           bytes_equal(g->key_tuv, mesh->tri_uvs, n3 * sizeof(uint32_t));
}

/* Everything that depends only on the undisplaced mesh: p0, UV copies, coarse normals; and the key. */
static void mesh_constants(render_geom *g, const sp_mesh *mesh)
{
    size_t nv = mesh->n_vertices, n3 = (size_t)mesh->n_triangles * 3;
    for (size_t i = 0; i < nv * 3; i++)
        g->p0[i] = (double)mesh->positions[i];
    build_uv_copies(g, mesh);
    vertex_normals(g->p0, mesh, g->m0, g->n0, g->im0);
    bytes_copy(g->key_pos, mesh->positions, nv * 3 * sizeof(float));
    bytes_copy(g->key_tv, mesh->tri_vertices, n3 * sizeof(uint32_t));
    bytes_copy(g->key_tuv, mesh->tri_uvs, n3 * sizeof(uint32_t));
    g->key_nv = mesh->n_vertices;
    g->key_nt = mesh->n_triangles;
    g->key_nuv = mesh->n_uvs;
    g->key_valid = 1;
}

void geom_forward(render_geom *g, const sp_mesh *mesh, const sp_render_texture *disp, const double R[9],
                  const double t[3])
{
    geom_forward_known(g, mesh, geom_mesh_unchanged(g, mesh), disp, R, t);
}

void geom_forward_known(render_geom *g, const sp_mesh *mesh, int same, const sp_render_texture *disp,
                        const double R[9], const double t[3])
{
    size_t nv = mesh->n_vertices;
    if (!same)
        mesh_constants(g, mesh);
    displacement(g, mesh, disp);
    if (disp->data) {
        vertex_normals(g->pd, mesh, g->md, g->nd, g->imd);
    } else {
        memcpy(g->md, g->m0, nv * 3 * sizeof(double));
        memcpy(g->nd, g->n0, nv * 3 * sizeof(double));
        memcpy(g->imd, g->im0, nv * sizeof(double));
    }
    for (size_t v = 0; v < nv; v++) {
        double *x = g->xc + v * 3;
        m3_mul(R, g->pd + v * 3, x);
        x[0] += t[0];
        x[1] += t[1];
        x[2] += t[2];
    }
    for (size_t i = 0; i < nv * 3; i++)
        g->ndf[i] = (float)g->nd[i];
}

static void displacement_backward(render_geom *g, const sp_mesh *mesh, const sp_render_texture *disp,
                                  double *g_disp)
{
    for (uint32_t v = 0; v < mesh->n_vertices; v++) {
        if (g->g_h[v] == 0.0 || !g->copy_count[v])
            continue;
        double share = g->g_h[v] / (double)g->copy_count[v];
        for (int32_t e = g->copy_head[v]; e >= 0; e = g->copy_next[e]) {
            const float *uv = mesh->uvs + (size_t)g->copy_uv[e] * 2;
            tex_lookup tl;
            tex_lookup_init(&tl, disp->width, disp->height, (double)uv[0], (double)uv[1]);
            tex_splat(&tl, g_disp, 1, &share);
        }
    }
}

void geom_backward(render_geom *g, const sp_mesh *mesh, const sp_render_texture *disp, double *g_positions,
                   double *g_disp)
{
    size_t nv = mesh->n_vertices;
    /* g_pd holds the direct adjoint of the displaced positions (camera space already folded in). */
    if (!disp->data) {
        /* no displacement: displaced normals are the coarse ones */
        if (!g_positions)
            return;
        vertex_normals_backward(g->p0, mesh, g->im0, g->n0, g->g_nd, g->g_m, g->g_pd);
        for (size_t i = 0; i < nv * 3; i++)
            g_positions[i] += g->g_pd[i];
        return;
    }
    vertex_normals_backward(g->pd, mesh, g->imd, g->nd, g->g_nd, g->g_m, g->g_pd);
    /* pd = p0 + h n0 */
    for (size_t v = 0; v < nv; v++) {
        const double *gp = g->g_pd + v * 3;
        g->g_h[v] = v3_dot(gp, g->n0 + v * 3);
        v3_scale(gp, g->h[v], g->g_n0 + v * 3);
    }
    if (g_disp)
        displacement_backward(g, mesh, disp, g_disp);
    if (!g_positions)
        return;
    vertex_normals_backward(g->p0, mesh, g->im0, g->n0, g->g_n0, g->g_m, g->g_pd);
    for (size_t i = 0; i < nv * 3; i++)
        g_positions[i] += g->g_pd[i];
}
