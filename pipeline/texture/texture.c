/* SPDX-License-Identifier: MIT */
/*
 * The tiled driver: tiles in raster order, each a window of its core plus a
 * halo of 4 patches; halo pixels already finished (above, to the left, and
 * across the wrap for a tileable output) are held fixed so the tile continues
 * them, except the 2 patches nearest the core that the sink has not had yet:
 * those are synthesised again and cross-faded from the old values to the new.
 * A tileable output's first tile row also makes the last halo rows (the strip
 * above row 0 across the wrap) and keeps them back from the sink, so the last
 * tile row closes onto rows it may still blend into, as the last tile of a row
 * does onto the first: the top-bottom wrap is joined like every other border.
 * The band of one tile row (plus the halo above), each pixel with the exemplar
 * pixel it was laid from (the blocks refuse to continue an earlier tile's
 * copy by source), waits in a scratch file, so
 * memory does not grow with the width; its rows go to the sink one at a time
 * when the row is done.
 */
#include "sunprobe/sp_texture.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

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
    int W, H, nx, ny, halo, blend, rows;
    int strip;           /* tileable: rows [H - strip, H) belong to the first tile row (ys[0] = -strip) */
    int blocks, seams;   /* the finest level in whole blocks, their cuts optimised (tex_job) */
    int *xs, *ys;        /* tile boundaries, nx + 1 and ny + 1 */
    int fd;              /* scratch file: output row y of the band at row y % rows; tileable: the strip after;
                            then the same rows' sources (int32, the exemplar pixel + 1, 0 for none) */
    float *win, *old;    /* the window; the band's values under it */
    int32_t *wsrc, *osrc; /* the window's sources (tex_synth_window), the band's under it (+ 1) */
    uint8_t *fixed;
    float *line;         /* one output row for the sink */
} tiler;

static int wrap(int v, int n)
{
    return ((v % n) + n) % n;
}

enum { PIXELS, SOURCES }; /* the scratch file's two parts */

static size_t part_bytes(int part)
{
    return part == PIXELS ? sizeof(float) * 3 : sizeof(int32_t);
}

/*
 * Reads (write = 0) or writes n pixels (RGB floats) or their sources (int32) of
 * scratch row frow from column x; bytes never written read as 0.
 */
static int store_io(const tiler *t, int part, int write, int frow, int x, int n, void *buf)
{
    size_t px = part_bytes(part), len = px * (size_t)n, done = 0;
    off_t base = part == PIXELS ? 0 : (off_t)part_bytes(PIXELS) * (off_t)(t->rows + t->halo) * t->W;
    off_t at = base + (off_t)px * ((off_t)frow * t->W + x);
    while (done < len) {
        ssize_t r = write ? pwrite(t->fd, (char *)buf + done, len - done, at + (off_t)done)
                          : pread(t->fd, (char *)buf + done, len - done, at + (off_t)done);
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0)
            return -errno;
        if (r == 0 && write)
            return -EIO;
        if (r == 0) { /* past the end: not written yet */
            memset((char *)buf + done, 0, len - done);
            break;
        }
        done += (size_t)r;
    }
    return 0;
}

/* One window row's span of columns [x0, x0 + w) (wrapped when tileable) from or to scratch row frow. */
static int row_io(const tiler *t, int part, int write, int frow, int x0, int w, void *buf)
{
    if (!t->s->tileable)
        return store_io(t, part, write, frow, x0, w, buf);
    int a = wrap(x0, t->W), n1 = t->W - a < w ? t->W - a : w, ret = store_io(t, part, write, frow, a, n1, buf);
    return ret || n1 == w ? ret
                          : store_io(t, part, write, frow, 0, w - n1, (char *)buf + part_bytes(part) * (size_t)n1);
}

/* Output row y (any integer) in the tile rows' coordinates (ys): wrapped when tileable, the strip as [-strip, 0). */
static int tile_row_y(const tiler *t, int y)
{
    if (!t->s->tileable)
        return y;
    y = wrap(y, t->H);
    return y >= t->H - t->strip ? y - t->H : y;
}

/* The piece k of n tile boundaries with cuts[k] <= v < cuts[k + 1], -1 outside them. */
static int cut_owner(const int *cuts, int n, int v)
{
    if (v < cuts[0] || v >= cuts[n])
        return -1;
    int lo = 0, hi = n - 1; /* by halves: a side of 10^6 pixels has 4000 tiles, and every window pixel asks */
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (v >= cuts[mid])
            lo = mid;
        else
            hi = mid - 1;
    }
    return lo;
}

/*
 * Whether output (x, y) is finished while tile (i, j) runs: -1 still to make,
 * 0 finished, 1 finished but not handed to the sink yet (this tile row, the
 * last rows of the one above, and a tileable output's strip), so the tile may
 * still blend into it.
 */
static int finished(const tiler *t, int i, int j, int x, int y)
{
    if (t->s->tileable)
        x = wrap(x, t->W);
    y = tile_row_y(t, y);
    int k = cut_owner(t->ys, t->ny, y), col = cut_owner(t->xs, t->nx, x);
    if (col < 0 || k < 0 || k > j)
        return -1;
    if (k < j) /* rows above (and, for the last tile row, the strip below): the sink has rows [0, ys[j] - blend) */
        return y < 0 || y >= t->ys[j] - t->blend;
    return col < i ? 1 : -1; /* this tile row: the tiles left of i */
}

/* Scratch row of output row y for tile row j; -1 when the band does not hold it. */
static int scratch_row(const tiler *t, int j, int y)
{
    y = tile_row_y(t, y);
    if (y < 0 && y >= -t->strip) /* the strip: kept apart until the end */
        return t->rows + t->strip + y;
    if (y >= 0 && y >= t->ys[j] - t->halo && y < t->ys[j + 1])
        return y % t->rows;
    return -1;
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
 * Reads the band under the window, marks each window pixel free, blended
 * (finished but pending, within blend of the core: free in the synthesis,
 * started from its value) or fixed, and fills the window with the values there are.
 */
static int gather(tiler *t, int i, int j, int x0, int y0, int w, int h)
{
    for (int y = 0, ret; y < h; y++) {
        int frow = scratch_row(t, j, y0 + y);
        if (frow >= 0 &&
            ((ret = row_io(t, PIXELS, 0, frow, x0, w, t->old + 3 * (size_t)y * w)) ||
             (ret = row_io(t, SOURCES, 0, frow, x0, w, t->osrc + (size_t)y * w))))
            return ret;
    }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int st = finished(t, i, j, x0 + x, y0 + y);
            size_t p = (size_t)y * w + x;
            int soft = st > 0 && core_dist(t, i, j, x0 + x, y0 + y) <= t->blend;
            t->fixed[p] = st < 0 ? TEX_FREE : soft ? TEX_SOFT : TEX_FIXED;
            if (st >= 0)
                memcpy(t->win + 3 * p, t->old + 3 * p, 3 * sizeof(float));
            t->wsrc[p] = st >= 0 ? t->osrc[p] - 1 : -1;
        }
    return 0;
}

/* The core into the band; blended pixels become a mix of old and new that moves to the new towards the core. */
static int scatter(tiler *t, const tex_exemplar *ex, int i, int j, int x0, int y0, int w, int h)
{
    int cut = t->blocks && tex_blocks_apply(ex, w, h); /* blocks settled the blend by a cut: no cross-fade */
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t p = (size_t)y * w + x;
            int d = core_dist(t, i, j, x0 + x, y0 + y);
            if (d > 0 && t->fixed[p] != TEX_SOFT)
                continue;
            int fade = d > 0 && !cut; /* the core is new: its old band values are not pixels yet */
            float *v = t->old + 3 * p, a = (float)(t->blend + 1 - d) / (float)(t->blend + 1);
            for (int c = 0; c < 3; c++)
                v[c] = fade ? v[c] + a * (t->win[3 * p + c] - v[c]) : t->win[3 * p + c];
            t->osrc[p] = fade ? 0 : t->wsrc[p] + 1; /* a cross-fade is no exemplar pixel */
        }
    for (int y = 0, ret; y < h; y++) {
        int frow = scratch_row(t, j, y0 + y);
        if (frow >= 0 &&
            ((ret = row_io(t, PIXELS, 1, frow, x0, w, t->old + 3 * (size_t)y * w)) ||
             (ret = row_io(t, SOURCES, 1, frow, x0, w, t->osrc + (size_t)y * w))))
            return ret;
    }
    return 0;
}

static int run_tile(tiler *t, const tex_exemplar *ex, sp_pool *pool, int i, int j)
{
    int x0, x1, y0, y1;
    span(t, t->xs, i, t->W, &x0, &x1);
    span(t, t->ys, j, t->H, &y0, &y1);
    int w = x1 - x0, h = y1 - y0, ret = gather(t, i, j, x0, y0, w, h);
    tex_job job = { ex, t->s, pool, tex_hash(t->s->seed, ((uint64_t)j << 32) | (uint64_t)i), t->blocks, t->seams };
    if (!ret)
        ret = tex_synth_window(&job, t->win, t->fixed, t->wsrc, w, h, tex_window_levels(w, h, ex->patch, ex->levels));
    if (ret)
        return ret;
    return scatter(t, ex, i, j, x0, y0, w, h);
}

/* n cuts of [0, len) into pieces of nearly equal size. */
static int *cuts(int len, int n)
{
    int *c = malloc(sizeof(int) * (size_t)(n + 1));
    for (int k = 0; c && k <= n; k++)
        c[k] = (int)((long long)len * k / n);
    return c;
}

/* An unlinked scratch file in $TMPDIR (else /tmp); -errno when none can be made. */
static int scratch_open(void)
{
    const char *dir = getenv("TMPDIR");
    char path[4096];
    if (snprintf(path, sizeof(path), "%s/sunprobe-texture-XXXXXX", dir && *dir ? dir : "/tmp") >= (int)sizeof(path))
        return -ENAMETOOLONG;
    int fd = mkstemp(path);
    if (fd < 0) {
        int e = errno;
        sp_log(SP_LOG_ERROR, "texture", "%s: cannot make the scratch file for the finished rows: %s", path, strerror(e));
        return -e;
    }
    unlink(path);
    return fd;
}

static int tiler_open(tiler *t, const sp_texture_settings *s, int W, int H)
{
    memset(t, 0, sizeof(*t));
    t->fd = -1;
    t->s = s, t->W = W, t->H = H, t->halo = 4 * s->patch, t->blend = 2 * s->patch;
    t->blocks = !getenv("SP_TEX_NOBLOCKS");
    t->seams = !getenv("SP_TEX_NOSEAMS");
    int T = s->tile;
    t->nx = (W + T - 1) / T, t->ny = (H + T - 1) / T;
    if (s->tileable) /* a tile never wraps onto itself */
        t->nx = t->nx < 2 ? 2 : t->nx, t->ny = t->ny < 2 ? 2 : t->ny;
    t->xs = cuts(W, t->nx), t->ys = cuts(H, t->ny);
    t->rows = (H + t->ny - 1) / t->ny + t->halo;
    t->strip = s->tileable ? t->halo : 0;
    for (int k = 0; t->ys && k <= t->ny; k++)
        t->ys[k] -= t->strip;
    size_t side = (size_t)T + 2 * (size_t)t->halo + 2; /* a core is at most T (or half a tileable side) */
    t->win = malloc(sizeof(float) * 3 * side * side);
    t->old = malloc(sizeof(float) * 3 * side * side);
    t->fixed = malloc(side * side);
    t->wsrc = malloc(sizeof(int32_t) * side * side);
    t->osrc = malloc(sizeof(int32_t) * side * side);
    t->line = malloc(sizeof(float) * 3 * (size_t)W);
    t->fd = scratch_open();
    if (t->fd < 0)
        return t->fd;
    return t->xs && t->ys && t->win && t->old && t->fixed && t->wsrc && t->osrc && t->line ? 0 : -ENOMEM;
}

static void tiler_close(tiler *t)
{
    if (t->fd >= 0)
        close(t->fd);
    free(t->xs), free(t->ys), free(t->win), free(t->old), free(t->fixed), free(t->wsrc), free(t->osrc), free(t->line);
    memset(t, 0, sizeof(*t));
}

/* Hands the rows of tile row j that no later tile blends into to the sink, one at a time; the strip comes last. */
static int finish_row(tiler *t, int j, sp_texture_sink sink, void *ctx)
{
    int last = j == t->ny - 1, e0 = j ? t->ys[j] - t->blend : 0, e1 = last ? t->ys[t->ny] : t->ys[j + 1] - t->blend;
    int ret = 0;
    for (int y = e0 < 0 ? 0 : e0; !ret && y < e1; y++)
        if (!(ret = store_io(t, PIXELS, 0, y % t->rows, 0, t->W, t->line)))
            ret = sink(ctx, (uint32_t)y, 1, t->line);
    for (int y = t->H - t->strip; !ret && last && y < t->H; y++) {
        int frow = scratch_row(t, j, y);
        if (!(ret = store_io(t, PIXELS, 0, frow, 0, t->W, t->line)))
            ret = sink(ctx, (uint32_t)y, 1, t->line);
    }
    return ret;
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
    tex_job job = { &ex, s, pool, tex_hash(s->seed, 0xF111ull), 0, 0 };
    if (!ret)
        ret = tex_synth_window(&job, win, fixed, NULL, bw, bh, tex_window_levels(bw, bh, s->patch, ex.levels));
    for (int y = 0; !ret && y < bh; y++)
        memcpy(rgb + 3 * ((size_t)(y + box[1]) * w + (size_t)box[0]), win + 3 * (size_t)y * bw,
               3 * sizeof(float) * (size_t)bw);
    sp_pool_close(&pool);
    free(win), free(fixed);
    tex_exemplar_free(&ex);
    return ret;
}
