/* SPDX-License-Identifier: MIT */
/*
 * The ground-truth directory: manifest (truth.json), per-frame truth
 * (frames.json), albedo (PNG preview + exact PFM), cluster map and material,
 * environment map, and held-out frames under new suns and from new cameras
 * (heldout/ PNG + JSON). Layout documented in pipeline/synth/SYNTH.md.
 */
#include "pipeline/synth/synth_internal.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/file_util.h"
#include "common/json.h"

#define DEG (M_PI / 180.0)

static const char *const cluster_names[SP_RENDER_CLUSTERS] = {
    "forehead", "nose", "left_cheek", "right_cheek", "chin", "lips", "left_eye", "right_eye", "jaw_neck", "other",
};

static int write_bytes(const char *dir, const char *name, const void *data, size_t size)
{
    char *path = sp_path_join_alloc(dir, name);
    if (!path)
        return -ENOMEM;
    int ret = sp_write_whole_file_atomic(path, data, size);
    free(path);
    return ret;
}

static int write_json(const char *dir, const char *name, sp_strbuf *b)
{
    int ret = b->failed ? -ENOMEM : write_bytes(dir, name, b->data, b->len);
    sp_strbuf_free(b);
    return ret;
}

int synth_write_image(const sp_synth_selfie *g, const char *dir, const char *stem, const uint8_t *px, uint32_t w,
                      uint32_t h, int channels, char *name, size_t name_size)
{
    if (g->s.write_image) {
        snprintf(name, name_size, "%s.png", stem);
        char *path = sp_path_join_alloc(dir, name);
        if (!path)
            return -ENOMEM;
        int ret = g->s.write_image(path, px, w, h, w * (uint32_t)channels, channels);
        free(path);
        return ret;
    }
    /* no PNG writer given: binary PPM (RGB) or PGM (gray) */
    snprintf(name, name_size, "%s.%s", stem, channels == 1 ? "pgm" : "ppm");
    char head[64];
    int hn = snprintf(head, sizeof(head), "P%c\n%u %u\n255\n", channels == 1 ? '5' : '6', w, h);
    size_t n = (size_t)w * h * (size_t)channels;
    uint8_t *buf = malloc((size_t)hn + n);
    if (!buf)
        return -ENOMEM;
    memcpy(buf, head, (size_t)hn);
    memcpy(buf + hn, px, n);
    int ret = write_bytes(dir, name, buf, (size_t)hn + n);
    free(buf);
    return ret;
}

/* PFM: "PF" (RGB) header, little-endian floats (scale -1), rows from the bottom of the image up. */
static int write_pfm(const char *dir, const char *name, const float *rgb, int w, int h)
{
    char head[64];
    int hn = snprintf(head, sizeof(head), "PF\n%d %d\n-1.0\n", w, h);
    size_t n = (size_t)w * (size_t)h * 3;
    uint8_t *buf = malloc((size_t)hn + n * 4);
    if (!buf)
        return -ENOMEM;
    memcpy(buf, head, (size_t)hn);
    uint8_t *o = buf + hn;
    for (int y = h - 1; y >= 0; y--)
        for (size_t i = 0; i < (size_t)w * 3; i++) {
            uint32_t u;
            memcpy(&u, &rgb[(size_t)y * (size_t)w * 3 + i], 4);
            for (int k = 0; k < 4; k++)
                *o++ = (uint8_t)(u >> (8 * k));
        }
    int ret = write_bytes(dir, name, buf, (size_t)hn + n * 4);
    free(buf);
    return ret;
}

static void json_farray(sp_strbuf *b, const float *v, int n)
{
    sp_strbuf_append(b, "[", 1);
    for (int i = 0; i < n; i++)
        sp_strbuf_printf(b, "%s%.9g", i ? "," : "", (double)v[i]);
    sp_strbuf_append(b, "]", 1);
}

/* Linear float RGB to display bytes with a plain 1/2.2 gamma (albedo previews). */
static int gamma_bytes(const float *lin, size_t n, double scale, uint8_t **out)
{
    *out = malloc(n * 3);
    if (!*out)
        return -ENOMEM;
    for (size_t i = 0; i < n * 3; i++) {
        double v = (double)lin[i] * scale;
        (*out)[i] = synth_to_byte(v > 0 ? pow(v > 1 ? 1 : v, 1.0 / 2.2) : 0.0);
    }
    return 0;
}

/* ---- camera / pose JSON shared by frames.json and the held-out files ---- */

static void json_camera(sp_strbuf *b, const synth_pose *p)
{
    double q[4] = { p->cam_to_world.w, p->cam_to_world.x, p->cam_to_world.y, p->cam_to_world.z };
    double pos[3] = { p->cam_pos.x, p->cam_pos.y, p->cam_pos.z };
    sp_strbuf_printf(b, "\"camera\":{\"fx\":%.17g,\"fy\":%.17g,\"cx\":%.17g,\"cy\":%.17g,\"R\":", p->cam.fx, p->cam.fy,
                     p->cam.cx, p->cam.cy);
    sp_strbuf_json_numbers(b, p->cam.R, 9);
    sp_strbuf_printf(b, ",\"t\":");
    sp_strbuf_json_numbers(b, p->cam.t, 3);
    sp_strbuf_printf(b, ",\"camera_to_world\":");
    sp_strbuf_json_numbers(b, q, 4);
    sp_strbuf_printf(b, ",\"position\":");
    sp_strbuf_json_numbers(b, pos, 3);
    sp_strbuf_printf(b, "},\"head\":{\"rotvec\":");
    sp_strbuf_json_numbers(b, p->rotvec, 3);
    sp_strbuf_printf(b, ",\"t\":");
    sp_strbuf_json_numbers(b, p->t, 3);
    sp_strbuf_printf(b, ",\"s\":1}");
}

static void sun_in_camera(const synth_pose *p, const double sun[3], double out[3])
{
    for (int i = 0; i < 3; i++)
        out[i] = p->cam.R[i * 3] * sun[0] + p->cam.R[i * 3 + 1] * sun[1] + p->cam.R[i * 3 + 2] * sun[2];
}

static int write_frames(sp_synth_selfie *g, const char *dir)
{
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"frames\":[\n");
    for (uint64_t i = 0; i < g->n_frames && !b.failed; i++) {
        sp_synth_frame_truth ft;
        synth_pose p;
        int ret = sp_synth_selfie_frame_truth(g, i, &ft);
        if (!ret)
            ret = synth_pose_at(g, ft.pose_ns, &p);
        if (ret) {
            sp_strbuf_free(&b);
            return ret;
        }
        sp_strbuf_printf(&b, "%s{\"index\":%llu,\"timestamp_ns\":%lld,\"pose_ns\":%lld,\"exposure\":", i ? ",\n" : "",
                         (unsigned long long)i, (long long)ft.timestamp_ns, (long long)ft.pose_ns);
        sp_strbuf_json_number(&b, ft.exposure);
        sp_strbuf_printf(&b, ",");
        json_camera(&b, &p);
        sp_strbuf_printf(&b, ",\"sun_dir_camera\":");
        sp_strbuf_json_numbers(&b, ft.sun_dir_camera, 3);
        sp_strbuf_printf(&b, "}");
    }
    sp_strbuf_printf(&b, "\n]}\n");
    return write_json(dir, "frames.json", &b);
}

/* ---- held-out frames ---- */

typedef struct heldout {
    const char *kind;   /* "relit" or "view" */
    char what[96];      /* description */
    uint64_t frame;     /* capture frame whose pose it starts from */
    synth_pose pose;
    double sun[3];
    double sun_intensity;
    float env[SP_RENDER_ENV_FLOATS];
} heldout;

static uint64_t heldout_frame(const sp_synth_selfie *g, int k, int n)
{
    uint64_t i = (uint64_t)floor((k + 0.5) * (double)g->n_frames / n);
    return i < g->n_frames ? i : g->n_frames - 1;
}

/* Relit k: the pose of a capture frame under a sun elsewhere (golden-angle azimuths, spread elevations). */
static int make_relit(const sp_synth_selfie *g, int k, heldout *h)
{
    h->kind = "relit";
    h->frame = heldout_frame(g, k, g->s.n_relit);
    double az = g->s.sun_azimuth_deg + 137.507764 * (k + 1);
    double el = 10.0 + 70.0 * fmod(0.618034 * (k + 1), 1.0);
    az = fmod(az, 360.0);
    snprintf(h->what, sizeof(h->what), "capture frame %llu under a clear sky, sun at elevation %.1f azimuth %.1f deg",
             (unsigned long long)h->frame, el, az);
    synth_sun_direction(el, az, h->sun);
    h->sun_intensity = g->s.sun_intensity;
    sp_synth_selfie_settings clear = g->s;
    clear.overcast = 0;
    synth_build_env(&clear, h->sun, h->sun_intensity, g->ground_albedo, h->env);
    int64_t t = g->s.imu.start_ns + (int64_t)llround((double)h->frame * 1e9 / g->s.fps + 0.5 * g->s.shutter_s * 1e9);
    return synth_pose_at(g, t, &h->pose);
}

/* Novel view k: the camera raised, lowered, closer, farther or orbited around the face of a capture frame. */
static int make_view(const sp_synth_selfie *g, int k, heldout *h)
{
    static const char *const names[6] = { "raised", "lowered", "closer", "farther", "orbited left", "orbited right" };
    h->kind = "view";
    h->frame = heldout_frame(g, k, g->s.n_novel);
    int64_t t = g->s.imu.start_ns + (int64_t)llround((double)h->frame * 1e9 / g->s.fps + 0.5 * g->s.shutter_s * 1e9);
    synth_pose p;
    int ret = synth_pose_at(g, t, &p);
    if (ret)
        return ret;
    /* look at the face: the landmarks' mean height on the turning axis, moved to the face's front */
    double fc[3] = { g->ff.o[0] - g->center[0], g->ff.o[1] - g->center[1], g->ff.o[2] - g->center[2] };
    sp_vec3 target = { 0, 0, 0 };
    for (int i = 0; i < 3; i++)
        (&target.x)[i] = p.R_head[i * 3] * fc[0] + p.R_head[i * 3 + 1] * fc[1] + p.R_head[i * 3 + 2] * fc[2];
    sp_vec3 off = sp_vec3_sub(p.cam_pos, target), pos = p.cam_pos;
    double amp = 1.0 + 0.5 * (k / 6);
    switch (k % 6) {
    case 0: pos.z += 0.15 * amp; break;
    case 1: pos.z -= 0.15 * amp; break;
    case 2: pos = sp_vec3_add(target, sp_vec3_scale(off, 1.0 / (1.0 + 0.55 * amp))); break;
    case 3: pos = sp_vec3_add(target, sp_vec3_scale(off, 1.0 + 0.5 * amp)); break;
    default: {
        double a = (k % 6 == 4 ? 30.0 : -30.0) * amp * DEG;
        sp_vec3 r = { cos(a) * off.x - sin(a) * off.y, sin(a) * off.x + cos(a) * off.y, off.z };
        pos = sp_vec3_add(target, r);
    }
    }
    snprintf(h->what, sizeof(h->what), "capture frame %llu, camera %s", (unsigned long long)h->frame, names[k % 6]);
    h->pose = p;
    synth_look_at(g, pos, target, &h->pose);
    memcpy(h->sun, g->sun_dir, sizeof(h->sun));
    h->sun_intensity = g->sun_intensity;
    memcpy(h->env, g->env, sizeof(h->env));
    return 0;
}

static int heldout_json(sp_synth_selfie *g, const char *dir, const heldout *h, const char *stem, const char *png,
                        const char *env)
{
    double sc[3];
    float lm[2 * SP_FACE_N_LANDMARKS];
    int ret = synth_landmarks(g, &h->pose, lm);
    if (ret)
        return ret;
    sun_in_camera(&h->pose, h->sun, sc);
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"kind\":\"%s\",\"description\":", h->kind);
    sp_strbuf_json_string(&b, h->what);
    sp_strbuf_printf(&b, ",\"image\":");
    sp_strbuf_json_string(&b, png);
    sp_strbuf_printf(&b, ",\"source_frame\":%llu,\"width\":%u,\"height\":%u,\"exposure\":%.17g,",
                     (unsigned long long)h->frame, g->s.width, g->s.height, g->initial_exposure);
    json_camera(&b, &h->pose);
    sp_strbuf_printf(&b, ",\"sun\":{\"direction_world\":");
    sp_strbuf_json_numbers(&b, h->sun, 3);
    sp_strbuf_printf(&b, ",\"direction_camera\":");
    sp_strbuf_json_numbers(&b, sc, 3);
    sp_strbuf_printf(&b, ",\"intensity\":%.17g},\"env_pfm\":", h->sun_intensity);
    sp_strbuf_json_string(&b, env);
    sp_strbuf_printf(&b, ",\"landmarks\":");
    json_farray(&b, lm, 2 * SP_FACE_N_LANDMARKS);
    sp_strbuf_printf(&b, "}\n");
    char name[80];
    snprintf(name, sizeof(name), "%s.json", stem);
    return write_json(dir, name, &b);
}

/* Renders one held-out frame (noise-free, no JPEG, the capture's initial exposure) and writes its files. */
static int write_heldout(sp_synth_selfie *g, const char *hdir, const heldout *h, int k, sp_strbuf *list)
{
    char stem[64], png[80], env[80], rel_png[96], rel_env[96];
    snprintf(stem, sizeof(stem), "%s_%02d", h->kind, k);
    snprintf(env, sizeof(env), "%s_env.pfm", stem);
    sp_render_outputs o;
    int ret = synth_render_pose(g, &h->pose, h->sun, h->sun_intensity, h->env, g->initial_exposure, &o);
    if (ret)
        return ret;
    size_t px = (size_t)g->s.width * g->s.height;
    memset(g->linear, 0, px * 3 * sizeof(double));
    synth_accumulate(g, &h->pose, &o, h->env, g->initial_exposure, g->linear);
    synth_linear_to_rgb(g->linear, px, g->rgb);
    if ((ret = synth_write_image(g, hdir, stem, g->rgb, g->s.width, g->s.height, 3, png, sizeof(png))))
        return ret;
    if ((ret = write_pfm(hdir, env, h->env, SP_RENDER_ENV_W, SP_RENDER_ENV_H)))
        return ret;
    snprintf(rel_png, sizeof(rel_png), "heldout/%s", png);
    snprintf(rel_env, sizeof(rel_env), "heldout/%s", env);
    if ((ret = heldout_json(g, hdir, h, stem, png, env)))
        return ret;
    sp_strbuf_printf(list, "%s{\"kind\":\"%s\",\"image\":", list->len && list->data[list->len - 1] != '[' ? "," : "",
                     h->kind);
    sp_strbuf_json_string(list, rel_png);
    sp_strbuf_printf(list, ",\"json\":\"heldout/%s.json\",\"env_pfm\":", stem);
    sp_strbuf_json_string(list, rel_env);
    sp_strbuf_printf(list, "}");
    return 0;
}

static int write_heldouts(sp_synth_selfie *g, const char *dir, sp_strbuf *list, uint64_t *count)
{
    char *hdir = sp_path_join_alloc(dir, "heldout");
    if (!hdir)
        return -ENOMEM;
    int ret = sp_mkdir_p(hdir, 0777);
    heldout *h = malloc(sizeof(*h));
    if (!h)
        ret = ret ? ret : -ENOMEM;
    sp_strbuf_printf(list, "[");
    if (!ret && g->s.cancel && *g->s.cancel) /* renders take a while: one more chance to stop */
        ret = -ECANCELED;
    for (int k = 0; !ret && k < g->s.n_relit; k++)
        if (!(ret = make_relit(g, k, h)) && !(ret = write_heldout(g, hdir, h, k, list)))
            (*count)++;
    for (int k = 0; !ret && k < g->s.n_novel; k++)
        if (!(ret = make_view(g, k, h)) && !(ret = write_heldout(g, hdir, h, k, list)))
            (*count)++;
    sp_strbuf_printf(list, "]");
    free(h);
    free(hdir);
    return ret;
}

/* ---- textures and the manifest ---- */

typedef struct file_names {
    char albedo_png[64], clusters_png[64], env_png[64];
} file_names;

static int write_textures(sp_synth_selfie *g, const char *dir, file_names *fn)
{
    uint8_t *px = NULL;
    size_t na = (size_t)g->aw * (size_t)g->ah;
    int ret = gamma_bytes(g->albedo, na, 1.0, &px);
    if (!ret)
        ret = synth_write_image(g, dir, "albedo", px, (uint32_t)g->aw, (uint32_t)g->ah, 3, fn->albedo_png,
                                sizeof(fn->albedo_png));
    free(px);
    if (!ret)
        ret = write_pfm(dir, "albedo.pfm", g->albedo, g->aw, g->ah);
    if (!ret)
        ret = synth_write_image(g, dir, "clusters", g->model->cluster_map, g->model->cluster_width,
                                g->model->cluster_height, 1, fn->clusters_png, sizeof(fn->clusters_png));
    if (!ret)
        ret = write_pfm(dir, "env.pfm", g->env, SP_RENDER_ENV_W, SP_RENDER_ENV_H);
    if (ret)
        return ret;
    /* env preview: tone-mapped at the capture's initial exposure */
    double lin[SP_RENDER_ENV_FLOATS];
    uint8_t rgb[SP_RENDER_ENV_FLOATS];
    for (int i = 0; i < SP_RENDER_ENV_FLOATS; i++)
        lin[i] = (double)g->env[i] * g->initial_exposure;
    synth_linear_to_rgb(lin, SP_RENDER_ENV_FLOATS / 3, rgb);
    return synth_write_image(g, dir, "env", rgb, SP_RENDER_ENV_W, SP_RENDER_ENV_H, 3, fn->env_png, sizeof(fn->env_png));
}

static void manifest_camera(sp_strbuf *b, const sp_synth_selfie *g)
{
    const sp_synth_selfie_settings *s = &g->s;
    sp_strbuf_printf(b, "\"camera\":{\"width\":%u,\"height\":%u,\"fps\":%.17g,\"fx\":%.17g,\"fy\":%.17g,\"cx\":%.17g,"
                        "\"cy\":%.17g,\"shutter_s\":%.17g,\"motion_blur_samples\":%d,\"supersample\":%d,"
                        "\"noise\":{\"scale\":%.17g,\"read\":%.17g,\"shot\":%.17g},\"jpeg_quality\":%d},\n",
                     s->width, s->height, s->fps, g->fx, g->fy, g->cx, g->cy, s->shutter_s, s->motion_blur_samples,
                     s->supersample, s->noise, 0.001, 0.0005, s->jpeg_quality);
    sp_strbuf_printf(b, "\"exposure\":{\"initial\":%.17g,\"auto\":%d,\"ae_speed\":%.17g,\"ae_drift\":%.17g,"
                        "\"tonemap\":\"display = (x / (1 + x))^(1/2.2), x = exposure * radiance\"},\n",
                     g->initial_exposure, s->auto_exposure, s->ae_speed, s->ae_drift);
}

static void manifest_face(sp_strbuf *b, const sp_synth_selfie *g)
{
    const sp_face_model *m = g->model;
    sp_strbuf_printf(b, "\"face\":{\"model_source\":");
    sp_strbuf_json_string(b, m->source);
    sp_strbuf_printf(b, ",\"n_vertices\":%u,\"n_triangles\":%u,\"identity\":", m->mesh.n_vertices,
                     m->mesh.n_triangles);
    sp_strbuf_json_numbers(b, g->id, (int)m->n_id);
    sp_strbuf_printf(b, ",\"expression_names\":[");
    for (uint32_t k = 0; k < m->n_exp; k++) {
        sp_strbuf_printf(b, "%s", k ? "," : "");
        sp_strbuf_json_string(b, sp_face_model_exp_name(m, k));
    }
    sp_strbuf_printf(b, "],\"expression\":");
    sp_strbuf_json_numbers(b, g->exp, (int)m->n_exp);
    sp_strbuf_printf(b, ",\"scale\":1,\"model_center\":");
    sp_strbuf_json_numbers(b, g->center, 3);
    const synth_look *lk = &g->look;
    sp_strbuf_printf(b, ",\"render_caps\":%d,\"look\":{\"skin_tone\":%.17g,\"skin\":", g->n_caps, lk->tone);
    sp_strbuf_json_numbers(b, lk->skin, 3);
    sp_strbuf_printf(b, ",\"hair\":");
    sp_strbuf_json_numbers(b, lk->hair, 3);
    sp_strbuf_printf(b, ",\"iris\":");
    sp_strbuf_json_numbers(b, lk->iris, 3);
    sp_strbuf_printf(b, ",\"freckles\":%.17g,\"redness\":%.17g}},\n", lk->freckles, lk->redness);
}

static void manifest_materials(sp_strbuf *b, const sp_synth_selfie *g, const file_names *fn)
{
    sp_strbuf_printf(b, "\"albedo\":{\"png\":\"%s\",\"pfm\":\"albedo.pfm\",\"width\":%d,\"height\":%d,"
                        "\"png_encoding\":\"linear^(1/2.2)\"},\n\"displacement\":null,\n",
                     fn->albedo_png, g->aw, g->ah);
    sp_strbuf_printf(b, "\"specular\":{\"cluster_map\":\"%s\",\"clusters\":[", fn->clusters_png);
    for (int c = 0; c < SP_RENDER_CLUSTERS; c++)
        sp_strbuf_printf(b, "%s{\"id\":%d,\"name\":\"%s\",\"ks\":%.17g,\"shininess\":%.17g}", c ? "," : "", c,
                         cluster_names[c], g->ks[c], g->shininess[c]);
    sp_strbuf_printf(b, "]},\n");
}

static void manifest_lighting(sp_strbuf *b, const sp_synth_selfie *g, const file_names *fn)
{
    const sp_synth_selfie_settings *s = &g->s;
    sp_strbuf_printf(b, "\"lighting\":{\"sun\":{\"direction_world\":");
    sp_strbuf_json_numbers(b, g->sun_dir, 3);
    sp_strbuf_printf(b, ",\"elevation_deg\":%.17g,\"azimuth_deg\":%.17g,\"intensity\":%.17g,\"angular_radius\":0},"
                        "\"sky\":{\"model\":\"%s\",\"intensity\":%.17g,\"ground_albedo\":%.17g},\"env_pfm\":\"env.pfm\","
                        "\"env_png\":\"%s\",\"env_layout\":\"%d rows x %d columns, row i: polar angle from +z, "
                        "column j: azimuth from +x towards +y\"},\n",
                     s->sun_elevation_deg, s->sun_azimuth_deg, g->sun_intensity, s->overcast ? "overcast" : "clear",
                     s->sky_intensity, g->ground_albedo, fn->env_png, SP_RENDER_ENV_H, SP_RENDER_ENV_W);
    /* the default (the sky map) leaves the manifest as it was, and so does the city at infinity */
    if (s->backdrop == SP_SYNTH_BACKDROP_CITY && !(s->backdrop_distance_m > 0.0))
        sp_strbuf_printf(b,
                         "\"backdrop\":{\"kind\":\"city\",\"note\":\"background pixels show a city panorama "
                         "at infinity shaded by the sky; the head is lit by env.pfm alone\"},\n");
    else if (s->backdrop == SP_SYNTH_BACKDROP_CITY)
        sp_strbuf_printf(b,
                         "\"backdrop\":{\"kind\":\"city\",\"distance_m\":%.17g,\"note\":\"background pixels "
                         "show a city panorama on a sphere of radius distance_m about the world origin (the turning "
                         "axis), shaded by the sky: the arm's motion adds parallax; the head is lit by env.pfm "
                         "alone\"},\n",
                         s->backdrop_distance_m);
}

static void manifest_motion(sp_strbuf *b, const sp_synth_selfie *g)
{
    const sp_fake_imu_settings *m = &g->s.imu;
    double q[4] = { m->imu_to_camera.w, m->imu_to_camera.x, m->imu_to_camera.y, m->imu_to_camera.z };
    double gb[3] = { m->gyro_bias.x, m->gyro_bias.y, m->gyro_bias.z };
    double ab[3] = { m->accel_bias.x, m->accel_bias.y, m->accel_bias.z };
    sp_strbuf_printf(b, "\"motion\":{\"start_ns\":%lld,\"still_before_s\":%.17g,\"turn_duration_s\":%.17g,"
                        "\"turn_deg\":%.17g,\"still_after_s\":%.17g,\"heading_deg\":%.17g,\"pitch_deg\":%.17g,"
                        "\"arm_radius_m\":%.17g,\"wobble_deg\":%.17g,\"camera_height_m\":%.17g,"
                        "\"head_wobble_deg\":%.17g},\n",
                     (long long)m->start_ns, m->still_before_s, m->turn_duration_s, m->turn_deg, m->still_after_s,
                     m->heading_deg, m->pitch_deg, m->arm_radius_m, m->wobble_deg, g->s.camera_height_m,
                     g->s.head_wobble_deg);
    sp_strbuf_printf(b, "\"imu\":{\"rate_hz\":%.17g,\"imu_to_camera\":", m->rate_hz);
    sp_strbuf_json_numbers(b, q, 4);
    sp_strbuf_printf(b, ",\"gyro_noise\":%.17g,\"gyro_bias\":", m->gyro_noise);
    sp_strbuf_json_numbers(b, gb, 3);
    sp_strbuf_printf(b, ",\"accel_noise\":%.17g,\"accel_bias\":", m->accel_noise);
    sp_strbuf_json_numbers(b, ab, 3);
    sp_strbuf_printf(b, ",\"gyro_range\":%.17g,\"seed\":%llu%s},\n", m->gyro_range, (unsigned long long)m->seed,
                     g->s.no_imu ? ",\"in_capture\":false" : ""); /* no_imu: the motion's IMU, not written */
}

int synth_write_truth(sp_synth_selfie *g, const char *dir, const char *capture_name, sp_synth_selfie_report *rep)
{
    file_names fn;
    sp_strbuf held = { 0 }, b = { 0 };
    int ret = write_textures(g, dir, &fn);
    if (!ret)
        ret = write_frames(g, dir);
    if (!ret)
        ret = write_heldouts(g, dir, &held, &rep->heldout_frames);
    if (ret) {
        sp_strbuf_free(&held);
        return ret;
    }
    sp_strbuf_printf(&b, "{\"version\":1,\"generator\":\"sunprobe synth selfie\",\"seed\":%llu,\"capture\":",
                     (unsigned long long)g->s.seed);
    sp_strbuf_json_string(&b, capture_name);
    sp_strbuf_printf(&b, ",\"frames\":{\"count\":%llu,\"file\":\"frames.json\"},\n", (unsigned long long)g->n_frames);
    manifest_camera(&b, g);
    manifest_face(&b, g);
    manifest_materials(&b, g, &fn);
    manifest_lighting(&b, g, &fn);
    manifest_motion(&b, g);
    sp_strbuf_printf(&b, "\"heldout\":");
    sp_strbuf_append(&b, held.data ? held.data : "[]", held.data ? held.len : 2);
    sp_strbuf_printf(&b, "}\n");
    sp_strbuf_free(&held);
    return write_json(dir, "truth.json", &b);
}
