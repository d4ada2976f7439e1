/* SPDX-License-Identifier: MIT */
#include "pipeline/render/raster.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "pipeline/render/vec3.h"

typedef struct tri_setup {
    double k[9];     /* B x C, C x A, A x B as the shading caches them */
    double kf[3][3]; /* the same, sign-flipped so covered samples are >= 0 */
    double abs_abc;  /* |A . (B x C)| */
} tri_setup;

/* Sample-grid x (or y) of a camera-space point with z >= near. */
static void project(const raster_camera *c, const double p[3], double *sx, double *sy)
{
    double s = (double)c->supersample;
    *sx = (c->fx * p[0] / p[2] + c->cx + 0.5) * s - 0.5;
    *sy = (c->fy * p[1] / p[2] + c->cy + 0.5) * s - 0.5;
}

/* Screen bounds of the part of the triangle in front of the near plane; 0 if none. */
static int tri_bounds(const raster_camera *c, const double *v[3], double bb[4])
{
    double n = c->near_plane;
    bb[0] = bb[1] = INFINITY;
    bb[2] = bb[3] = -INFINITY;
    int count = 0;
    for (int i = 0; i < 3; i++) {
        const double *p = v[i], *q = v[(i + 1) % 3];
        double pts[2][3];
        int np = 0;
        if (p[2] >= n) {
            pts[np][0] = p[0], pts[np][1] = p[1], pts[np][2] = p[2];
            np++;
        }
        if ((p[2] >= n) != (q[2] >= n)) { /* edge crosses the near plane: add the crossing */
            double t = (n - p[2]) / (q[2] - p[2]);
            for (int k = 0; k < 3; k++)
                pts[np][k] = p[k] + t * (q[k] - p[k]);
            pts[np][2] = n;
            np++;
        }
        for (int j = 0; j < np; j++) {
            double x, y;
            project(c, pts[j], &x, &y);
            bb[0] = dmin(bb[0], x), bb[1] = dmin(bb[1], y);
            bb[2] = dmax(bb[2], x), bb[3] = dmax(bb[3], y);
            count++;
        }
    }
    return count > 0;
}

static int tri_setup_init(const raster_camera *c, const double *v[3], tri_setup *ts)
{
    v3_cross(v[1], v[2], ts->k);
    v3_cross(v[2], v[0], ts->k + 3);
    v3_cross(v[0], v[1], ts->k + 6);
    double abc = v3_dot(v[0], ts->k);
    if (!(abc != 0.0) || !isfinite(abc)) /* edge-on (camera in the plane) or degenerate */
        return 0;
    if (abc > 0.0 && c->cull_backfaces) /* abc < 0: the outward (CCW) side faces the camera */
        return 0;
    /* covered samples have w_i / sum(w) >= 0 and sum(w) of abc's sign: flip to make both positive */
    double sg = abc < 0.0 ? -1.0 : 1.0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            ts->kf[i][j] = sg * ts->k[i * 3 + j];
    ts->abs_abc = fabs(abc);
    return 1;
}

static void draw_tri(const raster_camera *c, int32_t id, const double *v[3], int32_t *tri_id, float *zbuf,
                     float *bary, double *tri_k)
{
    if (v[0][2] < c->near_plane && v[1][2] < c->near_plane && v[2][2] < c->near_plane)
        return;
    if (v[0][2] > c->far_plane && v[1][2] > c->far_plane && v[2][2] > c->far_plane)
        return;
    tri_setup ts;
    double bb[4];
    if (!tri_setup_init(c, v, &ts) || !tri_bounds(c, v, bb))
        return;
    memcpy(tri_k + (size_t)id * 9, ts.k, sizeof(ts.k));
    int x0, x1, y0, y1;
    int_range(bb[0], bb[2], c->sample_width, &x0, &x1);
    int_range(bb[1], bb[3], c->sample_height, &y0, &y1);
    double s_min = ts.abs_abc / c->far_plane, s_max = ts.abs_abc / c->near_plane;
    for (int sy = y0; sy <= y1; sy++) {
        double d[3];
        raster_sample_ray(c, x0, sy, d);
        double base[3];
        for (int i = 0; i < 3; i++)
            base[i] = ts.kf[i][1] * d[1] + ts.kf[i][2];
        size_t row = (size_t)sy * (size_t)c->sample_width;
        for (int sx = x0; sx <= x1; sx++) {
            double dx = (((double)sx + 0.5) * c->inv_s - 0.5 - c->cx) * c->inv_fx;
            double w0 = ts.kf[0][0] * dx + base[0];
            double w1 = ts.kf[1][0] * dx + base[1];
            double w2 = ts.kf[2][0] * dx + base[2];
            if (w0 < 0.0 || w1 < 0.0 || w2 < 0.0)
                continue;
            double s = w0 + w1 + w2;
            /* depth |abc| / s within [near, far], written without dividing first */
            if (!(s >= s_min && s <= s_max) || !(s > 0.0))
                continue;
            double z = ts.abs_abc / s;
            size_t idx = row + (size_t)sx;
            if (!((float)z < zbuf[idx]))
                continue;
            zbuf[idx] = (float)z;
            tri_id[idx] = id;
            bary[idx * 3 + 0] = to_float(w0 / s);
            bary[idx * 3 + 1] = to_float(w1 / s);
            bary[idx * 3 + 2] = to_float(w2 / s);
        }
    }
}

void raster_camera_draw(const raster_camera *c, const double *xc, const sp_mesh *mesh, int32_t *tri_id,
                        float *zbuf, float *bary, double *tri_k)
{
    size_t n = (size_t)c->sample_width * (size_t)c->sample_height;
    for (size_t i = 0; i < n; i++) {
        tri_id[i] = -1;
        zbuf[i] = FLT_MAX;
        bary[i * 3 + 0] = bary[i * 3 + 1] = bary[i * 3 + 2] = 0.0f;
    }
    for (uint32_t t = 0; t < mesh->n_triangles; t++) {
        const uint32_t *tv = mesh->tri_vertices + (size_t)t * 3;
        const double *v[3] = {xc + (size_t)tv[0] * 3, xc + (size_t)tv[1] * 3, xc + (size_t)tv[2] * 3};
        draw_tri(c, (int32_t)t, v, tri_id, zbuf, bary, tri_k);
    }
}
