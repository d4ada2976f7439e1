/* SPDX-License-Identifier: MIT */
/*
 * The tiled driver: tiles in raster order, each a window of its core plus a
 * halo of 4 patches; halo pixels already finished (above, to the left, and
 * across the wrap for a tileable output) are held fixed so the tile continues
 * them, except the 2 patches nearest the core that the sink has not had yet:
 * those are synthesised again and cross-faded from the old values to the new.
 * A band of one tile row (plus the halo above) is all that is kept of the
 * output; it goes to the sink when the row is done.
 */
#include "sunprobe/sp_texture.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "texture_internal.h"

void sp_texture_default_settings(sp_texture_settings *s)
{
    *s = (sp_texture_settings){ .patch = 8, .tile = 256, .levels = 0, .iterations = 3, .threads = 0,
                                .reuse = 0.5, .seed = 1, .tileable = 0 };
}

static int settings_ok(const sp_texture_settings *s)
{
    return s && s->patch >= 4 && s->patch <= 32 && s->iterations >= 1 && s->iterations <= 16 &&
           s->levels >= 0 && s->levels <= TEX_MAX_LEVELS && s->reuse >= 0 && s->reuse <= 10 && s->threads >= 0;
}

/* Pyramid levels for an exemplar: down to about 4 patches a side, or as asked. */
static int exemplar_levels(const sp_texture_settings *s, uint32_t ew, uint32_t eh)
{
    if (s->levels)
        return s->levels;
    int l = 1;
    uint32_t m = ew < eh ? ew : eh;
    while (l < TEX_MAX_LEVELS && (m >> l) >= 4u * (uint32_t)s->patch)
        l++;
    return l;
}

typedef struct tiler {
    const sp_texture_settings *s;
    int W, H, nx, ny, halo, blend, band_rows;
    int *xs, *ys;        /* tile boundaries, nx + 1 and ny + 1 */
    float *band;         /* rows [ys[j] - halo, ys[j + 1]) of the output */
    float *first;        /* tileable: rows [0, halo), kept for the last tile row */
    float *win;
    uint8_t *fixed;
} tiler;

static int wrap(int v, int n)
{
    return ((v % n) + n) % n;
}

/*
 * The finished value at output (x, y) while tile (i, j) runs, or NULL when that
 * pixel is still to make. *pending: not handed to the sink yet (this tile row,
 * and the last rows of the one above), so the tile may still blend into it.
 */
static float *finished(const tiler *t, int i, int j, int x, int y, int *pending)
{
    *pending = 0;
    if (t->s->tileable)
        x = wrap(x, t->W), y = wrap(y, t->H);
    if (x < 0 || y < 0 || x >= t->W || y >= t->H)
        return NULL;
    int top = t->ys[j] - t->halo;
    if (y >= top && y < t->ys[j]) { /* the halo rows above: all finished */
        *pending = j > 0 && y >= t->ys[j] - t->blend;
        return t->band + 3 * ((size_t)(y - top) * t->W + x);
    }
    if (y >= t->ys[j] && y < t->ys[j + 1]) { /* this tile row: the tiles left of i */
        int col = 0;
        while (x >= t->xs[col + 1])
            col++;
        *pending = 1;
        return col < i ? t->band + 3 * ((size_t)(y - top) * t->W + x) : NULL;
    }
    if (t->first && j == t->ny - 1 && j > 0 && y < t->halo) /* across the bottom wrap */
        return t->first + 3 * ((size_t)y * t->W + x);
    return NULL;
}

/* Chebyshev distance of window pixel (x, y) (output coordinates, unwrapped) from tile (i, j)'s core. */
static int core_dist(const tiler *t, int i, int j, int x, int y)
{
    int dx = t->xs[i] - x > x - (t->xs[i + 1] - 1) ? t->xs[i] - x : x - (t->xs[i + 1] - 1);
    int dy = t->ys[j] - y > y - (t->ys[j + 1] - 1) ? t->ys[j] - y : y - (t->ys[j + 1] - 1);
    return dx > dy ? dx : dy;
}

/* Window bounds of tile (i, j) along one axis: the core plus the halo, clipped unless the output wraps. */
static void span(const tiler *t, const int *cuts, int k, int n, int *a, int *b)
{
    *a = cuts[k] - t->halo, *b = cuts[k + 1] + t->halo;
    if (!t->s->tileable) {
        *a = *a < 0 ? 0 : *a;
        *b = *b > n ? n : *b;
    }
}

/*
 * Marks each window pixel free, blended (finished but pending, within blend of
 * the core: free in the synthesis, started from its value) or fixed, and fills
 * the window with the values there are.
 */
static void gather(tiler *t, int i, int j, int x0, int y0, int w, int h)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int pending;
            const float *v = finished(t, i, j, x0 + x, y0 + y, &pending);
            size_t p = (size_t)y * w + x;
            t->fixed[p] = !v ? TEX_FREE : pending && core_dist(t, i, j, x0 + x, y0 + y) <= t->blend ? TEX_SOFT : TEX_FIXED;
            if (v)
                memcpy(t->win + 3 * p, v, 3 * sizeof(float));
        }
}

/* The core into the band; blended pixels become a mix of old and new that moves to the new towards the core. */
static void scatter(tiler *t, int i, int j, int x0, int y0, int w, int h)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t p = (size_t)y * w + x;
            int pending, d = core_dist(t, i, j, x0 + x, y0 + y);
            if (d > 0 && t->fixed[p] != TEX_SOFT)
                continue;
            float *v = finished(t, i, j, x0 + x, y0 + y, &pending);
            if (!v) /* the core: finished() does not count it yet */
                v = t->band + 3 * ((size_t)(y0 + y - (t->ys[j] - t->halo)) * t->W + (size_t)(x0 + x));
            float a = (float)(t->blend + 1 - d) / (float)(t->blend + 1);
            for (int c = 0; c < 3; c++) /* the core is new: its old band values are not pixels yet */
                v[c] = d > 0 ? v[c] + a * (t->win[3 * p + c] - v[c]) : t->win[3 * p + c];
        }
}

static int run_tile(tiler *t, const tex_exemplar *ex, sp_pool *pool, int i, int j)
{
    int x0, x1, y0, y1;
    span(t, t->xs, i, t->W, &x0, &x1);
    span(t, t->ys, j, t->H, &y0, &y1);
    int w = x1 - x0, h = y1 - y0;
    gather(t, i, j, x0, y0, w, h);
    tex_job job = { ex, t->s, pool, tex_hash(t->s->seed, ((uint64_t)j << 32) | (uint64_t)i) };
    int ret = tex_synth_window(&job, t->win, t->fixed, w, h, tex_window_levels(w, h, ex->patch, ex->levels));
    if (!ret)
        scatter(t, i, j, x0, y0, w, h);
    return ret;
}

/* n cuts of [0, len) into pieces of nearly equal size. */
static int *cuts(int len, int n)
{
    int *c = malloc(sizeof(int) * (size_t)(n + 1));
    for (int k = 0; c && k <= n; k++)
        c[k] = (int)((long long)len * k / n);
    return c;
}

static int tiler_open(tiler *t, const sp_texture_settings *s, int W, int H)
{
    memset(t, 0, sizeof(*t));
    t->s = s, t->W = W, t->H = H, t->halo = 4 * s->patch, t->blend = 2 * s->patch;
    int T = s->tile;
    t->nx = (W + T - 1) / T, t->ny = (H + T - 1) / T;
    if (s->tileable) /* a tile never wraps onto itself */
        t->nx = t->nx < 2 ? 2 : t->nx, t->ny = t->ny < 2 ? 2 : t->ny;
    t->xs = cuts(W, t->nx), t->ys = cuts(H, t->ny);
    t->band_rows = (H + t->ny - 1) / t->ny + t->halo;
    size_t side = (size_t)T + 2 * (size_t)t->halo + 2; /* a core is at most T (or half a tileable side) */
    t->band = malloc(sizeof(float) * 3 * (size_t)W * (size_t)t->band_rows);
    t->win = malloc(sizeof(float) * 3 * side * side);
    t->fixed = malloc(side * side);
    if (s->tileable)
        t->first = malloc(sizeof(float) * 3 * (size_t)W * (size_t)t->halo);
    return t->xs && t->ys && t->band && t->win && t->fixed && (!s->tileable || t->first) ? 0 : -ENOMEM;
}

static void tiler_close(tiler *t)
{
    free(t->xs), free(t->ys), free(t->band), free(t->first), free(t->win), free(t->fixed);
    memset(t, 0, sizeof(*t));
}

/* Hands the rows of tile row j that no later tile blends into to the sink; moves the last halo rows to the top. */
static int finish_row(tiler *t, int j, sp_texture_sink sink, void *ctx)
{
    size_t row = 3 * (size_t)t->W;
    int top = t->ys[j] - t->halo, n = t->ys[j + 1] - t->ys[j];
    int e0 = j ? t->ys[j] - t->blend : 0, e1 = j < t->ny - 1 ? t->ys[j + 1] - t->blend : t->H;
    int ret = sink(ctx, (uint32_t)e0, (uint32_t)(e1 - e0), t->band + row * (size_t)(e0 - top));
    if (ret)
        return ret;
    if (t->first && j == 0)
        memcpy(t->first, t->band + row * (size_t)t->halo, sizeof(float) * row * (size_t)t->halo);
    memmove(t->band, t->band + row * (size_t)n, sizeof(float) * row * (size_t)t->halo);
    return 0;
}
static int sizes_ok(const sp_texture_settings *s, uint32_t ew, uint32_t eh, uint32_t W, uint32_t H)
{
    uint32_t P = (uint32_t)s->patch;
    if (ew < P || eh < P || W < P || H < P || W > SP_TEXTURE_MAX_SIDE || H > SP_TEXTURE_MAX_SIDE)
        return 0;
    if (s->tile < 8 * s->patch || s->tile > 4096)
        return 0;
    return !s->tileable || (W >= 16 * P && H >= 16 * P);
}

int sp_texture_synthesize(const float *exemplar, uint32_t ew, uint32_t eh, uint32_t width, uint32_t height,
                          const sp_texture_settings *s, sp_texture_sink sink, void *ctx)
{
    if (!exemplar || !sink || !settings_ok(s) || !sizes_ok(s, ew, eh, width, height))
        return -EINVAL;
    tex_exemplar ex;
    int ret = tex_exemplar_build(&ex, exemplar, (int)ew, (int)eh, NULL, s->patch, exemplar_levels(s, ew, eh));
    if (ret)
        return ret;
    sp_pool *pool = NULL;
    tiler t;
    if (!(ret = tiler_open(&t, s, (int)width, (int)height)) && !(ret = sp_pool_open(&pool, s->threads)))
        for (int j = 0; !ret && j < t.ny; j++) {
            for (int i = 0; !ret && i < t.nx; i++)
                ret = run_tile(&t, &ex, pool, i, j);
            if (!ret)
                ret = finish_row(&t, j, sink, ctx);
        }
    sp_pool_close(&pool);
    tiler_close(&t);
    tex_exemplar_free(&ex);
    return ret;
}

/* The bounding box of the pixels to fill, grown by margin and clipped. 0 when there is nothing to fill. */
static int fill_box(const uint8_t *fill, int w, int h, int margin, int box[4])
{
    box[0] = w, box[1] = h, box[2] = -1, box[3] = -1;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            if (fill[(size_t)y * w + x]) {
                box[0] = x < box[0] ? x : box[0], box[2] = x > box[2] ? x : box[2];
                box[1] = y < box[1] ? y : box[1], box[3] = y > box[3] ? y : box[3];
            }
    if (box[2] < 0)
        return 0;
    box[0] = box[0] - margin > 0 ? box[0] - margin : 0, box[1] = box[1] - margin > 0 ? box[1] - margin : 0;
    box[2] = box[2] + margin + 1 < w ? box[2] + margin + 1 : w, box[3] = box[3] + margin + 1 < h ? box[3] + margin + 1 : h;
    return 1;
}

int sp_texture_fill(float *rgb, uint32_t w, uint32_t h, const uint8_t *fill, const uint8_t *source,
                    const sp_texture_settings *s)
{
    if (!rgb || !fill || !source || !settings_ok(s) || w < (uint32_t)s->patch || h < (uint32_t)s->patch ||
        w > 16384 || h > 16384)
        return -EINVAL;
    int box[4];
    if (!fill_box(fill, (int)w, (int)h, 4 * s->patch, box))
        return 0;
    int bw = box[2] - box[0], bh = box[3] - box[1];
    if (bw < s->patch || bh < s->patch) /* a box that small only happens at an image this small */
        box[0] = box[1] = 0, box[2] = (int)w, box[3] = (int)h, bw = (int)w, bh = (int)h;
    tex_exemplar ex;
    int ret = tex_exemplar_build(&ex, rgb, (int)w, (int)h, source, s->patch, exemplar_levels(s, w, h));
    if (ret)
        return ret;
    float *win = malloc(sizeof(float) * 3 * (size_t)bw * bh);
    uint8_t *fixed = malloc((size_t)bw * bh);
    sp_pool *pool = NULL;
    ret = win && fixed ? sp_pool_open(&pool, s->threads) : -ENOMEM;
    for (int y = 0; !ret && y < bh; y++)
        for (int x = 0; x < bw; x++) {
            size_t p = (size_t)y * bw + x, q = (size_t)(y + box[1]) * w + (size_t)(x + box[0]);
            memcpy(win + 3 * p, rgb + 3 * q, 3 * sizeof(float));
            fixed[p] = fill[q] ? TEX_FREE : TEX_FIXED;
        }
    tex_job job = { &ex, s, pool, tex_hash(s->seed, 0xF111ull) };
    if (!ret)
        ret = tex_synth_window(&job, win, fixed, bw, bh, tex_window_levels(bw, bh, s->patch, ex.levels));
    for (int y = 0; !ret && y < bh; y++)
        memcpy(rgb + 3 * ((size_t)(y + box[1]) * w + (size_t)box[0]), win + 3 * (size_t)y * bw,
               3 * sizeof(float) * (size_t)bw);
    sp_pool_close(&pool);
    free(win), free(fixed);
    tex_exemplar_free(&ex);
    return ret;
}
