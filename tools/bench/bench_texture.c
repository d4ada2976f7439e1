/* SPDX-License-Identifier: MIT */
/*
 * bench_texture: sunprobe's texture synthesis against image quilting (Efros and
 * Freeman 2001, implemented here as the baseline: blocks chosen among the
 * candidates within 10% of the best overlap error, joined along minimum-error
 * cuts) on procedural exemplars, crops of the path-traced captures (ground,
 * shirt, skin; when ../shared/captures is there) and a Debian-packaged fabric
 * (blender-data, GPL-2+). Measures: coherence, repetition, seams, colour
 * histogram and autocorrelation distances (texture_eval.h), and time. The
 * seam ratio is also taken where there is no tile border, at the tile centres
 * and at the block cut a block step inside each tile: the last summaries say
 * how often the borders exceed each.
 *
 *   bench_texture [quality] [--size N] [--captures DIR] [--seed N|A-B] [--quilt-seed N|A-B] [--coherence-step S]
 *       [--dump DIR]
 *       (--seed: sunprobe's, 1 unless given; --quilt-seed: quilting's, 11 unless given. With a range of either,
 *       every pair of seeds is compared and the spread reported: the median ratio over the exemplars per pair, its
 *       range and how many pairs are below 1, and each exemplar's range over the pairs. Coherence samples a
 *       7 x 7 patch at a fixed random place in every S x S cell, default 5; a regular grid, of any step, lined
 *       up unequally with the two methods' cuts; --dump writes every output and exemplar as DIR/NAME-WHO[-SEED].png
 *       to look at what a figure comes from)
 *   bench_texture scale --size WxH [--out FILE.png] [--threads N]   (one size per process: peak RSS)
 */
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include "export/png.h"
#include "export/png_read.h"
#include "sunprobe/sp_texture.h"
#include "pipeline/texture/texture_internal.h"
#include "texture_eval.h"

#define FABRIC "/usr/share/blender/scripts/addons/archimesh/images/fabric_diffuse.png"

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static double cpu_s(void)
{
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    return (double)u.ru_utime.tv_sec + (double)u.ru_stime.tv_sec + 1e-6 * (double)(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

/* A crop of a PNG file as an exemplar; 0, or -1 when the file is not there. */
static int load_crop(const char *path, int x0, int y0, int w, int h, tev_image *out)
{
    uint8_t *rgba = NULL;
    uint32_t iw, ih;
    if (sp_png_read_rgba(path, &rgba, &iw, &ih) || (uint32_t)(x0 + w) > iw || (uint32_t)(y0 + h) > ih) {
        free(rgba);
        return -1;
    }
    *out = (tev_image){ malloc(sizeof(float) * 3 * (size_t)w * h), w, h };
    for (int y = 0; out->px && y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++)
                out->px[3 * ((size_t)y * w + x) + c] = (float)rgba[4 * ((size_t)(y + y0) * iw + x + x0) + c] / 255.0f;
    free(rgba);
    return out->px ? 0 : -1;
}

/* ---- image quilting, the baseline ---- */

static double overlap_err(const tev_image *ex, int ex0, int ey0, const tev_image *out, int bx, int by, int bw, int bh,
                          int O)
{
    double e = 0;
    for (int y = 0; y < bh; y++)
        for (int x = 0; x < bw; x++) {
            if (!((bx > 0 && x < O) || (by > 0 && y < O)))
                continue;
            const float *a = ex->px + 3 * ((size_t)(ey0 + y) * ex->w + ex0 + x), *b = out->px + 3 * ((size_t)(by + y) * out->w + bx + x);
            for (int c = 0; c < 3; c++)
                e += (double)((a[c] - b[c]) * (a[c] - b[c]));
        }
    return e;
}

static double pix_err(const tev_image *ex, int ex0, int ey0, const tev_image *out, int bx, int by, int x, int y)
{
    const float *a = ex->px + 3 * ((size_t)(ey0 + y) * ex->w + ex0 + x), *b = out->px + 3 * ((size_t)(by + y) * out->w + bx + x);
    double e = 0;
    for (int c = 0; c < 3; c++)
        e += (double)((a[c] - b[c]) * (a[c] - b[c]));
    return e;
}

/* Minimum-error cut through an n x O strip of errors (row-major along n): cut[k] = where the new block starts. */
static void min_cut(const double *err, int n, int O, int *cut)
{
    double *acc = malloc(sizeof(double) * (size_t)n * O);
    if (!acc)
        return;
    for (int k = 0; k < n; k++)
        for (int o = 0; o < O; o++) {
            double best = 0;
            if (k) {
                best = acc[(k - 1) * O + o];
                if (o > 0 && acc[(k - 1) * O + o - 1] < best)
                    best = acc[(k - 1) * O + o - 1];
                if (o + 1 < O && acc[(k - 1) * O + o + 1] < best)
                    best = acc[(k - 1) * O + o + 1];
            }
            acc[k * O + o] = err[k * O + o] + best;
        }
    int o = 0;
    for (int t = 1; t < O; t++)
        o = acc[(n - 1) * O + t] < acc[(n - 1) * O + o] ? t : o;
    for (int k = n - 1; k >= 0; k--) {
        cut[k] = o;
        if (k) {
            int b = o;
            if (o > 0 && acc[(k - 1) * O + o - 1] < acc[(k - 1) * O + b])
                b = o - 1;
            if (o + 1 < O && acc[(k - 1) * O + o + 1] < acc[(k - 1) * O + b])
                b = o + 1;
            o = b;
        }
    }
    free(acc);
}

static void place_block(const tev_image *ex, int ex0, int ey0, tev_image *out, int bx, int by, int bw, int bh, int O)
{
    int *vcut = calloc((size_t)bh, sizeof(int)), *hcut = calloc((size_t)bw, sizeof(int));
    double *err = malloc(sizeof(double) * (size_t)(bw > bh ? bw : bh) * O);
    if (!vcut || !hcut || !err)
        goto out;
    if (bx > 0) {
        for (int y = 0; y < bh; y++)
            for (int o = 0; o < O; o++)
                err[y * O + o] = pix_err(ex, ex0, ey0, out, bx, by, o, y);
        min_cut(err, bh, O, vcut);
    }
    if (by > 0) {
        for (int x = 0; x < bw; x++)
            for (int o = 0; o < O; o++)
                err[x * O + o] = pix_err(ex, ex0, ey0, out, bx, by, x, o);
        min_cut(err, bw, O, hcut);
    }
    for (int y = 0; y < bh; y++)
        for (int x = 0; x < bw; x++) {
            if ((bx > 0 && x < vcut[y]) || (by > 0 && y < hcut[x]))
                continue; /* the old side of the cut */
            memcpy(out->px + 3 * ((size_t)(by + y) * out->w + bx + x), ex->px + 3 * ((size_t)(ey0 + y) * ex->w + ex0 + x),
                   3 * sizeof(float));
        }
out:
    free(vcut), free(hcut), free(err);
}

static uint64_t rnd(uint64_t *s)
{
    uint64_t z = (*s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Blocks of side B with overlap B/6, candidates on a stride-2 grid. */
static void quilt(const tev_image *ex, tev_image *out, int B, uint64_t seed)
{
    int O = B / 6 > 2 ? B / 6 : 2, step = B - O;
    int ncx = (ex->w - B) / 2 + 1, ncy = (ex->h - B) / 2 + 1;
    double *cand = malloc(sizeof(double) * (size_t)ncx * ncy);
    if (!cand)
        return;
    for (int by = 0; by < out->h; by += step)
        for (int bx = 0; bx < out->w; bx += step) {
            int bw = out->w - bx < B ? out->w - bx : B, bh = out->h - by < B ? out->h - by : B;
            double best = DBL_MAX;
            for (int k = 0; k < ncx * ncy; k++) {
                cand[k] = bx || by ? overlap_err(ex, 2 * (k % ncx), 2 * (k / ncx), out, bx, by, bw, bh, O) : 0;
                best = cand[k] < best ? cand[k] : best;
            }
            int n = 0;
            for (int k = 0; k < ncx * ncy; k++)
                n += cand[k] <= 1.1 * best + 1e-12;
            int pick = (int)(rnd(&seed) % (uint64_t)n), k = 0;
            for (;; k++)
                if (cand[k] <= 1.1 * best + 1e-12 && pick-- == 0)
                    break;
            place_block(ex, 2 * (k % ncx), 2 * (k / ncx), out, bx, by, bw, bh, O);
        }
    free(cand);
}

/* ---- sunprobe's synthesis into memory ---- */

typedef struct mem_sink {
    tev_image *out;
} mem_sink;

static int to_memory(void *ctx, uint32_t y0, uint32_t n, const float *rgb)
{
    tev_image *o = ((mem_sink *)ctx)->out;
    memcpy(o->px + (size_t)y0 * o->w * 3, rgb, sizeof(float) * 3 * (size_t)o->w * n);
    return 0;
}

typedef struct scores {
    double coh, rep, seam, hist, ac, secs;
    double seam_centres; /* the seam ratio at the tile centres: the control, where there is no border */
    double seam_cut;     /* at the block cut a block step inside each tile (sunprobe only, else 0) */
} scores;

static int coherence_step = 5;

/*
 * cut_step: sunprobe's block step (tex_block_step), 0 for quilting. sunprobe lays its finest level in blocks
 * from each window's origin, a block before its tile (texture.c), so a block cut ends at every tile border and
 * every block step inside: the line a block step past a border has the border's place on the block grid.
 */
static scores score(const tev_image *out, const tev_image *ex, int tile, int cut_step, double secs)
{
    return (scores){ tev_coherence(out, ex, 7, coherence_step),
                     tev_repetition(out, ex),
                     tev_seam_ratio(out, tile),
                     tev_histogram_distance(out, ex),
                     tev_autocorr_distance(out, ex, 8),
                     secs,
                     tev_seam_ratio_at(out, tile / 2, tile),
                     cut_step ? tev_seam_ratio_at(out, tile + cut_step, tile) : 0 };
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof(double), cmp_double);
    return n ? (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2])) : 0;
}

#define MAX_EX 8

static int gather_exemplars(const char *cap, tev_image *ex, const char **name)
{
    int n = 0;
    for (int k = 0; k < TEV_KINDS; k++, n++) {
        tev_procedural(&ex[n], (enum tev_kind)k, 128, 128, 7);
        name[n] = tev_kind_name((enum tev_kind)k);
    }
    char p[1024];
    snprintf(p, sizeof(p), "%s/street-sunny-dev1/gt/clean_plate.png", cap);
    if (!load_crop(p, 200, 232, 128, 128, &ex[n]))
        name[n++] = "ground (street plate)";
    snprintf(p, sizeof(p), "%s/selfie-sunny-dev1/frames/00000.png", cap);
    if (!load_crop(p, 190, 296, 96, 64, &ex[n]))
        name[n++] = "shirt (selfie frame)";
    snprintf(p, sizeof(p), "%s/selfie-sunny-dev1/gt/albedo_head.png", cap);
    if (!load_crop(p, 400, 300, 128, 128, &ex[n]))
        name[n++] = "skin (true albedo)";
    if (n == TEV_KINDS)
        printf("note: no path-traced captures under %s: their crops are left out\n", cap);
    if (!load_crop(FABRIC, 0, 0, 128, 128, &ex[n]))
        name[n++] = "fabric (blender-data, GPL-2+)";
    else
        printf("note: %s absent (Debian package blender-data): left out\n", FABRIC);
    return n;
}

static void print_row(const char *who, const scores *s)
{
    printf("  %-11s coherence %6.3f  repetition %6.3f  seams %6.3f (centres %5.3f", who, s->coh, s->rep, s->seam,
           s->seam_centres);
    if (s->seam_cut > 0)
        printf(", inner cut %5.3f", s->seam_cut);
    printf(")  histogram %7.4f  autocorr %6.4f  %6.2f s\n", s->hist, s->ac, s->secs);
}

#define MAX_SEEDS 16

/* Seeds lo..hi from "N" or "A-B" (at most MAX_SEEDS of them); 0 when the text is not one. */
typedef struct seed_range {
    uint64_t lo, hi;
} seed_range;

static int parse_seeds(const char *v, seed_range *r)
{
    char *end;
    if (*v < '0' || *v > '9')
        return 0;
    r->lo = r->hi = strtoull(v, &end, 10);
    if (*end == '-') {
        if (end[1] < '0' || end[1] > '9')
            return 0;
        r->hi = strtoull(end + 1, &end, 10);
    }
    return !*end && r->hi >= r->lo && r->hi - r->lo < MAX_SEEDS;
}

static double metric_of(const scores *s, int m)
{
    const double v[5] = { s->coh, s->rep, s->seam, s->hist, s->ac };
    return v[m];
}

static double ratio(const scores *a, const scores *q, int m)
{
    double d = metric_of(q, m);
    return metric_of(a, m) / (d > 1e-12 ? d : 1e-12);
}

static const char *const metric_name[5] = { "coherence", "repetition", "seams", "histogram", "autocorr" };

/* Two-sided sign test: the chance of k or a result as far from n / 2 among n fair coin tosses. */
static double sign_test(int k, int n)
{
    int far = k < n - k ? k : n - k;
    double p = 0, c = 1; /* c: n choose i, by the recurrence */
    for (int i = 0; i <= far; i++) {
        p += c;
        c = c * (n - i) / (i + 1);
    }
    p = 2 * p / pow(2, n);
    return p < 1 ? p : 1;
}

/*
 * Whether sunprobe's tile borders show a step: over its ns outputs of each exemplar, how often the borders' seam
 * ratio exceeds the same ratio at two controls, and over all of them with a sign test (ties left out). The tile
 * centres have no border but fall mid-block, while a border ends a block cut, which is smoother than mid-block
 * (TEXTURE.md); the inner cut, a block step inside each tile, has the border's place on the block grid but no
 * border. Without a step at the borders they are higher about half the time against the inner cut.
 */
static void summary_borders(scores sa[][MAX_EX], int n, int ns, const char **name)
{
    static const char *const control[2] = { "tile centres (mid-block)", "inner cuts (a block step inside)" };
    for (int c = 0; c < 2; c++) {
        int above = 0, untied = 0;
        printf("tile borders against the %s:\n", control[c]);
        for (int k = 0; k < n; k++) {
            int a = 0, m = 0, nr = 0;
            double r[MAX_SEEDS];
            for (int i = 0; i < ns; i++) {
                double b = sa[i][k].seam, d = c ? sa[i][k].seam_cut : sa[i][k].seam_centres;
                a += b > d, m += b != d; /* ties left out */
                if (d > 0)
                    r[nr++] = b / d;
            }
            printf("  %-30s borders higher in %2d of %d outputs, median ratio %.3f\n", name[k], a, m, median(r, nr));
            above += a, untied += m;
        }
        printf("  all: borders higher in %d of %d, two-sided sign test p = %.2g\n", above, untied,
               sign_test(above, untied));
    }
}

/* One seed each: the median ratio over the exemplars and on how many sunprobe is better. */
static void summary_one(scores sa[][MAX_EX], scores sq[][MAX_EX], int n)
{
    printf("median ratio sunprobe / quilting over %d exemplars (below 1: sunprobe better):\n", n);
    for (int m = 0; m < 5; m++) {
        double r[MAX_EX];
        int wins = 0;
        for (int k = 0; k < n; k++) {
            double a = metric_of(&sa[0][k], m), q = metric_of(&sq[0][k], m);
            r[k] = ratio(&sa[0][k], &sq[0][k], m);
            wins += m == 2 ? a < q || a < 1.1 : a < q;
        }
        printf("  %-10s %.3f  (sunprobe better on %d of %d%s)\n", metric_name[m], median(r, n), wins, n,
               m == 2 ? "; or no seam: ratio < 1.1" : "");
    }
}

/* Seed ranges: the median ratio of every (sunprobe, quilting) pair of seeds, its spread, and each exemplar's. */
static void summary_spread(scores sa[][MAX_EX], scores sq[][MAX_EX], int n, int ns, int nq, const char **name)
{
    printf("median ratio sunprobe / quilting over %d exemplars, for each of %d pairs of seeds (below 1: sunprobe "
           "better):\n",
           n, ns * nq);
    for (int m = 0; m < 5; m++) {
        double med[MAX_SEEDS * MAX_SEEDS], r[MAX_EX];
        int below = 0;
        for (int i = 0; i < ns; i++)
            for (int j = 0; j < nq; j++) {
                for (int k = 0; k < n; k++)
                    r[k] = ratio(&sa[i][k], &sq[j][k], m);
                med[i * nq + j] = median(r, n);
                below += med[i * nq + j] < 1.0;
            }
        int np = ns * nq;
        double mid = median(med, np); /* sorts med */
        printf("  %-10s median %.3f, range %.3f-%.3f, below 1 in %d of %d pairs\n", metric_name[m], mid, med[0],
               med[np - 1], below, np);
    }
    printf("each exemplar's ratio over the pairs, lowest-highest:\n");
    for (int k = 0; k < n; k++) {
        printf("  %-30s", name[k]);
        for (int m = 0; m < 5; m++) {
            double lo = DBL_MAX, hi = 0;
            for (int i = 0; i < ns; i++)
                for (int j = 0; j < nq; j++) {
                    double v = ratio(&sa[i][k], &sq[j][k], m);
                    lo = v < lo ? v : lo, hi = v > hi ? v : hi;
                }
            printf("  %s %.2f-%.2f", metric_name[m], lo, hi);
        }
        printf("\n");
    }
}

/* n values in [0, 1] to bytes, rounded and clamped (the values as they are: no transfer curve). */
static void to_bytes(const float *in, size_t n, uint8_t *out)
{
    for (size_t i = 0; i < n; i++) {
        float v = in[i] * 255.0f + 0.5f;
        out[i] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
    }
}

/* dir/<exemplar's first word>-<who, a space as '-'>.png; errors are reported, not fatal. */
static void dump_png(const char *dir, const char *name, const char *who, const tev_image *im)
{
    char path[4096];
    int k = snprintf(path, sizeof(path), "%s/%.*s-%s.png", dir, (int)strcspn(name, " "), name, who);
    uint8_t *rgb = malloc((size_t)im->w * im->h * 3);
    if (k < 0 || (size_t)k >= sizeof(path) || !rgb) {
        free(rgb);
        fprintf(stderr, "bench_texture: cannot dump %s %s\n", name, who);
        return;
    }
    for (char *c = path + strlen(dir) + 1; *c; c++)
        *c = *c == ' ' ? '-' : *c;
    to_bytes(im->px, (size_t)im->w * im->h * 3, rgb);
    int ret = sp_png_write(path, rgb, (uint32_t)im->w, (uint32_t)im->h, (uint32_t)im->w * 3, 3);
    if (ret)
        fprintf(stderr, "bench_texture: %s: %s\n", path, strerror(-ret));
    free(rgb);
}

static int quality(int N, const char *cap, seed_range seeds, seed_range quilt_seeds, const char *dump)
{
    tev_image ex[MAX_EX];
    const char *name[MAX_EX];
    int n = gather_exemplars(cap, ex, name), tile = 128, B = 32;
    int ns = (int)(seeds.hi - seeds.lo + 1), nq = (int)(quilt_seeds.hi - quilt_seeds.lo + 1);
    static scores sa[MAX_SEEDS][MAX_EX], sq[MAX_SEEDS][MAX_EX];
    sp_texture_settings s;
    sp_texture_default_settings(&s);
    s.tile = tile;
    printf("%dx%d from each exemplar; sunprobe tiles of %d (seams across them), quilting blocks of %d (seams across "
           "its block steps of %d); coherence sampled once per %d x %d cell; seeds %llu-%llu (sunprobe), %llu-%llu "
           "(quilting)\n",
           N, N, tile, B, B - B / 6, coherence_step, coherence_step, (unsigned long long)seeds.lo,
           (unsigned long long)seeds.hi, (unsigned long long)quilt_seeds.lo, (unsigned long long)quilt_seeds.hi);
    tev_image a = { malloc(sizeof(float) * 3 * (size_t)N * N), N, N };
    if (!a.px)
        return 1;
    for (int k = 0; k < n; k++) {
        printf("%s (%dx%d):\n", name[k], ex[k].w, ex[k].h);
        if (dump)
            dump_png(dump, name[k], "exemplar", &ex[k]);
        for (int i = 0; i < ns + nq; i++) {
            char who[32];
            double t0 = now_s();
            if (i < ns) {
                mem_sink ms = { &a };
                s.seed = seeds.lo + (uint64_t)i;
                if (sp_texture_synthesize(ex[k].px, (uint32_t)ex[k].w, (uint32_t)ex[k].h, (uint32_t)N, (uint32_t)N, &s,
                                          to_memory, &ms))
                    return 1;
                sa[i][k] = score(&a, &ex[k], tile, tex_block_step(s.patch), now_s() - t0);
                snprintf(who, sizeof(who), ns > 1 ? "sunprobe %llu" : "sunprobe", (unsigned long long)s.seed);
                print_row(who, &sa[i][k]);
                if (dump)
                    dump_png(dump, name[k], who, &a);
            } else {
                uint64_t qs = quilt_seeds.lo + (uint64_t)(i - ns);
                memset(a.px, 0, sizeof(float) * 3 * (size_t)N * N);
                quilt(&ex[k], &a, B, qs);
                sq[i - ns][k] = score(&a, &ex[k], B - B / 6, 0, now_s() - t0);
                snprintf(who, sizeof(who), nq > 1 ? "quilting %llu" : "quilting", (unsigned long long)qs);
                print_row(who, &sq[i - ns][k]);
                if (dump)
                    dump_png(dump, name[k], who, &a);
            }
        }
        tev_free(&ex[k]);
    }
    tev_free(&a);
    if (ns * nq == 1)
        summary_one(sa, sq, n);
    else
        summary_spread(sa, sq, n, ns, nq, name);
    summary_borders(sa, n, ns, name);
    return 0;
}

/* ---- scale: one size per process, the PNG streamed out ---- */

typedef struct png_sink {
    sp_png_stream *png;
    uint8_t *row;
    uint32_t w;
} png_sink;

static int to_png(void *ctx, uint32_t y0, uint32_t n, const float *rgb)
{
    (void)y0;
    png_sink *k = ctx;
    for (uint32_t y = 0; y < n; y++) {
        to_bytes(rgb + (size_t)y * k->w * 3, (size_t)k->w * 3, k->row);
        int ret = sp_png_stream_rows(k->png, k->row, 1, k->w * 3);
        if (ret)
            return ret;
    }
    return 0;
}

static int scale(uint32_t W, uint32_t H, const char *out, int threads)
{
    tev_image ex;
    if (tev_procedural(&ex, TEV_STONES, 128, 128, 7))
        return 1;
    sp_texture_settings s;
    sp_texture_default_settings(&s);
    s.threads = threads;
    FILE *f = fopen(out, "wb");
    png_sink k = { NULL, malloc((size_t)W * 3), W };
    if (!f || !k.row || sp_png_stream_open(&k.png, f, W, H, 3))
        return fprintf(stderr, "bench_texture: cannot write %s\n", out), 1;
    double t0 = now_s(), c0 = cpu_s();
    int ret = sp_texture_synthesize(ex.px, 128, 128, W, H, &s, to_png, &k);
    ret = ret ? ret : sp_png_stream_finish(&k.png);
    double secs = now_s() - t0, cpu = cpu_s() - c0, mp = (double)W * H / 1e6;
    fclose(f);
    struct rusage u;
    getrusage(RUSAGE_SELF, &u);
    printf("scale %ux%u (%.1f MP): %.1f s wall, %.1f s CPU, %.2f s/MP wall, %.2f s/MP CPU, peak RSS %.1f MB%s\n", W, H,
           mp, secs, cpu, secs / mp, cpu / mp, (double)u.ru_maxrss / 1024.0, ret ? " (FAILED)" : "");
    free(k.row);
    tev_free(&ex);
    return ret ? 1 : 0;
}

int main(int argc, char **argv)
{
    int scale_mode = argc > 1 && !strcmp(argv[1], "scale"), threads = 0, N = 384;
    uint32_t W = 2304, H = 2304;
    const char *cap = "../shared/captures", *out = "/dev/null", *dump = NULL;
    seed_range seeds = { 1, 1 }, quilt_seeds = { 11, 11 };
    for (int i = 1 + (argc > 1 && (scale_mode || !strcmp(argv[1], "quality"))); i + 1 < argc; i += 2) {
        if (!strcmp(argv[i], "--size") && scale_mode && sscanf(argv[i + 1], "%ux%u", &W, &H) == 2)
            continue;
        if (!strcmp(argv[i], "--size") && !scale_mode && (N = atoi(argv[i + 1])) >= 64)
            continue;
        if (!strcmp(argv[i], "--captures"))
            cap = argv[i + 1];
        else if (!strcmp(argv[i], "--out"))
            out = argv[i + 1];
        else if (!strcmp(argv[i], "--dump") && !scale_mode)
            dump = argv[i + 1];
        else if (!strcmp(argv[i], "--seed") && !scale_mode && parse_seeds(argv[i + 1], &seeds))
            continue;
        else if (!strcmp(argv[i], "--quilt-seed") && !scale_mode && parse_seeds(argv[i + 1], &quilt_seeds))
            continue;
        else if (!strcmp(argv[i], "--threads"))
            threads = atoi(argv[i + 1]);
        else if (!strcmp(argv[i], "--coherence-step") && !scale_mode && atoi(argv[i + 1]) >= 1)
            coherence_step = atoi(argv[i + 1]);
        else
            return fprintf(stderr,
                           "usage: bench_texture [quality] [--size N] [--captures DIR] [--seed N|A-B] "
                           "[--quilt-seed N|A-B] [--coherence-step S] [--dump DIR] | "
                           "scale --size WxH [--out F.png] [--threads N]\n"),
                   1;
    }
    return scale_mode ? scale(W, H, out, threads) : quality(N, cap, seeds, quilt_seeds, dump);
}
