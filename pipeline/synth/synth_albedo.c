/* SPDX-License-Identifier: MIT */
/*
 * Procedural skin albedo in UV space. Every texel gets the 3-D point of the
 * mean head it shows (the render mesh rasterised in UV space, then dilated
 * over seams), and the colour is a function of that point in the face frame:
 * skin tone with low- and high-frequency variation, redder cheeks and nose,
 * lips, darker brows, freckles, hair, and eyes / mouth interior on the caps.
 * Noise fields live in 3-D, so the texture is continuous across UV seams.
 */
#include "pipeline/synth/synth_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

enum texel_kind { TEX_NONE = 0, TEX_SKIN = 1, TEX_CAP = 2 /* + enum synth_cap_kind */ };

typedef struct uv_raster {
    int w, h;
    float *pos;    /* 3 per texel, model frame, metres */
    uint8_t *kind; /* enum texel_kind */
} uv_raster;

/* Face-frame landmarks and derived anchors for painting. */
typedef struct paint_ctx {
    const sp_synth_selfie *g;
    double lm[SP_FACE_N_LANDMARKS][3];
    double brow_y, eye_y;
    double cheek[2][3], eye_c[2][3];
} paint_ctx;

static double clamp01(double x) { return x < 0 ? 0 : x > 1 ? 1 : x; }

static double smoothstep(double a, double b, double x)
{
    double t = b != a ? clamp01((x - a) / (b - a)) : (x >= b);
    return t * t * (3.0 - 2.0 * t);
}

/* ---- UV rasterisation ---- */

static void raster_triangle(uv_raster *r, const sp_mesh *m, size_t t, uint8_t kind)
{
    double X[3], Y[3];
    for (int k = 0; k < 3; k++) {
        const float *uv = m->uvs + (size_t)m->tri_uvs[t * 3 + (size_t)k] * 2;
        X[k] = (double)uv[0] * r->w - 0.5;
        Y[k] = (1.0 - (double)uv[1]) * r->h - 0.5;
    }
    double area = (X[1] - X[0]) * (Y[2] - Y[0]) - (X[2] - X[0]) * (Y[1] - Y[0]);
    if (!(fabs(area) > 1e-12))
        return;
    int x0 = (int)floor(fmin(X[0], fmin(X[1], X[2]))), x1 = (int)ceil(fmax(X[0], fmax(X[1], X[2])));
    int y0 = (int)floor(fmin(Y[0], fmin(Y[1], Y[2]))), y1 = (int)ceil(fmax(Y[0], fmax(Y[1], Y[2])));
    x0 = x0 < 0 ? 0 : x0;
    y0 = y0 < 0 ? 0 : y0;
    x1 = x1 >= r->w ? r->w - 1 : x1;
    y1 = y1 >= r->h ? r->h - 1 : y1;
    for (int y = y0; y <= y1; y++)
        for (int x = x0; x <= x1; x++) {
            double l[3];
            for (int k = 0; k < 3; k++) {
                int a = (k + 1) % 3, b = (k + 2) % 3;
                l[k] = ((X[b] - X[a]) * (y - Y[a]) - (x - X[a]) * (Y[b] - Y[a])) / area;
            }
            if (l[0] < -1e-6 || l[1] < -1e-6 || l[2] < -1e-6)
                continue;
            size_t i = (size_t)y * (size_t)r->w + (size_t)x;
            for (int c = 0; c < 3; c++) {
                double p = 0.0;
                for (int k = 0; k < 3; k++)
                    p += l[k] * (double)m->positions[(size_t)m->tri_vertices[t * 3 + (size_t)k] * 3 + (size_t)c];
                r->pos[i * 3 + (size_t)c] = (float)p;
            }
            r->kind[i] = kind;
        }
}

/* Fills empty texels from a filled 4-neighbour, `passes` times (bilinear lookups at seams need it). */
static void dilate(uv_raster *r, int passes)
{
    static const int dx[4] = { 1, -1, 0, 0 }, dy[4] = { 0, 0, 1, -1 };
    size_t n = (size_t)r->w * (size_t)r->h;
    uint8_t *prev = malloc(n);
    if (!prev)
        return; /* the texture just keeps its gaps, which render at the fallback colour */
    for (int p = 0; p < passes; p++) {
        memcpy(prev, r->kind, n);
        for (int y = 0; y < r->h; y++)
            for (int x = 0; x < r->w; x++) {
                size_t i = (size_t)y * (size_t)r->w + (size_t)x;
                for (int k = 0; k < 4 && prev[i] == TEX_NONE; k++) {
                    int xx = x + dx[k], yy = y + dy[k];
                    if (xx < 0 || yy < 0 || xx >= r->w || yy >= r->h)
                        continue;
                    size_t j = (size_t)yy * (size_t)r->w + (size_t)xx;
                    if (prev[j] == TEX_NONE || r->kind[i] != TEX_NONE)
                        continue;
                    memcpy(r->pos + i * 3, r->pos + j * 3, 3 * sizeof(float));
                    r->kind[i] = prev[j];
                }
            }
    }
    free(prev);
}

static void to_face(const synth_face_frame *ff, const double p[3], double out[3]);

static int raster_mesh(const sp_synth_selfie *g, uv_raster *r)
{
    size_t n = (size_t)r->w * (size_t)r->h;
    r->pos = calloc(n * 3, sizeof(float));
    r->kind = calloc(n, 1);
    if (!r->pos || !r->kind)
        return -ENOMEM;
    const sp_mesh *m = &g->mesh;
    size_t t = g->model->mesh.n_triangles;
    /* caps first: where a hole's UV polygon overlaps another chart, the skin wins */
    for (int c = 0; c < g->n_caps; c++)
        for (uint32_t j = 0; j < g->caps[c].n; j++)
            raster_triangle(r, m, t++, (uint8_t)(TEX_CAP + g->caps[c].kind));
    const sp_face_model *fm = g->model;
    for (size_t k = 0; k < fm->mesh.n_triangles; k++) {
        uint32_t v0 = fm->mesh.tri_vertices[k * 3];
        uint8_t kind = TEX_SKIN;
        if (fm->part[v0] == SP_FACE_PART_EYE) { /* the model's own eyeballs: painted as eyes, by side */
            double f[3], pm[3] = { fm->mesh.positions[v0 * 3], fm->mesh.positions[v0 * 3 + 1],
                                   fm->mesh.positions[v0 * 3 + 2] };
            to_face(&g->ff, pm, f);
            kind = (uint8_t)(TEX_CAP + (f[0] > 0 ? SYNTH_CAP_LEFT_EYE : SYNTH_CAP_RIGHT_EYE));
        }
        raster_triangle(r, m, k, kind);
    }
    dilate(r, 4);
    return 0;
}

/* ---- noise ---- */

/* Value noise in [-1, 1] at a 3-D point (lattice spacing 1). */
static double vnoise(const double p[3], uint64_t seed)
{
    double f[3], w[3];
    int64_t i[3];
    for (int k = 0; k < 3; k++) {
        double fl = floor(p[k]);
        i[k] = (int64_t)fl;
        f[k] = p[k] - fl;
        w[k] = f[k] * f[k] * (3.0 - 2.0 * f[k]);
    }
    double s = 0.0;
    for (int c = 0; c < 8; c++) {
        int a = c & 1, b = (c >> 1) & 1, d = (c >> 2) & 1;
        double wt = (a ? w[0] : 1 - w[0]) * (b ? w[1] : 1 - w[1]) * (d ? w[2] : 1 - w[2]);
        s += wt * synth_hash3(i[0] + a, i[1] + b, i[2] + d, seed);
    }
    return 2.0 * s - 1.0;
}

static double noise_at(const double pm[3], double freq, uint64_t seed)
{
    double q[3] = { pm[0] * freq, pm[1] * freq, pm[2] * freq };
    return vnoise(q, seed);
}

/* Freckles: a dot of random radius around a random point in some lattice cells (spacing 4 mm). */
static double freckle(const double pm[3], double density, uint64_t seed)
{
    const double cell = 0.004;
    double q[3] = { pm[0] / cell, pm[1] / cell, pm[2] / cell }, best = 0.0;
    int64_t c0[3] = { (int64_t)floor(q[0]), (int64_t)floor(q[1]), (int64_t)floor(q[2]) };
    for (int c = 0; c < 27; c++) {
        int64_t ci[3] = { c0[0] + c % 3 - 1, c0[1] + (c / 3) % 3 - 1, c0[2] + c / 9 - 1 };
        if (synth_hash3(ci[0], ci[1], ci[2], seed) >= density)
            continue;
        double d2 = 0.0;
        for (int k = 0; k < 3; k++) {
            double pt = (double)ci[k] + synth_hash3(ci[0], ci[1], ci[2], seed + 1 + (uint64_t)k);
            d2 += (q[k] - pt) * (q[k] - pt);
        }
        double rad = 0.12 + 0.2 * synth_hash3(ci[0], ci[1], ci[2], seed + 7);
        double v = 1.0 - smoothstep(0.6 * rad, rad, sqrt(d2));
        best = v > best ? v : best;
    }
    return best;
}

/* ---- face geometry in the face frame ---- */

static void to_face(const synth_face_frame *ff, const double p[3], double out[3])
{
    double d[3] = { p[0] - ff->o[0], p[1] - ff->o[1], p[2] - ff->o[2] };
    const double *ax[3] = { ff->x, ff->y, ff->z };
    for (int i = 0; i < 3; i++)
        out[i] = (d[0] * ax[i][0] + d[1] * ax[i][1] + d[2] * ax[i][2]) / ff->unit;
}

static double seg_dist(const double p[2], const double a[3], const double b[3])
{
    double ux = b[0] - a[0], uy = b[1] - a[1], L = ux * ux + uy * uy;
    double t = L > 0 ? ((p[0] - a[0]) * ux + (p[1] - a[1]) * uy) / L : 0.0;
    t = clamp01(t);
    double dx = p[0] - a[0] - t * ux, dy = p[1] - a[1] - t * uy;
    return sqrt(dx * dx + dy * dy);
}

/* Signed distance (positive inside) to the closed polygon of landmarks first..last, in x/y. */
static double poly_sdist(const paint_ctx *pc, const double p[2], int first, int last)
{
    int inside = 0;
    double d = INFINITY;
    for (int i = first, j = last; i <= last; j = i++) {
        const double *a = pc->lm[i], *b = pc->lm[j];
        if ((a[1] > p[1]) != (b[1] > p[1]) && p[0] < (b[0] - a[0]) * (p[1] - a[1]) / (b[1] - a[1]) + a[0])
            inside = !inside;
        double s = seg_dist(p, a, b);
        d = s < d ? s : d;
    }
    return inside ? d : -d;
}

/* Distance to the open polyline of landmarks first..last, and where along it (0 first .. 1 last). */
static double polyline_dist(const paint_ctx *pc, const double p[2], int first, int last, double *along)
{
    double d = INFINITY;
    *along = 0.0;
    for (int i = first; i < last; i++) {
        double s = seg_dist(p, pc->lm[i], pc->lm[i + 1]);
        if (s < d) {
            d = s;
            *along = (i - first + 0.5) / (last - first);
        }
    }
    return d;
}

static void paint_init(paint_ctx *pc, const sp_synth_selfie *g)
{
    const sp_face_model *m = g->model;
    pc->g = g;
    for (int l = 0; l < SP_FACE_N_LANDMARKS; l++) {
        const float *v = m->mesh.positions + (size_t)m->landmarks[l] * 3;
        double p[3] = { v[0], v[1], v[2] };
        to_face(&g->ff, p, pc->lm[l]);
    }
    pc->brow_y = pc->eye_y = 0.0;
    for (int l = 17; l < 27; l++)
        pc->brow_y += pc->lm[l][1] / 10.0;
    for (int l = 36; l < 48; l++)
        pc->eye_y += pc->lm[l][1] / 12.0;
    for (int k = 0; k < 3; k++) {
        pc->cheek[0][k] = 0.5 * (pc->lm[36][k] + pc->lm[48][k]);
        pc->cheek[1][k] = 0.5 * (pc->lm[45][k] + pc->lm[54][k]);
        pc->eye_c[0][k] = pc->eye_c[1][k] = 0.0;
        for (int l = 0; l < 6; l++) {
            pc->eye_c[0][k] += pc->lm[36 + l][k] / 6.0;
            pc->eye_c[1][k] += pc->lm[42 + l][k] / 6.0;
        }
    }
}

static double gauss2(const double f[3], const double c[3], double sigma)
{
    double dx = f[0] - c[0], dy = f[1] - c[1];
    return exp(-(dx * dx + dy * dy) / (2.0 * sigma * sigma));
}

/* ---- colour ---- */

static void mix3(double *c, const double *to, double w)
{
    for (int k = 0; k < 3; k++)
        c[k] += w * (to[k] - c[k]);
}

static double hair_weight(const paint_ctx *pc, const double f[3], const double pm[3], uint64_t seed)
{
    /* hairline: above the forehead in front, dropping behind the ears towards the nape */
    double line = pc->brow_y + 0.65;
    if (f[2] < -0.3)
        line -= 1.4 * (-0.3 - f[2]);
    if (fabs(f[1] - line) > 0.1) /* beyond the noise's reach */
        return f[1] > line ? 1.0 : 0.0;
    line += 0.06 * noise_at(pm, 80.0, seed + 11);
    return smoothstep(line - 0.03, line + 0.03, f[1]);
}

static void paint_skin(const paint_ctx *pc, const double pm[3], const double f[3], double c[3])
{
    const synth_look *lk = &pc->g->look;
    uint64_t sd = lk->noise_seed;
    double var = 1.0 + 0.06 * noise_at(pm, 60.0, sd) + 0.03 * noise_at(pm, 250.0, sd + 1) +
                 0.02 * noise_at(pm, 900.0, sd + 2);
    double front = smoothstep(-0.6, -0.2, f[2]);
    for (int k = 0; k < 3; k++)
        c[k] = lk->skin[k] * var;
    double red = lk->redness * front *
                 fmax(fmax(gauss2(f, pc->cheek[0], 0.28), gauss2(f, pc->cheek[1], 0.28)),
                      0.6 * gauss2(f, pc->lm[30], 0.14));
    c[1] *= 1.0 - 0.22 * red;
    c[2] *= 1.0 - 0.18 * red;
    double p2[2] = { f[0], f[1] };
    /* lips: inside the outer lip contour 48..59, soft edge */
    double wl = front * smoothstep(-0.012, 0.012, poly_sdist(pc, p2, 48, 59));
    const double lip[3] = { c[0] * 0.82, c[1] * 0.48, c[2] * 0.5 };
    mix3(c, lip, wl);
    /* brows: along 17..21 and 22..26, thicker at the inner ends, with hair-like streaks */
    double al, ar, dr = polyline_dist(pc, p2, 17, 21, &ar), dl = polyline_dist(pc, p2, 22, 26, &al);
    double thick_r = 0.035 + 0.03 * ar, thick_l = 0.065 - 0.03 * al; /* 21 and 22 are the inner ends */
    double wb = fmax(1.0 - smoothstep(thick_r - 0.015, thick_r + 0.015, dr),
                     1.0 - smoothstep(thick_l - 0.015, thick_l + 0.015, dl));
    if (wb > 0) {
        wb *= front * (0.75 + 0.25 * noise_at(pm, 1500.0, sd + 3));
        mix3(c, lk->hair, 0.85 * clamp01(wb));
    }
    /* freckles: densest over the nose bridge and upper cheeks */
    double dens = lk->freckles * 0.5 * front * fmax(gauss2(f, pc->lm[29], 0.5), 0.7 * gauss2(f, pc->cheek[0], 0.35));
    dens = fmax(dens, lk->freckles * 0.35 * front * gauss2(f, pc->cheek[1], 0.35));
    double fr = dens > 1e-4 ? freckle(pm, dens, sd + 20) : 0.0;
    const double spot[3] = { c[0] * 0.78, c[1] * 0.66, c[2] * 0.6 };
    mix3(c, spot, fr);
    double wh = hair_weight(pc, f, pm, sd);
    if (wh > 0) {
        double hair[3], streak = 1.0 + 0.2 * noise_at(pm, 700.0, sd + 4);
        for (int k = 0; k < 3; k++)
            hair[k] = lk->hair[k] * streak;
        mix3(c, hair, wh);
    }
}

static void paint_eye(const paint_ctx *pc, const double f[3], int side, double c[3])
{
    const synth_look *lk = &pc->g->look;
    double dx = f[0] - pc->eye_c[side][0], dy = f[1] - pc->eye_c[side][1];
    double r = sqrt(dx * dx + dy * dy);
    const double sclera[3] = { 0.55, 0.5, 0.47 };
    double corner = smoothstep(0.1, 0.25, r); /* reddish towards the corners */
    for (int k = 0; k < 3; k++)
        c[k] = sclera[k] * (k ? 1.0 - 0.15 * corner : 1.0);
    double iris_w = 1.0 - smoothstep(0.06, 0.07, r);
    double iris[3], ring = smoothstep(0.045, 0.065, r);
    for (int k = 0; k < 3; k++)
        iris[k] = lk->iris[k] * (1.0 - 0.5 * ring);
    mix3(c, iris, iris_w);
    const double pupil[3] = { 0.01, 0.01, 0.01 };
    mix3(c, pupil, 1.0 - smoothstep(0.022, 0.03, r));
}

static void paint_texel(const paint_ctx *pc, const float *pos, uint8_t kind, float *out)
{
    double pm[3] = { pos[0], pos[1], pos[2] }, f[3], c[3];
    to_face(&pc->g->ff, pm, f);
    if (kind == TEX_CAP + SYNTH_CAP_RIGHT_EYE || kind == TEX_CAP + SYNTH_CAP_LEFT_EYE) {
        paint_eye(pc, f, kind == TEX_CAP + SYNTH_CAP_LEFT_EYE, c);
    } else if (kind == TEX_CAP + SYNTH_CAP_MOUTH) {
        c[0] = 0.08;
        c[1] = c[2] = 0.02;
    } else if (kind == TEX_NONE) {
        memcpy(c, pc->g->look.skin, sizeof(c));
    } else {
        paint_skin(pc, pm, f, c);
    }
    for (int k = 0; k < 3; k++) {
        double v = c[k] < 0.005 ? 0.005 : c[k] > 0.95 ? 0.95 : c[k];
        out[k] = (float)v;
    }
}

int synth_build_albedo(sp_synth_selfie *g)
{
    const sp_face_model *m = g->model;
    double aspect = m->cluster_height ? (double)m->cluster_width / m->cluster_height : 1.0;
    aspect = aspect < 0.25 ? 0.25 : aspect > 4 ? 4 : aspect;
    g->ah = (int)g->s.albedo_height;
    g->aw = (int)lround(g->ah * aspect);
    uv_raster r = { .w = g->aw, .h = g->ah };
    int ret = raster_mesh(g, &r);
    if (!ret && !(g->albedo = malloc((size_t)g->aw * (size_t)g->ah * 3 * sizeof(float))))
        ret = -ENOMEM;
    if (!ret) {
        paint_ctx pc;
        paint_init(&pc, g);
        for (size_t i = 0; i < (size_t)g->aw * (size_t)g->ah; i++)
            paint_texel(&pc, r.pos + i * 3, r.kind[i], g->albedo + i * 3);
    }
    free(r.pos);
    free(r.kind);
    return ret;
}
