/* SPDX-License-Identifier: MIT */
/*
 * Renderer benchmark: one 224 x 224 frame of a ~10k-triangle sphere head
 * (displacement, 10 specular clusters, SH sky, shadowed sun), forward render
 * plus the adjoint of an L2 loss, single thread. Prints the median of RUNS
 * timed runs (after one warm-up) for forward, backward and their total, in ms,
 * as wall time and as thread CPU time (the latter is robust to other jobs).
 * Usage: bench_render [supersample]   (default 1)
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "common/clock.h"
#include "pipeline/render/testmesh.h"
#include "sunprobe/sp_render.h"

#define RUNS 10
#define SIZE 224
#define TEX 256

/* Thread CPU time: the figure that matters when other jobs share the cores. */
static int64_t cpu_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof(double), cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
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
    if (!albedo || !disp || !clusters || !g_alb || !g_disp || sp_renderer_open(&r, &set) != 0 ||
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
    double tf[RUNS], tb[RUNS], tt[RUNS], cf[RUNS], cb[RUNS], ct[RUNS];
    int covered = 0;
    for (int run = -1; run < RUNS; run++) {
        sp_render_outputs o;
        double loss;
        int64_t t0 = sp_clock_monotonic_ns(), c0 = cpu_ns();
        int err = sp_render(r, &sc, &o);
        int64_t t1 = sp_clock_monotonic_ns(), c1 = cpu_ns();
        if (!err)
            err = sp_render_l2_loss(o.image, target, o.coverage, SIZE, SIZE, &loss, dl);
        sp_render_grads_zero(&g, &sc);
        int64_t t2 = sp_clock_monotonic_ns(), c2 = cpu_ns();
        if (!err)
            err = sp_render_backward(r, &sc, dl, &g);
        int64_t t3 = sp_clock_monotonic_ns(), c3 = cpu_ns();
        if (err) {
            fprintf(stderr, "bench_render: %s\n", sp_strerror(err));
            return 1;
        }
        if (run < 0) {
            for (int i = 0; i < SIZE * SIZE; i++)
                covered += o.coverage[i] > 0.0f;
            continue;
        }
        tf[run] = (double)(t1 - t0) * 1e-6;
        tb[run] = (double)(t3 - t2) * 1e-6;
        tt[run] = tf[run] + tb[run];
        cf[run] = (double)(c1 - c0) * 1e-6;
        cb[run] = (double)(c3 - c2) * 1e-6;
        ct[run] = cf[run] + cb[run];
    }
    printf("bench_render: %dx%d, supersample %d, %u triangles, %d covered pixels, shadow map %d^2\n", SIZE, SIZE,
           ss, head.n_triangles, covered, set.shadow_size);
    printf("median of %d (wall):       forward %.2f ms, backward %.2f ms, total %.2f ms\n", RUNS,
           median(tf, RUNS), median(tb, RUNS), median(tt, RUNS));
    printf("median of %d (thread CPU): forward %.2f ms, backward %.2f ms, total %.2f ms\n", RUNS,
           median(cf, RUNS), median(cb, RUNS), median(ct, RUNS));
    /* median() sorted the arrays: element 0 is the fastest run */
    printf("fastest run (thread CPU):  forward %.2f ms, backward %.2f ms, total %.2f ms\n", cf[0], cb[0], ct[0]);
    sp_renderer_close(&r);
    sp_mesh_free(&head);
    free(albedo);
    free(disp);
    free(clusters);
    free(g_alb);
    free(g_disp);
    free(g_pos);
    return 0;
}
