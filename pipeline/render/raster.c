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
    unsigned falls[3]; /* 1 where kf[i][0] < 0: the edge function decreases along a row */
} tri_setup;

/* Where one triangle writes: the frame's per-sample buffers. */
typedef struct raster_out {
    int32_t *tri_id;
    float *zbuf, *bary;
    double *tri_k;
    const double *col_dx; /* ray x per sample column (raster_sample_ray's d[0]) */
    const double *row_dy; /* ray y per sample row (raster_sample_ray's d[1]) */
} raster_out;

/* Sample-grid x (or y) of a camera-space point with z >= near. */
static void project(const raster_camera *c, const double p[3], double *sx, double *sy)
{
    double s = (double)c->supersample;
    *sx = (c->fx * p[0] / p[2] + c->cx + 0.5) * s - 0.5;
    *sy = (c->fy * p[1] / p[2] + c->cy + 0.5) * s - 0.5;
}

/* Screen bounds of the part of the triangle in front of the near plane; 0 if none. */
static int tri_bounds_clipped(const raster_camera *c, const double *v[3], double bb[4])
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

/*
 * Screen bounds; xs holds the vertices' projections (valid where z >= near),
 * so a triangle wholly in front (nearly all) needs no division here.
 */
static int tri_bounds(const raster_camera *c, const double *v[3], const double *xs[3], double bb[4])
{
    double n = c->near_plane;
    if (!(v[0][2] >= n && v[1][2] >= n && v[2][2] >= n))
        return tri_bounds_clipped(c, v, bb);
    bb[0] = dmin(xs[0][0], dmin(xs[1][0], xs[2][0]));
    bb[1] = dmin(xs[0][1], dmin(xs[1][1], xs[2][1]));
    bb[2] = dmax(xs[0][0], dmax(xs[1][0], xs[2][0]));
    bb[3] = dmax(xs[0][1], dmax(xs[1][1], xs[2][1]));
    return 1;
}

/* Edge vectors and orientation; 0 for edge-on, degenerate, non-finite or culled triangles. */
static int tri_setup_init(const raster_camera *c, const double *v[3], tri_setup *ts)
{
    v3_cross(v[1], v[2], ts->k);
    double abc = v3_dot(v[0], ts->k);
    if (!(abc != 0.0) || !isfinite(abc)) /* edge-on (camera in the plane) or degenerate */
        return 0;
    if (abc > 0.0 && c->cull_backfaces) /* abc < 0: the outward (CCW) side faces the camera */
        return 0;
    v3_cross(v[2], v[0], ts->k + 3);
    v3_cross(v[0], v[1], ts->k + 6);
    double inf_test = 0.0; /* NaN if any entry is infinite or NaN: then no sample could pass anyway */
    for (int i = 0; i < 9; i++)
        inf_test += ts->k[i] - ts->k[i];
    if (inf_test != 0.0)
        return 0;
    /* covered samples have w_i / sum(w) >= 0 and sum(w) of abc's sign: flip to make both positive */
    double sg = abc < 0.0 ? -1.0 : 1.0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            ts->kf[i][j] = sg * ts->k[i * 3 + j];
    ts->abs_abc = fabs(abc);
    for (int i = 0; i < 3; i++)
        ts->falls[i] = (unsigned)(ts->kf[i][0] < 0.0);
    return 1;
}

/* Flipped edge functions at row offsets base (kf[i][1] d1 + kf[i][2]) and ray x dx. */
static inline void edge_eval(const tri_setup *ts, const double base[3], double dx, double w[3])
{
    w[0] = ts->kf[0][0] * dx + base[0];
    w[1] = ts->kf[1][0] * dx + base[1];
    w[2] = ts->kf[2][0] * dx + base[2];
}

/* 1 when every edge whose function does not decrease along the row (kf[i][0] >= 0) passes at dx. */
static inline int rising_pass(const tri_setup *ts, const double base[3], double dx)
{
    double w[3];
    edge_eval(ts, base, dx, w);
    /* bitwise, one branch for the caller: the edges' roles differ from triangle to triangle */
    return (int)(((unsigned)(w[0] >= 0.0) | ts->falls[0]) & ((unsigned)(w[1] >= 0.0) | ts->falls[1]) &
                 ((unsigned)(w[2] >= 0.0) | ts->falls[2]));
}

/*
 * First sample of the row in [x0, x1] where the rising edges pass (x1 + 1 if
 * none), found by walking from a guess (the previous row's answer). Exact, not
 * an estimate: along a row dx(sx) is monotone, so each computed edge function
 * fl(fl(a dx) + b) is monotone too (rounding is monotone; finite coefficients
 * are checked in setup), and "w >= 0" (NaN fails) holds on an interval that
 * ends at x1 for a >= 0 and starts at x0 for a < 0.
 */
static int row_start(const double *cdx, const tri_setup *ts, const double base[3], int guess, int x0, int x1)
{
    int sx = guess < x0 ? x0 : (guess > x1 ? x1 : guess);
    if (rising_pass(ts, base, cdx[sx])) {
        while (sx > x0 && rising_pass(ts, base, cdx[sx - 1]))
            sx--;
        return sx;
    }
    for (sx++; sx <= x1; sx++)
        if (rising_pass(ts, base, cdx[sx]))
            break;
    return sx;
}

/* Depth test and write of one covered sample (edge functions w, all >= 0). */
static inline void write_sample(const tri_setup *ts, double s_min, double s_max, const double w[3], size_t idx,
                                int32_t id, const raster_out *o)
{
    double s = w[0] + w[1] + w[2];
    /* depth |abc| / s within [near, far], written without dividing first */
    if (!(s >= s_min && s <= s_max) || !(s > 0.0))
        return;
    double z = ts->abs_abc / s;
    if (!((float)z < o->zbuf[idx]))
        return;
    o->zbuf[idx] = (float)z;
    o->tri_id[idx] = id;
    if (!o->bary) /* fit_float's gather recomputes them in double */
        return;
    o->bary[idx * 3 + 0] = to_float(w[0] / s);
    o->bary[idx * 3 + 1] = to_float(w[1] / s);
    o->bary[idx * 3 + 2] = to_float(w[2] / s);
}

/*
 * Covered samples of rows y0..y1 within [x0, x1]: per row, from the first
 * sample the rising edges accept until a falling edge rejects (the covered
 * run is an interval, see row_start), instead of every sample of the box.
 */
static void fill_rows(const raster_camera *c, const tri_setup *ts, int32_t id, const int box[4],
                      const raster_out *o)
{
    double s_min = ts->abs_abc / c->far_plane, s_max = ts->abs_abc / c->near_plane;
    int x0 = box[0], x1 = box[1], guess = box[0];
    for (int sy = box[2]; sy <= box[3]; sy++) {
        double d1 = o->row_dy[sy], base[3];
        for (int i = 0; i < 3; i++)
            base[i] = ts->kf[i][1] * d1 + ts->kf[i][2];
        int sx = row_start(o->col_dx, ts, base, guess, x0, x1);
        if (sx > x1)
            continue;
        guess = sx;
        size_t row = (size_t)sy * (size_t)c->sample_width;
        for (; sx <= x1; sx++) {
            double w[3];
            edge_eval(ts, base, o->col_dx[sx], w);
            if (!(w[0] >= 0.0 && w[1] >= 0.0 && w[2] >= 0.0))
                break; /* a falling edge: it rejects the rest of the row too */
            write_sample(ts, s_min, s_max, w, row + (size_t)sx, id, o);
        }
    }
}

static void draw_tri(const raster_camera *c, int32_t id, const double *v[3], const double *xs[3],
                     const raster_out *o)
{
    if (v[0][2] < c->near_plane && v[1][2] < c->near_plane && v[2][2] < c->near_plane)
        return;
    if (v[0][2] > c->far_plane && v[1][2] > c->far_plane && v[2][2] > c->far_plane)
        return;
    double bb[4];
    int box[4];
    if (!tri_bounds(c, v, xs, bb))
        return;
    int_range(bb[0], bb[2], c->sample_width, &box[0], &box[1]);
    int_range(bb[1], bb[3], c->sample_height, &box[2], &box[3]);
    if (box[0] > box[1] || box[2] > box[3]) /* off screen, or no sample centre inside (sub-sample) */
        return;
    tri_setup ts;
    if (!tri_setup_init(c, v, &ts))
        return;
    memcpy(o->tri_k + (size_t)id * 9, ts.k, sizeof(ts.k));
    fill_rows(c, &ts, id, box, o);
}

void raster_camera_draw(const raster_camera *c, const double *xc, const sp_mesh *mesh, int32_t *tri_id,
                        float *zbuf, float *bary, double *tri_k, double *xs, double *col_dx)
{
    size_t n = (size_t)c->sample_width * (size_t)c->sample_height;
    for (size_t i = 0; i < n; i++) {
        tri_id[i] = -1;
        zbuf[i] = FLT_MAX;
    }
    if (bary)
        memset(bary, 0, n * 3 * sizeof(float));
    for (uint32_t v = 0; v < mesh->n_vertices; v++) { /* once per vertex instead of once per corner */
        const double *p = xc + (size_t)v * 3;
        if (p[2] >= c->near_plane)
            project(c, p, xs + (size_t)v * 2, xs + (size_t)v * 2 + 1);
    }
    /* ray x per column and y per row, once: shorter dependency chains before each coverage branch, and
     * every triangle sees the same ray for a sample */
    double *row_dy = col_dx + c->sample_width, d[3];
    for (int sx = 0; sx < c->sample_width; sx++) {
        raster_sample_ray(c, sx, 0, d);
        col_dx[sx] = d[0];
    }
    for (int sy = 0; sy < c->sample_height; sy++) {
        raster_sample_ray(c, 0, sy, d);
        row_dy[sy] = d[1];
    }
    const raster_out o = {tri_id, zbuf, bary, tri_k, col_dx, row_dy};
    for (uint32_t t = 0; t < mesh->n_triangles; t++) {
        const uint32_t *tv = mesh->tri_vertices + (size_t)t * 3;
        const double *v[3] = {xc + (size_t)tv[0] * 3, xc + (size_t)tv[1] * 3, xc + (size_t)tv[2] * 3};
        const double *p[3] = {xs + (size_t)tv[0] * 2, xs + (size_t)tv[1] * 2, xs + (size_t)tv[2] * 2};
        draw_tri(c, (int32_t)t, v, p, &o);
    }
}
