/* SPDX-License-Identifier: MIT */
/*
 * The stream contract (sp_source.h) and the orientation tagger (sp_tagger.h):
 * a capture whose IMU log starts a second before its video, with a phone front
 * camera's imu.to_camera in a META chunk timed at the first frame, must give
 * every frame the true camera orientation; metadata comes first; side data is
 * attached to its frame; the ring thins evenly while the filter initialises;
 * frames of a capture without IMU go on at once, tagged NO_IMU.
 */
#include "sunprobe/sp_tagger.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "../common/check.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_fake_imu.h"
#include "sunprobe/sp_meta.h"
#include "sunprobe/sp_replay.h"

#define DEG (M_PI / 180.0)
#define FRAME_NS 33333333LL

typedef struct cap_opts {
    int64_t video_start_ns; /* the IMU starts at 0 */
    sp_quat to_camera;
    int with_imu;
    int landmarks_every;    /* frames with landmark side data; 0 none */
} cap_opts;

static int write_imu_until(sp_capture_writer *w, sp_fake_imu *imu, sp_imu_sample *held, int *have, int64_t t)
{
    int ret = 0;
    while (!ret) {
        if (!*have && (ret = sp_fake_imu_next(imu, held)))
            return ret == SP_EOS ? 0 : ret;
        *have = 1;
        if (held->timestamp_ns > t)
            return 0;
        ret = sp_capture_write_imu(w, held, 1);
        *have = 0;
    }
    return ret;
}

/* Writes the capture; returns the number of frames or a negative error. */
static int make_capture(const char *path, const cap_opts *o, const sp_fake_imu_settings *g)
{
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    ws.sync = SP_SYNC_NONE;
    ws.overwrite = 1;
    sp_capture_writer *w = NULL;
    int ret = sp_capture_writer_open(&w, path, &ws);
    if (ret)
        return ret;
    char meta[256];
    snprintf(meta, sizeof(meta),
             "{\"kind\":\"selfie\",\"camera\":{\"width\":16,\"height\":16,\"fps\":30},"
             "\"imu\":{\"name\":\"phone\",\"to_camera\":[%.17g,%.17g,%.17g,%.17g]}}",
             o->to_camera.w, o->to_camera.x, o->to_camera.y, o->to_camera.z);
    ret = sp_capture_write_meta(w, o->video_start_ns, meta, strlen(meta));
    sp_fake_imu *imu = NULL;
    if (!ret && o->with_imu)
        ret = sp_fake_imu_open(&imu, g);
    uint8_t px[256];
    memset(px, 128, sizeof(px));
    sp_imu_sample held;
    int have = 0, n = 0;
    int64_t end = g->start_ns + (int64_t)(sp_fake_imu_duration_s(g) * 1e9);
    for (int64_t t = o->video_start_ns; !ret && t < end - FRAME_NS; t += FRAME_NS, n++) {
        if (imu)
            ret = write_imu_until(w, imu, &held, &have, t);
        sp_frame f = { .format = SP_PIXFMT_GRAY8, .width = 16, .height = 16, .stride = 16, .data = px,
                       .capacity = sizeof(px), .bytes_used = sizeof(px), .timestamp_ns = t, .sequence = (uint64_t)n,
                       .exposure_us = NAN, .gain = NAN };
        if (!ret)
            ret = sp_capture_write_frame(w, &f);
        sp_quat q;
        if (!ret && (ret = sp_fake_imu_truth(g, t, NULL, &q)) == 0) {
            float v[4] = { (float)q.w, (float)q.x, (float)q.y, (float)q.z };
            ret = sp_capture_write_side(w, t, (uint64_t)n, SP_SIDE_TRUE_ORIENTATION, v, 4);
        }
        if (!ret && o->landmarks_every && n % o->landmarks_every == 0) {
            float lm[136];
            for (int k = 0; k < 136; k++)
                lm[k] = (float)(n + k);
            ret = sp_capture_write_side(w, t, (uint64_t)n, SP_SIDE_LANDMARKS_2D, lm, 136);
        }
    }
    if (!ret && imu)
        ret = write_imu_until(w, imu, &held, &have, INT64_MAX);
    sp_fake_imu_close(&imu);
    int cret = sp_capture_writer_close(&w);
    return ret ? ret : cret ? cret : n;
}

typedef struct tally {
    int events, frames, oriented, no_imu, with_landmarks, landmarks_right, with_truth, side_passed;
    int meta_first;          /* the first event is META, carrying imu.to_camera */
    int order_ok;            /* frames in sequence order */
    double err_max, up_err_max;
    sp_tagger_stats stats;
} tally;

static void run_tagger(const char *path, const sp_tagger_settings *ts, sp_quat want_to_camera, tally *t)
{
    memset(t, 0, sizeof(*t));
    t->order_ok = 1;
    sp_replay_settings rs;
    sp_replay_default_settings(&rs);
    rs.pool_frames += ts ? ts->max_waiting : 32;
    sp_source *replay = NULL, *tagger = NULL;
    CHECK_EQ_INT(sp_replay_open(&replay, path, &rs), 0);
    CHECK_EQ_INT(sp_tagger_open(&tagger, replay, ts), 0);
    if (!tagger)
        return;
    sp_event ev;
    int ret, have_align = 0;
    sp_quat align = { 1, 0, 0, 0 };
    int64_t last_seq = -1;
    while ((ret = sp_source_next(tagger, &ev)) == 0) {
        if (t->events++ == 0)
            t->meta_first = ev.type == SP_EVENT_META && ev.meta &&
                            fabs(ev.meta->imu_to_camera.w - want_to_camera.w) < 1e-9 &&
                            fabs(ev.meta->imu_to_camera.z - want_to_camera.z) < 1e-9;
        if (ev.type == SP_EVENT_SIDE)
            t->side_passed++;
        if (ev.type == SP_EVENT_FRAME) {
            const sp_frame_tags *g = ev.tags;
            CHECK(g != NULL);
            t->frames++;
            t->order_ok &= (int64_t)ev.frame->sequence > last_seq;
            last_seq = (int64_t)ev.frame->sequence;
            t->no_imu += g->orientation == SP_ORIENTATION_NO_IMU;
            t->with_truth += g->has_true_orientation;
            if (g->has_landmarks) {
                t->with_landmarks++;
                t->landmarks_right += g->landmarks[0] == (float)ev.frame->sequence &&
                                      g->landmarks[135] == (float)(ev.frame->sequence + 135);
            }
            if (g->orientation == SP_ORIENTATION_OK && g->has_true_orientation) {
                t->oriented++;
                if (!have_align) { /* the filter's heading is arbitrary: aligned on the first frame */
                    align = sp_quat_mul(g->true_camera_to_world, sp_quat_conj(g->camera_to_world));
                    have_align = 1;
                }
                double e = sp_quat_angle_between(sp_quat_mul(align, g->camera_to_world), g->true_camera_to_world);
                t->err_max = fmax(t->err_max, e / DEG);
                /* the camera's up (-y) against the world's up needs no alignment */
                sp_vec3 up = sp_quat_rotate(g->camera_to_world, (sp_vec3){ 0, -1, 0 });
                sp_vec3 up_true = sp_quat_rotate(g->true_camera_to_world, (sp_vec3){ 0, -1, 0 });
                t->up_err_max = fmax(t->up_err_max, fabs(asin(fmax(-1.0, fmin(1.0, up.z))) -
                                                         asin(fmax(-1.0, fmin(1.0, up_true.z)))) / DEG);
            }
        }
        sp_event_release(&ev);
    }
    CHECK_EQ_INT(ret, SP_EOS);
    CHECK_EQ_INT(sp_tagger_get_stats(tagger, &t->stats), 0);
    CHECK(sp_tagger_get_stats(replay, &t->stats) == -EINVAL); /* not a tagger */
    sp_source_close(&tagger);
    sp_source_close(&replay);
}

static void phone_settings(sp_fake_imu_settings *g, sp_quat to_camera)
{
    sp_fake_imu_default_settings(g);
    g->start_ns = 0;
    g->imu_to_camera = to_camera;
}

/* The bug this contract fixes: IMU before META in time, a non-identity imu.to_camera. */
static void test_imu_before_video(const char *path)
{
    const sp_quat front = { 0, 0, 0, 1 }; /* 180 deg about z: a phone's front camera */
    sp_fake_imu_settings g;
    phone_settings(&g, front);
    cap_opts o = { .video_start_ns = 1000000000LL, .to_camera = front, .with_imu = 1, .landmarks_every = 5 };
    int n = make_capture(path, &o, &g);
    CHECK(n > 300);
    tally t;
    run_tagger(path, NULL, front, &t);
    printf("IMU 1 s before the video, front camera: %d frames, %d oriented, max error %.3f deg, "
           "max tilt error %.3f deg\n", t.frames, t.oriented, t.err_max, t.up_err_max);
    CHECK(t.meta_first);
    CHECK_EQ_INT(t.frames, n);
    CHECK(t.order_ok);
    CHECK_EQ_INT(t.oriented, n);
    CHECK_MSG(t.err_max < 1.5, "max error %.3f deg", t.err_max);
    CHECK_MSG(t.up_err_max < 1.0, "tilt error %.3f deg", t.up_err_max);
    CHECK_EQ_INT(t.with_truth, n);
    CHECK_EQ_INT(t.with_landmarks, (n + 4) / 5);
    CHECK_EQ_INT(t.landmarks_right, t.with_landmarks);
    CHECK_EQ_INT(t.side_passed, 0); /* every side chunk found its frame */
    CHECK_EQ_INT(t.stats.frames, n);
    CHECK_EQ_INT(t.stats.oriented, n);
    CHECK_EQ_INT(t.stats.thinned, 0);
    CHECK(t.stats.have_filter && t.stats.filter.initialized);
    CHECK_EQ_INT(t.stats.side_attached, n + (n + 4) / 5);
}

/* The same capture with the identity in its metadata: the orientation must change (to_camera is used). */
static void test_to_camera_is_used(const char *path)
{
    const sp_quat front = { 0, 0, 0, 1 };
    sp_fake_imu_settings g;
    phone_settings(&g, front);
    cap_opts o = { .video_start_ns = 1000000000LL, .to_camera = { 1, 0, 0, 0 }, .with_imu = 1 };
    CHECK(make_capture(path, &o, &g) > 300);
    tally t;
    run_tagger(path, NULL, o.to_camera, &t);
    printf("wrong imu.to_camera: max tilt error %.1f deg\n", t.up_err_max);
    CHECK(t.meta_first);
    CHECK_MSG(t.up_err_max > 45.0, "tilt error %.3f deg with the wrong to_camera", t.up_err_max);
}

/* A small ring before the filter initialises (about 0.75 s): thinned evenly, the rest oriented. */
static void test_thinning(const char *path)
{
    sp_fake_imu_settings g;
    phone_settings(&g, (sp_quat){ 1, 0, 0, 0 });
    cap_opts o = { .video_start_ns = 0, .to_camera = { 1, 0, 0, 0 }, .with_imu = 1 };
    int n = make_capture(path, &o, &g);
    sp_tagger_settings ts;
    sp_tagger_default_settings(&ts);
    ts.max_waiting = 4;
    tally t;
    run_tagger(path, &ts, o.to_camera, &t);
    printf("ring of 4: %d frames handed on, %llu thinned, max error %.3f deg\n", t.frames,
           (unsigned long long)t.stats.thinned, t.err_max);
    CHECK(t.stats.thinned >= 10); /* ~22 frames come before initialisation */
    CHECK_EQ_INT((uint64_t)t.frames + t.stats.thinned, n);
    CHECK(t.order_ok);
    CHECK_EQ_INT(t.oriented, t.frames);
    CHECK_MSG(t.err_max < 1.5, "max error %.3f deg", t.err_max);
}

/* No IMU at all: frames go on at once (only waiting for the next frame's side data), tagged NO_IMU. */
static void test_no_imu(const char *path)
{
    sp_fake_imu_settings g;
    phone_settings(&g, (sp_quat){ 1, 0, 0, 0 });
    cap_opts o = { .to_camera = { 1, 0, 0, 0 }, .with_imu = 0 };
    int n = make_capture(path, &o, &g);
    sp_tagger_settings ts;
    sp_tagger_default_settings(&ts);
    ts.max_waiting = 2;
    tally t;
    run_tagger(path, &ts, o.to_camera, &t);
    CHECK_EQ_INT(t.frames, n);
    CHECK_EQ_INT(t.no_imu, n);
    CHECK_EQ_INT(t.stats.thinned, 0);
    CHECK(!t.stats.have_filter);
}

/* Orientation from elsewhere (the video pass): every frame takes it, odd sequences have none; the IMU
   filter is never opened, so nothing is thinned while it would have settled. */
static int orientation_by_sequence(void *user, uint64_t sequence, int64_t t, sp_quat *q)
{
    (void)t;
    (*(int *)user)++;
    if (sequence % 2)
        return SP_ENODATA;
    *q = sp_quat_from_axis_angle((sp_vec3){ 0, 0, 1 }, (double)sequence * DEG);
    return 0;
}

static void test_orientation_from_elsewhere(const char *path)
{
    sp_fake_imu_settings g;
    phone_settings(&g, (sp_quat){ 1, 0, 0, 0 });
    cap_opts o = { .video_start_ns = 0, .to_camera = { 1, 0, 0, 0 }, .with_imu = 1 };
    int n = make_capture(path, &o, &g);
    sp_tagger_settings ts;
    sp_tagger_default_settings(&ts);
    ts.max_waiting = 4; /* with the IMU this ring thins 10 or more frames (test_thinning) */
    int calls = 0;
    ts.orientation_for = orientation_by_sequence;
    ts.orientation_user = &calls;
    sp_replay_settings rs;
    sp_replay_default_settings(&rs);
    rs.pool_frames += ts.max_waiting;
    sp_source *replay = NULL, *tagger = NULL;
    CHECK_EQ_INT(sp_replay_open(&replay, path, &rs), 0);
    CHECK_EQ_INT(sp_tagger_open(&tagger, replay, &ts), 0);
    sp_event ev;
    int frames = 0, right = 0, imu = 0;
    while (tagger && sp_source_next(tagger, &ev) == 0) {
        imu += ev.type == SP_EVENT_IMU;
        if (ev.type == SP_EVENT_FRAME) {
            frames++;
            uint64_t seq = ev.frame->sequence;
            if (seq % 2)
                right += ev.tags->orientation == SP_ORIENTATION_NOT_COVERED;
            else
                right += ev.tags->orientation == SP_ORIENTATION_OK &&
                    fabs(sp_quat_angle_between(ev.tags->camera_to_world, sp_quat_identity()) / DEG -
                         (double)(seq % 360 <= 180 ? seq % 360 : 360 - seq % 360)) < 1e-6;
        }
        sp_event_release(&ev);
    }
    sp_tagger_stats st;
    CHECK_EQ_INT(sp_tagger_get_stats(tagger, &st), 0);
    CHECK_EQ_INT(frames, n);
    CHECK_EQ_INT(right, n);
    CHECK_EQ_INT(calls, n);
    CHECK_EQ_INT(st.thinned, 0);
    CHECK(!st.have_filter && imu > 0 && st.imu_samples == (uint64_t)imu); /* the samples pass, unused */
    sp_source_close(&tagger);
    sp_source_close(&replay);
}

static void test_settings(void)
{
    sp_source *out = NULL, *inner = NULL;
    sp_tagger_settings ts;
    sp_tagger_default_settings(&ts);
    CHECK_EQ_INT(ts.max_waiting, 32);
    ts.max_waiting = 1;
    CHECK(sp_tagger_open(&out, (sp_source *)&ts, &ts) == -EINVAL && out == NULL);
    ts.max_waiting = 2000;
    CHECK(sp_tagger_open(&out, (sp_source *)&ts, &ts) == -EINVAL);
    CHECK(sp_tagger_open(&out, inner, NULL) == -EINVAL);
    CHECK(sp_tagger_open(NULL, inner, NULL) == -EINVAL);
    sp_tagger_default_settings(NULL);
}

int main(void)
{
    char path[64];
    snprintf(path, sizeof(path), "/tmp/sp-test-tagger-%d.spcap", (int)getpid());
    test_settings();
    test_imu_before_video(path);
    test_to_camera_is_used(path);
    test_thinning(path);
    test_no_imu(path);
    test_orientation_from_elsewhere(path);
    unlink(path);
    return check_exit();
}
