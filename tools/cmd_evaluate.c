/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe evaluate FACE_DIR CAPTURE_DIR`: scores a fitted face against a
 * capture directory with ground truth laid out like the folders of ../shared/captures
 * (meta.json, gt/relight/relight.json, gt/nvs/nvs.json): sun direction error,
 * training and held-out PSNR, relighting and novel-view PSNR/SSIM inside the
 * union of the true and rendered face masks, landmark coverage and error (the
 * fit's landmarks.csv against gt/landmarks.csv), fit time. Table on stdout, JSON
 * with --json.
 *
 * Registration uses the fit's own cameras: the fit's world maps onto the true
 * one by the rotation that best aligns the keyframe camera orientations, and
 * the asset's mesh onto the true head frame by the mean over keyframes of
 * (true head pose)^-1 (true camera) (fitted face pose) (asset placement)^-1.
 * A held-out image is then drawn with its own camera, head pose and sun.
 */
#include <errno.h>
#include <getopt.h>
#include <libgen.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cmd.h"
#include "common/atomic_file.h"
#include "common/rigid.h"
#include "common/file_util.h"
#include "common/image_metrics.h"
#include "common/json.h"
#include "export/png.h"
#include "export/png_read.h"
#include "sunprobe/sp_face_model.h"
#include "sunprobe/sp_math.h"
#include "sunprobe/sp_sunstage.h"
#include "tools/evaluate_landmarks.h"

#define MAX_KEYFRAMES 80

typedef sp_rigid rigid; /* x' = R x + t */

typedef struct eval_args {
    const char *face, *capture, *json, *renders;
    int passes; /* --passes: per-pixel planes of every view beside its PNG (save_passes) */
} eval_args;

typedef struct scored {
    int n;
    double psnr_sum, ssim_sum, psnr_min;
    double overlap_sum; /* fraction of the true face mask the rendered face covers */
} scored;

typedef struct eval_ctx {
    const eval_args *a;
    sp_face_asset asset;
    sp_face_model model;        /* for its face mask, when its topology is the asset's */
    int have_model;
    const uint8_t *face_mask;   /* per asset vertex, or NULL: the rendered mask is the whole mesh */
    sp_json *meta, *cams, *manifest;
    double align[9]; /* fit world -> true world */
    rigid asset_to_head;
    double asset_scale; /* the asset is drawn k times its size: the monocular fit's depth-scale gauge, registered */
    int n_keyframes;
    double camera_err_mean, camera_err_max;
    double sun_err;  /* NaN: not scored */
    const char *sun_note;
    const char *relight_note; /* why relighting was not scored, or how it was lit; NULL: the fitted sun */
    scored relight, nvs;
    sp_strbuf images; /* per-image JSON rows */
    int srgb;                /* the face directory's capture was sRGB: renders are compared as sRGB */
    int have_landmarks[2];   /* the tracker's record (landmarks.csv) and the fitted model's (landmarks_fitted.csv) */
    landmark_score landmarks[2];
} eval_ctx;

/* The two landmark records a face directory may hold: its manifest key, and how the table names it. */
static const char *const landmark_files[2] = { "landmarks", "landmarks_fitted" };
static const char *const landmark_labels[2] = { "landmarks, tracker", "landmarks, fitted model" };

static void usage(FILE *out)
{
    fprintf(out,
            "usage: sunprobe evaluate FACE_DIR CAPTURE_DIR [--json FILE] [--renders DIR [--passes]]\n\n"
            "Scores a fitted face against a capture with ground truth (laid out as in ../shared/captures):\n"
            "sun direction error, training and held-out PSNR, relighting (gt/relight) and novel-view\n"
            "(gt/nvs) PSNR and SSIM inside the union of the true and rendered face masks, and the\n"
            "coverage and error of the fit's landmarks (the tracker's landmarks.csv and the fitted model's\n"
            "landmarks_fitted.csv against gt/landmarks.csv).\n"
            "  --json FILE     also write the figures as JSON\n"
            "  --renders DIR   write each rendered view beside its ground truth as PNG\n"
            "  --passes        with --renders: also KIND_NN.f32, the view's per-pixel render, truth, masks,\n"
            "                  world normal and sun visibility as floats (layout in SUNSTAGE.md, Evaluation)\n");
}

/* ---- small rigid algebra ---- */

/* A 4x4 row-major JSON matrix (rotation part orthonormal) as a rigid transform; -1 if malformed. */
static int rigid_from_json(const sp_json *m, rigid *out)
{
    for (int i = 0; i < 3; i++) {
        double row[4];
        if (sp_json_numbers(sp_json_at(m, (size_t)i), row, 4) != 4)
            return -1;
        for (int j = 0; j < 3; j++)
            out->R[i * 3 + j] = row[j];
        out->t[i] = row[3];
    }
    return 0;
}


static double angle_deg(const double a[3], const double b[3])
{
    double na = sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]), nb = sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    double d = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) / fmax(na * nb, 1e-300);
    return acos(fmax(-1.0, fmin(1.0, d))) * 180.0 / M_PI;
}

/* ---- inputs ---- */

static int load_json(const char *dir, const char *name, sp_json **out)
{
    char *path = sp_path_join_alloc(dir, name);
    void *buf = NULL;
    size_t n = 0;
    int ret = path ? sp_read_whole_file(path, 256u << 20, &buf, &n) : -ENOMEM;
    char err[160] = "";
    if (!ret && (ret = sp_json_parse(buf, n, out, err, sizeof(err))))
        fprintf(stderr, "sunprobe evaluate: %s: %s\n", path, err);
    else if (ret)
        fprintf(stderr, "sunprobe evaluate: %s: %s\n", path ? path : name, sp_strerror(ret));
    free(buf);
    free(path);
    return ret;
}

/* The true frame of the capture with this index: its camera and rigid head pose. */
static const sp_json *true_frame(const eval_ctx *c, double index)
{
    const sp_json *frames = sp_json_get(c->meta, "frames");
    for (size_t i = 0;; i++) {
        const sp_json *f = sp_json_at(frames, i);
        if (!f)
            return NULL;
        if (sp_json_number(sp_json_get(f, "index"), -1) == index)
            return f;
    }
}

/* A keyframe's fitted camera orientation and face pose (model x s -> camera). */
static int fitted_keyframe(const sp_json *k, rigid *face, double q_c2w[9])
{
    double q[4], rv[3];
    if (sp_json_numbers(sp_json_get(k, "camera_to_world_wxyz"), q, 4) != 4 ||
        sp_json_numbers(sp_json_get(k, "face_rotvec"), rv, 3) != 3 ||
        sp_json_numbers(sp_json_get(k, "face_t"), face->t, 3) != 3)
        return -1;
    sp_quat_to_matrix(sp_quat_normalize((sp_quat){ q[0], q[1], q[2], q[3] }), q_c2w);
    sp_quat_to_matrix(sp_quat_from_rotvec((sp_vec3){ rv[0], rv[1], rv[2] }), face->R);
    return 0;
}

/*
 * The fit's world onto the true world (camera orientations) and the asset onto the true head
 * frame (every keyframe's fitted face pose against the true one), with the camera errors.
 */
static int register_fit(eval_ctx *c)
{
    const sp_json *frames = sp_json_get(c->cams, "frames");
    rigid place0 = { { 0 } }; /* asset -> scaled model frame: inverse of keyframe 0's placement */
    int have0 = 0;
    sp_quat_mean world, head;
    sp_quat_mean_init(&world);
    sp_quat_mean_init(&head);
    rigid G[MAX_KEYFRAMES], F[MAX_KEYFRAMES], HC[MAX_KEYFRAMES];
    double E[MAX_KEYFRAMES][9], T[MAX_KEYFRAMES][9], ratio[MAX_KEYFRAMES];
    int n = 0;
    for (size_t i = 0; n < MAX_KEYFRAMES; i++) {
        const sp_json *k = sp_json_at(frames, i);
        if (!k)
            break;
        rigid face, cam, hd;
        double e[9];
        const sp_json *tf = true_frame(c, sp_json_number(sp_json_get(k, "sequence"), -1));
        if (fitted_keyframe(k, &face, e) || !tf || rigid_from_json(sp_json_get(tf, "cam_to_world"), &cam) ||
            rigid_from_json(sp_json_get(tf, "head_to_world_rigid_m"), &hd))
            continue;
        const sp_json *held = sp_json_get(k, "heldout");
        if (!have0 && held && held->type == SP_JSON_BOOL && held->number == 0.0) { /* the asset is placed as the first training keyframe */
            rigid w0 = { { 0 }, { 0, 0, 0 } };
            memcpy(w0.R, e, sizeof(e));
            rigid p = sp_rigid_mul(&w0, &face);
            place0 = sp_rigid_inv(&p);
            have0 = 1;
        }
        memcpy(E[n], e, sizeof(e));
        memcpy(T[n], cam.R, sizeof(cam.R));
        double a[9]; /* T E^T */
        for (int r = 0; r < 3; r++)
            for (int q = 0; q < 3; q++)
                a[r * 3 + q] = cam.R[r * 3] * e[q * 3] + cam.R[r * 3 + 1] * e[q * 3 + 1] + cam.R[r * 3 + 2] * e[q * 3 + 2];
        sp_quat_mean_add(&world, sp_quat_from_matrix(a));
        rigid hinv = sp_rigid_inv(&hd);
        HC[n] = sp_rigid_mul(&hinv, &cam); /* camera -> true head */
        F[n] = face;                    /* scaled model -> camera, composed with place0 below */
        rigid ch = sp_rigid_inv(&HC[n]);   /* the true head's origin in this camera, against the fitted one */
        double dt = sqrt(ch.t[0] * ch.t[0] + ch.t[1] * ch.t[1] + ch.t[2] * ch.t[2]);
        double df = sqrt(face.t[0] * face.t[0] + face.t[1] * face.t[1] + face.t[2] * face.t[2]);
        ratio[n] = df > 0.0 ? dt / df : 1.0;
        n++;
    }
    if (n < 1 || !have0) {
        fprintf(stderr, "sunprobe evaluate: no fitted keyframe matches a frame of %s/meta.json\n", c->a->capture);
        return SP_ENODATA;
    }
    sp_quat_to_matrix(sp_quat_mean_get(&world), c->align);
    c->n_keyframes = n;
    for (int i = 0; i < n; i++) {
        double ae[9];
        for (int r = 0; r < 3; r++)
            for (int q = 0; q < 3; q++)
                ae[r * 3 + q] = c->align[r * 3] * E[i][q] + c->align[r * 3 + 1] * E[i][3 + q] +
                                c->align[r * 3 + 2] * E[i][6 + q];
        double err = sp_quat_angle_between(sp_quat_from_matrix(ae), sp_quat_from_matrix(T[i])) * 180.0 / M_PI;
        c->camera_err_mean += err / n;
        c->camera_err_max = fmax(c->camera_err_max, err);
    }
    /*
     * One camera sees the same image of a head k times as large k times as far: the fit's size is
     * a prior's, not a measurement. The held-out views are drawn with the fitted head scaled about
     * each keyframe's camera by the median k, as a similarity, and k is reported.
     */
    double sorted[MAX_KEYFRAMES];
    memcpy(sorted, ratio, sizeof(double) * (size_t)n);
    for (int i = 1; i < n; i++)
        for (int j = i; j > 0 && sorted[j - 1] > sorted[j]; j--) {
            double t = sorted[j];
            sorted[j] = sorted[j - 1];
            sorted[j - 1] = t;
        }
    double med = n % 2 ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
    c->asset_scale = med > 0.5 && med < 2.0 ? med : 1.0;
    for (int i = 0; i < n; i++) {
        rigid fp = sp_rigid_mul(&F[i], &place0);
        for (int q = 0; q < 3; q++)
            fp.t[q] *= c->asset_scale;
        G[i] = sp_rigid_mul(&HC[i], &fp); /* x -> k G.R x + G.t */
        sp_quat_mean_add(&head, sp_quat_from_matrix(G[i].R));
    }
    sp_quat_to_matrix(sp_quat_mean_get(&head), c->asset_to_head.R);
    /*
     * The translation: where the keyframes put the face's centre in the head frame, on average. The
     * asset's origin is the fit's world origin, about an arm's length from the face, where a
     * degree of disagreement between keyframes' rotations moves it by centimetres.
     */
    double centre[3] = { 0, 0, 0 }, at[3] = { 0, 0, 0 };
    const sp_mesh *mesh = &c->asset.mesh;
    for (uint32_t v = 0; v < mesh->n_vertices; v++)
        for (int q = 0; q < 3; q++)
            centre[q] += (double)mesh->positions[(size_t)v * 3 + (size_t)q] / (double)mesh->n_vertices;
    for (int i = 0; i < n; i++) {
        double g[3];
        sp_mat3_apply(G[i].R, centre, g);
        for (int q = 0; q < 3; q++)
            at[q] += (c->asset_scale * g[q] + G[i].t[q]) / n;
    }
    double rc[3];
    sp_mat3_apply(c->asset_to_head.R, centre, rc);
    for (int q = 0; q < 3; q++)
        c->asset_to_head.t[q] = at[q] - c->asset_scale * rc[q];
    return 0;
}

/* ---- one held-out image ---- */

static int read_truth(const char *path, float **rgb, uint8_t **mask, int *w, int *h, int as_mask)
{
    uint8_t *px = NULL;
    uint32_t pw = 0, ph = 0;
    int ret = sp_png_read_rgba(path, &px, &pw, &ph);
    if (ret) {
        fprintf(stderr, "sunprobe evaluate: %s: %s\n", path, sp_strerror(ret));
        return ret;
    }
    size_t n = (size_t)pw * ph;
    if (as_mask) {
        *mask = malloc(n);
        for (size_t i = 0; *mask && i < n; i++)
            (*mask)[i] = px[i * 4] > 127;
    } else {
        *rgb = malloc(sizeof(float) * n * 3);
        for (size_t i = 0; *rgb && i < n; i++)
            for (int k = 0; k < 3; k++)
                (*rgb)[i * 3 + (size_t)k] = (float)px[i * 4 + (size_t)k] / 255.0f;
    }
    free(px);
    *w = (int)pw;
    *h = (int)ph;
    return (as_mask ? (void *)*mask : (void *)*rgb) ? 0 : -ENOMEM;
}

static void save_pair(const eval_ctx *c, const char *kind, int index, const float *render, const float *truth, int w,
                      int h)
{
    char name[64];
    snprintf(name, sizeof(name), "%s_%02d.png", kind, index);
    char *path = sp_path_join_alloc(c->a->renders, name);
    uint8_t *px = malloc((size_t)w * 2 * h * 3);
    for (int y = 0; px && y < h; y++)
        for (int x = 0; x < 2 * w; x++)
            for (int k = 0; k < 3; k++) {
                const float *src = x < w ? render : truth;
                double v = src[((size_t)y * w + (size_t)(x % w)) * 3 + (size_t)k];
                px[((size_t)y * 2 * w + (size_t)x) * 3 + (size_t)k] = (uint8_t)lround(255.0 * fmin(1.0, fmax(0.0, v)));
            }
    if (px && path && sp_png_write(path, px, (uint32_t)(2 * w), (uint32_t)h, (uint32_t)(2 * w * 3), 3))
        fprintf(stderr, "sunprobe evaluate: cannot write %s\n", path);
    free(px);
    free(path);
}

/*
 * --passes: KIND_NN.f32 beside KIND_NN.png, for residual analyses (tools/bench/residual_by_normal.py):
 * "SPEV", int32 version 1, width, height, float32 sun direction (world, towards the sun) and intensity,
 * then float32 planes of width x height: the render (RGB, as scored), the truth (RGB), the rendered
 * face's coverage, the true mask (0/1), the shading normal (world xyz, unit; 0 off the head) and the
 * sun visibility (0..1). Native byte order. Written atomically, as the PNGs are; a failure is reported
 * and skips the file.
 */
static void save_passes(const eval_ctx *c, const char *kind, int index, const sp_face_view *v, const float *render,
                        const float *truth, const float *cover, const uint8_t *tmask, int w, int h)
{
    size_t np = (size_t)w * (size_t)h;
    float *nrm = malloc(sizeof(float) * np * 3), *vis = malloc(sizeof(float) * np), *head = malloc(sizeof(float) * np);
    float *tm = malloc(sizeof(float) * np);
    char name[64];
    snprintf(name, sizeof(name), "%s_%02d.f32", kind, index);
    char *path = sp_path_join_alloc(c->a->renders, name);
    sp_face_passes ps = { .normal = nrm, .visibility = vis, .coverage = head };
    int ok = nrm && vis && head && tm && tmask && path && !sp_face_asset_render_passes(&c->asset, v, &ps);
    for (size_t i = 0; ok && i < np; i++) { /* the passes are premultiplied by the head's coverage */
        double n2 = 0.0;
        for (int k = 0; k < 3; k++)
            n2 += (double)nrm[i * 3 + (size_t)k] * (double)nrm[i * 3 + (size_t)k];
        float s = n2 > 1e-12 ? (float)(1.0 / sqrt(n2)) : 0.0f;
        for (int k = 0; k < 3; k++)
            nrm[i * 3 + (size_t)k] *= s;
        vis[i] = head[i] > 1e-6f ? fminf(1.0f, vis[i] / head[i]) : 0.0f;
        tm[i] = (float)tmask[i];
    }
    sp_atomic_file af;
    if (ok && !sp_atomic_file_open(&af, path)) {
        FILE *f = af.file;
        int32_t hd[4] = { 0, 1, w, h };
        memcpy(hd, "SPEV", 4);
        float sun[4] = { (float)v->sun_dir[0], (float)v->sun_dir[1], (float)v->sun_dir[2], (float)v->sun_intensity };
        ok = fwrite(hd, sizeof(hd), 1, f) == 1 && fwrite(sun, sizeof(sun), 1, f) == 1 &&
            fwrite(render, sizeof(float), np * 3, f) == np * 3 && fwrite(truth, sizeof(float), np * 3, f) == np * 3 &&
            fwrite(cover, sizeof(float), np, f) == np && fwrite(tm, sizeof(float), np, f) == np &&
            fwrite(nrm, sizeof(float), np * 3, f) == np * 3 && fwrite(vis, sizeof(float), np, f) == np;
        ok = sp_atomic_file_finish(&af, ok ? 0 : -EIO) == 0;
    } else {
        ok = 0;
    }
    if (!ok)
        fprintf(stderr, "sunprobe evaluate: cannot write %s\n", path ? path : name);
    free(path);
    free(nrm);
    free(vis);
    free(head);
    free(tm);
}

/* Renders one gt/relight or gt/nvs image with its camera, head pose and the given sun; scores it. */
static int score_image(eval_ctx *c, const char *kind, const sp_json *img, const double K[4], const double sun[3],
                       double sun_I, scored *acc)
{
    rigid cam, head;
    const char *file = sp_json_string(sp_json_get(img, "file"), NULL);
    const char *mfile = sp_json_string(sp_json_get(img, "mask"), NULL);
    if (!file || !mfile || rigid_from_json(sp_json_get(img, "cam_to_world"), &cam) ||
        rigid_from_json(sp_json_get(img, "head_to_world_rigid_m"), &head))
        return SP_ECORRUPT;
    char *path = sp_path_join_alloc(c->a->capture, file), *mpath = sp_path_join_alloc(c->a->capture, mfile);
    float *truth = NULL, *render = NULL, *cover = NULL;
    uint8_t *mask = NULL;
    int w = 0, h = 0, mw = 0, mh = 0;
    int ret = path && mpath ? read_truth(path, &truth, NULL, &w, &h, 0) : -ENOMEM;
    if (!ret)
        ret = read_truth(mpath, NULL, &mask, &mw, &mh, 1);
    if (!ret && (mw != w || mh != h))
        ret = SP_ECORRUPT;
    sp_face_view v;
    sp_face_view_init(&v, &c->asset);
    v.width = w;
    v.height = h;
    v.vertex_mask = c->face_mask;
    if (!ret) {
        render = malloc(sizeof(float) * 3 * (size_t)w * h);
        cover = malloc(sizeof(float) * (size_t)w * h);
        ret = render && cover ? 0 : -ENOMEM;
    }
    if (!ret) {
        v.camera.fx = K[0], v.camera.fy = K[1], v.camera.cx = K[2], v.camera.cy = K[3];
        rigid w2c = sp_rigid_inv(&cam), a2w = sp_rigid_mul(&head, &c->asset_to_head);
        memcpy(v.camera.R, w2c.R, sizeof(w2c.R));
        memcpy(v.camera.t, w2c.t, sizeof(w2c.t));
        for (int i = 0; i < 3; i++) {
            for (int j = 0; j < 3; j++)
                v.asset_to_world[i * 4 + j] = c->asset_scale * a2w.R[i * 3 + j];
            v.asset_to_world[i * 4 + 3] = a2w.t[i];
        }
        memcpy(v.env_to_world, c->align, sizeof(c->align));
        memcpy(v.sun_dir, sun, sizeof(v.sun_dir));
        v.sun_intensity = sun_I;
    }
    if (!ret)
        ret = sp_face_asset_render(&c->asset, &v, render, cover);
    if (!ret && c->srgb) /* the fit decoded sRGB frames to linear light: compare in the capture's encoding */
        for (size_t i = 0; i < (size_t)w * (size_t)h * 3; i++)
            render[i] = (float)sp_sunstage_display_to_srgb((double)render[i]);
    if (!ret) {
        size_t npx = (size_t)w * h, n_true = 0, n_both = 0;
        uint8_t *tmask = c->a->passes ? malloc(npx) : NULL; /* the true mask alone, for --passes */
        if (tmask)
            memcpy(tmask, mask, npx);
        for (size_t i = 0; i < npx; i++) {
            n_true += mask[i];
            n_both += mask[i] && cover[i] > 0.5f;
            mask[i] = mask[i] || cover[i] > 0.5f;
        }
        double overlap = n_true ? (double)n_both / (double)n_true : (double)NAN;
        acc->overlap_sum += overlap;
        double p = sp_psnr_masked(render, truth, mask, w, h), s = sp_ssim_masked(render, truth, mask, w, h);
        acc->n++;
        acc->psnr_sum += p;
        acc->ssim_sum += s;
        acc->psnr_min = acc->n == 1 ? p : fmin(acc->psnr_min, p);
        sp_strbuf_printf(&c->images, "%s{\"kind\":\"%s\",\"file\":", c->images.len ? ",\n" : "\n", kind);
        sp_strbuf_json_string(&c->images, file);
        sp_strbuf_printf(&c->images, ",\"psnr\":");
        sp_strbuf_json_number(&c->images, p);
        sp_strbuf_printf(&c->images, ",\"ssim\":");
        sp_strbuf_json_number(&c->images, s);
        sp_strbuf_printf(&c->images, ",\"mask_overlap\":");
        sp_strbuf_json_number(&c->images, overlap);
        sp_strbuf_printf(&c->images, "}");
        if (c->a->renders)
            save_pair(c, kind, (int)sp_json_number(sp_json_get(img, "index"), acc->n - 1), render, truth, w, h);
        if (c->a->passes)
            save_passes(c, kind, (int)sp_json_number(sp_json_get(img, "index"), acc->n - 1), &v, render, truth, cover,
                        tmask, w, h);
        free(tmask);
    }
    free(path);
    free(mpath);
    free(truth);
    free(render);
    free(cover);
    free(mask);
    return ret;
}

/* Every image of gt/KIND/KIND.json; the sun per image (relight) or the fitted one (nvs). */
static int score_set(eval_ctx *c, const char *kind, scored *acc)
{
    char rel[64];
    snprintf(rel, sizeof(rel), "gt/%s/%s.json", kind, kind);
    sp_json *set = NULL;
    int ret = load_json(c->a->capture, rel, &set);
    if (ret)
        return ret;
    const sp_json *cam = sp_json_get(set, "camera");
    if (!cam) {
        fprintf(stderr, "sunprobe evaluate: %s/%s has no \"camera\"\n", c->a->capture, rel);
        sp_json_free(set);
        return SP_ECORRUPT;
    }
    double K[4] = { sp_json_number(sp_json_get(cam, "fx"), NAN), sp_json_number(sp_json_get(cam, "fy"), NAN),
                    sp_json_number(sp_json_get(cam, "cx"), NAN), sp_json_number(sp_json_get(cam, "cy"), NAN) };
    double fit_sun[3];
    sp_mat3_apply(c->align, c->asset.sun_dir, fit_sun);
    double fit_I = c->asset.left_out & SP_FACE_LEFT_OUT_SUN ? 0.0 : c->asset.sun_intensity;
    const sp_json *imgs = sp_json_get(set, "images");
    for (size_t i = 0; !ret; i++) {
        const sp_json *img = sp_json_at(imgs, i);
        if (!img)
            break;
        if (sp_cmd_stop_signal) { /* between images: each render and pass file is whole or not there */
            ret = -ECANCELED;
            break;
        }
        double sun[3];
        if (!strcmp(kind, "relight")) {
            if (sp_json_numbers(sp_json_get(img, "sun_dir_world"), sun, 3) != 3) {
                ret = SP_ECORRUPT;
                break;
            }
            double I = fit_I;
            if (!(I > 0.0)) { /* overcast: the fit's geometry, albedo and sky under the true sun's irradiance,
                                 which is in the fit's units when the capture's pixels are the scene's radiance */
                I = sp_json_number(sp_json_get(img, "sun_strength"), NAN);
                if (!(I > 0.0 && I < 1e6)) {
                    c->relight_note = "relighting not scored: the fit has no sun and the image no \"sun_strength\"";
                    break;
                }
                c->relight_note = "relighting with the true sun's strength: the fit left the sun out";
            }
            ret = score_image(c, kind, img, K, sun, I, acc);
        } else {
            ret = score_image(c, kind, img, K, fit_sun, fit_I, acc);
        }
    }
    sp_json_free(set);
    return ret;
}

/* ---- the report ---- */

/* what: 0 PSNR, 1 SSIM, 2 mask overlap */
static double mean_of(const scored *s, int what)
{
    double sum = what == 0 ? s->psnr_sum : what == 1 ? s->ssim_sum : s->overlap_sum;
    return s->n ? sum / s->n : (double)NAN;
}

static void sun_error(eval_ctx *c)
{
    c->sun_err = NAN;
    const sp_json *sun = sp_json_get(c->meta, "sun");
    const sp_json *present = sp_json_get(sun, "present");
    double truth[3];
    int has_sun = present && present->type == SP_JSON_BOOL && present->number != 0.0 &&
                  sp_json_numbers(sp_json_get(sun, "dir_world"), truth, 3) == 3;
    int fitted = !(c->asset.left_out & SP_FACE_LEFT_OUT_SUN) && c->asset.sun_intensity > 0.0;
    if (has_sun && fitted) {
        double d[3];
        sp_mat3_apply(c->align, c->asset.sun_dir, d);
        c->sun_err = angle_deg(d, truth);
        c->sun_note = "";
    } else if (has_sun) {
        c->sun_note = "the capture has a sun and the fit left it out";
    } else {
        c->sun_note = fitted ? "the capture is overcast and the fit kept a sun" : "overcast, and the sun was left out";
    }
}

static void print_table(const eval_ctx *c, const sp_json *fit)
{
    printf("evaluate: %s against %s\n", c->a->face, c->a->capture);
    printf("  %-28s %d keyframes, error mean %.2f deg, max %.2f deg\n", "cameras (heading aligned)", c->n_keyframes,
           c->camera_err_mean, c->camera_err_max);
    printf("  %-28s the true head is %.3f times the fitted one (views are drawn at that scale)\n",
           "depth-scale gauge", c->asset_scale);
    if (isfinite(c->sun_err))
        printf("  %-28s %.2f deg\n", "sun direction error", c->sun_err);
    else
        printf("  %-28s not scored: %s\n", "sun direction error", c->sun_note);
    printf("  %-28s %.2f dB / %.2f dB\n", "train / held-out PSNR", sp_json_number(sp_json_get(fit, "train_psnr"), NAN),
           sp_json_number(sp_json_get(fit, "heldout_psnr"), NAN));
    printf("  %-28s %d images: PSNR %.2f dB (min %.2f), SSIM %.4f; rendered face covers %.0f%% of the true one\n",
           "relighting (gt/relight)", c->relight.n, mean_of(&c->relight, 0), c->relight.psnr_min,
           mean_of(&c->relight, 1), 100.0 * mean_of(&c->relight, 2));
    printf("  %-28s %d images: PSNR %.2f dB (min %.2f), SSIM %.4f; rendered face covers %.0f%% of the true one\n",
           "novel views (gt/nvs)", c->nvs.n, mean_of(&c->nvs, 0), c->nvs.psnr_min, mean_of(&c->nvs, 1),
           100.0 * mean_of(&c->nvs, 2));
    if (c->relight_note)
        printf("  %s\n", c->relight_note);
    for (int i = 0; i < 2; i++)
        if (c->have_landmarks[i] && !c->landmarks[i].found)
            printf("  %-28s not scored: on none of the %d frames with a visible face (%d tried)\n", landmark_labels[i],
                   c->landmarks[i].faces, c->landmarks[i].tried);
        else if (c->have_landmarks[i])
            printf("  %-28s on %d of %d frames with a visible face (%d tried, the rest skipped before detection); "
                   "error over the inter-ocular distance mean %.2f%%, 90th percentile %.2f%%\n",
                   landmark_labels[i], c->landmarks[i].found, c->landmarks[i].faces, c->landmarks[i].tried,
                   100.0 * c->landmarks[i].mean, 100.0 * c->landmarks[i].p90);
    printf("  %-28s %.1f s\n", "fit wall time", sp_json_number(sp_json_get(fit, "seconds"), NAN));
}

static int write_json(const eval_ctx *c, const sp_json *fit)
{
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"face_dir\":");
    sp_strbuf_json_string(&b, c->a->face);
    sp_strbuf_printf(&b, ",\"capture\":");
    sp_strbuf_json_string(&b, c->a->capture);
    sp_strbuf_printf(&b, ",\"keyframes\":%d,\"camera_error_deg\":{\"mean\":", c->n_keyframes);
    sp_strbuf_json_number(&b, c->camera_err_mean);
    sp_strbuf_printf(&b, ",\"max\":");
    sp_strbuf_json_number(&b, c->camera_err_max);
    sp_strbuf_printf(&b, "},\"head_scale_true_over_fit\":");
    sp_strbuf_json_number(&b, c->asset_scale);
    sp_strbuf_printf(&b, ",\"sun_error_deg\":");
    sp_strbuf_json_number(&b, c->sun_err);
    sp_strbuf_printf(&b, ",\"sun_note\":");
    sp_strbuf_json_string(&b, c->sun_note ? c->sun_note : "");
    const char *keys[] = { "train_psnr", "heldout_psnr", "seconds" };
    for (int i = 0; i < 3; i++) {
        sp_strbuf_printf(&b, ",\"fit_%s\":", keys[i]);
        sp_strbuf_json_number(&b, sp_json_number(sp_json_get(fit, keys[i]), NAN));
    }
    const scored *sets[2] = { &c->relight, &c->nvs };
    const char *names[2] = { "relight", "nvs" };
    for (int i = 0; i < 2; i++) {
        sp_strbuf_printf(&b, ",\"%s\":{\"images\":%d,\"psnr\":", names[i], sets[i]->n);
        sp_strbuf_json_number(&b, mean_of(sets[i], 0));
        sp_strbuf_printf(&b, ",\"psnr_min\":");
        sp_strbuf_json_number(&b, sets[i]->n ? sets[i]->psnr_min : (double)NAN);
        sp_strbuf_printf(&b, ",\"ssim\":");
        sp_strbuf_json_number(&b, mean_of(sets[i], 1));
        sp_strbuf_printf(&b, ",\"mask_overlap\":");
        sp_strbuf_json_number(&b, mean_of(sets[i], 2));
        if (i == 0 && c->relight_note) {
            sp_strbuf_printf(&b, ",\"note\":");
            sp_strbuf_json_string(&b, c->relight_note);
        }
        sp_strbuf_printf(&b, "}");
    }
    for (int i = 0; i < 2; i++) {
        const landmark_score *l = &c->landmarks[i];
        if (!c->have_landmarks[i])
            continue;
        sp_strbuf_printf(&b,
                         ",\"%s\":{\"frames_with_face\":%d,\"tried\":%d,\"found\":%d,\"error_iod\":", landmark_files[i],
                         l->faces, l->tried, l->found);
        sp_strbuf_json_number(&b, l->found ? l->mean : (double)NAN);
        sp_strbuf_printf(&b, ",\"error_iod_p90\":");
        sp_strbuf_json_number(&b, l->found ? l->p90 : (double)NAN);
        sp_strbuf_printf(&b, "}");
    }
    sp_strbuf_printf(&b, ",\"images\":[%s]}\n", c->images.data ? c->images.data : "");
    int ret = b.failed ? -ENOMEM : sp_write_whole_file_atomic(c->a->json, b.data, b.len);
    sp_strbuf_free(&b);
    return ret;
}

static int parse_args(int argc, char **argv, eval_args *a)
{
    static const struct option opts[] = {
        { "help", no_argument, NULL, 'h' },
        { "json", required_argument, NULL, 'j' },
        { "renders", required_argument, NULL, 'r' },
        { "passes", no_argument, NULL, 'p' },
        { 0 },
    };
    int c;
    while ((c = getopt_long(argc, argv, "h", opts, NULL)) != -1) {
        switch (c) {
        case 'h': usage(stdout); return 1;
        case 'j': a->json = optarg; break;
        case 'r': a->renders = optarg; break;
        case 'p':
            a->passes = 1;
            break;
        default: usage(stderr); return -1;
        }
    }
    if (optind != argc - 2) {
        fprintf(stderr, "sunprobe evaluate: expected FACE_DIR and CAPTURE_DIR (see --help)\n");
        return -1;
    }
    if (a->passes && !a->renders) {
        fprintf(stderr, "sunprobe evaluate: --passes needs --renders DIR\n");
        return -1;
    }
    a->face = argv[optind];
    a->capture = argv[optind + 1];
    return 0;
}

/*
 * The landmark records the manifest names, against the capture's gt/landmarks.csv; before the images are
 * rendered, so that a damaged record fails in a second, not after them. A record the manifest names must be
 * there; a capture without landmark truth is said and skipped.
 */
static int score_landmarks(eval_ctx *c)
{
    char truth_csv[4096];
    snprintf(truth_csv, sizeof(truth_csv), "%s/gt/landmarks.csv", c->a->capture);
    int have_truth = access(truth_csv, F_OK) == 0, ret;
    double last = -1; /* the capture's last frame index bounds the records' (none listed: no bound) */
    const sp_json *frames = sp_json_get(c->meta, "frames"), *f;
    for (size_t i = 0; (f = sp_json_at(frames, i)); i++) {
        double index = sp_json_number(sp_json_get(f, "index"), -1);
        if (isfinite(index) && index > last)
            last = index;
    }
    int n_frames = last >= 0 && last < 1e6 ? (int)last + 1 : 0;
    for (int i = 0; i < 2; i++) { /* the fit ran its landmark tracker (and fitted the model to every frame) */
        const char *name = sp_json_string(sp_json_get(c->manifest, landmark_files[i]), NULL);
        if (!name)
            continue;
        char fit_csv[4096], err[512] = "";
        if (strchr(name, '/') || !strcmp(name, "..") || !*name)
            return sp_cmd_failf("evaluate", SP_EFORMAT,
                                "%s/manifest.json: %s names \"%s\", not a file of the directory", c->a->face,
                                landmark_files[i], name);
        snprintf(fit_csv, sizeof(fit_csv), "%s/%s", c->a->face, name);
        if (access(fit_csv, F_OK) != 0)
            return sp_cmd_failf("evaluate", SP_EFORMAT, "%s is missing, though manifest.json names it", fit_csv);
        if (!have_truth) {
            fprintf(stderr, "sunprobe evaluate: %s: absent, %s not scored\n", truth_csv, fit_csv);
            continue;
        }
        if ((ret = evaluate_landmarks(fit_csv, truth_csv, n_frames, &c->landmarks[i], err, sizeof(err))))
            return sp_cmd_fail("evaluate", ret, err[0] ? err : "scoring the landmarks");
        c->have_landmarks[i] = 1;
    }
    return 0;
}

/* The report's directory must exist and be writable: said before the work, not after it (the report is written atomically). */
static int check_report_dir(const char *json)
{
    char *copy = strdup(json);
    if (!copy)
        return sp_cmd_fail("evaluate", -ENOMEM, json);
    struct stat st;
    const char *dir = dirname(copy);
    int err = stat(dir, &st) != 0 ? errno : !S_ISDIR(st.st_mode) ? ENOTDIR : access(dir, W_OK | X_OK) != 0 ? errno : 0;
    int code = err ? sp_cmd_failf("evaluate", -err, "--json %s: directory %s", json, dir) : 0;
    free(copy);
    return code;
}

static int run(eval_ctx *c)
{
    if (c->a->json) {
        int code = check_report_dir(c->a->json);
        if (code)
            return code;
    }
    int ret = sp_face_dir_read(&c->asset, c->a->face);
    if (ret) {
        fprintf(stderr, "sunprobe evaluate: %s is not a readable face directory: %s\n", c->a->face, sp_strerror(ret));
        return sp_exit_for_error(ret == -ENOENT ? SP_EFORMAT : ret);
    }
    if ((ret = load_json(c->a->face, "cameras.json", &c->cams)) || (ret = load_json(c->a->face, "manifest.json", &c->manifest)) ||
        (ret = load_json(c->a->capture, "meta.json", &c->meta)))
        return sp_exit_for_error(ret == -ENOENT ? SP_EFORMAT : ret);
    if ((ret = register_fit(c)))
        return sp_exit_for_error(ret);
    const char *transfer = sp_json_string(sp_json_get(c->manifest, "capture_transfer"), NULL);
    c->srgb = transfer && !strcmp(transfer, "srgb"); /* older face directories: the renderer's own encoding */
    /* the rendered face mask: the model's skin vertices, if the asset has the model's topology */
    c->have_model = sp_face_model_load_default(&c->model) == 0;
    if (c->have_model && c->model.mesh.n_vertices == c->asset.mesh.n_vertices && c->model.face_mask)
        c->face_mask = c->model.face_mask;
    else
        fprintf(stderr, "sunprobe evaluate: the face model does not match the asset's mesh: the rendered mask is "
                        "the whole mesh\n");
    if ((ret = score_landmarks(c)))
        return ret;
    if (c->a->renders && (ret = sp_mkdir_p(c->a->renders, 0755)))
        return sp_cmd_fail("evaluate", ret, c->a->renders);
    sun_error(c);
    if ((ret = score_set(c, "relight", &c->relight)) || (ret = score_set(c, "nvs", &c->nvs))) {
        if (ret == -ECANCELED && sp_cmd_stop_signal) { /* the renders already made are whole files: say so */
            fprintf(stderr, "sunprobe evaluate: interrupted by %s; no report written%s%s\n",
                    sp_cmd_signal_name(sp_cmd_stop_signal), c->a->renders ? "; the renders made so far stay in " : "",
                    c->a->renders ? c->a->renders : "");
            return sp_exit_for_error(ret);
        }
        return sp_cmd_fail("evaluate", ret, "scoring the held-out images");
    }
    const sp_json *fit = sp_json_get(c->manifest, "fit");
    print_table(c, fit);
    if (c->a->json && (ret = write_json(c, fit)))
        return sp_cmd_fail("evaluate", ret, c->a->json);
    return SP_EXIT_OK;
}

int sp_cmd_evaluate(int argc, char **argv)
{
    eval_args a = { 0 };
    int p = parse_args(argc, argv, &a);
    if (p)
        return p > 0 ? SP_EXIT_OK : SP_EXIT_USAGE;
    eval_ctx c = { .a = &a, .sun_err = NAN };
    sp_cmd_signals sig; /* every file it writes goes through a temporary: held until the last is renamed or removed */
    sp_cmd_catch_signals(&sig);
    int code = run(&c);
    sp_cmd_restore_signals(&sig);
    sp_face_asset_free(&c.asset);
    if (c.have_model)
        sp_face_model_free(&c.model);
    sp_json_free(c.meta);
    sp_json_free(c.cams);
    sp_json_free(c.manifest);
    sp_strbuf_free(&c.images);
    return code;
}
