/* SPDX-License-Identifier: MIT */
/*
 * A small tracker that remembers what each person looked like when fully
 * visible. Objects are matched frame to frame by the predicted foot point (or
 * the top of the head when the feet are hidden); a complete view refreshes the
 * track's silhouette template, a partial one (the person shrank: part of them
 * is behind something) is completed by laying the template at the predicted
 * position. Template pixels that now show the plate were hidden by something
 * static: occlusion evidence the hull alone cannot give (a head behind a pole,
 * the end of a sign). A body cut on the way in, then not seen where the
 * template lies, then cut on the way out went wholly behind something wider
 * than itself (maps_add_passage). Bounded: PROBE_MAX_TRACKS templates of
 * fixed size.
 */
#include "probe_internal.h"

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#define MAX_MISSING 8      /* frames a track survives unseen */
#define MATCH_X 0.35       /* of the height */
#define MATCH_Y 0.12
#define COMPLETE_H 0.08    /* a complete view: height within this of the template's, and ... */
#define COMPLETE_AREA 0.85 /* ... at least this much of its area */
#define HIDDEN_SHOWING 0.02 /* an unseen frame hid the body when at most this share of the template shows an object */

int tracks_open(probe_tracks *t)
{
    memset(t, 0, sizeof(*t));
    t->track = calloc(PROBE_MAX_TRACKS, sizeof(*t->track));
    return t->track ? 0 : -ENOMEM;
}

void tracks_close(probe_tracks *t)
{
    free(t->track);
    t->track = NULL;
}

static void take_template(probe_track *k, const probe_segment *sg, const probe_object *o)
{
    int fx = (int)lrint(o->foot_x), fy = (int)o->foot_y;
    int th = (int)o->height, tw = o->x1 - o->x0 + 1;
    k->has_template = th <= PROBE_TMPL_H && tw <= PROBE_TMPL_W && fx >= o->x0 && fx <= o->x1;
    if (!k->has_template)
        return;
    k->th = th, k->tw = tw, k->ax = fx - o->x0;
    k->area = 0;
    for (int ty = 0; ty < th; ty++)
        for (int tx = 0; tx < tw; tx++) {
            int x = o->x0 + tx, y = fy - th + 1 + ty;
            uint8_t on = y >= 0 && segment_in_mask(sg, o, (uint32_t)x, (uint32_t)y);
            k->mask[ty * PROBE_TMPL_W + tx] = on;
            k->area += on;
        }
    k->height = o->height;
}

/* Match cost of object o to track k (lower is better), or INFINITY; sets *by_top when only the head matches. */
static double match_cost(const probe_track *k, const probe_object *o, uint64_t frame, int *by_top)
{
    double dt = (double)(frame - k->last_frame);
    double px = k->fx + k->vx * dt, py = k->fy + k->vy * dt, h = k->height;
    double dx = fabs(o->foot_x - px), dfoot = fabs(o->foot_y - py), dtop = fabs(o->y0 - (py - h + 1));
    if (!(h > 0) || dx > MATCH_X * h)
        return (double)INFINITY;
    *by_top = dfoot > MATCH_Y * h;
    if (*by_top && dtop > MATCH_Y * h)
        return (double)INFINITY;
    return (dx + fmin(dfoot, dtop)) / h;
}

/* A dead or expired slot, else the longest unseen one not matched in this frame; NULL when all are. */
static probe_track *free_slot(probe_tracks *t, uint64_t frame)
{
    probe_track *oldest = NULL;
    for (unsigned i = 0; i < PROBE_MAX_TRACKS; i++) {
        probe_track *k = &t->track[i];
        if (!k->alive || frame - k->last_frame > MAX_MISSING)
            return k;
        if (k->last_frame < frame && (!oldest || k->last_frame < oldest->last_frame))
            oldest = k;
    }
    return oldest;
}

/* A template must be one whole person: person-shaped, and as tall as the scale model expects (when known). */
static int template_worthy(const probe_object *o, const sp_probe_plane *plane)
{
    double expect = sp_probe_plane_height(plane, o->foot_x, o->foot_y);
    return o->person && !o->touches && (!isfinite(expect) || fabs(o->height - expect) <= 0.15 * expect);
}

static probe_track *start_track(probe_tracks *t, const probe_segment *sg, const probe_object *o, uint64_t frame,
                                const sp_probe_plane *plane)
{
    probe_track *k = free_slot(t, frame);
    if (!k)
        return NULL;
    memset(k, 0, offsetof(probe_track, mask)); /* the template is rewritten before it is read */
    k->alive = 1;
    k->last_frame = frame;
    k->fx = o->foot_x, k->fy = o->foot_y;
    k->height = o->height;
    if (template_worthy(o, plane))
        take_template(k, sg, o);
    return k;
}

/*
 * Updates track k with its object; fills the completion (anchor of the
 * template) when the view is partial and a template exists.
 */
static void follow(probe_track *k, const probe_segment *sg, const probe_object *o, uint64_t frame, int by_top,
                   const sp_probe_plane *plane, probe_completion *c)
{
    double dt = (double)(frame - k->last_frame);
    double px = k->fx + k->vx * dt;
    int complete = !by_top && o->person && fabs(o->height - k->height) <= COMPLETE_H * k->height &&
                   o->area >= COMPLETE_AREA * k->area;
    double nx = o->foot_x, ny = o->foot_y;
    c->track = NULL;
    if (!complete && k->has_template) {
        nx = px; /* the visible part's middle is not the body's */
        ny = by_top ? o->y0 + k->height - 1 : o->foot_y;
        c->track = k;
        c->x = (int)lrint(nx), c->y = (int)lrint(ny);
        /*
         * Cut on entering, gone, cut on leaving: the body went wholly behind something on the way
         * (a cabinet, a van). A lost segmentation does not cut the view on both sides of the gap.
         */
        if (dt > 1 && k->last_partial && k->unseen_hidden) {
            c->pass_x0 = k->fx, c->pass_y0 = k->fy, c->pass_x1 = nx, c->pass_y1 = ny;
            c->pass_frames = (unsigned)dt;
            c->pass_hidden = k->unseen_hidden;
        }
    }
    k->unseen_hidden = 0;
    k->last_partial = !complete;
    k->travel += hypot(nx - k->fx, ny - k->fy);
    k->vx = 0.6 * k->vx + 0.4 * (nx - k->fx) / dt;
    k->vy = 0.6 * k->vy + 0.4 * (ny - k->fy) / dt;
    k->fx = nx, k->fy = ny;
    k->last_frame = frame;
    if (complete || !k->has_template) {
        if (template_worthy(o, plane))
            take_template(k, sg, o);
        else
            k->height = o->height;
    }
}

/* No object pixel shows where track k's template lies at its predicted foot point in this frame. */
static int wholly_hidden(const probe_track *k, const probe_segment *sg, uint64_t frame)
{
    double dt = (double)(frame - k->last_frame);
    int x0 = (int)lrint(k->fx + k->vx * dt) - k->ax, y0 = (int)lrint(k->fy + k->vy * dt) - k->th + 1;
    if (x0 < 0 || y0 < 0 || x0 + k->tw > (int)sg->width || y0 + k->th > (int)sg->height)
        return 0; /* leaving the view is not hiding */
    uint32_t showing = 0;
    for (int ty = 0; ty < k->th; ty++)
        for (int tx = 0; tx < k->tw; tx++)
            showing += k->mask[ty * PROBE_TMPL_W + tx] &&
                sg->cls[(size_t)(y0 + ty) * sg->width + (size_t)(x0 + tx)] == PROBE_CLS_OBJECT;
    return showing <= HIDDEN_SHOWING * k->area;
}

void tracks_update(probe_tracks *t, const probe_segment *sg, uint64_t frame, const sp_probe_plane *plane,
                   probe_completion *out)
{
    uint8_t taken[PROBE_MAX_TRACKS] = { 0 };
    for (unsigned i = 0; i < sg->n_obj; i++) {
        const probe_object *o = &sg->obj[i];
        out[i].track = out[i].owner = NULL;
        out[i].pass_frames = 0;
        if (o->touches & PROBE_TOUCH_BOTTOM)
            continue;
        double best = (double)INFINITY;
        int best_k = -1, best_top = 0;
        for (unsigned k = 0; k < PROBE_MAX_TRACKS; k++) {
            const probe_track *tk = &t->track[k];
            int by_top = 0;
            if (!tk->alive || taken[k] || tk->last_frame >= frame || frame - tk->last_frame > MAX_MISSING)
                continue;
            double c = match_cost(tk, o, frame, &by_top);
            if (c < best) {
                best = c, best_k = (int)k, best_top = by_top;
            }
        }
        if (best_k < 0) {
            out[i].owner = start_track(t, sg, o, frame, plane);
            continue;
        }
        taken[best_k] = 1;
        follow(&t->track[best_k], sg, o, frame, best_top, plane, &out[i]);
        out[i].owner = &t->track[best_k];
    }
    for (unsigned k = 0; k < PROBE_MAX_TRACKS; k++) {
        probe_track *tk = &t->track[k];
        if (tk->alive && tk->has_template && tk->last_partial && tk->last_frame < frame &&
            frame - tk->last_frame <= MAX_MISSING && wholly_hidden(tk, sg, frame))
            tk->unseen_hidden |= (uint16_t)(1u << (frame - tk->last_frame - 1));
    }
}
