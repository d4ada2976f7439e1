/* SPDX-License-Identifier: MIT */
/*
 * Recorder benchmarks. (1) Throughput: 1280x720 YUYV from the fake camera (unpaced,
 * prerendered frames, so the camera is never the bottleneck) through the recorder
 * to a file with the default sync policy; sustained frames/s = frames written /
 * wall time, median of 5, against the baseline of the same frames appended with
 * the capture writer alone (no threads, no queue). (2) Drops: a paced 30 fps
 * 1280x720 camera for 3 s against a writer slowed by a per-chunk delay.
 * Usage: bench_record [WORKDIR]   (default /tmp/sp-bench); files are removed after each run.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "bench_util.h"
#include "common/clock.h"
#include "sunprobe/sp_recorder.h"

#define RUNS 5
#define FRAMES 240
#define W 1280
#define H 720

static sp_camera *open_camera(const char *device, double fps, unsigned pool)
{
    sp_camera_settings cs;
    sp_camera_default_settings(&cs);
    cs.device = device;
    cs.format = SP_PIXFMT_YUYV;
    cs.width = W;
    cs.height = H;
    cs.fps = fps;
    cs.pool_frames = pool;
    sp_camera *cam = NULL;
    int err = sp_camera_open(&cam, &cs);
    if (err < 0)
        fprintf(stderr, "bench_record: camera %s: %s\n", device, sp_strerror(err));
    return cam;
}

/* One recording; returns wall seconds from start to the file being closed, < 0 on error. */
static double record_once(const char *path, sp_camera *cam, unsigned queue, uint32_t delay_us, double duration,
                          sp_recorder_stats *st)
{
    sp_recorder_settings rs;
    sp_recorder_default_settings(&rs);
    rs.path = path;
    rs.camera = cam;
    rs.kind = "static";
    rs.frame_queue = queue;
    rs.writer_delay_us = delay_us;
    rs.duration_s = duration;
    rs.writer.overwrite = 1;
    sp_recorder *rec = NULL;
    int64_t t0 = sp_clock_monotonic_ns();
    int err = sp_recorder_open(&rec, &rs);
    if (err == 0)
        err = sp_recorder_start(rec);
    if (err == 0)
        err = sp_recorder_wait(rec, st);
    double secs = (double)(sp_clock_monotonic_ns() - t0) * 1e-9;
    sp_recorder_close(&rec);
    unlink(path);
    if (err < 0) {
        fprintf(stderr, "bench_record: recording failed: %s\n", sp_strerror(err));
        return -1.0;
    }
    return secs;
}

/* The baseline: the same frames appended by the capture writer on this thread. */
static double writer_only(const char *path)
{
    sp_camera *cam = open_camera("fake:unpaced,prerender", 30.0, 4);
    sp_capture_writer *w = NULL;
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    ws.overwrite = 1;
    int64_t t0 = sp_clock_monotonic_ns(); /* open and close count on both sides */
    if (!cam || sp_camera_start(cam) < 0 || sp_capture_writer_open(&w, path, &ws) < 0) {
        sp_camera_close(&cam);
        return -1.0;
    }
    int err = 0;
    for (int i = 0; i < FRAMES && err == 0; i++) {
        sp_frame *f = NULL;
        err = sp_camera_next(cam, 1000, &f);
        if (err == 0)
            err = sp_capture_write_frame(w, f);
        sp_frame_unref(&f);
    }
    if (sp_capture_writer_close(&w) < 0 || err < 0)
        err = -EIO;
    double secs = (double)(sp_clock_monotonic_ns() - t0) * 1e-9;
    sp_camera_close(&cam);
    unlink(path);
    return err < 0 ? -1.0 : FRAMES / secs;
}

static int throughput(const char *path)
{
    double fps[RUNS], base[RUNS];
    uint64_t dropped = 0;
    char device[64];
    snprintf(device, sizeof(device), "fake:unpaced,prerender,frames=%d", FRAMES);
    for (int i = 0; i < RUNS; i++) {
        /* fewer pooled frames than queue slots: an unpaced camera waits for the writer instead of dropping */
        sp_camera *cam = open_camera(device, 30.0, 8);
        sp_recorder_stats st;
        double secs = cam ? record_once(path, cam, 16, 0, 0, &st) : -1.0;
        sp_camera_close(&cam);
        base[i] = writer_only(path);
        if (secs <= 0 || base[i] <= 0)
            return 1;
        fps[i] = (double)st.frames_written / secs;
        dropped += st.frames_dropped + st.device_dropped;
        printf("  run %d: %llu frames in %.2f s = %.1f frames/s (%.0f MB/s); writer alone %.1f frames/s\n", i + 1,
               (unsigned long long)st.frames_written, secs, fps[i], fps[i] * W * H * 2 / 1e6, base[i]);
    }
    double m = bench_median(fps, RUNS), b = bench_median(base, RUNS);
    printf("record throughput 1280x720 yuyv: median %.1f frames/s (%.0f MB/s), %llu drops over %d runs; "
           "writer alone %.1f frames/s (ratio %.2f)\n", m, m * W * H * 2 / 1e6, (unsigned long long)dropped, RUNS,
           b, b > 0 ? m / b : 0.0);
    return 0;
}

/* A 30 fps camera for 3 s against writers slowed to fewer chunks per second than that. */
static int slow_writer(const char *path)
{
    static const uint32_t delays_us[] = { 0, 20000, 40000, 66000 };
    printf("slowed writer, paced 30 fps 1280x720 yuyv for 3 s, queue 8 frames:\n");
    for (size_t i = 0; i < sizeof(delays_us) / sizeof(delays_us[0]); i++) {
        sp_camera *cam = open_camera("fake:prerender", 30.0, 10);
        sp_recorder_stats st;
        double secs = cam ? record_once(path, cam, 8, delays_us[i], 3.0, &st) : -1.0;
        sp_camera_close(&cam);
        if (secs <= 0)
            return 1;
        printf("  delay %5.1f ms/chunk: %llu captured, %llu written, %llu dropped by the queue, %llu by the "
               "device\n", delays_us[i] / 1000.0, (unsigned long long)st.frames_captured,
               (unsigned long long)st.frames_written, (unsigned long long)st.frames_dropped,
               (unsigned long long)st.device_dropped);
    }
    return 0;
}

int main(int argc, char **argv)
{
    const char *dir = argc > 1 ? argv[1] : "/tmp/sp-bench";
    mkdir(dir, 0755);
    char path[512];
    snprintf(path, sizeof(path), "%s/bench_record.spcap", dir);
    int ret = throughput(path);
    if (ret == 0)
        ret = slow_writer(path);
    return ret;
}
