/* SPDX-License-Identifier: MIT */
/*
 * Area-sun relighting benchmark: a 1024 x 1024 render (2 x 2 samples a pixel, as `sunprobe relight`) of a
 * ~10k-triangle sphere head with a shadowed sun, on one thread, three ways:
 *  - point: a point sun (the baseline);
 *  - soft: a sun disk of 5 deg (scene.sun_soft_radius: one shadow map, percentage-closer soft shadows);
 *  - samples: the same disk as 24 point suns, one render each (what relight did before).
 * Prints the median thread CPU time of RUNS runs of each (after one warm-up), alternated so all see the
 * same machine load, and the ratios to the point sun. Usage: bench_relight [size]   (default 1024)
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench_util.h"
#include "pipeline/render/testmesh.h"
#include "sunprobe/sp_render.h"

#define RUNS 5
#define SAMPLES 24
#define TEX 256

/* One way's render: seconds of thread CPU, or -1 on failure. */
static double render_way(sp_renderer *r, sp_render_scene *sc, int way)
{
    sp_render_outputs o;
    const double radius = 2.5 * M_PI / 180.0, *l = sc->sun_dir, I = sc->sun_intensity;
    int64_t t0 = bench_thread_cpu_ns();
    int err = 0;
    sc->sun_soft_radius = way == 1 ? radius : 0.0;
    if (way != 2) {
        err = sp_render(r, sc, &o);
    } else { /* equal-area rings of the cap along a Fibonacci spiral, as relight had it */
        sp_render_scene s = *sc;
        double u[3] = { 1, 0, 0 }, w[3], t = l[0];
        for (int k = 0; k < 3; k++)
            u[k] -= t * l[k];
        double un = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        for (int k = 0; k < 3; k++)
            u[k] /= un;
        w[0] = l[1] * u[2] - l[2] * u[1], w[1] = l[2] * u[0] - l[0] * u[2], w[2] = l[0] * u[1] - l[1] * u[0];
        s.sun_intensity = I / SAMPLES;
        for (int i = 0; i < SAMPLES && !err; i++) {
            double ct = 1.0 - (1.0 - cos(radius)) * (i + 0.5) / SAMPLES, st = sqrt(fmax(0.0, 1.0 - ct * ct));
            double ph = i * M_PI * (3.0 - sqrt(5.0));
            for (int k = 0; k < 3; k++)
                s.sun_dir[k] = ct * l[k] + st * (cos(ph) * u[k] + sin(ph) * w[k]);
            err = sp_render(r, &s, &o);
        }
    }
    return err ? -1.0 : (double)(bench_thread_cpu_ns() - t0) * 1e-9;
}

int main(int argc, char **argv)
{
    int size = argc > 1 ? atoi(argv[1]) : 1024;
    sp_renderer_settings set;
    sp_renderer_default_settings(&set);
    set.width = set.height = size > 16 && size <= 4096 ? size : 1024;
    set.supersample = 2;
    set.skip_outputs = SP_RENDER_SKIP_DECOMPOSITION; /* as relight without --passes */
    sp_renderer *r = NULL;
    sp_mesh head;
    double c[3] = { 0, 0, 0 };
    float *albedo = malloc(sizeof(float) * TEX * TEX * 3);
    static float env[SP_RENDER_ENV_FLOATS];
    if (!albedo || sp_renderer_open(&r, &set) || testmesh_head(&head, 64, 80, c, 0.075, 0.095, 0.11, 0.25)) {
        fprintf(stderr, "bench_relight: setup failed\n");
        return 1;
    }
    for (int i = 0; i < TEX * TEX * 3; i++)
        albedo[i] = 0.4f + 0.2f * (float)((i / 3) % 7) / 7.0f;
    for (int i = 0; i < SP_RENDER_ENV_FLOATS; i++)
        env[i] = 0.3f;
    sp_render_scene sc;
    sp_render_scene_defaults(&sc);
    double eye[3] = { 0.05, -0.42, 0.03 }, at[3] = { 0, 0, 0 }, up[3] = { 0, 0, 1 };
    sc.camera.fx = sc.camera.fy = 420.0 * set.width / 224.0;
    sc.camera.cx = sc.camera.cy = 0.5 * set.width - 0.5;
    testmesh_look_at(&sc.camera, eye, at, up);
    sc.mesh = &head;
    sc.albedo = (sp_render_texture){ TEX, TEX, albedo };
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++) {
        sc.ks[k] = 0.05;
        sc.shininess[k] = 32.0;
    }
    sc.env = env;
    double n = sqrt(0.6 * 0.6 + 0.5 * 0.5 + 0.4 * 0.4);
    sc.sun_dir[0] = 0.6 / n, sc.sun_dir[1] = -0.5 / n, sc.sun_dir[2] = 0.4 / n;
    sc.sun_intensity = 3.0;
    static const char *const names[3] = { "point sun", "soft sun, 5 deg", "24 point suns, 5 deg" };
    double t[3][RUNS];
    for (int run = -1; run < RUNS; run++) /* run -1 warms up */
        for (int way = 0; way < 3; way++) {
            double s = render_way(r, &sc, way);
            if (s < 0.0) {
                fprintf(stderr, "bench_relight: %s failed\n", names[way]);
                return 1;
            }
            if (run >= 0)
                t[way][run] = s;
        }
    printf("bench_relight: %dx%d, 2x2 samples, %u triangles, one thread, median of %d\n", set.width, set.height,
           head.n_triangles, RUNS);
    double base = bench_median(t[0], RUNS);
    for (int way = 0; way < 3; way++) {
        double m = way ? bench_median(t[way], RUNS) : base;
        printf("  %-22s %8.3f s CPU  %6.2fx the point sun\n", names[way], m, m / base);
    }
    sp_renderer_close(&r);
    free(albedo);
    sp_mesh_free(&head);
    return 0;
}
