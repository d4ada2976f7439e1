/* SPDX-License-Identifier: MIT */
/*
 * SunStage fit benchmark on synthetic selfies (sp_synth, default settings but
 * the duration): for each capture length, writes the capture, then fits it in
 * a child process per solver (so peak RSS is the fit's own, from wait4) and
 * prints wall time, sun-direction error, training and held-out PSNR, albedo
 * error (scale-aligned RMS over covered texels) and peak RSS. For Adam, also the
 * wall time at which its held-out PSNR first reached the fast solver's.
 * Relighting and novel-view PSNR against the truth directory are not measured yet.
 * Usage: bench_fit [SECONDS...] [--face generic|auto] [--supersample S] [--no-adam]
 *        (default: 20 120; auto face; the synth's default supersampling)
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

#include "common/clock.h"
#include "sunprobe/sp_replay.h"
#include "sunprobe/sp_sunstage.h"
#include "sunprobe/sp_synth.h"

typedef struct result {
    int ok;
    double seconds, sun_err, train, heldout, albedo_err, adam_reach_s;
    int keyframes;
    long rss_kb;
} result;

typedef struct bench_cb {
    double target, reach;
    int64_t t0;
} bench_cb;

static int on_progress(void *user, const sp_sunstage_progress *p)
{
    bench_cb *c = user;
    if (isfinite(p->heldout_psnr) && p->heldout_psnr >= c->target && !(c->reach >= 0.0))
        c->reach = (double)(sp_clock_monotonic_ns() - c->t0) * 1e-9;
    return 0;
}

static double albedo_error(const sp_sunstage_result *r, const sp_synth_selfie_truth *t)
{
    /* truth sampled at our texel centres (nearest); scale-aligned because albedo x light is ambiguous */
    double sab = 0.0, sbb = 0.0, saa = 0.0;
    size_t n = 0;
    for (int y = 0; y < r->tex_height; y++)
        for (int x = 0; x < r->tex_width; x++) {
            int tx = (int)((x + 0.5) * t->albedo.width / r->tex_width);
            int ty = (int)((y + 0.5) * t->albedo.height / r->tex_height);
            const float *a = t->albedo.data + ((size_t)ty * (size_t)t->albedo.width + (size_t)tx) * 3;
            const float *b = r->albedo + ((size_t)y * (size_t)r->tex_width + (size_t)x) * 3;
            const sp_face_model *m = r->model;
            int cx = (int)((x + 0.5) * m->cluster_width / r->tex_width);
            int cy = (int)((y + 0.5) * m->cluster_height / r->tex_height);
            if (m->cluster_map[(size_t)cy * m->cluster_width + (size_t)cx] > 7) /* face clusters only */
                continue;
            for (int c = 0; c < 3; c++) {
                sab += (double)a[c] * (double)b[c];
                sbb += (double)b[c] * (double)b[c];
                saa += (double)a[c] * (double)a[c];
            }
            n += 3;
        }
    if (!n || !(sbb > 0.0))
        return NAN;
    double k = sab / sbb, e = saa - 2.0 * k * sab + k * k * sbb;
    return sqrt(fmax(e, 0.0) / (double)n);
}

static int fit_child(const char *cap, enum sp_sunstage_solver solver, const sp_synth_selfie_truth *t, double target,
                     result *res)
{
    sp_sunstage_settings set;
    sp_sunstage_default_settings(&set);
    set.solver = solver;
    sp_sunstage *ss = NULL;
    int ret = sp_sunstage_open(&ss, &set, t->model);
    if (ret)
        return ret;
    bench_cb cb = { target, -1.0, sp_clock_monotonic_ns() };
    sp_replay_settings rs;
    sp_replay_default_settings(&rs);
    sp_source *src = NULL;
    if ((ret = sp_replay_open(&src, cap, &rs)))
        goto done;
    sp_event ev;
    while ((ret = sp_source_next(src, &ev)) == 0) {
        ret = sp_sunstage_push(ss, &ev);
        sp_event_release(&ev);
        if (ret)
            break;
    }
    sp_source_close(&src);
    if (ret != SP_EOS || (ret = sp_sunstage_end_stream(ss)) || (ret = sp_sunstage_fit(ss, on_progress, &cb)))
        goto done;
    sp_sunstage_result r;
    sp_sunstage_get_result(ss, &r);
    double R[9], d = 0.0;
    if (sp_sunstage_align_world(ss, R) == 0)
        for (int i = 0; i < 3; i++)
            d += (R[i * 3] * r.sun_dir[0] + R[i * 3 + 1] * r.sun_dir[1] + R[i * 3 + 2] * r.sun_dir[2]) * t->sun_dir_world[i];
    res->ok = 1;
    res->seconds = (double)(sp_clock_monotonic_ns() - cb.t0) * 1e-9;
    res->sun_err = acos(fmax(-1.0, fmin(1.0, d))) * 180.0 / M_PI;
    res->train = r.train_psnr;
    res->heldout = r.heldout_psnr;
    res->albedo_err = albedo_error(&r, t);
    res->adam_reach_s = cb.reach;
    res->keyframes = r.n_frames;
done:
    sp_sunstage_close(&ss);
    return ret;
}

static int run_fit(const char *cap, enum sp_sunstage_solver solver, const sp_synth_selfie_truth *t, double target,
                   result *res)
{
    int fd[2];
    if (pipe(fd))
        return -errno;
    pid_t pid = fork();
    if (pid < 0)
        return -errno;
    if (pid == 0) {
        close(fd[0]);
        result r;
        memset(&r, 0, sizeof(r));
        fit_child(cap, solver, t, target, &r);
        ssize_t w = write(fd[1], &r, sizeof(r));
        _exit(w == (ssize_t)sizeof(r) ? 0 : 1);
    }
    close(fd[1]);
    memset(res, 0, sizeof(*res));
    ssize_t n = read(fd[0], res, sizeof(*res));
    close(fd[0]);
    int status;
    struct rusage ru;
    wait4(pid, &status, 0, &ru);
    res->rss_kb = ru.ru_maxrss;
    return n == (ssize_t)sizeof(*res) && res->ok ? 0 : -EIO;
}

static void print_row(const char *name, double dur, const result *r)
{
    printf("%-5s %5.0f s  %3d kf  wall %7.1f s  sun %6.2f deg  train %6.2f dB  held-out %6.2f dB  albedo RMS %.4f"
           "  peak RSS %6.1f MB",
           name, dur, r->keyframes, r->seconds, r->sun_err, r->train, r->heldout, r->albedo_err,
           (double)r->rss_kb / 1024.0);
    if (r->adam_reach_s >= 0.0)
        printf("  reached fast's held-out PSNR at %.1f s", r->adam_reach_s);
    printf("\n");
    fflush(stdout);
}

static int bench_one(double duration, int generic, int supersample, int adam)
{
    sp_synth_selfie_settings s;
    sp_synth_selfie_default_settings(&s);
    s.face = generic ? SP_SYNTH_FACE_GENERIC : SP_SYNTH_FACE_AUTO;
    if (supersample > 0)
        s.supersample = supersample;
    s.imu.turn_duration_s = duration - s.imu.still_before_s - s.imu.still_after_s;
    if (s.imu.turn_duration_s < 1.0)
        s.imu.turn_duration_s = 1.0;
    s.n_relit = s.n_novel = 0;
    sp_synth_selfie *g = NULL;
    int ret = sp_synth_selfie_open(&g, &s);
    if (ret)
        return ret;
    char cap[256];
    snprintf(cap, sizeof(cap), "/tmp/bench_fit_%d_%.0f.spcap", (int)getpid(), duration);
    int64_t t0 = sp_clock_monotonic_ns();
    sp_synth_selfie_report rep;
    if (!(ret = sp_synth_selfie_write(g, cap, NULL, &rep))) {
        printf("capture: %.0f s, %llu frames, %.1f MB, synthesised in %.1f s\n", duration,
               (unsigned long long)rep.frames, (double)rep.capture_bytes / 1e6,
               (double)(sp_clock_monotonic_ns() - t0) * 1e-9);
        const sp_synth_selfie_truth *t = sp_synth_selfie_get_truth(g);
        result fast, ad;
        if (!(ret = run_fit(cap, SP_SUNSTAGE_SOLVER_FAST, t, INFINITY, &fast))) {
            print_row("fast", duration, &fast);
            if (adam && !(ret = run_fit(cap, SP_SUNSTAGE_SOLVER_ADAM, t, fast.heldout, &ad))) {
                print_row("adam", duration, &ad);
                if (ad.adam_reach_s >= 0.0)
                    printf("adam/fast time to the same held-out PSNR: %.1fx\n", ad.adam_reach_s / fast.seconds);
                else
                    printf("adam never reached fast's held-out PSNR (%.2f dB) in %d iterations\n", fast.heldout, 300);
            }
        }
    }
    unlink(cap);
    sp_synth_selfie_close(&g);
    return ret;
}

int main(int argc, char **argv)
{
    double durations[8];
    int n = 0, generic = 0, ss = 0, adam = 1;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--face") && i + 1 < argc)
            generic = !strcmp(argv[++i], "generic");
        else if (!strcmp(argv[i], "--supersample") && i + 1 < argc)
            ss = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--no-adam"))
            adam = 0;
        else if (n < 8 && atof(argv[i]) >= 3.0)
            durations[n++] = atof(argv[i]);
    }
    if (!n) {
        durations[0] = 20;
        durations[1] = 120;
        n = 2;
    }
    sp_log_set_level(SP_LOG_WARN);
    for (int i = 0; i < n; i++) {
        int ret = bench_one(durations[i], generic, ss, adam);
        if (ret)
            fprintf(stderr, "bench_fit: %.0f s capture: %s\n", durations[i], sp_strerror(ret));
    }
    return 0;
}
