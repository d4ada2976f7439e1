/* SPDX-License-Identifier: MIT */
/*
 * The orientation tagger (sp_tagger.h): frames wait in a ring, in arrival order,
 * until the filter can answer for their time and their side data has come.
 */
#include "sunprobe/sp_tagger.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_meta.h"

#define MOD "tagger"

typedef struct waiting {
    sp_frame *frame; /* the inner source's reference, handed on with the frame */
    int64_t t;
    int no_imu;      /* no IMU sample had come when the frame did */
    sp_frame_tags tags;
} waiting;

typedef struct tagger {
    sp_tagger_settings set;
    sp_source *inner;
    sp_capture_meta meta;
    int have_meta;
    sp_orientation *filter;
    waiting *ring;
    size_t head, count;
    int eos;
    sp_frame_tags out_tags; /* tags of the frame handed on last: valid until the next call */
    sp_tagger_stats stats;
} tagger;

static waiting *at(tagger *g, size_t i)
{
    return &g->ring[(g->head + i) % g->set.max_waiting];
}

static int open_filter(tagger *g)
{
    sp_orientation_settings os;
    sp_orientation_default_settings(&os);
    if (g->have_meta) {
        os.imu_to_camera = g->meta.imu_to_camera;
        os.time_offset_s = isfinite(g->meta.imu_time_offset_s) ? g->meta.imu_time_offset_s : 0.0;
    } else {
        sp_log(SP_LOG_WARN, MOD, "IMU samples before any metadata: imu.to_camera taken as identity");
    }
    int ret = sp_orientation_open(&g->filter, &os);
    g->stats.have_filter = ret == 0;
    return ret;
}

static void on_meta(tagger *g, const sp_event *ev)
{
    if (!ev->meta)
        return;
    if (g->filter && memcmp(&ev->meta->imu_to_camera, &g->meta.imu_to_camera, sizeof(sp_quat)) != 0)
        sp_log(SP_LOG_WARN, MOD, "metadata after the first IMU sample changes imu.to_camera; kept the first");
    g->meta = *ev->meta;
    g->have_meta = 1;
}

/* Attaches side data to the waiting frame it names; 0 when none waits (the event is handed on). */
static int attach_side(tagger *g, const sp_event *ev)
{
    const float *v = ev->side_values;
    int lm = ev->side_kind == SP_SIDE_LANDMARKS_2D && ev->side_count == 136;
    int truth = ev->side_kind == SP_SIDE_TRUE_ORIENTATION && ev->side_count == 4;
    if (!v || (!lm && !truth))
        return 0;
    for (size_t i = 0; i < g->count; i++) {
        waiting *w = at(g, i);
        if (w->frame->sequence != ev->side_sequence)
            continue;
        if (truth) {
            w->tags.true_camera_to_world = sp_quat_normalize((sp_quat){ v[0], v[1], v[2], v[3] });
            w->tags.has_true_orientation = 1;
        } else {
            int finite = 1;
            for (int k = 0; k < 136; k++)
                finite &= isfinite(v[k]) != 0;
            memcpy(w->tags.landmarks, v, sizeof(w->tags.landmarks));
            w->tags.has_landmarks = finite; /* a set with a NaN counts as none */
        }
        g->stats.side_attached++;
        return 1;
    }
    return 0;
}

/* Orientation of a waiting frame; 1 when it must wait longer (unless forced). */
static int resolve(tagger *g, waiting *w, int force)
{
    if (g->set.orientation_for) {
        int ret = g->set.orientation_for(g->set.orientation_user, w->frame->sequence, w->t, &w->tags.camera_to_world);
        w->tags.orientation = ret == 0 ? SP_ORIENTATION_OK : SP_ORIENTATION_NOT_COVERED;
        return 0;
    }
    if (w->no_imu) {
        w->tags.orientation = SP_ORIENTATION_NO_IMU;
        return 0;
    }
    int ret = sp_orientation_camera_at(g->filter, w->t, &w->tags.camera_to_world);
    if (ret == -EAGAIN && !force)
        return 1;
    w->tags.orientation = ret == 0 ? SP_ORIENTATION_OK : SP_ORIENTATION_NOT_COVERED;
    sp_orientation_stats st;
    w->tags.heading_magnetic = ret == 0 && !sp_orientation_get_stats(g->filter, &st) && st.using_magnetometer;
    return 0;
}

/* The oldest frame may go on: its side data has come (a newer frame did) and its orientation is known. */
static int head_ready(tagger *g, int force)
{
    if (!force && g->count < 2)
        return 0;
    return resolve(g, at(g, 0), force) == 0;
}

static void hand_on(tagger *g, sp_event *ev)
{
    waiting *w = at(g, 0);
    memset(ev, 0, sizeof(*ev));
    ev->type = SP_EVENT_FRAME;
    ev->timestamp_ns = w->t;
    ev->frame = w->frame; /* the reference moves to the receiver */
    g->out_tags = w->tags;
    g->out_tags.thinned = g->stats.thinned;
    ev->tags = &g->out_tags;
    w->frame = NULL;
    g->head = (g->head + 1) % g->set.max_waiting;
    g->count--;
    g->stats.frames++;
    g->stats.oriented += g->out_tags.orientation == SP_ORIENTATION_OK;
    g->stats.no_imu += g->out_tags.orientation == SP_ORIENTATION_NO_IMU;
    g->stats.not_covered += g->out_tags.orientation == SP_ORIENTATION_NOT_COVERED;
}

static int initialising(const tagger *g)
{
    sp_orientation_stats st;
    return g->filter && sp_orientation_get_stats(g->filter, &st) == 0 && !st.initialized;
}

/* Ring full while the filter initialises: drops the later of the two frames closest in time. */
static void thin(tagger *g)
{
    size_t drop = 1;
    int64_t best = INT64_MAX;
    for (size_t i = 1; i < g->count; i++) {
        int64_t gap = at(g, i)->t - at(g, i - 1)->t;
        if (gap < best) {
            best = gap;
            drop = i;
        }
    }
    sp_frame_unref(&at(g, drop)->frame);
    for (size_t i = drop; i + 1 < g->count; i++)
        *at(g, i) = *at(g, i + 1);
    g->count--;
    g->stats.thinned++;
}

static int take_frame(tagger *g, sp_event *in)
{
    waiting *w = at(g, g->count);
    memset(w, 0, sizeof(*w));
    w->frame = in->frame;
    in->frame = NULL;
    w->t = in->timestamp_ns;
    w->no_imu = g->filter == NULL;
    g->count++;
    return 0;
}

/* Handles one inner event: 1 when it goes on as it is, 0 when the tagger consumed it, or an error. */
static int take(tagger *g, sp_event *in)
{
    switch (in->type) {
    case SP_EVENT_META:
        on_meta(g, in);
        return 1;
    case SP_EVENT_IMU: {
        if (g->set.orientation_for) { /* orientation comes from elsewhere: the samples only pass */
            g->stats.imu_samples++;
            return 1;
        }
        int ret = g->filter ? 0 : open_filter(g);
        if (ret)
            return ret;
        g->stats.imu_samples++;
        sp_orientation_push(g->filter, &in->imu); /* drops are counted in the filter's stats */
        return 1;
    }
    case SP_EVENT_SIDE:
        return !attach_side(g, in);
    case SP_EVENT_FRAME:
        if (!in->frame)
            return 1;
        return take_frame(g, in);
    }
    return 1;
}

static int tagger_next(void *ctx, sp_event *ev)
{
    tagger *g = ctx;
    for (;;) {
        if (g->count && head_ready(g, g->eos)) {
            hand_on(g, ev);
            return 0;
        }
        if (g->eos)
            return SP_EOS;
        if (g->count == g->set.max_waiting) {
            if (initialising(g)) {
                thin(g);
            } else {
                resolve(g, at(g, 0), 1);
                hand_on(g, ev);
                return 0;
            }
            continue;
        }
        sp_event in;
        int ret = sp_source_next(g->inner, &in);
        if (ret == SP_EOS) {
            g->eos = 1;
            continue;
        }
        if (ret)
            return ret; /* -EAGAIN from a live device passes on */
        if ((ret = take(g, &in)) == 1) {
            *ev = in;
            return 0;
        }
        sp_event_release(&in);
        if (ret < 0)
            return ret;
    }
}

static void tagger_close(void *ctx)
{
    tagger *g = ctx;
    if (!g)
        return;
    while (g->count) {
        sp_frame_unref(&at(g, 0)->frame);
        g->head = (g->head + 1) % g->set.max_waiting;
        g->count--;
    }
    sp_orientation_close(&g->filter);
    free(g->ring);
    free(g);
}

static const sp_source_ops tagger_ops = {
    .name = "tagger",
    .next = tagger_next,
    .close = tagger_close,
};

void sp_tagger_default_settings(sp_tagger_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->max_waiting = 32;
}

int sp_tagger_open(sp_source **out, sp_source *inner, const sp_tagger_settings *s)
{
    if (!out || !inner)
        return -EINVAL;
    *out = NULL;
    sp_tagger_settings defaults;
    if (!s) {
        sp_tagger_default_settings(&defaults);
        s = &defaults;
    }
    if (s->max_waiting < 2 || s->max_waiting > 1024)
        return -EINVAL;
    tagger *g = calloc(1, sizeof(*g));
    if (!g)
        return -ENOMEM;
    g->set = *s;
    g->inner = inner;
    sp_capture_meta_init(&g->meta);
    g->ring = calloc(s->max_waiting, sizeof(*g->ring));
    int ret = g->ring ? sp_source_create(out, &tagger_ops, g) : -ENOMEM;
    if (ret)
        tagger_close(g);
    return ret;
}

int sp_tagger_get_stats(const sp_source *src, sp_tagger_stats *out)
{
    if (!src || !out || src->ops != &tagger_ops)
        return -EINVAL;
    const tagger *g = src->ctx;
    *out = g->stats;
    if (g->filter)
        sp_orientation_get_stats(g->filter, &out->filter);
    return 0;
}
