/* SPDX-License-Identifier: MIT */
/*
 * People as Scene Probes on a static camera: frames stream in one at a time
 * and the people and other objects walking through are used as probes of the
 * scene. Out come a clean plate, an occlusion map, a lighting map, a ground-
 * plane scale model (pixel height of a person at each ground point) and a shadow
 * model; compositing then inserts cut-outs with the right size, occlusion,
 * brightness and shadow. No network, no GPU, memory bounded by the frame size
 * and the settings, never by the capture length. Method, parameters and the
 * memory bound: pipeline/probe/PROBE.md.
 *
 * Coordinates are pixels, x to the right, y down, pixel centres at integers.
 * An object's "bottom" is the image row of its lowest visible pixel, its ground
 * contact point: on a ground plane seen from above, a larger bottom row means
 * closer to the camera.
 */
#ifndef SUNPROBE_SP_PROBE_H
#define SUNPROBE_SP_PROBE_H

#include <stddef.h>
#include <stdint.h>

#include "sp_common.h"
#include "sp_frame.h"

#ifdef __cplusplus
extern "C" {
#endif

/* How objects are labelled people (only people feed the scale model). */
enum sp_probe_detector {
    SP_PROBE_DETECT_SHAPE = 0, /* upright, person-like bounding box and fill (no dependency) */
    SP_PROBE_DETECT_HOG = 1,   /* shape, confirmed by OpenCV's HOG people detector (-Dopencv) */
};

/* A ground-truth point a synthetic capture supplies, to report error against run time. */
typedef struct sp_probe_truth_sample {
    double x, y;     /* a ground point in the image */
    double height;   /* true pixel height of a person of nominal height standing there */
    double shadow_dx, shadow_dy; /* true image direction of that person's shadow (any length; 0,0: none) */
} sp_probe_truth_sample;

typedef struct sp_probe_settings {
    double window_s;          /* clean-plate median window in seconds, default 4 */
    unsigned window_samples;  /* frames kept for the median, odd, 3..31, default 15 */
    double settle_s;          /* a person who walked in and stopped stays out of the plate this long,
                                 then becomes background; default 120, 0: the median alone */
    unsigned fg_threshold;    /* refined mask: |dR|+|dG|+|dB| to the plate above this, default 50 */
    double shadow_min_ratio;  /* a shadow pixel keeps this much of the plate's brightness at least, default 0.3 */
    double shadow_max_ratio;  /* and at most this much, default 0.85 */
    double shadow_chroma_tol; /* and its normalised chromaticity moves by at most this, default 0.035 */
    unsigned block;           /* coarse cell for morphology and components, pixels, 2..15, default 4 */
    unsigned min_object_px;   /* smallest object, refined-mask pixels; default 0: width * height / 4000, >= 16 */
    enum sp_probe_detector detector; /* default SP_PROBE_DETECT_SHAPE */
    unsigned min_occlusion_events; /* occlusion evidence needed before a pixel occludes, default 1 */
    int64_t holdout_from;     /* frames from this index test the scale model instead of fitting it; -1: none (default) */
    unsigned max_observations; /* reservoir of person observations for the fits, default 4096 */
    unsigned checkpoint_frames; /* frames between rows of the convergence report, default 25 */
    double max_foreground;    /* a frame this much foreground counts as "camera moved", default 0.5 */
    const char *report_prefix; /* error-against-run-time report PREFIX.csv/.svg, NULL: none; borrowed until close */
    const sp_probe_truth_sample *truth; /* optional ground truth for the report; borrowed until close */
    size_t n_truth;
    uint64_t seed;            /* for the sampling in robust fits and reservoirs, default 1 */
} sp_probe_settings;

enum sp_probe_plane_status {
    SP_PROBE_PLANE_OK = 0,        /* h = a x + b y + c everywhere */
    SP_PROBE_PLANE_NONE = 1,      /* no person observed: nothing known */
    SP_PROBE_PLANE_ONE_POINT = 2, /* people seen at (nearly) one place: only the height there (c, a = b = 0) */
    SP_PROBE_PLANE_LINE = 3,      /* people seen along one line: the slope across it is unknown (a, b along it) */
};

/* Eq. 3.7: the pixel height of a person standing at ground point (x, y) is h = a x + b y + c. */
typedef struct sp_probe_plane {
    enum sp_probe_plane_status status;
    double a, b, c;
    double line_x, line_y, line_dx, line_dy; /* LINE: the line (point, unit direction) the model holds on;
                                                ONE_POINT: the point (direction 0, 0) */
    double line_tol;          /* LINE, ONE_POINT: how far from it (pixels) the model still answers */
    unsigned n_observations;  /* person observations the fit saw */
    unsigned n_inliers;
    double residual_rel;      /* median |h - fit| / h over inliers */
    unsigned holdout_n;       /* observations held out (holdout_from) */
    double holdout_error_rel; /* their median relative height error; NaN when none */
    char note[200];           /* what could not be estimated, for people */
} sp_probe_plane;

#define SP_PROBE_CONTACT_BINS 6 /* sp_probe_shadow.contact: rings at 0-1.5 x 0.25 h from the foot */

/*
 * The shadow model: a person's shadow is the person's image mask projected
 * along the image-space shadow direction onto the ground: a point at height
 * fraction t (0 feet, 1 head) lands at foot + t (dx, dy) h, where (dx, dy)
 * depends linearly on the normalised ground point (u, v) = (x / width, y / height):
 * dx = ox[0] + ox[1] u + ox[2] v and dy = oy[0] + oy[1] u + oy[2] v.
 * Shadowed ground keeps `ratio` of its lit colour.
 */
typedef struct sp_probe_shadow {
    int present;              /* 0: left out, `note` says why (e.g. overcast) */
    double ox[3], oy[3];
    double ratio[3];          /* R, G, B */
    unsigned n_shadows;       /* person observations with a hard shadow */
    unsigned n_candidates;    /* person observations examined */
    double direction_spread_deg; /* circular spread of the observed directions */
    char note[200];
    /* the contact shadow: how people darken the ground at their feet, used where there is no sun model
       (PROBE.md, "Contact shadow"). contact[k]: the median ground/plate luminance ratio beside the feet at
       horizontal distance (k + 0.5) / 4 x 0.25 h from the foot, h the person's height in pixels, over that
       at 1.5-2 x 0.25 h */
    int contact_present;
    double contact[SP_PROBE_CONTACT_BINS];
    unsigned n_contact; /* person observations measured */
    char contact_note[120];
} sp_probe_shadow;

typedef struct sp_probe_stats {
    uint64_t frames;          /* pushed */
    uint64_t frames_probed;   /* after the clean plate was ready */
    uint64_t frames_moving;   /* probed frames over max_foreground */
    uint64_t objects;         /* object observations (one object in one frame) */
    uint64_t people;          /* of those, labelled people */
    uint64_t cars;            /* and labelled cars (or other vehicles); the rest are "other" */
    uint64_t repeats;         /* person views the models skipped: a tracked person who had not moved since */
    uint64_t hog_checked, hog_confirmed; /* SP_PROBE_DETECT_HOG */
    double covered_fraction;  /* pixels any object covered */
    double occluder_fraction; /* pixels the occlusion map marks as occluding */
    size_t memory_bytes;      /* allocated by the probe: fixed at open */
} sp_probe_stats;

/* The maps, borrowed from the probe or a loaded probe directory. */
typedef struct sp_probe_maps {
    uint32_t width, height;
    const uint8_t *clean_plate; /* RGB24, rows width*3 bytes */
    /*
     * Occlusion (eq. 3.1): per pixel the bottom row of the nearest object seen
     * hidden there, -1 where nothing was ("never occluding"). An object whose
     * bottom row is at most that value is hidden at the pixel (eq. 3.2).
     */
    const float *occlusion;
    /* Lighting (eq. 3.3): mean colour of the objects that covered a pixel over the mean of all, RGB; 0: none did. */
    const float *lighting;
    /*
     * How far the pixel's own events back its occlusion value, 0..1: the events that agree over all of them,
     * with one contrary event as the prior (0: nothing seen there; one hidden event alone 0.5). NULL where
     * unknown (a probe directory written before it existed).
     */
    const float *occlusion_confidence;
} sp_probe_maps;

typedef struct sp_probe sp_probe;

/* What an object is taken for (PROBE.md, "Object classes"). */
typedef enum sp_probe_class { SP_PROBE_OTHER = 0, SP_PROBE_PERSON = 1, SP_PROBE_CAR = 2 } sp_probe_class;

/* One object of the last probed frame, pixels (x right, y down). */
typedef struct sp_probe_object {
    int x0, y0, x1, y1;       /* refined-mask box, inclusive */
    double foot_x, foot_y;    /* bottom middle: where it stands */
    double height;            /* foot_y - top + 1 */
    uint32_t area;            /* refined-mask pixels */
    int touches_border;
    sp_probe_class cls;
} sp_probe_object;

SP_API void sp_probe_default_settings(sp_probe_settings *s);
/*
 * A probe for width x height frames. Allocates everything here (the memory
 * bound in PROBE.md); nothing is allocated per frame. -EINVAL for bad settings,
 * SP_EDISABLED for SP_PROBE_DETECT_HOG without OpenCV.
 */
SP_API int sp_probe_open(sp_probe **out, uint32_t width, uint32_t height, const sp_probe_settings *s);
/* Frees everything; *p becomes NULL; accepts NULL and a half-built probe. */
SP_API void sp_probe_close(sp_probe **p);

/*
 * Probes one frame (packed RGB24 rows `stride` bytes apart, borrowed for the
 * call) taken at timestamp_ns (monotonic; frames in order). -EINVAL for a
 * bad size or a timestamp going backwards, -EALREADY after finish.
 */
SP_API int sp_probe_push_rgb(sp_probe *p, const uint8_t *rgb, uint32_t stride, int64_t timestamp_ns);
/* The same for a frame of any pixel format (converted; MJPEG needs libjpeg). */
SP_API int sp_probe_push_frame(sp_probe *p, const sp_frame *frame);

/*
 * Ends the stream: fits the models and finalises the maps. Returns 0, or
 * SP_ENODATA when nothing can be probed (too few frames for the clean plate,
 * a moving camera, no moving objects); sp_probe_message says why.
 */
SP_API int sp_probe_finish(sp_probe *p);
/* A sentence about the last failure or the outcome; never NULL, valid until the next call. */
SP_API const char *sp_probe_message(const sp_probe *p);

SP_API int sp_probe_get_stats(const sp_probe *p, sp_probe_stats *out);
/* The objects of the last pushed frame (none when it was not probed): how many there are; the first
 * min(that, cap) are copied to out. */
SP_API unsigned sp_probe_frame_objects(const sp_probe *p, sp_probe_object *out, unsigned cap);
SP_API const char *sp_probe_class_name(sp_probe_class c);
/* After finish: the models and the maps (borrowed until close). -EAGAIN before finish. */
SP_API int sp_probe_get_plane(const sp_probe *p, sp_probe_plane *out);
SP_API int sp_probe_get_shadow(const sp_probe *p, sp_probe_shadow *out);
SP_API int sp_probe_get_maps(const sp_probe *p, sp_probe_maps *out);

/*
 * Removal ("emptying the street"): the last pushed frame with its moving
 * objects and their shadows replaced by the current clean plate, into dst
 * (RGB24, rows dst_stride bytes apart). -EAGAIN while the plate is not ready.
 */
SP_API int sp_probe_empty_frame(const sp_probe *p, uint8_t *dst, uint32_t dst_stride);

/* ---- plane and shadow parameters as JSON ---- */

/*
 * The models of a finished probe (or given ones) as a JSON object, with the
 * observations per class when stats is not NULL; *out is malloc'd,
 * NUL-terminated, the caller frees it.
 */
SP_API int sp_probe_params_to_json(const sp_probe_plane *plane, const sp_probe_shadow *shadow,
                                   const sp_probe_stats *stats, uint32_t width, uint32_t height, char **out);
/* Parses what sp_probe_params_to_json wrote; SP_ECORRUPT for anything else. */
SP_API int sp_probe_params_from_json(const char *json, size_t len, sp_probe_plane *plane, sp_probe_shadow *shadow,
                                     uint32_t *width, uint32_t *height);

/* Pixel height of a person at (x, y) from the plane; NaN where the model does not say. */
SP_API double sp_probe_plane_height(const sp_probe_plane *plane, double x, double y);

/* ---- compositing ---- */

typedef struct sp_composite_object {
    const uint8_t *rgba;      /* the cut-out, RGBA8 (straight alpha), rows `stride` bytes apart; borrowed */
    uint32_t width, height, stride;
    double x, y;              /* ground point in the background where the cut-out's bottom middle goes */
    double height_px;         /* > 0: the height on screen; 0: from the plane */
    double height_scale;      /* with the plane: object height over a person's height, default 1 */
} sp_composite_object;

typedef struct sp_composite_settings {
    int occlusion;            /* apply the occlusion map (eq. 3.2), default 1 */
    int lighting;             /* scale the brightness by the lighting map (eq. 3.4), default 1 */
    int shadow;               /* draw a shadow where a shadow model was learned, default 1 */
} sp_composite_settings;

typedef struct sp_composite_report {
    double height_px;         /* of the last object drawn */
    double gain[3];           /* its lighting gain */
    uint64_t pixels_drawn, pixels_hidden, shadow_pixels;
    uint64_t contact_pixels; /* darkened by the contact shadow (scenes without a sun model) */
} sp_composite_report;

SP_API void sp_composite_default_settings(sp_composite_settings *s);
/*
 * Draws `n` objects into `rgb` (the background, RGB24 of maps->width x
 * maps->height, rows `stride` bytes apart, modified in place) back to front
 * (by ground row). `maps` (occlusion and lighting may be NULL: not applied),
 * `plane` and `shadow` (may be NULL) are borrowed. -EINVAL for bad arguments,
 * SP_ENODATA when an object needs the plane for its height and the plane does
 * not cover its ground point; nothing is drawn then.
 */
SP_API int sp_composite(const sp_probe_maps *maps, const sp_probe_plane *plane, const sp_probe_shadow *shadow,
                        const sp_composite_settings *s, const sp_composite_object *objects, size_t n, uint8_t *rgb,
                        uint32_t stride, sp_composite_report *report);

#ifdef __cplusplus
}
#endif
#endif
