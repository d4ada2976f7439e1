/* SPDX-License-Identifier: MIT */
/*
 * The selfie generator (pipeline/synth): a short small capture read back chunk
 * by chunk (frame and IMU counts, landmark and orientation side data for every
 * frame, META), the truth directory, determinism for a seed, noise-free frames
 * agreeing with the renderer, overcast, bad settings and lighting extremes; the street and turn
 * generators' captures, truth files, determinism, bad settings and cancelling.
 */
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "common/crc32c.h"
#include "common/file_util.h"
#include "common/jpeg.h"
#include "common/json.h"
#include "common/pixconv.h"
#include "export/png.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_synth.h"

static char tmpdir[256];

static void path_in(char *out, size_t n, const char *name) { snprintf(out, n, "%s/%s", tmpdir, name); }

/* Small and quick: 96x96, 2 s (0.5 still, 1 turn, 0.5 still) at 15 fps, generic head, small albedo. */
static void small_settings(sp_synth_selfie_settings *s)
{
    sp_synth_selfie_default_settings(s);
    s->width = s->height = 96;
    s->fps = 15;
    s->imu.still_before_s = s->imu.still_after_s = 0.5;
    s->imu.turn_duration_s = 1.0;
    s->face = SP_SYNTH_FACE_GENERIC;
    s->albedo_height = 128;
    s->supersample = 1;
    s->shadow_size = 256;
    s->n_relit = 2;
    s->n_novel = 3;
    s->write_image = sp_png_write;
}

static int generate(const sp_synth_selfie_settings *s, const char *cap, const char *truth, sp_synth_selfie_report *rep)
{
    sp_synth_selfie *g = NULL;
    int ret = sp_synth_selfie_open(&g, s);
    if (!ret)
        ret = sp_synth_selfie_write(g, cap, truth, rep);
    sp_synth_selfie_close(&g);
    return ret;
}

typedef struct scan {
    uint64_t frames, gyro, accel, imu, lm_chunks, ori_chunks, meta;
    uint64_t lm_outside, lm_bad;
    uint32_t payload_crc; /* over every chunk payload in file order */
    int64_t last_frame_ts;
    int ts_order_ok;
    char meta_json[2048];
} scan;

static void scan_side(const sp_chunk *ch, uint32_t w, uint32_t h, scan *sc)
{
    sp_side_chunk sd;
    if (sp_chunk_parse_side(ch, &sd))
        return;
    if (sd.kind == SP_SIDE_LANDMARKS_2D) {
        sc->lm_chunks++;
        sc->lm_bad += sd.count != 136;
        for (uint32_t i = 0; i + 1 < sd.count; i += 2) {
            float x = sp_side_value(&sd, i), y = sp_side_value(&sd, i + 1);
            sc->lm_outside += !(x >= 0 && x < (float)w && y >= 0 && y < (float)h);
        }
    } else if (sd.kind == SP_SIDE_TRUE_ORIENTATION && sd.count == 4) {
        double n = 0;
        for (uint32_t i = 0; i < 4; i++)
            n += (double)sp_side_value(&sd, i) * (double)sp_side_value(&sd, i);
        sc->ori_chunks += fabs(n - 1.0) < 1e-5;
    }
}

static int scan_capture(const char *path, uint32_t w, uint32_t h, scan *sc)
{
    memset(sc, 0, sizeof(*sc));
    sc->ts_order_ok = 1;
    sc->last_frame_ts = INT64_MIN;
    sp_capture_reader *r = NULL;
    int ret = sp_capture_reader_open(&r, path, NULL);
    while (!ret) {
        sp_chunk ch;
        ret = sp_capture_reader_next(r, &ch);
        if (ret)
            break;
        if (ch.type != SP_CHUNK_INDEX && ch.type != SP_CHUNK_END)
            sc->payload_crc = sp_crc32c(sc->payload_crc, ch.payload, ch.payload_size);
        if (ch.type == SP_CHUNK_FRAME) {
            sp_frame_chunk fc;
            if (sp_chunk_parse_frame(&ch, &fc) == 0 && fc.width == w && fc.height == h) {
                sc->frames++;
                sc->ts_order_ok &= ch.timestamp_ns > sc->last_frame_ts;
                sc->last_frame_ts = ch.timestamp_ns;
            }
        } else if (ch.type == SP_CHUNK_IMU) {
            int64_t n = sp_chunk_imu_count(&ch);
            for (int64_t i = 0; i < n; i++) {
                sp_imu_sample smp;
                if (sp_chunk_imu_get(&ch, (size_t)i, &smp) == 0) {
                    sc->gyro += smp.sensor == SP_IMU_GYRO;
                    sc->accel += smp.sensor == SP_IMU_ACCEL;
                    sc->imu++;
                }
            }
        } else if (ch.type == SP_CHUNK_SIDE) {
            scan_side(&ch, w, h, sc);
        } else if (ch.type == SP_CHUNK_META && ch.payload_size < sizeof(sc->meta_json)) {
            memcpy(sc->meta_json, ch.payload, ch.payload_size);
            sc->meta_json[ch.payload_size] = '\0';
            sc->meta++;
        }
    }
    int clean = sp_capture_reader_saw_end(r);
    sp_capture_reader_close(&r);
    return ret == SP_EOS && clean ? 0 : (ret ? ret : -EIO);
}

static uint64_t imu_ticks(const sp_fake_imu_settings *s)
{
    sp_fake_imu *imu = NULL;
    uint64_t n = 0;
    sp_imu_sample smp;
    if (sp_fake_imu_open(&imu, s))
        return 0;
    while (sp_fake_imu_next(imu, &smp) == 0)
        n++;
    sp_fake_imu_close(&imu);
    return n;
}

static int file_exists(const char *dir, const char *name)
{
    char p[512];
    struct stat st;
    snprintf(p, sizeof(p), "%s/%s", dir, name);
    return stat(p, &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0;
}

/* The whole file, NUL-terminated (common/file_util.h); NULL when it cannot be read. */
static char *slurp(const char *path, size_t *len)
{
    void *data = NULL;
    size_t n = 0;
    if (sp_read_whole_file(path, (size_t)1 << 30, &data, &n))
        return NULL;
    if (len)
        *len = n;
    return data;
}

static sp_json *load_json(const char *dir, const char *name)
{
    char p[512], err[128];
    size_t len = 0;
    snprintf(p, sizeof(p), "%s/%s", dir, name);
    char *text = slurp(p, &len);
    sp_json *root = NULL;
    if (text && sp_json_parse(text, len, &root, err, sizeof(err)) != 0)
        root = NULL;
    free(text);
    return root;
}

static void test_truth_dir(const char *truth, uint64_t n_frames)
{
    static const char *const files[] = { "truth.json", "frames.json", "albedo.png", "albedo.pfm", "clusters.png",
                                         "env.pfm", "env.png", "heldout/relit_00.png", "heldout/relit_01.json",
                                         "heldout/view_00.png", "heldout/view_02.json", "heldout/view_02_env.pfm" };
    for (size_t i = 0; i < sizeof(files) / sizeof(files[0]); i++)
        CHECK_MSG(file_exists(truth, files[i]), "missing %s/%s", truth, files[i]);
    sp_json *m = load_json(truth, "truth.json");
    CHECK(m != NULL);
    if (m) {
        CHECK_EQ_INT(sp_json_number(sp_json_get(sp_json_get(m, "frames"), "count"), -1), n_frames);
        const sp_json *held = sp_json_get(m, "heldout");
        CHECK(held && held->type == SP_JSON_ARRAY && held->count == 5);
        const sp_json *cl = sp_json_get(sp_json_get(m, "specular"), "clusters");
        CHECK(cl && cl->count == SP_RENDER_CLUSTERS);
        for (size_t c = 0; cl && c < cl->count; c++) {
            double ks = sp_json_number(sp_json_get(sp_json_at(cl, c), "ks"), -1);
            double sh = sp_json_number(sp_json_get(sp_json_at(cl, c), "shininess"), -1);
            CHECK(ks > 0 && ks < 0.2 && sh >= 5 && sh <= 100);
        }
        const sp_json *face = sp_json_get(m, "face");
        CHECK(sp_json_get(face, "identity") && sp_json_get(face, "identity")->count == 6);
        CHECK(sp_json_number(sp_json_get(sp_json_get(sp_json_get(m, "lighting"), "sun"), "intensity"), -1) == 3.0);
        sp_json_free(m);
    }
    sp_json *fr = load_json(truth, "frames.json");
    const sp_json *arr = sp_json_get(fr, "frames");
    CHECK(arr && arr->count == n_frames);
    for (size_t i = 0; arr && i < arr->count; i++) {
        double e = sp_json_number(sp_json_get(sp_json_at(arr, i), "exposure"), -1);
        CHECK_MSG(e > 0 && isfinite(e), "frame %zu exposure %g", i, e);
    }
    sp_json_free(fr);
    sp_json *v = load_json(truth, "heldout/view_01.json");
    const sp_json *lm = sp_json_get(v, "landmarks");
    CHECK(v && lm && lm->count == 136);
    CHECK(sp_json_number(sp_json_get(v, "exposure"), -1) > 0);
    sp_json_free(v);
}

/* A short capture: counts, side data, META, truth dir. */
static void test_capture(void)
{
    sp_synth_selfie_settings s;
    small_settings(&s);
    char cap[300], truth[300];
    path_in(cap, sizeof(cap), "a.spcap");
    path_in(truth, sizeof(truth), "a.truth");
    sp_synth_selfie_report rep;
    int ret = generate(&s, cap, truth, &rep);
    CHECK_EQ_INT(ret, 0);
    if (ret)
        return;
    uint64_t want_frames = (uint64_t)floor(2.0 * s.fps) + 1;
    CHECK_EQ_INT(rep.frames, want_frames);
    CHECK_EQ_INT(rep.heldout_frames, 5);
    char partial[320];
    snprintf(partial, sizeof(partial), "%s.partial", cap);
    CHECK(access(partial, F_OK) != 0);
    scan sc;
    CHECK_EQ_INT(scan_capture(cap, 96, 96, &sc), 0);
    CHECK_EQ_INT(sc.frames, want_frames);
    CHECK(sc.ts_order_ok);
    CHECK_EQ_INT(sc.imu, imu_ticks(&s.imu));
    CHECK_EQ_INT(sc.imu, rep.imu_samples);
    CHECK_EQ_INT(sc.gyro, sc.accel);
    CHECK_EQ_INT(sc.gyro, (uint64_t)floor(2.0 * s.imu.rate_hz) + 1);
    CHECK_EQ_INT(sc.lm_chunks, want_frames);
    CHECK_EQ_INT(sc.ori_chunks, want_frames);
    CHECK_EQ_INT(sc.lm_bad, 0);
    CHECK_EQ_INT(sc.lm_outside, 0);
    CHECK_EQ_INT(sc.meta, 1);
    char err[128];
    sp_json *meta = NULL;
    CHECK_EQ_INT(sp_json_parse(sc.meta_json, strlen(sc.meta_json), &meta, err, sizeof(err)), 0);
    CHECK(!strcmp(sp_json_string(sp_json_get(meta, "kind"), ""), "selfie"));
    CHECK(!strcmp(sp_json_string(sp_json_get(meta, "ground_truth"), ""), "a.truth"));
    CHECK_NEAR(sp_json_number(sp_json_get(sp_json_get(meta, "camera"), "fx"), 0), 0.8 * 96, 1e-9);
    CHECK_NEAR(sp_json_number(sp_json_get(sp_json_get(meta, "imu"), "rate_hz"), 0), 200, 1e-9);
    sp_json_free(meta);
    test_truth_dir(truth, want_frames);
}

/*
 * The city backdrop without IMU: every frame and both side data, no IMU sample and no "imu" in META; the same
 * seed gives the same chunks, and they differ from the sky backdrop's.
 */
static void test_city_no_imu(void)
{
    sp_synth_selfie_settings s;
    small_settings(&s);
    s.format = SP_SYNTH_FORMAT_RGB24;
    char c1[320], c2[320], c3[320];
    path_in(c1, sizeof(c1), "city1.spcap");
    path_in(c2, sizeof(c2), "city2.spcap");
    path_in(c3, sizeof(c3), "sky.spcap");
    s.no_imu = 1;
    CHECK_EQ_INT(generate(&s, c3, NULL, NULL), 0);
    s.backdrop = SP_SYNTH_BACKDROP_CITY;
    sp_synth_selfie_report rep;
    CHECK_EQ_INT(generate(&s, c1, NULL, &rep), 0);
    CHECK_EQ_INT(generate(&s, c2, NULL, NULL), 0);
    CHECK_EQ_INT(rep.imu_samples, 0);
    scan a, b, c;
    CHECK_EQ_INT(scan_capture(c1, 96, 96, &a), 0);
    CHECK_EQ_INT(scan_capture(c2, 96, 96, &b), 0);
    CHECK_EQ_INT(scan_capture(c3, 96, 96, &c), 0);
    CHECK_EQ_INT(a.frames, 31);
    CHECK_EQ_INT(a.imu, 0);
    CHECK_EQ_INT(a.lm_chunks, 31);
    CHECK_EQ_INT(a.ori_chunks, 31);
    CHECK(a.payload_crc == b.payload_crc);
    CHECK(a.payload_crc != c.payload_crc);
    char err[128];
    sp_json *meta = NULL;
    CHECK_EQ_INT(sp_json_parse(a.meta_json, strlen(a.meta_json), &meta, err, sizeof(err)), 0);
    CHECK(meta && sp_json_get(meta, "imu") == NULL);
    CHECK(meta && sp_json_get(meta, "camera") != NULL);
    sp_json_free(meta);
}

/* Same seed: identical chunks and truth files; another seed: different frames. */
static void test_determinism(void)
{
    sp_synth_selfie_settings s;
    small_settings(&s);
    s.n_relit = s.n_novel = 1;
    char d1[300], d2[300], c1[320], c2[320], t1[320], t2[320], c3[320];
    path_in(d1, sizeof(d1), "r1");
    path_in(d2, sizeof(d2), "r2");
    mkdir(d1, 0777);
    mkdir(d2, 0777);
    snprintf(c1, sizeof(c1), "%s/x.spcap", d1);
    snprintf(c2, sizeof(c2), "%s/x.spcap", d2);
    snprintf(t1, sizeof(t1), "%s/x.truth", d1);
    snprintf(t2, sizeof(t2), "%s/x.truth", d2);
    snprintf(c3, sizeof(c3), "%s/y.spcap", d2);
    CHECK_EQ_INT(generate(&s, c1, t1, NULL), 0);
    CHECK_EQ_INT(generate(&s, c2, t2, NULL), 0);
    s.seed = 2;
    CHECK_EQ_INT(generate(&s, c3, NULL, NULL), 0);
    scan a, b, c;
    CHECK_EQ_INT(scan_capture(c1, 96, 96, &a), 0);
    CHECK_EQ_INT(scan_capture(c2, 96, 96, &b), 0);
    CHECK_EQ_INT(scan_capture(c3, 96, 96, &c), 0);
    CHECK(a.payload_crc == b.payload_crc);
    CHECK(a.payload_crc != c.payload_crc);
    const char *names[] = { "truth.json", "frames.json", "heldout/relit_00.png", "albedo.pfm" };
    for (int i = 0; i < 4; i++) {
        char p1[400], p2[400];
        size_t n1 = 0, n2 = 0;
        snprintf(p1, sizeof(p1), "%s/%s", t1, names[i]);
        snprintf(p2, sizeof(p2), "%s/%s", t2, names[i]);
        char *x = slurp(p1, &n1), *y = slurp(p2, &n2);
        CHECK_MSG(x && y && n1 == n2 && !memcmp(x, y, n1), "%s differs between runs", names[i]);
        free(x);
        free(y);
    }
}

/* Noise-free RGB24 frames with fixed exposure equal the renderer's own tone-mapped image on the face. */
static void test_frames_match_renderer(void)
{
    sp_synth_selfie_settings s;
    small_settings(&s);
    s.format = SP_SYNTH_FORMAT_RGB24;
    s.noise = 0;
    s.auto_exposure = 0;
    s.n_relit = s.n_novel = 0;
    char cap[300];
    path_in(cap, sizeof(cap), "m.spcap");
    sp_synth_selfie *g = NULL;
    CHECK_EQ_INT(sp_synth_selfie_open(&g, &s), 0);
    if (!g)
        return;
    CHECK_EQ_INT(sp_synth_selfie_write(g, cap, NULL, NULL), 0);
    const uint64_t idx = 12;
    uint8_t *px = malloc(96 * 96 * 3);
    sp_capture_reader *r = NULL;
    int found = 0;
    CHECK_EQ_INT(sp_capture_reader_open(&r, cap, NULL), 0);
    sp_chunk ch;
    while (r && !found && sp_capture_reader_next(r, &ch) == 0) {
        sp_frame_chunk fc;
        if (ch.type == SP_CHUNK_FRAME && sp_chunk_parse_frame(&ch, &fc) == 0 && fc.sequence == idx) {
            CHECK_EQ_INT(fc.format, SP_PIXFMT_RGB24);
            memcpy(px, fc.data, 96 * 96 * 3);
            found = 1;
        }
    }
    sp_capture_reader_close(&r);
    CHECK(found);
    sp_synth_frame_truth ft;
    CHECK_EQ_INT(sp_synth_selfie_frame_truth(g, idx, &ft), 0);
    CHECK_NEAR(ft.exposure, sp_synth_selfie_get_truth(g)->initial_exposure, 0);
    sp_render_outputs o;
    CHECK_EQ_INT(sp_synth_selfie_render_frame(g, idx, 0, &o), 0);
    int covered = 0, off = 0, lm_on_face = 0;
    for (int i = 0; i < 96 * 96; i++) {
        if (o.coverage[i] < 1.0f)
            continue;
        covered++;
        for (int c = 0; c < 3; c++) {
            int want = (int)floor((double)o.image[3 * i + c] * 255.0 + 0.5);
            off += abs(want - px[3 * i + c]) > 1;
        }
    }
    /* inner landmarks (17..67) lie on the rendered face; the jaw contour (0..16) on its outline, within 2 px */
    for (int l = 0; l < SP_FACE_N_LANDMARKS; l++) {
        int u = (int)lround(ft.landmarks[2 * l]), v = (int)lround(ft.landmarks[2 * l + 1]), rad = l < 17 ? 2 : 0, hit = 0;
        for (int dv = -rad; dv <= rad; dv++)
            for (int du = -rad; du <= rad; du++)
                if (u + du >= 0 && v + dv >= 0 && u + du < 96 && v + dv < 96)
                    hit |= o.coverage[(v + dv) * 96 + u + du] > 0;
        lm_on_face += hit;
    }
    CHECK_MSG(covered > 500, "face covers %d pixels", covered);
    CHECK_MSG(off == 0, "%d channel values differ from the renderer by more than 1", off);
    CHECK_MSG(lm_on_face == 68, "%d of 68 landmarks on the rendered face", lm_on_face);
    /* the true orientation is the fake IMU's at the pose instant, and drives the camera */
    sp_quat q;
    CHECK_EQ_INT(sp_fake_imu_truth(&s.imu, ft.pose_ns, NULL, &q), 0);
    CHECK(sp_quat_angle_between(q, ft.camera_to_world) < 1e-9);
    double Rcw[9];
    sp_quat_to_matrix(q, Rcw);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            CHECK_NEAR(ft.camera.R[i * 3 + j], Rcw[j * 3 + i], 1e-9);
    /* the contact sheet: 3 decoded frames + 8 components in 4 columns: 3 rows of 96 + gaps */
    uint8_t *sheet = NULL;
    uint32_t w = 0, h = 0;
    CHECK_EQ_INT(sp_synth_selfie_contact_sheet(g, cap, 3, idx, 4, &sheet, &w, &h), 0);
    CHECK_EQ_INT(w, 2 + 4 * 98);
    CHECK_EQ_INT(h, 2 + 3 * 98);
    int tile_off = 0;
    for (uint32_t y = 0; sheet && y < 96; y++)
        for (uint32_t x = 0; x < 96; x++)
            for (int c = 0; c < 3; c++) {
                /* slot 3 is empty (3 frames), slot 4 is the final image of frame idx */
                tile_off += sheet[((size_t)(2 + y) * w + 2 + 3 * 98 + x) * 3 + (size_t)c] != 32;
                int want = (int)floor((double)o.image[(y * 96 + x) * 3 + (uint32_t)c] * 255.0 + 0.5);
                tile_off += sheet[((size_t)(2 + 98 + y) * w + 2 + x) * 3 + (size_t)c] != want;
            }
    CHECK_MSG(sheet && tile_off == 0, "%d contact-sheet values off", tile_off);
    free(sheet);
    free(px);
    sp_synth_selfie_close(&g);
}

static void test_overcast(void)
{
    sp_synth_selfie_settings s;
    small_settings(&s);
    s.overcast = 1;
    s.n_relit = 1;
    s.n_novel = 0;
    char cap[300], truth[300];
    path_in(cap, sizeof(cap), "o.spcap");
    path_in(truth, sizeof(truth), "o.truth");
    sp_synth_selfie *g = NULL;
    CHECK_EQ_INT(sp_synth_selfie_open(&g, &s), 0);
    if (!g)
        return;
    const sp_synth_selfie_truth *t = sp_synth_selfie_get_truth(g);
    CHECK(t->sun_intensity == 0.0);
    int grey = 1;
    for (int i = 0; i < SP_RENDER_ENV_FLOATS / 2; i += 3)
        grey &= t->env[i] > 0 && t->env[i] == t->env[i + 1] && t->env[i] == t->env[i + 2];
    CHECK(grey);
    CHECK_EQ_INT(sp_synth_selfie_write(g, cap, truth, NULL), 0);
    sp_json *m = load_json(truth, "truth.json");
    const sp_json *lt = sp_json_get(m, "lighting");
    CHECK(sp_json_number(sp_json_get(sp_json_get(lt, "sun"), "intensity"), -1) == 0.0);
    CHECK(!strcmp(sp_json_string(sp_json_get(sp_json_get(lt, "sky"), "model"), ""), "overcast"));
    sp_json_free(m);
    sp_render_outputs o;
    CHECK_EQ_INT(sp_synth_selfie_render_frame(g, 0, 0, &o), 0);
    double spec = 0;
    for (int i = 0; i < 96 * 96 * 3; i++)
        spec += (double)o.specular[i] + (double)o.diffuse[i];
    CHECK(spec == 0.0); /* no sun: no sun diffuse or specular */
    sp_synth_selfie_close(&g);
}

static void test_bad_settings(void)
{
    sp_synth_selfie_settings s;
    sp_synth_selfie *g = NULL;
    for (int k = 0; k < 15; k++) {
        small_settings(&s);
        switch (k) {
        case 9:
            s.backdrop = (enum sp_synth_backdrop)2;
            break;
        case 10:
            s.no_imu = 2;
            break;
        case 11: /* the camera could leave the city's sphere */
            s.backdrop_distance_m = 1.0;
            break;
        case 12:
            s.backdrop_distance_m = NAN;
            break;
        case 13:
            s.backdrop_distance_m = -5.0;
            break;
        case 14: /* 3 m is allowed, but not with the camera 4 m from the axis */
            s.backdrop_distance_m = 3.0;
            s.imu.arm_radius_m = 4.0;
            break;
        case 0: s.width = 8; break;
        case 1: s.imu.arm_radius_m = 0.1; break;
        case 2: s.fps = 0; break;
        case 3: s.shutter_s = 1.0; break;
        case 4: s.sun_elevation_deg = NAN; break;
        case 5: s.jpeg_quality = 0; break;
        case 6: s.motion_blur_samples = 0; break;
        case 7: s.sun_intensity = INFINITY; break;
        default: s.imu.turn_duration_s = s.imu.still_before_s = s.imu.still_after_s = 0; break;
        }
        CHECK_MSG(sp_synth_selfie_open(&g, &s) == -EINVAL, "case %d accepted", k);
        CHECK(g == NULL);
    }
    CHECK_EQ_INT(sp_synth_selfie_open(NULL, &s), -EINVAL);
    sp_synth_selfie_close(NULL);
    sp_synth_selfie_close(&g);
    small_settings(&s);
    s.format = SP_SYNTH_FORMAT_MJPEG;
    int ret = sp_synth_selfie_open(&g, &s);
    CHECK_EQ_INT(ret, sp_jpeg_available() ? 0 : SP_EDISABLED);
    if (g) {
        CHECK_EQ_INT(sp_synth_selfie_render_frame(g, 1u << 30, 0, NULL), -EINVAL);
        sp_synth_frame_truth ft;
        CHECK_EQ_INT(sp_synth_selfie_frame_truth(g, sp_synth_selfie_get_truth(g)->n_frames, &ft), -EINVAL);
    }
    sp_synth_selfie_close(&g);
}

static int all_finite(const float *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* Lighting and camera extremes: every output finite, exposure positive and finite. */
static void test_extremes(void)
{
    static const double cases[][4] = { /* elevation, intensity, sky, noise */
        { 0, 3, 1, 1 }, { -30, 3, 1, 1 }, { 90, 3, 1, 1 }, { 40, 1e5, 1e5, 1 }, { 40, 0, 0, 1 },
        { 40, 3, 1, 100 }, { -90, 1e5, 0, 0 } };
    for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
        sp_synth_selfie_settings s;
        small_settings(&s);
        s.width = s.height = 24;
        s.albedo_height = 32;
        s.sun_elevation_deg = cases[k][0];
        s.sun_intensity = cases[k][1];
        s.sky_intensity = cases[k][2];
        s.noise = cases[k][3];
        s.motion_blur_samples = k % 2 ? 3 : 1;
        s.imu.still_before_s = s.imu.still_after_s = 0.1;
        s.imu.turn_duration_s = 0.2;
        s.n_relit = s.n_novel = 1;
        sp_synth_selfie *g = NULL;
        CHECK_EQ_INT(sp_synth_selfie_open(&g, &s), 0);
        if (!g)
            continue;
        const sp_synth_selfie_truth *t = sp_synth_selfie_get_truth(g);
        CHECK(all_finite(t->env, SP_RENDER_ENV_FLOATS));
        CHECK_MSG(t->initial_exposure > 0 && isfinite(t->initial_exposure), "case %zu exposure %g", k,
                  t->initial_exposure);
        char cap[300], truth[300];
        path_in(cap, sizeof(cap), "e.spcap");
        path_in(truth, sizeof(truth), "e.truth");
        CHECK_EQ_INT(sp_synth_selfie_write(g, cap, truth, NULL), 0);
        sp_render_outputs o;
        CHECK_EQ_INT(sp_synth_selfie_render_frame(g, t->n_frames - 1, 0, &o), 0);
        CHECK(all_finite(o.image, 24 * 24 * 3) && all_finite(o.radiance, 24 * 24 * 3));
        sp_synth_frame_truth ft;
        for (uint64_t i = 0; i < t->n_frames; i++) {
            CHECK_EQ_INT(sp_synth_selfie_frame_truth(g, i, &ft), 0);
            CHECK_MSG(ft.exposure > 0 && isfinite(ft.exposure), "case %zu frame %llu exposure %g", k,
                      (unsigned long long)i, ft.exposure);
            CHECK(all_finite(ft.landmarks, 136));
        }
        sp_synth_selfie_close(&g);
    }
}

/* The truth path in META is relative to the capture's directory. */
static void test_relative_truth(void)
{
    sp_synth_selfie_settings s;
    small_settings(&s);
    s.width = s.height = 24;
    s.albedo_height = 32;
    s.imu.still_before_s = s.imu.still_after_s = 0.1;
    s.imu.turn_duration_s = 0.2;
    s.n_relit = s.n_novel = 0;
    char da[300], db[300], cap[400], truth[400];
    path_in(da, sizeof(da), "dirA");
    path_in(db, sizeof(db), "dirB");
    mkdir(da, 0777);
    mkdir(db, 0777);
    snprintf(cap, sizeof(cap), "%s/c.spcap", da);
    snprintf(truth, sizeof(truth), "%s/t", db);
    CHECK_EQ_INT(generate(&s, cap, truth, NULL), 0);
    scan sc;
    CHECK_EQ_INT(scan_capture(cap, 24, 24, &sc), 0);
    sp_json *meta = NULL;
    char err[128];
    CHECK_EQ_INT(sp_json_parse(sc.meta_json, strlen(sc.meta_json), &meta, err, sizeof(err)), 0);
    CHECK_MSG(!strcmp(sp_json_string(sp_json_get(meta, "ground_truth"), ""), "../dirB/t"), "ground_truth %s",
              sp_json_string(sp_json_get(meta, "ground_truth"), "(none)"));
    sp_json_free(meta);
}

/* The street generator (synth_street.c): frames as promised, the truth set beside the capture (a PPM
   background without an image writer), the same bytes for a seed, bad settings and a cancel leaving nothing. */
static void test_street(void)
{
    sp_synth_street_settings s;
    sp_synth_street_default_settings(&s);
    s.width = 64, s.height = 48, s.fps = 4, s.seconds = 2, s.figures = 3, s.seed = 5;
    char cap[512];
    path_in(cap, sizeof(cap), "street.spcap");
    sp_synth_street_report rep = { 0 };
    CHECK_EQ_INT(sp_synth_street_write(&s, cap, &rep), 0);
    CHECK_EQ_INT(rep.frames, 8);
    CHECK_EQ_INT(rep.figures, 3);
    scan a, b;
    CHECK_EQ_INT(scan_capture(cap, 64, 48, &a), 0);
    CHECK_EQ_INT(a.frames, 8);
    CHECK(a.ts_order_ok && a.meta == 1 && strstr(a.meta_json, "street.truth.json"));
    CHECK(file_exists(tmpdir, "street.truth.json") && file_exists(tmpdir, "street.background.ppm"));
    CHECK(file_exists(tmpdir, "street.hidden-far.pgm") && file_exists(tmpdir, "street.hidden-count.pgm"));
    CHECK(!file_exists(tmpdir, "street.background.png"));
    CHECK_EQ_INT(sp_synth_street_write(&s, cap, NULL), 0); /* replaced: the same chunks again */
    CHECK_EQ_INT(scan_capture(cap, 64, 48, &b), 0);
    CHECK(a.payload_crc == b.payload_crc);
    s.seed = 6;
    CHECK_EQ_INT(sp_synth_street_write(&s, cap, NULL), 0);
    CHECK_EQ_INT(scan_capture(cap, 64, 48, &b), 0);
    CHECK(a.payload_crc != b.payload_crc);
    s.seed = 5;
    CHECK_EQ_INT(sp_synth_street_write(&s, cap, NULL), 0);

    char none[512];
    path_in(none, sizeof(none), "street-bad.spcap");
    sp_synth_street_settings bad = s;
    bad.width = 31;
    CHECK_EQ_INT(sp_synth_street_write(&bad, none, NULL), -EINVAL);
    bad = s, bad.fps = NAN;
    CHECK_EQ_INT(sp_synth_street_write(&bad, none, NULL), -EINVAL);
    bad = s, bad.figures = SP_SYNTH_STREET_MAX_FIGURES + 1;
    CHECK_EQ_INT(sp_synth_street_write(&bad, none, NULL), -EINVAL);
    bad = s, bad.cars = SP_SYNTH_STREET_MAX_CARS + 1;
    CHECK_EQ_INT(sp_synth_street_write(&bad, none, NULL), -EINVAL);
    bad = s, bad.jpeg_quality = 101;
    CHECK_EQ_INT(sp_synth_street_write(&bad, none, NULL), -EINVAL);
    bad = s, bad.sun_elevation_deg = 85.001;
    CHECK_EQ_INT(sp_synth_street_write(&bad, none, NULL), -EINVAL);
    CHECK_EQ_INT(sp_synth_street_write(NULL, none, NULL), -EINVAL);
    CHECK_EQ_INT(sp_synth_street_write(&s, "", NULL), -EINVAL);
    volatile sig_atomic_t stop = 1;
    bad = s, bad.cancel = &stop;
    CHECK_EQ_INT(sp_synth_street_write(&bad, none, NULL), -ECANCELED);
    CHECK(!file_exists(tmpdir, "street-bad.spcap") && !file_exists(tmpdir, "street-bad.truth.json"));
    /* a cancelled rewrite keeps the earlier set whole */
    CHECK_EQ_INT(sp_synth_street_write(&bad, cap, NULL), -ECANCELED);
    CHECK_EQ_INT(scan_capture(cap, 64, 48, &b), 0);
    CHECK(a.payload_crc == b.payload_crc && file_exists(tmpdir, "street.truth.json"));
}

/* The turn generator (synth_turn.c): one frame per 1/fps over the fake IMU's profile, IMU samples and a true
   orientation for every frame, no partial file left; a cancel leaves nothing. */
static void test_turn(void)
{
    sp_synth_turn_settings s;
    sp_synth_turn_default_settings(&s);
    s.camera.width = 64, s.camera.height = 48, s.camera.fps = 10;
    s.imu.turn_duration_s = 1;
    char cap[512];
    path_in(cap, sizeof(cap), "turn.spcap");
    CHECK_EQ_INT(sp_synth_turn_write(&s, cap), 0);
    scan a;
    CHECK_EQ_INT(scan_capture(cap, 64, 48, &a), 0);
    uint64_t want = (uint64_t)floor(sp_fake_imu_duration_s(&s.imu) * s.camera.fps) + 1;
    CHECK_EQ_INT(a.frames, want);
    CHECK_EQ_INT(a.ori_chunks, want);
    CHECK(a.gyro > 0 && a.accel > 0 && a.ts_order_ok && strstr(a.meta_json, "synth turn"));
    CHECK(!file_exists(tmpdir, "turn.spcap.partial"));
    volatile sig_atomic_t stop = 1;
    s.cancel = &stop;
    char other[512];
    path_in(other, sizeof(other), "turn-stopped.spcap");
    CHECK_EQ_INT(sp_synth_turn_write(&s, other), -ECANCELED);
    CHECK(!file_exists(tmpdir, "turn-stopped.spcap") && !file_exists(tmpdir, "turn-stopped.spcap.partial"));
    CHECK_EQ_INT(sp_synth_turn_write(NULL, other), -EINVAL);
}

int main(void)
{
    const char *base = getenv("TMPDIR");
    snprintf(tmpdir, sizeof(tmpdir), "%s/sp-synth.XXXXXX", base && *base ? base : "/tmp");
    if (!mkdtemp(tmpdir)) {
        fprintf(stderr, "mkdtemp failed\n");
        return 99;
    }
    test_capture();
    test_determinism();
    test_frames_match_renderer();
    test_overcast();
    test_bad_settings();
    test_city_no_imu();
    test_extremes();
    test_relative_truth();
    test_street();
    test_turn();
    char cmd[400];
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", tmpdir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", tmpdir);
    return check_exit();
}
