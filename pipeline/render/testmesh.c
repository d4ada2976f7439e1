/* SPDX-License-Identifier: MIT */
#include "pipeline/render/testmesh.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "pipeline/render/vec3.h"

#define PI 3.14159265358979323846

static void set3(float *dst, double x, double y, double z)
{
    dst[0] = (float)x;
    dst[1] = (float)y;
    dst[2] = (float)z;
}

static void tri(sp_mesh *m, uint32_t *t, uint32_t a, uint32_t b, uint32_t c, uint32_t ua, uint32_t ub, uint32_t uc)
{
    uint32_t *v = m->tri_vertices + (size_t)*t * 3, *u = m->tri_uvs + (size_t)*t * 3;
    v[0] = a, v[1] = b, v[2] = c;
    u[0] = ua, u[1] = ub, u[2] = uc;
    (*t)++;
}

static void head_vertex(float *dst, double theta, double phi, const double c[3], double ax, double ay, double az,
                        double nose)
{
    double d[3] = {sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta)};
    /* angle from the -y axis: the bump is a Gaussian in it */
    double cosang = -d[1];
    double ang = acos(cosang < -1.0 ? -1.0 : (cosang > 1.0 ? 1.0 : cosang));
    double s = 1.0 + nose * exp(-ang * ang / (2.0 * 0.22 * 0.22));
    set3(dst, c[0] + ax * d[0] * s, c[1] + ay * d[1] * s, c[2] + az * d[2] * s);
}

int testmesh_head(sp_mesh *m, int n_lat, int n_lon, const double c[3], double ax, double ay, double az,
                  double nose)
{
    if (!m || n_lat < 2 || n_lon < 3)
        return -EINVAL;
    uint32_t L = (uint32_t)n_lat, N = (uint32_t)n_lon;
    uint32_t nv = 2 + (L - 1) * N, nuv = (L + 1) * (N + 1), nt = 2 * N * (L - 1);
    int err = sp_mesh_alloc(m, nv, nuv, nt);
    if (err)
        return err;
    uint32_t bottom = nv - 1;
    head_vertex(m->positions, 0.0, 0.0, c, ax, ay, az, nose);
    head_vertex(m->positions + (size_t)bottom * 3, PI, 0.0, c, ax, ay, az, nose);
    for (uint32_t i = 1; i < L; i++)
        for (uint32_t j = 0; j < N; j++)
            head_vertex(m->positions + (size_t)(1 + (i - 1) * N + j) * 3, PI * i / L, 2.0 * PI * j / N, c, ax, ay,
                        az, nose);
    for (uint32_t i = 0; i <= L; i++)
        for (uint32_t j = 0; j <= N; j++) {
            m->uvs[(size_t)(i * (N + 1) + j) * 2 + 0] = (float)((double)j / N);
            m->uvs[(size_t)(i * (N + 1) + j) * 2 + 1] = (float)(1.0 - (double)i / L);
        }
    uint32_t t = 0;
#define VID(i, j) ((i) == 0 ? 0u : ((i) == L ? bottom : 1 + ((i) - 1) * N + ((j) % N)))
#define UID(i, j) ((i) * (N + 1) + (j))
    for (uint32_t i = 0; i < L; i++)
        for (uint32_t j = 0; j < N; j++) {
            uint32_t a = VID(i, j), b = VID(i + 1, j), cc = VID(i + 1, j + 1), d = VID(i, j + 1);
            uint32_t ua = UID(i, j), ub = UID(i + 1, j), uc = UID(i + 1, j + 1), ud = UID(i, j + 1);
            if (i != L - 1) /* south-west half; degenerate at the bottom pole */
                tri(m, &t, a, b, cc, ua, ub, uc);
            if (i != 0) /* north-east half; degenerate at the top pole */
                tri(m, &t, a, cc, d, ua, uc, ud);
        }
#undef VID
#undef UID
    m->n_triangles = t;
    return 0;
}

int testmesh_grid(sp_mesh *m, const double p0[3], const double e_u[3], const double e_v[3], int nu, int nv)
{
    if (!m || nu < 1 || nv < 1)
        return -EINVAL;
    uint32_t cols = (uint32_t)nu + 1, rows = (uint32_t)nv + 1;
    int err = sp_mesh_alloc(m, cols * rows, cols * rows, 2u * (uint32_t)nu * (uint32_t)nv);
    if (err)
        return err;
    for (uint32_t y = 0; y < rows; y++)
        for (uint32_t x = 0; x < cols; x++) {
            double s = (double)x / nu, tt = (double)y / nv;
            size_t i = (size_t)(y * cols + x);
            set3(m->positions + i * 3, p0[0] + s * e_u[0] + tt * e_v[0], p0[1] + s * e_u[1] + tt * e_v[1],
                 p0[2] + s * e_u[2] + tt * e_v[2]);
            m->uvs[i * 2 + 0] = (float)s;
            m->uvs[i * 2 + 1] = (float)tt;
        }
    uint32_t t = 0;
    for (uint32_t y = 0; y < (uint32_t)nv; y++)
        for (uint32_t x = 0; x < (uint32_t)nu; x++) {
            uint32_t a = y * cols + x, b = a + 1, c = a + cols + 1, d = a + cols;
            tri(m, &t, a, b, c, a, b, c);
            tri(m, &t, a, c, d, a, c, d);
        }
    return 0;
}

int testmesh_append(sp_mesh *a, const sp_mesh *b)
{
    if (!a || !b)
        return -EINVAL;
    sp_mesh out;
    int err = sp_mesh_alloc(&out, a->n_vertices + b->n_vertices, a->n_uvs + b->n_uvs, a->n_triangles + b->n_triangles);
    if (err)
        return err;
    memcpy(out.positions, a->positions, (size_t)a->n_vertices * 3 * sizeof(float));
    memcpy(out.positions + (size_t)a->n_vertices * 3, b->positions, (size_t)b->n_vertices * 3 * sizeof(float));
    memcpy(out.uvs, a->uvs, (size_t)a->n_uvs * 2 * sizeof(float));
    memcpy(out.uvs + (size_t)a->n_uvs * 2, b->uvs, (size_t)b->n_uvs * 2 * sizeof(float));
    size_t ta = (size_t)a->n_triangles * 3;
    memcpy(out.tri_vertices, a->tri_vertices, ta * sizeof(uint32_t));
    memcpy(out.tri_uvs, a->tri_uvs, ta * sizeof(uint32_t));
    for (size_t i = 0; i < (size_t)b->n_triangles * 3; i++) {
        out.tri_vertices[ta + i] = b->tri_vertices[i] + a->n_vertices;
        out.tri_uvs[ta + i] = b->tri_uvs[i] + a->n_uvs;
    }
    sp_mesh_free(a);
    *a = out;
    return 0;
}

void testmesh_look_at(sp_render_camera *cam, const double eye[3], const double target[3], const double up[3])
{
    double f[3], x[3], y[3], d[3];
    v3_sub(target, eye, d);
    v3_normalize(d, f);
    v3_cross(f, up, d);
    v3_normalize(d, x);
    v3_cross(f, x, y); /* OpenCV: y = z x x points down */
    for (int k = 0; k < 3; k++) {
        cam->R[k] = x[k];
        cam->R[3 + k] = y[k];
        cam->R[6 + k] = f[k];
    }
    m3_mul(cam->R, eye, d);
    v3_scale(d, -1.0, cam->t);
}
