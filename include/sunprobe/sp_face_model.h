/* SPDX-License-Identifier: MIT */
/*
 * The morphable face model: a mean head mesh with UV seams, linear identity and
 * expression bases, 68 landmark vertices (Multi-PIE order), a per-vertex face
 * mask and a UV map of ten specular clusters. Models come from the ICT Face
 * Model Light (read at run time, never shipped) or from the built-in generic
 * head, and are stored in the project's ".spface" file (pipeline/face/FACE_MODEL.md).
 *
 * Frames: the model frame is right-handed, metres, +x towards the subject's
 * left, +y up, +z out of the face (the nose points along +z). Evaluation maps it
 * into a caller frame ("world", or the camera frame for landmark projection):
 *     v = s * R(r) * (mean + B_id a + B_exp e) + t
 * with R(r) the rotation by |r| radians about the rotation vector r.
 */
#ifndef SUNPROBE_SP_FACE_MODEL_H
#define SUNPROBE_SP_FACE_MODEL_H

#include <stddef.h>
#include <stdint.h>

#include "sp_common.h"
#include "sp_mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SP_FACE_N_LANDMARKS 68
#define SP_FACE_N_CLUSTERS 10
#define SP_FACE_CLUSTER_NONE 255 /* cluster-map texel covered by no triangle */

/* Parts of the head mesh, per vertex (sp_face_model.part). */
enum {
    SP_FACE_PART_SKIN = 0, /* face, head and neck */
    SP_FACE_PART_EYE = 1,  /* an eyeball: its own albedo texels (a corner of the atlas) and the eye clusters */
    SP_FACE_N_PARTS
};
#define SP_FACE_NAME_LEN 32      /* bytes per expression name, NUL included */
#define SP_FACE_PARAM_LIMIT 1e6  /* |coefficient|, |s|, |t|, |r| above this are rejected */

/* Specular clusters; "left"/"right" are the subject's own sides (left = +x). */
enum sp_face_cluster {
    SP_FACE_CLUSTER_FOREHEAD = 0,
    SP_FACE_CLUSTER_NOSE = 1,
    SP_FACE_CLUSTER_LEFT_CHEEK = 2,
    SP_FACE_CLUSTER_RIGHT_CHEEK = 3,
    SP_FACE_CLUSTER_CHIN = 4,
    SP_FACE_CLUSTER_LIPS = 5, /* lips and the upper-lip skin */
    SP_FACE_CLUSTER_LEFT_EYE = 6,
    SP_FACE_CLUSTER_RIGHT_EYE = 7,
    SP_FACE_CLUSTER_JAW_NECK = 8, /* jaw sides, under the chin, neck */
    SP_FACE_CLUSTER_OTHER = 9,    /* remaining skin: temples, ears, scalp */
};

/* All arrays are owned by the model and freed by sp_face_model_free. */
typedef struct sp_face_model {
    sp_mesh mesh;        /* mean shape, model frame, metres */
    uint32_t n_id;       /* identity modes */
    uint32_t n_exp;      /* expression modes */
    float *id_basis;     /* n_id * n_vertices * 3: mode k, vertex i at [(k * n_vertices + i) * 3] */
    float *exp_basis;    /* n_exp * n_vertices * 3, same layout */
    char *exp_names;     /* n_exp * SP_FACE_NAME_LEN, each NUL-terminated (e.g. "jawOpen") */
    uint32_t landmarks[SP_FACE_N_LANDMARKS]; /* vertex indices, Multi-PIE 68-point order */
    uint8_t *face_mask;  /* n_vertices, 1 = skin fitted by SunStage, 0 = elsewhere */
    uint8_t *part;       /* n_vertices, SP_FACE_PART_*: what a vertex belongs to (all skin for older files) */
    uint32_t cluster_width, cluster_height;
    uint8_t *cluster_map; /* width * height cluster ids, row 0 is the top (v = 1) */
    char source[128];    /* NUL-terminated provenance, e.g. "generic-head v1" */
} sp_face_model;

/* Identity modes are scaled so coefficients have a unit-variance prior; expressions are in [0, 1]. */

/* Allocates zeroed arrays (model is overwritten); free with sp_face_model_free. */
SP_API int sp_face_model_alloc(sp_face_model *model, uint32_t n_vertices, uint32_t n_uvs,
                               uint32_t n_triangles, uint32_t n_id, uint32_t n_exp,
                               uint32_t cluster_width, uint32_t cluster_height);
/* Frees the arrays and zeroes the struct; safe on a zeroed or half-built model. */
SP_API void sp_face_model_free(sp_face_model *model);
/* 0 if sizes, indices, values (finite, mask 0/1, cluster ids) and names are consistent, else SP_ECORRUPT. */
SP_API int sp_face_model_validate(const sp_face_model *model);
/* Name of expression mode k (static "" when out of range). */
SP_API const char *sp_face_model_exp_name(const sp_face_model *model, uint32_t k);

/* ---- files (format: pipeline/face/FACE_MODEL.md) ---- */

/* Writes atomically (temporary file + rename). model borrowed; it must validate. */
SP_API int sp_face_model_write(const sp_face_model *model, const char *path);
/*
 * Reads a file into *model (overwritten; caller frees). Returns SP_EFORMAT (not
 * a face-model file), SP_EVERSION (newer format), SP_ETRUNCATED, SP_ECORRUPT
 * (checksum, sizes, indices, NaN) or -errno; on error *model is zeroed.
 */
SP_API int sp_face_model_read(sp_face_model *model, const char *path);
/* Same from memory; data borrowed for the call. */
SP_API int sp_face_model_read_memory(sp_face_model *model, const void *data, size_t size);

/* ---- sources ---- */

/*
 * Builds the built-in generic head (coarser than ICT: ~4.8k vertices, ~9.5k
 * triangles, 6 identity and 3 expression modes), with no data files.
 */
SP_API int sp_face_model_generic(sp_face_model *model);

typedef struct sp_face_ict_settings {
    const char *dir;           /* ICT FaceXModel folder; NULL: sp_face_ict_dir(). Borrowed. */
    uint32_t max_identity;     /* read identity000.. up to this many (default 30; 0 = none) */
    uint32_t target_triangles; /* decimate to about this many; 0 = keep all (default 10000) */
    int keep_eyeballs;         /* keep the eyeball meshes (default 1; 0: the eye openings are holes) */
    uint32_t cluster_width;    /* cluster map size (default 512 x 256: ICT's UVs span two tiles) */
    uint32_t cluster_height;
} sp_face_ict_settings;

SP_API void sp_face_ict_default_settings(sp_face_ict_settings *settings);
/*
 * The ICT data folder: $SP_ICT_FACEKIT_DIR when set, else the first of $XDG_DATA_HOME/sunprobe/ict-facekit,
 * each $XDG_DATA_DIRS entry's sunprobe/ict-facekit, the install prefix's share/sunprobe/ict-facekit that
 * holds generic_neutral_mesh.obj, else ../shared/face-models/ict-facekit beside the source tree.
 * Thread-local storage, valid until the thread's next call; never NULL.
 */
SP_API const char *sp_face_ict_dir(void);
/*
 * Imports the ICT model: crop to face, head and neck, triangulate, centimetres to
 * metres, identity and expression differences, decimation, landmarks, regions.
 * Returns -ENOENT (with a logged hint naming tools/fetch-ict-facekit.sh) when the
 * data is missing, SP_ECORRUPT for malformed OBJ files.
 */
SP_API int sp_face_model_import_ict(sp_face_model *model, const sp_face_ict_settings *settings);

typedef struct sp_face_load_settings {
    const char *ict_dir;       /* NULL: sp_face_ict_dir(). Borrowed. */
    const char *cache_path;    /* NULL: $XDG_CACHE_HOME or ~/.cache + /sunprobe/face-ict-<n>.spface */
    uint32_t target_triangles; /* default 10000 */
    int use_cache;             /* default 1 */
} sp_face_load_settings;

SP_API void sp_face_load_default_settings(sp_face_load_settings *settings);
/*
 * The ICT model (decimated, from the cache when it matches, else imported and
 * cached) when the ICT folder exists, else the generic head; logs which at INFO
 * and model->source says which. Fails only on memory errors or a broken ICT folder.
 */
SP_API int sp_face_model_load(sp_face_model *model, const sp_face_load_settings *settings);
SP_API int sp_face_model_load_default(sp_face_model *model);

/* ---- evaluation and gradients ---- */

/* Coefficients and pose; all borrowed. */
typedef struct sp_face_params {
    const double *id;  /* n_id coefficients, NULL = all zero */
    const double *exp; /* n_exp coefficients, NULL = all zero */
    double rotvec[3];  /* rotation vector r (radians) */
    double t[3];       /* translation, metres */
    double s;          /* uniform scale */
} sp_face_params;

/* Zero coefficients, identity pose, s = 1. */
SP_API void sp_face_params_init(sp_face_params *params);

/* v for every vertex into out (3 * n_vertices doubles, caller-owned). -EINVAL for non-finite or out-of-limit params. */
SP_API int sp_face_model_eval(const sp_face_model *model, const sp_face_params *params, double *out);
/*
 * Same in float. For the renderer: sp_mesh world = model->mesh; world.positions = out;
 * (triangles and UVs are shared, still owned by the model).
 */
SP_API int sp_face_model_eval_float(const sp_face_model *model, const sp_face_params *params, float *out);

/* Gradient of a scalar loss; id/exp are caller arrays (n_id / n_exp), NULL to skip. */
typedef struct sp_face_grad {
    double *id;
    double *exp;
    double rotvec[3];
    double t[3];
    double s;
} sp_face_grad;

/*
 * Adjoint of sp_face_model_eval: given dL/dv (3 * n_vertices doubles, one
 * triple per vertex in the output frame, e.g. sp_render_grads.positions;
 * borrowed), OVERWRITES grad with dL/da, dL/de, dL/dr, dL/dt and dL/ds at params.
 */
SP_API int sp_face_model_eval_adjoint(const sp_face_model *model, const sp_face_params *params,
                                      const double *dl_dv, sp_face_grad *grad);

/*
 * Pinhole camera as in sp_render_camera: OpenCV convention (looks along +z,
 * +x right, +y down in the image), x_cam = R x_world + t.
 */
typedef struct sp_face_camera {
    double fx, fy, cx, cy; /* pixels */
    double R[9];           /* world -> camera rotation, row-major */
    double t[3];           /* world -> camera translation, metres */
} sp_face_camera;

/* Sets the intrinsics and an identity pose (world = camera frame). */
SP_API void sp_face_camera_init(sp_face_camera *camera, double fx, double fy, double cx, double cy);

/*
 * Marks the vertices of the cranium (above the brows, and beside the face down to the ears' lobes:
 * the temples, the ears; outside face_mask) in scalp (n_vertices bytes, caller-owned): where a bald
 * head's outline is, or hair covers it.
 * Returns 0 or a negative error.
 */
SP_API int sp_face_model_scalp(const sp_face_model *model, uint8_t *scalp);

/* Columns of the landmark Jacobian: id (n_id), exp (n_exp), rotvec (3), t (3), s (1). */
SP_API uint32_t sp_face_model_n_params(const sp_face_model *model);

/*
 * Projects the 68 landmark vertices: params map the model into the world,
 * camera maps the world into the camera frame, (u, v) = (fx X/Z + cx, fy Y/Z + cy)
 * with X, Y, Z camera coordinates. uv: 136 doubles (u0 v0 u1 v1 ...). valid
 * (68 bytes, may be NULL) gets 0 for a landmark with Z < 1e-6 m, whose uv is
 * (cx, cy) and whose Jacobian rows are zero. jac (may be NULL): 136 x n_params
 * row-major, derivatives with respect to the face params. All caller-owned. Returns the number of valid landmarks or a negative error.
 */
SP_API int sp_face_model_project_landmarks(const sp_face_model *model, const sp_face_params *params,
                                           const sp_face_camera *camera, double *uv, uint8_t *valid,
                                           double *jac);

#ifdef __cplusplus
}
#endif
#endif
