/* SPDX-License-Identifier: MIT */
/*
 * A probe directory: what `sunprobe probe` writes and `sunprobe composite`
 * reads. clean_plate.png; occlusion.pfm and occlusion_confidence.pfm (1 channel) and
 * lighting.pfm (RGB), the exact float maps (occlusion and lighting also as .exr where OpenImageIO is built), with .png
 * previews; probe.json, the plane and shadow models.
 * PFM is the portable float map: "Pf" (gray) or "PF" (RGB), width height, -1
 * (little-endian), rows bottom to top.
 */
#ifndef SUNPROBE_EXPORT_PROBE_DIR_H
#define SUNPROBE_EXPORT_PROBE_DIR_H

#include <stdint.h>

#include "sunprobe/sp_probe.h"
#include "common/private_api.h"

/* Writes a finished probe's outputs into `dir` (which must exist); every file atomically, probe.json last. */
SP_PRIVATE int sp_probe_dir_write(const char *dir, const sp_probe *p);

typedef struct sp_probe_dir {
    uint32_t width, height;
    uint8_t *clean_plate; /* RGB24 */
    float *occlusion, *lighting;
    float *occlusion_confidence; /* NULL: the directory has none (written before it existed) */
    sp_probe_plane plane;
    sp_probe_shadow shadow;
} sp_probe_dir;

/* Loads a probe directory (everything owned by *out; free with sp_probe_dir_free). */
SP_PRIVATE int sp_probe_dir_load(const char *dir, sp_probe_dir *out);
SP_PRIVATE void sp_probe_dir_free(sp_probe_dir *d);
/* The maps of a loaded directory as borrowed views. */
SP_PRIVATE sp_probe_maps sp_probe_dir_maps(const sp_probe_dir *d);

/* PFM with 1 or 3 channels; values row-major top to bottom in memory. */
SP_PRIVATE int sp_pfm_write(const char *path, const float *v, uint32_t width, uint32_t height, int channels);
/* *v is malloc'd; SP_EFORMAT when not a PFM, SP_ECORRUPT/SP_ETRUNCATED when damaged. */
int sp_pfm_read(const char *path, float **v, uint32_t *width, uint32_t *height, int *channels);

#endif
