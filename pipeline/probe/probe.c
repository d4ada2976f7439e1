/* SPDX-License-Identifier: MIT */
/*
 * The scene probe: frames in, one at a time; the clean plate, segmentation,
 * maps and observation reservoirs are updated per frame; the models are
 * fitted at checkpoints (for the convergence report) and at the end.
 * Everything is allocated at open (PROBE.md gives the bound).
 */
#include "probe_internal.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/clock.h"
#include "common/pixconv.h"
#include "common/report.h"
#include "repopulate.h"
#include "sp_config.h"
#if HAVE_OPENCV
#include "opencv_probe_shim.h"
#endif

#define PERSON_REC 3     /* x, y, h */
/* a car's height against a person's: scales a scene where only cars were seen (PROBE.md, Object classes) */
#define CAR_HEIGHT_M 1.5
#define PERSON_HEIGHT_M SP_REPOP_PERSON_HEIGHT_M /* the scale model's person, which cut-outs are measured against */
#define RECENT_MAX 1024  /* observations between checkpoints scored before they join the fit */
#define N_SERIES 8
#define REPEAT_MOVE 0.015 /* of the height: closer to the last counted foot point, a person's view repeats */
#define STILL_FRAMES 10   /* a person still for this many frames feeds the maps once in this many */

struct sp_probe {
    sp_probe_settings s;
    uint32_t width, height;
    probe_plate plate;
    probe_segment seg;
    probe_maps maps;
    probe_shadows shadows;
    probe_tracks tracks;
    probe_motion motion;
    probe_completion completion[PROBE_MAX_OBJECTS];
    uint8_t *hold, *hold_prev; /* seg.gw * seg.gh: cells the next plate sample keeps (see plate_offer) */
    uint64_t hold_frame;     /* st.frames of the frame after the one that set hold (0: none) */
    sp_probe_class cls[PROBE_MAX_OBJECTS]; /* of the last frame's objects */
    unsigned n_cls;
    probe_reservoir people, holdout, cars; /* cars: heights scaled to a person's, for a car-only scene */
    float *recent;
    unsigned n_recent;
    uint8_t *rgb;            /* the last frame, packed RGB24 */
    int segmented;           /* the last frame was segmented against a ready plate */
    sp_probe_truth_sample *truth;
    sp_report *report;
    int64_t start_ns, last_ts;
    sp_probe_plane plane;    /* the latest fit */
    sp_probe_shadow shadow;
    sp_probe_stats st;
    uint64_t rng;
    int finished;
    void *hog;
    char message[320];
};

void sp_probe_default_settings(sp_probe_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->window_s = 4.0;
    s->window_samples = 15;
    s->settle_s = 120.0; /* PROBE.md, "People who stop" */
    s->fg_threshold = 50;
    s->shadow_min_ratio = 0.3;
    s->shadow_max_ratio = 0.85;
    s->shadow_chroma_tol = 0.035;
    s->block = 4;
    s->min_object_px = 0; /* automatic: width * height / 4000, at least 16 */
    s->detector = SP_PROBE_DETECT_SHAPE;
    s->min_occlusion_events = 1;
    s->holdout_from = -1;
    s->max_observations = 4096;
    s->checkpoint_frames = 25;
    s->max_foreground = 0.5;
    s->seed = 1;
}

static int check_settings(const sp_probe_settings *s, uint32_t width, uint32_t height)
{
    if (width < 16 || height < 16 || width > 16384 || height > 16384)
        return -EINVAL; /* rows are stored as int16 */
    if (!(s->window_s > 0 && s->window_s <= 3600) || !(s->settle_s >= 0 && s->settle_s <= 36000) ||
        s->window_samples < 3 ||
        s->window_samples > PROBE_MAX_WIRES || s->window_samples % 2 == 0)
        return -EINVAL;
    if (s->fg_threshold < 1 || s->fg_threshold > 765 || s->block < 2 || s->block > 15)
        return -EINVAL;
    if (!(s->shadow_min_ratio >= 0 && s->shadow_min_ratio < s->shadow_max_ratio && s->shadow_max_ratio <= 1.0) ||
        !(s->shadow_chroma_tol >= 0 && s->shadow_chroma_tol <= 3.0))
        return -EINVAL;
    if (s->max_observations < 16 || s->max_observations > (1u << 24) || s->checkpoint_frames < 1 ||
        !(s->max_foreground > 0 && s->max_foreground <= 1.0))
        return -EINVAL;
    if (s->detector != SP_PROBE_DETECT_SHAPE && s->detector != SP_PROBE_DETECT_HOG)
        return -EINVAL;
    if (s->n_truth && !s->truth)
        return -EINVAL;
    return 0;
}

/* What open allocates (PROBE.md, "Memory bound"); it never grows afterwards. */
static size_t memory_bound(uint32_t w, uint32_t h, const sp_probe_settings *s)
{
    size_t px = (size_t)w * h, cells = ((size_t)w / s->block + 1) * ((size_t)h / s->block + 1);
    size_t per_px = 3 * (size_t)s->window_samples + 3 /* plate */ + 2 /* held */ + 3 /* frame */ + 3 /* denoised */ +
        1 /* classes */ + 4 * PROBE_EVIDENCE * 2 /* occlusion slots */ + 16 /* lighting */ + 16 /* long-term plate */ +
        3 + 4 + 4 + 12 /* final maps */ + 5 /* checkpoint */ + 5 /* occluder groups */;
    return px * per_px + px / 8 /* motion thumbnails */ + cells * 32 + PROBE_MAX_TRACKS * sizeof(probe_track) +
        (size_t)s->max_observations * 4 * (3 * PERSON_REC + 4) + RECENT_MAX * PERSON_REC * 4 +
        sizeof(probe_shadows) /* its ratio and contact histograms */ + (size_t)h * 4 /* a group's depths */ +
        (size_t)h * 8 + (size_t)w * 20 /* segmentation's row and column scratch */;
}

static int open_report(sp_probe *p)
{
    /* each with its unit: the plot gives every quantity its own panel and axis */
    static const char *const names[N_SERIES] = {
        "occlusion_change [share of pixels flipped since the last checkpoint]",
        "lighting_change [mean |change| of relative luma]",
        "coverage [share of pixels any object covered]",
        "occluders [share of pixels marked occluding]",
        "plane_heldout_err [median relative height error, new observations]",
        "plane_change [relative change of the height model]",
        "plane_truth_err [median relative height error against the truth]",
        "shadow_truth_deg [mean shadow direction error, degrees]",
    };
    if (!p->s.report_prefix)
        return 0;
    return sp_report_open(&p->report, p->s.report_prefix, "scene probe: convergence against run time", names,
                          N_SERIES, 1);
}

static int open_parts(sp_probe *p)
{
    const sp_probe_settings *s = &p->s;
    int ret = plate_open(&p->plate, p->width, p->height, s->window_samples, (int64_t)(s->window_s * 1e9),
                         (int64_t)(s->settle_s * 1e9));
    if (!ret)
        ret = segment_open(&p->seg, p->width, p->height, s);
    if (!ret && (!(p->hold = calloc((size_t)p->seg.gw * p->seg.gh, 1)) ||
                 !(p->hold_prev = calloc((size_t)p->seg.gw * p->seg.gh, 1))))
        ret = -ENOMEM;
    if (!ret)
        ret = maps_open(&p->maps, p->width, p->height, s->min_occlusion_events);
    if (!ret)
        ret = shadows_open(&p->shadows, s->max_observations, s->seed);
    if (!ret)
        ret = tracks_open(&p->tracks);
    if (!ret)
        ret = motion_open(&p->motion, p->width, p->height);
    if (!ret)
        ret = reservoir_open(&p->people, s->max_observations, PERSON_REC, s->seed);
    if (!ret)
        ret = reservoir_open(&p->holdout, s->max_observations, PERSON_REC, s->seed + 1);
    if (!ret)
        ret = reservoir_open(&p->cars, s->max_observations, PERSON_REC, s->seed + 2);
    if (!ret) {
        p->recent = malloc(RECENT_MAX * PERSON_REC * sizeof(float));
        p->rgb = calloc((size_t)p->width * p->height, 3);
        ret = p->recent && p->rgb ? 0 : -ENOMEM;
    }
    if (!ret && s->n_truth) {
        p->truth = malloc(s->n_truth * sizeof(*p->truth));
        if (p->truth)
            memcpy(p->truth, s->truth, s->n_truth * sizeof(*p->truth));
        ret = p->truth ? 0 : -ENOMEM;
    }
    p->s.truth = p->truth; /* our copy: the caller's array need not outlive open */
    return ret ? ret : open_report(p);
}

int sp_probe_open(sp_probe **out, uint32_t width, uint32_t height, const sp_probe_settings *s)
{
    if (!out || !s)
        return -EINVAL;
    *out = NULL;
    int ret = check_settings(s, width, height);
    if (ret)
        return ret;
#if !HAVE_OPENCV
    if (s->detector == SP_PROBE_DETECT_HOG) {
        sp_log(SP_LOG_ERROR, "probe", "the HOG people detector needs OpenCV: build with -Dopencv=enabled");
        return SP_EDISABLED;
    }
#endif
    sp_probe *p = calloc(1, sizeof(*p));
    if (!p)
        return -ENOMEM;
    p->s = *s;
    if (!p->s.min_object_px) {
        size_t autopx = (size_t)width * height / 4000;
        p->s.min_object_px = autopx > 16 ? (unsigned)autopx : 16;
    }
    p->width = width;
    p->height = height;
    p->rng = s->seed * 0x9E3779B97F4A7C15ull + 7;
    p->last_ts = INT64_MIN;
    p->plane.status = SP_PROBE_PLANE_NONE;
    p->plane.holdout_error_rel = (double)NAN;
    p->start_ns = sp_clock_monotonic_ns();
    p->st.memory_bytes = memory_bound(width, height, s);
    ret = open_parts(p); /* after the automatic settings are filled in */
    if (ret) {
        sp_probe_close(&p);
        return ret;
    }
    snprintf(p->message, sizeof(p->message), "no frames yet");
    *out = p;
    return 0;
}

void sp_probe_close(sp_probe **pp)
{
    if (!pp || !*pp)
        return;
    sp_probe *p = *pp;
    sp_report_abort(&p->report); /* still open: the probe did not finish */
    plate_close(&p->plate);
    segment_close(&p->seg);
    maps_close(&p->maps);
    shadows_close(&p->shadows);
    tracks_close(&p->tracks);
    motion_close(&p->motion);
    reservoir_close(&p->people);
    reservoir_close(&p->holdout);
    reservoir_close(&p->cars);
    probe_hog_close(&p->hog);
    free(p->recent);
    free(p->hold);
    free(p->hold_prev);
    free(p->rgb);
    free(p->truth);
    free(p);
    *pp = NULL;
}

/* ---- per frame ---- */

static int is_person(sp_probe *p, const probe_object *o)
{
    if (!o->person || p->s.detector != SP_PROBE_DETECT_HOG)
        return o->person;
    int yes = 0;
    p->st.hog_checked++;
    if (probe_hog_person(&p->hog, p->rgb, p->width, p->height, o, &yes))
        return 0;
    p->st.hog_confirmed += (uint64_t)yes;
    return yes;
}

/*
 * A car (or another vehicle) seen from the street, judged on its core rows (segment.c: a walker merged
 * behind it adds a narrow column on top) and the span h from the core's top down to the ground. Under the
 * core at most CAR_UNDER of h: a car's wheels and the clearance under its body are about a fifth of its
 * height, 0.2-0.4 of h (the core of a side view is its body and the cabin's lower half), while the core of
 * a group of people is their torsos, over legs that are 0.47 of a person's height, 0.57 of h. Wider than
 * tall (a side view about 0.3, a front or back view 0.8 of its width) and solid: its core, holes closed
 * (segment.c), fills CAR_FILL of the core's box (people side by side leave gaps no column closes). The
 * roof (the first row a quarter as wide as the widest) lies within CAR_ROOF times h of the ground: a cabin
 * sits on the body, while a walker with a wide stride or shadow under the torso has the head far above
 * that core. Where the scale model is known it is vehicle-sized: h 0.3 to 2.2 of a
 * person's height standing there (about 1.2 m of a 1.5 m car's side view; a van or bus up to about
 * 3.5 m) and at least 0.8 of a person's height wide (a car is 1.7 m across from the front, over 3.5 m long
 * from the side; a dog or a bag is not). Not by speed: a car crosses the view in a few frames, too fast
 * for the person tracker.
 */
#define CAR_UNDER 0.45
#define CAR_FILL 0.65
#define CAR_ROOF 2.0
/* The shape and size tests with the object standing on row `foot` at column x (its foot point's, or for a car
 * behind a walker the middle of its box: the walker's feet are not the car's); need_scale: no scale model, no car. */
static int car_shaped_at(const sp_probe *p, const probe_object *o, double x, double foot, int need_scale)
{
    double w = o->x1 - o->x0 + 1, core = o->core_y1 - o->core_y0 + 1, h = foot - o->core_y0 + 1;
    double fill = o->core_area / (w * core);
    if (o->core_y0 < 0 || foot - o->core_y1 > CAR_UNDER * h || h < 8 || h > 0.8 * w || fill < CAR_FILL ||
        foot - o->roof_y + 1 > CAR_ROOF * h)
        return 0;
    double expect = sp_probe_plane_height(&p->plane, x, foot);
    if (!isfinite(expect) || expect <= 0)
        return !need_scale;
    return h >= 0.3 * expect && h <= 2.2 * expect && w >= 0.8 * expect;
}

static int car_shaped(const sp_probe *p, const probe_object *o)
{
    return car_shaped_at(p, o, o->foot_x, o->foot_y, 0);
}

/*
 * A car with a walker in front of it: the walker's legs hang below the car's core, further than a car's
 * wheels do. Judged standing on its core's last row, where the scale model is known (it is what tells a
 * car's width from a person's).
 */
static int car_behind_walker(const sp_probe *p, const probe_object *o)
{
    return o->core_y1 < o->foot_y && car_shaped_at(p, o, 0.5 * (o->x0 + o->x1), o->core_y1, 1);
}

static void observe_person(sp_probe *p, const probe_object *o)
{
    float rec[PERSON_REC] = { (float)o->foot_x, (float)o->foot_y, (float)o->height };
    p->st.people++;
    if (p->s.holdout_from >= 0 && p->st.frames - 1 >= (uint64_t)p->s.holdout_from) {
        reservoir_add(&p->holdout, rec);
        return;
    }
    reservoir_add(&p->people, rec);
    if (p->n_recent < RECENT_MAX)
        memcpy(p->recent + (size_t)p->n_recent++ * PERSON_REC, rec, sizeof(rec));
    shadows_add(&p->shadows, &p->seg, o, p->rgb, p->plate.median);
}

static void checkpoint(sp_probe *p);

/* Cell (cx, cy) of the coarse grid is one of object o's component. */
static int object_cell(const probe_segment *sg, const probe_object *o, int cx, int cy)
{
    return cx >= 0 && cy >= 0 && cx < (int)sg->gw && cy < (int)sg->gh &&
           sg->lab_obj[(size_t)cy * sg->gw + (size_t)cx] == o->label;
}

/*
 * A ghost (the plate shows someone who is gone) has its outline in the plate, not in the frame; a
 * body standing there has it in the frame. Compares the luma gradient of the two along the object's
 * refined-mask outline.
 */
static int ghost_like(const sp_probe *p, const probe_object *o)
{
    const probe_segment *sg = &p->seg;
    double in_frame = 0, in_plate = 0;
    for (int y = o->y0 > 0 ? o->y0 : 1; y <= o->y1 && y + 1 < (int)p->height; y++)
        for (int x = o->x0 > 0 ? o->x0 : 1; x <= o->x1 && x + 1 < (int)p->width; x++) {
            if (!segment_in_mask(sg, o, (uint32_t)x, (uint32_t)y) ||
                (segment_in_mask(sg, o, (uint32_t)x - 1, (uint32_t)y) &&
                 segment_in_mask(sg, o, (uint32_t)x + 1, (uint32_t)y) &&
                 segment_in_mask(sg, o, (uint32_t)x, (uint32_t)y - 1) &&
                 segment_in_mask(sg, o, (uint32_t)x, (uint32_t)y + 1)))
                continue; /* not on the outline */
            size_t i = (size_t)y * p->width + (size_t)x, w = p->width;
            for (int c = 0; c < 3; c++) {
                const uint8_t *f = p->rgb + c, *q = p->plate.median + c;
                in_frame += abs(f[3 * (i + 1)] - f[3 * (i - 1)]) + abs(f[3 * (i + w)] - f[3 * (i - w)]);
                in_plate += abs(q[3 * (i + 1)] - q[3 * (i - 1)]) + abs(q[3 * (i + w)] - q[3 * (i - w)]);
            }
        }
    return in_plate > in_frame;
}

/*
 * The cells of this frame's objects that walked in (their track moved half their height or more), or
 * that stand where the last frame held (a person who stopped: trackers lose still or merged people, and
 * a new track has not moved), one cell around them included: the next plate sample keeps the slot's
 * older background value there (plate_offer), so a person who stops stays out of the plate. Ghosts
 * (ghost_like) are not held and clear within half the window. Nothing to do when holding is off, nor
 * in the plate's first two windows: the warm-up samples show whoever crowded the view at the start
 * (vtest.avi's sign), and holding them would keep those people in the plate where others keep walking.
 */
static void hold_movers(sp_probe *p)
{
    if (!p->plate.settle_samples || p->plate.updates < 2 * p->plate.k)
        return;
    const probe_segment *sg = &p->seg;
    uint8_t *prev = p->hold;
    p->hold = p->hold_prev, p->hold_prev = prev;
    int had = p->hold_frame == p->st.frames; /* the previous frame set what is now prev */
    memset(p->hold, 0, (size_t)sg->gw * sg->gh);
    for (unsigned i = 0; i < sg->n_obj; i++) {
        const probe_track *k = p->completion[i].owner;
        const probe_object *o = &sg->obj[i];
        const int32_t *box = sg->comp + 5 * o->label; /* the component's cells: the body and its shadow */
        int cx0 = box[0], cy0 = box[1], cx1 = box[2], cy1 = box[3];
        int moved = k && k->travel >= 0.5 * k->height, stays = 0;
        for (int cy = cy0; had && !moved && !stays && cy <= cy1; cy++)
            for (int cx = cx0; !stays && cx <= cx1; cx++)
                stays = object_cell(sg, o, cx, cy) && prev[(size_t)cy * sg->gw + (size_t)cx];
        if ((!moved && !stays) || ghost_like(p, o))
            continue;
        for (int cy = cy0 - 1; cy <= cy1 + 1; cy++)
            for (int cx = cx0 - 1; cx <= cx1 + 1; cx++) {
                if (cx < 0 || cy < 0 || cx >= (int)sg->gw || cy >= (int)sg->gh)
                    continue;
                int own = 0; /* the cell or a neighbour is the object's */
                for (int dy = -1; dy <= 1 && !own; dy++)
                    for (int dx = -1; dx <= 1 && !own; dx++)
                        own = object_cell(sg, o, cx + dx, cy + dy);
                p->hold[(size_t)cy * sg->gw + (size_t)cx] |= (uint8_t)own;
            }
    }
    p->hold_frame = p->st.frames + 1;
}

/*
 * The view shifted in more than `share` of at least `min_checks` motion
 * checks, or that share of the probed frames differs from the plate almost
 * everywhere: a moving camera (or a light that keeps jumping). Says so.
 */
static int camera_moves(sp_probe *p, uint64_t min_checks, double share)
{
    const probe_motion *mo = &p->motion;
    int shifted = mo->checks >= min_checks && (double)mo->moved > share * (double)mo->checks;
    int changed = p->st.frames_probed >= 3 * min_checks &&
                  (double)p->st.frames_moving > share * (double)p->st.frames_probed;
    if (shifted)
        snprintf(p->message, sizeof(p->message),
                 "the camera moves: the whole view shifted in %llu of %llu checks; probing needs a static camera",
                 (unsigned long long)mo->moved, (unsigned long long)mo->checks);
    else if (changed)
        snprintf(p->message, sizeof(p->message),
                 "the camera moves: %llu of %llu frames differ from the clean plate over more than %.0f%% "
                 "of the image; probing needs a static camera",
                 (unsigned long long)p->st.frames_moving, (unsigned long long)p->st.frames_probed,
                 100.0 * p->s.max_foreground);
    return shifted || changed;
}

static int probe_frame(sp_probe *p, int64_t t)
{
    p->st.frames++;
    motion_frame(&p->motion, p->rgb, p->width);
    if (camera_moves(p, 10, 0.8))
        return SP_ENODATA;
    plate_hold hold = { .cells = p->hold, .block = p->seg.block, .gw = p->seg.gw };
    int updated = plate_offer(&p->plate, p->rgb, t, p->hold_frame == p->st.frames ? &hold : NULL);
    if (updated < 0) {
        snprintf(p->message, sizeof(p->message),
                 "frame %llu: timestamp %lld ns is too close to the end of the clock's range (int64 overflow)",
                 (unsigned long long)(p->st.frames - 1), (long long)t);
        return SP_ENODATA;
    }
    p->segmented = 0;
    p->n_cls = 0;
    if (!plate_ready(&p->plate))
        return 0;
    segment_frame(&p->seg, p->rgb, p->plate.median, &p->plane);
    p->segmented = 1;
    p->st.frames_probed++;
    double changed = (double)(p->seg.fg_pixels + p->seg.shadow_pixels) / ((double)p->width * p->height);
    if (changed > p->s.max_foreground) {
        /* the plate does not describe this frame: the camera moved or the light jumped */
        p->st.frames_moving++;
        return camera_moves(p, 10, 0.8) ? SP_ENODATA : 0;
    }
    if (updated)
        maps_add_background(&p->maps, p->plate.median, p->seg.cls);
    tracks_update(&p->tracks, &p->seg, p->st.frames - 1, &p->plane, p->completion);
    hold_movers(p);
    p->n_cls = p->seg.n_obj;
    for (unsigned i = 0; i < p->seg.n_obj; i++) {
        const probe_object *o = &p->seg.obj[i];
        p->st.objects++;
        /*
         * A person standing still shows the same view frame after frame: for the scale and shadow models
         * that is one observation, not hundreds (they would outweigh everyone who walked past), so a
         * tracked person counts again once the foot point moved REPEAT_MOVE of the height. The maps take
         * every frame of a short stop (a walker held up behind a pole is evidence each frame) but, once
         * a person has stood still for STILL_FRAMES, one frame in STILL_FRAMES.
         */
        probe_track *k = p->completion[i].owner;
        uint64_t now = p->st.frames;
        int repeat = k && k->evidenced && hypot(o->foot_x - k->ex, o->foot_y - k->ey) < REPEAT_MOVE * o->height;
        if (k && !repeat)
            k->evidenced = 1, k->ex = o->foot_x, k->ey = o->foot_y, k->still_since = now;
        int to_maps = !k || !repeat || now - k->still_since < STILL_FRAMES || now - k->fed >= STILL_FRAMES;
        if (to_maps) {
            maps_add_object(&p->maps, &p->seg, o, &p->plane);
            maps_add_template(&p->maps, &p->seg, p->plate.median, o, &p->completion[i]);
            maps_add_passage(&p->maps, &p->seg, &p->completion[i]);
            if (k)
                k->fed = now;
        }
        int own_foot = car_shaped(p, o);
        p->cls[i] = is_person(p, o)               ? SP_PROBE_PERSON
            : own_foot || car_behind_walker(p, o) ? SP_PROBE_CAR
                                                  : SP_PROBE_OTHER;
        if (p->cls[i] == SP_PROBE_PERSON && repeat)
            p->st.repeats++;
        else if (p->cls[i] == SP_PROBE_PERSON)
            observe_person(p, o);
        p->st.cars += p->cls[i] == SP_PROBE_CAR;
        if (own_foot && p->cls[i] == SP_PROBE_CAR && !o->touches && !repeat) /* cut by the border: no height */
            reservoir_add(
                &p->cars,
                (const float[PERSON_REC]){ (float)o->foot_x, (float)o->foot_y,
                                           (float)((o->foot_y - o->roof_y + 1) * PERSON_HEIGHT_M / CAR_HEIGHT_M) });
    }
    if (p->st.frames_probed % p->s.checkpoint_frames == 0)
        checkpoint(p);
    return 0;
}

int sp_probe_push_rgb(sp_probe *p, const uint8_t *rgb, uint32_t stride, int64_t timestamp_ns)
{
    if (!p || !rgb || stride < p->width * 3)
        return -EINVAL;
    if (p->finished)
        return -EALREADY;
    if (p->last_ts != INT64_MIN && timestamp_ns < p->last_ts)
        return -EINVAL;
    p->last_ts = timestamp_ns;
    for (uint32_t y = 0; y < p->height; y++)
        memcpy(p->rgb + (size_t)y * p->width * 3, rgb + (size_t)y * stride, (size_t)p->width * 3);
    return probe_frame(p, timestamp_ns);
}

int sp_probe_push_frame(sp_probe *p, const sp_frame *frame)
{
    if (!p || !frame || frame->width != p->width || frame->height != p->height)
        return -EINVAL;
    if (p->finished)
        return -EALREADY;
    if (p->last_ts != INT64_MIN && frame->timestamp_ns < p->last_ts)
        return -EINVAL;
    int ret = sp_pixconv_frame_to_rgb24(frame, p->rgb, (size_t)p->width * p->height * 3, p->width * 3);
    if (ret) {
        snprintf(p->message, sizeof(p->message), "frame %llu could not be decoded: %s",
                 (unsigned long long)frame->sequence, sp_strerror(ret));
        return ret;
    }
    p->last_ts = frame->timestamp_ns;
    return probe_frame(p, frame->timestamp_ns);
}

/* ---- checkpoints: the error-against-run-time report ---- */

/* Relative change of the predicted heights on a 3x3 grid of image points. */
static double plane_change(const sp_probe_plane *a, const sp_probe_plane *b, uint32_t w, uint32_t h)
{
    double sum = 0;
    int n = 0;
    for (int i = 1; i <= 3; i++)
        for (int j = 1; j <= 3; j++) {
            double x = w * i / 4.0, y = h * j / 4.0;
            double ha = sp_probe_plane_height(a, x, y), hb = sp_probe_plane_height(b, x, y);
            if (isfinite(ha) && isfinite(hb) && hb > 0) {
                sum += fabs(ha - hb) / hb;
                n++;
            }
        }
    return n ? sum / n : (double)NAN;
}

static double truth_plane_error(const sp_probe *p, const sp_probe_plane *pl)
{
    double sum = 0;
    size_t n = 0;
    for (size_t i = 0; i < p->s.n_truth; i++) {
        double h = sp_probe_plane_height(pl, p->truth[i].x, p->truth[i].y);
        if (isfinite(h) && p->truth[i].height > 0) {
            sum += fabs(h - p->truth[i].height) / p->truth[i].height;
            n++;
        }
    }
    return n ? sum / (double)n : (double)NAN;
}

/* Mean angle (degrees) between the model's shadow direction and the truth's at the truth points. */
double probe_shadow_direction_error(const sp_probe_shadow *sh, const sp_probe_truth_sample *t, size_t n,
                                    uint32_t width, uint32_t height)
{
    if (!sh->present)
        return (double)NAN;
    double sum = 0;
    size_t k = 0;
    for (size_t i = 0; i < n; i++) {
        double u = t[i].x / width, v = t[i].y / height;
        double dx = sh->ox[0] + sh->ox[1] * u + sh->ox[2] * v, dy = sh->oy[0] + sh->oy[1] * u + sh->oy[2] * v;
        double a = hypot(dx, dy), b = hypot(t[i].shadow_dx, t[i].shadow_dy);
        if (!(a > 0) || !(b > 0))
            continue;
        double c = (dx * t[i].shadow_dx + dy * t[i].shadow_dy) / (a * b);
        sum += acos(c > 1 ? 1 : c < -1 ? -1 : c) * 180.0 / M_PI;
        k++;
    }
    return k ? sum / (double)k : (double)NAN;
}

/*
 * The scale model from people; where no person was seen, from cars with the car-height prior (a car's
 * pixel height times PERSON_HEIGHT_M / CAR_HEIGHT_M is a person's there), and the note says so.
 */
static void fit_scale(sp_probe *p, sp_probe_plane *out)
{
    int from_cars = !p->people.n && p->cars.n;
    const probe_reservoir *r = from_cars ? &p->cars : &p->people;
    plane_fit(r->v, r->n, PERSON_REC, p->width, p->height, &p->rng, out);
    char note[sizeof(out->note)];
    if (from_cars)
        snprintf(note, sizeof(note), "no person seen: from %u car observations, a car taken as %.1f m against a "
                 "person's %.1f m; %.100s", r->n, CAR_HEIGHT_M, PERSON_HEIGHT_M, out->note);
    else if (!r->n)
        snprintf(note, sizeof(note), "no person or car was observed: the scale cannot be estimated");
    else
        return;
    memcpy(out->note, note, sizeof(note));
}

static void checkpoint(sp_probe *p)
{
    double v[N_SERIES];
    maps_checkpoint(&p->maps, v);
    /* prequential: observations since the last checkpoint against the fit made before them */
    v[4] = p->n_recent ? plane_median_error(&p->plane, p->recent, p->n_recent, PERSON_REC) : (double)NAN;
    p->n_recent = 0;
    p->seg.no_cast_shadows = shadows_absent(&p->shadows);
    sp_probe_plane next = p->plane;
    fit_scale(p, &next);
    v[5] = plane_change(&next, &p->plane, p->width, p->height);
    p->plane = next;
    v[6] = p->s.n_truth ? truth_plane_error(p, &p->plane) : (double)NAN;
    v[7] = (double)NAN;
    if (p->s.n_truth) {
        shadows_fit(&p->shadows, p->width, p->height, &p->shadow);
        v[7] = probe_shadow_direction_error(&p->shadow, p->truth, p->s.n_truth, p->width, p->height);
    }
    if (p->report)
        sp_report_add(p->report, (double)(sp_clock_monotonic_ns() - p->start_ns) * 1e-9, v);
}

/* ---- the end ---- */

static int check_enough(sp_probe *p)
{
    if (p->st.frames_probed == 0) {
        snprintf(p->message, sizeof(p->message),
                 "the capture is too short: %llu frames, but the clean plate needs %u samples over %.1f s "
                 "(--window) before probing can start",
                 (unsigned long long)p->st.frames, p->s.window_samples, p->s.window_s);
        return SP_ENODATA;
    }
    if (camera_moves(p, 2, 0.5))
        return SP_ENODATA;
    if (p->st.objects == 0) {
        snprintf(p->message, sizeof(p->message),
                 "no moving objects were seen in %llu probed frames: nothing to probe the scene with",
                 (unsigned long long)p->st.frames_probed);
        return SP_ENODATA;
    }
    return 0;
}

int sp_probe_finish(sp_probe *p)
{
    if (!p)
        return -EINVAL;
    if (p->finished)
        return 0;
    int ret = check_enough(p);
    if (ret)
        return ret;
    checkpoint(p);
    fit_scale(p, &p->plane);
    p->plane.holdout_n = (unsigned)(p->holdout.seen < UINT32_MAX ? p->holdout.seen : UINT32_MAX);
    p->plane.holdout_error_rel =
        p->holdout.n ? plane_median_error(&p->plane, p->holdout.v, p->holdout.n, PERSON_REC) : (double)NAN;
    shadows_fit(&p->shadows, p->width, p->height, &p->shadow);
    if (!p->shadow.present)
        sp_log(SP_LOG_INFO, "probe", "shadow model %s", p->shadow.note);
    probe_occluder_stats occ;
    maps_finalise(&p->maps, p->plate.median, &p->plane, &occ);
    sp_log(SP_LOG_INFO, "probe",
           "occluders: %zu groups; %zu specks, %zu torn and %zu plain groups dropped (%zu pixels), %zu pixels raised "
           "to their group's depth",
           occ.groups, occ.specks, occ.torn, occ.plain, occ.dropped_pixels, occ.raised);
    if (p->report)
        ret = sp_report_close(&p->report);
    p->finished = 1;
    snprintf(p->message, sizeof(p->message),
             "probed %llu of %llu frames: %llu object observations (%llu people, %llu cars, %llu other; "
             "%llu more views of people standing still)",
             (unsigned long long)p->st.frames_probed, (unsigned long long)p->st.frames,
             (unsigned long long)p->st.objects, (unsigned long long)p->st.people, (unsigned long long)p->st.cars,
             (unsigned long long)(p->st.objects - p->st.people - p->st.cars - p->st.repeats),
             (unsigned long long)p->st.repeats);
    return ret;
}

unsigned sp_probe_frame_objects(const sp_probe *p, sp_probe_object *out, unsigned cap)
{
    if (!p)
        return 0;
    for (unsigned i = 0; out && i < p->n_cls && i < cap; i++) {
        const probe_object *o = &p->seg.obj[i];
        out[i] = (sp_probe_object){ .x0 = o->x0, .y0 = o->y0, .x1 = o->x1, .y1 = o->y1, .foot_x = o->foot_x,
                                    .foot_y = o->foot_y, .height = o->height, .area = o->area,
                                    .touches_border = o->touches != 0, .cls = p->cls[i] };
    }
    return p->n_cls;
}

const char *sp_probe_class_name(sp_probe_class c)
{
    return c == SP_PROBE_PERSON ? "person" : c == SP_PROBE_CAR ? "car" : "other";
}

const char *sp_probe_message(const sp_probe *p)
{
    return p ? p->message : "no probe";
}

int sp_probe_get_stats(const sp_probe *p, sp_probe_stats *out)
{
    if (!p || !out)
        return -EINVAL;
    *out = p->st;
    size_t n = (size_t)p->width * p->height, covered = 0, occluding = 0;
    for (size_t i = 0; i < n; i++) {
        covered += p->maps.light_n[i] > 0;
        /* once finished, the map as written (occluders settled) */
        occluding += (p->finished ? p->maps.occlusion[i] : maps_occlusion_at(&p->maps, i)) >= 0;
    }
    out->covered_fraction = (double)covered / (double)n;
    out->occluder_fraction = (double)occluding / (double)n;
    return 0;
}

int sp_probe_get_plane(const sp_probe *p, sp_probe_plane *out)
{
    if (!p || !out)
        return -EINVAL;
    if (!p->finished)
        return -EAGAIN;
    *out = p->plane;
    return 0;
}

int sp_probe_get_shadow(const sp_probe *p, sp_probe_shadow *out)
{
    if (!p || !out)
        return -EINVAL;
    if (!p->finished)
        return -EAGAIN;
    *out = p->shadow;
    return 0;
}

int sp_probe_get_maps(const sp_probe *p, sp_probe_maps *out)
{
    if (!p || !out)
        return -EINVAL;
    if (!p->finished)
        return -EAGAIN;
    *out = (sp_probe_maps){ p->width,          p->height,        p->maps.clean,
                            p->maps.occlusion, p->maps.lighting, p->maps.occlusion_confidence };
    return 0;
}

int sp_probe_empty_frame(const sp_probe *p, uint8_t *dst, uint32_t dst_stride)
{
    if (!p || !dst || dst_stride < p->width * 3)
        return -EINVAL;
    if (!p->segmented)
        return -EAGAIN;
    const probe_segment *sg = &p->seg;
    for (uint32_t y = 0; y < p->height; y++) {
        uint8_t *d = dst + (size_t)y * dst_stride;
        const uint8_t *f = p->rgb + (size_t)y * p->width * 3, *b = p->plate.median + (size_t)y * p->width * 3;
        int64_t gy = y / sg->block;
        for (uint32_t x = 0; x < p->width; x++) {
            int64_t gx = x / sg->block;
            int near = 0; /* any changed cell within one cell: objects, shadows and their soft edges */
            for (int64_t yy = gy - 1; yy <= gy + 1 && !near; yy++)
                for (int64_t xx = gx - 1; xx <= gx + 1 && !near; xx++)
                    near = yy >= 0 && xx >= 0 && yy < sg->gh && xx < sg->gw && sg->grid[yy * sg->gw + xx];
            memcpy(d + 3 * x, (near ? b : f) + 3 * x, 3);
        }
    }
    return 0;
}

/* ---- the HOG people detector, through the OpenCV shim ---- */

int probe_hog_person(void **hog, const uint8_t *rgb, uint32_t width, uint32_t height, const probe_object *o,
                     int *is_person)
{
#if HAVE_OPENCV
    int ret = 0;
    if (!*hog)
        ret = sp_cv_hog_open((sp_cv_hog **)hog);
    double score = 0;
    if (!ret)
        ret = sp_cv_hog_score((sp_cv_hog *)*hog, rgb, width, height, width * 3, o->x0, o->y0, o->x1, o->y1, &score);
    *is_person = !ret && score > 0;
    return ret;
#else
    (void)hog, (void)rgb, (void)width, (void)height, (void)o;
    *is_person = 0;
    return SP_EDISABLED;
#endif
}

void probe_hog_close(void **hog)
{
#if HAVE_OPENCV
    sp_cv_hog_close((sp_cv_hog **)hog);
#else
    (void)hog;
#endif
}
