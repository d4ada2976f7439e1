/* SPDX-License-Identifier: MIT */
#include "pipeline/render/shadow.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline/render/vec3.h"

int shadow_map_init(shadow_map *m, int n)
{
    memset(m, 0, sizeof(*m));
    m->depth = calloc((size_t)n * (size_t)n, sizeof(float));
    if (!m->depth)
        return -ENOMEM;
    m->n = n;
    return 0;
}

int shadow_map_reserve(shadow_map *m, uint32_t n_vertices)
{
    if (m->proj && n_vertices <= m->cap_v)
        return 0;
    free(m->proj);
    m->cap_v = 0;
    m->proj = calloc((size_t)n_vertices * 3 + 3, sizeof(double));
    if (!m->proj)
        return -ENOMEM;
    m->cap_v = n_vertices;
    return 0;
}

void shadow_map_free(shadow_map *m)
{
    free(m->depth);
    free(m->proj);
    memset(m, 0, sizeof(*m));
}

void shadow_bounds(const double *pts, uint32_t n, double c[3], double *r)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = dmin(lo[k], pts[(size_t)i * 3 + k]);
            hi[k] = dmax(hi[k], pts[(size_t)i * 3 + k]);
        }
    if (n == 0) {
        v3_zero(c);
        *r = 1.0;
        return;
    }
    double half[3];
    for (int k = 0; k < 3; k++) {
        c[k] = 0.5 * (lo[k] + hi[k]);
        half[k] = 0.5 * (hi[k] - lo[k]);
    }
    /* small margin so silhouette texels stay inside; a point cloud of one point still gets a frame */
    double rad = v3_norm(half) * 1.001;
    *r = rad > 1e-9 ? rad : 1e-3;
}

void shadow_frame_init(shadow_frame *f, const double l[3], const double c[3], double r, double offset, int n)
{
    memcpy(f->l, l, sizeof(f->l));
    memcpy(f->c, c, sizeof(f->c));
    /* branch-free orthonormal basis around l (continuous except across l.z = 0 sign flips) */
    double sg = l[2] >= 0.0 ? 1.0 : -1.0;
    double a = -1.0 / (sg + l[2]);
    double b = l[0] * l[1] * a;
    f->e1[0] = 1.0 + sg * l[0] * l[0] * a;
    f->e1[1] = sg * b;
    f->e1[2] = -sg * l[0];
    f->e2[0] = b;
    f->e2[1] = sg + l[1] * l[1] * a;
    f->e2[2] = -l[1];
    f->r = r;
    f->offset = offset;
    f->n = n;
    f->scale = (double)n / (2.0 * r);
}

static void to_map(const shadow_frame *f, const double p[3], double out[3])
{
    double q[3];
    v3_sub(p, f->c, q);
    double h = 0.5 * (double)f->n - 0.5;
    out[0] = v3_dot(q, f->e1) * f->scale + h;
    out[1] = v3_dot(q, f->e2) * f->scale + h;
    out[2] = f->offset - v3_dot(q, f->l) / f->r;
}

/* Edge function of (a, b) as e(p) = A px + B py + C; the reversed edge gives exact negatives (watertight). */
static void edge_coef(const double *a, const double *b, double e[3])
{
    e[0] = a[1] - b[1];
    e[1] = b[0] - a[0];
    e[2] = a[0] * b[1] - a[1] * b[0];
}

/*
 * Narrows [lo, hi] (texel x range of one row) to where e(x) = A x + r has the
 * sign of the triangle or is zero; ia = 1 / A (sign-adjusted). Shared edges
 * give the same boundary from both sides, so neighbouring triangles leave no gap.
 */
static inline void edge_span(double A, double ia, double r, double *lo, double *hi)
{
    if (A > 0.0)
        *lo = dmax(*lo, -r * ia);
    else if (A < 0.0)
        *hi = dmin(*hi, -r * ia);
    else if (r < 0.0)
        *hi = -1.0; /* parallel edge, row outside */
}

/* A triangle in map space after setup: flipped edge functions, their 1 / A, the depth plane. */
typedef struct shadow_tri {
    double e[3][3], ia[3];
    double zx, zy, z0;
    int box[4]; /* texel x0, x1, y0, y1 */
} shadow_tri;

/* Keeps the minimum of the depth plane over texels x0..x1 of one row. */
static inline void fill_span(float *row, int x0, int x1, double zx, double zr)
{
    double px = (double)x0; /* (double)x by exact increments: no int -> double conversion in the chain */
    for (int x = x0; x <= x1; x++, px += 1.0) {
        float z = (float)(zx * px + zr);
        if (z < row[x])
            row[x] = z;
    }
}

/* Rows with edge_span per edge: any triangle (flat edges included). */
static void fill_rows_generic(shadow_map *m, const shadow_tri *t)
{
    int n = m->n;
    for (int y = t->box[2]; y <= t->box[3]; y++) {
        double py = (double)y, lo = (double)t->box[0], hi = (double)t->box[1];
        for (int k = 0; k < 3; k++)
            edge_span(t->e[k][0], t->ia[k], t->e[k][1] * py + t->e[k][2], &lo, &hi);
        if (!(lo <= hi))
            continue;
        fill_span(m->depth + (size_t)y * (size_t)n, iceil(lo), ifloor(hi), t->zx, t->zy * py + t->z0);
    }
}

/*
 * Rows of a triangle without flat edges (|A| > 1e-290, so every crossing is
 * finite): one edge bounds the span below (A > 0), one above (A < 0), and the
 * third edge m either; its role is a bias of 0 or -+infinity instead of a
 * branch per row and edge (the signs change from triangle to triangle and
 * mispredict). Same crossings and same max / min as edge_span, so the same texels.
 */
static void fill_rows_sorted(shadow_map *m, const shadow_tri *t)
{
    int a = -1, b = -1, mid = -1, n = m->n;
    for (int k = 0; k < 3; k++) {
        if (t->e[k][0] > 0.0 && a < 0)
            a = k;
        else if (t->e[k][0] < 0.0 && b < 0)
            b = k;
        else
            mid = k;
    }
    if (a < 0 || b < 0) { /* a degenerate orientation after all: keep the general form */
        fill_rows_generic(m, t);
        return;
    }
    double blo = t->e[mid][0] > 0.0 ? 0.0 : -HUGE_VAL, bhi = t->e[mid][0] > 0.0 ? HUGE_VAL : 0.0;
    double py = (double)t->box[2];
    for (int y = t->box[2]; y <= t->box[3]; y++, py += 1.0) {
        double xa = -(t->e[a][1] * py + t->e[a][2]) * t->ia[a];
        double xb = -(t->e[b][1] * py + t->e[b][2]) * t->ia[b];
        double xm = -(t->e[mid][1] * py + t->e[mid][2]) * t->ia[mid];
        double lo = dmax(dmax((double)t->box[0], xa), xm + blo);
        double hi = dmin(dmin((double)t->box[1], xb), xm + bhi);
        if (!(lo <= hi))
            continue;
        fill_span(m->depth + (size_t)y * (size_t)n, iceil(lo), ifloor(hi), t->zx, t->zy * py + t->z0);
    }
}

/* Orthographic triangle fill at texel centres, keeping the minimum depth (affine in x, y); row spans. */
static void fill_tri(shadow_map *m, const double *a, const double *b, const double *c)
{
    shadow_tri t;
    int n = m->n;
    int_range(dmin(a[0], dmin(b[0], c[0])), dmax(a[0], dmax(b[0], c[0])), n, &t.box[0], &t.box[1]);
    int_range(dmin(a[1], dmin(b[1], c[1])), dmax(a[1], dmax(b[1], c[1])), n, &t.box[2], &t.box[3]);
    if (t.box[0] > t.box[1] || t.box[2] > t.box[3]) /* outside the map or between texel centres */
        return;
    edge_coef(b, c, t.e[0]);
    edge_coef(c, a, t.e[1]);
    edge_coef(a, b, t.e[2]);
    double area = t.e[0][0] * a[0] + t.e[0][1] * a[1] + t.e[0][2]; /* e0 at a: twice the signed area */
    if (!(area > 1e-12 || area < -1e-12))
        return;
    double sg = area > 0.0 ? 1.0 : -1.0, inv = 1.0 / area;
    int flat = 0;
    for (int k = 0; k < 3; k++) {
        for (int j = 0; j < 3; j++)
            t.e[k][j] *= sg; /* exact: covered texels now have e >= 0 */
        t.ia[k] = t.e[k][0] != 0.0 ? 1.0 / t.e[k][0] : 0.0;
        flat |= !(fabs(t.e[k][0]) > 1e-290);
    }
    inv *= sg;
    /* depth plane z = zx x + zy y + z0 from the barycentric form */
    t.zx = (t.e[0][0] * a[2] + t.e[1][0] * b[2] + t.e[2][0] * c[2]) * inv;
    t.zy = (t.e[0][1] * a[2] + t.e[1][1] * b[2] + t.e[2][1] * c[2]) * inv;
    t.z0 = (t.e[0][2] * a[2] + t.e[1][2] * b[2] + t.e[2][2] * c[2]) * inv;
    if (flat)
        fill_rows_generic(m, &t);
    else
        fill_rows_sorted(m, &t);
}

void shadow_map_render(shadow_map *m, const double *pts, const sp_mesh *mesh)
{
    size_t nn = (size_t)m->n * (size_t)m->n;
    float empty = (float)(m->f.offset + SHADOW_EMPTY_DEPTH);
    for (size_t i = 0; i < nn; i++)
        m->depth[i] = empty;
    for (uint32_t v = 0; v < mesh->n_vertices; v++)
        to_map(&m->f, pts + (size_t)v * 3, m->proj + (size_t)v * 3);
    for (uint32_t t = 0; t < mesh->n_triangles; t++) {
        const uint32_t *tv = mesh->tri_vertices + (size_t)t * 3;
        fill_tri(m, m->proj + (size_t)tv[0] * 3, m->proj + (size_t)tv[1] * 3, m->proj + (size_t)tv[2] * 3);
    }
    m->valid = 1;
}

double shadow_sigmoid(double x, double *deriv)
{
    if (fabs(x) > 60.0) { /* exp(-60) ~ 1e-26: saturated to double precision, skip the exp */
        if (deriv)
            *deriv = 0.0;
        return x > 0.0 ? 1.0 : 0.0;
    }
    double e = exp(-fabs(x)); /* in (0, 1]: never overflows */
    double inv = 1.0 / (1.0 + e);
    if (deriv)
        *deriv = e * inv * inv;
    return x >= 0.0 ? inv : e * inv;
}

static double tap(const shadow_map *m, int x, int y, double empty)
{
    if (x < 0 || y < 0 || x >= m->n || y >= m->n)
        return empty;
    return (double)m->depth[(size_t)y * (size_t)m->n + (size_t)x];
}

void shadow_eval(const shadow_map *m, double k, double b, const double p[3], shadow_sample *out)
{
    double z, dzdp[3], dsig;
    shadow_eval_z(m, k, b, p, &z, dzdp, &out->texel);
    if (out->texel < 0) { /* outside the map: nothing can shadow it */
        out->V = 1.0;
        v3_zero(out->dVdp);
        return;
    }
    out->V = shadow_sigmoid(-z, &dsig); /* 1 - sigmoid(z), so dV/dz = -sigmoid'(z) */
    for (int i = 0; i < 3; i++)
        out->dVdp[i] = -dsig * dzdp[i];
}

/* shadow_eval_z's body, inline so that shadow_eval_z_lanes hoists the frame loads out of its lane loop. */
static inline void eval_z(const shadow_map *m, double k, double b, const double p[3], double *z, double dzdp[3],
                          int32_t *texel)
{
    const shadow_frame *f = &m->f;
    double q[3];
    to_map(f, p, q);
    v3_zero(dzdp);
    *z = -1e30;
    *texel = -1;
    int n = m->n;
    if (!(q[0] > -1.0 && q[0] < (double)n && q[1] > -1.0 && q[1] < (double)n))
        return;
    int ix = ifloor(q[0]), iy = ifloor(q[1]);
    double fx = q[0] - (double)ix, fy = q[1] - (double)iy;
    double empty = f->offset + SHADOW_EMPTY_DEPTH;
    double d00, d10, d01, d11;
    if (ix >= 0 && iy >= 0 && ix + 1 < n && iy + 1 < n) { /* the usual case: one bounds test for all four */
        const float *row = m->depth + (size_t)iy * (size_t)n + (size_t)ix;
        d00 = (double)row[0], d10 = (double)row[1];
        d01 = (double)row[n], d11 = (double)row[n + 1];
    } else {
        d00 = tap(m, ix, iy, empty), d10 = tap(m, ix + 1, iy, empty);
        d01 = tap(m, ix, iy + 1, empty), d11 = tap(m, ix + 1, iy + 1, empty);
    }
    double ds = (1.0 - fy) * ((1.0 - fx) * d00 + fx * d10) + fy * ((1.0 - fx) * d01 + fx * d11);
    double dsdx = (1.0 - fy) * (d10 - d00) + fy * (d11 - d01);
    double dsdy = (1.0 - fx) * (d01 - d00) + fx * (d11 - d10);
    *z = k * (q[2] - b * ds);
    *texel = (iy + 1) * (n + 1) + (ix + 1);
    /* dz/dp = -k (l / r + b scale (dsdx e1 + dsdy e2)) */
    double gzr = -k / f->r, gs = -k * b * f->scale;
    for (int i = 0; i < 3; i++)
        dzdp[i] = gzr * f->l[i] + gs * (dsdx * f->e1[i] + dsdy * f->e2[i]);
}

void shadow_eval_z(const shadow_map *m, double k, double b, const double p[3], double *z, double dzdp[3],
                   int32_t *texel)
{
    eval_z(m, k, b, p, z, dzdp, texel);
}

void shadow_eval_z_lanes(const shadow_map *m, double k, double b, int n, const double *const p[3], const float *lit,
                         float *z, float *const dz[3], int32_t *texel)
{
    for (int i = 0; i < n; i++) {
        double zi = -1e30, g[3] = {0.0, 0.0, 0.0}, q[3] = {p[0][i], p[1][i], p[2][i]};
        int32_t t = -1;
        if (lit[i] > 0.0f)
            eval_z(m, k, b, q, &zi, g, &t);
        zi = zi < -1e30 ? -1e30 : (zi > 1e30 ? 1e30 : zi); /* NaN stays NaN */
        z[i] = (float)zi;
        dz[0][i] = (float)g[0], dz[1][i] = (float)g[1], dz[2][i] = (float)g[2];
        texel[i] = t;
    }
}

/* Map depth at map coordinates (x, y), bilinear, empty beyond the map. */
static double depth_at(const shadow_map *m, double x, double y, double empty)
{
    int ix = ifloor(x), iy = ifloor(y);
    double fx = x - (double)ix, fy = y - (double)iy;
    double d00 = tap(m, ix, iy, empty), d10 = tap(m, ix + 1, iy, empty);
    double d01 = tap(m, ix, iy + 1, empty), d11 = tap(m, ix + 1, iy + 1, empty);
    return (1.0 - fy) * ((1.0 - fx) * d00 + fx * d10) + fy * ((1.0 - fx) * d01 + fx * d11);
}

/* SOFT_TAPS points of a Vogel spiral over the unit disk: radius sqrt((i + 0.5) / 16), i golden angles. */
static const double soft_taps[SOFT_TAPS][2] = {
    { 0.17677669529663689, 0 },
    { -0.22577218793754808, 0.20682581839289904 },
    { 0.034558052024559444, -0.3937711785291908 },
    { 0.28457121982273492, 0.37117276415249095 },
    { -0.52222318724428429, -0.092373928705133418 },
    { 0.49469539152781705, -0.31468471459722952 },
    { -0.16546592706317484, 0.61552500110159947 },
    { -0.31556146793512924, -0.60759440415019161 },
    { 0.68464216158370672, 0.25003021933756281 },
    { -0.71225608622975578, 0.29400895841567593 },
    { 0.34335449874552404, -0.73372862026174901 },
    { 0.25373024091125462, 0.80893199024832541 },
    { -0.7647458919689033, -0.44318587603474729 },
    { 0.8971339835726424, -0.19723238962980169 },
    { -0.54750690485416109, 0.77877223187336142 },
    { -0.12648677292148833, -0.97608969683933655 },
};

double shadow_soft_eval(const shadow_map *m, double k, double b, const double p[3], const double nrm[3], double tan_r)
{
    double z, dz[3];
    int32_t texel;
    eval_z(m, k, b, p, &z, dz, &texel);
    if (texel < 0)
        return 1.0;
    const shadow_frame *f = &m->f;
    double q[3], empty = f->offset + SHADOW_EMPTY_DEPTH, half = 0.5 * (double)m->n, cap = (double)m->n / 8.0;
    to_map(f, p, q);
    /* the receiver's plane: depth (radii) per texel along x and y, so wide kernels do not shadow their own
       surface; grazing planes clamped at 4x a 45-degree slope */
    double nl = fmax(fabs(v3_dot(nrm, f->l)), 0.25), lim = 4.0 / half;
    double gx = fmax(-lim, fmin(lim, v3_dot(nrm, f->e1) / (half * nl)));
    double gy = fmax(-lim, fmin(lim, v3_dot(nrm, f->e2) / (half * nl)));
    /* a per-texel turn of the pattern: noise, which supersampling averages, rather than bands */
    uint32_t hsh = (uint32_t)ifloor(q[0]) * 73856093u ^ (uint32_t)ifloor(q[1]) * 19349663u;
    double rot = (double)(hsh % 1024u) * (2.0 * 3.14159265358979323846 / 1024.0), cr = cos(rot), sr = sin(rot);
    /* blockers: nearer than the receiver within the widest penumbra this depth allows (nearest depth offset - 1) */
    double search = fmin((q[2] - (f->offset - 1.0)) * tan_r * half, cap), dsum = 0.0, nb = 0.0;
    for (int i = 0; i < SOFT_TAPS; i++) { /* nearest texels: the mean depth need not be smooth */
        double ox = (cr * soft_taps[i][0] - sr * soft_taps[i][1]) * search;
        double oy = (sr * soft_taps[i][0] + cr * soft_taps[i][1]) * search;
        double d = tap(m, ifloor(q[0] + ox + 0.5), ifloor(q[1] + oy + 0.5), empty);
        if (b * d < q[2] + gx * ox + gy * oy) {
            dsum += d;
            nb += 1.0;
        }
    }
    double w = nb > 0.0 ? fmin((q[2] - dsum / nb) * tan_r * half, cap) : 0.0;
    if (!(w >= 0.5)) /* a penumbra under a texel (or none): the point sun's test */
        return shadow_sigmoid(-z, NULL);
    double v = 0.0;
    for (int i = 0; i < SOFT_TAPS; i++) {
        double ox = (cr * soft_taps[i][0] - sr * soft_taps[i][1]) * w;
        double oy = (sr * soft_taps[i][0] + cr * soft_taps[i][1]) * w;
        v += shadow_sigmoid(-k * (q[2] + gx * ox + gy * oy - b * depth_at(m, q[0] + ox, q[1] + oy, empty)), NULL);
    }
    return v / SOFT_TAPS;
}
