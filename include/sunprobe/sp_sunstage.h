/* SPDX-License-Identifier: MIT */
/*
 * SunStage fitting: from a rotating-selfie stream (frames + IMU + landmarks) to
 * face geometry, skin reflectance, sun and sky, and per-frame cameras.
 * Streaming front end (one event at a time, bounded keyframe reservoir), then
 * a two-stage fit (landmark alignment, photometric) with one of two solvers.
 * Method, memory bound and face-directory layout: pipeline/sunstage/SUNSTAGE.md.
 */
#ifndef SUNPROBE_SP_SUNSTAGE_H
#define SUNPROBE_SP_SUNSTAGE_H

#include <stdint.h>

#include "sp_common.h"
#include "sp_face_model.h"
#include "sp_math.h"
#include "sp_render.h"
#include "sp_source.h"

#ifdef __cplusplus
extern "C" {
#endif

enum sp_sunstage_solver {
    SP_SUNSTAGE_SOLVER_FAST = 0, /* closed-form albedo, least squares lighting, sun search, Gauss-Newton pose */
    SP_SUNSTAGE_SOLVER_ADAM = 1, /* reference: Adam on every parameter through the renderer adjoint */
};

typedef struct sp_sunstage_settings {
    enum sp_sunstage_solver solver; /* default FAST */
    int keyframes;          /* training reservoir: one frame per camera-yaw bin (default 12, 2..64) */
    int heldout;            /* held-out reservoir bins (default 3, 0..16) */
    int fit_width;          /* fit image width: the face crop's side, or the whole frame's width (default 128) */
    int face_crop;          /* 1: fit a square crop around the face (1.8x the landmarks' extent), resampled to
                               fit_width; 0: the whole frame box-downsampled to fit_width (default 0) */
    int texture_size;       /* albedo/displacement height; width doubles for two-tile UVs (default 128); 0: matched
                               to the data after stage 1 (one texel per face pixel, SUNSTAGE.md) */
    int adam_iterations;    /* Adam steps (default 300) */
    double time_budget_s;   /* stop the photometric stage after this wall time; 0 = none (default 0) */
    double min_rotation_deg; /* yaw range below which lighting is called unobservable (default 90) */
    double blur_ratio;      /* skip frames sharper than this fraction of the running mean (default 0.35) */
    const char *dlib_model; /* shape predictor path; NULL = /usr/share/dlib/... Borrowed. */
    int use_dlib;           /* 1: detect landmarks when a frame carries none (default 1) */
    double silhouette_weight; /* silhouette loss per outline vertex, px^2 (landmarks: 1); 0 = off (default 0.5) */
    int refine_steps;       /* fast solver: Adam steps refining pose, expression, shape and displacement
                               photometrically after the solve, kept only if the held-out PSNR rises;
                               0 = off (default 20) */
    int threads;            /* worker threads of the solvers, the caller included; 0 = the online CPUs (default 0).
                               The result does not depend on it. */
    int fixed_exposure;     /* 0 (default): when no frame gives its exposure (a phone's video, its auto-exposure
                               unrecorded), the fast solver estimates each keyframe's and, when that pays, solves
                               again (the Adam solver never estimates); 1: such frames are all at exposure 1 */
} sp_sunstage_settings;

/* What the front end kept and skipped. */
typedef struct sp_sunstage_counts {
    uint64_t frames, imu_samples;
    uint64_t skipped_dark, skipped_saturated, skipped_blurred, skipped_no_face, skipped_no_orientation;
    uint64_t accepted;  /* passed every check (then competed for a reservoir slot) */
    int keyframes, heldout; /* slots filled */
    uint64_t thinned_early; /* dropped by the orientation tagger while its filter initialised (sp_frame_tags) */
    uint64_t skipped_undecodable; /* damaged image data (a warning names each frame) */
} sp_sunstage_counts;

/* Progress of the fit, passed to the callback (borrowed for the call). */
typedef struct sp_sunstage_progress {
    const char *stage; /* "align", "photometric", "landmarks" (the model fitted to every tracked frame) */
    int iteration, total;
    double seconds;     /* wall time since the fit started */
    double loss;        /* training photometric loss (display values, masked L2) or landmark RMS px */
    double heldout_psnr; /* dB on held-out frames, NaN when not measured */
} sp_sunstage_progress;

/* Called during sp_sunstage_fit; returning non-zero stops the fit early (the result stays usable). */
typedef int (*sp_sunstage_callback)(void *user, const sp_sunstage_progress *p);

/* The fitted face; every pointer is owned by the sp_sunstage and valid until it is closed. */
typedef struct sp_sunstage_result {
    const sp_face_model *model;  /* borrowed model given at open */
    const double *id;            /* n_id identity coefficients */
    double scale;                /* shared model scale */
    int tex_width, tex_height;
    const float *albedo;         /* tex_width * tex_height * 3 linear albedo */
    const float *displacement;   /* tex_width * tex_height metres along the normal */
    double ks[SP_RENDER_CLUSTERS], shininess[SP_RENDER_CLUSTERS];
    const float *env;            /* SP_RENDER_ENV_FLOATS, world frame (z up) */
    double sun_dir[3];           /* unit, world frame, towards the sun */
    double sun_intensity;        /* 0 when the sun was dropped */
    int sun_dropped;             /* overcast: no sun, shadows or specular */
    int lighting_unobservable;   /* too little rotation: lighting not fitted (env only, neutral) */
    const char *notes;           /* NUL-terminated, human-readable reasons for the two flags */
    double yaw_range_deg;        /* camera yaw covered by the keyframes */
    int n_frames;                /* keyframes fitted */
    double train_psnr, heldout_psnr; /* dB, display values on the face mask; NaN if unknown */
    double seconds;              /* fit wall time */
    /* wall time per phase: the front end's per-frame work while streaming, stage-1 alignment, the photometric
       solve, its refinement */
    double frontend_seconds, align_seconds, solve_seconds, refine_seconds;
    int threads;                 /* solver threads used */
    /* the sun from the clock (utc_start, location and a known north; common/SOLAR.md): */
    int have_clock_sun;
    double clock_sun_dir[3];     /* unit, world frame */
    double clock_sun_angle_deg;  /* to the fitted sun; NaN when there is none of either */
} sp_sunstage_result;

/* One fitted keyframe camera: the face in the camera frame and the camera in the world. */
typedef struct sp_sunstage_frame {
    uint64_t sequence;
    int64_t timestamp_ns;
    double fx, fy, cx, cy;  /* fit-resolution pixels */
    int width, height;      /* fit resolution */
    double scale_to_capture; /* capture pixels per fit pixel */
    double crop_x, crop_y;  /* capture pixel position of the fit image's top-left corner (0, 0 without a crop) */
    sp_quat camera_to_world;
    double rotvec[3], t[3]; /* face pose in the camera frame */
    const double *exp;      /* n_exp expression coefficients (owned by the fitter) */
    int heldout;
} sp_sunstage_frame;

typedef struct sp_sunstage sp_sunstage;

SP_API void sp_sunstage_default_settings(sp_sunstage_settings *s);
/* model is borrowed and must outlive the fitter; settings are copied. Caller owns *out. */
SP_API int sp_sunstage_open(sp_sunstage **out, const sp_sunstage_settings *s, const sp_face_model *model);
SP_API void sp_sunstage_close(sp_sunstage **ss);

/*
 * Feeds one event of a tagged stream (sp_tagger.h; borrowed for the call, no
 * reference kept): META events set the intrinsics, frames carry their camera
 * orientation and landmarks in ev->tags. Returns 0, -EINVAL for an untagged
 * frame, or a negative error for a broken frame.
 */
SP_API int sp_sunstage_push(sp_sunstage *ss, const sp_event *ev);
/* The end of the stream (nothing waits in the front end; kept for the stage contract). */
SP_API int sp_sunstage_end_stream(sp_sunstage *ss);

/*
 * Adds one keyframe directly (tests, other front ends): rgb is width * height * 3
 * display values in [0, 1] (borrowed, copied), landmarks 136 pixel coordinates
 * (borrowed), fx..cy intrinsics of that image. Bypasses the quality checks.
 * -EINVAL for bad arguments, or when the settings' keyframes (heldout) slots are all used.
 */
SP_API int sp_sunstage_add_keyframe(sp_sunstage *ss, const float *rgb, int width, int height,
                                    const double landmarks[136], double fx, double fy, double cx, double cy,
                                    sp_quat camera_to_world, int heldout);

SP_API void sp_sunstage_get_counts(const sp_sunstage *ss, sp_sunstage_counts *out);

/*
 * Runs both stages on the reservoir. Returns 0; SP_ENODATA (logged, with the
 * reason) when fewer than 2 keyframes survived or no IMU orientation was seen.
 * cb may be NULL.
 */
SP_API int sp_sunstage_fit(sp_sunstage *ss, sp_sunstage_callback cb, void *user);

/* The current (or final) fit; views owned by ss. */
SP_API int sp_sunstage_get_result(const sp_sunstage *ss, sp_sunstage_result *out);
SP_API int sp_sunstage_n_frames(const sp_sunstage *ss);
SP_API int sp_sunstage_get_frame(const sp_sunstage *ss, int i, sp_sunstage_frame *out);
/* Keyframe i's target image (display values), width * height * 3; owned by ss. */
SP_API const float *sp_sunstage_frame_image(const sp_sunstage *ss, int i);

/*
 * Maps the fit's world frame (IMU world, arbitrary heading) onto the world of
 * the capture's true orientations (SP_SIDE_TRUE_ORIENTATION side data of
 * synthetic captures), averaged over the keyframes that carry one: R
 * (row-major) with x_true = R x_fit. SP_ENODATA when no keyframe has truth.
 */
SP_API int sp_sunstage_align_world(const sp_sunstage *ss, double R[9]);
/* A new view of the fitted face for evaluation (relighting, novel views). All fields borrowed. */
typedef struct sp_sunstage_view {
    double fx, fy, cx, cy;     /* intrinsics of an image with the capture's size */
    sp_quat camera_to_world;   /* in the fit's world */
    const double *landmarks;   /* 136 capture-size pixel coordinates: the face pose is aligned to them */
    double sun_dir[3];         /* fit world; intensity 0 = no sun */
    double sun_intensity;
    const float *env;          /* SP_RENDER_ENV_FLOATS, fit world; NULL = the fitted one */
    double exposure;           /* relative to sp_sunstage_exposure_reference */
} sp_sunstage_view;

/*
 * Renders the view at the fit resolution into rgb (W * H * 3 display values,
 * caller-owned) and the face-skin mask into mask (W * H, may be NULL); W and H
 * from sp_sunstage_get_frame. Returns 0 or a negative error.
 */
SP_API int sp_sunstage_render_view(sp_sunstage *ss, const sp_sunstage_view *v, float *rgb, float *mask);

/* Exposure (exposure_us x gain) that the fit's intensities are relative to; 0 when frames carried none. */
SP_API double sp_sunstage_exposure_reference(const sp_sunstage *ss);
/*
 * A display value of the renderer's encoding (gamma 2.2 of x / (1 + x), what the fit and
 * sp_face_asset_render work in) as the sRGB value of the same linear light, clipped at 1: how an
 * sRGB camera (a face directory's "capture_transfer": "srgb") would have recorded it.
 */
SP_API double sp_sunstage_display_to_srgb(double display);

/*
 * Face directory (layout in SUNSTAGE.md). sp_face_dir_write writes every file
 * of the result into dir (which must exist; borrowed path). Readers get a
 * self-contained asset for relighting; free it with sp_face_asset_free.
 */
SP_API int sp_face_dir_write(const sp_sunstage *ss, const char *dir);

/* What a fit left out (manifest "left_out"); a renderer or exporter should not use those parts. */
enum sp_face_left_out {
    SP_FACE_LEFT_OUT_SUN = 1u << 0,          /* no sun (overcast or lighting unobservable) */
    SP_FACE_LEFT_OUT_SHADOWS = 1u << 1,      /* no cast shadows (they come with the sun) */
    SP_FACE_LEFT_OUT_SPECULAR = 1u << 2,     /* no specular term: ks is 0 */
    SP_FACE_LEFT_OUT_DISPLACEMENT = 1u << 3, /* displacement map not fitted (all zero) */
    SP_FACE_LEFT_OUT_ENVIRONMENT = 1u << 4,  /* sky not resolved: a neutral constant light */
};

typedef struct sp_face_asset {
    sp_mesh mesh;              /* placed in the fit's world (z up) as in keyframe 0, metres; owned */
    int tex_width, tex_height;
    float *albedo, *displacement; /* owned */
    int cluster_width, cluster_height;
    uint8_t *clusters;         /* owned */
    double ks[SP_RENDER_CLUSTERS], shininess[SP_RENDER_CLUSTERS];
    float env[SP_RENDER_ENV_FLOATS]; /* world frame */
    double sun_dir[3], sun_intensity;
    sp_render_camera camera;   /* keyframe 0's camera */
    int width, height;
    unsigned left_out;         /* SP_FACE_LEFT_OUT_* bits */
    int left_out_inferred;     /* 1: an old manifest without "left_out"; bits inferred from ks, sun and maps */
} sp_face_asset;

SP_API int sp_face_dir_read(sp_face_asset *asset, const char *dir);
SP_API void sp_face_asset_free(sp_face_asset *asset);

/*
 * A view of a fitted face: any camera, any placement of the face, any light.
 * What evaluation (against held-out photographs), relighting and new views use.
 * All directions and poses are in one world of the caller's choosing: the
 * asset's own (the fit's world) unless asset_to_world and env_to_world move it.
 */
typedef struct sp_face_view {
    int width, height;         /* output size, pixels */
    int supersample;           /* samples per pixel side, 1..4 (default 2) */
    sp_render_camera camera;   /* intrinsics of the output image and world -> camera */
    double asset_to_world[12]; /* row-major [M | t]: world = M x + t for the asset's vertices x (M a rotation,
                                  possibly times a uniform scale) */
    double sun_dir[3];         /* world, towards the sun */
    double sun_intensity;      /* 0: no sun, no cast shadows */
    double sun_angular_radius; /* radians, 0..pi/2: > 0 a sun disk, soft shadows and highlights (sun_soft_radius) */
    int sun_is_point;          /* 1: the sun is a point light at sun_position (world, metres), sun_intensity at 1 m */
    double sun_position[3];
    const float *env;          /* SP_RENDER_ENV_FLOATS radiance in its own frame; NULL: the asset's (borrowed) */
    double env_to_world[9];    /* rotation (row-major) of the environment into the world */
    double exposure;           /* default 1 */
    const uint8_t *vertex_mask; /* per vertex, 1 = face: `mask` covers only triangles of face vertices (e.g. the
                                   model's face_mask); NULL: the whole mesh (borrowed) */
} sp_face_view;

/* The asset's own view: keyframe 0's camera and size, the mesh where it is, its sun and sky. */
SP_API void sp_face_view_init(sp_face_view *v, const sp_face_asset *asset);
/*
 * Renders the asset in view v: rgb gets width * height * 3 display values (the
 * fit's tone map, comparable with the capture's frames), mask (may be NULL)
 * width * height face coverage in [0, 1]; both caller-owned. Specular follows
 * the asset's left_out flags; cast shadows come with any sun; the mask is the
 * fraction of a pixel's samples on the face (see vertex_mask). -EINVAL for a bad
 * view (size, intrinsics, non-finite pose), -ENOMEM.
 */
SP_API int sp_face_asset_render(const sp_face_asset *asset, const sp_face_view *v, float *rgb, float *mask);
/*
 * The same view as linear radiance (width * height * 3, before exposure and the tone map): what
 * several renders of one view under different lights are summed in (light is additive).
 */
SP_API int sp_face_asset_render_radiance(const sp_face_asset *asset, const sp_face_view *v, float *radiance,
                                         float *mask);
/*
 * One render's decomposition, linear light before exposure, each per pixel and premultiplied by the
 * head's coverage (0 off the head); every buffer caller-owned, NULL to skip it.
 * radiance = diffuse + specular + ambient.
 */
typedef struct sp_face_passes {
    float *radiance;   /* RGB, width * height * 3 */
    float *diffuse;    /* RGB sun diffuse, shadowed */
    float *specular;   /* RGB sun specular, shadowed */
    float *ambient;    /* RGB sky (environment) diffuse */
    float *visibility; /* sun visibility in [0, 1], width * height */
    float *normal;     /* world shading normal xyz, width * height * 3 */
    float *albedo;     /* RGB albedo as sampled */
    float *mask;       /* face coverage as sp_face_asset_render's mask, width * height */
    float *coverage;   /* the whole head's coverage, width * height */
    float *depth;      /* camera-space z (metres) of each pixel's central sample, 0 where it misses the head */
} sp_face_passes;
/* Renders view v into the buffers p names; -EINVAL when p names none, else as sp_face_asset_render. */
SP_API int sp_face_asset_render_passes(const sp_face_asset *asset, const sp_face_view *v, const sp_face_passes *p);
/* The fit's tone map (the display encoding sp_face_asset_render returns) of linear light x >= 0. */
SP_API double sp_sunstage_linear_to_display(double x);

#ifdef __cplusplus
}
#endif
#endif
