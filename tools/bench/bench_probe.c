/* SPDX-License-Identifier: MIT */
/*
 * Scene-probe benchmarks on 768x576 video (vtest.avi, imported once).
 * (1) Throughput: probing the first N frames single-threaded, median of 5
 *     runs, frames/s of the probe alone (decoding is timed apart), against
 *     OpenCV's MOG2 background subtractor on the same decoded frames in the
 *     same run (the ratio: probe frames/s over MOG2 frames/s), by the wall
 *     clock and by this thread's CPU time (the ratio a shared machine's load
 *     does not move).
 * (2) Memory: peak RSS of a child process probing the capture once, and of
 *     one probing it 5 times in a row (one long stream), which should match.
 * Usage: bench_probe [--frames N] [WORKDIR]  (default 300 frames, /tmp/sp-bench)
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "bench_util.h"
#include "common/clock.h"
#include "common/pixconv.h"
#include "sp_config.h"
#include "sunprobe/sp_import.h"
#include "sunprobe/sp_probe.h"
#include "pipeline/stage.h"
#include "sunprobe/sp_replay.h"
#if HAVE_OPENCV
#include "pipeline/probe/opencv_probe_shim.h"
#endif

#define RUNS 5
#define VTEST "/usr/share/doc/opencv-doc/examples/data/vtest.avi"

static int make_capture(const char *path)
{
    struct stat st;
    if (stat(path, &st) == 0)
        return 0; /* cached from an earlier run */
    sp_import_settings s;
    sp_import_default_settings(&s);
    s.input = VTEST;
    s.output = path;
    sp_import_report rep;
    int ret = sp_import_run(&s, &rep);
    if (ret)
        fprintf(stderr, "bench_probe: importing %s: %s %s\n", VTEST, sp_strerror(ret), rep.message);
    return ret;
}

typedef int (*frame_fn)(void *user, const sp_frame *f, uint64_t index);

/* A bench-local stage: every frame to fn, its timestamp continued across loops. */
typedef struct frame_stage {
    frame_fn fn;
    void *user;
    int64_t offset, last;
    uint64_t index;
} frame_stage;

static int frame_stage_open(void **ctx, const void *settings)
{
    *ctx = (void *)settings; /* the caller's frame_stage, borrowed */
    return 0;
}

static int frame_stage_push(void *ctx, const sp_event *ev)
{
    frame_stage *s = ctx;
    if (ev->type != SP_EVENT_FRAME)
        return 0;
    ev->frame->timestamp_ns += s->offset;
    s->last = ev->frame->timestamp_ns;
    return s->fn(s->user, ev->frame, s->index++);
}

static void frame_stage_close(void *ctx)
{
    (void)ctx;
}

static const sp_stage_ops frame_stage_ops = {
    .name = "bench-frames",
    .description = "frames to a callback",
    .open = frame_stage_open,
    .push = frame_stage_push,
    .close = frame_stage_close,
};

/* Streams the capture `loops` times (timestamps continued) through fn, at most max_frames per loop. */
static int stream(const char *path, int loops, uint64_t max_frames, frame_fn fn, void *user)
{
    frame_stage fs = { .fn = fn, .user = user };
    sp_stage st = { 0 };
    int ret = sp_stage_open(&st, &frame_stage_ops, &fs);
    sp_run_settings rs;
    sp_run_default_settings(&rs);
    rs.max_frames = max_frames;
    rs.progress = 0;
    rs.finish = 0;
    for (int l = 0; !ret && l < loops; l++) {
        ret = sp_stage_run(path, &st, &rs, NULL);
        fs.offset = fs.last + 100000000; /* the next loop continues 0.1 s later */
    }
    sp_stage_close(&st);
    return ret;
}

/* ---- throughput ---- */

typedef struct timing {
    sp_probe *probe;
    void *mog;
    uint8_t *rgb;
    double probe_s, mog_s, decode_s, probe_cpu_s, mog_cpu_s;
    uint64_t frames;
} timing;

#define WARMUP 50 /* frames while the clean plate fills (4 s at 10 fps) are cheap: not timed */

static int time_frame(void *user, const sp_frame *f, uint64_t index)
{
    timing *t = user;
    int64_t a = sp_clock_monotonic_ns();
    int ret = sp_pixconv_frame_to_rgb24(f, t->rgb, (size_t)f->width * f->height * 3, f->width * 3);
    int64_t b = sp_clock_monotonic_ns(), b_cpu = bench_thread_cpu_ns();
    if (!ret)
        ret = sp_probe_push_rgb(t->probe, t->rgb, f->width * 3, f->timestamp_ns);
    int64_t c = sp_clock_monotonic_ns(), c_cpu = bench_thread_cpu_ns();
#if HAVE_OPENCV
    static uint8_t *mask;
    if (!mask)
        mask = malloc((size_t)f->width * f->height);
    if (!ret && mask)
        ret = sp_cv_mog2_apply(t->mog, t->rgb, f->width, f->height, f->width * 3, mask, f->width);
#endif
    int64_t d = sp_clock_monotonic_ns(), d_cpu = bench_thread_cpu_ns();
    if (index < WARMUP)
        return ret;
    t->decode_s += (double)(b - a) * 1e-9;
    t->probe_s += (double)(c - b) * 1e-9;
    t->mog_s += (double)(d - c) * 1e-9;
    t->probe_cpu_s += (double)(c_cpu - b_cpu) * 1e-9;
    t->mog_cpu_s += (double)(d_cpu - c_cpu) * 1e-9;
    t->frames++;
    return ret;
}

static double median5(double *v)
{
    return bench_median(v, RUNS);
}

static int throughput(const char *path, uint64_t frames)
{
    double probe_fps[RUNS], mog_fps[RUNS], ratio[RUNS], decode_fps[RUNS], finish_ms[RUNS], cpu_ratio[RUNS];
    timing t = { 0 };
    t.rgb = malloc(768 * 576 * 3);
#if HAVE_OPENCV
    sp_cv_set_threads(1);
#endif
    for (int r = 0; r < RUNS; r++) {
        sp_probe_settings s;
        sp_probe_default_settings(&s);
        int ret = sp_probe_open(&t.probe, 768, 576, &s);
#if HAVE_OPENCV
        if (!ret)
            ret = sp_cv_mog2_open((sp_cv_mog2 **)&t.mog, 500, 16, 1);
#endif
        t.probe_s = t.mog_s = t.decode_s = t.probe_cpu_s = t.mog_cpu_s = 0;
        t.frames = 0;
        if (!ret)
            ret = stream(path, 1, frames, time_frame, &t);
        int64_t a = sp_clock_monotonic_ns();
        if (!ret)
            ret = sp_probe_finish(t.probe);
        finish_ms[r] = (double)(sp_clock_monotonic_ns() - a) * 1e-6;
        sp_probe_close(&t.probe);
#if HAVE_OPENCV
        sp_cv_mog2_close((sp_cv_mog2 **)&t.mog);
#endif
        if (ret) {
            fprintf(stderr, "bench_probe: run %d: %s\n", r, sp_strerror(ret));
            free(t.rgb);
            return ret;
        }
        probe_fps[r] = (double)t.frames / t.probe_s;
        decode_fps[r] = (double)t.frames / t.decode_s;
        mog_fps[r] = t.mog_s > 0 ? (double)t.frames / t.mog_s : (double)NAN;
        ratio[r] = probe_fps[r] / mog_fps[r];
        cpu_ratio[r] = t.probe_cpu_s > 0 ? t.mog_cpu_s / t.probe_cpu_s : (double)NAN; /* speed: time inverted */
    }
    free(t.rgb);
    printf("probe 768x576, %llu frames after %d of warm-up, single thread, median of %d:\n",
           (unsigned long long)t.frames, WARMUP, RUNS);
    printf("  probe        %8.1f frames/s  (finish: %.0f ms)\n", median5(probe_fps), median5(finish_ms));
    printf("  MJPEG decode %8.1f frames/s  (not included above)\n", median5(decode_fps));
#if HAVE_OPENCV
    printf("  OpenCV MOG2  %8.1f frames/s  (same frames, same run, 1 thread)\n", median5(mog_fps));
    printf("  ratio probe / MOG2: %.2f (wall clock), %.2f (thread CPU time; each run: ", median5(ratio),
           median5((double[RUNS]){ cpu_ratio[0], cpu_ratio[1], cpu_ratio[2], cpu_ratio[3], cpu_ratio[4] }));
    for (int r = 0; r < RUNS; r++)
        printf("%.2f%s", cpu_ratio[r], r + 1 < RUNS ? " " : ")\n");
#else
    printf("  OpenCV MOG2: not built (-Dopencv=enabled)\n");
    (void)ratio, (void)mog_fps, (void)cpu_ratio;
#endif
    return 0;
}

/* ---- peak RSS ---- */

typedef struct rss_run {
    sp_probe *probe;
} rss_run;

static int rss_frame(void *user, const sp_frame *f, uint64_t index)
{
    rss_run *r = user;
    (void)index;
    if (!r->probe) {
        sp_probe_settings s;
        sp_probe_default_settings(&s);
        int ret = sp_probe_open(&r->probe, f->width, f->height, &s);
        if (ret)
            return ret;
    }
    return sp_probe_push_frame(r->probe, f);
}

static long child_rss_kb(const char *path, int loops)
{
    fflush(stdout);
    pid_t pid = fork();
    if (pid == 0) {
        rss_run r = { 0 };
        int ret = stream(path, loops, 0, rss_frame, &r);
        if (!ret)
            ret = sp_probe_finish(r.probe);
        sp_probe_close(&r.probe);
        _exit(ret ? 1 : 0);
    }
    int status = 0;
    struct rusage ru;
    if (pid < 0 || wait4(pid, &status, 0, &ru) != pid || !WIFEXITED(status) || WEXITSTATUS(status))
        return -1;
    return ru.ru_maxrss;
}

int main(int argc, char **argv)
{
    const char *dir = "/tmp/sp-bench";
    uint64_t frames = 300;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--frames") && i + 1 < argc)
            frames = strtoull(argv[++i], NULL, 10);
        else
            dir = argv[i];
    }
    if (access(VTEST, R_OK) != 0) {
        fprintf(stderr, "bench_probe: needs %s (Debian package opencv-doc)\n", VTEST);
        return 77;
    }
    mkdir(dir, 0755);
    char path[512];
    snprintf(path, sizeof(path), "%s/vtest.spcap", dir);
    if (make_capture(path))
        return 1;
    /* memory first, while this process is small: children inherit its pages */
    long once = child_rss_kb(path, 1), five = child_rss_kb(path, 5);
    printf("peak RSS probing vtest.avi (795 frames, decode included): once %ld KiB, looped 5 times %ld KiB "
           "(%.1f%% more)\n", once, five, once > 0 ? 100.0 * (double)(five - once) / (double)once : (double)NAN);
    return throughput(path, frames) ? 1 : 0;
}
