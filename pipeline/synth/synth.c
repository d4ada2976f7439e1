/* SPDX-License-Identifier: MIT */
/*
 * The selfie generator's core: settings, open/close, the pose of every frame
 * (camera from the fake IMU's truth, head turning with the body), rendering
 * with the distant-world background, landmarks and the truth getters.
 */
#include "sunprobe/sp_synth.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/jpeg.h"
#include "sunprobe/sp_solar.h"
#include "pipeline/synth/synth_internal.h"

#define DEG (M_PI / 180.0)
#define SYNTH_LOG "synth"

void sp_synth_selfie_default_settings(sp_synth_selfie_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->width = s->height = 320;
    s->fps = 30.0;
    s->focal_ratio = 0.8;
    s->format = SP_SYNTH_FORMAT_AUTO;
    s->jpeg_quality = 90;
    s->shutter_s = 1.0 / 240.0;
    s->motion_blur_samples = 1;
    s->noise = 1.0;
    s->exposure = 0.0;
    s->auto_exposure = 1;
    s->ae_speed = 0.15;
    s->ae_drift = 0.01;
    sp_fake_imu_default_settings(&s->imu);
    s->imu.arm_radius_m = 0.5;
    s->camera_height_m = 0.0;
    s->head_wobble_deg = 1.0;
    s->face = SP_SYNTH_FACE_AUTO;
    s->identity_sigma = 0.7;
    s->expression_max = 0.15;
    s->albedo_height = 512;
    s->sun_elevation_deg = 35.0;
    s->sun_azimuth_deg = 150.0;
    s->utc_start[0] = '\0';
    s->latitude = s->longitude = NAN;
    s->sun_intensity = 3.0;
    s->sky_intensity = 1.0;
    s->supersample = 2;
    s->shadow_size = 512;
    s->n_relit = 6;
    s->n_novel = 6;
    s->seed = 1;
    s->progress = 0;
}

static int in_range(double v, double lo, double hi) { return isfinite(v) && v >= lo && v <= hi; }

/* Returns the name of the first bad field, NULL when all are valid. */
static const char *bad_field(const sp_synth_selfie_settings *s)
{
    if (s->width < 16 || s->width > 4096 || s->height < 16 || s->height > 4096)
        return "width/height (16..4096)";
    if (!in_range(s->fps, 0.1, 1000))
        return "fps (0.1..1000)";
    if (!in_range(s->focal_ratio, 0.05, 20))
        return "focal_ratio (0.05..20)";
    if (s->format < SP_SYNTH_FORMAT_AUTO || s->format > SP_SYNTH_FORMAT_RGB24)
        return "format";
    if (s->jpeg_quality < 1 || s->jpeg_quality > 100)
        return "jpeg_quality (1..100)";
    if (!(in_range(s->shutter_s, 0, 1e3) && s->shutter_s <= 1.0 / s->fps))
        return "shutter_s (0..1/fps)";
    if (s->motion_blur_samples < 1 || s->motion_blur_samples > 64)
        return "motion_blur_samples (1..64)";
    if (!in_range(s->noise, 0, 100))
        return "noise (0..100)";
    if (!in_range(s->exposure, 0, 1e6) || !in_range(s->ae_speed, 0, 1) || !in_range(s->ae_drift, 0, 1))
        return "exposure / ae_speed (0..1) / ae_drift (0..1)";
    if (!in_range(s->imu.arm_radius_m, 0.2, 10))
        return "imu.arm_radius_m (0.2..10: the camera must stay outside the head)";
    if (!in_range(s->camera_height_m, -2, 2) || !in_range(s->head_wobble_deg, 0, 30))
        return "camera_height_m (-2..2) / head_wobble_deg (0..30)";
    if (s->face < SP_SYNTH_FACE_AUTO || s->face > SP_SYNTH_FACE_ICT)
        return "face";
    if (!in_range(s->identity_sigma, 0, 10) || !in_range(s->expression_max, 0, 1))
        return "identity_sigma (0..10) / expression_max (0..1)";
    if (s->albedo_height < 16 || s->albedo_height > 4096)
        return "albedo_height (16..4096)";
    if (!in_range(s->sun_elevation_deg, -90, 90) || !in_range(s->sun_azimuth_deg, -1e4, 1e4))
        return "sun_elevation_deg (-90..90) / sun_azimuth_deg";
    if (!in_range(s->sun_intensity, 0, 1e5) || !in_range(s->sky_intensity, 0, 1e5))
        return "sun_intensity / sky_intensity (0..1e5)";
    if (s->supersample < 1 || s->supersample > 8 || s->shadow_size < 16 || s->shadow_size > 8192)
        return "supersample (1..8) / shadow_size (16..8192)";
    if (s->n_relit < 0 || s->n_relit > 64 || s->n_novel < 0 || s->n_novel > 64)
        return "n_relit / n_novel (0..64)";
    if (s->backdrop < SP_SYNTH_BACKDROP_SKY || s->backdrop > SP_SYNTH_BACKDROP_CITY)
        return "backdrop";
    if (!(s->backdrop_distance_m == 0.0 || in_range(s->backdrop_distance_m, SP_SYNTH_BACKDROP_MIN_DISTANCE_M, 1e9)))
        return "backdrop_distance_m (0 = infinity, or 2..1e9 m: the camera must stay inside the city's sphere)";
    if (s->backdrop_distance_m > 0.0 && !(s->backdrop_distance_m > hypot(s->imu.arm_radius_m, s->camera_height_m)))
        return "backdrop_distance_m (more than the camera's distance from the turning axis, hypot(arm, camera "
               "height): the camera must stay inside the city's sphere)";
    if (s->no_imu < 0 || s->no_imu > 1)
        return "no_imu (0 or 1)";
    return NULL;
}

/* The sun from the clock in the middle of the capture, as the synthetic world's angles (+x magnetic north,
 * here true north too). SP_ENODATA when the sun is below the horizon then, -EINVAL for a bad time/place. */
static int clock_sun(const sp_synth_selfie_settings *s, double *elevation_deg, double *azimuth_deg)
{
    double t;
    sp_sun_position p;
    if (sp_utc_parse(s->utc_start, &t)) {
        sp_log(SP_LOG_ERROR, SYNTH_LOG, "bad setting: utc_start '%s' is not an ISO 8601 time with a zone",
               s->utc_start);
        return -EINVAL;
    }
    if (sp_sun_position_at(t + 0.5 * sp_fake_imu_duration_s(&s->imu), s->latitude, s->longitude, &p)) {
        sp_log(SP_LOG_ERROR, SYNTH_LOG, "bad setting: latitude (-90..90) / longitude (-360..360)");
        return -EINVAL;
    }
    if (p.elevation_deg <= 0.0) {
        sp_log(SP_LOG_ERROR, SYNTH_LOG, "the sun is %.1f deg below the horizon at %s, %.4f, %.4f: a sunlit selfie "
               "needs daylight", -p.elevation_deg, s->utc_start, s->latitude, s->longitude);
        return SP_ENODATA;
    }
    *elevation_deg = p.elevation_deg;
    *azimuth_deg = -p.azimuth_deg;
    return 0;
}

static int check_settings(const sp_synth_selfie_settings *s)
{
    const char *bad = bad_field(s);
    if (bad) {
        sp_log(SP_LOG_ERROR, SYNTH_LOG, "bad setting: %s", bad);
        return -EINVAL;
    }
    double dur = sp_fake_imu_duration_s(&s->imu);
    if (!(dur > 0) || dur * s->fps > 1e7) {
        sp_log(SP_LOG_ERROR, SYNTH_LOG, "bad setting: duration x fps must be in (0, 1e7] frames");
        return -EINVAL;
    }
    sp_quat q;
    if (sp_fake_imu_truth(&s->imu, s->imu.start_ns, NULL, &q) < 0) {
        sp_log(SP_LOG_ERROR, SYNTH_LOG, "bad setting: fake IMU settings rejected");
        return -EINVAL;
    }
    return 0;
}

static int load_model(sp_synth_selfie *g)
{
    if (g->s.model) {
        g->model = g->s.model;
        return sp_face_model_validate(g->model) ? -EINVAL : 0;
    }
    int ret = g->s.face == SP_SYNTH_FACE_GENERIC ? sp_face_model_generic(&g->own_model)
                                                 : sp_face_model_load_default(&g->own_model);
    if (ret)
        return ret;
    g->model = &g->own_model;
    if (g->s.face == SP_SYNTH_FACE_ICT && strncmp(g->own_model.source, "ict", 3) != 0) {
        sp_log(SP_LOG_ERROR, SYNTH_LOG, "the ICT face model is not installed (%s): fetch it with "
               "tools/fetch-ict-facekit.sh", sp_face_ict_dir());
        return -ENOENT;
    }
    return 0;
}

/* Identity ~ N(0, sigma^2) clamped, expressions ~ U(0, max): drawn in a fixed order from the FACE stream. */
static int draw_face(sp_synth_selfie *g)
{
    const sp_face_model *m = g->model;
    g->id = calloc(m->n_id ? m->n_id : 1, sizeof(double));
    g->exp = calloc(m->n_exp ? m->n_exp : 1, sizeof(double));
    if (!g->id || !g->exp)
        return -ENOMEM;
    synth_rng r;
    synth_rng_init(&r, g->s.seed, SYNTH_STREAM_FACE, 0);
    double sig = g->s.identity_sigma, lim = 2.5 * sig;
    for (uint32_t k = 0; k < m->n_id; k++) {
        double a = sig * synth_rng_gauss(&r);
        g->id[k] = a > lim ? lim : a < -lim ? -lim : a;
    }
    for (uint32_t k = 0; k < m->n_exp; k++)
        g->exp[k] = g->s.expression_max * synth_rng_uniform(&r);
    return 0;
}

/* The head's centre on the turning axis: the mesh's x/z box centre at the landmarks' mean height. */
static void head_center(sp_synth_selfie *g)
{
    const sp_mesh *mesh = &g->model->mesh;
    double lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY };
    for (uint32_t i = 0; i < mesh->n_vertices; i++)
        for (int k = 0; k < 3; k++) {
            double v = mesh->positions[(size_t)i * 3 + (size_t)k];
            lo[k] = v < lo[k] ? v : lo[k];
            hi[k] = v > hi[k] ? v : hi[k];
        }
    double y = 0.0;
    for (int l = 0; l < SP_FACE_N_LANDMARKS; l++)
        y += (double)mesh->positions[(size_t)g->model->landmarks[l] * 3 + 1];
    g->center[0] = 0.5 * (lo[0] + hi[0]);
    g->center[1] = y / SP_FACE_N_LANDMARKS;
    g->center[2] = 0.5 * (lo[2] + hi[2]);
}

static int open_renderer(sp_synth_selfie *g)
{
    sp_renderer_settings rs;
    sp_renderer_default_settings(&rs);
    rs.width = (int)g->s.width;
    rs.height = (int)g->s.height;
    rs.supersample = g->s.supersample;
    rs.shadow_size = g->s.shadow_size;
    rs.max_vertices = g->mesh.n_vertices;
    rs.max_triangles = g->mesh.n_triangles;
    return sp_renderer_open(&g->r, &rs);
}

static void fill_truth(sp_synth_selfie *g)
{
    sp_synth_selfie_truth *t = &g->truth;
    t->model = g->model;
    t->identity = g->id;
    t->expression = g->exp;
    memcpy(t->model_center, g->center, sizeof(g->center));
    t->albedo = (sp_render_texture){ g->aw, g->ah, g->albedo };
    memcpy(t->ks, g->ks, sizeof(g->ks));
    memcpy(t->shininess, g->shininess, sizeof(g->shininess));
    t->env = g->env;
    memcpy(t->sun_dir_world, g->sun_dir, sizeof(g->sun_dir));
    t->sun_intensity = g->sun_intensity;
    t->fx = g->fx;
    t->fy = g->fy;
    t->cx = g->cx;
    t->cy = g->cy;
    t->n_frames = g->n_frames;
    t->initial_exposure = g->initial_exposure;
}

static int alloc_buffers(sp_synth_selfie *g)
{
    size_t px = (size_t)g->s.width * g->s.height;
    double dur = sp_fake_imu_duration_s(&g->s.imu);
    g->n_frames = (uint64_t)floor(dur * g->s.fps + 1e-9) + 1;
    g->linear = malloc(px * 3 * sizeof(double));
    g->rgb = malloc(px * 3);
    g->frame_exposure = malloc(g->n_frames * sizeof(double));
    g->bg_grid = malloc(((size_t)g->s.width / BG_STEP + 2) * ((size_t)g->s.height / BG_STEP + 2) * 3 * sizeof(double));
    if (!g->linear || !g->rgb || !g->frame_exposure || !g->bg_grid)
        return -ENOMEM;
    if (g->s.backdrop == SP_SYNTH_BACKDROP_CITY) {
        g->horizon_grid =
            malloc(((size_t)g->s.width / BG_STEP + 2) * ((size_t)g->s.height / BG_STEP + 2) * 3 * sizeof(double));
        g->city_corner = calloc(((size_t)g->s.width + 1) * ((size_t)g->s.height + 1), sizeof(synth_city_sample));
        int ret = g->horizon_grid && g->city_corner ? synth_city_build(g->s.seed, &g->city) : -ENOMEM;
        if (ret)
            return ret;
    }
    for (uint64_t i = 0; i < g->n_frames; i++)
        g->frame_exposure[i] = NAN;
    return 0;
}

/* Exposure that puts the mean luminance of the face's radiance at display 0.45. */
static double metered_exposure(const sp_render_outputs *o, double fallback)
{
    double sum = 0.0, w = 0.0;
    size_t n = (size_t)o->width * (size_t)o->height;
    for (size_t i = 0; i < n; i++) {
        if (!(o->coverage[i] > 0.5f))
            continue;
        const float *c = o->radiance + 3 * i;
        sum += 0.2126 * (double)c[0] + 0.7152 * (double)c[1] + 0.0722 * (double)c[2];
        w += 1.0;
    }
    double lum = w > 0 ? sum / w : 0.0;
    const double target = 0.2086; /* x with (x / (1 + x))^(1/2.2) = 0.45 */
    if (!(lum > 1e-9) || !isfinite(lum))
        return fallback;
    double e = target / lum;
    return e < 1e-4 ? 1e-4 : e > 1e6 ? 1e6 : e;
}

static int initial_exposure(sp_synth_selfie *g)
{
    if (g->s.exposure > 0) {
        g->initial_exposure = g->s.exposure;
        return 0;
    }
    synth_pose p;
    sp_render_outputs out;
    int64_t t0 = g->s.imu.start_ns + (int64_t)llround(0.5 * g->s.shutter_s * 1e9);
    int ret = synth_pose_at(g, t0, &p);
    if (!ret)
        ret = synth_render_pose(g, &p, NULL, 0, NULL, 1.0, &out);
    if (!ret)
        g->initial_exposure = metered_exposure(&out, 1.0);
    return ret;
}

static int open_steps(sp_synth_selfie *g)
{
    int ret = load_model(g);
    if (!ret)
        ret = draw_face(g);
    if (ret)
        return ret;
    head_center(g);
    if ((ret = synth_face_frame_init(g->model, &g->ff)))
        return ret;
    synth_draw_look(g);
    synth_draw_materials(g);
    if ((ret = synth_build_mesh(g)) || (ret = synth_build_albedo(g)))
        return ret;
    g->ground_albedo = 0.2;
    g->sun_intensity = g->s.overcast ? 0.0 : g->s.sun_intensity;
    synth_sun_direction(g->s.sun_elevation_deg, g->s.sun_azimuth_deg, g->sun_dir);
    synth_build_env(&g->s, g->sun_dir, g->sun_intensity, g->ground_albedo, g->env);
    g->fx = g->fy = g->s.focal_ratio * g->s.width;
    g->cx = 0.5 * (g->s.width - 1.0);
    g->cy = 0.5 * (g->s.height - 1.0);
    if ((ret = alloc_buffers(g)) || (ret = open_renderer(g)) || (ret = initial_exposure(g)))
        return ret;
    fill_truth(g);
    return 0;
}

int sp_synth_selfie_open(sp_synth_selfie **out, const sp_synth_selfie_settings *s)
{
    if (!out || !s)
        return -EINVAL;
    *out = NULL;
    int ret = check_settings(s);
    if (ret)
        return ret;
    if (s->format == SP_SYNTH_FORMAT_MJPEG && !sp_jpeg_available()) {
        sp_log(SP_LOG_ERROR, SYNTH_LOG, "MJPEG frames need libjpeg: rebuild with -Djpeg=enabled or use RGB24");
        return SP_EDISABLED;
    }
    sp_synth_selfie *g = calloc(1, sizeof(*g));
    if (!g)
        return -ENOMEM;
    g->s = *s;
    if (s->utc_start[0]) {
        g->s.imu.magnetometer = 1;
        g->s.imu.mag_field_ut.y = 0.0; /* the field's horizontal part along +x: magnetic north = world +x */
        ret = clock_sun(s, &g->s.sun_elevation_deg, &g->s.sun_azimuth_deg);
    }
    if (!ret)
        ret = open_steps(g);
    if (ret) {
        sp_synth_selfie_close(&g);
        return ret;
    }
    *out = g;
    return 0;
}

void sp_synth_selfie_close(sp_synth_selfie **gp)
{
    if (!gp || !*gp)
        return;
    sp_synth_selfie *g = *gp;
    sp_renderer_close(&g->r);
    for (int i = 0; i < g->n_caps; i++)
        free(g->caps[i].rim);
    sp_mesh_free(&g->mesh);
    free(g->albedo);
    free(g->id);
    free(g->exp);
    free(g->linear);
    free(g->rgb);
    free(g->frame_exposure);
    free(g->bg_grid);
    free(g->horizon_grid);
    free(g->city_corner);
    synth_city_free(&g->city);
    sp_face_model_free(&g->own_model);
    free(g);
    *gp = NULL;
}

const sp_synth_selfie_truth *sp_synth_selfie_get_truth(const sp_synth_selfie *g) { return g ? &g->truth : NULL; }

/* ---- poses ---- */

static void mat3_mul(const double a[9], const double b[9], double out[9])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            out[i * 3 + j] = a[i * 3] * b[j] + a[i * 3 + 1] * b[3 + j] + a[i * 3 + 2] * b[6 + j];
}

/* Slow head sway relative to the body: yaw, pitch, roll about the model's y, x, z axes. */
static void head_wobble(const sp_synth_selfie *g, double tau, double R[9])
{
    static const double freq[3][2] = { { 0.23, 0.61 }, { 0.31, 0.47 }, { 0.19, 0.53 } };
    static const sp_vec3 axes[3] = { { 0, 1, 0 }, { 1, 0, 0 }, { 0, 0, 1 } };
    sp_quat q = sp_quat_identity();
    for (int k = 0; k < 3; k++) {
        double a = 0.0;
        for (int j = 0; j < 2; j++) {
            uint64_t st = g->s.seed ^ (0xD1B54A32D192ED03ull * (uint64_t)(2 * k + j + 1));
            double ph = 2.0 * M_PI * synth_hash3(k, j, 0, st);
            a += (j ? 0.3 : 0.7) * sin(2.0 * M_PI * freq[k][j] * tau + ph);
        }
        q = sp_quat_mul(q, sp_quat_from_axis_angle(axes[k], a * g->s.head_wobble_deg * DEG));
    }
    sp_quat_to_matrix(sp_quat_normalize(q), R);
}

static void camera_from(const sp_synth_selfie *g, sp_quat cam_to_world, sp_vec3 pos, synth_pose *p)
{
    double Rcw[9];
    sp_quat_to_matrix(cam_to_world, Rcw);
    p->cam = (sp_render_camera){ .fx = g->fx, .fy = g->fy, .cx = g->cx, .cy = g->cy };
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            p->cam.R[i * 3 + j] = Rcw[j * 3 + i];
    double c[3] = { pos.x, pos.y, pos.z };
    for (int i = 0; i < 3; i++)
        p->cam.t[i] = -(p->cam.R[i * 3] * c[0] + p->cam.R[i * 3 + 1] * c[1] + p->cam.R[i * 3 + 2] * c[2]);
    p->cam_to_world = cam_to_world;
    p->cam_pos = pos;
}

/* Head into the world: yaw psi about z, then the model's frame (nose along -x at psi = 0), then the sway. */
static void head_pose(const sp_synth_selfie *g, double psi, double tau, synth_pose *p)
{
    static const double B[9] = { 0, 0, -1, -1, 0, 0, 0, 1, 0 }; /* model x->-y, y->+z, z->-x */
    double c = cos(psi), s = sin(psi);
    double Rz[9] = { c, -s, 0, s, c, 0, 0, 0, 1 }, W[9], RB[9];
    head_wobble(g, tau, W);
    mat3_mul(Rz, B, RB);
    mat3_mul(RB, W, p->R_head);
    sp_vec3 rv = sp_quat_to_rotvec(sp_quat_from_matrix(p->R_head));
    p->rotvec[0] = rv.x;
    p->rotvec[1] = rv.y;
    p->rotvec[2] = rv.z;
    for (int i = 0; i < 3; i++)
        p->t[i] = -(p->R_head[i * 3] * g->center[0] + p->R_head[i * 3 + 1] * g->center[1] +
                    p->R_head[i * 3 + 2] * g->center[2]);
}

int synth_pose_at(const sp_synth_selfie *g, int64_t t_ns, synth_pose *p)
{
    sp_quat q;
    sp_vec3 pos;
    int ret = sp_fake_imu_truth(&g->s.imu, t_ns, NULL, &q);
    if (!ret)
        ret = sp_fake_imu_truth_position(&g->s.imu, t_ns, &pos);
    if (ret)
        return ret;
    /* the body faces the camera: its yaw is the direction from the axis to the camera, reversed */
    double psi = atan2(-pos.y, -pos.x);
    pos.z += g->s.camera_height_m;
    camera_from(g, q, pos, p);
    head_pose(g, psi, (double)(t_ns - g->s.imu.start_ns) * 1e-9, p);
    return 0;
}

void synth_look_at(const sp_synth_selfie *g, sp_vec3 pos, sp_vec3 target, synth_pose *p)
{
    sp_vec3 z = sp_vec3_normalize(sp_vec3_sub(target, pos));
    sp_vec3 x = sp_vec3_normalize(sp_vec3_cross(z, (sp_vec3){ 0, 0, 1 }));
    if (sp_vec3_norm(x) < 0.5) /* looking straight up or down */
        x = (sp_vec3){ 0, -1, 0 };
    sp_vec3 y = sp_vec3_cross(z, x);
    double Rcw[9] = { x.x, y.x, z.x, x.y, y.y, z.y, x.z, y.z, z.z };
    camera_from(g, sp_quat_from_matrix(Rcw), pos, p);
}

/* ---- rendering ---- */

int synth_render_pose(sp_synth_selfie *g, const synth_pose *p, const double sun_dir[3], double sun_intensity,
                      const float *env, double exposure, sp_render_outputs *out)
{
    sp_face_params fp;
    sp_face_params_init(&fp);
    fp.id = g->id;
    fp.exp = g->exp;
    memcpy(fp.rotvec, p->rotvec, sizeof(fp.rotvec));
    memcpy(fp.t, p->t, sizeof(fp.t));
    int ret = sp_face_model_eval_float(g->model, &fp, g->mesh.positions);
    if (ret)
        return ret;
    synth_place_caps(g, p->R_head, 1.0);
    if (!sun_dir) {
        sun_dir = g->sun_dir;
        sun_intensity = g->sun_intensity;
    }
    sp_render_scene sc;
    sp_render_scene_defaults(&sc);
    sc.camera = p->cam;
    sc.mesh = &g->mesh;
    sc.albedo = (sp_render_texture){ g->aw, g->ah, g->albedo };
    sc.clusters = (sp_render_cluster_map){ (int)g->model->cluster_width, (int)g->model->cluster_height,
                                           g->model->cluster_map };
    memcpy(sc.ks, g->ks, sizeof(sc.ks));
    memcpy(sc.shininess, g->shininess, sizeof(sc.shininess));
    sc.env = env ? env : g->env;
    memcpy(sc.sun_dir, sun_dir, sizeof(sc.sun_dir));
    sc.sun_intensity = sun_intensity;
    sc.exposure = exposure;
    sc.shadow_mode = sun_intensity > 0 ? SP_RENDER_SHADOW_RENDER : SP_RENDER_SHADOW_OFF;
    return sp_render(g->r, &sc, out);
}

/* World direction (unit) of the view ray through pixel (u, v). */
static void ray_dir(const sp_synth_selfie *g, const double R[9], double u, double v, double d[3])
{
    double dc[3] = { (u - g->cx) / g->fx, (v - g->cy) / g->fy, 1.0 };
    for (int k = 0; k < 3; k++)
        d[k] = R[k] * dc[0] + R[3 + k] * dc[1] + R[6 + k] * dc[2];
    double n = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    for (int k = 0; k < 3; k++)
        d[k] /= n; /* n >= 1: the ray's camera z is 1 and R is a rotation */
}

/* Environment radiance along the view ray of pixel (u, v). */
static void ray_env(const sp_synth_selfie *g, const double R[9], const float *env, double u, double v, double rgb[3])
{
    double d[3];
    ray_dir(g, R, u, v, d);
    synth_env_lookup(env, d, rgb);
}

/* The sky 3 deg over the horizon at the azimuth of pixel (u, v)'s ray: what lights the city's facades. */
static void ray_horizon(const sp_synth_selfie *g, const double R[9], const float *env, double u, double v,
                        double rgb[3])
{
    double d[3];
    ray_dir(g, R, u, v, d);
    double h = sqrt(d[0] * d[0] + d[1] * d[1]);
    if (!(h > 1e-9)) { /* straight up or down: any azimuth */
        d[0] = 1.0;
        d[1] = 0.0;
        h = 1.0;
    }
    double e[3] = { d[0] / h * cos(3.0 * DEG), d[1] / h * cos(3.0 * DEG), sin(3.0 * DEG) };
    synth_env_lookup(env, e, rgb);
}

static double luminance(const double c[3])
{
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

/* Bilinear value of a BG_STEP grid (gw columns) at pixel (u, v). */
static void grid_at(const double *grid, uint32_t gw, uint32_t u, uint32_t v, double out[3])
{
    uint32_t i = u / BG_STEP, j = v / BG_STEP;
    double fx = (double)(u % BG_STEP) / BG_STEP, fy = (double)(v % BG_STEP) / BG_STEP;
    const double *a = grid + (j * gw + i) * 3, *b = a + 3, *c = a + gw * 3, *d = c + 3;
    for (int k = 0; k < 3; k++)
        out[k] = (1 - fy) * ((1 - fx) * a[k] + fx * b[k]) + fy * ((1 - fx) * c[k] + fx * d[k]);
}

/*
 * The city at a finite distance D (backdrop_distance_m > 0): painted on the sphere of radius D about the world
 * origin (the turning axis), so the view ray from the camera centre c along d meets it at c + s d, s > 0 the
 * root of |c + s d| = D, and shows the panorama in the direction of that point from the origin. The pixel's
 * footprint there, seen from the origin, is about s / D times its angle from the camera. A camera on or outside
 * the sphere (only a held-out view can be; the setting keeps the capture's inside) sees it at infinity.
 */
static double city_direction(double D, const double c[3], double d[3])
{
    double cd = c[0] * d[0] + c[1] * d[1] + c[2] * d[2], cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    double disc = cd * cd - cc + D * D;
    if (!(cc < D * D) || !(disc > 0.0))
        return 1.0;
    double s = -cd + sqrt(disc), x[3] = { c[0] + s * d[0], c[1] + s * d[1], c[2] + s * d[2] };
    double n = sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    for (int k = 0; k < 3; k++)
        d[k] = x[k] / n;
    return s / D;
}

/* What the city shows at the corners of the pixels (i, j) .. (i + 1, j + 1) that need it (need[] set). */
static void city_corners(const sp_synth_selfie *g, const synth_pose *p)
{
    uint32_t cw = g->s.width + 1, ch = g->s.height + 1;
    double D = g->s.backdrop_distance_m, cam[3] = { p->cam_pos.x, p->cam_pos.y, p->cam_pos.z };
    for (uint32_t j = 0; j < ch; j++)
        for (uint32_t i = 0; i < cw; i++) {
            synth_city_sample *cs = g->city_corner + (size_t)j * cw + i;
            if (!cs->need)
                continue;
            double d[3], c[3], haze, px_rad = 1.0 / g->fx;
            ray_dir(g, p->cam.R, (double)i - 0.5, (double)j - 0.5, d);
            if (D > 0.0)
                px_rad *= city_direction(D, cam, d);
            cs->part = (uint8_t)synth_city_look(g->city, d, px_rad, c, &haze);
            for (int k = 0; k < 3; k++)
                cs->rgb[k] = (float)c[k];
            cs->haze = (float)haze;
        }
}

/*
 * Radiance of the city backdrop behind pixel (u, v): the mean of its four corners (one evaluation per pixel,
 * shared, antialiases the edges) shaded by the sky there (grid values; the sky is smooth, the city is not).
 * lum_ground: the luminance of the env's ground (the same below the whole horizon) over its albedo, what a
 * ground of reflectance 1 would show.
 */
static void city_pixel(const sp_synth_selfie *g, uint32_t gw, uint32_t u, uint32_t v, double lum_ground, double out[3])
{
    const double facade_k = 2.0; /* a facade of reflectance 0.5 matches the sky at the horizon */
    double sky[3], hor[3];
    grid_at(g->bg_grid, gw, u, v, sky);
    grid_at(g->horizon_grid, gw, u, v, hor);
    double lum_hor = luminance(hor);
    size_t cw = g->s.width + 1;
    const synth_city_sample *c0 = g->city_corner + v * cw + u, *cs[4] = { c0, c0 + 1, c0 + cw, c0 + cw + 1 };
    out[0] = out[1] = out[2] = 0.0;
    for (int n = 0; n < 4; n++) {
        const synth_city_sample *c = cs[n];
        double haze = (double)c->haze;
        for (int k = 0; k < 3; k++) {
            double r = c->part == SYNTH_CITY_SKY ? sky[k]
                : c->part == SYNTH_CITY_FACADE   ? facade_k * (double)c->rgb[k] * lum_hor
                                                 : (double)c->rgb[k] * lum_ground;
            out[k] += 0.25 * ((1.0 - haze) * r + haze * hor[k]);
        }
    }
}

/* synth_accumulate for the city backdrop: the sky grids, the city at the background pixels' corners, then
 * every background pixel on its own. */
static void accumulate_city(const sp_synth_selfie *g, const synth_pose *p, const sp_render_outputs *o, const float *env,
                            double weight, double *lin)
{
    uint32_t w = g->s.width, h = g->s.height, gw = w / BG_STEP + 2, gh = h / BG_STEP + 2;
    static const double down[3] = { 0, 0, -1 };
    double ground[3];
    synth_env_lookup(env, down, ground);
    double lum_ground = luminance(ground) / g->ground_albedo;
    for (uint32_t j = 0; j < gh; j++)
        for (uint32_t i = 0; i < gw; i++) {
            ray_env(g, p->cam.R, env, (double)(i * BG_STEP), (double)(j * BG_STEP), g->bg_grid + (j * gw + i) * 3);
            ray_horizon(g, p->cam.R, env, (double)(i * BG_STEP), (double)(j * BG_STEP),
                        g->horizon_grid + (j * gw + i) * 3);
        }
    size_t cw = (size_t)w + 1;
    for (size_t i = 0; i < cw * (h + 1); i++)
        g->city_corner[i].need = 0;
    for (uint32_t v = 0; v < h; v++)
        for (uint32_t u = 0; u < w; u++)
            if (1.0 - (double)o->coverage[(size_t)v * w + u] > 1e-6) {
                synth_city_sample *c = g->city_corner + v * cw + u;
                c[0].need = c[1].need = c[cw].need = c[cw + 1].need = 1;
            }
    city_corners(g, p);
    for (uint32_t v = 0; v < h; v++)
        for (uint32_t u = 0; u < w; u++) {
            size_t px = (size_t)v * w + u;
            double bgw = 1.0 - (double)o->coverage[px], bg[3] = { 0, 0, 0 };
            if (bgw > 1e-6)
                city_pixel(g, gw, u, v, lum_ground, bg);
            for (int k = 0; k < 3; k++)
                lin[3 * px + (size_t)k] += weight * ((double)o->radiance[3 * px + (size_t)k] + bgw * bg[k]);
        }
}

void synth_accumulate(const sp_synth_selfie *g, const synth_pose *p, const sp_render_outputs *o, const float *env,
                      double weight, double *lin)
{
    /* the 16x32 sky varies slowly across the image: look it up every BG_STEP pixels, interpolate between */
    uint32_t w = g->s.width, h = g->s.height, gw = w / BG_STEP + 2, gh = h / BG_STEP + 2;
    env = env ? env : g->env;
    if (g->city) {
        accumulate_city(g, p, o, env, weight, lin);
        return;
    }
    for (uint32_t j = 0; j < gh; j++)
        for (uint32_t i = 0; i < gw; i++)
            ray_env(g, p->cam.R, env, (double)(i * BG_STEP), (double)(j * BG_STEP), g->bg_grid + (j * gw + i) * 3);
    for (uint32_t v = 0; v < h; v++) {
        uint32_t j = v / BG_STEP;
        double fy = (double)(v % BG_STEP) / BG_STEP;
        for (uint32_t u = 0; u < w; u++) {
            size_t px = (size_t)v * w + u;
            double bgw = 1.0 - (double)o->coverage[px];
            uint32_t i = u / BG_STEP;
            double fx = (double)(u % BG_STEP) / BG_STEP;
            const double *a = g->bg_grid + (j * gw + i) * 3, *b = a + 3, *c = a + gw * 3, *d = c + 3;
            for (int k = 0; k < 3; k++) {
                double bg = bgw > 1e-6 ? (1 - fy) * ((1 - fx) * a[k] + fx * b[k]) + fy * ((1 - fx) * c[k] + fx * d[k])
                                       : 0.0;
                lin[3 * px + (size_t)k] += weight * ((double)o->radiance[3 * px + (size_t)k] + bgw * bg);
            }
        }
    }
}

double synth_display(double x)
{
    if (!(x > 0.0))
        return 0.0;
    if (isinf(x))
        return 1.0;
    return pow(x / (1.0 + x), 1.0 / 2.2);
}

uint8_t synth_to_byte(double v)
{
    double b = floor(v * 255.0 + 0.5);
    return (uint8_t)(b < 0 ? 0 : b > 255 ? 255 : b);
}

#define TONE_BINS 4096

void synth_linear_to_rgb(const double *linear, size_t n, uint8_t *rgb)
{
    /* byte b is reached when y = x / (1 + x) reaches ((b - 0.5) / 255)^2.2; a table over y gives
       the byte at each bin's start, a short forward walk the exact one */
    double thr[257];
    uint8_t start[TONE_BINS];
    thr[0] = -1.0;
    for (int b = 1; b < 256; b++)
        thr[b] = pow((b - 0.5) / 255.0, 2.2);
    thr[256] = 2.0;
    for (int k = 0, b = 0; k < TONE_BINS; k++) {
        while (thr[b + 1] <= (double)k / TONE_BINS)
            b++;
        start[k] = (uint8_t)b;
    }
    for (size_t i = 0; i < 3 * n; i++) {
        double x = linear[i];
        if (!(x > 0.0)) {
            rgb[i] = 0;
            continue;
        }
        double y = isinf(x) ? 1.0 : x / (1.0 + x);
        int k = (int)(y * TONE_BINS), b;
        b = start[k < TONE_BINS ? k : TONE_BINS - 1];
        while (thr[b + 1] <= y)
            b++;
        rgb[i] = (uint8_t)b;
    }
}

int synth_landmarks(const sp_synth_selfie *g, const synth_pose *p, float out[2 * SP_FACE_N_LANDMARKS])
{
    sp_face_params fp;
    sp_face_params_init(&fp);
    fp.id = g->id;
    fp.exp = g->exp;
    memcpy(fp.rotvec, p->rotvec, sizeof(fp.rotvec));
    memcpy(fp.t, p->t, sizeof(fp.t));
    sp_face_camera cam;
    sp_face_camera_init(&cam, g->fx, g->fy, g->cx, g->cy);
    memcpy(cam.R, p->cam.R, sizeof(cam.R));
    memcpy(cam.t, p->cam.t, sizeof(cam.t));
    double uv[2 * SP_FACE_N_LANDMARKS];
    int ret = sp_face_model_project_landmarks(g->model, &fp, &cam, uv, NULL, NULL);
    if (ret < 0)
        return ret;
    for (int i = 0; i < 2 * SP_FACE_N_LANDMARKS; i++)
        out[i] = (float)uv[i];
    return 0;
}

/* ---- public per-frame API ---- */

static int64_t frame_start_ns(const sp_synth_selfie *g, uint64_t i)
{
    return g->s.imu.start_ns + (int64_t)llround((double)i * 1e9 / g->s.fps);
}

int sp_synth_selfie_frame_truth(const sp_synth_selfie *g, uint64_t index, sp_synth_frame_truth *out)
{
    if (!g || !out || index >= g->n_frames)
        return -EINVAL;
    memset(out, 0, sizeof(*out));
    out->index = index;
    out->timestamp_ns = frame_start_ns(g, index);
    out->pose_ns = out->timestamp_ns + (int64_t)llround(0.5 * g->s.shutter_s * 1e9);
    synth_pose p;
    int ret = synth_pose_at(g, out->pose_ns, &p);
    if (ret)
        return ret;
    out->camera = p.cam;
    out->camera_to_world = p.cam_to_world;
    out->camera_position = p.cam_pos;
    memcpy(out->head_rotvec, p.rotvec, sizeof(p.rotvec));
    memcpy(out->head_t, p.t, sizeof(p.t));
    out->head_s = 1.0;
    for (int i = 0; i < 3; i++)
        out->sun_dir_camera[i] =
            p.cam.R[i * 3] * g->sun_dir[0] + p.cam.R[i * 3 + 1] * g->sun_dir[1] + p.cam.R[i * 3 + 2] * g->sun_dir[2];
    out->exposure = g->frame_exposure[index];
    return synth_landmarks(g, &p, out->landmarks);
}

int sp_synth_selfie_render_frame(sp_synth_selfie *g, uint64_t index, double exposure, sp_render_outputs *out)
{
    if (!g || !out || index >= g->n_frames || !(exposure <= 1e6))
        return -EINVAL;
    if (!(exposure > 0))
        exposure = isfinite(g->frame_exposure[index]) ? g->frame_exposure[index] : g->initial_exposure;
    synth_pose p;
    int64_t t = frame_start_ns(g, index) + (int64_t)llround(0.5 * g->s.shutter_s * 1e9);
    int ret = synth_pose_at(g, t, &p);
    return ret ? ret : synth_render_pose(g, &p, NULL, 0, NULL, exposure, out);
}
