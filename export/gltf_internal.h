/* SPDX-License-Identifier: MIT */
/* Shared pieces of the face exporter (gltf*.c): glTF-ready geometry, baked textures, writers. */
#ifndef SUNPROBE_EXPORT_GLTF_INTERNAL_H
#define SUNPROBE_EXPORT_GLTF_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "common/file_set.h"
#include "sunprobe/sp_export.h"
#include "sunprobe/sp_face_model.h"
#include "sunprobe/sp_render.h"
#include "sunprobe/sp_sunstage.h"

/* One glTF vertex per distinct (position, UV) corner pair; glTF frame (y up), glTF UVs (v down). */
typedef struct sp_gltf_geom {
    uint32_t n_vertices, n_triangles;
    float *positions, *normals, *uvs; /* 3, 3, 2 floats per vertex; owned */
    float *tangents;                  /* 4 per vertex (xyz along +u, w = handedness for +v up); owned */
    uint32_t *indices;                /* 3 per triangle; owned */
    uint32_t *source;                 /* per vertex: the face mesh's position index; owned */
    float min[3], max[3];             /* position bounds */
} sp_gltf_geom;

/* Fit world (z up) to glTF (y up): (x, y, z) -> (x, z, -y), a proper rotation. */
void sp_gltf_from_world(const double w[3], double g[3]);
/*
 * Fit world -> exported scene, g = R w + t (R row-major): the y-up mapping, then
 * a turn about +y by whole environment columns (2 pi / SP_RENDER_ENV_W, so the
 * map is re-indexed, not resampled) that points the face (towards keyframe 0's
 * camera) along +z within half a column; t puts the head's bounding-box centre
 * at the origin.
 */
typedef struct sp_gltf_placement {
    double R[9], t[3];
} sp_gltf_placement;

void sp_gltf_placement_init(sp_gltf_placement *p, const sp_mesh *m, const sp_render_camera *key0);
/* g = R w (+ t when point). */
void sp_gltf_place(const sp_gltf_placement *p, const double w[3], double g[3], int point);
/* SP_ECORRUPT for a mesh with NaN/Inf or bad indices, -ENOMEM. Vertices placed by p. */
int sp_gltf_geom_build(sp_gltf_geom *g, const sp_mesh *m, const sp_gltf_placement *p);
void sp_gltf_geom_free(sp_gltf_geom *g);
/*
 * One primitive of the head mesh with its material: the skin (textured), and where the fit's face
 * model has them (EXPORT.md, "Eyes and mouth") eye_sclera, eye_iris, mouth_interior and teeth, each a
 * constant colour.
 */
typedef struct sp_gltf_prim {
    char name[24];             /* also the material's name */
    const sp_gltf_geom *geom;  /* own, or the whole mesh's (borrowed) */
    sp_gltf_geom own;
    float *deltas;             /* morph offsets, n_targets * geom->n_vertices * 3, or NULL; owned */
    float colour[3];           /* linear base colour (not the skin's) */
    float roughness;
    char note[200];            /* where the colour comes from */
} sp_gltf_prim;
#define SP_GLTF_MAX_PRIMS 5

/*
 * The fit's face model applied to the export (gltf_morph.c, gltf_parts.c): its expressions as morph
 * targets (per glTF vertex, the position offset of each mode at full strength, in the exported frame)
 * and the head split into primitives. n_targets 0 / one primitive with a reason when the face
 * directory or the model on this machine cannot give them.
 */
#define SP_GLTF_MAX_TARGETS 64
typedef struct sp_gltf_morphs {
    uint32_t n_targets;
    char names[SP_GLTF_MAX_TARGETS][32];
    double fitted[SP_GLTF_MAX_TARGETS]; /* the expression the mesh was written with (keyframe 0's) */
    int reorder;                        /* the primitives' vertices are reordered (--reorder) */
    uint32_t n_prims;                   /* >= 1: prims[0] is the skin */
    sp_gltf_prim prims[SP_GLTF_MAX_PRIMS];
    char reason[400];                   /* why there are no targets */
    char eyes_reason[400], mouth_reason[400]; /* why there are no eye / mouth primitives, "" when there are */
} sp_gltf_morphs;
/* 0 (with or without targets and parts) or -ENOMEM. whole: the whole mesh (borrowed, kept alive by the caller). */
int sp_gltf_morphs_build(sp_gltf_morphs *mo, const char *face_dir, const sp_face_asset *a, const sp_gltf_geom *whole,
                         const sp_gltf_placement *p, int want_parts, int reorder);
/* Drops the morph targets, keeps the primitives. */
void sp_gltf_morphs_drop_targets(sp_gltf_morphs *mo);
void sp_gltf_morphs_free(sp_gltf_morphs *mo);

/* The fit's parameters: what sp_face_model_eval needs, from the manifest and keyframe 0. */
typedef struct sp_gltf_fit {
    char model[128];
    double id[256], exp[SP_GLTF_MAX_TARGETS], rotvec[3], t[3], s, c2w[9];
    size_t n_id, n_exp;
} sp_gltf_fit;
/*
 * Splits the skin mesh into skin and eye primitives and adds the mouth interior, posed with f
 * (gltf_parts.c). mo->prims[0] must be the whole mesh; model is the fit's (borrowed). Sets the
 * reasons for what it cannot add. 0 or -ENOMEM.
 */
int sp_gltf_parts_build(sp_gltf_morphs *mo, const char *face_dir, const sp_face_asset *a,
                        const sp_face_model *model, const sp_gltf_fit *f, const sp_gltf_placement *p);
/* Per vertex of g (g->source indexes model): mode k's offset at strength 1, exported frame; caller frees. */
float *sp_gltf_fill_deltas(uint32_t n_targets, const sp_face_model *m, const sp_gltf_fit *f,
                           const sp_gltf_geom *g, const sp_gltf_placement *p);
/* Vertices of model evaluated with f, in the fit world (keyframe 0's camera at the origin); caller frees. */
double *sp_gltf_fit_eval(const sp_face_model *model, const sp_gltf_fit *f);

typedef struct sp_export_image {
    int width, height, channels; /* packed rows, row 0 = top */
    uint8_t *pixels;             /* owned */
} sp_export_image;

typedef struct sp_export_textures {
    sp_export_image albedo;    /* RGB, sRGB-encoded */
    sp_export_image spec_rough; /* RGBA: G = roughness, B = metallic 0, A = specular strength */
    sp_export_image normal;    /* RGB tangent-space normal map */
    int has_specular, has_normal;
} sp_export_textures;

/*
 * size: longest edge (0 = as fitted). left_out: SP_FACE_LEFT_OUT_* bits of the
 * face (sp_face_asset.left_out): SPECULAR leaves the specular texture out,
 * DISPLACEMENT the normal map.
 */
int sp_export_textures_build(sp_export_textures *t, const sp_face_asset *a, int size, unsigned left_out);
void sp_export_textures_free(sp_export_textures *t);
/*
 * A w x h map of nc (1..4) float channels resampled to ow x oh with a Mitchell-Netravali filter (widened
 * when shrinking, edges clamped): what the export does to the fit's linear albedo and displacement.
 * Caller frees; NULL when out of memory or nc is out of range.
 */
float *sp_export_resample(const float *map, int w, int h, int nc, int ow, int oh);
/* Blinn-Phong exponent -> glTF roughness (EXPORT.md): alpha = sqrt(2 / (s + 2)), roughness = sqrt(alpha). */
double sp_export_roughness(double shininess);
/* Cluster specular intensity -> KHR_materials_specular strength in [0, 1] (EXPORT.md). */
double sp_export_specular(double ks);

/*
 * The fit's environment map (renderer layout, fit world) as the equirectangular
 * map of Blender and three.js in the frame g = R w (R row-major, a rotation from
 * the fit world): row i at polar angle (i + 0.5) pi / H from +y, column j at
 * u = (j + 0.5) / W = 0.5 + atan2(g.z, g.x) / 2 pi. Nearest texel: exact when R
 * turns texel centres onto texel centres (the y-up mapping, turns by whole columns).
 * env and out: SP_RENDER_ENV_FLOATS each.
 */
void sp_export_env_equirect(const float *env, const double R[9], float *out);
/* Radiance RGBE (.hdr), run-length-free scanlines, written atomically. rgb: w*h*3 linear floats, row 0 = top. */
int sp_hdr_write(const char *path, const float *rgb, int width, int height);

/*
 * `--reorder` (gltf_reorder.c): triangles in vertex-cache order, vertices in first-use order (all
 * arrays, source included). SP_EDISABLED without meshoptimizer.
 */
int sp_gltf_geom_reorder(sp_gltf_geom *g);
/* Average cache miss ratio of g's triangles (16-entry FIFO; 0 without meshoptimizer). */
double sp_gltf_geom_acmr(const sp_gltf_geom *g);

/* Writes the OBJ + MTL + PNG variant (gltf_obj.c) under temporary names added to fs (committed by the caller). */
int sp_export_write_obj(const char *out_path, sp_file_set *fs, const sp_gltf_geom *g, const sp_export_textures *t,
                        sp_export_stats *st);

#endif
