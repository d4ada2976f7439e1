/* SPDX-License-Identifier: MIT */
/*
 * Writes the capture: META, then for every frame the IMU samples up to its
 * timestamp, the frame (motion-blurred render + distant world, sensor noise,
 * tone map, JPEG) and its side data (landmarks, true orientation), then the
 * remaining IMU samples. Auto-exposure meters each frame and steers the next.
 * With no_imu there are no IMU samples and META names no IMU.
 */
#include "pipeline/synth/synth_internal.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/clock.h"
#include "common/file_util.h"
#include "common/jpeg.h"
#include "common/json.h"
#include "common/progress.h"
#include "sunprobe/sp_capture.h"

/* Phone-like sensor at noise scale 1, in exposed linear units: std = sqrt(READ^2 + SHOT * x). */
#define NOISE_READ 0.001
#define NOISE_SHOT 0.0005
#define SENSOR_WIDTH_MM 5.6

typedef struct cap_state {
    sp_synth_selfie *g;
    sp_capture_writer *w;
    sp_fake_imu *imu;
    sp_imu_sample held;
    int have_held;
    uint64_t imu_count;
    enum sp_pixfmt fmt;
    sp_jpeg_buffer jpg;
    double exposure;
    synth_rng ae;
} cap_state;

static enum sp_pixfmt frame_format(const sp_synth_selfie_settings *s)
{
    if (s->format == SP_SYNTH_FORMAT_RGB24 || (s->format == SP_SYNTH_FORMAT_AUTO && !sp_jpeg_available()))
        return SP_PIXFMT_RGB24;
    return SP_PIXFMT_MJPEG;
}

static int write_meta(cap_state *c, const char *truth_rel)
{
    const sp_synth_selfie *g = c->g;
    const sp_fake_imu_settings *imu = &g->s.imu;
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b,
                     "{\"kind\":\"selfie\",\"source\":\"sunprobe synth selfie\",\"camera\":{\"name\":"
                     "\"synthetic phone camera\",\"driver\":\"synthetic\",\"width\":%u,\"height\":%u,\"fps\":%.17g,"
                     "\"fx\":%.17g,\"fy\":%.17g,\"cx\":%.17g,\"cy\":%.17g,\"focal_length_mm\":%.17g,"
                     "\"sensor_width_mm\":%.17g,\"transfer\":\"sunprobe\"}",
                     g->s.width, g->s.height, g->s.fps, g->fx, g->fy, g->cx, g->cy, g->s.focal_ratio * SENSOR_WIDTH_MM,
                     SENSOR_WIDTH_MM);
    if (!g->s.no_imu) /* --no-imu: no samples, so no IMU to describe */
        sp_strbuf_printf(&b,
                         ",\"imu\":{\"name\":\"fake imu\",\"rate_hz\":%.17g,\"to_camera\":[%.17g,%.17g,%.17g,"
                         "%.17g],\"time_offset_s\":0}",
                         imu->rate_hz, imu->imu_to_camera.w, imu->imu_to_camera.x, imu->imu_to_camera.y,
                         imu->imu_to_camera.z);
    if (g->s.utc_start[0]) { /* the sun from the clock: magnetic north is the synthetic world's +x */
        sp_strbuf_printf(&b, ",\"utc_start\":");
        sp_strbuf_json_string(&b, g->s.utc_start);
        sp_strbuf_printf(&b, ",\"location\":{\"latitude\":%.17g,\"longitude\":%.17g,\"magnetic_declination_deg\":0}",
                         g->s.latitude, g->s.longitude);
    }
    if (truth_rel) {
        sp_strbuf_printf(&b, ",\"ground_truth\":");
        sp_strbuf_json_string(&b, truth_rel);
    }
    sp_strbuf_printf(&b, "}");
    int ret = b.failed ? -ENOMEM : sp_capture_write_meta(c->w, imu->start_ns, b.data, b.len);
    sp_strbuf_free(&b);
    return ret;
}

/* IMU samples with timestamps up to t_ns, in batches; the first sample past t_ns is held for later. None
 * without an IMU (--no-imu). */
static int write_imu_until(cap_state *c, int64_t t_ns)
{
    enum { BATCH = 256 };
    sp_imu_sample batch[BATCH];
    size_t n = 0;
    int ret = 0;
    if (!c->imu)
        return 0;
    for (;;) {
        if (!c->have_held) {
            ret = sp_fake_imu_next(c->imu, &c->held);
            if (ret == SP_EOS) {
                ret = 0;
                break;
            }
            if (ret)
                return ret;
            c->have_held = 1;
        }
        if (c->held.timestamp_ns > t_ns)
            break;
        batch[n++] = c->held;
        c->have_held = 0;
        if (n == BATCH) {
            if ((ret = sp_capture_write_imu(c->w, batch, n)))
                return ret;
            c->imu_count += n;
            n = 0;
        }
    }
    if (n && !(ret = sp_capture_write_imu(c->w, batch, n)))
        c->imu_count += n;
    return ret;
}

static int64_t frame_start(const sp_synth_selfie *g, uint64_t i)
{
    return g->s.imu.start_ns + (int64_t)llround((double)i * 1e9 / g->s.fps);
}

/* Mean luminance of the covered pixels' radiance, weighted into *sum / *cnt. */
static void meter(const sp_render_outputs *o, double *sum, double *cnt)
{
    size_t n = (size_t)o->width * (size_t)o->height;
    for (size_t i = 0; i < n; i++)
        if (o->coverage[i] > 0.5f) {
            const float *r = o->radiance + 3 * i;
            *sum += 0.2126 * (double)r[0] + 0.7152 * (double)r[1] + 0.0722 * (double)r[2];
            *cnt += 1.0;
        }
}

/* Renders frame i into g->linear (exposed): the average of the sub-frame renders over the shutter. */
static int render_frame(cap_state *c, uint64_t i, double *face_lum)
{
    sp_synth_selfie *g = c->g;
    int N = g->s.motion_blur_samples;
    size_t px = (size_t)g->s.width * g->s.height;
    memset(g->linear, 0, px * 3 * sizeof(double));
    double sum = 0.0, cnt = 0.0;
    for (int k = 0; k < N; k++) {
        int64_t t = frame_start(g, i) + (int64_t)llround((k + 0.5) / N * g->s.shutter_s * 1e9);
        synth_pose p;
        sp_render_outputs o;
        int ret = synth_pose_at(g, t, &p);
        if (!ret)
            ret = synth_render_pose(g, &p, NULL, 0, NULL, c->exposure, &o);
        if (ret)
            return ret;
        synth_accumulate(g, &p, &o, NULL, c->exposure / N, g->linear);
        meter(&o, &sum, &cnt);
    }
    *face_lum = cnt > 0 ? sum / cnt : 0.0;
    return 0;
}

/* Shot + read noise in the exposed linear domain; Gaussian approximated by four summed uniforms. */
static void add_noise(const sp_synth_selfie *g, uint64_t i)
{
    if (!(g->s.noise > 0))
        return;
    synth_rng r;
    synth_rng_init(&r, g->s.seed, SYNTH_STREAM_NOISE, i);
    size_t n = (size_t)g->s.width * g->s.height * 3;
    double read2 = NOISE_READ * NOISE_READ, k = g->s.noise;
    for (size_t j = 0; j < n; j++) {
        uint64_t u = synth_rng_u64(&r);
        double s = (double)(u & 0xFFFF) + (double)((u >> 16) & 0xFFFF) + (double)((u >> 32) & 0xFFFF) +
                   (double)(u >> 48);
        double z = (s / 65536.0 - 2.0) * 1.7320508075688772; /* unit variance */
        double x = g->linear[j];
        double sd = k * sqrt(read2 + NOISE_SHOT * (x > 0 ? x : 0));
        x += sd * z;
        g->linear[j] = x > 0 ? x : 0;
    }
}

static int write_image_frame(cap_state *c, uint64_t i)
{
    sp_synth_selfie *g = c->g;
    sp_frame f = { 0 };
    f.format = c->fmt;
    f.width = g->s.width;
    f.height = g->s.height;
    f.timestamp_ns = frame_start(g, i);
    f.sequence = i;
    f.exposure_us = (float)(g->s.shutter_s * 1e6);
    f.gain = (float)c->exposure;
    if (c->fmt == SP_PIXFMT_MJPEG) {
        int ret = sp_jpeg_encode_rgb24(g->rgb, g->s.width, g->s.height, g->s.width * 3, g->s.jpeg_quality, &c->jpg);
        if (ret)
            return ret;
        f.data = c->jpg.data;
        f.bytes_used = c->jpg.size;
    } else {
        f.stride = g->s.width * 3;
        f.data = g->rgb;
        f.bytes_used = (size_t)f.stride * g->s.height;
    }
    return sp_capture_write_frame(c->w, &f);
}

static int write_side(cap_state *c, uint64_t i)
{
    sp_synth_frame_truth ft;
    int ret = sp_synth_selfie_frame_truth(c->g, i, &ft);
    if (ret)
        return ret;
    ret = sp_capture_write_side(c->w, ft.timestamp_ns, i, SP_SIDE_LANDMARKS_2D, ft.landmarks,
                                2 * SP_FACE_N_LANDMARKS);
    float q[4] = { (float)ft.camera_to_world.w, (float)ft.camera_to_world.x, (float)ft.camera_to_world.y,
                   (float)ft.camera_to_world.z };
    return ret ? ret : sp_capture_write_side(c->w, ft.timestamp_ns, i, SP_SIDE_TRUE_ORIENTATION, q, 4);
}

/* The camera's auto-exposure: move a fraction of the way to the metered exposure, plus a small random walk. */
static void update_exposure(cap_state *c, double face_lum)
{
    const sp_synth_selfie_settings *s = &c->g->s;
    if (!s->auto_exposure)
        return;
    double le = log(c->exposure);
    if (face_lum > 1e-9 && isfinite(face_lum))
        le += s->ae_speed * (log(0.2086 / face_lum) - le);
    le += s->ae_drift * synth_rng_gauss(&c->ae);
    le = le < log(1e-4) ? log(1e-4) : le > log(1e6) ? log(1e6) : le;
    c->exposure = exp(le);
}

static int one_frame(cap_state *c, uint64_t i)
{
    sp_synth_selfie *g = c->g;
    double lum = 0.0;
    int ret = write_imu_until(c, frame_start(g, i));
    if (!ret)
        ret = render_frame(c, i, &lum);
    if (ret)
        return ret;
    add_noise(g, i);
    synth_linear_to_rgb(g->linear, (size_t)g->s.width * g->s.height, g->rgb);
    g->frame_exposure[i] = c->exposure;
    if ((ret = write_image_frame(c, i)) || (ret = write_side(c, i)))
        return ret;
    update_exposure(c, lum);
    return 0;
}

static int run(cap_state *c, const char *partial, const char *truth_rel)
{
    sp_synth_selfie *g = c->g;
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    ws.sync = SP_SYNC_NONE; /* the file is renamed into place only when complete; close syncs */
    ws.overwrite = 1;
    int ret = sp_capture_writer_open(&c->w, partial, &ws);
    if (!ret && !g->s.no_imu)
        ret = sp_fake_imu_open(&c->imu, &g->s.imu);
    if (!ret)
        ret = write_meta(c, truth_rel);
    sp_progress bar;
    sp_progress_start(&bar, "synth selfie", g->n_frames, g->s.progress);
    for (uint64_t i = 0; !ret && i < g->n_frames; i++) {
        ret = g->s.cancel && *g->s.cancel ? -ECANCELED : one_frame(c, i);
        sp_progress_update(&bar, i + 1, NULL);
    }
    if (!ret)
        ret = write_imu_until(c, INT64_MAX);
    sp_progress_finish(&bar);
    return ret;
}

int synth_write_capture(sp_synth_selfie *g, const char *path, const char *truth_rel, sp_synth_selfie_report *rep,
                        sp_partial *partial)
{
    cap_state c = { .g = g, .fmt = frame_format(&g->s), .exposure = g->initial_exposure };
    if (c.fmt == SP_PIXFMT_MJPEG && !sp_jpeg_available()) {
        sp_log(SP_LOG_ERROR, "synth", "MJPEG frames need libjpeg: rebuild with -Djpeg=enabled or use RGB24");
        return SP_EDISABLED;
    }
    synth_rng_init(&c.ae, g->s.seed, SYNTH_STREAM_AE, 0);
    int ret = sp_partial_file_open(partial, path);
    if (ret)
        return ret;
    int64_t t0 = sp_clock_monotonic_ns();
    ret = run(&c, partial->path, truth_rel);
    if (c.w) {
        rep->capture_bytes = sp_capture_writer_bytes(c.w);
        int cr = sp_capture_writer_close(&c.w);
        ret = ret ? ret : cr;
    }
    sp_fake_imu_close(&c.imu);
    sp_jpeg_buffer_free(&c.jpg);
    rep->frames = g->n_frames;
    rep->imu_samples = c.imu_count;
    rep->seconds = (double)(sp_clock_monotonic_ns() - t0) * 1e-9;
    return ret;
}
