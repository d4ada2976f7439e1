/* SPDX-License-Identifier: MIT */
#include "texture_eval.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static uint64_t rnd(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static double unit(uint64_t *s)
{
    return (double)(rnd(s) >> 11) * 0x1.0p-53;
}

static void put(tev_image *im, int x, int y, double r, double g, double b)
{
    float *p = im->px + 3 * ((size_t)y * im->w + x);
    p[0] = (float)(r < 0 ? 0 : r > 1 ? 1 : r), p[1] = (float)(g < 0 ? 0 : g > 1 ? 1 : g);
    p[2] = (float)(b < 0 ? 0 : b > 1 ? 1 : b);
}

static void bricks(tev_image *im, uint64_t *s)
{
    const int bh = 16, bw = 36;
    double tone[64][3];
    for (int i = 0; i < 64; i++) {
        double v = 0.8 + 0.4 * unit(s);
        tone[i][0] = 0.55 * v, tone[i][1] = 0.25 * v, tone[i][2] = 0.18 * v;
    }
    for (int y = 0; y < im->h; y++)
        for (int x = 0; x < im->w; x++) {
            int row = y / bh, xs = x + (row & 1) * bw / 2, col = xs / bw;
            double n = 0.08 * (unit(s) - 0.5);
            if (y % bh < 2 || xs % bw < 2)
                put(im, x, y, 0.75 + n, 0.73 + n, 0.68 + n);
            else {
                const double *t = tone[(row * 7 + col * 13) & 63];
                put(im, x, y, t[0] + n, t[1] + n, t[2] + n);
            }
        }
}

static void blobs(tev_image *im, uint64_t *s)
{
    for (int y = 0; y < im->h; y++)
        for (int x = 0; x < im->w; x++)
            put(im, x, y, 0.3, 0.45, 0.25);
    int n = im->w * im->h / 60;
    for (int k = 0; k < n; k++) {
        double cx = unit(s) * im->w, cy = unit(s) * im->h, r = 1.5 + 4.0 * unit(s);
        double c[3] = { 0.2 + 0.6 * unit(s), 0.3 + 0.5 * unit(s), 0.1 + 0.3 * unit(s) };
        for (int y = (int)(cy - 3 * r); y <= (int)(cy + 3 * r); y++)
            for (int x = (int)(cx - 3 * r); x <= (int)(cx + 3 * r); x++) {
                int wx = (x % im->w + im->w) % im->w, wy = (y % im->h + im->h) % im->h;
                double a = exp(-((x - cx) * (x - cx) + (y - cy) * (y - cy)) / (2 * r * r));
                const float *p = im->px + 3 * ((size_t)wy * im->w + wx);
                double q[3] = { p[0], p[1], p[2] };
                put(im, wx, wy, q[0] + a * (c[0] - q[0]), q[1] + a * (c[1] - q[1]), q[2] + a * (c[2] - q[2]));
            }
    }
}

static void stones(tev_image *im, uint64_t *s)
{
    int n = im->w * im->h / 300 + 4;
    double *site = malloc(sizeof(double) * 5 * (size_t)n);
    if (!site)
        return;
    for (int k = 0; k < n; k++) {
        double v = 0.35 + 0.4 * unit(s);
        site[5 * k] = unit(s) * im->w, site[5 * k + 1] = unit(s) * im->h;
        site[5 * k + 2] = v * 1.05, site[5 * k + 3] = v * 0.95, site[5 * k + 4] = v * 0.8;
    }
    for (int y = 0; y < im->h; y++)
        for (int x = 0; x < im->w; x++) {
            double d1 = DBL_MAX, d2 = DBL_MAX;
            int best = 0;
            for (int k = 0; k < n; k++) {
                double dx = fabs(x - site[5 * k]), dy = fabs(y - site[5 * k + 1]);
                dx = fmin(dx, im->w - dx), dy = fmin(dy, im->h - dy);
                double d = dx * dx + dy * dy;
                if (d < d1)
                    d2 = d1, d1 = d, best = k;
                else if (d < d2)
                    d2 = d;
            }
            double edge = sqrt(d2) - sqrt(d1), shade = edge < 1.5 ? 0.35 : 1.0, n0 = 0.06 * (unit(s) - 0.5);
            const double *c = site + 5 * best + 2;
            put(im, x, y, c[0] * shade + n0, c[1] * shade + n0, c[2] * shade + n0);
        }
    free(site);
}

int tev_procedural(tev_image *out, enum tev_kind kind, int w, int h, uint64_t seed)
{
    out->w = w, out->h = h;
    out->px = calloc((size_t)w * h * 3, sizeof(float));
    if (!out->px)
        return -ENOMEM;
    uint64_t s = seed * 7919 + (uint64_t)kind;
    if (kind == TEV_BRICKS)
        bricks(out, &s);
    else if (kind == TEV_BLOBS)
        blobs(out, &s);
    else
        stones(out, &s);
    return 0;
}

const char *tev_kind_name(enum tev_kind kind)
{
    static const char *names[TEV_KINDS] = { "bricks", "blobs", "stones" };
    return kind < TEV_KINDS ? names[kind] : "?";
}

void tev_free(tev_image *im)
{
    free(im->px);
    im->px = NULL;
}

static double pdist(const tev_image *a, int ax, int ay, const tev_image *b, int bx, int by, int p, double bound)
{
    double d = 0;
    for (int y = 0; y < p && d < bound; y++) {
        const float *ra = a->px + 3 * ((size_t)(ay + y) * a->w + ax), *rb = b->px + 3 * ((size_t)(by + y) * b->w + bx);
        for (int i = 0; i < 3 * p; i++)
            d += (double)((ra[i] - rb[i]) * (ra[i] - rb[i]));
    }
    return d;
}

/* Nearest exemplar patch to a's patch at (x, y); self: skip exemplar patches overlapping (x, y). */
static double nearest(const tev_image *a, int x, int y, const tev_image *ex, int p, int self)
{
    double best = DBL_MAX;
    for (int ey = 0; ey + p <= ex->h; ey++)
        for (int ex_ = 0; ex_ + p <= ex->w; ex_++) {
            if (self && abs(ex_ - x) < p && abs(ey - y) < p)
                continue;
            double d = pdist(a, x, y, ex, ex_, ey, p, best);
            best = d < best ? d : best;
        }
    return best;
}

/*
 * One patch per step x step cell, at a fixed pseudo-random place in the cell: a
 * regular grid beats against the methods' own periods (blocks, tiles) and
 * biased the mean by up to 8 % depending on the step.
 */
static double mean_nearest(const tev_image *a, const tev_image *ex, int p, int step, int self)
{
    double s = 0;
    int n = 0;
    for (int cy = 0; cy + p <= a->h; cy += step)
        for (int cx = 0; cx + p <= a->w; cx += step, n++) {
            uint64_t r = ((uint64_t)cy << 32 | (uint64_t)cx) * 0x9E3779B97F4A7C15ull;
            r = (r ^ (r >> 29)) * 0xBF58476D1CE4E5B9ull;
            r ^= r >> 32;
            int x = cx + (int)(r % (uint64_t)step), y = cy + (int)((r >> 16) % (uint64_t)step);
            x = x + p <= a->w ? x : a->w - p, y = y + p <= a->h ? y : a->h - p;
            s += sqrt(nearest(a, x, y, ex, p, self));
        }
    return n ? s / n : 0;
}

double tev_coherence(const tev_image *out, const tev_image *ex, int p, int step)
{
    double self = mean_nearest(ex, ex, p, p, 1);
    return mean_nearest(out, ex, p, step, 0) / (self > 1e-9 ? self : 1e-9);
}

/* 3x3 neighbourhood quantised to bytes, the key of exact matches. */
static void key3(const tev_image *im, int x, int y, uint8_t k[27])
{
    for (int dy = 0; dy < 3; dy++)
        for (int dx = 0; dx < 3; dx++)
            for (int c = 0; c < 3; c++)
                k[(dy * 3 + dx) * 3 + c] = (uint8_t)lrintf(im->px[3 * ((size_t)(y + dy) * im->w + x + dx) + c] * 255.0f);
}

static uint64_t hash27(const uint8_t *k)
{
    uint64_t h = 1469598103934665603ull;
    for (int i = 0; i < 27; i++)
        h = (h ^ k[i]) * 1099511628211ull;
    return h;
}

/* Union-find root with path halving. */
static int32_t root(int32_t *par, int32_t i)
{
    while (par[i] != i)
        i = par[i] = par[par[i]];
    return i;
}

double tev_repetition(const tev_image *out, const tev_image *ex)
{
    size_t cap = 1;
    while (cap < (size_t)ex->w * ex->h * 2)
        cap <<= 1;
    int32_t *tab = malloc(sizeof(int32_t) * cap);
    size_t no = (size_t)out->w * out->h;
    int64_t *off = malloc(sizeof(int64_t) * no);
    int32_t *par = malloc(sizeof(int32_t) * no), *cnt = calloc(no, sizeof(int32_t));
    double result = -1;
    if (!tab || !off || !par || !cnt)
        goto out;
    memset(tab, 0xff, sizeof(int32_t) * cap);
    uint8_t k[27], k2[27];
    for (int y = 0; y + 3 <= ex->h; y++)
        for (int x = 0; x + 3 <= ex->w; x++) {
            key3(ex, x, y, k);
            size_t h = hash27(k) & (cap - 1);
            while (tab[h] >= 0)
                h = (h + 1) & (cap - 1);
            tab[h] = y * ex->w + x;
        }
    for (size_t i = 0; i < no; i++)
        off[i] = INT64_MIN, par[i] = (int32_t)i;
    for (int y = 0; y + 3 <= out->h; y++)
        for (int x = 0; x + 3 <= out->w; x++) {
            key3(out, x, y, k);
            for (size_t h = hash27(k) & (cap - 1); tab[h] >= 0; h = (h + 1) & (cap - 1)) {
                key3(ex, tab[h] % ex->w, tab[h] / ex->w, k2);
                if (!memcmp(k, k2, 27)) { /* the centre pixel's offset to its first exact match */
                    off[(size_t)(y + 1) * out->w + x + 1] = (int64_t)(tab[h] / ex->w - y) * 65536 + (tab[h] % ex->w - x);
                    break;
                }
            }
        }
    for (int y = 0; y < out->h; y++)
        for (int x = 0; x < out->w; x++) {
            size_t i = (size_t)y * out->w + x;
            if (off[i] == INT64_MIN)
                continue;
            if (x && off[i - 1] == off[i])
                par[root(par, (int32_t)i)] = root(par, (int32_t)(i - 1));
            if (y && off[i - out->w] == off[i])
                par[root(par, (int32_t)i)] = root(par, (int32_t)(i - out->w));
        }
    int32_t big = 0;
    for (size_t i = 0; i < no; i++)
        if (off[i] != INT64_MIN) {
            int32_t r = root(par, (int32_t)i);
            big = ++cnt[r] > big ? cnt[r] : big;
        }
    result = (double)big / ((double)ex->w * ex->h);
out:
    free(tab), free(off), free(par), free(cnt);
    return result;
}

static double step2(const tev_image *im, int x0, int y0, int x1, int y1)
{
    const float *a = im->px + 3 * ((size_t)y0 * im->w + x0), *b = im->px + 3 * ((size_t)y1 * im->w + x1);
    double d = 0;
    for (int c = 0; c < 3; c++)
        d += (double)((a[c] - b[c]) * (a[c] - b[c]));
    return d;
}

/* Mean squared step across the vertical line before column x (rows) or the horizontal one before row x. */
static double line_step(const tev_image *im, int x, int vertical)
{
    double s = 0;
    int n = vertical ? im->h : im->w;
    for (int k = 0; k < n; k++)
        s += vertical ? step2(im, x - 1, k, x, k) : step2(im, k, x - 1, k, x);
    return s / n;
}

double tev_seam_ratio_at(const tev_image *out, int first, int period)
{
    double on = 0, off = 0;
    int non = 0, noff = 0;
    if (first <= 0 || period <= 0)
        return 1.0;
    for (int v = 0; v < 2; v++) {
        int n = v ? out->w : out->h;
        for (int t = first; t < n; t += period) {
            on += line_step(out, t, v), non++;
            for (int d = -32; d <= 32; d += 2) /* even shifts: the same pixel parity as the line */
                if (d && t + d > 0 && t + d < n)
                    off += line_step(out, t + d, v), noff++;
        }
    }
    if (!non || !noff || off <= 0)
        return 1.0;
    return (on / non) / (off / noff);
}

double tev_seam_ratio(const tev_image *out, int tile)
{
    return tev_seam_ratio_at(out, tile, tile);
}

static void histogram(const tev_image *im, double *h)
{
    memset(h, 0, sizeof(double) * 512);
    size_t n = (size_t)im->w * im->h;
    for (size_t i = 0; i < n; i++) {
        int b[3];
        for (int c = 0; c < 3; c++) {
            int v = (int)(im->px[3 * i + c] * 8.0f);
            b[c] = v < 0 ? 0 : v > 7 ? 7 : v;
        }
        h[b[0] * 64 + b[1] * 8 + b[2]] += 1.0 / (double)n;
    }
}

double tev_histogram_distance(const tev_image *a, const tev_image *b)
{
    double ha[512], hb[512], d = 0;
    histogram(a, ha);
    histogram(b, hb);
    for (int i = 0; i < 512; i++)
        d += fabs(ha[i] - hb[i]);
    return d;
}

/* Normalised autocorrelation of luminance at shifts [-r, r] x [0, r] over the top-left 256 x 256 at most. */
static void autocorr(const tev_image *im, int r, double *out)
{
    int w = im->w < 256 ? im->w : 256, h = im->h < 256 ? im->h : 256;
    double mean = 0, var = 0;
    float *l = malloc(sizeof(float) * (size_t)w * h);
    if (!l)
        return;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const float *p = im->px + 3 * ((size_t)y * im->w + x);
            l[y * w + x] = 0.299f * p[0] + 0.587f * p[1] + 0.114f * p[2];
            mean += (double)l[y * w + x];
        }
    mean /= (double)w * h;
    for (int i = 0; i < w * h; i++)
        var += ((double)l[i] - mean) * ((double)l[i] - mean);
    var = var / ((double)w * h) + 1e-12;
    int k = 0;
    for (int dy = 0; dy <= r; dy++)
        for (int dx = -r; dx <= r; dx++, k++) {
            double s = 0;
            long n = 0;
            for (int y = 0; y + dy < h; y++)
                for (int x = dx < 0 ? -dx : 0; x < w && x + dx < w; x++, n++)
                    s += ((double)l[y * w + x] - mean) * ((double)l[(y + dy) * w + x + dx] - mean);
            out[k] = n ? s / n / var : 0;
        }
    free(l);
}

double tev_autocorr_distance(const tev_image *a, const tev_image *b, int r)
{
    int n = (r + 1) * (2 * r + 1);
    double *ca = calloc((size_t)n, sizeof(double)), *cb = calloc((size_t)n, sizeof(double)), d = 0;
    if (!ca || !cb) {
        free(ca), free(cb);
        return -1;
    }
    autocorr(a, r, ca);
    autocorr(b, r, cb);
    for (int i = 0; i < n; i++)
        d += (ca[i] - cb[i]) * (ca[i] - cb[i]);
    free(ca), free(cb);
    return sqrt(d / n);
}
