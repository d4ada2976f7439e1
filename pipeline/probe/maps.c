/* SPDX-License-Identifier: MIT */
/*
 * The per-pixel maps, as bounded running statistics (PROBE.md, "Maps"):
 *
 * Occlusion. An object is evidence twice. Where its refined mask M' covers a
 * pixel, the pixel was visible in front of the object: nothing there occludes
 * an object that far away (the eq. 3.1 record: the farthest bottoms seen
 * visible, vis1 <= vis2). Where a row of its upper body is interrupted by
 * background-coloured pixels, something static stood in front of it: those
 * pixels occlude objects that far away (the nearest bottoms seen hidden,
 * occ1 >= occ2). A pixel occludes objects with bottom row <= occ2 once it has
 * min_events occlusion events and no two visible events contradict it
 * (vis2 < occ2). Second-order statistics make one stray frame harmless.
 *
 * Lighting (eq. 3.3): per pixel, the running mean of the mean colours of the
 * objects whose M' covered it; divided by the mean over all objects at the end.
 */
#include "probe_internal.h"

#include <errno.h>
#include <stdio.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

int maps_open(probe_maps *m, uint32_t width, uint32_t height, unsigned min_events)
{
    memset(m, 0, sizeof(*m));
    size_t n = (size_t)width * height;
    m->width = width;
    m->height = height;
    m->min_events = min_events ? min_events : 1;
    m->occ1 = malloc(n * sizeof(int16_t));
    m->occ2 = malloc(n * sizeof(int16_t));
    m->occ_n = calloc(n, sizeof(uint16_t));
    m->vis1 = malloc(n * sizeof(int16_t));
    m->vis2 = malloc(n * sizeof(int16_t));
    m->light = calloc(n * 3, sizeof(float));
    m->light_n = calloc(n, sizeof(uint32_t));
    m->bg = calloc(n * 3, sizeof(float));
    m->bg_n = calloc(n, sizeof(uint32_t));
    m->clean = calloc(n * 3, 1);
    m->occlusion = malloc(n * sizeof(float));
    m->lighting = calloc(n * 3, sizeof(float));
    m->prev_occ = calloc(n, 1);
    m->prev_light = calloc(n, sizeof(float));
    m->span_l = malloc((size_t)height * sizeof(int32_t));
    m->span_r = malloc((size_t)height * sizeof(int32_t));
    m->col_top = malloc((size_t)width * sizeof(int32_t));
    m->span_hidden = malloc(height);
    if (!m->occ1 || !m->occ2 || !m->occ_n || !m->vis1 || !m->vis2 || !m->light || !m->light_n || !m->bg ||
        !m->bg_n || !m->clean || !m->occlusion || !m->lighting || !m->prev_occ || !m->prev_light || !m->span_l || !m->span_r ||
        !m->col_top || !m->span_hidden) {
        maps_close(m);
        return -ENOMEM;
    }
    for (size_t i = 0; i < n; i++) {
        m->occ1[i] = m->occ2[i] = -1;
        m->vis1[i] = m->vis2[i] = INT16_MAX;
        m->occlusion[i] = -1.0f;
    }
    return 0;
}

void maps_close(probe_maps *m)
{
    free(m->occ1);
    free(m->occ2);
    free(m->occ_n);
    free(m->vis1);
    free(m->vis2);
    free(m->light);
    free(m->light_n);
    free(m->bg);
    free(m->bg_n);
    free(m->clean);
    free(m->occlusion);
    free(m->lighting);
    free(m->prev_occ);
    free(m->prev_light);
    free(m->span_l);
    free(m->span_r);
    free(m->col_top);
    free(m->span_hidden);
    memset(m, 0, sizeof(*m));
}

static inline void seen_visible(probe_maps *m, size_t i, int16_t yb)
{
    if (yb < m->vis1[i]) {
        m->vis2[i] = m->vis1[i];
        m->vis1[i] = yb;
    } else if (yb < m->vis2[i]) {
        m->vis2[i] = yb;
    }
}

static inline void seen_hidden(probe_maps *m, size_t i, int16_t yb)
{
    if (yb > m->occ1[i]) {
        m->occ2[i] = m->occ1[i];
        m->occ1[i] = yb;
    } else if (yb > m->occ2[i]) {
        m->occ2[i] = yb;
    }
    if (m->occ_n[i] < UINT16_MAX)
        m->occ_n[i]++;
}

static inline void seen_colour(probe_maps *m, size_t i, const float col[3])
{
    uint32_t n = ++m->light_n[i];
    float inv = 1.0f / (float)n; /* running mean: stable however long the capture */
    for (int c = 0; c < 3; c++)
        m->light[3 * i + c] += (col[c] - m->light[3 * i + c]) * inv;
}

/*
 * The object's silhouette hull: per row the leftmost and rightmost M' pixel;
 * rows with none between rows with some (an occluder across the whole body)
 * take the union of the nearest spans above and below (and are marked). Per
 * column, the first row with an M' pixel (INT32_MAX: none).
 */
static void hull(probe_maps *m, const probe_segment *sg, const probe_object *o)
{
    for (int x = o->x0; x <= o->x1; x++)
        m->col_top[x] = INT32_MAX;
    for (int y = o->y0; y <= o->y1; y++) {
        int l = -1, r = -1;
        for (int x = o->x0; x <= o->x1; x++)
            if (segment_in_mask(sg, o, (uint32_t)x, (uint32_t)y)) {
                l = l < 0 ? x : l;
                r = x;
                m->col_top[x] = m->col_top[x] == INT32_MAX ? y : m->col_top[x];
            }
        m->span_l[y] = l, m->span_r[y] = r;
        m->span_hidden[y] = 0;
    }
    for (int y = o->y0, last = -1; y <= o->y1; y++) {
        if (m->span_l[y] >= 0) {
            last = y;
            continue;
        }
        int next = y + 1;
        while (next <= o->y1 && m->span_l[next] < 0)
            next++;
        if (last < 0 || next > o->y1)
            continue;
        for (int k = y; k < next; k++) {
            m->span_hidden[k] = 1;
            m->span_l[k] = m->span_l[last] < m->span_l[next] ? m->span_l[last] : m->span_l[next];
            m->span_r[k] = m->span_r[last] > m->span_r[next] ? m->span_r[last] : m->span_r[next];
        }
        y = next - 1;
    }
}

/* The widest span over the torso rows (height fractions 0.45 to 0.85); -1 when none. */
static void torso_span(const probe_maps *m, const probe_object *o, int *l, int *r)
{
    *l = *r = -1;
    int y0 = (int)ceil(o->foot_y - 0.85 * o->height), y1 = (int)floor(o->foot_y - 0.45 * o->height);
    for (int y = y0 < o->y0 ? o->y0 : y0; y <= y1 && y <= o->y1; y++) {
        if (m->span_l[y] < 0)
            continue;
        *l = *l < 0 || m->span_l[y] < *l ? m->span_l[y] : *l;
        *r = m->span_r[y] > *r ? m->span_r[y] : *r;
    }
}

/*
 * Visible evidence on M'; occlusion evidence on background-coloured pixels
 * inside the hull: in the upper body (legs leave gaps of their own), in rows
 * hidden across the whole body, or in a column with no M' pixel at all (cut
 * from top to bottom: a pole, not the space between the legs or beside an arm).
 */
void maps_add_object(probe_maps *m, const probe_segment *sg, const probe_object *o)
{
    int ground = !(o->touches & PROBE_TOUCH_BOTTOM); /* a cut-off bottom says nothing about depth */
    int16_t yb = (int16_t)o->foot_y;
    int upper_last = (int)floor(o->foot_y - 0.45 * o->height);
    float col[3] = { (float)o->mean_rgb[0], (float)o->mean_rgb[1], (float)o->mean_rgb[2] };
    hull(m, sg, o);
    int tl, tr;
    torso_span(m, o, &tl, &tr);
    for (int y = o->y0; y <= o->y1; y++) {
        int l = m->span_l[y], r = m->span_r[y];
        if (y > upper_last && tl >= 0) { /* below the torso, columns cut from the top down may widen the span */
            l = l < 0 || tl < l ? tl : l;
            r = tr > r ? tr : r;
        }
        if (l < 0)
            continue;
        size_t row = (size_t)y * m->width;
        for (int x = l; x <= r; x++) {
            size_t i = row + (size_t)x;
            if (segment_in_mask(sg, o, (uint32_t)x, (uint32_t)y)) {
                seen_colour(m, i, col);
                if (ground)
                    seen_visible(m, i, yb);
            } else if (ground && sg->cls[i] == PROBE_CLS_BG &&
                       (y <= upper_last || m->span_hidden[y] || m->col_top[x] == INT32_MAX)) {
                seen_hidden(m, i, yb);
            }
        }
    }
    for (int c = 0; c < 3; c++)
        m->light_ref[c] += o->mean_rgb[c] * o->area;
    m->light_ref_w += o->area;
}

void maps_add_background(probe_maps *m, const uint8_t *plate, const uint8_t *cls)
{
    size_t n = (size_t)m->width * m->height;
    for (size_t i = 0; i < n; i++) {
        if (cls[i] != PROBE_CLS_BG)
            continue;
        uint32_t k = ++m->bg_n[i];
        float inv = 1.0f / (float)k;
        for (int c = 0; c < 3; c++)
            m->bg[3 * i + c] += ((float)plate[3 * i + c] - m->bg[3 * i + c]) * inv;
    }
}

float maps_occlusion_at(const probe_maps *m, size_t i)
{
    if (m->occ_n[i] < m->min_events || m->occ2[i] < 0)
        return -1.0f;
    if (m->vis2[i] < m->occ2[i]) /* two objects farther than the occluder were seen right there */
        return -1.0f;
    return (float)m->occ2[i];
}

static void reference_colour(const probe_maps *m, double ref[3])
{
    for (int c = 0; c < 3; c++) {
        double v = m->light_ref_w > 0 ? m->light_ref[c] / m->light_ref_w : 0;
        ref[c] = v > 1.0 ? v : 1.0; /* a black reference would blow the ratios up */
    }
}

void maps_finalise(probe_maps *m, const uint8_t *fallback_plate)
{
    size_t n = (size_t)m->width * m->height;
    double ref[3];
    reference_colour(m, ref);
    for (size_t i = 0; i < n; i++) {
        for (int c = 0; c < 3; c++) {
            float v = m->bg_n[i] ? m->bg[3 * i + c] : (float)fallback_plate[3 * i + c];
            m->clean[3 * i + c] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : lrintf(v));
            m->lighting[3 * i + c] = m->light_n[i] ? (float)((double)m->light[3 * i + c] / ref[c]) : 0.0f;
        }
        m->occlusion[i] = maps_occlusion_at(m, i);
    }
    if (getenv("SP_PROBE_DEBUG")) {
        size_t e1 = 0, e3 = 0, veto = 0;
        for (size_t i = 0; i < n; i++) {
            e1 += m->occ_n[i] >= 1;
            e3 += m->occ_n[i] >= m->min_events;
            veto += m->occ_n[i] >= m->min_events && m->occ2[i] >= 0 && m->vis2[i] < m->occ2[i];
        }
        fprintf(stderr, "DEBUG events>=1 %zu >=min %zu vetoed %zu\n", e1, e3, veto);
        unsigned dx, dy;
        if (sscanf(getenv("SP_PROBE_DEBUG"), "%u,%u", &dx, &dy) == 2 && dx < m->width && dy < m->height) {
            size_t i = (size_t)dy * m->width + dx;
            fprintf(stderr, "DEBUG (%u,%u): occ %d %d n %u vis %d %d\n", dx, dy, m->occ1[i], m->occ2[i], m->occ_n[i],
                    m->vis1[i], m->vis2[i]);
        }
    }
}

static float relative_luma(const probe_maps *m, size_t i, const double ref[3])
{
    const float *l = m->light + 3 * i;
    double y = 0.299 * (double)l[0] + 0.587 * (double)l[1] + 0.114 * (double)l[2];
    double yr = 0.299 * ref[0] + 0.587 * ref[1] + 0.114 * ref[2];
    return (float)(y / yr);
}

void maps_checkpoint(probe_maps *m, double out[4])
{
    size_t n = (size_t)m->width * m->height, flips = 0, covered = 0, occluding = 0, both = 0;
    double ref[3], dl = 0;
    reference_colour(m, ref);
    for (size_t i = 0; i < n; i++) {
        uint8_t occ = maps_occlusion_at(m, i) >= 0;
        flips += occ != m->prev_occ[i];
        occluding += occ;
        m->prev_occ[i] = occ;
        if (!m->light_n[i])
            continue;
        covered++;
        float l = relative_luma(m, i, ref);
        if (m->prev_light[i] > 0) {
            dl += fabs((double)l - (double)m->prev_light[i]);
            both++;
        }
        m->prev_light[i] = l;
    }
    double total = n ? (double)n : 1.0;
    out[0] = (double)flips / total;
    out[1] = both ? dl / (double)both : (double)NAN;
    out[2] = (double)covered / total;
    out[3] = (double)occluding / total;
}
