/* SPDX-License-Identifier: MIT */
/* Shared state and cross-file helpers of the selfie generator (pipeline/synth). Not installed. */
#ifndef SUNPROBE_SYNTH_INTERNAL_H
#define SUNPROBE_SYNTH_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "common/file_util.h"
#include "sunprobe/sp_synth.h"

#define SYNTH_MAX_CAPS 3
#define BG_STEP 4 /* pixels between background lookups */

/* Deterministic random streams (splitmix64); separate streams keep options from shifting each other's draws. */
enum synth_stream {
    SYNTH_STREAM_FACE = 1,
    SYNTH_STREAM_LOOK = 2,
    SYNTH_STREAM_NOISE = 3,
    SYNTH_STREAM_AE = 4,
    SYNTH_STREAM_BACKDROP = 5,
};

typedef struct synth_city synth_city; /* synth_backdrop.c */

/* What the city shows at one pixel corner (synth.c): enum synth_city_part, colour, haze. */
typedef struct synth_city_sample {
    float rgb[3];
    float haze;
    uint8_t part;
    uint8_t need; /* a background pixel has this corner */
} synth_city_sample;

typedef struct synth_rng {
    uint64_t state;
    int have_spare;
    double spare;
} synth_rng;

void synth_rng_init(synth_rng *r, uint64_t seed, uint64_t stream, uint64_t index);
uint64_t synth_rng_u64(synth_rng *r);
double synth_rng_uniform(synth_rng *r); /* in (0, 1) */
double synth_rng_gauss(synth_rng *r);
/* A stateless hash to [0, 1) of three lattice coordinates and a seed (for noise fields). */
double synth_hash3(int64_t x, int64_t y, int64_t z, uint64_t seed);

/* A hole of the model (eye or mouth opening) closed by a fan for rendering only. */
enum synth_cap_kind { SYNTH_CAP_RIGHT_EYE = 0, SYNTH_CAP_LEFT_EYE = 1, SYNTH_CAP_MOUTH = 2 };

typedef struct synth_cap {
    enum synth_cap_kind kind;
    uint32_t n;           /* rim vertices */
    uint32_t *rim;        /* 2n: model vertex indices in loop order, then their UV indices */
    uint32_t first;       /* render-mesh index of the rim duplicates; the centre follows them */
    double offset_m;      /* centre moved along the face's forward axis (negative = recessed) */
} synth_cap;

/* The drawn appearance, recorded in the manifest. */
typedef struct synth_look {
    double tone;          /* 0 light .. 1 dark */
    double skin[3];       /* base linear albedo */
    double hair[3];
    double iris[3];
    double freckles;      /* 0 .. 1 */
    double redness;       /* cheek redness 0 .. 1 */
    uint64_t noise_seed;
} synth_look;

/* Face frame of the mean shape (from landmarks): origin, axes, unit length. */
typedef struct synth_face_frame {
    double o[3], x[3], y[3], z[3];
    double unit;
} synth_face_frame;

struct sp_synth_selfie {
    sp_synth_selfie_settings s;
    sp_face_model own_model;
    const sp_face_model *model;
    double *id, *exp;
    double center[3];
    synth_face_frame ff;
    synth_look look;
    /* render mesh: the model's triangles and UVs plus the caps */
    sp_mesh mesh;
    synth_cap caps[SYNTH_MAX_CAPS];
    int n_caps;
    /* materials and lighting */
    float *albedo;
    int aw, ah;
    double ks[SP_RENDER_CLUSTERS], shininess[SP_RENDER_CLUSTERS];
    float env[SP_RENDER_ENV_FLOATS];
    double sun_dir[3];
    double sun_intensity;
    double ground_albedo;
    /* camera and timing */
    double fx, fy, cx, cy;
    uint64_t n_frames;
    double initial_exposure;
    double *frame_exposure; /* n_frames, NaN until written */
    sp_renderer *r;
    sp_synth_selfie_truth truth;
    /* scratch */
    double *linear;         /* 3 * w * h exposed linear values */
    uint8_t *rgb;           /* 3 * w * h display bytes */
    double *bg_grid;        /* sky behind the head every BG_STEP pixels: (w / BG_STEP + 2) * (h / BG_STEP + 2) * 3 */
    /* the city backdrop (NULL for the sky), the sky at the horizon of each bg_grid point's azimuth, the city
       at the pixels' corners: (w + 1) * (h + 1) */
    synth_city *city;
    double *horizon_grid;
    synth_city_sample *city_corner;
};

/* A rendering pose: camera and the head's face params. */
typedef struct synth_pose {
    sp_render_camera cam;
    sp_quat cam_to_world;
    sp_vec3 cam_pos;
    double rotvec[3], t[3];
    double R_head[9];
} synth_pose;

/* ---- synth.c ---- */
/* Pose of the capture at motion time t_ns (camera from the fake IMU truth, head following the body yaw). */
int synth_pose_at(const sp_synth_selfie *g, int64_t t_ns, synth_pose *p);
/* Camera at `pos` looking at world point `target` with world +z up. */
void synth_look_at(const sp_synth_selfie *g, sp_vec3 pos, sp_vec3 target, synth_pose *p);
/* Renders a pose with the given sun and env (NULL: the capture's); out views renderer buffers. */
int synth_render_pose(sp_synth_selfie *g, const synth_pose *p, const double sun_dir[3], double sun_intensity,
                      const float *env, double exposure, sp_render_outputs *out);
/*
 * Adds weight * (radiance + (1 - coverage) * env(view ray)) of a render into lin (3 doubles per pixel):
 * the distant world behind the head is the environment map seen along each pixel's ray.
 */
void synth_accumulate(const sp_synth_selfie *g, const synth_pose *p, const sp_render_outputs *o, const float *env,
                      double weight, double *lin);
/* Display value of an exposed linear value: (x / (1 + x))^(1/2.2), 0 for x <= 0. */
double synth_display(double x);
/* Quantises display values in [0, 1] to bytes. */
uint8_t synth_to_byte(double v);
/* Tone-maps exposed linear RGB (3 * n doubles) into bytes (rounded display values, by a threshold table). */
void synth_linear_to_rgb(const double *linear, size_t n, uint8_t *rgb);
/* The 68 landmarks of a pose, pixels. */
int synth_landmarks(const sp_synth_selfie *g, const synth_pose *p, float out[2 * SP_FACE_N_LANDMARKS]);

/* ---- synth_look.c: appearance and materials ---- */
void synth_draw_look(sp_synth_selfie *g);
void synth_draw_materials(sp_synth_selfie *g);
int synth_face_frame_init(const sp_face_model *m, synth_face_frame *ff);

/* ---- synth_mesh.c: the render mesh ---- */
/* Finds the eye and mouth openings and builds the render mesh (model + caps). */
int synth_build_mesh(sp_synth_selfie *g);
/* Places the caps' vertices for the model positions in the mesh; R_head NULL = model frame. */
void synth_place_caps(sp_synth_selfie *g, const double R_head[9], double scale);

/* ---- synth_albedo.c ---- */
/* Paints the albedo texture (needs the render mesh at the mean shape). */
int synth_build_albedo(sp_synth_selfie *g);

/* ---- synth_sky.c ---- */
/* World direction towards the sun. */
void synth_sun_direction(double elevation_deg, double azimuth_deg, double out[3]);
/* Fills a 16x32 env map: clear sky around the sun direction, or overcast; plus ground bounce. */
void synth_build_env(const sp_synth_selfie_settings *s, const double sun_dir[3], double sun_intensity,
                     double ground_albedo, float *env);
/* Bilinear radiance of the env map in a world direction (unit). */
void synth_env_lookup(const float *env, const double dir[3], double rgb[3]);

/* ---- synth_backdrop.c: the city panorama at infinity (--backdrop city) ---- */
enum synth_city_part { SYNTH_CITY_SKY = 0, SYNTH_CITY_FACADE = 1, SYNTH_CITY_GROUND = 2 };
/* Draws the panorama of a seed (its own random stream). *out: synth_city_free. */
int synth_city_build(uint64_t seed, synth_city **out);
void synth_city_free(synth_city **c);
/*
 * What world direction d (unit) shows for a pixel px_rad radians across (details smaller than ~2 pixels
 * fade to their mean): the part, its reflectance-like colour (1 for the sky) and how much of it is haze
 * (0..1, the weight of the horizon sky's colour in front of it).
 */
enum synth_city_part synth_city_look(const synth_city *c, const double d[3], double px_rad, double rgb[3],
                                     double *haze);

/* ---- synth_capture.c ---- */
int synth_write_capture(sp_synth_selfie *g, const char *path, const char *truth_rel, sp_synth_selfie_report *rep,
                        sp_partial *partial);

/* ---- synth_truth.c ---- */
int synth_write_truth(sp_synth_selfie *g, const char *dir, const char *capture_name, sp_synth_selfie_report *rep);
/* Writes an 8-bit image through the settings' writer, else as PPM/PGM; `stem` gets the extension. */
int synth_write_image(const sp_synth_selfie *g, const char *dir, const char *stem, const uint8_t *px, uint32_t w,
                      uint32_t h, int channels, char *name, size_t name_size);

#endif
