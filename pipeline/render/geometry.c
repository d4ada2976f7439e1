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
                    &g->g_pd, &g->g_nd, &g->g_xc, &g->g_n0, &g->g_h, &g->g_m};
    for (size_t i = 0; i < sizeof(d) / sizeof(d[0]); i++) {
        free(*d[i]);
        *d[i] = NULL;
    }
    free(g->tri_k);
    free(g->copy_head);
    free(g->copy_next);
    free(g->copy_uv);
    free(g->copy_count);
    memset(g, 0, sizeof(*g));
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
    ok &= (g->copy_head = calloc(v1, sizeof(int32_t))) != NULL;
    ok &= (g->copy_count = calloc(v1, sizeof(uint32_t))) != NULL;
    ok &= (g->copy_next = calloc(c, sizeof(int32_t))) != NULL;
    ok &= (g->copy_uv = calloc(c, sizeof(uint32_t))) != NULL;
    ok &= (g->tri_k = calloc((size_t)nt * 9 + 9, sizeof(double))) != NULL;
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

/* m = sum over incident faces of (B - A) x (C - A) (twice the area times the unit normal); n = m / |m|. */
static void vertex_normals(const double *pos, const sp_mesh *mesh, double *m, double *n)
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
    for (size_t v = 0; v < nv; v++)
        v3_normalize(m + v * 3, n + v * 3);
}

/* Adjoint of vertex_normals: g_n (per vertex) -> g_pos (added). */
static void vertex_normals_backward(const double *pos, const sp_mesh *mesh, const double *m, const double *n,
                                    const double *g_n, double *g_m, double *g_pos)
{
    size_t nv = mesh->n_vertices;
    memset(g_m, 0, nv * 3 * sizeof(double));
    for (size_t v = 0; v < nv; v++)
        v3_normalize_backward(n + v * 3, v3_norm(m + v * 3), g_n + v * 3, g_m + v * 3);
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

void geom_forward(render_geom *g, const sp_mesh *mesh, const sp_render_texture *disp, const double R[9],
                  const double t[3])
{
    size_t nv = mesh->n_vertices;
    for (size_t i = 0; i < nv * 3; i++)
        g->p0[i] = (double)mesh->positions[i];
    build_uv_copies(g, mesh);
    vertex_normals(g->p0, mesh, g->m0, g->n0);
    displacement(g, mesh, disp);
    if (disp->data) {
        vertex_normals(g->pd, mesh, g->md, g->nd);
    } else {
        memcpy(g->md, g->m0, nv * 3 * sizeof(double));
        memcpy(g->nd, g->n0, nv * 3 * sizeof(double));
    }
    for (size_t v = 0; v < nv; v++) {
        double *x = g->xc + v * 3;
        m3_mul(R, g->pd + v * 3, x);
        x[0] += t[0];
        x[1] += t[1];
        x[2] += t[2];
    }
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
        vertex_normals_backward(g->p0, mesh, g->m0, g->n0, g->g_nd, g->g_m, g->g_pd);
        for (size_t i = 0; i < nv * 3; i++)
            g_positions[i] += g->g_pd[i];
        return;
    }
    vertex_normals_backward(g->pd, mesh, g->md, g->nd, g->g_nd, g->g_m, g->g_pd);
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
    vertex_normals_backward(g->p0, mesh, g->m0, g->n0, g->g_n0, g->g_m, g->g_pd);
    for (size_t i = 0; i < nv * 3; i++)
        g_positions[i] += g->g_pd[i];
}
