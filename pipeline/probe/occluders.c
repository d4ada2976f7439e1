/* SPDX-License-Identifier: MIT */
/*
 * The occlusion map as objects (PROBE.md, "Occluders"). The per-pixel vote
 * (maps.c) decides each pixel alone; a static occluder is one rigid thing
 * standing on the ground, so its pixels share one bottom row B. Every hidden
 * event is a lower bound on B where it fell, which is why a sign people pass
 * behind at one distance and the post under it, passed at another, came out
 * 109 rows apart on vtest.avi. Each 8-connected group of occluding pixels is
 * settled as one object:
 *
 * - Too small to hide anything: a group whose longest side is under
 *   SPECK_SHARE of a person's height standing at its depth (the scale model)
 *   is a stray inference (grain on a leg, a gap in a stride), not an object.
 *   Thin poles stay: they are long. Without a scale model nothing is dropped.
 * - Torn: a thing standing on the ground hides each body behind it over a
 *   vertical span, so most of its pixels lie in tall columns. A group whose
 *   median pixel lies in a vertical run under TORN_RUN of a person's height
 *   is wrong inferences strung along strides, kerbs and crossing stripes
 *   (one to five rows tall), however wide it spreads; it is dropped too.
 * - Plain: an occluder is a thing the clean plate shows, so where it ends the
 *   plate changes. A group whose outline lies on edges of the plate for less
 *   than EDGE_SHARE of its length and for less than EDGE_SPAN of a person's
 *   height is wrong inferences on plain ground (legs that blur into the road
 *   under compression, stripes of feet) and is dropped. The second clause
 *   keeps a real occluder whose group has false strips attached: its own
 *   outline is still long on edges. Sized groups only, like the rules above.
 * - One depth: the group's depth is its pixels' SETTLE_QUANTILE (the top
 *   share is left to wrong inferences: a near figure whose head has the
 *   sign's colour seems hidden by it). A pixel whose value is farther (a
 *   smaller row) by more than two foot rows' slack is raised to it, unless a
 *   body standing that far or farther was seen over that pixel: then the
 *   pixel belongs to something farther that touches the group. Pixels whose
 *   value is nearer keep it.
 */
#include "probe_internal.h"

#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* a quarter of a person (about 0.4 m): street furniture that can hide part of a body (bins, bollards) is larger */
#define SPECK_SHARE 0.25
/* a tenth of a person (about 17 cm): the vertical span of a body the least occluder hides (a kerb hides a foot) */
#define TORN_RUN 0.1
/* a plate edge: |dR| + |dG| + |dB| across two pixels of half the default change test (fg_threshold 50) */
#define EDGE_LEVELS 25
/* a thing in the plate: this share of the group's outline on its edges, or edges along EDGE_SPAN of a person */
#define EDGE_SHARE 0.3
#define EDGE_SPAN 0.5
#define SETTLE_QUANTILE 0.85 /* of the group's pixels, by depth */
#define FOOT_SLACK 2         /* rows: a foot row is no better (the evidence slots merge values this close) */

/* Grows the group of pixel `seed` into order[*end...]; returns its first index in order. */
static size_t grow(const float *z, uint32_t w, uint32_t h, uint8_t *grouped, int32_t *order, size_t *end, size_t seed)
{
    size_t start = *end, head = start;
    order[(*end)++] = (int32_t)seed;
    grouped[seed] = 1;
    while (head < *end) {
        size_t i = (size_t)order[head++];
        int x = (int)(i % w), y = (int)(i / w);
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                int xx = x + dx, yy = y + dy;
                if (xx < 0 || yy < 0 || xx >= (int)w || yy >= (int)h)
                    continue;
                size_t j = (size_t)yy * w + (size_t)xx;
                if (z[j] >= 0 && !grouped[j]) {
                    grouped[j] = 1;
                    order[(*end)++] = (int32_t)j;
                }
            }
    }
    return start;
}

/* The farthest body seen over pixel i: its bottom row (INT_MAX: none seen). */
static int farthest_seen(const probe_maps *m, size_t i)
{
    const int16_t *vv = m->vis + i * PROBE_EVIDENCE;
    const uint16_t *vn = m->vis_n + i * PROBE_EVIDENCE;
    int far = INT_MAX;
    for (int k = 0; k < PROBE_EVIDENCE; k++)
        if (vn[k] && vv[k] < far)
            far = vv[k];
    return far;
}

/* The smallest value v in [lo, hi] with more than `rank` of the histogram's entries at or below it. */
static int hist_rank(const uint32_t *hist, int lo, int hi, size_t rank)
{
    size_t acc = 0;
    for (int v = lo; v < hi; v++)
        if ((acc += hist[v]) > rank)
            return v;
    return hi;
}

/* Pixels of the group (order[start..end)) lying in vertical runs of occluding pixels at least min_run long. */
static size_t in_tall_runs(const float *z, uint32_t w, uint32_t h, const int32_t *order, size_t start, size_t end,
                           double min_run)
{
    size_t tall = 0;
    for (size_t k = start; k < end; k++) {
        size_t i = (size_t)order[k];
        if (i >= w && z[i - w] >= 0)
            continue;     /* not the top of its run */
        uint32_t run = 1; /* the pixels below are in the group: vertical neighbours are 8-connected */
        for (size_t j = i + w; j < (size_t)w * h && z[j] >= 0; j += w)
            run++;
        if (run >= min_run)
            tall += run;
    }
    return tall;
}

/* The clean plate's change across pixel i (not on the image's edge), measured as the change test measures:
 * |dR| + |dG| + |dB| of the central differences, the larger of across and down. */
static int plate_step(const uint8_t *rgb, uint32_t w, size_t i)
{
    const uint8_t *l = rgb + 3 * (i - 1), *r = rgb + 3 * (i + 1), *u = rgb + 3 * (i - w), *d = rgb + 3 * (i + w);
    int dx = 0, dy = 0;
    for (int c = 0; c < 3; c++)
        dx += abs(r[c] - l[c]), dy += abs(d[c] - u[c]);
    return dx > dy ? dx : dy;
}

/*
 * The group's outline pixels (a 4-neighbour outside the group; the image's two outer rows and columns are
 * left out: no plate edge is measured there) into *outline; returns those within a pixel of an edge of the
 * clean plate (a step of EDGE_LEVELS or more).
 */
static size_t outline_on_plate_edges(const float *z, const uint8_t *plate, uint32_t w, uint32_t h, const int32_t *order,
                                     size_t start, size_t end, size_t *outline)
{
    size_t on = 0;
    *outline = 0;
    for (size_t k = start; k < end; k++) {
        size_t i = (size_t)order[k];
        uint32_t x = (uint32_t)(i % w), y = (uint32_t)(i / w);
        if (x < 2 || y < 2 || x + 2 >= w || y + 2 >= h ||
            (z[i - 1] >= 0 && z[i + 1] >= 0 && z[i - w] >= 0 && z[i + w] >= 0))
            continue;
        (*outline)++;
        int edge = 0;
        for (size_t j = i - w - 1; j <= i + w - 1 && !edge; j += w)
            edge = plate_step(plate, w, j) >= EDGE_LEVELS || plate_step(plate, w, j + 1) >= EDGE_LEVELS ||
                plate_step(plate, w, j + 2) >= EDGE_LEVELS;
        on += (size_t)edge;
    }
    return on;
}

static inline int clamp_row(int v, uint32_t h)
{
    return v < 0 ? 0 : v >= (int)h ? (int)h - 1 : v;
}

void occluders_settle(probe_maps *m, const sp_probe_plane *plane, probe_occluder_stats *st)
{
    uint32_t w = m->width, h = m->height;
    size_t n = (size_t)w * h, end = 0;
    float *z = m->occlusion;
    memset(st, 0, sizeof(*st));
    memset(m->occ_grouped, 0, n);
    memset(m->occ_hist, 0, (size_t)h * sizeof(uint32_t));
    for (size_t seed = 0; seed < n; seed++) {
        if (z[seed] < 0 || m->occ_grouped[seed])
            continue;
        size_t start = grow(z, w, h, m->occ_grouped, m->occ_order, &end, seed);
        size_t count = end - start;
        int x0 = (int)w, x1 = -1, y0 = (int)h, y1 = -1, z0 = (int)h, z1 = -1;
        double sx = 0;
        for (size_t k = start; k < end; k++) {
            size_t i = (size_t)m->occ_order[k];
            int x = (int)(i % w), y = (int)(i / w);
            x0 = x < x0 ? x : x0, x1 = x > x1 ? x : x1;
            y0 = y < y0 ? y : y0, y1 = y > y1 ? y : y1;
            sx += x;
            int zi = clamp_row((int)z[i], h);
            z0 = zi < z0 ? zi : z0, z1 = zi > z1 ? zi : z1;
            m->occ_hist[zi]++;
        }
        /* the histogram is cleared where this group filled it: a frame of specks costs no h per speck */
        int depth = hist_rank(m->occ_hist, z0, z1, (size_t)(SETTLE_QUANTILE * (double)count));
        for (int v = z0; v <= z1; v++)
            m->occ_hist[v] = 0;
        double person = sp_probe_plane_height(plane, sx / (double)count, depth);
        int side = (x1 - x0 > y1 - y0 ? x1 - x0 : y1 - y0) + 1;
        st->groups++;
        int sized = isfinite(person) && person > 0;
        int speck = sized && side < SPECK_SHARE * person;
        int torn = sized && !speck && 2 * in_tall_runs(z, w, h, m->occ_order, start, end, TORN_RUN * person) < count;
        int plain = 0;
        if (sized && !speck && !torn) {
            size_t outline, on = outline_on_plate_edges(z, m->clean, w, h, m->occ_order, start, end, &outline);
            plain = (double)on < EDGE_SHARE * (double)outline && (double)on < EDGE_SPAN * person;
        }
        if (speck || torn || plain) {
            for (size_t k = start; k < end; k++)
                z[m->occ_order[k]] = -1.0f;
            st->specks += (size_t)speck, st->torn += (size_t)torn, st->plain += (size_t)plain;
            st->dropped_pixels += count;
            continue;
        }
        for (size_t k = start; k < end; k++) {
            size_t i = (size_t)m->occ_order[k];
            if (z[i] < (float)(depth - 2 * FOOT_SLACK) && farthest_seen(m, i) > depth + FOOT_SLACK) {
                z[i] = (float)depth;
                st->raised++;
            }
        }
    }
}
