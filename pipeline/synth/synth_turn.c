/* SPDX-License-Identifier: MIT */
/*
 * The turn generator (sp_synth_turn_write, `sunprobe synth turn`): a person turning in place with the
 * camera at arm's length - fake IMU (noise, bias) plus a fake camera seeing a panorama at the true yaw,
 * and the true camera orientation per frame as side data, so orientation and replay can be checked end
 * to end.
 */
#include "sunprobe/sp_synth.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/json.h"
#include "common/progress.h"
#include "sunprobe/sp_capture.h"

static int write_turn_meta(sp_capture_writer *w, const sp_synth_turn_settings *a)
{
    double f = 0.5 * a->camera.width / tan(0.5 * a->camera.hfov_deg * M_PI / 180.0);
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"kind\":\"selfie\",\"source\":\"sunprobe synth turn\",\"camera\":{\"name\":\"fake camera\","
                         "\"driver\":\"fake\",\"width\":%u,\"height\":%u,\"fps\":%.17g,\"fx\":%.17g,\"fy\":%.17g,"
                         "\"cx\":%.17g,\"cy\":%.17g},\"imu\":{\"name\":\"fake imu\",\"rate_hz\":%.17g,"
                         "\"to_camera\":[%.17g,%.17g,%.17g,%.17g],\"time_offset_s\":0}}",
                     a->camera.width, a->camera.height, a->camera.fps, f, f, 0.5 * a->camera.width, 0.5 * a->camera.height,
                     a->imu.rate_hz, a->imu.imu_to_camera.w, a->imu.imu_to_camera.x, a->imu.imu_to_camera.y,
                     a->imu.imu_to_camera.z);
    int ret = b.failed ? -ENOMEM : sp_capture_write_meta(w, a->imu.start_ns, b.data, b.len);
    sp_strbuf_free(&b);
    return ret;
}

/* Writes IMU samples with timestamps up to t_ns in batches; keeps the one sample read past it. */
static int write_imu_until(sp_capture_writer *w, sp_fake_imu *imu, sp_imu_sample *held, int *have_held, int64_t t_ns)
{
    sp_imu_sample batch[256];
    size_t n = 0;
    int ret = 0;
    for (;;) {
        if (!*have_held) {
            ret = sp_fake_imu_next(imu, held);
            if (ret == SP_EOS) {
                ret = 0;
                break;
            }
            if (ret)
                break;
            *have_held = 1;
        }
        if (held->timestamp_ns > t_ns)
            break;
        batch[n++] = *held;
        *have_held = 0;
        if (n == 256) {
            if ((ret = sp_capture_write_imu(w, batch, n)))
                return ret;
            n = 0;
        }
    }
    return !ret && n ? sp_capture_write_imu(w, batch, n) : ret;
}

/* Heading that the panorama pattern expects: azimuth of the view, increasing to the right. */
static double view_yaw(sp_quat camera_to_world)
{
    sp_vec3 fwd = sp_quat_rotate(camera_to_world, (sp_vec3){ 0, 0, 1 });
    return -atan2(fwd.y, fwd.x);
}

static int write_frame(sp_capture_writer *w, sp_fake_camera *cam, const sp_synth_turn_settings *a, uint64_t i, int64_t t)
{
    sp_quat q;
    int ret = sp_fake_imu_truth(&a->imu, t, NULL, &q);
    sp_frame *f = NULL;
    if (!ret)
        ret = sp_fake_camera_frame(cam, i, t, view_yaw(q), &f);
    if (!ret)
        ret = sp_capture_write_frame(w, f);
    sp_frame_unref(&f);
    float truth[4] = { (float)q.w, (float)q.x, (float)q.y, (float)q.z };
    if (!ret)
        ret = sp_capture_write_side(w, t, i, SP_SIDE_TRUE_ORIENTATION, truth, 4);
    return ret;
}

static int write_turn(const sp_synth_turn_settings *a, const char *partial)
{
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    ws.sync = a->sync_every_chunk ? SP_SYNC_EVERY_CHUNK : SP_SYNC_PERIODIC;
    ws.overwrite = 1;
    sp_capture_writer *w = NULL;
    sp_fake_camera *cam = NULL;
    sp_fake_imu *imu = NULL;
    int ret = sp_capture_writer_open(&w, partial, &ws);
    if (!ret)
        ret = sp_fake_camera_open(&cam, &a->camera);
    if (!ret)
        ret = sp_fake_imu_open(&imu, &a->imu);
    if (!ret)
        ret = write_turn_meta(w, a);
    uint64_t n_frames = (uint64_t)floor(sp_fake_imu_duration_s(&a->imu) * a->camera.fps) + 1;
    sp_progress bar;
    sp_progress_start(&bar, "synth", n_frames, a->progress);
    sp_imu_sample held;
    int have_held = 0;
    for (uint64_t i = 0; !ret && i < n_frames; i++) {
        int64_t t = a->imu.start_ns + (int64_t)llround((double)i * 1e9 / a->camera.fps);
        ret = a->cancel && *a->cancel ? -ECANCELED : write_imu_until(w, imu, &held, &have_held, t);
        if (!ret)
            ret = write_frame(w, cam, a, i, t);
        sp_progress_update(&bar, i + 1, NULL);
    }
    if (!ret) /* the IMU samples after the last frame */
        ret = write_imu_until(w, imu, &held, &have_held, INT64_MAX);
    sp_progress_finish(&bar);
    int close_ret = sp_capture_writer_close(&w);
    sp_fake_camera_close(&cam);
    sp_fake_imu_close(&imu);
    return ret ? ret : close_ret;
}

void sp_synth_turn_default_settings(sp_synth_turn_settings *s)
{
    *s = (sp_synth_turn_settings){ 0 };
    sp_fake_camera_default_settings(&s->camera);
    s->camera.pattern = SP_FAKE_PATTERN_PANORAMA;
    sp_fake_imu_default_settings(&s->imu);
}

int sp_synth_turn_write(const sp_synth_turn_settings *s, const char *capture_path)
{
    if (!s || !capture_path || !capture_path[0])
        return -EINVAL;
    size_t n = strlen(capture_path) + 16;
    char *partial = malloc(n);
    if (!partial)
        return -ENOMEM;
    snprintf(partial, n, "%s.partial", capture_path);
    int ret = write_turn(s, partial);
    if (!ret && s->cancel && *s->cancel) /* a signal after the last frame: the old capture stays */
        ret = -ECANCELED;
    if (!ret && rename(partial, capture_path) != 0)
        ret = -errno;
    if (ret)
        unlink(partial);
    free(partial);
    return ret;
}
