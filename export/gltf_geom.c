/* SPDX-License-Identifier: MIT */
/* Face mesh -> glTF vertices: one per distinct (position, UV) pair, smooth normals, placed in the y-up scene. */
#include "export/gltf_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

void sp_gltf_from_world(const double w[3], double g[3])
{
    double x = w[0], y = w[1], z = w[2];
    g[0] = x;
    g[1] = z;
    g[2] = -y;
}

void sp_gltf_place(const sp_gltf_placement *p, const double w[3], double g[3], int point)
{
    for (int r = 0; r < 3; r++)
        g[r] = p->R[r * 3] * w[0] + p->R[r * 3 + 1] * w[1] + p->R[r * 3 + 2] * w[2] + (point ? p->t[r] : 0.0);
}

/* Bounding-box centre of the mesh's positions under p. */
static void box_centre(const sp_gltf_placement *p, const sp_mesh *m, double c[3])
{
    double lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (uint32_t i = 0; i < m->n_vertices; i++) {
        double w[3] = { m->positions[i * 3], m->positions[i * 3 + 1], m->positions[i * 3 + 2] }, g[3];
        sp_gltf_place(p, w, g, 1);
        for (int k = 0; k < 3; k++) {
            lo[k] = g[k] < lo[k] ? g[k] : lo[k];
            hi[k] = g[k] > hi[k] ? g[k] : hi[k];
        }
    }
    for (int k = 0; k < 3; k++)
        c[k] = m->n_vertices && isfinite(lo[k] + hi[k]) ? 0.5 * (lo[k] + hi[k]) : 0.0;
}

void sp_gltf_placement_init(sp_gltf_placement *p, const sp_mesh *m, const sp_render_camera *key0)
{
    memset(p, 0, sizeof(*p));
    for (int k = 0; k < 3; k++) { /* column k: the fit world's axis k in glTF */
        double w[3] = { k == 0, k == 1, k == 2 }, g[3];
        sp_gltf_from_world(w, g);
        p->R[k] = g[0], p->R[3 + k] = g[1], p->R[6 + k] = g[2];
    }
    double c[3], cam[3], eye[3];
    box_centre(p, m, c);
    for (int k = 0; k < 3; k++) /* camera centre -R^T t */
        cam[k] = -(key0->R[k] * key0->t[0] + key0->R[3 + k] * key0->t[1] + key0->R[6 + k] * key0->t[2]);
    sp_gltf_place(p, cam, eye, 1);
    double dx = eye[0] - c[0], dz = eye[2] - c[2], step = 2.0 * M_PI / SP_RENDER_ENV_W;
    double yaw = hypot(dx, dz) > 1e-9 && isfinite(dx + dz) ? -step * round(atan2(dx, dz) / step) : 0.0;
    double cy = cos(yaw), sy = sin(yaw), M[9];
    memcpy(M, p->R, sizeof(M));
    for (int k = 0; k < 3; k++) { /* R = Ry(yaw) M: the camera's azimuth (from +z towards +x) goes to 0 */
        p->R[k] = cy * M[k] + sy * M[6 + k];
        p->R[6 + k] = -sy * M[k] + cy * M[6 + k];
    }
    box_centre(p, m, c);
    for (int k = 0; k < 3; k++)
        p->t[k] = -c[k];
}

static int cmp_u64(const void *a, const void *b)
{
    uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* Area-weighted vertex normals over positions (world frame), unit length; +z where degenerate. */
static double *position_normals(const sp_mesh *m)
{
    double *n = calloc((size_t)m->n_vertices * 3, sizeof(double));
    if (!n)
        return NULL;
    for (uint32_t t = 0; t < m->n_triangles; t++) {
        const uint32_t *v = m->tri_vertices + (size_t)t * 3;
        const float *a = m->positions + (size_t)v[0] * 3, *b = m->positions + (size_t)v[1] * 3,
                    *c = m->positions + (size_t)v[2] * 3;
        double e1[3] = { (double)(b[0] - a[0]), (double)(b[1] - a[1]), (double)(b[2] - a[2]) };
        double e2[3] = { (double)(c[0] - a[0]), (double)(c[1] - a[1]), (double)(c[2] - a[2]) };
        double f[3] = { e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                        e1[0] * e2[1] - e1[1] * e2[0] };
        for (int k = 0; k < 3; k++)
            for (int d = 0; d < 3; d++)
                n[(size_t)v[k] * 3 + d] += f[d];
    }
    for (uint32_t i = 0; i < m->n_vertices; i++) {
        double *p = n + (size_t)i * 3;
        double len = sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
        if (!(len > 1e-30) || !isfinite(len)) {
            p[0] = p[1] = 0.0;
            p[2] = 1.0;
        } else {
            p[0] /= len, p[1] /= len, p[2] /= len;
        }
    }
    return n;
}

static void fill_vertex(sp_gltf_geom *g, uint32_t out, const sp_mesh *m, const sp_gltf_placement *p,
                        const double *pn, uint32_t pv, uint32_t uv)
{
    double w[3], gl[3];
    for (int d = 0; d < 3; d++)
        w[d] = (double)m->positions[(size_t)pv * 3 + d];
    sp_gltf_place(p, w, gl, 1);
    sp_gltf_place(p, pn + (size_t)pv * 3, w, 0);
    for (int d = 0; d < 3; d++) {
        g->positions[(size_t)out * 3 + d] = (float)gl[d];
        g->normals[(size_t)out * 3 + d] = (float)w[d];
        if (out == 0 || (float)gl[d] < g->min[d])
            g->min[d] = (float)gl[d];
        if (out == 0 || (float)gl[d] > g->max[d])
            g->max[d] = (float)gl[d];
    }
    g->source[out] = pv;
    g->uvs[(size_t)out * 2] = m->uvs[(size_t)uv * 2];
    g->uvs[(size_t)out * 2 + 1] = 1.0f - m->uvs[(size_t)uv * 2 + 1]; /* glTF v runs down */
}

static int alloc_geom(sp_gltf_geom *g, uint32_t nv, uint32_t nt)
{
    g->n_vertices = nv;
    g->n_triangles = nt;
    g->positions = malloc((size_t)nv * 3 * sizeof(float));
    g->normals = malloc((size_t)nv * 3 * sizeof(float));
    g->uvs = malloc((size_t)nv * 2 * sizeof(float));
    g->tangents = malloc((size_t)nv * 4 * sizeof(float));
    g->indices = malloc((size_t)nt * 3 * sizeof(uint32_t));
    g->source = malloc((size_t)nv * sizeof(uint32_t));
    return g->positions && g->normals && g->uvs && g->tangents && g->indices && g->source ? 0 : -ENOMEM;
}

/* Per-triangle dP/du and dP/dv (v up, as the normal map's green channel), summed per vertex into tb (6 each). */
static void accumulate_tb(const sp_gltf_geom *g, double *tb)
{
    for (uint32_t t = 0; t < g->n_triangles; t++) {
        const uint32_t *v = g->indices + (size_t)t * 3;
        const float *p0 = g->positions + (size_t)v[0] * 3, *p1 = g->positions + (size_t)v[1] * 3,
                    *p2 = g->positions + (size_t)v[2] * 3;
        const float *u0 = g->uvs + (size_t)v[0] * 2, *u1 = g->uvs + (size_t)v[1] * 2, *u2 = g->uvs + (size_t)v[2] * 2;
        double du1 = (double)(u1[0] - u0[0]), du2 = (double)(u2[0] - u0[0]);
        double dv1 = (double)(u0[1] - u1[1]), dv2 = (double)(u0[1] - u2[1]); /* glTF v runs down: negate */
        double r = du1 * dv2 - du2 * dv1;
        if (!(fabs(r) > 1e-20))
            continue;
        for (int d = 0; d < 3; d++) {
            double e1 = (double)(p1[d] - p0[d]), e2 = (double)(p2[d] - p0[d]);
            double T = (e1 * dv2 - e2 * dv1) / r, B = (e2 * du1 - e1 * du2) / r;
            for (int k = 0; k < 3; k++) {
                tb[(size_t)v[k] * 6 + d] += T;
                tb[(size_t)v[k] * 6 + 3 + d] += B;
            }
        }
    }
}

/* Unit tangent orthogonal to the normal (Gram-Schmidt), any perpendicular where degenerate; w from B. */
static int build_tangents(sp_gltf_geom *g)
{
    double *tb = calloc((size_t)g->n_vertices * 6, sizeof(double));
    if (!tb)
        return -ENOMEM;
    accumulate_tb(g, tb);
    for (uint32_t i = 0; i < g->n_vertices; i++) {
        const float *nf = g->normals + (size_t)i * 3;
        double n[3] = { (double)nf[0], (double)nf[1], (double)nf[2] }, *T = tb + (size_t)i * 6, *B = T + 3;
        double nt = n[0] * T[0] + n[1] * T[1] + n[2] * T[2], t[3], len = 0.0;
        for (int d = 0; d < 3; d++) {
            t[d] = T[d] - n[d] * nt;
            len += t[d] * t[d];
        }
        len = sqrt(len);
        if (!(len > 1e-12) || !isfinite(len)) { /* perpendicular to n from the axis it is least aligned with */
            double a[3] = { fabs(n[0]) < 0.9 ? 1.0 : 0.0, fabs(n[0]) < 0.9 ? 0.0 : 1.0, 0.0 };
            double an = a[0] * n[0] + a[1] * n[1];
            for (int d = 0; d < 3; d++)
                t[d] = a[d] - n[d] * an;
            len = sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
        }
        double c[3] = { n[1] * t[2] - n[2] * t[1], n[2] * t[0] - n[0] * t[2], n[0] * t[1] - n[1] * t[0] };
        float *out = g->tangents + (size_t)i * 4;
        for (int d = 0; d < 3; d++)
            out[d] = (float)(t[d] / len);
        out[3] = c[0] * B[0] + c[1] * B[1] + c[2] * B[2] < 0.0 ? -1.0f : 1.0f;
    }
    free(tb);
    return 0;
}

/* Binary search of a corner key in the sorted unique list. */
static uint32_t find_key(const uint64_t *keys, uint32_t n, uint64_t k)
{
    uint32_t lo = 0, hi = n;
    while (lo + 1 < hi) {
        uint32_t mid = lo + (hi - lo) / 2;
        if (keys[mid] <= k)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

int sp_gltf_geom_build(sp_gltf_geom *g, const sp_mesh *m, const sp_gltf_placement *p)
{
    if (!g || !m || !p)
        return -EINVAL;
    memset(g, 0, sizeof(*g));
    if (m->n_triangles == 0 || m->n_vertices == 0 || sp_mesh_validate(m))
        return SP_ECORRUPT;
    size_t nc = (size_t)m->n_triangles * 3;
    uint64_t *keys = malloc(nc * sizeof(uint64_t));
    double *pn = position_normals(m);
    int ret = keys && pn ? 0 : -ENOMEM;
    uint32_t nu = 0;
    if (!ret) {
        for (size_t c = 0; c < nc; c++)
            keys[c] = ((uint64_t)m->tri_vertices[c] << 32) | m->tri_uvs[c];
        qsort(keys, nc, sizeof(uint64_t), cmp_u64);
        for (size_t c = 0; c < nc; c++)
            if (c == 0 || keys[c] != keys[nu - 1])
                keys[nu++] = keys[c];
        ret = alloc_geom(g, nu, m->n_triangles);
    }
    if (!ret) {
        for (uint32_t i = 0; i < nu; i++)
            fill_vertex(g, i, m, p, pn, (uint32_t)(keys[i] >> 32), (uint32_t)keys[i]);
        for (size_t c = 0; c < nc; c++)
            g->indices[c] = find_key(keys, nu, ((uint64_t)m->tri_vertices[c] << 32) | m->tri_uvs[c]);
        ret = build_tangents(g);
    }
    free(keys);
    free(pn);
    if (ret)
        sp_gltf_geom_free(g);
    return ret;
}

void sp_gltf_geom_free(sp_gltf_geom *g)
{
    if (!g)
        return;
    free(g->positions);
    free(g->normals);
    free(g->uvs);
    free(g->tangents);
    free(g->indices);
    free(g->source);
    memset(g, 0, sizeof(*g));
}
