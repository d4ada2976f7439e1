/* SPDX-License-Identifier: MIT */
/*
 * SunStage fit benchmark on synthetic selfies (sp_synth, default settings but
 * the duration): for each capture length, writes the capture, then fits it in
 * a child process per solver (so peak RSS is the fit's own, from wait4) and
 * prints wall time, sun-direction error, training and held-out PSNR, albedo
 * error (scale-aligned RMS over covered texels) and peak RSS. For Adam, also the
 * wall time at which its held-out PSNR first reached the fast solver's.
 * Relighting and novel-view PSNR: the truth directory's held-out frames (other suns at
 * capture poses; cameras the capture never had) rendered from the fit (face pose aligned to
 * the frame's landmarks, light mapped into the fit's world and scaled by the fitted/true sun
 * intensity ratio), compared at the fit resolution on the rendered face-skin mask.
 * The fast solver runs on one thread and on all online CPUs (the ratio is printed; the
 * results are bit-identical). RSS and times of the fast rows are the all-CPU run's.
 * Usage: bench_fit [SECONDS...] [--face generic|auto] [--supersample S] [--no-adam]
 *                  [--face-crop W] [--keyframes N] [--texture ROWS]
 *        (default: 20 120; auto face; the synth's default supersampling; the fit's defaults)
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
#include "common/file_util.h"
#include "common/json.h"
#include "common/parallel.h"
#include "pipeline/stages/stages.h"
#include "sunprobe/sp_sunstage.h"
#include "sunprobe/sp_synth.h"

#define N_HELDOUT 4 /* relit and novel-view frames each */

/* Fit settings given on the command line (0 = the fit's default) and the solver threads of the next fit. */
static struct {
    int crop_width, keyframes, texture, threads;
} opts;

typedef struct result {
    int ok;
    double seconds, sun_err, train, heldout, albedo_err, adam_reach_s, relit, novel;
    double adam_reach_sun_s; /* wall time at which the sun error first reached the target, -1 = never */
    double min_sun_err;      /* smallest sun error at any progress call (deg) */
    int keyframes;
    long rss_kb;
} result;

typedef struct bench_cb {
    double target, reach;
    int64_t t0;
    const sp_sunstage *ss;
    const double *true_sun;
    double target_sun, reach_sun; /* sun-error target (deg) and when it was first met */
    double min_sun;               /* smallest sun error seen at a progress call */
} bench_cb;

/* Sun-direction error of the current fit in degrees; NaN without truth alignment. */
static double sun_error(const sp_sunstage *ss, const double true_sun[3])
{
    sp_sunstage_result r;
    double R[9], d = 0.0;
    if (sp_sunstage_align_world(ss, R) || sp_sunstage_get_result(ss, &r))
        return NAN;
    for (int i = 0; i < 3; i++)
        d += (R[i * 3] * r.sun_dir[0] + R[i * 3 + 1] * r.sun_dir[1] + R[i * 3 + 2] * r.sun_dir[2]) * true_sun[i];
    return acos(fmax(-1.0, fmin(1.0, d))) * 180.0 / M_PI;
}

static int on_progress(void *user, const sp_sunstage_progress *p)
{
    bench_cb *c = user;
    double now = (double)(sp_clock_monotonic_ns() - c->t0) * 1e-9;
    if (isfinite(p->heldout_psnr) && p->heldout_psnr >= c->target && !(c->reach >= 0.0))
        c->reach = now;
    double e = strcmp(p->stage, "photometric") ? (double)NAN : sun_error(c->ss, c->true_sun);
    if (e <= c->target_sun && !(c->reach_sun >= 0.0))
        c->reach_sun = now;
    if (e < c->min_sun)
        c->min_sun = e;
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

/* Binary PPM (P6, 8 bit) or PFM ("PF", bottom row first); floats into out (w * h * 3). */
static float *read_image(const char *path, int *w, int *h)
{
    size_t len;
    char *b = slurp(path, &len);
    if (!b)
        return NULL;
    int pfm = b[0] == 'P' && b[1] == 'F', off = 0;
    double maxv = 0;
    float *out = NULL;
    if (sscanf(b + 2, "%d %d %lf%n", w, h, &maxv, &off) == 3 && *w > 0 && *h > 0 && *w < 8192 && *h < 8192) {
        size_t n = (size_t)*w * (size_t)*h * 3, start = 2 + (size_t)off + 1;
        if (start + n * (pfm ? 4 : 1) <= len && (out = malloc(n * sizeof(float))))
            for (size_t i = 0; i < n; i++) {
                if (pfm) {
                    size_t row = i / ((size_t)*w * 3), col = i % ((size_t)*w * 3);
                    memcpy(&out[((size_t)*h - 1 - row) * (size_t)*w * 3 + col], b + start + i * 4, 4);
                } else {
                    out[i] = (float)((unsigned char)b[start + i] / maxv);
                }
            }
    }
    free(b);
    return out;
}

/* Box-downsamples a w x h RGB image to W x H. */
static void downsample(const float *src, int w, int h, float *dst, int W, int H)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int x0 = x * w / W, x1 = (x + 1) * w / W, y0 = y * h / H, y1 = (y + 1) * h / H;
            double acc[3] = { 0, 0, 0 };
            int n = 0;
            for (int yy = y0; yy < (y1 > y0 ? y1 : y0 + 1); yy++)
                for (int xx = x0; xx < (x1 > x0 ? x1 : x0 + 1); xx++, n++)
                    for (int c = 0; c < 3; c++)
                        acc[c] += (double)src[((size_t)yy * (size_t)w + (size_t)xx) * 3 + (size_t)c];
            for (int c = 0; c < 3; c++)
                dst[((size_t)y * (size_t)W + (size_t)x) * 3 + (size_t)c] = (float)(acc[c] / (n ? n : 1));
        }
}

/* Resamples a truth-world env map into the fit's world: fit direction d reads the truth at R d. */
static void rotate_env(const float *src, const double R[9], double scale, float *dst)
{
    for (int i = 0; i < SP_RENDER_ENV_H; i++)
        for (int j = 0; j < SP_RENDER_ENV_W; j++) {
            double th = (i + 0.5) * M_PI / SP_RENDER_ENV_H, ph = (j + 0.5) * 2.0 * M_PI / SP_RENDER_ENV_W;
            double d[3] = { sin(th) * cos(ph), sin(th) * sin(ph), cos(th) }, e[3];
            for (int r = 0; r < 3; r++)
                e[r] = R[r * 3] * d[0] + R[r * 3 + 1] * d[1] + R[r * 3 + 2] * d[2];
            double th2 = acos(fmax(-1.0, fmin(1.0, e[2]))), ph2 = atan2(e[1], e[0]);
            if (ph2 < 0)
                ph2 += 2.0 * M_PI;
            int ii = (int)(th2 / M_PI * SP_RENDER_ENV_H), jj = (int)(ph2 / (2.0 * M_PI) * SP_RENDER_ENV_W);
            ii = ii < 0 ? 0 : (ii >= SP_RENDER_ENV_H ? SP_RENDER_ENV_H - 1 : ii);
            jj = jj < 0 ? 0 : (jj >= SP_RENDER_ENV_W ? SP_RENDER_ENV_W - 1 : jj);
            for (int c = 0; c < 3; c++)
                dst[(i * SP_RENDER_ENV_W + j) * 3 + c] = (float)(scale * (double)src[(ii * SP_RENDER_ENV_W + jj) * 3 + c]);
        }
}

typedef struct heldout_ctx {
    const char *truth_dir;
    double shutter_us;
    const sp_synth_selfie_truth *t;
} heldout_ctx;

/* PSNR of one held-out frame; NaN when it cannot be evaluated. */
static double eval_heldout(sp_sunstage *ss, const heldout_ctx *h, const char *stem, const double R[9])
{
    char path[512], err[128];
    snprintf(path, sizeof(path), "%s/heldout/%s.json", h->truth_dir, stem);
    size_t len;
    char *txt = slurp(path, &len);
    sp_json *j = NULL;
    if (!txt || sp_json_parse(txt, len, &j, err, sizeof(err))) {
        free(txt);
        return NAN;
    }
    free(txt);
    const sp_json *cam = sp_json_get(j, "camera");
    double q[4], sun[3], lm[136];
    sp_sunstage_result r;
    sp_sunstage_get_result(ss, &r);
    sp_sunstage_view v;
    memset(&v, 0, sizeof(v));
    v.fx = sp_json_number(sp_json_get(cam, "fx"), 0);
    v.fy = sp_json_number(sp_json_get(cam, "fy"), 0);
    v.cx = sp_json_number(sp_json_get(cam, "cx"), 0);
    v.cy = sp_json_number(sp_json_get(cam, "cy"), 0);
    int ok = sp_json_numbers(sp_json_get(cam, "camera_to_world"), q, 4) == 4 &&
             sp_json_numbers(sp_json_get(sp_json_get(j, "sun"), "direction_world"), sun, 3) == 3 &&
             sp_json_numbers(sp_json_get(j, "landmarks"), lm, 136) == 136;
    double I = sp_json_number(sp_json_get(sp_json_get(j, "sun"), "intensity"), 0);
    double expo = sp_json_number(sp_json_get(j, "exposure"), 1);
    snprintf(path, sizeof(path), "%s/heldout/%s", h->truth_dir, sp_json_string(sp_json_get(j, "image"), ""));
    char envp[512];
    snprintf(envp, sizeof(envp), "%s/heldout/%s", h->truth_dir, sp_json_string(sp_json_get(j, "env_pfm"), ""));
    sp_json_free(j);
    int iw, ih, ew, eh;
    float *img = ok ? read_image(path, &iw, &ih) : NULL, *env = ok ? read_image(envp, &ew, &eh) : NULL;
    double psnr = NAN;
    sp_sunstage_frame f0;
    if (img && env && ew == SP_RENDER_ENV_W && eh == SP_RENDER_ENV_H && sp_sunstage_get_frame(ss, 0, &f0) == 0 &&
        h->t->sun_intensity > 0.0) {
        /* truth world -> fit world: x_fit = R^T x_true */
        sp_quat qa = sp_quat_from_matrix(R);
        v.camera_to_world = sp_quat_mul(sp_quat_conj(qa), (sp_quat){ q[0], q[1], q[2], q[3] });
        for (int i = 0; i < 3; i++)
            v.sun_dir[i] = R[i] * sun[0] + R[3 + i] * sun[1] + R[6 + i] * sun[2];
        double k = r.sun_intensity / h->t->sun_intensity; /* fitted light units per true unit */
        v.sun_intensity = I * k;
        float envf[SP_RENDER_ENV_FLOATS];
        rotate_env(env, R, k, envf);
        v.env = envf;
        v.landmarks = lm;
        double ref = sp_sunstage_exposure_reference(ss);
        v.exposure = ref > 0.0 ? h->shutter_us * expo / ref : 1.0;
        int W = f0.width, H = f0.height;
        float *mine = malloc(sizeof(float) * 3 * (size_t)W * (size_t)H), *mask = malloc(sizeof(float) * (size_t)W * (size_t)H);
        float *small = malloc(sizeof(float) * 3 * (size_t)W * (size_t)H);
        if (mine && mask && small && sp_sunstage_render_view(ss, &v, mine, mask) == 0) {
            downsample(img, iw, ih, small, W, H);
            double se = 0.0, m = 0.0;
            for (int p = 0; p < W * H; p++)
                if (mask[p] > 0.0f)
                    for (int c = 0; c < 3; c++, m += 1.0) {
                        double d = (double)mine[p * 3 + c] - (double)small[p * 3 + c];
                        se += d * d;
                    }
            psnr = m > 0.0 && se > 0.0 ? -10.0 * log10(se / m) : (double)NAN;
        }
        free(mine);
        free(mask);
        free(small);
    }
    free(img);
    free(env);
    return psnr;
}

/* Mean PSNR (pooled through the MSE) over the held-out frames of one kind. */
static double eval_kind(sp_sunstage *ss, const heldout_ctx *h, const char *kind, int n)
{
    double R[9], se = 0.0;
    int m = 0;
    if (!h->truth_dir || sp_sunstage_align_world(ss, R))
        return NAN;
    for (int k = 0; k < n; k++) {
        char stem[64];
        snprintf(stem, sizeof(stem), "%s_%02d", kind, k);
        double p = eval_heldout(ss, h, stem, R);
        if (isfinite(p)) {
            se += pow(10.0, -p / 10.0);
            m++;
        }
    }
    return m ? -10.0 * log10(se / m) : (double)NAN;
}

static int fit_child(const char *cap, enum sp_sunstage_solver solver, const heldout_ctx *h, const double target[2],
                     result *res)
{
    const sp_synth_selfie_truth *t = h->t;
    sp_fit_stage_settings fs = { .model = t->model };
    sp_sunstage_default_settings(&fs.fit);
    fs.fit.solver = solver;
    fs.fit.threads = opts.threads;
    if (opts.crop_width)
        fs.fit.face_crop = 1, fs.fit.fit_width = opts.crop_width;
    if (opts.keyframes)
        fs.fit.keyframes = opts.keyframes;
    if (opts.texture)
        fs.fit.texture_size = opts.texture;
    sp_stage stage = { 0 };
    int ret = sp_stage_open(&stage, &sp_stage_fit, &fs);
    if (ret)
        return ret;
    sp_sunstage *ss = stage.ctx;
    bench_cb cb = { target[0], -1.0, sp_clock_monotonic_ns(), ss, t->sun_dir_world, target[1], -1.0, INFINITY };
    sp_run_settings rs;
    sp_run_default_settings(&rs);
    rs.progress = 0;
    if ((ret = sp_stage_run(cap, &stage, &rs, NULL)) || (ret = sp_sunstage_fit(ss, on_progress, &cb)))
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
    res->adam_reach_sun_s = cb.reach_sun;
    res->min_sun_err = cb.min_sun;
    res->keyframes = r.n_frames;
    /* held-out frames are whole frames; a face-crop fit renders its own crop size, which this scoring does not
       map (use `sunprobe evaluate` on a capture directory for those) */
    res->relit = opts.crop_width ? (double)NAN : eval_kind(ss, h, "relit", N_HELDOUT);
    res->novel = opts.crop_width ? (double)NAN : eval_kind(ss, h, "view", N_HELDOUT);
done:
    sp_stage_close(&stage);
    return ret;
}

static int run_fit(const char *cap, enum sp_sunstage_solver solver, const heldout_ctx *t, const double target[2],
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
    printf("%-6s %5.0f s  %3d kf  wall %7.1f s  sun %6.2f deg  train %6.2f dB  held-out %6.2f dB  albedo RMS %.4f"
           "  peak RSS %6.1f MB",
           name, dur, r->keyframes, r->seconds, r->sun_err, r->train, r->heldout, r->albedo_err,
           (double)r->rss_kb / 1024.0);
    printf("  relit %6.2f dB  novel %6.2f dB", r->relit, r->novel);
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
    s.n_relit = s.n_novel = N_HELDOUT;
    sp_synth_selfie *g = NULL;
    int ret = sp_synth_selfie_open(&g, &s);
    if (ret)
        return ret;
    char cap[256], truth[256];
    snprintf(cap, sizeof(cap), "/tmp/bench_fit_%d_%.0f.spcap", (int)getpid(), duration);
    snprintf(truth, sizeof(truth), "/tmp/bench_fit_%d_%.0f.truth", (int)getpid(), duration);
    int64_t t0 = sp_clock_monotonic_ns();
    sp_synth_selfie_report rep;
    if (!(ret = sp_synth_selfie_write(g, cap, truth, &rep))) {
        printf("capture: %.0f s, %llu frames, %.1f MB, synthesised in %.1f s\n", duration,
               (unsigned long long)rep.frames, (double)rep.capture_bytes / 1e6,
               (double)(sp_clock_monotonic_ns() - t0) * 1e-9);
        heldout_ctx t = { truth, s.shutter_s * 1e6, sp_synth_selfie_get_truth(g) };
        result fast, ad;
        const double none[2] = { INFINITY, -1.0 };
        sp_sunstage_settings defaults;
        sp_sunstage_default_settings(&defaults);
        result one;
        opts.threads = 1;
        if (!(ret = run_fit(cap, SP_SUNSTAGE_SOLVER_FAST, &t, none, &one)))
            print_row("fast1", duration, &one);
        opts.threads = 0;
        if (!ret && !(ret = run_fit(cap, SP_SUNSTAGE_SOLVER_FAST, &t, none, &fast))) {
            print_row("fast", duration, &fast);
            printf("fast on 1 thread / on %d CPUs: wall %.1f s / %.1f s = %.2fx\n", sp_cpu_count(), one.seconds,
                   fast.seconds, one.seconds / fast.seconds);
            const double target[2] = { fast.heldout, fast.sun_err };
            if (adam && !(ret = run_fit(cap, SP_SUNSTAGE_SOLVER_ADAM, &t, target, &ad))) {
                print_row("adam", duration, &ad);
                if (ad.adam_reach_s >= 0.0)
                    printf("adam/fast time to the same held-out PSNR: %.1fx\n", ad.adam_reach_s / fast.seconds);
                else
                    printf("adam never reached fast's held-out PSNR (%.2f dB) in %d steps\n", fast.heldout,
                           defaults.adam_iterations);
                if (ad.adam_reach_sun_s >= 0.0)
                    printf("adam/fast time to the same sun error (%.2f deg): %.1fx (adam's smallest %.2f deg, "
                           "final %.2f deg)\n", fast.sun_err, ad.adam_reach_sun_s / fast.seconds, ad.min_sun_err,
                           ad.sun_err);
                else
                    printf("adam never reached fast's sun error (%.2f deg) in %d steps\n", fast.sun_err,
                           defaults.adam_iterations);
            }
        }
    }
    unlink(cap);
    char cmd[300];
    snprintf(cmd, sizeof(cmd), "rm -rf %s", truth);
    if (system(cmd) == -1)
        fprintf(stderr, "bench_fit: cannot remove %s\n", truth);
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
        else if (!strcmp(argv[i], "--face-crop") && i + 1 < argc)
            opts.crop_width = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--keyframes") && i + 1 < argc)
            opts.keyframes = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--texture") && i + 1 < argc)
            opts.texture = atoi(argv[++i]);
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
