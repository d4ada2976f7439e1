/* SPDX-License-Identifier: MIT */
/*
 * One window's multi-scale synthesis. Per level and iteration a lattice of
 * patches (stride patch/2, random offset) is cut into crops at a random place;
 * each crop (a pool task owning its patches' matches, so the result does not
 * depend on the threads) matches them to the exemplar by PatchMatch from the
 * previous source map, with a penalty on exemplar regions the window already
 * uses more than their share. Then each free pixel becomes the mean of the
 * votes of all patches covering it, across crop borders (pool tasks by rows).
 */
#include "texture_internal.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define CROP_MIN 64 /* crop side (level pixels) when a patch is small */
#define N_RANDOM 2  /* fresh draws from anywhere per patch and pass */

typedef struct level_win {
    float *img, *next;       /* w x h x 3 */
    uint8_t *fixed;
    int32_t *src, *src_next; /* exemplar pixel each window pixel comes from (y * ew + x) */
    int w, h;
} level_win;

/* One iteration's patch lattice: positions, per pixel the patches covering it, and each patch's match. */
typedef struct pgrid {
    int *px, *py, nx, ny;
    int *lox, *loy;          /* per column / row: first covering patch; the range ends at lo of +1 past P */
    int *hix, *hiy;
    int32_t *nn;             /* exemplar start per patch */
    float *d;                /* its distance + penalty */
} pgrid;

typedef struct iter_ctx {
    const tex_job *job;
    const tex_level *ex;
    level_win *win;
    pgrid *g;
    const int *cx, *cy;      /* crop boundaries in patch indices, ncx + 1 and ncy + 1 */
    int ncx, ncy, level, iter, band;
    const float *pen;        /* penalty per exemplar bin */
    int bins_w;
} iter_ctx;

static uint64_t rng_next(uint64_t *s)
{
    *s += 0x9E3779B97F4A7C15ull;
    return tex_hash(*s, 0);
}

static float patch_dist(const float *a, int astride, const float *b, int bstride, int P, float bound)
{
    float d = 0;
    for (int y = 0; y < P; y++) {
        const float *ra = a + (size_t)y * astride, *rb = b + (size_t)y * bstride;
        float r0 = 0, r1 = 0, r2 = 0, r3 = 0;
        int i = 0;
        for (; i + 4 <= 3 * P; i += 4) {
            float t0 = ra[i] - rb[i], t1 = ra[i + 1] - rb[i + 1], t2 = ra[i + 2] - rb[i + 2], t3 = ra[i + 3] - rb[i + 3];
            r0 += t0 * t0, r1 += t1 * t1, r2 += t2 * t2, r3 += t3 * t3;
        }
        for (; i < 3 * P; i++)
            r0 += (ra[i] - rb[i]) * (ra[i] - rb[i]);
        d += (r0 + r1) + (r2 + r3);
        if (d >= bound)
            return d;
    }
    return d;
}

/* A candidate patch start (ex pixel index) made usable: clamped into the exemplar; -1 where the mask refuses it. */
static int32_t usable(const tex_level *ex, int P, int x, int y)
{
    x = x < 0 ? 0 : x > ex->w - P ? ex->w - P : x;
    y = y < 0 ? 0 : y > ex->h - P ? ex->h - P : y;
    int32_t i = y * ex->w + x;
    return ex->valid && !ex->valid[i] ? -1 : i;
}

static float cand_cost(const iter_ctx *c, int i, int j, int32_t n, float bound)
{
    const tex_level *ex = c->ex;
    int P = c->job->ex->patch, ew = ex->w;
    float pen = c->pen[(n / ew / P) * c->bins_w + (n % ew) / P];
    if (pen >= bound)
        return FLT_MAX;
    const float *a = c->win->img + 3 * ((size_t)c->g->py[j] * c->win->w + c->g->px[i]);
    return pen + patch_dist(a, 3 * c->win->w, ex->px + 3 * (size_t)n, 3 * ew, P, bound - pen);
}

static void try_cand(const iter_ctx *c, int i, int j, int32_t n)
{
    pgrid *g = c->g;
    int idx = j * g->nx + i;
    if (n < 0 || n == g->nn[idx])
        return;
    float d = cand_cost(c, i, j, n, g->d[idx]);
    if (d < g->d[idx])
        g->d[idx] = d, g->nn[idx] = n;
}

/* The neighbour's match shifted by the distance between the two patches (neighbours in the same crop only). */
static void propagate(const iter_ctx *c, const int box[4], int i, int j, int ni, int nj)
{
    if (ni < box[0] || nj < box[1] || ni >= box[2] || nj >= box[3])
        return;
    const pgrid *g = c->g;
    int32_t n = g->nn[nj * g->nx + ni];
    int ew = c->ex->w;
    try_cand(c, i, j, usable(c->ex, c->job->ex->patch, n % ew + g->px[i] - g->px[ni], n / ew + g->py[j] - g->py[nj]));
}

static void search(const iter_ctx *c, int i, int j, uint64_t *rng)
{
    const tex_level *ex = c->ex;
    int P = c->job->ex->patch;
    int32_t cur = c->g->nn[j * c->g->nx + i];
    for (int r = ex->w > ex->h ? ex->w : ex->h; r >= 1; r /= 2) {
        uint64_t u = rng_next(rng);
        int dx = (int)(u % (uint64_t)(2 * r + 1)) - r, dy = (int)((u >> 32) % (uint64_t)(2 * r + 1)) - r;
        try_cand(c, i, j, usable(ex, P, cur % ex->w + dx, cur / ex->w + dy));
    }
    for (int t = 0; t < N_RANDOM; t++)
        try_cand(c, i, j, ex->list[rng_next(rng) % (uint64_t)ex->n_list]);
}

/* A crop's patches: start from the source map, then two PatchMatch sweeps (forward, backward). */
static void run_crop(void *ctx, int task)
{
    const iter_ctx *c = ctx;
    pgrid *g = c->g;
    const tex_level *ex = c->ex;
    int P = c->job->ex->patch;
    int box[4] = { c->cx[task % c->ncx], c->cy[task / c->ncx], c->cx[task % c->ncx + 1], c->cy[task / c->ncx + 1] };
    uint64_t rng = tex_hash(c->job->key, ((uint64_t)c->level << 48) ^ ((uint64_t)c->iter << 32) ^ (uint64_t)task);
    for (int j = box[1]; j < box[3]; j++)
        for (int i = box[0]; i < box[2]; i++) {
            int32_t sp = c->win->src[(size_t)g->py[j] * c->win->w + g->px[i]];
            int32_t n = usable(ex, P, sp % ex->w, sp / ex->w);
            if (n < 0)
                n = ex->list[rng_next(&rng) % (uint64_t)ex->n_list];
            g->nn[j * g->nx + i] = n;
            g->d[j * g->nx + i] = cand_cost(c, i, j, n, FLT_MAX);
        }
    for (int pass = 0; pass < 2; pass++)
        for (int jj = box[1]; jj < box[3]; jj++)
            for (int ii = box[0]; ii < box[2]; ii++) {
                int i = pass ? box[2] - 1 - (ii - box[0]) : ii, j = pass ? box[3] - 1 - (jj - box[1]) : jj;
                int d = pass ? 1 : -1;
                propagate(c, box, i, j, i + d, j);
                propagate(c, box, i, j, i, j + d);
                search(c, i, j, &rng);
            }
}

/* Each free pixel of a band of rows: the mean of the votes of every patch covering it; src_next from the best. */
static void run_vote(void *ctx, int task)
{
    const iter_ctx *c = ctx;
    const pgrid *g = c->g;
    level_win *W = c->win;
    const tex_level *ex = c->ex;
    int y1 = (task + 1) * c->band < W->h ? (task + 1) * c->band : W->h;
    for (int y = task * c->band; y < y1; y++)
        for (int x = 0; x < W->w; x++) {
            size_t p = (size_t)y * W->w + x;
            float s[3] = { 0, 0, 0 }, best = FLT_MAX, n = 0;
            int32_t bsrc = W->src[p];
            for (int j = g->loy[y]; j < g->hiy[y]; j++)
                for (int i = g->lox[x]; i < g->hix[x]; i++) {
                    int32_t q = g->nn[j * g->nx + i] + (y - g->py[j]) * ex->w + (x - g->px[i]);
                    const float *e = ex->px + 3 * (size_t)q;
                    s[0] += e[0], s[1] += e[1], s[2] += e[2];
                    n += 1;
                    if (g->d[j * g->nx + i] < best)
                        best = g->d[j * g->nx + i], bsrc = q;
                }
            W->src_next[p] = bsrc;
            float *o = W->next + 3 * p;
            const float *old = W->img + 3 * p;
            for (int ch = 0; ch < 3; ch++)
                o[ch] = W->fixed[p] == TEX_FIXED || n <= 0 ? old[ch] : s[ch] / n;
        }
}

/* Patch positions over [0, n): 0, then off + k * s, then n - P; and per pixel the covering range. */
static int lattice(int n, int P, int s, int off, int *pos, int *lo, int *hi)
{
    int k = 0;
    pos[k++] = 0;
    for (int x = off; x + P <= n; x += s)
        if (x > pos[k - 1])
            pos[k++] = x;
    if (pos[k - 1] + P < n)
        pos[k++] = n - P;
    for (int x = 0, a = 0, b = 0; x < n; x++) {
        while (pos[a] + P <= x)
            a++;
        while (b < k && pos[b] <= x)
            b++;
        lo[x] = a, hi[x] = b;
    }
    return k;
}

/* Crop boundaries over k patch indices: pieces of about side, the first cut at a random place. */
static int crop_cuts(int k, int side, uint64_t r, int *cut)
{
    int m = 0, x = (int)(r % (uint64_t)side);
    cut[m++] = 0;
    for (; x < k; x += side)
        if (x > 0)
            cut[m++] = x;
    cut[m] = k;
    return m;
}

/* Penalty per exemplar bin (patch-sized): how far the window's patches overuse it, times the typical distance. */
static void reuse_penalty(const level_win *W, const tex_level *ex, int P, double reuse, float *pen, int bw, int bh)
{
    int s = P / 2, n = 0;
    memset(pen, 0, sizeof(float) * (size_t)bw * bh);
    for (int y = 0; y + P <= W->h; y += s)
        for (int x = 0; x + P <= W->w; x += s) {
            int32_t q = W->src[(size_t)y * W->w + x];
            pen[(q / ex->w / P) * bw + (q % ex->w) / P] += 1;
            n++;
        }
    /* a bin's fair share: the window's patches spread evenly over the usable starts, P x P per bin */
    double per = (double)n / (double)ex->n_list * (double)P * P;
    for (int b = 0; b < bw * bh; b++) {
        double over = (double)pen[b] / (per > 1e-9 ? per : 1e-9) - 1.0;
        pen[b] = over > 0 ? (float)(reuse * ex->scale * over) : 0.0f;
    }
}

static void pgrid_free(pgrid *g)
{
    free(g->px), free(g->lox), free(g->nn), free(g->d);
}

static int pgrid_alloc(pgrid *g, int w, int h, int s)
{
    size_t mx = (size_t)w / s + 3, my = (size_t)h / s + 3;
    *g = (pgrid){ 0 };
    g->px = malloc(sizeof(int) * (mx + my));
    g->lox = malloc(sizeof(int) * 2 * ((size_t)w + h));
    g->nn = malloc(sizeof(int32_t) * mx * my);
    g->d = malloc(sizeof(float) * mx * my);
    if (!g->px || !g->lox || !g->nn || !g->d) {
        pgrid_free(g);
        return -ENOMEM;
    }
    g->py = g->px + mx;
    g->hix = g->lox + w, g->loy = g->hix + w, g->hiy = g->loy + h;
    return 0;
}

static void run_iteration(iter_ctx *c, int s, int side)
{
    const tex_job *job = c->job;
    level_win *W = c->win;
    int P = job->ex->patch;
    uint64_t r = tex_hash(job->key ^ 0xC0FFEEull, (uint64_t)c->level * 64 + (uint64_t)c->iter);
    pgrid *g = c->g;
    g->nx = lattice(W->w, P, s, (int)(r % (uint64_t)s), g->px, g->lox, g->hix);
    g->ny = lattice(W->h, P, s, (int)((r >> 16) % (uint64_t)s), g->py, g->loy, g->hiy);
    int *cx = (int *)c->cx, *cy = (int *)c->cy;
    c->ncx = crop_cuts(g->nx, side, r >> 24, cx);
    c->ncy = crop_cuts(g->ny, side, r >> 40, cy);
    sp_pool_for(job->pool, c->ncx * c->ncy, run_crop, c);
    c->band = 16;
    sp_pool_for(job->pool, (W->h + c->band - 1) / c->band, run_vote, c);
    float *t = W->img;
    W->img = W->next, W->next = t;
    int32_t *u = W->src;
    W->src = W->src_next, W->src_next = u;
}

static int run_level(const tex_job *job, level_win *W, int level)
{
    const tex_level *ex = &job->ex->lv[level];
    int P = job->ex->patch, s = P / 2;
    int side = (4 * P > CROP_MIN ? 4 * P : CROP_MIN) / s; /* crop side in patches */
    int bw = (ex->w + P - 1) / P, bh = (ex->h + P - 1) / P;
    pgrid g;
    int *cuts = malloc(sizeof(int) * (size_t)(W->w / s + W->h / s + 8));
    float *pen = malloc(sizeof(float) * (size_t)bw * bh);
    if (!cuts || !pen || pgrid_alloc(&g, W->w, W->h, s)) {
        free(cuts), free(pen);
        return -ENOMEM;
    }
    iter_ctx c = { job, ex, W, &g, cuts, cuts + W->w / s + 4, 0, 0, level, 0, 0, pen, bw };
    int iters = job->s->iterations << level; /* coarse passes are cheap and settle the layout */
    for (c.iter = 0; c.iter < iters; c.iter++) {
        reuse_penalty(W, ex, P, job->s->reuse, pen, bw, bh);
        run_iteration(&c, s, side);
    }
    pgrid_free(&g);
    free(cuts), free(pen);
    return 0;
}

/*
 * ---- The finest level in whole blocks ----
 * The vote of the finest level is replaced by image-quilting-style blocks
 * (4 patches a side, overlapping by a sixth of that, as quilting does) laid in
 * raster order, each copying one exemplar offset found for the block as a whole:
 * candidates from the voted layout (its source map), continued from the
 * neighbouring blocks, drawn at random, on a coarse grid (subsampled cost)
 * refined around its best, and searched around the best, costed by the block's
 * error against the pixels already settled (held fixed or laid by earlier
 * blocks; not against the voted image, whose blur favours featureless
 * regions). Of the candidates within a factor 1 + 0.25 x reuse of the best
 * cost, the one whose exemplar region and colours the window has used most
 * sparingly is laid: a penalty in the cost itself would trade every block's fit
 * for spread, this only chooses among near-ties. A block may not continue the
 * copy of the blocks it overlaps (the sides and the two diagonals above) beyond
 * BLOCK_RUN blocks, nor (at BLOCK_RUN 1) reproduce half
 * a patch side of settled pixels from the same exemplar pixels (any other
 * copy, an earlier tile's included; a blended pixel, which has no source, by
 * equal value), which bounds verbatim repetition the way quilting's fixed block does; borders
 * are minimum-error cuts, then the band about them is optimised (refine_seams
 * below). Sequential, so the result depends on the seed only.
 */
#define BLOCK_PATCHES 4   /* block side in patches */
#define BLOCK_RANDOM 24   /* random offsets tried per block */
#define BLOCK_STRIDE 2    /* the exhaustive search's grid step */
#define GRID_SUB 2        /* and its pixel subsampling (the grid only picks where to refine) */
#define REFINE_SIDE (BLOCK_STRIDE + 1) /* full-cost offsets around the grid's best, a side */
#define N_REFINE (REFINE_SIDE * REFINE_SIDE)
#define BLOCK_RUN 1       /* blocks one verbatim copy may span */
#define N_OVERLAPPED 4    /* laid blocks a block overlaps: left, up, up-left, up-right */
#define BLOCK_TOLERANCE 0.25 /* x reuse: how far over the best cost (relative) a less used region may still be laid */
#define MAX_NEAR 256         /* candidates kept within that tolerance */
#define UNSETTLED_COST 1e6f /* a cut through a pixel nothing has laid yet: kept inside the overlap */

enum { LAID = 1, PENDING = 2 }; /* settled: laid by this window's blocks; an earlier tile's, that they may lay again */

typedef struct block_pass {
    const tex_level *ex;
    float *out;
    uint8_t *settled;     /* 0 free, LAID, PENDING, or TEX_FIXED + 1 held fixed */
    float *tgt;           /* the block's settled pixels, the grid's subsample first */
    int32_t *tpos, *tsrc; /* each one's place (y * exemplar width + x) and its src (-1: a blend) */
    int n_tgt, n_sub;
    int w, h, B, x0, y0, bw, bh;
    float *cnt;              /* blocks covering each patch-sized exemplar bin */
    int bins_w, P;
    double fair, tolerance;
    int exact_max;           /* settled pixels a candidate may reproduce exactly */
    int32_t *src;   /* exemplar pixel each window pixel was laid from (here or by an earlier tile), -1 unknown */
    uint32_t *hout; /* pixels per colour bin (tex_level.colour) among those the blocks laid */
    uint32_t n_out;
} block_pass;

/* How far over their share of the exemplar the laid pixels already hold the colours of offset (ox, oy). */
static double colour_overuse(const block_pass *b, int ox, int oy)
{
    if (!b->n_out)
        return 0;
    double over = 0, n_ex = (double)b->ex->w * b->ex->h;
    int n = 0;
    for (int y = 0; y < b->bh; y += 2)
        for (int x = 0; x < b->bw; x += 2, n++) {
            int k = b->ex->colour[(size_t)(oy + y) * b->ex->w + ox + x];
            double o = ((double)b->hout[k] / b->n_out) / ((double)b->ex->colour_count[k] / n_ex) - 1.0;
            over += o > 0 ? o : 0;
        }
    return over / n;
}

/* How far over their fair share the window already uses the exemplar bins under offset (ox, oy), per bin. */
static double block_overuse(const block_pass *b, int ox, int oy)
{
    double over = 0;
    int nb = 0;
    for (int y = oy + b->P / 2; y < oy + b->bh; y += b->P)
        for (int x = ox + b->P / 2; x < ox + b->bw; x += b->P, nb++) {
            double o = (double)b->cnt[(y / b->P) * b->bins_w + x / b->P] / b->fair - 1.0;
            over += o > 0 ? o : 0;
        }
    return over / (nb ? nb : 1);
}

enum cost_pixels { COST_ALL, COST_SUBSAMPLE };

/*
 * Distance of the block's settled pixels to exemplar offset (ox, oy), over all
 * of them or the grid's subsample (scaled to the whole); FLT_MAX past bound.
 */
static float block_cost(const block_pass *b, int ox, int oy, float bound, int check_exact, enum cost_pixels which)
{
    int sub = which == COST_SUBSAMPLE;
    const float *base = b->ex->px + 3 * ((size_t)oy * b->ex->w + ox);
    int32_t s0 = oy * b->ex->w + ox;
    int n = sub ? b->n_sub : b->n_tgt, exact = 0;
    float d = 0, area = sub ? (float)(GRID_SUB * GRID_SUB) : 1.0f;
    for (int k = 0; k < n; k++) {
        const float *e = base + 3 * (size_t)b->tpos[k], *t = b->tgt + 3 * (size_t)k;
        float t0 = e[0] - t[0], t1 = e[1] - t[1], t2 = e[2] - t[2], q = t0 * t0 + t1 * t1 + t2 * t2;
        d += q;
        /* the same exemplar pixel where the source is known; else (a blend: seams band, cross-fade, wrap ramp) the same value */
        exact += b->tsrc[k] >= 0 ? b->tsrc[k] == s0 + b->tpos[k] : q == 0.0f;
        if ((k & 31) == 31 && d * area > bound)
            return FLT_MAX;
    }
    /* reproducing settled pixels verbatim (a neighbour's, a diagonal's or an earlier tile's copy) extends that copy */
    if (check_exact && exact >= b->exact_max)
        return FLT_MAX;
    d *= area;
    return d <= bound ? d : FLT_MAX;
}

/* Union-find over the block grid: blocks joined when one continues the other's copy. */
static int run_root(int *parent, int i)
{
    while (parent[i] != i)
        i = parent[i] = parent[parent[i]];
    return i;
}

/* The minimum-error path across a strip of the block (vertical: top to bottom over columns [0, n)). */
static void cut_path(const float *err, int bw, int bh, int n, int vertical, int *path, float *acc)
{
    int len = vertical ? bh : bw;
    for (int k = 0; k < len; k++)
        for (int c = 0; c < n; c++) {
            float e = vertical ? err[(size_t)k * bw + c] : err[(size_t)c * bw + k], best = 0;
            if (k > 0) {
                best = acc[(size_t)(k - 1) * n + c];
                if (c > 0 && acc[(size_t)(k - 1) * n + c - 1] < best)
                    best = acc[(size_t)(k - 1) * n + c - 1];
                if (c + 1 < n && acc[(size_t)(k - 1) * n + c + 1] < best)
                    best = acc[(size_t)(k - 1) * n + c + 1];
            }
            acc[(size_t)k * n + c] = e + best;
        }
    int c = 0;
    for (int i = 1; i < n; i++)
        if (acc[(size_t)(len - 1) * n + i] < acc[(size_t)(len - 1) * n + c])
            c = i;
    for (int k = len - 1; k >= 0; k--) {
        path[k] = c;
        if (k > 0) {
            int cc = c;
            for (int d = -1; d <= 1; d += 2)
                if (c + d >= 0 && c + d < n && acc[(size_t)(k - 1) * n + c + d] < acc[(size_t)(k - 1) * n + cc])
                    cc = c + d;
            c = cc;
        }
    }
}

typedef struct cut_strip {
    int skip, depth;
} cut_strip;

/* settled[] of the block pixel at depth d from one side (vertical: columns; trailing: from the last) along line k. */
static uint8_t settled_at(const block_pass *b, int vertical, int trailing, int k, int d)
{
    int a = trailing ? (vertical ? b->bw : b->bh) - 1 - d : d;
    return b->settled[vertical ? (size_t)(b->y0 + k) * b->w + b->x0 + a : (size_t)(b->y0 + a) * b->w + b->x0 + k];
}

/*
 * Where a cut through one side of the block may run (vertical: columns; from
 * its first side or its last): past the lines held fixed all along that side (a
 * cut there would change nothing, and the block would meet them with no cut at
 * all), then over the settled pixels beyond, the most over the side's length
 * (the fewest for a last side: only a finished tile across the wrap covers a
 * whole trailing side), at most half the block.
 */
static cut_strip settled_strip(const block_pass *b, int vertical, int trailing)
{
    int side = vertical ? b->bw : b->bh, len = vertical ? b->bh : b->bw, lim = side / 2;
    cut_strip c = { side, trailing ? lim : 0 };
    for (int k = 0; k < len; k++) {
        int f = 0;
        while (f < c.skip && settled_at(b, vertical, trailing, k, f) == TEX_FIXED + 1)
            f++;
        c.skip = f;
    }
    for (int k = 0; k < len; k++) {
        int d = 0;
        while (d < lim && c.skip + d < side && settled_at(b, vertical, trailing, k, c.skip + d))
            d++;
        c.depth = trailing ? (d < c.depth ? d : c.depth) : (d > c.depth ? d : c.depth);
    }
    return c;
}

/*
 * Lays exemplar offset (ox, oy) into the block: settled pixels stay on the far
 * side of a minimum-error cut through each side they cover (left and top from
 * earlier blocks; right and bottom where a finished tile lies across the wrap).
 */
static void lay_block(block_pass *b, int ox, int oy, float *err, int *path, float *acc)
{
    const tex_level *ex = b->ex;
    for (int y = 0; y < b->bh; y++)
        for (int x = 0; x < b->bw; x++) {
            size_t p = (size_t)(b->y0 + y) * b->w + b->x0 + x;
            const float *e = ex->px + 3 * ((size_t)(oy + y) * ex->w + ox + x), *o = b->out + 3 * p;
            float d0 = e[0] - o[0], d1 = e[1] - o[1], d2 = e[2] - o[2];
            /* a cut keeps to pixels it can change: fixed ones stay whichever side of it they lie */
            int open = b->settled[p] && b->settled[p] != TEX_FIXED + 1;
            err[(size_t)y * b->bw + x] = open ? d0 * d0 + d1 * d1 + d2 * d2 : UNSETTLED_COST;
        }
    cut_strip l = settled_strip(b, 1, 0), t = settled_strip(b, 0, 0), r = settled_strip(b, 1, 1),
              u = settled_strip(b, 0, 1);
    int nl = l.depth, nt = t.depth, nr = r.depth, nb = u.depth, bw = b->bw, bh = b->bh;
    int *lpath = path, *tpath = path + bh, *rpath = tpath + bw, *bpath = rpath + bh;
    if (nl)
        cut_path(err + l.skip, bw, bh, nl, 1, lpath, acc);
    if (nt)
        cut_path(err + (size_t)t.skip * bw, bw, bh, nt, 0, tpath, acc);
    if (nr)
        cut_path(err + (bw - r.skip - nr), bw, bh, nr, 1, rpath, acc);
    if (nb)
        cut_path(err + (size_t)(bh - u.skip - nb) * bw, bw, bh, nb, 0, bpath, acc);
    for (int y = 0; y < bh; y++)
        for (int x = 0; x < bw; x++) {
            size_t p = (size_t)(b->y0 + y) * b->w + b->x0 + x;
            int cut_off = (nl && x < l.skip + lpath[y]) || (nt && y < t.skip + tpath[x]) ||
                (nr && x > bw - r.skip - nr + rpath[y]) || (nb && y > bh - u.skip - nb + bpath[x]);
            int keep = b->settled[p] && cut_off;
            if (b->settled[p] == TEX_FIXED + 1 || keep)
                continue;
            memcpy(b->out + 3 * p, ex->px + 3 * ((size_t)(oy + y) * ex->w + ox + x), 3 * sizeof(float));
            if (b->settled[p] == LAID && b->src[p] >= 0) /* laid again: the colour counts move */
                b->hout[ex->colour[b->src[p]]] -= 1, b->n_out -= 1;
            b->hout[ex->colour[(size_t)(oy + y) * ex->w + ox + x]] += 1, b->n_out += 1;
            b->settled[p] = LAID;
            b->src[p] = (oy + y) * ex->w + ox + x;
        }
    for (int y = oy + b->P / 2; y < oy + b->bh; y += b->P)
        for (int x = ox + b->P / 2; x < ox + b->bw; x += b->P)
            b->cnt[(y / b->P) * b->bins_w + x / b->P] += 1;
}

/* Block origins along one axis: the given steps, the last one flush with the end. */
static int block_origins(int n, int B, int step, int *pos)
{
    int k = 0;
    for (int x = 0;; x += step) {
        pos[k++] = x + B < n ? x : n - B;
        if (x + B >= n)
            return k;
    }
}

static int clampi(int v, int lo, int hi)
{
    return v < lo ? lo : v > hi ? hi : v;
}

/* The overlap of neighbouring blocks: a sixth of the block, as image quilting lays its own. */
static int block_overlap(int B)
{
    return B / 6 > 2 ? B / 6 : 2;
}

int tex_block_step(int patch)
{
    int B = BLOCK_PATCHES * patch;
    return B - block_overlap(B);
}

static void settle_blocks(const tex_job *job, level_win *W, const tex_level *ex, int *xs, int *ys, int *off,
                          int *parent, int *size, block_pass *b)
{
    int B = b->B, step = tex_block_step(b->P), nx = block_origins(W->w, B, step, xs),
        ny = block_origins(W->h, B, step, ys);
    uint64_t rng = tex_hash(job->key ^ 0xB10Cull, 0);
    float *err = b->tgt + (size_t)3 * B * B, *acc = err + (size_t)B * B;
    int *path = (int *)(acc + (size_t)B * B);
    for (int j = 0; j < ny; j++)
        for (int i = 0; i < nx; i++) {
            int id = j * nx + i;
            b->x0 = xs[i], b->y0 = ys[j], b->bw = B, b->bh = B;
            b->n_tgt = 0; /* the settled pixels the cost compares: the grid's subsample, then the rest */
            for (int pass = 0; pass < 2; pass++) {
                for (int y = 0; y < B; y++)
                    for (int x = 0; x < B; x++) {
                        size_t p = (size_t)(b->y0 + y) * W->w + b->x0 + x;
                        if (!b->settled[p] || (y % GRID_SUB == 0 && x % GRID_SUB == 0) == pass)
                            continue;
                        memcpy(b->tgt + 3 * (size_t)b->n_tgt, b->out + 3 * p, 3 * sizeof(float));
                        b->tpos[b->n_tgt] = y * ex->w + x;
                        b->tsrc[b->n_tgt++] = b->src[p];
                    }
                if (pass == 0)
                    b->n_sub = b->n_tgt;
            }
            /*
             * The laid blocks this one overlaps (left and up first: their continuations are candidates when
             * BLOCK_RUN allows a run; then the two above diagonally, which share a corner of overlap with it)
             * and the offset that would continue each one's copy: continuing a diagonal's joins the two
             * copies through that corner as surely as a side's does (768 x 768 fabric: a region of two
             * blocks, 0.071 of the exemplar).
             */
            int nbr[N_OVERLAPPED] = { i > 0 ? id - 1 : -1, j > 0 ? id - nx : -1, i > 0 && j > 0 ? id - nx - 1 : -1,
                                      j > 0 && i + 1 < nx ? id - nx + 1 : -1 };
            int cont[N_OVERLAPPED][2];
            for (int k = 0; k < N_OVERLAPPED; k++)
                if (nbr[k] >= 0) {
                    int ni = nbr[k] % nx, nj = nbr[k] / nx;
                    cont[k][0] = off[2 * nbr[k]] + xs[i] - xs[ni];
                    cont[k][1] = off[2 * nbr[k] + 1] + ys[j] - ys[nj];
                }
            /* a block closing onto a finished tile across the wrap has to continue what lies on both sides */
            cut_strip right = settled_strip(b, 1, 1), below = settled_strip(b, 0, 1);
            int closing = right.skip || right.depth || below.skip || below.depth;
            int bx = -1, by = -1, gx = 0, gy = 0, near_x[MAX_NEAR], near_y[MAX_NEAR], n_near = 0;
            float near_d[MAX_NEAR], gbest = FLT_MAX;
            float best = FLT_MAX;
            int n_grid = ((ex->w - B) / BLOCK_STRIDE + 1) * ((ex->h - B) / BLOCK_STRIDE + 1);
            int n_cand = 5 + 2 + n_grid + N_REFINE + BLOCK_RANDOM + 16;
            for (int t = 0; t < n_cand; t++) {
                int cx, cy;
                if (t < 5) { /* the voted layout at the block's centre and corners */
                    int dx = t == 0 ? B / 2 : (t & 1) ? 0 : B - 1, dy = t == 0 ? B / 2 : t < 3 ? 0 : B - 1;
                    int32_t s = W->src[(size_t)(b->y0 + dy) * W->w + b->x0 + dx];
                    cx = s % ex->w - dx, cy = s / ex->w - dy;
                } else if (t < 7) {
                    if (nbr[t - 5] < 0)
                        continue;
                    cx = cont[t - 5][0], cy = cont[t - 5][1];
                } else if (t < 7 + n_grid) { /* every offset on a coarse grid */
                    int gw = (ex->w - B) / BLOCK_STRIDE + 1;
                    cx = (t - 7) % gw * BLOCK_STRIDE, cy = (t - 7) / gw * BLOCK_STRIDE;
                } else if (t < 7 + n_grid + N_REFINE) { /* the grid's best, refined at full resolution */
                    if (gbest == FLT_MAX)
                        continue;
                    int k = t - 7 - n_grid;
                    cx = gx + k % REFINE_SIDE - REFINE_SIDE / 2, cy = gy + k / REFINE_SIDE - REFINE_SIDE / 2;
                } else if (t < 7 + n_grid + N_REFINE + BLOCK_RANDOM) {
                    int32_t s = ex->list[rng_next(&rng) % (uint64_t)ex->n_list];
                    cx = s % ex->w, cy = s / ex->w;
                } else { /* around the best, the radius halving */
                    if (bx < 0)
                        break;
                    int r = (ex->w > ex->h ? ex->w : ex->h) >> (t - 7 - n_grid - N_REFINE - BLOCK_RANDOM);
                    if (r < 1)
                        break;
                    uint64_t u = rng_next(&rng);
                    cx = bx + (int)(u % (uint64_t)(2 * r + 1)) - r;
                    cy = by + (int)((u >> 32) % (uint64_t)(2 * r + 1)) - r;
                }
                cx = clampi(cx, 0, ex->w - B), cy = clampi(cy, 0, ex->h - B);
                int run = 1, roots[N_OVERLAPPED];
                for (int k = 0; k < N_OVERLAPPED; k++) {
                    roots[k] = nbr[k] >= 0 && cx == cont[k][0] && cy == cont[k][1] ? run_root(parent, nbr[k]) : -1;
                    int counted = 0; /* two neighbours in one run count it once */
                    for (int q = 0; q < k; q++)
                        counted |= roots[q] == roots[k];
                    if (roots[k] >= 0 && !counted)
                        run += size[roots[k]];
                }
                if (run > BLOCK_RUN)
                    continue;
                if (t >= 7 && t < 7 + n_grid) { /* the grid only picks where to refine: a subsampled cost */
                    float d = block_cost(b, cx, cy, gbest, 0, COST_SUBSAMPLE);
                    if (d < gbest)
                        gbest = d, gx = cx, gy = cy;
                    continue;
                }
                float bound = best == FLT_MAX ? FLT_MAX : best * (float)(1 + b->tolerance);
                float d = block_cost(b, cx, cy, bound, run == 1 && !closing, COST_ALL);
                if (d < FLT_MAX && n_near < MAX_NEAR)
                    near_x[n_near] = cx, near_y[n_near] = cy, near_d[n_near++] = d;
                if (d < best)
                    best = d, bx = cx, by = cy;
            }
            /*
             * Within the tolerance the candidate least over its share wins: its exemplar bins against their
             * fair share of the window's blocks (nothing is over it early in a window), plus its colours against
             * their share of the exemplar among the pixels the blocks laid so far (from the first block on).
             * Among equals the first tried, i.e. the voted layout, which carries the coarse levels'
             * arrangement, even where a later candidate fits a little better (measured before the colours
             * were added: autocorrelation 0.70-0.86 against quilting this way, 0.72-1.12 taking the best fit
             * among equals; TEXTURE.md).
             */
            double least = DBL_MAX;
            for (int k = 0; k < n_near && b->tolerance > 0; k++)
                if (near_d[k] <= best * (float)(1 + b->tolerance)) {
                    double o = block_overuse(b, near_x[k], near_y[k]) + colour_overuse(b, near_x[k], near_y[k]);
                    if (o < least)
                        least = o, bx = near_x[k], by = near_y[k];
                }
            if (bx < 0) { /* every candidate continued a full run: the first random one not doing so */
                bx = clampi((int)(rng_next(&rng) % (uint64_t)(ex->w - B + 1)), 0, ex->w - B);
                by = clampi((int)(rng_next(&rng) % (uint64_t)(ex->h - B + 1)), 0, ex->h - B);
            }
            off[2 * id] = bx, off[2 * id + 1] = by;
            parent[id] = id, size[id] = 1;
            for (int k = 0; k < N_OVERLAPPED; k++)
                if (nbr[k] >= 0 && bx == cont[k][0] && by == cont[k][1]) {
                    int r = run_root(parent, nbr[k]), me = run_root(parent, id);
                    if (r != me)
                        parent[r] = me, size[me] += size[r];
                }
            lay_block(b, bx, by, err, path, acc);
        }
}

/*
 * ---- Seams ----
 * A patch across a cut matches no exemplar patch exactly: that is where the
 * blocks depart from the exemplar. A few passes of texture optimisation (Kwatra
 * et al. 2005) restricted to a band about the cuts lower that distance: each
 * patch touching the band takes the nearest exemplar patch among the
 * continuations of the copies it spans, their neighbours, its neighbours'
 * matches and a local search; then each band pixel becomes the mean of the
 * matches covering it, weighted by the robust weight d^((r-2)/2) with r = 0.8, so
 * the better matches win over a blur of all of them, and tapered towards the
 * patch's edges (a sin^2 window): at a stride of 2 two neighbouring rows are
 * covered by the same patches, and with flat votes a near-exact match took both
 * and the next pair switched to another (steps every other row across each
 * cut, 3-6x the texture's own). With the edges tapered away a near-exact
 * match's centre decided a pixel outright and joined the two copies it
 * continues across the cut (larger verbatim regions), so a match nearer than
 * SEAM_EXACT weighs as one at SEAM_EXACT. Pixels outside the band stay verbatim copies.
 * Raster order in one thread, as the blocks.
 */
#define SEAM_RADIUS 3 /* band half-width about a cut, pixels */
#define SEAM_PASSES 3
#define SEAM_STRIDE 2     /* between the optimised patches */
#define SEAM_ROBUST -0.6f /* the vote weight's exponent on a match's distance per pixel */
#define SEAM_EXACT 0.003  /* a match this near (x the distance of unrelated patches) counts as exact */

/* Patch origins along one axis: every SEAM_STRIDE, the last one flush with the end. */
static int seam_origins(int n, int P, int *pos)
{
    int k = 0;
    for (int x = 0; x + P <= n; x += SEAM_STRIDE)
        pos[k++] = x;
    if (k && pos[k - 1] != n - P)
        pos[k++] = n - P;
    return k;
}

/* Whether neighbouring pixels p and q = p + (dx, dy) come from different copies (or one from none). */
static int seam_between(const int32_t *src, int ew, size_t p, size_t q, int dx, int dy)
{
    if (src[p] < 0 || src[q] < 0)
        return src[p] != src[q];
    return src[q] % ew - src[p] % ew != dx || src[q] / ew - src[p] / ew != dy;
}

/* band[p] = 1 for pixels the synthesis may change within SEAM_RADIUS of a cut; near is scratch. */
static void seam_band(const level_win *W, const int32_t *src, int ew, uint8_t *band, uint8_t *near)
{
    int w = W->w, h = W->h, R = SEAM_RADIUS;
    memset(near, 0, (size_t)w * h);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t p = (size_t)y * w + x;
            if (x + 1 < w && seam_between(src, ew, p, p + 1, 1, 0))
                near[p] = near[p + 1] = 1;
            if (y + 1 < h && seam_between(src, ew, p, p + (size_t)w, 0, 1))
                near[p] = near[p + (size_t)w] = 1;
        }
    for (int y = 0; y < h; y++) /* the square about each: rows first, then columns */
        for (int x = 0; x < w; x++) {
            int in = 0;
            for (int k = -R; k <= R && !in; k++)
                in = x + k >= 0 && x + k < w && near[(size_t)y * w + x + k] == 1;
            band[(size_t)y * w + x] = (uint8_t)in;
        }
    for (int x = 0; x < w; x++)
        for (int y = 0; y < h; y++) {
            int in = 0;
            for (int k = -R; k <= R && !in; k++)
                in = y + k >= 0 && y + k < h && band[(size_t)(y + k) * w + x];
            near[(size_t)y * w + x] = (uint8_t)(in && W->fixed[(size_t)y * w + x] != TEX_FIXED);
        }
    memcpy(band, near, (size_t)w * h);
}

/* The nearest exemplar patch to the window's patch at (px, py) among the candidates above; -1 if none is usable. */
static int32_t seam_match(const tex_level *ex, int P, const float *img, int w, const int32_t *src, int px, int py,
                          const int32_t *prior, int n_prior, uint64_t *rng, float *dist)
{
    int ew = ex->w;
    const float *a = img + 3 * ((size_t)py * w + px);
    int32_t cand[5 * 9 + 4], best = -1;
    int nc = 0;
    for (int k = 0; k < n_prior; k++)
        cand[nc++] = prior[k];
    for (int k = 0; k < 5; k++) { /* the copies at the corners and the centre, each shifted by up to a pixel */
        int qx = px + (k == 4 ? P / 2 : (k & 1) * (P - 1)), qy = py + (k == 4 ? P / 2 : (k >> 1) * (P - 1));
        int32_t s = src[(size_t)qy * w + qx];
        for (int d = 0; d < 9 && s >= 0; d++)
            cand[nc++] = usable(ex, P, s % ew - (qx - px) + d % 3 - 1, s / ew - (qy - py) + d / 3 - 1);
    }
    float bd = FLT_MAX;
    for (int k = 0; k < nc; k++) {
        if (cand[k] < 0 || cand[k] == best)
            continue;
        float d = patch_dist(a, 3 * w, ex->px + 3 * (size_t)cand[k], 3 * ew, P, bd);
        if (d < bd)
            bd = d, best = cand[k];
    }
    for (int r = P; r >= 1 && best >= 0; r /= 2) { /* around the best, the radius halving */
        uint64_t u = rng_next(rng);
        int32_t c = usable(ex, P, best % ew + (int)(u % (uint64_t)(2 * r + 1)) - r,
                           best / ew + (int)((u >> 32) % (uint64_t)(2 * r + 1)) - r);
        float d = c < 0 || c == best ? FLT_MAX : patch_dist(a, 3 * w, ex->px + 3 * (size_t)c, 3 * ew, P, bd);
        if (d < bd)
            bd = d, best = c;
    }
    *dist = bd;
    return best;
}

static int refine_seams(const tex_job *job, level_win *W, const tex_level *ex, const block_pass *b)
{
    int w = W->w, h = W->h, P = job->ex->patch, ew = ex->w;
    size_t n = (size_t)w * h;
    int *xs = malloc(sizeof(int) * ((size_t)w + h + 4)), *ys = xs ? xs + w + 2 : NULL;
    int nx = xs ? seam_origins(w, P, xs) : 0, ny = xs ? seam_origins(h, P, ys) : 0;
    uint8_t *band = malloc(n), *scratch = malloc(n);
    float *acc = malloc(sizeof(float) * 4 * n);
    int32_t *z = malloc(sizeof(int32_t) * ((size_t)nx * ny + 1));
    if (!xs || !band || !scratch || !acc || !z) {
        free(xs), free(band), free(scratch), free(acc), free(z);
        return -ENOMEM;
    }
    seam_band(W, b->src, ew, band, scratch);
    memset(scratch, 0, n);       /* now: the pixels the passes blended */
    for (int j = 0; j < ny; j++) /* -1: no match yet; -2: the patch lies outside the band, never matched */
        for (int i = 0; i < nx; i++) {
            int touches = 0;
            for (int y = 0; y < P && !touches; y++)
                for (int x = 0; x < P && !touches; x++)
                    touches = band[(size_t)(ys[j] + y) * w + xs[i] + x];
            z[j * nx + i] = touches ? -1 : -2;
        }
    float *img = b->out, taper[32]; /* patch <= 32 (settings_ok) */
    float exact = (float)(SEAM_EXACT * ex->scale);
    for (int k = 0; k < P; k++) {
        float a = sinf(3.14159265f * ((float)k + 0.5f) / (float)P);
        taper[k] = a * a;
    }
    uint64_t rng = tex_hash(job->key ^ 0x5EA4ull, 0);
    for (int pass = 0; pass < SEAM_PASSES; pass++) {
        memset(acc, 0, sizeof(float) * 4 * n);
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                int px = xs[i], py = ys[j];
                if (z[j * nx + i] == -2)
                    continue;
                int32_t prior[3];
                int np = 0;
                if (z[j * nx + i] >= 0)
                    prior[np++] = z[j * nx + i];
                if (i > 0 && z[j * nx + i - 1] >= 0) /* the neighbours' matches, shifted along */
                    prior[np++] = usable(ex, P, z[j * nx + i - 1] % ew + px - xs[i - 1], z[j * nx + i - 1] / ew);
                if (j > 0 && z[(j - 1) * nx + i] >= 0)
                    prior[np++] = usable(ex, P, z[(j - 1) * nx + i] % ew, z[(j - 1) * nx + i] / ew + py - ys[j - 1]);
                float d;
                int32_t m = seam_match(ex, P, img, w, b->src, px, py, prior, np, &rng, &d);
                z[j * nx + i] = m;
                if (m < 0)
                    continue;
                float wt = powf((d > exact ? d : exact) / (float)(P * P) + 1e-6f, SEAM_ROBUST);
                for (int y = 0; y < P; y++)
                    for (int x = 0; x < P; x++) {
                        size_t q = (size_t)(py + y) * w + px + x;
                        const float *e = ex->px + 3 * ((size_t)m + (size_t)y * ew + x);
                        float tw = wt * taper[y] * taper[x];
                        if (band[q])
                            acc[4 * q] += tw * e[0], acc[4 * q + 1] += tw * e[1], acc[4 * q + 2] += tw * e[2],
                                acc[4 * q + 3] += tw;
                    }
            }
        for (size_t q = 0; q < n; q++)
            if (band[q] && acc[4 * q + 3] > 0) {
                for (int c = 0; c < 3; c++)
                    img[3 * q + c] = acc[4 * q + c] / acc[4 * q + 3];
                scratch[q] = 1;
            }
    }
    /* a blend of matches is no exemplar pixel's value; kept until now: the passes start from the copies' sources */
    for (size_t q = 0; q < n; q++)
        if (scratch[q])
            b->src[q] = -1;
    free(xs), free(band), free(scratch), free(acc), free(z);
    return 0;
}

/* The finest level's window in blocks (above); left as voted where the exemplar or window is smaller than a block. */
int tex_blocks_apply(const tex_exemplar *ex, int w, int h)
{
    int B = BLOCK_PATCHES * ex->patch;
    return !ex->lv[0].valid && ex->lv[0].w >= B && ex->lv[0].h >= B && w >= B && h >= B;
}

static int block_level(const tex_job *job, level_win *W, const tex_level *ex, const float *held, int32_t *src)
{
    int P = job->ex->patch, B = BLOCK_PATCHES * P;
    if (!tex_blocks_apply(job->ex, W->w, W->h))
        return 0;
    int step = tex_block_step(P), nx = (W->w + step - 1) / step + 1, ny = (W->h + step - 1) / step + 1;
    size_t n = (size_t)W->w * W->h, nb = (size_t)nx * ny;
    int bins_w = (ex->w + P - 1) / P, bins_h = (ex->h + P - 1) / P;
    block_pass b = { .ex = ex,
                     .out = W->next,
                     .settled = calloc(n, 1),
                     .tgt = malloc(sizeof(float) * (size_t)B * B * 5 + sizeof(int) * 4 * B),
                     .tpos = malloc(sizeof(int32_t) * 2 * (size_t)B * B),
                     .w = W->w,
                     .h = W->h,
                     .B = B,
                     .cnt = calloc((size_t)bins_w * bins_h, sizeof(float)),
                     .bins_w = bins_w,
                     .P = P,
                     .fair = (double)n / ((double)ex->w * ex->h),
                     .tolerance = BLOCK_TOLERANCE * job->s->reuse,
                     .hout = calloc(TEX_COLOUR_BINS, sizeof(uint32_t)) };
    int *idx = malloc(sizeof(int) * ((size_t)nx + ny + 4 * nb));
    if (!b.settled || !b.tgt || !b.tpos || !b.cnt || !idx || !b.hout) {
        free(b.settled), free(b.tgt), free(b.tpos), free(b.cnt), free(idx), free(b.hout);
        return -ENOMEM;
    }
    b.tsrc = b.tpos + (size_t)B * B;
    b.exact_max = P / 2 > 1 ? P / 2 : 1;
    b.src = W->src_next; /* free after the last vote: the blocks' own source map */
    /* pending pixels (an earlier tile's, not yet out) are settled: a cut may pass through them, no cross-fade follows */
    for (size_t p = 0; p < n; p++) {
        b.settled[p] = W->fixed[p] == TEX_FIXED ? TEX_FIXED + 1 : W->fixed[p] == TEX_SOFT ? PENDING : 0;
        memcpy(W->next + 3 * p, W->fixed[p] == TEX_FREE ? W->img + 3 * p : held + 3 * p, 3 * sizeof(float));
        /* an earlier tile's pixels keep the source it laid them from (the exact test compares sources) */
        b.src[p] = src && W->fixed[p] != TEX_FREE ? src[p] : -1;
    }
    settle_blocks(job, W, ex, idx, idx + nx, idx + nx + ny, idx + nx + ny + 2 * nb, idx + nx + ny + 3 * nb, &b);
    int ret = job->seams ? refine_seams(job, W, ex, &b) : 0;
    if (src)
        memcpy(src, b.src, sizeof(int32_t) * n);
    float *t = W->img;
    W->img = W->next, W->next = t;
    free(b.settled), free(b.tgt), free(b.tpos), free(b.cnt), free(idx), free(b.hout);
    return ret;
}

static void win_free(level_win *W)
{
    free(W->img), free(W->next), free(W->src), free(W->src_next);
    memset(W, 0, sizeof(*W));
}

static int win_alloc(level_win *W, int w, int h)
{
    size_t n = (size_t)w * h;
    *W = (level_win){ malloc(n * 3 * sizeof(float)), malloc(n * 3 * sizeof(float)), NULL,
                      malloc(n * sizeof(int32_t)), malloc(n * sizeof(int32_t)), w, h };
    if (W->img && W->next && W->src && W->src_next)
        return 0;
    win_free(W);
    return -ENOMEM;
}

/* Free pixels copy their source pixel; the others take the window's own values at this level. */
static void paint(level_win *W, const tex_level *ex, const float *img, const uint8_t *fixed)
{
    for (size_t p = 0; p < (size_t)W->w * W->h; p++)
        memcpy(W->img + 3 * p, fixed[p] != TEX_FREE ? img + 3 * p : ex->px + 3 * (size_t)W->src[p], 3 * sizeof(float));
}

/* The coarsest start: patch-sized cells, each copying a random exemplar patch. */
static void seed_cells(const tex_job *job, level_win *W, const tex_level *ex)
{
    int P = job->ex->patch;
    for (int y = 0; y < W->h; y++)
        for (int x = 0; x < W->w; x++) {
            uint64_t cell = ((uint64_t)(y / P) << 32) | (uint64_t)(x / P);
            int32_t n = ex->list[tex_hash(job->key, cell) % (uint64_t)ex->n_list];
            W->src[(size_t)y * W->w + x] = n + (y % P) * ex->w + x % P;
        }
}

/* The next finer level's source map: each coarse source pixel's 2 x 2 children. */
static void upsample(const level_win *C, const tex_level *cex, level_win *F, const tex_level *fex)
{
    for (int y = 0; y < F->h; y++)
        for (int x = 0; x < F->w; x++) {
            int32_t q = C->src[(size_t)(y / 2) * C->w + x / 2];
            int sx = 2 * (q % cex->w) + (x & 1), sy = 2 * (q / cex->w) + (y & 1);
            sx = sx < fex->w ? sx : fex->w - 1;
            sy = sy < fex->h ? sy : fex->h - 1;
            F->src[(size_t)y * F->w + x] = sy * fex->w + sx;
        }
}

int tex_synth_window(const tex_job *job, float *img, const uint8_t *fixed, int32_t *src, int w, int h, int levels)
{
    float *pimg[TEX_MAX_LEVELS] = { img };
    uint8_t *pfix[TEX_MAX_LEVELS] = { (uint8_t *)fixed };
    int pw[TEX_MAX_LEVELS] = { w }, ph[TEX_MAX_LEVELS] = { h }, ret = -ENOMEM;
    level_win W = { 0 }, C = { 0 };
    for (int l = 1; l < levels; l++) {
        pw[l] = (pw[l - 1] + 1) / 2, ph[l] = (ph[l - 1] + 1) / 2;
        pimg[l] = malloc(sizeof(float) * 3 * (size_t)pw[l] * ph[l]);
        pfix[l] = malloc((size_t)pw[l] * ph[l]);
        if (!pimg[l] || !pfix[l])
            goto out;
        tex_reduce(pimg[l - 1], pfix[l - 1], pw[l - 1], ph[l - 1], pimg[l], pfix[l], pw[l], ph[l]);
    }
    for (int l = levels - 1; l >= 0; l--) {
        const tex_level *ex = &job->ex->lv[l];
        if (win_alloc(&W, pw[l], ph[l]))
            goto out;
        W.fixed = pfix[l];
        if (l == levels - 1)
            seed_cells(job, &W, ex);
        else
            upsample(&C, &job->ex->lv[l + 1], &W, ex);
        win_free(&C);
        paint(&W, ex, pimg[l], pfix[l]);
        if ((ret = run_level(job, &W, l)) || (l == 0 && job->blocks && (ret = block_level(job, &W, ex, img, src))))
            goto out;
        C = W;
        memset(&W, 0, sizeof(W));
    }
    memcpy(img, C.img, sizeof(float) * 3 * (size_t)w * h);
    if (src && !(job->blocks && tex_blocks_apply(job->ex, w, h))) /* the vote's pixels are means, not copies */
        for (size_t p = 0; p < (size_t)w * h; p++)
            src[p] = -1;
    ret = 0;
out:
    win_free(&W), win_free(&C);
    for (int l = 1; l < levels; l++)
        free(pimg[l]), free(pfix[l]);
    return ret;
}
