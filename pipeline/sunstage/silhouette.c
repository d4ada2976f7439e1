/* SPDX-License-Identifier: MIT */
/*
 * Silhouette loss. Target: the edge of a per-frame skin mask (pixels whose
 * chroma is more typical of the skin inside the landmark outline than of the
 * background far from it), as a signed Euclidean distance (negative inside).
 * Model: the projected outline of the face-skin and scalp vertices (per image
 * row the leftmost and rightmost, per column the topmost, kept when seen at a
 * grazing angle, i.e. on the occluding contour). Residual per outline vertex,
 * one-sided: a face vertex outside the skin, a scalp vertex inside it (the
 * distance map is bilinear, so the gradient is analytic), with the
 * projection's Jacobian with respect to the face parameters.
 */
#include "pipeline/sunstage/sunstage_internal.h"
#include "pipeline/sunstage/landmarks.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define SIL_FAR 1e10f
#define SIL_REACH 2.2  /* the skin mask may reach this far beyond the landmark outline (neck, ears, a bald crown)... */
#define SIL_LEAK 0.15  /* ...with at most this fraction of its pixels, else it leaked into the background */
#define SIL_GRAZING 0.35 /* |cos| between vertex normal and view ray below this: on the contour */
#define SIL_THIN 0.15    /* eye widths (outer corners): skin joined by a band under twice this is not the head */

/* Felzenszwalb-Huttenlocher 1-D squared distance transform of f (n) into d; v, z work arrays. */
static void dt1d(const float *f, int n, float *d, int *v, float *z)
{
    int k = 0;
    v[0] = 0;
    z[0] = -SIL_FAR;
    z[1] = SIL_FAR;
    for (int q = 1; q < n; q++) {
        float s;
        for (;;) {
            int p = v[k];
            s = ((f[q] + (float)(q * q)) - (f[p] + (float)(p * p))) / (float)(2 * (q - p));
            if (s <= z[k] && k > 0)
                k--;
            else
                break;
        }
        if (s <= z[k]) { /* k == 0 and the new parabola dominates */
            v[0] = q;
            z[0] = -SIL_FAR;
            z[1] = SIL_FAR;
            continue;
        }
        k++;
        v[k] = q;
        z[k] = s;
        z[k + 1] = SIL_FAR;
    }
    k = 0;
    for (int q = 0; q < n; q++) {
        while (z[k + 1] < (float)q)
            k++;
        float dq = (float)(q - v[k]);
        d[q] = dq * dq + f[v[k]];
    }
}

/* Euclidean distance (pixels) to the nearest seed (dist[i] == 0 on entry, else SIL_FAR), in place. */
static int edt(float *dist, int w, int h)
{
    int n = w > h ? w : h;
    float *f = malloc(sizeof(float) * (size_t)n * 3 + sizeof(float));
    int *v = malloc(sizeof(int) * (size_t)n);
    if (!f || !v) {
        free(f);
        free(v);
        return -ENOMEM;
    }
    float *d = f + n, *z = d + n;
    for (int x = 0; x < w; x++) {
        for (int y = 0; y < h; y++)
            f[y] = dist[(size_t)y * (size_t)w + (size_t)x];
        dt1d(f, h, d, v, z);
        for (int y = 0; y < h; y++)
            dist[(size_t)y * (size_t)w + (size_t)x] = d[y];
    }
    for (int y = 0; y < h; y++) {
        float *row = dist + (size_t)y * (size_t)w;
        memcpy(f, row, sizeof(float) * (size_t)w);
        dt1d(f, w, d, v, z);
        for (int x = 0; x < w; x++)
            row[x] = sqrtf(fmaxf(d[x], 0.0f));
    }
    free(f);
    free(v);
    return 0;
}

static int inside_outline(const double lm[136], double x, double y);

/* Point in the polygon through landmarks (jaw 0..16, brows 26..17), scaled by k about the nose tip, by ray crossing. */
static int inside_scaled(const double lm[136], double k, double x, double y)
{
    x = lm[60] + (x - lm[60]) / k;
    y = lm[61] + (y - lm[61]) / k;
    return inside_outline(lm, x, y);
}

static int inside_outline(const double lm[136], double x, double y)
{
    static const int order[27] = { 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13,
                                   14, 15, 16, 26, 25, 24, 23, 22, 21, 20, 19, 18, 17 };
    int in = 0;
    for (int i = 0, j = 26; i < 27; j = i++) {
        double xi = lm[2 * order[i]], yi = lm[2 * order[i] + 1], xj = lm[2 * order[j]], yj = lm[2 * order[j] + 1];
        if ((yi > y) != (yj > y) && x < (xj - xi) * (y - yi) / (yj - yi) + xi)
            in = !in;
    }
    return in;
}

/* Chroma of the undone display gamma (the power only: ratios of light are what separate skin from grey). */
static void chroma(const float *p, double c[2])
{
    double r = pow(fmax((double)p[0], 0.0), 2.2), g = pow(fmax((double)p[1], 0.0), 2.2),
           b = pow(fmax((double)p[2], 0.0), 2.2), s = r + g + b + 1e-6;
    c[0] = r / s;
    c[1] = g / s;
}

/* Mean (pass 0) or covariance (pass 1, given the mean) of the chroma inside the landmark outline; pixel count. */
static int outline_stats(const float *rgb, int w, int h, const double lm[136], int pass, double m[2], double S[3])
{
    int n = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const float *p = rgb + ((size_t)y * (size_t)w + (size_t)x) * 3;
            if (!inside_outline(lm, x, y) || (double)(p[0] + p[1] + p[2]) < 0.15)
                continue;
            double c[2];
            chroma(p, c);
            n++;
            if (pass == 0) {
                m[0] += c[0];
                m[1] += c[1];
            } else {
                double a = c[0] - m[0], b = c[1] - m[1];
                S[0] += a * a;
                S[1] += a * b;
                S[2] += b * b;
            }
        }
    return n;
}

#define SKIN_BINS 64
#define SKIN_LO 0.1 /* chroma range the histograms resolve (r and g of r + g + b) */
#define SKIN_HI 0.6
#define SKIN_FAR 2.5 /* background colours are learned outside the landmark outline scaled by this */

static int chroma_bin(const double c[2])
{
    int a = (int)((c[0] - SKIN_LO) / (SKIN_HI - SKIN_LO) * SKIN_BINS);
    int b = (int)((c[1] - SKIN_LO) / (SKIN_HI - SKIN_LO) * SKIN_BINS);
    a = a < 0 ? 0 : a >= SKIN_BINS ? SKIN_BINS - 1 : a;
    b = b < 0 ? 0 : b >= SKIN_BINS ? SKIN_BINS - 1 : b;
    return a * SKIN_BINS + b;
}

/* 3x3 box smoothing of a chroma histogram, so sparse bins generalise to their neighbours. */
static void smooth_hist(const double *in, double *out)
{
    for (int a = 0; a < SKIN_BINS; a++)
        for (int b = 0; b < SKIN_BINS; b++) {
            double s = 0.0;
            for (int da = -1; da <= 1; da++)
                for (int db = -1; db <= 1; db++) {
                    int x = a + da, y = b + db;
                    if (x >= 0 && y >= 0 && x < SKIN_BINS && y < SKIN_BINS)
                        s += in[x * SKIN_BINS + y];
                }
            out[a * SKIN_BINS + b] = s / 9.0;
        }
}

/*
 * Skin mask: a pixel is skin when its chroma is more typical of the skin inside the landmark
 * outline than of the background far from it (two per-frame chroma histograms, a likelihood
 * ratio), and within 6 sigma of the skin's chroma. Returns 0 or SP_ENODATA.
 */
static int skin_mask(const float *rgb, int w, int h, const double lm[136], uint8_t *mask)
{
    double m[2] = { 0, 0 }, S[3] = { 0, 0, 0 };
    int n = outline_stats(rgb, w, h, lm, 0, m, S);
    if (n < 20)
        return SP_ENODATA;
    m[0] /= n;
    m[1] /= n;
    outline_stats(rgb, w, h, lm, 1, m, S);
    for (int k = 0; k < 3; k++)
        S[k] /= n;
    /* a floor on the spread: flat-shaded synthetic skin would otherwise give a zero covariance */
    S[0] += 1e-4;
    S[2] += 1e-4;
    double det = S[0] * S[2] - S[1] * S[1];
    if (!(det > 0.0))
        return SP_ENODATA;
    double *hist = calloc(4 * SKIN_BINS * SKIN_BINS, sizeof(double));
    if (!hist)
        return -ENOMEM;
    double *hs = hist, *hb = hist + SKIN_BINS * SKIN_BINS, *ss = hb + SKIN_BINS * SKIN_BINS,
           *sb = ss + SKIN_BINS * SKIN_BINS, ns = 0.0, nb = 0.0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const float *p = rgb + ((size_t)y * (size_t)w + (size_t)x) * 3;
            if ((double)(p[0] + p[1] + p[2]) < 0.15)
                continue;
            int in = inside_outline(lm, x, y);
            if (!in && inside_scaled(lm, SKIN_FAR, x, y))
                continue;
            double c[2];
            chroma(p, c);
            if (in) {
                hs[chroma_bin(c)] += 1.0;
                ns += 1.0;
            } else {
                hb[chroma_bin(c)] += 1.0;
                nb += 1.0;
            }
        }
    smooth_hist(hs, ss);
    smooth_hist(hb, sb);
    for (int i = 0; i < w * h; i++) {
        const float *p = rgb + (size_t)i * 3;
        double c[2];
        chroma(p, c);
        double a = c[0] - m[0], b = c[1] - m[1];
        double d2 = (S[2] * a * a - 2.0 * S[1] * a * b + S[0] * b * b) / det;
        int k = chroma_bin(c);
        int skinlike = nb < 1.0 || ss[k] / ns > 0.5 * sb[k] / nb;
        mask[i] = d2 < 36.0 && skinlike && (double)(p[0] + p[1] + p[2]) >= 0.15;
    }
    free(hist);
    return 0;
}

/* Marks with `to` every pixel of value `from` 4-connected to the `top` seeds on the stack (already `to`). */
static void flood(uint8_t *mask, int w, int h, int *stack, int top, uint8_t from, uint8_t to)
{
    while (top > 0) {
        int i = stack[--top], x = i % w, y = i / w;
        int nb[4] = { x > 0 ? i - 1 : -1, x < w - 1 ? i + 1 : -1, y > 0 ? i - w : -1, y < h - 1 ? i + w : -1 };
        for (int k = 0; k < 4; k++)
            if (nb[k] >= 0 && mask[nb[k]] == from) {
                mask[nb[k]] = to;
                stack[top++] = nb[k];
            }
    }
}

/*
 * Keeps the 4-connected parts of mask that reach into the landmark outline (a highlight or a
 * shadow on the nose tip must not lose the face); stack holds w * h ints.
 */
static void keep_face_components(uint8_t *mask, int w, int h, const double lm[136], int *stack)
{
    int top = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            if (mask[y * w + x] == 1 && inside_outline(lm, x, y)) {
                mask[y * w + x] = 2;
                stack[top++] = y * w + x;
            }
    flood(mask, w, h, stack, top, 1, 2);
    for (int i = 0; i < w * h; i++)
        mask[i] = mask[i] == 2;
}

/* Fills the holes of mask (background not 4-connected to the image border: highlights, eyes, mouth). */
static void fill_holes(uint8_t *mask, int w, int h, int *stack)
{
    int top = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            if ((x == 0 || y == 0 || x == w - 1 || y == h - 1) && !mask[y * w + x]) {
                mask[y * w + x] = 3;
                stack[top++] = y * w + x;
            }
    flood(mask, w, h, stack, top, 0, 3);
    for (int i = 0; i < w * h; i++)
        mask[i] = mask[i] != 3;
}

/*
 * Cuts what the skin mask reaches only through a band thinner than 2 r (r = SIL_THIN eye widths) from the face:
 * a warm horizon behind the head joining a skin-coloured wall, and the whole frame's mask leaked. The mask
 * opened by a disc of radius r (eroded, grown back by r; the opening lies inside the mask), so face_part then
 * keeps the face without the band. Thin parts of the head go too (the ears' rims); only frames that leaked
 * come here. Grown back by r once more and cut to the mask, the ears stayed but so did a stub of the band at
 * each side of the head, which moved the sun more.
 */
static int cut_thin_joins(uint8_t *mask, int w, int h, const double lm[136])
{
    double r = SIL_THIN * ss_lm_interocular(lm);
    if (!(r >= 1.0))
        return 0; /* a face this small has no band thinner than a pixel to cut */
    size_t n = (size_t)w * (size_t)h;
    float *d = malloc(sizeof(float) * n);
    if (!d)
        return -ENOMEM;
    for (size_t i = 0; i < n; i++) /* erosion: farther than r from every non-skin pixel */
        d[i] = mask[i] ? SIL_FAR : 0.0f;
    int ret = edt(d, w, h);
    for (size_t i = 0; !ret && i < n; i++)
        d[i] = d[i] > (float)r ? 0.0f : SIL_FAR;
    if (!ret && !(ret = edt(d, w, h))) /* dilation: within r of the eroded mask */
        for (size_t i = 0; i < n; i++)
            mask[i] = d[i] <= (float)r;
    free(d);
    return ret;
}

/* The face's part of a skin mask, holes filled; SP_ENODATA when it leaks far beyond the face (no usable outline). */
static int face_part(uint8_t *mask, int w, int h, const double lm[136], int *stack)
{
    keep_face_components(mask, w, h, lm, stack);
    fill_holes(mask, w, h, stack);
    int in = 0, out = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            if (mask[y * w + x]) {
                if (inside_scaled(lm, SIL_REACH, x, y))
                    in++;
                else
                    out++;
            }
    return out > SIL_LEAK * (in + out) ? SP_ENODATA : 0;
}

int ss_silhouette_target(const float *rgb, int w, int h, const double lm[136], float *dist)
{
    if (!rgb || !lm || !dist || w < 4 || h < 4)
        return -EINVAL;
    size_t n = (size_t)w * (size_t)h;
    uint8_t *mask = malloc(2 * n), *raw = mask ? mask + n : NULL;
    int *stack = malloc(sizeof(int) * n);
    int ret = mask && stack ? skin_mask(rgb, w, h, lm, raw) : -ENOMEM;
    if (!ret) {
        memcpy(mask, raw, n);
        if (face_part(mask, w, h, lm, stack)) { /* leaked: again without what joins the face by a thin band */
            memcpy(mask, raw, n);
            ret = cut_thin_joins(mask, w, h, lm);
            ret = ret ? ret : face_part(mask, w, h, lm, stack);
        }
    }
    if (!ret) {
        int nb = 0;
        for (int y = 1; y < h - 1; y++)
            for (int x = 1; x < w - 1; x++) {
                int i = y * w + x; /* boundary: a mask pixel next to a non-mask one, the image border aside */
                nb += mask[i] && (!mask[i - 1] || !mask[i + 1] || !mask[i - w] || !mask[i + w]);
            }
        /*
         * Signed distance to the edge between skin and non-skin pixels (half a pixel beyond a pixel
         * centre): positive outside, negative inside. Only real non-skin pixels seed the inside
         * distance, so the image border is no silhouette.
         */
        float *in_d = nb >= 8 ? malloc(sizeof(float) * (size_t)w * (size_t)h) : NULL;
        ret = nb < 8 ? SP_ENODATA : in_d ? 0 : -ENOMEM;
        for (int i = 0; !ret && i < w * h; i++) {
            dist[i] = mask[i] ? 0.0f : SIL_FAR;
            in_d[i] = mask[i] ? SIL_FAR : 0.0f;
        }
        if (!ret && !(ret = edt(dist, w, h)) && !(ret = edt(in_d, w, h))) {
            for (int i = 0; i < w * h; i++)
                dist[i] = mask[i] ? 0.5f - in_d[i] : dist[i] - 0.5f;
            ret = nb;
        }
        free(in_d);
    }
    free(mask);
    free(stack);
    return ret;
}

/* Area-weighted vertex normals of camera-frame positions v into nrm (3 * n_vertices). */
static void vertex_normals(const sp_mesh *mesh, const double *v, double *nrm)
{
    memset(nrm, 0, sizeof(double) * 3 * mesh->n_vertices);
    for (uint32_t t = 0; t < mesh->n_triangles; t++) {
        const uint32_t *tri = mesh->tri_vertices + (size_t)t * 3;
        const double *a = v + (size_t)tri[0] * 3, *b = v + (size_t)tri[1] * 3, *c = v + (size_t)tri[2] * 3;
        double e1[3] = { b[0] - a[0], b[1] - a[1], b[2] - a[2] }, e2[3] = { c[0] - a[0], c[1] - a[1], c[2] - a[2] };
        double n[3] = { e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0] };
        for (int k = 0; k < 3; k++)
            for (int d = 0; d < 3; d++)
                nrm[(size_t)tri[k] * 3 + (size_t)d] += n[d];
    }
}

/* Keeps vertex i in slot k of the extremes table when u beats the slot's value in direction sgn. */
static void extreme(uint32_t *idx, double *ext, int k, uint32_t i, double u, double sgn)
{
    if (sgn * u > sgn * ext[k] || idx[k] == UINT32_MAX) {
        ext[k] = u;
        idx[k] = i;
    }
}

int ss_silhouette_vertices(const sp_face_model *m, const uint8_t *scalp, const sp_face_params *p,
                           const sp_face_camera *cam, int w, int h, uint32_t *idx, int cap, double *work)
{
    if (!m || !p || !cam || !idx || !work || w < 1 || h < 1 || cap < 1)
        return -EINVAL;
    uint32_t nv = m->mesh.n_vertices;
    double *v = work, *nrm = work + (size_t)nv * 3;
    int ret = sp_face_model_eval(m, p, v);
    if (ret)
        return ret;
    vertex_normals(&m->mesh, v, nrm);
    /*
     * The table: per row the leftmost (slot 2y) and rightmost (2y + 1) outline vertex, then with a
     * scalp per column the topmost (slot 2 h + x), so the crown's outline is found too; idx doubles as it.
     */
    int rows = h, cols = scalp ? w : 0;
    if (2 * rows + cols > cap) {
        rows = cap / 2 < h ? cap / 2 : h;
        cols = scalp && cap - 2 * rows > 0 ? (cap - 2 * rows < w ? cap - 2 * rows : w) : 0;
    }
    int slots = 2 * rows + cols;
    double *ext = malloc(sizeof(double) * (size_t)slots);
    uint8_t *taken = calloc(nv, 1); /* a vertex extreme in its row and its column is one residual */
    if (!ext || !taken) {
        free(ext);
        free(taken);
        return -ENOMEM;
    }
    for (int k = 0; k < slots; k++)
        idx[k] = UINT32_MAX;
    for (uint32_t i = 0; i < nv; i++) {
        const double *x = v + (size_t)i * 3;
        if (!(m->face_mask[i] || (scalp && scalp[i])) || !(x[2] > 1e-6))
            continue;
        double u = cam->fx * x[0] / x[2] + cam->cx, y = cam->fy * x[1] / x[2] + cam->cy;
        int r = (int)floor(y), c = (int)floor(u);
        if (r >= 0 && r < rows) {
            extreme(idx, ext, 2 * r, i, u, -1.0);
            extreme(idx, ext, 2 * r + 1, i, u, 1.0);
        }
        if (c >= 0 && c < cols)
            extreme(idx, ext, 2 * rows + c, i, y, -1.0);
    }
    free(ext);
    int n = 0;
    for (int k = 0; k < slots; k++) {
        uint32_t i = idx[k];
        if (i == UINT32_MAX)
            continue;
        const double *x = v + (size_t)i * 3, *nn = nrm + (size_t)i * 3;
        double ln = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
        double lx = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
        if (!(ln > 0.0) || !(lx > 0.0))
            continue;
        double c = (nn[0] * x[0] + nn[1] * x[1] + nn[2] * x[2]) / (ln * lx);
        if (fabs(c) < SIL_GRAZING && !taken[i]) {
            taken[i] = 1;
            idx[n++] = i | (scalp && scalp[i] ? SS_SIL_SCALP : 0u);
        }
    }
    free(taken);
    return n;
}

/* Bilinear sample of the distance map and its image gradient; clamps to the border. */
static double sample(const float *d, int w, int h, double u, double v, double *du, double *dv)
{
    u = u < 0.0 ? 0.0 : (u > w - 1.001 ? w - 1.001 : u);
    v = v < 0.0 ? 0.0 : (v > h - 1.001 ? h - 1.001 : v);
    int x = (int)u, y = (int)v;
    double fx = u - x, fy = v - y;
    const float *p = d + (size_t)y * (size_t)w + (size_t)x;
    double a = p[0], b = p[1], c = p[w], e = p[w + 1];
    *du = (1.0 - fy) * (b - a) + fy * (e - c);
    *dv = (1.0 - fx) * (c - a) + fx * (e - b);
    return (1.0 - fy) * ((1.0 - fx) * a + fx * b) + fy * ((1.0 - fx) * c + fx * e);
}

/* dR/dr_k for the rotation vector r (Gallego and Yezzi's closed form), into dR[k][9]. */
static void rotation_derivatives(const double r[3], double dR[3][9])
{
    double R[9];
    ss_rotvec_to_matrix(r, R);
    double th2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    for (int k = 0; k < 3; k++) {
        double S[9];
        if (th2 < 1e-16) { /* at identity: dR/dr_k = [e_k]x */
            double e[3] = { k == 0, k == 1, k == 2 };
            double M[9] = { 0, -e[2], e[1], e[2], 0, -e[0], -e[1], e[0], 0 };
            memcpy(dR[k], M, sizeof(M));
            continue;
        }
        double ie[3] = { (k == 0) - R[k], (k == 1) - R[3 + k], (k == 2) - R[6 + k] }; /* (I - R) e_k */
        double c[3] = { r[1] * ie[2] - r[2] * ie[1], r[2] * ie[0] - r[0] * ie[2], r[0] * ie[1] - r[1] * ie[0] };
        double a[3] = { r[k] * r[0] + c[0], r[k] * r[1] + c[1], r[k] * r[2] + c[2] };
        double M[9] = { 0, -a[2], a[1], a[2], 0, -a[0], -a[1], a[0], 0 };
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                S[i * 3 + j] = (M[i * 3] * R[j] + M[i * 3 + 1] * R[3 + j] + M[i * 3 + 2] * R[6 + j]) / th2;
        memcpy(dR[k], S, sizeof(S));
    }
}

/* Model-frame position of vertex i (mean + identity + expression). */
static void model_point(const sp_face_model *m, const sp_face_params *p, uint32_t i, double x[3])
{
    size_t nv = m->mesh.n_vertices;
    for (int d = 0; d < 3; d++)
        x[d] = (double)m->mesh.positions[(size_t)i * 3 + (size_t)d];
    for (uint32_t k = 0; p->id && k < m->n_id; k++)
        for (int d = 0; d < 3; d++)
            x[d] += p->id[k] * (double)m->id_basis[((size_t)k * nv + i) * 3 + (size_t)d];
    for (uint32_t k = 0; p->exp && k < m->n_exp; k++)
        for (int d = 0; d < 3; d++)
            x[d] += p->exp[k] * (double)m->exp_basis[((size_t)k * nv + i) * 3 + (size_t)d];
}

static void mat_vec(const double M[9], const double x[3], double y[3])
{
    for (int i = 0; i < 3; i++)
        y[i] = M[i * 3] * x[0] + M[i * 3 + 1] * x[1] + M[i * 3 + 2] * x[2];
}

/* Jacobian row of the residual: g (du, dv) through the projection, into row (n_params). */
static void jacobian_row(const sp_face_model *m, const sp_face_params *p, const sp_face_camera *cam, uint32_t i,
                         const double R[9], const double dR[3][9], const double X[3], double gu, double gv,
                         double *row)
{
    size_t nv = m->mesh.n_vertices;
    double iz = 1.0 / X[2];
    /* dr/dX for the camera-frame point */
    double g[3] = { gu * cam->fx * iz, gv * cam->fy * iz, -(gu * cam->fx * X[0] + gv * cam->fy * X[1]) * iz * iz };
    double gR[3]; /* s R^T g: the gradient with respect to a model-frame offset */
    for (int d = 0; d < 3; d++)
        gR[d] = p->s * (R[d] * g[0] + R[3 + d] * g[1] + R[6 + d] * g[2]);
    uint32_t c = 0;
    for (uint32_t k = 0; k < m->n_id; k++, c++) {
        const float *b = m->id_basis + ((size_t)k * nv + i) * 3;
        row[c] = gR[0] * (double)b[0] + gR[1] * (double)b[1] + gR[2] * (double)b[2];
    }
    for (uint32_t k = 0; k < m->n_exp; k++, c++) {
        const float *b = m->exp_basis + ((size_t)k * nv + i) * 3;
        row[c] = gR[0] * (double)b[0] + gR[1] * (double)b[1] + gR[2] * (double)b[2];
    }
    double x[3], Rx[3];
    model_point(m, p, i, x);
    for (int k = 0; k < 3; k++, c++) {
        double y[3];
        mat_vec(dR[k], x, y);
        row[c] = p->s * (g[0] * y[0] + g[1] * y[1] + g[2] * y[2]);
    }
    for (int k = 0; k < 3; k++, c++)
        row[c] = g[k];
    mat_vec(R, x, Rx);
    row[c] = g[0] * Rx[0] + g[1] * Rx[1] + g[2] * Rx[2];
}

int ss_silhouette_residuals(const sp_face_model *m, const sp_face_params *p, const sp_face_camera *cam,
                            const uint32_t *idx, int n, const float *dist, int w, int h, double *r, double *jac)
{
    if (!m || !p || !cam || (!idx && n > 0) || !dist || !r || n < 0 || w < 2 || h < 2)
        return -EINVAL;
    double R[9], dR[3][9];
    ss_rotvec_to_matrix(p->rotvec, R);
    if (jac)
        rotation_derivatives(p->rotvec, dR);
    uint32_t nc = sp_face_model_n_params(m);
    for (int j = 0; j < n; j++) {
        double x[3], X[3];
        model_point(m, p, idx[j] & ~SS_SIL_SCALP, x);
        mat_vec(R, x, X);
        for (int d = 0; d < 3; d++)
            X[d] = p->s * X[d] + p->t[d];
        double *row = jac ? jac + (size_t)j * nc : NULL;
        if (!(X[2] > 1e-6)) { /* behind the camera: no residual, no gradient */
            r[j] = 0.0;
            if (row)
                memset(row, 0, sizeof(double) * nc);
            continue;
        }
        double u = cam->fx * X[0] / X[2] + cam->cx, v = cam->fy * X[1] / X[2] + cam->cy, gu, gv;
        double d = sample(dist, w, h, u, v, &gu, &gv);
        if (u <= 0.0 || u >= w - 1.001)
            gu = 0.0; /* clamped: flat outside */
        if (v <= 0.0 || v >= h - 1.001)
            gv = 0.0;
        /* a face vertex pulls in only from outside the skin, a scalp vertex out only from inside it */
        double sgn = (idx[j] & SS_SIL_SCALP) ? (d < 0.0 ? -1.0 : 0.0) : (d > 0.0 ? 1.0 : 0.0);
        r[j] = sgn * d;
        gu *= sgn;
        gv *= sgn;
        if (row)
            jacobian_row(m, p, cam, idx[j] & ~SS_SIL_SCALP, R, dR, X, gu, gv, row);
    }
    return 0;
}

int ss_silhouette_prepare(sp_sunstage *ss)
{
    int found = 0;
    for (int i = 0; ss->res.slots && i < ss->res.n_slots; i++) {
        ss_frame *f = &ss->res.slots[i];
        f->sil_ok = 0;
        if (!f->used)
            continue;
        if (!f->sil && !(f->sil = malloc(sizeof(float) * (size_t)ss->W * (size_t)ss->H)))
            return -ENOMEM;
        int ret = ss_silhouette_target(f->rgb, ss->W, ss->H, f->lm, f->sil);
        if (ret == -ENOMEM)
            return ret;
        f->sil_ok = ret > 0;
        found += f->sil_ok;
    }
    return found;
}
