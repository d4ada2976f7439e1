/* SPDX-License-Identifier: MIT */
/*
 * Texture transfer onto a probed scene's ground (the thesis' §5.4.2, classical):
 * a texture laid on the ground plane in perspective, its scale from the
 * probe's plane model, multiplied by the plate's own shading so shadows stay.
 * pipeline/probe/RETEXTURE.md.
 */
#ifndef SUNPROBE_PIPELINE_PROBE_RETEXTURE_H
#define SUNPROBE_PIPELINE_PROBE_RETEXTURE_H

#include <stdint.h>

#include "sunprobe/sp_probe.h"
#include "common/private_api.h"

#define SP_RETEXTURE_PERSON_M 1.7 /* the nominal person height the plane model's pixel heights stand for */

typedef struct sp_retexture_settings {
    double metres;    /* the texture's width on the ground in metres, default 1 */
    double focal_px;  /* focal length in pixels; 0 (default): the image width (about 53 degrees across) */
    double shading_m; /* the shading's low-pass radius on the ground in metres, default 0.15 */
} sp_retexture_settings;

typedef struct sp_retexture_report {
    uint64_t pixels;      /* pixels replaced */
    double lit[3];        /* the lit ground's linear colour, the shading's 1 */
    double near_px_per_m; /* texture scale at the nearest and farthest replaced pixel */
    double far_px_per_m;
} sp_retexture_report;

SP_PRIVATE void sp_retexture_default_settings(sp_retexture_settings *s);

/*
 * The default ground: pixels where the plane gives a person at least 2 pixels
 * tall (below the horizon) and the occlusion map (NULL: none) never saw anyone
 * hidden (Z < 0). region (w x h) is written 1 / 0. SP_ENODATA when the plane is
 * not a full plane (plane->note says why).
 */
SP_PRIVATE int sp_retexture_ground(const sp_probe_plane *plane, const float *occlusion, uint32_t w, uint32_t h,
                        uint8_t *region);

/*
 * out (w x h RGB24) = plate where region is 0; elsewhere the texture (tw x th
 * RGB float in [0, 1], sRGB-encoded, repeated) seen on the ground plane, times
 * the plate's shading there. All buffers borrowed. 0, -EINVAL, -ENOMEM, or
 * SP_ENODATA when the plane is not a full plane or region holds no ground.
 */
SP_PRIVATE int sp_retexture(const uint8_t *plate, uint32_t w, uint32_t h, const sp_probe_plane *plane, const uint8_t *region,
                 const float *tex, uint32_t tw, uint32_t th, const sp_retexture_settings *s, uint8_t *out,
                 sp_retexture_report *rep);

#endif
