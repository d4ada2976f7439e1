/* SPDX-License-Identifier: MIT */
/*
 * Exports a fitted face directory (sp_sunstage.h, pipeline/sunstage/SUNSTAGE.md)
 * as a relightable asset: binary glTF 2.0 (optionally Draco-compressed), OBJ +
 * MTL + PNGs, or a raw Draco mesh. Conventions and mappings: export/EXPORT.md.
 */
#ifndef SUNPROBE_SP_EXPORT_H
#define SUNPROBE_SP_EXPORT_H

#include <signal.h>
#include <stddef.h>
#include <stdint.h>

#include "sp_common.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum sp_export_format {
    SP_EXPORT_GLB = 0, /* one .glb (+ FILE.env.hdr beside it) */
    SP_EXPORT_OBJ,     /* FILE.obj + FILE.mtl + FILE_*.png (+ FILE.env.hdr) */
    SP_EXPORT_DRC,     /* raw Draco mesh (needs Draco) */
} sp_export_format;

typedef struct sp_export_settings {
    sp_export_format format; /* default SP_EXPORT_GLB */
    int draco;          /* GLB: 1 = KHR_draco_mesh_compression (default 1 when built with Draco, else 0) */
    int jpeg;           /* GLB: embed the albedo as JPEG instead of PNG (default 0; needs libjpeg) */
    int jpeg_quality;   /* 1..100 (default 90) */
    int texture_size;   /* longest texture edge in pixels, 16..8192; 0 = as fitted (default 512) */
    int position_bits;  /* Draco quantisation, 1..30 (default 14) */
    int normal_bits;    /* 1..30 (default 10) */
    int uv_bits;        /* 1..30 (default 12) */
    int write_env;      /* write the environment map as FILE.env.hdr (default 1) */
    int draco_expressions; /* GLB + Draco: keep the vertex order (sequential encoding, larger) and write the
                              expressions' morph targets (default 0: Draco leaves them out) */
    int reorder;        /* triangles in vertex-cache order, vertices in fetch order (default 0; needs meshoptimizer) */
    /* when not NULL and non-zero (a signal handler sets it) before the files are put in place, the export
       stops with -ECANCELED and leaves nothing of its own (borrowed; default NULL) */
    const volatile sig_atomic_t *cancel;
} sp_export_settings;

/* What was written; filled by sp_export_face when not NULL. */
typedef struct sp_export_stats {
    uint32_t vertices, triangles;    /* glTF vertices (position+UV pairs) and triangles */
    size_t raw_geometry_bytes;       /* positions, normals, UVs and u32 indices uncompressed */
    size_t geometry_bytes;           /* as stored (Draco buffer or raw) */
    size_t total_bytes;              /* the main output file */
    int has_specular_texture, has_normal_map, has_sun;
    uint32_t morph_targets;          /* expression morph targets written (plain GLB only) */
    size_t morph_bytes;              /* their sparse indices and offsets */
    double acmr;                     /* skin triangles' average cache miss ratio, 16-entry FIFO (0: no meshoptimizer) */
} sp_export_stats;

SP_API void sp_export_default_settings(sp_export_settings *settings);

/*
 * Reads face_dir and writes out_path (borrowed strings) in settings->format.
 * Every file is written under a temporary name and renamed into place, so a
 * failure never leaves a half-written file under its final name. Returns 0,
 * -EINVAL (arguments), SP_EFORMAT/SP_ECORRUPT/SP_ETRUNCATED (a bad face
 * directory: missing or corrupt map, NaN in the mesh), SP_EDISABLED (Draco or
 * JPEG asked for in a build without them; the message names the meson option),
 * or -errno from the file system. Messages go to sp_log.
 */
SP_API int sp_export_face(const char *face_dir, const char *out_path, const sp_export_settings *settings,
                          sp_export_stats *stats);

#ifdef __cplusplus
}
#endif
#endif
