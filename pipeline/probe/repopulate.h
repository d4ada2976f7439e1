/* SPDX-License-Identifier: MIT */
/*
 * Repopulating a street from one image (pipeline/probe/REPOPULATE.md): the
 * lighting a cut-out was shot under and a scene's, how well they match (the
 * thesis' dot product of sun directions, and the ground's brightness), the
 * cut-out sidecar JSON, and the camera-plane geometry that scales an inserted
 * person and casts its shadow along the sun. Internal, not installed.
 */
#ifndef SUNPROBE_PIPELINE_PROBE_REPOPULATE_H
#define SUNPROBE_PIPELINE_PROBE_REPOPULATE_H

#include <stddef.h>
#include <stdint.h>

#include "common/json.h"
#include "depopulate.h"
#include "sunprobe/sp_probe.h"
#include "common/private_api.h"

typedef enum sp_repop_sky { SP_REPOP_UNKNOWN = 0, SP_REPOP_SUNNY = 1, SP_REPOP_OVERCAST = 2 } sp_repop_sky;

typedef struct sp_repop_light {
    sp_repop_sky sky;
    double sun_az_deg, sun_el_deg; /* SUNNY: relative to the camera, as sp_depop_sun */
    double ground_rgb[3];          /* lit ground reference in 8-bit levels; all 0: unknown */
} sp_repop_light;

/* The probe's scale model takes a person to be this tall (probe.c); a cut-out without a real height is one. */
#define SP_REPOP_PERSON_HEIGHT_M 1.7

/* A cut-out's sidecar: the person is the PNG's opaque content, its foot the content's bottom middle. */
typedef struct sp_cutout_meta {
    char image[256];       /* the PNG's file name, beside the sidecar */
    double height_px;      /* the person's height in the cut-out, pixels */
    double height_m;       /* its real height, metres (0.2..10); 0: not given, a person of the scene's height */
    double foot_x, foot_y; /* the foot point in the cut-out, pixels */
    sp_repop_light light;  /* of the image it came from */
} sp_cutout_meta;

/* Appends the sidecar as JSON (fields in REPOPULATE.md); source (may be NULL) says where it came from. */
SP_PRIVATE void sp_cutout_meta_json(const sp_cutout_meta *m, const char *source, sp_strbuf *b);
/*
 * Parses a sidecar; SP_ECORRUPT with a sentence naming the field in err
 * (err_size bytes) for bad JSON, a missing field, a number that is not
 * finite or out of range, or an unknown sky.
 */
SP_PRIVATE int sp_cutout_meta_parse(const char *json, size_t len, sp_cutout_meta *out, char *err, size_t err_size);

/*
 * How well a cut-out's lighting matches the scene's, -1..1: both sunny, the
 * cosine between the two sun directions; both overcast 1; one sunny and one
 * overcast -1; either unknown 0. gain (may be NULL) gets the per-channel
 * scale that takes the cut-out's ground to the scene's (1 where unknown),
 * within 0.25..4.
 */
SP_PRIVATE double sp_repop_match(const sp_repop_light *scene, const sp_repop_light *cut, double gain[3]);

/*
 * The lit ground of an image: the mean colour between the 70th and 95th luma
 * percentiles of its lower half, pixels where mask != 0 (may be NULL) left
 * out. -1 when fewer than 64 pixels are left.
 */
SP_PRIVATE int sp_repop_ground_light(const uint8_t *rgb, uint32_t width, uint32_t height, const uint8_t *mask, double out[3]);

/* The pixel height of a person H camera heights tall standing at foot pixel (x, y); NaN above the horizon. */
SP_PRIVATE double sp_repop_height_px(const sp_depop_camera *cam, double H, double x, double y);
/* The median height (camera heights) of the objects standing on the ground; NaN when none gives one. */
SP_PRIVATE double sp_repop_people_height(const sp_depop_object *objs, size_t n, const sp_depop_camera *cam);
/*
 * The image offset, per pixel of height, of a shadow cast by the sun (az, el
 * as sp_depop_sun) of a person h_px tall at foot (x, y): where the head's
 * shadow falls is foot + h_px (dx, dy). -1 when the sun is too low (under 2
 * degrees) or the geometry fails.
 */
SP_PRIVATE int sp_repop_shadow_offset(const sp_depop_camera *cam, double az_deg, double el_deg, double x, double y, double h_px,
                           double *dx, double *dy);
/*
 * The sun in the camera's frame from a probe's shadow model (the head's
 * shadow tip of a person at ground points of the lower image half,
 * back-projected through the camera); found 0 when no model was learned.
 */
SP_PRIVATE int sp_repop_sun_from_model(const sp_probe_shadow *sh, const sp_probe_plane *plane, uint32_t width, uint32_t height,
                            const sp_depop_camera *cam, sp_depop_sun *out);
#endif
