/* SPDX-License-Identifier: MIT */
/*
 * Internals of the scene probe (pipeline/probe): the clean plate, per-frame
 * segmentation, the maps, the robust fits. Not installed. PROBE.md describes
 * the method; each part here is a plain struct with open/close and one step.
 */
#ifndef SUNPROBE_PIPELINE_PROBE_INTERNAL_H
#define SUNPROBE_PIPELINE_PROBE_INTERNAL_H

#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

#include "sunprobe/sp_probe.h"

#define PROBE_MAX_OBJECTS 64  /* objects kept per frame (largest first) */
#define PROBE_MAX_WIRES 32    /* median network width: window_samples rounded up to a power of two */
#define PROBE_MAX_PAIRS 256   /* compare-exchanges of that network (Batcher, n = 32: 191) */
#define PROBE_EVIDENCE 4      /* occlusion evidence slots per pixel and side */

/* ---- clean plate: per-channel median of a ring of sampled frames (plate.c) ---- */

typedef struct probe_plate {
    uint32_t width, height;
    size_t bytes;            /* width * height * 3 */
    unsigned k;              /* ring slots (window_samples) */
    unsigned filled, next;
    uint8_t *ring;           /* k images of `bytes` */
    uint8_t *median;         /* the plate, valid once filled == k */
    int64_t interval_ns, next_sample_ns;
    unsigned n_wires, out_wire, n_pairs;
    uint8_t pairs[PROBE_MAX_PAIRS][2];
    uint64_t updates;
    uint16_t *held;          /* width * height: consecutive samples the slot's older value was kept instead */
    unsigned settle_samples; /* after this many, a held pixel takes the frame again (a lasting change) */
} probe_plate;

/* Where a sample keeps the slot's older value: cells of block x block pixels, gw per row, nonzero = held. */
typedef struct plate_hold {
    const uint8_t *cells;
    unsigned block;
    uint32_t gw;
} plate_hold;

/* settle_ns: how long a held pixel stays held before the frame's value is sampled there anyway. */
int plate_open(probe_plate *pl, uint32_t width, uint32_t height, unsigned k, int64_t window_ns, int64_t settle_ns);
void plate_close(probe_plate *pl);
/* Samples the frame when the interval has passed, keeping the slot's older value where hold (may be
 * NULL) says an object that walked in stands; 1 when the plate was recomputed, else 0; -ERANGE when
 * the next sampling time would overflow int64. */
int plate_offer(probe_plate *pl, const uint8_t *rgb, int64_t t_ns, const plate_hold *hold);
static inline int plate_ready(const probe_plate *pl) { return pl->filled == pl->k; }
/* Element-wise median of `k` (3..PROBE_MAX_WIRES) byte arrays of n bytes into out: exposed for tests. */
int probe_median_bytes(const uint8_t *const *in, unsigned k, size_t n, uint8_t *out);

/* ---- camera motion check (motion.c) ---- */

typedef struct probe_motion {
    uint32_t tw, th;         /* thumbnail: a gray cell per 4x4 pixels */
    uint8_t *cur, *prev;
    uint16_t *rowsum;        /* 12 * tw: thumbnail scratch */
    int have_prev;
    uint64_t frames, checks, moved;
} probe_motion;

int motion_open(probe_motion *mo, uint32_t width, uint32_t height);
void motion_close(probe_motion *mo);
/* Every few frames: did the whole view shift since the last check? Counts in checks / moved. */
void motion_frame(probe_motion *mo, const uint8_t *rgb, uint32_t width);

/* ---- segmentation: refined mask, shadows, components, objects (segment.c) ---- */

/*
 * Under the open sky a cast shadow keeps the skylight and loses the sun, and skylight is bluer than
 * sunlight: each channel keeps a different share, red the least and blue the most (on the path-traced
 * street about 0.48, 0.57, 0.72), so the chromaticity shifts by 0.06-0.13, past the neutral test's
 * tolerance. Accepted when the kept shares rise from red to blue (within sensor noise), blue keeps
 * at most all of its light, and blue keeps at most PROBE_SKY_SPREAD times red's share: clothing that
 * happens to be a darker blue than the ground differs by more.
 */
#define PROBE_SKY_SPREAD 2
static inline int probe_sky_lit(const uint8_t *p, const uint8_t *q, int32_t n)
{
    int32_t r = p[0], g = p[1], b = p[2], R = q[0], G = q[1], B = q[2];
    return (r - n) * G <= (g + n) * R && (g - n) * B <= (b + n) * G && b <= B + n &&
           (b - n) * R <= PROBE_SKY_SPREAD * (r + n) * B;
}

/*
 * Pixel p is a cast shadow on ground of colour q (the plate, or the lit ground near an object): darker
 * by a ratio in [lo, hi] (1/1024), its normalised chromaticity kept within tol (1/1024) plus what sensor
 * noise of `noise` levels per channel does to a dark pixel, or skylit. Shared by the probe's
 * segmentation and single-image removal (depop_mask.c).
 */
static inline int probe_shadow_of(const uint8_t *p, const uint8_t *q, int32_t lo, int32_t hi, int32_t tol,
                                  int32_t noise)
{
    int32_t r = p[0], g = p[1], b = p[2], R = q[0], G = q[1], B = q[2];
    int32_t s = r + g + b, S = R + G + B;
    if (s * 1024 < lo * S || s * 1024 > hi * S)
        return 0;
    /* sum |c/s - C/S| <= tol + 3 noise / s, multiplied through by s*S */
    int32_t chroma = abs(r * S - R * s) + abs(g * S - G * s) + abs(b * S - B * s);
    int64_t allowed = (int64_t)tol * s * S + 1024 * 3 * noise * (int64_t)S;
    return (int64_t)chroma * 1024 <= allowed || probe_sky_lit(p, q, noise);
}

enum { PROBE_CLS_BG = 0, PROBE_CLS_OBJECT = 1, PROBE_CLS_SHADOW = 2 };
enum { PROBE_TOUCH_TOP = 1, PROBE_TOUCH_BOTTOM = 2, PROBE_TOUCH_LEFT = 4, PROBE_TOUCH_RIGHT = 8 };

typedef struct probe_object {
    int32_t label;           /* coarse component label */
    int x0, y0, x1, y1;      /* refined-mask bounding box, inclusive */
    uint32_t area;           /* refined-mask pixels */
    int touches;             /* PROBE_TOUCH_* */
    double foot_x, foot_y;   /* bottom middle: the ground contact point */
    double height;           /* foot_y - top + 1 */
    double mean_rgb[3];      /* mean colour of the refined mask */
    double cx;               /* mean x of the refined mask */
    double tbar;             /* mean height fraction (0 foot .. 1 top) of the refined mask */
    int person;
    int core_y0, core_y1;    /* solid rows: spans at least half the widest's (a car under a merged walker) */
    uint32_t core_area;      /* their pixels with the holes closed (a car's body may match the road) */
    int roof_y;              /* first row a quarter as wide as the widest: a car's roof, not a walker behind */
    double cut_foot;         /* lower body behind a low occluder: the foot the scale model puts there; NaN: none */
    /* its shadow, when one was found (shadow_area > 0) */
    uint32_t shadow_area;
    double shadow_cx, shadow_cy;
    double shadow_ratio;     /* mean brightness of the shadow over the plate's */
} probe_object;

typedef struct probe_segment {
    uint32_t width, height, gw, gh, block;
    unsigned fg_threshold, min_object_px;
    int32_t shadow_lo, shadow_hi, chroma_tol; /* ratios in 1/1024 */
    uint8_t *cls;            /* width * height: PROBE_CLS_* */
    uint8_t *cell_obj, *cell_sh;       /* gw * gh: object and shadow pixel counts per cell */
    uint8_t *grid, *tmp;               /* gw * gh: changed cells, morphology scratch */
    uint8_t *morph_rows;               /* 3 * gw: morphology's row scratch */
    int32_t *lab_obj;                  /* gw * gh component labels of changed cells, 0 = none */
    int32_t *row_span, *row_first;     /* height: an object's rows, first to last object pixel (core_rows) */
    int32_t *col_first, *col_last;     /* width: its core's columns, first and last object row (core_rows) */
    uint8_t *denoised;                 /* width * height * 3: the grainy frame denoised (classify) */
    int32_t *colsum;                   /* 3 * width: denoising scratch */
    double noise;                      /* the last frame's noise against the plate, 8-bit levels */
    int no_cast_shadows;               /* people cast no hard shadows here: no plate edge is a shadow's (set at
                                          each checkpoint; every plate-edge test: top and foot cuts, foot room,
                                          the template below an edge) */
    int32_t noise_allow;               /* the noise the shadow tests allow for, levels */
    int32_t *parent;                   /* union-find scratch, gw * gh + 1 */
    int32_t *comp;                     /* per label: x0, y0, x1, y1, cells (5 each), gw * gh + 1 labels */
    int32_t *objbox;                   /* the same over the cells holding object pixels */
    int32_t *order;                    /* gw * gh + 1: label renumbering, then candidates by size */
    probe_object obj[PROBE_MAX_OBJECTS];
    unsigned n_obj;
    uint64_t fg_pixels, shadow_pixels; /* of the last frame */
} probe_segment;

int segment_open(probe_segment *sg, uint32_t width, uint32_t height, const sp_probe_settings *s);
void segment_close(probe_segment *sg);
/*
 * Classifies the frame against the plate and extracts the objects and their
 * shadows; the current scale model (may be NULL) helps rejoin people an
 * occluder cut in two and find legs whose colour is close to the plate's.
 */
void segment_frame(probe_segment *sg, const uint8_t *rgb, const uint8_t *plate, const sp_probe_plane *plane);
/* Column x (0..width-1) of the plate has a horizontal edge of `level` (|dR|+|dG|+|dB| across two rows)
 * within 3 rows of `row`, not a cast shadow's (unless sg->no_cast_shadows). */
int segment_plate_edge_at(const probe_segment *sg, const uint8_t *plate, int row, int x, int level);
/* 1 when pixel (x, y) belongs to object o's refined mask M'. */
static inline int segment_in_mask(const probe_segment *sg, const probe_object *o, uint32_t x, uint32_t y)
{
    return sg->cls[(size_t)y * sg->width + x] == PROBE_CLS_OBJECT &&
           sg->lab_obj[(y / sg->block) * sg->gw + x / sg->block] == o->label;
}

/* ---- tracks and silhouette templates (track.c) ---- */

#define PROBE_MAX_TRACKS 32
#define PROBE_TMPL_W 96      /* largest template: people taller or wider get none */
#define PROBE_TMPL_H 192

typedef struct probe_track {
    int alive, has_template;
    uint64_t last_frame;
    double fx, fy, vx, vy;   /* foot point when last seen, velocity per frame */
    double height;
    double travel;           /* foot-point path length since it started, px: a ghost never moves */
    double ex, ey;           /* foot point when its view last fed the scale and shadow models */
    int evidenced;
    uint64_t still_since, fed; /* frame it last moved at, frame its view last fed the maps */
    uint32_t area;           /* template pixels */
    int last_partial;        /* the last view was incomplete: part of the body behind something */
    uint16_t unseen_hidden;  /* bit d-1: d frames after last_frame, no object showed where the template lay */
    int tw, th, ax;          /* template size, column of the foot point */
    uint8_t mask[PROBE_TMPL_H * PROBE_TMPL_W]; /* last, see start_track */
} probe_track;

typedef struct probe_tracks {
    probe_track *track;      /* PROBE_MAX_TRACKS */
} probe_tracks;

/* For a partly hidden person: the template to lay with its foot point at (x, y); track NULL: none. */
typedef struct probe_completion {
    const probe_track *track;
    int x, y;
    probe_track *owner;      /* the track the object was matched to or started, NULL: none */
    /* A passage wholly behind something that this view ends: the foot went from (pass_x0, pass_y0) to
     * (pass_x1, pass_y1) over pass_frames frames (0: none); bit j-1 of pass_hidden: frame j hid the body. */
    double pass_x0, pass_y0, pass_x1, pass_y1;
    unsigned pass_frames;
    uint16_t pass_hidden;
} probe_completion;

int tracks_open(probe_tracks *t);
void tracks_close(probe_tracks *t);
/*
 * Matches this frame's objects to tracks; out[i] (sg->n_obj entries) says how
 * to complete object i. The scale model (may be NULL) vets templates.
 */
void tracks_update(probe_tracks *t, const probe_segment *sg, uint64_t frame, const sp_probe_plane *plane,
                   probe_completion *out);

/* ---- maps: occlusion, lighting, long-term plate (maps.c) ---- */

typedef struct probe_maps {
    uint32_t width, height;
    unsigned min_events;
    int16_t *hid, *vis;      /* PROBE_EVIDENCE slots per pixel: bottoms of objects seen hidden / visible */
    uint16_t *hid_n, *vis_n; /* and how many events each slot holds (0: free) */
    float *light;            /* running mean RGB of covering objects' mean colours */
    uint32_t *light_n;
    uint32_t *bg;            /* sum of the local plate's RGB where the frame is background (bg_n terms) */
    uint32_t bg_updates;     /* maps_add_background calls since the last halving: bounds every bg_n */
    uint32_t *bg_n;
    double light_ref[3];     /* running mean colour over all object observations (pixel-weighted) */
    double light_ref_w;
    /* finalised (maps_finalise) */
    uint8_t *clean;
    float *occlusion, *lighting;
    float *occlusion_confidence; /* maps_confidence_at of the final value */
    uint8_t *prev_occ;       /* occluding bit at the previous checkpoint */
    float *prev_light;       /* relative luminance at the previous checkpoint */
    int32_t *span_l, *span_r; /* height: an object's hull per row (scratch) */
    int32_t *col_top;        /* width: its first M' row per column (scratch) */
    uint8_t *span_hidden;    /* height: the row had no M' pixel, its span was interpolated (scratch) */
    int32_t *slant_hit;      /* 4 slopes x slant_cap: first M' row along each leaning line from the top (scratch) */
    int32_t slant_cap, slant_n, slant_c0; /* lines per slope: room, this object's, the column of its first */
    uint8_t *occ_grouped;                 /* pixels: already in an occluder group (scratch) */
    int32_t *occ_order;                   /* pixels listed group by group (scratch) */
    uint32_t *occ_hist;                   /* height: one group's depths (scratch) */
} probe_maps;

/* What occluders_settle did to the per-pixel occlusion map. */
typedef struct probe_occluder_stats {
    size_t groups, specks, torn, plain, dropped_pixels, raised; /* dropped: the pixels of those three */
} probe_occluder_stats;

int maps_open(probe_maps *m, uint32_t width, uint32_t height, unsigned min_events);
void maps_close(probe_maps *m);
/* Adds one object's visibility, occlusion and lighting evidence; the scale model (may be NULL) says how tall it should be. */
void maps_add_object(probe_maps *m, const probe_segment *sg, const probe_object *o, const sp_probe_plane *plane);
/* After maps_add_object(o): the hidden part of a partly hidden person, from its track's template; the plate
 * says where an edge in front of the body runs. */
void maps_add_template(probe_maps *m, const probe_segment *sg, const uint8_t *plate, const probe_object *o,
                       const probe_completion *c);
/* After maps_add_template(c): the template laid along a passage wholly behind something (c->pass_frames). */
void maps_add_passage(probe_maps *m, const probe_segment *sg, const probe_completion *c);
/* Adds the local plate at background pixels to the long-term plate. */
void maps_add_background(probe_maps *m, const uint8_t *plate, const uint8_t *cls);
/* Final occlusion value of pixel i from the evidence (-1: never occluding). */
float maps_occlusion_at(const probe_maps *m, size_t i);
/* How far pixel i's own events back the occlusion value z, 0..1 (0: no events). */
float maps_confidence_at(const probe_maps *m, size_t i, float z);
/* Fills clean, occlusion and lighting; `fallback_plate` where no background was seen; the scale model (may be
 * NULL) sizes the occluders (occluders_settle). */
void maps_finalise(probe_maps *m, const uint8_t *fallback_plate, const sp_probe_plane *plane, probe_occluder_stats *st);
/* Per-pixel occlusion values to occluders: specks, torn and plain groups dropped, one depth per connected group
 * (occluders.c). */
void occluders_settle(probe_maps *m, const sp_probe_plane *plane, probe_occluder_stats *st);
/* Convergence metrics since the last call: occlusion change, lighting change, coverage, occluders. */
void maps_checkpoint(probe_maps *m, double out[4]);

/* ---- fixed-capacity reservoir of float records (fit.c) ---- */

typedef struct probe_reservoir {
    float *v;
    unsigned cap, n, stride; /* records of `stride` floats */
    uint64_t seen;
    uint64_t rng;
} probe_reservoir;

int reservoir_open(probe_reservoir *r, unsigned cap, unsigned stride, uint64_t seed);
void reservoir_close(probe_reservoir *r);
void reservoir_add(probe_reservoir *r, const float *rec);
/* xorshift64* step; never returns the same stream for different seeds. */
uint64_t probe_rand(uint64_t *state);

/* ---- robust fits (fit.c) ---- */

/* Solves the 3x3 system A x = b (row-major); -1 when (near) singular. */
int probe_solve3(const double A[9], const double b[3], double x[3]);
/*
 * Eq. 3.7: fits h = a x + b y + c to records {x, y, h} (RANSAC on relative
 * residuals, then Tukey IRLS), or says which part cannot be estimated.
 */
void plane_fit(const float *rec, unsigned n, unsigned stride, uint32_t width, uint32_t height, uint64_t *rng,
               sp_probe_plane *out);
/* Median relative error |h - plane| / h of records {x, y, h}; NaN when the plane says nothing there. */
double plane_median_error(const sp_probe_plane *pl, const float *rec, unsigned n, unsigned stride);

/* ---- shadow model (shadow.c) ---- */

#define PROBE_RATIO_BINS 256  /* shadow/lit ratio histogram over [0, 2) */
#define PROBE_CONTACT_RINGS 8 /* normalised distance from the foot in quarters, 0-2 */

typedef struct probe_shadows {
    probe_reservoir obs;     /* {u, v, dx, dy} per hard shadow */
    uint64_t candidates, hard;
    uint64_t ratio_hist[3][PROBE_RATIO_BINS]; /* 64 bits, like the rings: one median for both */
    /* the ground around each person's feet: luminance ratio to the plate by normalised distance, 0-2 in
       quarters (the last two bins are the reference), and the observations that gave any */
    uint64_t contact_hist[PROBE_CONTACT_RINGS][PROBE_RATIO_BINS]; /* 64 bits: a ring gains ~1000 a person */
    uint64_t contact_obs;
} probe_shadows;

int shadows_open(probe_shadows *sh, unsigned cap, uint64_t seed);
void shadows_close(probe_shadows *sh);
/* Examines a person's shadow; records it when hard (returns 1). */
int shadows_add(probe_shadows *sh, const probe_segment *sg, const probe_object *o, const uint8_t *rgb,
                const uint8_t *plate);
/* So far, people cast no hard shadows (overcast, indoors): the fit's own verdict, on enough observations. */
int shadows_absent(const probe_shadows *sh);
/* Fits the model or leaves it out with the reason. */
void shadows_fit(const probe_shadows *sh, uint32_t width, uint32_t height, sp_probe_shadow *out);

/* Mean angle in degrees between the model's shadow direction and the truth's; NaN when not comparable. */
double probe_shadow_direction_error(const sp_probe_shadow *sh, const sp_probe_truth_sample *t, size_t n,
                                    uint32_t width, uint32_t height);

/* ---- OpenCV people detector (opencv_probe_shim.cpp under HAVE_OPENCV) ---- */

/* Lazily created HOG scorer; SP_EDISABLED without OpenCV. */
int probe_hog_person(void **hog, const uint8_t *rgb, uint32_t width, uint32_t height, const probe_object *o,
                     int *is_person);
void probe_hog_close(void **hog);

#endif
