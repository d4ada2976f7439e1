/* SPDX-License-Identifier: MIT */
/*
 * Emptying a street from one image (pipeline/probe/DEPOPULATE.md): masks for
 * the objects to remove grown to take their cast and contact shadows, and an
 * exemplar-based inpainting that fills the holes from the rest of the image.
 * Internal, not installed; `sunprobe depopulate` is its user.
 */
#ifndef SUNPROBE_PIPELINE_PROBE_DEPOPULATE_H
#define SUNPROBE_PIPELINE_PROBE_DEPOPULATE_H

#include <stddef.h>
#include <stdint.h>

#include "sunprobe/sp_probe.h"
#include "common/private_api.h"

/* ---- exemplar inpainting (inpaint.c) ---- */

typedef struct sp_inpaint_settings {
    int patch_radius;        /* patches are (2r+1)^2, 1..8, default 4 */
    int search_radius;       /* source window around each target patch, 0 (default): a sixth of the
                                shorter side, at least 24 */
    unsigned max_candidates; /* coarse search budget per patch (a strided grid, then refined), default 1500 */
    int blend;               /* the best this many sources (1..8) are averaged where nearly as good, default 4 */
} sp_inpaint_settings;

typedef struct sp_inpaint_report {
    uint64_t hole_pixels, patches; /* pixels filled, patches copied */
} sp_inpaint_report;

void sp_inpaint_default_settings(sp_inpaint_settings *s);
/*
 * Fills the pixels where mask != 0 of the RGB24 image (rows `stride` bytes
 * apart, modified in place; mask width x height, borrowed). Returns 0 (an
 * empty mask changes nothing), -EINVAL for bad arguments, -ENOMEM, or
 * SP_ENODATA when no whole patch outside the hole exists to copy from (the
 * image is left as it was).
 */
SP_PRIVATE int sp_inpaint_exemplar(uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, const uint8_t *mask,
                        const sp_inpaint_settings *s, sp_inpaint_report *report);

/* ---- removal masks (depop_mask.c) ---- */

/* One object to remove: its box (inclusive pixels) and its own mask inside the box, if known. */
typedef struct sp_depop_object {
    int x0, y0, x1, y1;
    const uint8_t *mask;     /* NULL: the whole box; else the image-sized object mask (nonzero: object) */
    /* out: what the shadow search found */
    uint32_t shadow_px, contact_px;
    double shadow_dx, shadow_dy; /* mean offset of the cast shadow from the foot, pixels; 0,0: none */
    double shadow_len;           /* farthest shadow pixel from the foot along that direction, pixels */
    int shadow_leak;             /* the dark ground along the sun was too large to be its shadow: left */
    double tip_x, tip_y;         /* the shadow's end: on its axis (foot to its mean), as far as it goes */
    uint32_t shadow_spill;       /* shadow-dark ground next to the cast shadow but outside its cone or reach,
                                    or on the image's edge: the shadow may go on, so its tip is not its end */
    int shadow_cut;              /* the cast shadow went on past the search's reach (max_length heights) or
                                    out of the image */
    int truncated;               /* the box touches the image's edge: its foot or top may be outside */
    int shadow_thin;             /* the cast shadow is a thin dark line from the foot, found where no flood took
                                    one (depop_mask.c); its tip is where the line test stops, so the sun from
                                    one image does not use it */
    uint32_t strip_px;           /* with a camera, where the closed shadows tell the sun: the cast shadow's
                                    pixels, taken in the strip that sun casts from the foot instead of by the
                                    search (whose figures above stay); 0 otherwise */
} sp_depop_object;

typedef struct sp_depop_settings {
    double sun_dx, sun_dy;   /* image direction shadows fall in from the foot (any length), 0,0: unknown */
    double cone_deg;         /* with a direction: how far off it a shadow pixel may lie, default 30 */
    double max_length;       /* shadow length bound in object heights, default 3 */
    double ratio_lo, ratio_hi; /* a shadow keeps this share of the lit ground's brightness, default 0.2..0.85 */
    double chroma_tol;       /* normalised chromaticity change allowed, default 0.05 */
    int shadows;             /* grow masks by cast and contact shadows, default 1 */
    /* the camera (borrowed, may be NULL): without sun_dx, sun_dy, the shadows' one ground direction is
       searched for through it (depop_mask.c, "one sun") */
    const struct sp_depop_camera *camera;
    /* the sun from the clock (borrowed, may be NULL; azimuth and elevation as sp_depop_sun's, relative to the
       camera): with the camera, the sun's strips and thin shadows use it where no closed shadow tells the sun */
    const struct sp_depop_sun *clock_sun;
} sp_depop_settings;

SP_PRIVATE void sp_depop_default_settings(sp_depop_settings *s);
/* 1 when the object's cast shadow (as sp_depop_mask found it) is closed: its tip is its end. */
SP_PRIVATE int sp_depop_closed_shadow(const sp_depop_object *o);
/*
 * 1 when the object stands whole in the image, as a person or a pole does: not touching the image's edge
 * (its foot or top may be outside) and not wider than tall (a car's shadow does not start at its box's
 * bottom middle). Only such objects tell the sun and get the sun's strip.
 */
int sp_depop_standing(const sp_depop_object *o);
/*
 * The removal mask of n objects in an RGB24 image: each object's mask (or
 * box), a pixel of dilation for its anti-aliased edge, its contact shadow
 * (dark ground right at the foot) and its cast shadow (dark, chromaticity-
 * keeping ground connected to the foot, in the sun's direction when known).
 * Writes mask (width x height; 1 object, 2 shadow) and each object's shadow
 * figures. -EINVAL for bad arguments, -ENOMEM.
 */
SP_PRIVATE int sp_depop_mask(const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, sp_depop_object *objs,
                  size_t n, const sp_depop_settings *s, uint8_t *mask);

/*
 * Each box object's own silhouette (depop_segment.c): GrabCut inside the box, holes and the rows it left
 * empty closed, grown by 3% of the box height (at least a pixel), the box's lowest fifth whole (where it meets
 * the ground); a cut under a twentieth or over 95% of the box keeps the whole box. Objects
 * that came with a mask keep it. masks (image-sized) is cleared and gets the union of the silhouettes;
 * each box object's mask points to it (masks must outlive objs' use). *segmented: how many boxes were cut.
 * SP_EMODULE where OpenCV is not built or cannot be loaded (no object changed), -EINVAL, -ENOMEM.
 */
SP_PRIVATE int sp_depop_segment(const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride,
                                sp_depop_object *objs, size_t n, uint8_t *masks, size_t *segmented);

/*
 * Objects and their shadows from a clean plate (a probe directory's): the
 * probe's own segmentation of the image against the plate (plane may be
 * NULL). Objects whose box holds one of the n_keep points keep (x, y pairs)
 * stay. Up to `cap` objects to remove go to objs (their boxes; mask NULL);
 * mask gets 1 on their pixels and 2 on their shadows, a pixel of dilation
 * included; *n is how many there are, *kept how many stayed. -EINVAL, -ENOMEM.
 */
SP_PRIVATE int sp_depop_from_plate(const uint8_t *rgb, const uint8_t *plate, uint32_t width, uint32_t height,
                        const sp_probe_plane *plane, const double *keep, size_t n_keep, sp_depop_object *objs,
                        size_t cap, size_t *n, size_t *kept, uint8_t *mask);

/*
 * The lit band of a luma histogram of n pixels: its 70th to 95th percentile
 * levels (a shadow or a dark road may cover most of the pixels; a bright
 * stray is rare), into *lo and *hi.
 */
void sp_depop_lit_band(const uint32_t hist[256], uint32_t n, int *lo, int *hi);

/* 1 when one of the n_keep points (x, y pairs) lies in the box x0..x1, y0..y1. */
SP_PRIVATE int sp_depop_keeps(const double *keep, size_t n_keep, int x0, int y0, int x1, int y1);

/* ---- the sun from one image (depop_sun.c) ---- */

/* A pinhole camera without roll looking pitch_deg below the horizon; the ground plane below it. */
typedef struct sp_depop_camera {
    double f, cx, cy;  /* focal length and principal point, pixels */
    double pitch_deg;  /* 0..89 */
} sp_depop_camera;

typedef struct sp_depop_sun {
    int found;              /* 0: no object cast a usable shadow ("no sun shadows") */
    double azimuth_deg;     /* from the camera's horizontal view direction towards its right, -180..180 */
    double elevation_deg;
    unsigned used;          /* objects whose shadow gave a direction */
    double azimuth_spread_deg, elevation_spread_deg; /* median absolute deviations over them */
    int closed; /* 1: from closed shadows (tips that are their ends); 0: no shadow was closed,
                               the answer is from open ones, whose tips may be dark ground's */
} sp_depop_sun;

/*
 * The sun from the objects' cast shadows as sp_depop_mask found them: each
 * shadow's foot and tip back-projected onto the ground, the object's height
 * from its box top on the vertical through the foot; azimuth from the
 * shadow's direction, elevation from height over length; medians over the
 * objects. Objects touching the image's edge or wider than tall give none;
 * open shadows only when no shadow is closed. -EINVAL for a bad camera.
 */
SP_PRIVATE int sp_depop_sun_estimate(const sp_depop_object *objs, size_t n, const sp_depop_camera *cam, sp_depop_sun *out);

/*
 * The camera's ground geometry, everything in camera heights (the camera one
 * unit above the ground, looking along +y, x to its right, z up): the ground
 * point under pixel (u, v) (-1 at or above the horizon); the pixel of world
 * point p (-1 behind the camera); the height of the point on the vertical
 * through ground point g that projects to row v (NaN when none does).
 */
int sp_depop_ground_point(const sp_depop_camera *cam, double u, double v, double g[2]);
int sp_depop_project(const sp_depop_camera *cam, const double p[3], double *u, double *v);
double sp_depop_height_at(const sp_depop_camera *cam, const double g[2], double v);
#endif
