/* SPDX-License-Identifier: MIT */
/*
 * Renderer benchmark: one 224 x 224 frame of a ~10k-triangle sphere head
 * (displacement, 10 specular clusters, SH sky, shadowed sun, shadow map
 * rendered every frame), forward render plus the adjoint of an L2 loss,
 * single thread, three ways:
 *  - classic: sp_render (all output buffers) + sp_render_l2_loss +
 *    sp_render_backward, timed as forward (render) and backward (loss + adjoint);
 *  - fit: the fused sp_render_fit_l2 (render + loss + adjoint in one sweep,
 *    no decomposition buffers), timed as one call;
 *  - fit_float: the same with settings.fit_float (float SoA shading kernels),
 *    alternated run by run with fit so both see the same machine load; where
 *    the renderer picks a faster kernel set than the baseline (AVX2 on
 *    x86-64, pipeline/render/simd_kernels.h), also fit_float on the baseline
 *    set, in the same alternation.
 * Both use the same scene, target, mask (the coverage of the warm-up render)
 * and gradient groups. Prints the median of RUNS timed runs (after one
 * warm-up) as wall time and as thread CPU time (the latter is robust to other
 * jobs), the ratio, and user-space instruction counts where the kernel allows
 * perf counters. Usage: bench_render [supersample]   (default 1)
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#ifdef __linux__
#include <linux/perf_event.h>
#include <sys/syscall.h>
#include <unistd.h>
#endif

#include "bench_util.h"
#include "common/clock.h"
#include "pipeline/render/simd_kernels.h"
#include "pipeline/render/testmesh.h"
#include "sunprobe/sp_render.h"

#define RUNS 10
#define SIZE 224
#define TEX 256

/* User-space instruction counter of this thread, -1 where unavailable. */
static int instr_open(void)
{
#ifdef __linux__
    struct perf_event_attr a;
    memset(&a, 0, sizeof(a));
    a.type = PERF_TYPE_HARDWARE;
    a.size = sizeof(a);
    a.config = PERF_COUNT_HW_INSTRUCTIONS;
    a.exclude_kernel = 1;
    a.exclude_hv = 1;
    return (int)syscall(SYS_perf_event_open, &a, 0, -1, -1, 0);
#else
    return -1;
#endif
}

static double instr_read(int fd)
{
#ifdef __linux__
    long long v = 0;
    if (fd >= 0 && read(fd, &v, sizeof(v)) == (ssize_t)sizeof(v))
        return (double)v;
#else
    (void)fd;
#endif
    return 0.0;
}

/* A fit_float renderer on the baseline kernels (SP_RENDER_SIMD=base while it opens). */
static int open_base_kernels(sp_renderer **r, const sp_renderer_settings *set)
{
    const char *was = getenv("SP_RENDER_SIMD");
    char *saved = was ? strdup(was) : NULL;
    setenv("SP_RENDER_SIMD", "base", 1);
    int err = sp_renderer_open(r, set);
    if (saved)
        setenv("SP_RENDER_SIMD", saved, 1);
    else
        unsetenv("SP_RENDER_SIMD");
    free(saved);
    return err;
}

/* Smooth, deterministic textures: skin-like albedo, millimetre bumps, 10 cluster bands. */
static void make_textures(float *albedo, float *disp, uint8_t *clusters, float *env)
{
    for (int y = 0; y < TEX; y++)
        for (int x = 0; x < TEX; x++) {
            int i = y * TEX + x;
            double s = (double)((x * 37 + y * 91) % 101) / 101.0;
            albedo[i * 3 + 0] = (float)(0.55 + 0.1 * s);
            albedo[i * 3 + 1] = (float)(0.40 + 0.08 * s);
            albedo[i * 3 + 2] = (float)(0.32 + 0.05 * s);
            disp[i] = (float)(0.0005 * ((double)((x * 13 + y * 7) % 17) / 17.0 - 0.5));
        }
    for (int y = 0; y < 64; y++)
        for (int x = 0; x < 64; x++)
            clusters[y * 64 + x] = (uint8_t)((y * 10) / 64);
    for (int i = 0; i < SP_RENDER_ENV_FLOATS; i++)
        env[i] = (float)(0.2 + (i < SP_RENDER_ENV_FLOATS / 2 ? 0.5 : 0.1) + 0.05 * (i % 7));
}

int main(int argc, char **argv)
{
    int ss = argc > 1 ? atoi(argv[1]) : 1;
    sp_renderer_settings set;
    sp_renderer_default_settings(&set);
    set.width = set.height = SIZE;
    set.supersample = ss;
    sp_renderer *r = NULL;
    sp_mesh head;
    double c[3] = {0, 0, 0};
    float *albedo = malloc(sizeof(float) * TEX * TEX * 3), *disp = malloc(sizeof(float) * TEX * TEX);
    uint8_t *clusters = malloc(64 * 64);
    static float env[SP_RENDER_ENV_FLOATS], target[SIZE * SIZE * 3], dl[SIZE * SIZE * 3];
    double *g_alb = calloc(TEX * TEX * 3, sizeof(double)), *g_disp = calloc(TEX * TEX, sizeof(double));
    static double g_env[SP_RENDER_ENV_FLOATS];
    sp_renderer *r_ff = NULL;
    sp_renderer_settings set_ff = set;
    set_ff.fit_float = 1;
    const char *kernels = simd_kernels_select()->name;
    int with_base = strcmp(kernels, "base") != 0;
    sp_renderer *r_ffb = NULL;
    if (!albedo || !disp || !clusters || !g_alb || !g_disp || sp_renderer_open(&r, &set) != 0 ||
        sp_renderer_open(&r_ff, &set_ff) != 0 || (with_base && open_base_kernels(&r_ffb, &set_ff) != 0) ||
        testmesh_head(&head, 64, 80, c, 0.075, 0.095, 0.11, 0.25) != 0) {
        fprintf(stderr, "bench_render: setup failed\n");
        return 1;
    }
    double *g_pos = calloc((size_t)head.n_vertices * 3, sizeof(double));
    make_textures(albedo, disp, clusters, env);
    sp_render_scene sc;
    sp_render_scene_defaults(&sc);
    double eye[3] = {0.05, -0.42, 0.03}, at[3] = {0, 0, 0}, up[3] = {0, 0, 1};
    sc.camera.fx = sc.camera.fy = 420.0;
    sc.camera.cx = sc.camera.cy = 111.5;
    testmesh_look_at(&sc.camera, eye, at, up);
    sc.mesh = &head;
    sc.albedo = (sp_render_texture){TEX, TEX, albedo};
    sc.displacement = (sp_render_texture){TEX, TEX, disp};
    sc.clusters = (sp_render_cluster_map){64, 64, clusters};
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++) {
        sc.ks[k] = 0.05 + 0.02 * k;
        sc.shininess[k] = 10.0 + 5.0 * k;
    }
    sc.env = env;
    sc.sun_dir[0] = 0.6, sc.sun_dir[1] = -0.5, sc.sun_dir[2] = 0.6;
    sc.sun_intensity = 3.0;
    for (int i = 0; i < SIZE * SIZE * 3; i++)
        target[i] = 0.5f;
    sp_render_grads g = {.albedo = g_alb, .displacement = g_disp, .env = g_env, .positions = g_pos};
    double tf[RUNS], tb[RUNS], tt[RUNS], cf[RUNS], cb[RUNS], ct[RUNS], in_f[RUNS], in_b[RUNS];
    double tfit[RUNS], cfit[RUNS], in_fit[RUNS], loss_classic = 0.0, loss_fit = 0.0;
    double tfit_ff[RUNS], cfit_ff[RUNS], in_fit_ff[RUNS], loss_fit_ff = 0.0;
    double tfit_ffb[RUNS], cfit_ffb[RUNS], in_fit_ffb[RUNS], loss_fit_ffb = 0.0;
    float *mask = calloc(SIZE * SIZE, sizeof(float));
    int covered = 0, ifd = instr_open();
    for (int run = -1; run < RUNS; run++) { /* classic: render, then loss + adjoint */
        sp_render_outputs o;
        int64_t t0 = sp_clock_monotonic_ns(), c0 = bench_thread_cpu_ns();
        double i0 = instr_read(ifd);
        int err = mask ? sp_render(r, &sc, &o) : -1;
        double i1 = instr_read(ifd);
        int64_t t1 = sp_clock_monotonic_ns(), c1 = bench_thread_cpu_ns();
        if (!err)
            err = sp_render_l2_loss(o.image, target, o.coverage, SIZE, SIZE, &loss_classic, dl);
        double i2 = instr_read(ifd);
        if (!err)
            err = sp_render_backward(r, &sc, dl, &g);
        double i3 = instr_read(ifd);
        int64_t t3 = sp_clock_monotonic_ns(), c3 = bench_thread_cpu_ns();
        sp_render_grads_zero(&g, &sc);
        if (err) {
            fprintf(stderr, "bench_render: classic failed\n");
            return 1;
        }
        if (run < 0) {
            for (int i = 0; i < SIZE * SIZE; i++)
                covered += o.coverage[i] > 0.0f;
            memcpy(mask, o.coverage, sizeof(float) * SIZE * SIZE);
            continue;
        }
        tf[run] = (double)(t1 - t0) * 1e-6;
        tb[run] = (double)(t3 - t1) * 1e-6;
        tt[run] = tf[run] + tb[run];
        cf[run] = (double)(c1 - c0) * 1e-6;
        cb[run] = (double)(c3 - c1) * 1e-6;
        ct[run] = cf[run] + cb[run];
        in_f[run] = i1 - i0;
        in_b[run] = i3 - i2 + (i2 - i1);
    }
    /* fit: the fused call, double (r), float shading (r_ff) and on the baseline kernels (r_ffb), alternated */
    sp_renderer *fits[3] = {r, r_ff, r_ffb};
    double *tw[3] = {tfit, tfit_ff, tfit_ffb}, *tc[3] = {cfit, cfit_ff, cfit_ffb};
    double *ti[3] = {in_fit, in_fit_ff, in_fit_ffb}, *lf[3] = {&loss_fit, &loss_fit_ff, &loss_fit_ffb};
    for (int run = -1; run < RUNS; run++)
        for (int k = 0; k < 2 + with_base; k++) {
            sp_render_outputs o;
            int64_t t0 = sp_clock_monotonic_ns(), c0 = bench_thread_cpu_ns();
            double i0 = instr_read(ifd);
            int err = sp_render_fit_l2(fits[k], &sc, target, mask, lf[k], &g, &o);
            double i1 = instr_read(ifd);
            int64_t t1 = sp_clock_monotonic_ns(), c1 = bench_thread_cpu_ns();
            sp_render_grads_zero(&g, &sc);
            if (err) {
                fprintf(stderr, "bench_render: fit: %s\n", sp_strerror(err));
                return 1;
            }
            if (run >= 0) {
                tw[k][run] = (double)(t1 - t0) * 1e-6;
                tc[k][run] = (double)(c1 - c0) * 1e-6;
                ti[k][run] = i1 - i0;
            }
        }
    printf("bench_render: %dx%d, supersample %d, %u triangles, %d covered pixels, shadow map %d^2 (every frame)\n",
           SIZE, SIZE, ss, head.n_triangles, covered, set.shadow_size);
    printf("classic = sp_render (all outputs) + sp_render_l2_loss + sp_render_backward; "
           "fit = fused sp_render_fit_l2\n");
    printf("classic median of %d (wall):       forward %.2f ms, backward %.2f ms, total %.2f ms\n", RUNS,
           bench_median(tf, RUNS), bench_median(tb, RUNS), bench_median(tt, RUNS));
    double classic_cpu = bench_median(ct, RUNS), fit_cpu = bench_median(cfit, RUNS);
    printf("classic median of %d (thread CPU): forward %.2f ms, backward %.2f ms, total %.2f ms\n", RUNS,
           bench_median(cf, RUNS), bench_median(cb, RUNS), classic_cpu);
    /* bench_median() sorted the arrays: element 0 is the fastest run */
    printf("classic fastest (thread CPU):      forward %.2f ms, backward %.2f ms, total %.2f ms\n", cf[0], cb[0],
           ct[0]);
    printf("fit median of %d (wall):           total %.2f ms\n", RUNS, bench_median(tfit, RUNS));
    printf("fit median of %d (thread CPU):     total %.2f ms (fastest %.2f ms)\n", RUNS, fit_cpu, cfit[0]);
    printf("ratio classic / fit (thread CPU median): %.2f\n", fit_cpu > 0.0 ? classic_cpu / fit_cpu : 0.0);
    double ff_cpu = bench_median(cfit_ff, RUNS);
    printf("fit_float median of %d (wall):     total %.2f ms\n", RUNS, bench_median(tfit_ff, RUNS));
    printf("fit_float median of %d (thread CPU): total %.2f ms (fastest %.2f ms), ratio fit / fit_float %.2f "
           "(%s kernels)\n", RUNS, ff_cpu, cfit_ff[0], ff_cpu > 0.0 ? fit_cpu / ff_cpu : 0.0, kernels);
    if (with_base) {
        double ffb_cpu = bench_median(cfit_ffb, RUNS);
        printf("fit_float, base kernels (thread CPU): total %.2f ms (fastest %.2f ms), ratio base / %s %.2f\n",
               ffb_cpu, cfit_ffb[0], kernels, ff_cpu > 0.0 ? ffb_cpu / ff_cpu : 0.0);
    }
    if (ifd >= 0)
        printf("instructions (user, median): classic forward %.1f M, backward %.1f M, total %.1f M; fit %.1f M\n",
               bench_median(in_f, RUNS) * 1e-6, bench_median(in_b, RUNS) * 1e-6,
               (bench_median(in_f, RUNS) + bench_median(in_b, RUNS)) * 1e-6, bench_median(in_fit, RUNS) * 1e-6);
    if (ifd >= 0)
        printf("instructions (user, median): fit_float %.1f M\n", bench_median(in_fit_ff, RUNS) * 1e-6);
    else
        printf("instructions: perf counters unavailable here (try valgrind --tool=callgrind)\n");
    printf("loss classic %.17g, fit %.17g (%s)\n", loss_classic, loss_fit,
           loss_classic == loss_fit ? "identical" : "DIFFERENT");
    printf("loss fit_float %.17g (relative difference to classic %.2e)\n", loss_fit_ff,
           loss_classic != 0.0 ? fabs(loss_fit_ff - loss_classic) / loss_classic : 0.0);
    if (with_base)
        printf("loss fit_float, base kernels %.17g (relative difference to classic %.2e)\n", loss_fit_ffb,
               loss_classic != 0.0 ? fabs(loss_fit_ffb - loss_classic) / loss_classic : 0.0);
#ifdef __linux__
    if (ifd >= 0)
        close(ifd);
#endif
    free(mask);
    sp_renderer_close(&r);
    sp_renderer_close(&r_ff);
    sp_renderer_close(&r_ffb);
    sp_mesh_free(&head);
    free(albedo);
    free(disp);
    free(clusters);
    free(g_alb);
    free(g_disp);
    free(g_pos);
    return 0;
}
