/* SPDX-License-Identifier: MIT */
/*
 * Orientation from the video (the video-orientation stage, fit's pass for a capture without an
 * IMU) against the IMU's orientation stage on the same capture: a synthetic turn before a distant
 * city (`synth selfie --backdrop city`, 361 frames of 320x320, cached), median of 3 runs, wall time
 * and the process's CPU time (OpenCV's tracker may use worker threads), per frame, and the ratio.
 * Usage: bench_orientation [WORKDIR]   (default /tmp/sp-bench)
 */
#include <stdio.h>
#include <sys/resource.h>
#include <sys/stat.h>

#include "bench_util.h"
#include "common/clock.h"
#include "pipeline/stages/stages.h"
#include "sunprobe/sp_synth.h"

#define RUNS 3

static double process_cpu_s(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (double)ru.ru_utime.tv_sec + (double)ru.ru_stime.tv_sec +
        1e-6 * (double)(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec);
}

static int make_capture(const char *path)
{
    struct stat st;
    if (stat(path, &st) == 0)
        return 0; /* cached from an earlier run */
    sp_synth_selfie_settings s;
    sp_synth_selfie_default_settings(&s);
    s.backdrop = SP_SYNTH_BACKDROP_CITY;
    sp_synth_selfie *g = NULL;
    int ret = sp_synth_selfie_open(&g, &s);
    if (!ret)
        ret = sp_synth_selfie_write(g, path, NULL, NULL);
    sp_synth_selfie_close(&g);
    return ret;
}

/* Runs the stage over the capture RUNS times; medians of wall and process CPU seconds. */
static int time_stage(const char *path, const sp_stage_ops *ops, double *wall, double *cpu, uint64_t *frames)
{
    double w[RUNS], c[RUNS];
    FILE *quiet = fopen("/dev/null", "w");
    for (int i = 0; i < RUNS; i++) {
        sp_stage st = { 0 };
        sp_stage_options none = { 0 };
        int ret = sp_stage_open(&st, ops, &none);
        sp_run_settings rs;
        sp_run_default_settings(&rs);
        rs.progress = 0;
        rs.summary = quiet;
        sp_run_stats stats;
        double c0 = process_cpu_s();
        int64_t t0 = sp_clock_monotonic_ns();
        if (!ret)
            ret = sp_stage_run(path, &st, &rs, &stats);
        w[i] = (double)(sp_clock_monotonic_ns() - t0) * 1e-9;
        c[i] = process_cpu_s() - c0;
        *frames = stats.frames;
        sp_stage_close(&st);
        if (ret) {
            fprintf(stderr, "bench_orientation: %s: %s\n", ops->name, sp_strerror(ret));
            fclose(quiet);
            return ret;
        }
    }
    fclose(quiet);
    *wall = bench_median(w, RUNS);
    *cpu = bench_median(c, RUNS);
    return 0;
}

int main(int argc, char **argv)
{
    const char *dir = argc > 1 ? argv[1] : "/tmp/sp-bench";
    char path[512];
    snprintf(path, sizeof(path), "%s/orientation-city.spcap", dir);
    int ret = make_capture(path);
    if (ret) {
        fprintf(stderr, "bench_orientation: cannot make %s: %s\n", path, sp_strerror(ret));
        return 1;
    }
    double vw, vc, iw, ic;
    uint64_t vn = 0, in = 0;
    if (time_stage(path, &sp_stage_video_orientation, &vw, &vc, &vn) ||
        time_stage(path, &sp_stage_orientation, &iw, &ic, &in))
        return 1;
    printf("orientation over %llu frames of 320x320, median of %d:\n", (unsigned long long)vn, RUNS);
    printf("  from the video   wall %.3f s, CPU %.3f s (%.2f ms of CPU per frame)\n", vw, vc, 1e3 * vc / (double)vn);
    printf("  from the IMU     wall %.3f s, CPU %.3f s (%.2f ms of CPU per frame; the baseline)\n", iw, ic,
           1e3 * ic / (double)in);
    printf("  ratio video / IMU: wall %.2f, CPU %.2f\n", vw / iw, vc / ic);
    return 0;
}
