/* SPDX-License-Identifier: MIT */
/*
 * Synthetic rotating-selfie captures with ground truth (SunStage-style): a
 * morphable head with a procedural skin albedo and specular clusters, lit by a
 * sun and an analytic sky, seen by a phone camera held at arm's length by a
 * person turning in place (the fake IMU's motion). Writes a real .spcap
 * (MJPEG or RGB24 frames, IMU batches, landmark and orientation side data,
 * META) plus a ground-truth directory with held-out relit and novel-view
 * frames. Everything is deterministic given the settings (seed included).
 * Conventions, files and defaults: pipeline/synth/SYNTH.md.
 *
 * World frame: the fake IMU's (z up, the person turns about z through the
 * origin, the head's turning axis). Cameras are OpenCV pinholes as in
 * sp_render_camera (x_cam = R x_world + t, x right, y down, z forward).
 */
#ifndef SUNPROBE_SP_SYNTH_H
#define SUNPROBE_SP_SYNTH_H

#include <signal.h>
#include <stdint.h>

#include "sp_common.h"
#include "sp_face_model.h"
#include "sp_fake_camera.h"
#include "sp_fake_imu.h"
#include "sp_math.h"
#include "sp_render.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Writes an 8-bit image (channels 1 or 3, rows `stride` bytes apart); 0 or a negative error. */
typedef int (*sp_synth_image_writer)(const char *path, const uint8_t *pixels, uint32_t width, uint32_t height,
                                     uint32_t stride, int channels);

enum sp_synth_face_source {
    SP_SYNTH_FACE_AUTO = 0,    /* sp_face_model_load_default: ICT when its folder exists, else generic */
    SP_SYNTH_FACE_GENERIC = 1, /* the built-in generic head (fast, no data files) */
    SP_SYNTH_FACE_ICT = 2,     /* ICT only: -ENOENT (log names tools/fetch-ict-facekit.sh) without it */
};

/* What the background pixels show (the head is lit by the sky's environment map either way). */
enum sp_synth_backdrop {
    SP_SYNTH_BACKDROP_SKY = 0,  /* the environment map itself: smooth, nothing to track (default) */
    SP_SYNTH_BACKDROP_CITY = 1, /* a procedural city panorama at infinity (buildings, windows, paved ground),
                                   shaded by the sky: corners all round for rotation-only tracking */
};

/* Smallest finite backdrop_distance_m: the camera must stay inside the city's sphere. */
#define SP_SYNTH_BACKDROP_MIN_DISTANCE_M 2.0

enum sp_synth_frame_format {
    SP_SYNTH_FORMAT_AUTO = 0,  /* MJPEG when the build has libjpeg, else RGB24 */
    SP_SYNTH_FORMAT_MJPEG = 1, /* SP_EDISABLED (naming -Djpeg) without libjpeg */
    SP_SYNTH_FORMAT_RGB24 = 2,
};

typedef struct sp_synth_selfie_settings {
    /* camera */
    uint32_t width, height;   /* frame size; default 320 x 320 (16..4096) */
    double fps;               /* default 30 */
    double focal_ratio;       /* fx = fy = focal_ratio * width; default 0.8 (a phone's ~26 mm-equivalent) */
    enum sp_synth_frame_format format; /* default AUTO */
    int jpeg_quality;         /* 1..100, default 90 */
    double shutter_s;         /* exposure time; default 1/240 s, at most one frame interval */
    int motion_blur_samples;  /* sub-frame renders averaged over the shutter; default 1 = off (1..64) */
    double noise;             /* sensor noise scale: 0 = off, 1 = default phone-like shot + read noise */
    /* exposure: x = exposure * radiance, display = (x / (1 + x))^(1/2.2) */
    double exposure;          /* initial exposure; 0 = meter the first frame (default) */
    int auto_exposure;        /* 1: the camera meters each frame and adapts with a lag (default); 0: fixed */
    double ae_speed;          /* fraction of the log-exposure error corrected per frame; default 0.15 */
    double ae_drift;          /* random walk of log exposure per frame (std); default 0.01 */
    /* motion, IMU noise and bias: the fake IMU, used as given (its own seed sets the sway and IMU noise) */
    sp_fake_imu_settings imu; /* defaults: sp_fake_imu_default_settings with arm_radius_m 0.5 */
    int no_imu;               /* 1: the capture holds no IMU samples and its META no "imu" (the motion and the
                                 true-orientation side data stay); default 0 */
    double camera_height_m;   /* camera above the face centre (added to the fake IMU's position); default 0 */
    double head_wobble_deg;   /* head rotation relative to the body (slow sway); default 1 */
    /* face */
    enum sp_synth_face_source face; /* default AUTO */
    const sp_face_model *model; /* non-NULL overrides `face`; borrowed until sp_synth_selfie_close */
    double identity_sigma;    /* identity coefficients ~ N(0, sigma^2), clamped to +-2.5 sigma; default 0.7 */
    double expression_max;    /* expression coefficients ~ U(0, max); default 0.15 */
    uint32_t albedo_height;   /* albedo texture rows (width follows the model's UV aspect); default 512 */
    /* lighting */
    double sun_elevation_deg; /* default 35 */
    double sun_azimuth_deg;   /* from world +x towards +y; default 150 */
    /* the sun from the clock: with utc_start (ISO 8601 with a zone) and latitude/longitude (degrees), the sun
       stands where the ephemeris puts it in the middle of the capture (common/SOLAR.md; the two angles above
       are replaced), world +x is magnetic north, the fake IMU has a magnetometer, and META says all three
       (magnetic_declination_deg 0); default "" and NaN: off */
    char utc_start[40];
    double latitude, longitude;
    double sun_intensity;     /* white irradiance at normal incidence; default 3 */
    double sky_intensity;     /* scale of the analytic sky radiance; default 1 */
    int overcast;             /* 1: sun 0, bright grey overcast sky; default 0 */
    enum sp_synth_backdrop backdrop; /* background pixels; default SKY (the head's lighting never changes) */
    /* CITY only: 0 = at infinity (default: the background moves with the camera's rotation alone); a distance
       D >= SP_SYNTH_BACKDROP_MIN_DISTANCE_M puts the panorama on a sphere of radius D about the turning axis
       (the world origin), so the arm's motion adds parallax. The camera must stay inside the sphere: D also
       has to exceed hypot(imu.arm_radius_m, camera_height_m) */
    double backdrop_distance_m;
    /* renderer */
    int supersample;          /* S x S samples per pixel; default 2 */
    int shadow_size;          /* default 512 */
    /* held-out evaluation frames (truth directory only) */
    int n_relit;              /* frames of capture poses under other suns; default 6 (0..64) */
    int n_novel;              /* frames from cameras the capture never had; default 6 (0..64) */
    uint64_t seed;            /* default 1 */
    sp_synth_image_writer write_image; /* PNG writer (tools pass sp_png_write); NULL: binary PPM/PGM files */
    int progress;             /* progress bar on stderr: 1 on, 0 off, -1 when a terminal (default 0) */
    /* Polled between frames: non-zero stops sp_synth_selfie_write with -ECANCELED, nothing left (a signal flag). */
    const volatile sig_atomic_t *cancel;
} sp_synth_selfie_settings;

typedef struct sp_synth_selfie sp_synth_selfie;

/* Ground truth that does not change per frame; all arrays owned by the generator. */
typedef struct sp_synth_selfie_truth {
    const sp_face_model *model;
    const double *identity;    /* model->n_id */
    const double *expression;  /* model->n_exp */
    double model_center[3];    /* model-frame point placed on the turning axis at the camera's height */
    sp_render_texture albedo;  /* linear RGB, row 0 at the top (v = 1) */
    double ks[SP_RENDER_CLUSTERS];
    double shininess[SP_RENDER_CLUSTERS];
    const float *env;          /* SP_RENDER_ENV_FLOATS radiance values */
    double sun_dir_world[3];   /* unit, towards the sun */
    double sun_intensity;      /* 0 when overcast */
    double fx, fy, cx, cy;     /* intrinsics of every frame */
    uint64_t n_frames;
    double initial_exposure;   /* exposure of frame 0 (metered or given); held-out frames use it */
} sp_synth_selfie_truth;

/* Per-frame truth at the instant the frame shows (the middle of its exposure). */
typedef struct sp_synth_frame_truth {
    uint64_t index;
    int64_t timestamp_ns;      /* exposure start: the FRAME chunk's timestamp */
    int64_t pose_ns;           /* timestamp_ns + shutter / 2: the pose below */
    sp_render_camera camera;   /* intrinsics and world -> camera */
    sp_quat camera_to_world;
    sp_vec3 camera_position;   /* world metres */
    double head_rotvec[3], head_t[3], head_s; /* face pose (sp_face_params) into the world */
    double sun_dir_camera[3];  /* unit, camera axes */
    double exposure;           /* the frame's exposure; NaN before sp_synth_selfie_write decided it */
    float landmarks[2 * SP_FACE_N_LANDMARKS]; /* pixels, u0 v0 u1 v1 ... (Multi-PIE order) */
} sp_synth_frame_truth;

/* What sp_synth_selfie_write produced. */
typedef struct sp_synth_selfie_report {
    uint64_t frames;
    uint64_t imu_samples;
    uint64_t capture_bytes;
    uint64_t heldout_frames;
    double seconds;            /* wall time of the write */
} sp_synth_selfie_report;

SP_API void sp_synth_selfie_default_settings(sp_synth_selfie_settings *s);

/*
 * Loads the face model, draws the appearance from the seed and builds the
 * albedo, sky and renderer. s is copied (s->model stays borrowed). *out is
 * owned by the caller (sp_synth_selfie_close). -EINVAL for bad settings (a
 * log line names the field), -ENOENT for SP_SYNTH_FACE_ICT without the data.
 */
SP_API int sp_synth_selfie_open(sp_synth_selfie **out, const sp_synth_selfie_settings *s);
/* Frees everything and sets *g = NULL; accepts NULL and half-built generators. */
SP_API void sp_synth_selfie_close(sp_synth_selfie **g);

/* The constant truth; owned by g, valid until it is closed. */
SP_API const sp_synth_selfie_truth *sp_synth_selfie_get_truth(const sp_synth_selfie *g);
/* Truth of frame `index` (< n_frames) into caller storage. */
SP_API int sp_synth_selfie_frame_truth(const sp_synth_selfie *g, uint64_t index, sp_synth_frame_truth *out);

/*
 * Renders frame `index` noise-free at its pose instant with the given exposure
 * (<= 0: the frame's own once written, else the initial one). *out views
 * renderer buffers (the component decomposition), valid until the next call on g.
 */
SP_API int sp_synth_selfie_render_frame(sp_synth_selfie *g, uint64_t index, double exposure,
                                        sp_render_outputs *out);

/*
 * Writes the capture to `capture_path` (through "<capture_path>.partial",
 * renamed when complete; an existing file is replaced) and, when truth_dir is
 * non-NULL, the ground-truth directory (created if needed, files replaced).
 * Paths borrowed; report (may be NULL) filled on success. SP_EDISABLED for
 * MJPEG without libjpeg, -errno for file errors.
 */
SP_API int sp_synth_selfie_write(sp_synth_selfie *g, const char *capture_path, const char *truth_dir,
                                 sp_synth_selfie_report *report);

/*
 * A contact sheet of a written capture: `n_frames` frames decoded from the
 * file (evenly spaced) then the component decomposition of frame
 * `component_frame` (final, diffuse, specular, ambient, visibility, normals,
 * albedo, mask), tiles `columns` wide. *rgb (packed RGB24, caller frees with
 * free()) and its size are returned. SP_EDISABLED for MJPEG frames without libjpeg.
 */
SP_API int sp_synth_selfie_contact_sheet(sp_synth_selfie *g, const char *capture_path, int n_frames,
                                         uint64_t component_frame, int columns, uint8_t **rgb,
                                         uint32_t *width, uint32_t *height);

/* ---- street: a static camera watching people walk past occluders (`sunprobe synth street`) ---- */

#define SP_SYNTH_STREET_MAX_FIGURES 64
#define SP_SYNTH_STREET_MAX_CARS 16

/*
 * A pinhole camera above a ground plane, static occluders at known depths, an unseen wall whose shadow is
 * pre-existing shadow, walking figures of known height, cars on the road behind them, a sun casting shadows
 * (or an overcast sky).
 * Ground truth beside the capture (PREFIX = the capture path without ".spcap"): PREFIX.truth.json,
 * PREFIX.background.png (.ppm without an image writer) and 16-bit PGMs PREFIX.hidden-far / hidden-near /
 * seen-far / hidden-count.pgm (pipeline/synth/SYNTH.md). Deterministic for the settings (seed included).
 */
typedef struct sp_synth_street_settings {
    uint32_t width, height;   /* frame size; default 320 x 240 (32..4096) */
    double fps;               /* default 10 (1..240) */
    double seconds;           /* duration; default 40 (0.01..36000) */
    unsigned figures;         /* walking figures; default 10 (0..SP_SYNTH_STREET_MAX_FIGURES) */
    uint64_t seed;            /* default 1 */
    int overcast;             /* 1: no sun, no shadows; default 0 */
    double sun_azimuth_deg;   /* from the view direction towards the right; default -30 (front left) */
    double sun_elevation_deg; /* default 40 (5..85) */
    double pan_deg_s;         /* camera turn rate (a moving camera, for bad-input tests); default 0 (-90..90) */
    double camera_height_m;   /* default 4 (0.5..50) */
    double pitch_deg;         /* downwards; default 15 (0..60) */
    double hfov_deg;          /* horizontal field of view; default 45 (10..120) */
    double linger_s;          /* every other figure stops once for 5 s up to this long; default 0: nobody */
    double noise;             /* sensor noise, standard deviation in 8-bit levels; default 0 (0..64) */
    unsigned cars;            /* cars driving past behind the walkers; default 0 (0..SP_SYNTH_STREET_MAX_CARS) */
    int jpeg_quality;         /* frames stored as MJPEG at this quality (1..100, libjpeg); default 0: RGB24 */
    int indoor;               /* 1: a hall: back wall, wooden floor, furniture as the occluders, no sun */
    sp_synth_image_writer write_image; /* the background PNG (tools pass sp_png_write); NULL: binary PPM */
    int progress;             /* progress bar on stderr: 1 on, 0 off (default), -1 when a terminal */
    /* Polled between frames: non-zero stops sp_synth_street_write with -ECANCELED, nothing left. */
    const volatile sig_atomic_t *cancel;
} sp_synth_street_settings;

typedef struct sp_synth_street_report {
    uint64_t frames;
    unsigned figures, cars;
} sp_synth_street_report;

SP_API void sp_synth_street_default_settings(sp_synth_street_settings *s);
/*
 * Writes the capture and its truth files as one set: all of them replace any previous ones, or none
 * does. -EINVAL for bad settings (a log line names the field), -ECANCELED, -errno for file errors.
 */
SP_API int sp_synth_street_write(const sp_synth_street_settings *s, const char *capture_path,
                                 sp_synth_street_report *report);

/* ---- turn: a person turning in place, fake camera + fake IMU (`sunprobe synth turn`) ---- */

typedef struct sp_synth_turn_settings {
    sp_fake_camera_settings camera; /* default: sp_fake_camera_default_settings, panorama pattern */
    sp_fake_imu_settings imu;       /* default: sp_fake_imu_default_settings (its seed sets the noise) */
    int sync_every_chunk;           /* 1: fdatasync after every chunk; default 0 (periodic) */
    int progress;                   /* progress bar on stderr: 1 on, 0 off (default), -1 when a terminal */
    /* Polled between frames: non-zero stops sp_synth_turn_write with -ECANCELED, nothing left. */
    const volatile sig_atomic_t *cancel;
} sp_synth_turn_settings;

SP_API void sp_synth_turn_default_settings(sp_synth_turn_settings *s);
/*
 * Writes the capture: frames of a panorama at the true heading, the IMU samples between them and the
 * true camera orientation of every frame as side data (SP_SIDE_TRUE_ORIENTATION), through
 * "<capture_path>.partial" renamed when complete (an existing file is replaced; kept on any error).
 */
SP_API int sp_synth_turn_write(const sp_synth_turn_settings *s, const char *capture_path);

#ifdef __cplusplus
}
#endif
#endif
