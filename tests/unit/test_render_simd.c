/* SPDX-License-Identifier: MIT */
/*
 * The float SoA shading kernels (shade_simd.c) against the double shading
 * code (shading.c, envlight.c, shadow_sigmoid): forward radiance within
 * 2e-6 + 1e-7 s relative (float n.h raised to the power s), every adjoint group (albedo, normal, view, shadow argument, ks,
 * shininess, sun direction and irradiance, SH coefficients) against central
 * differences of the double forward within 1e-3 relative, the exp2 / log2
 * approximations, and extremes (s = 1e4, |z| = 1e6, n.l = 0, black and
 * 1e3 albedo, 1e5 sun and sky) without NaN or Inf.
 * The surface kernels (surf_simd.c) against shade_geometry and
 * shade_backward_surface on a head mesh: normal, view direction and albedo
 * within 2e-5, clusters identical, every adjoint group (vertex positions,
 * normals, camera pose, albedo texels, eye, intrinsics) within 3e-4
 * of its scale; degenerate hits refused by both; cancelling vertex normals,
 * UVs far outside the texture, grazing triangles and huge adjoints without
 * NaN or Inf. The S = 1 float tone map and loss against tonemap_eval.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "pipeline/render/adjoint.h"
#include "pipeline/render/geometry.h"
#include "pipeline/render/shade_simd.h"
#include "pipeline/render/shading.h"
#include "pipeline/render/simd_kernels.h"
#include "pipeline/render/shadow.h"
#include "pipeline/render/surf_simd.h"
#include "pipeline/render/testmesh.h"
#include "pipeline/render/vec3.h"

typedef struct sample {
    double n[3], v[3], a[3], ks, s, z;
} sample;

typedef struct frame {
    double l[3], I, C[3][ENV_SH_N];
} frame;

static double urand(double lo, double hi)
{
    return lo + (hi - lo) * (double)rand() / (double)RAND_MAX;
}

static void unit_rand(double o[3])
{
    double len;
    do {
        for (int i = 0; i < 3; i++)
            o[i] = urand(-1.0, 1.0);
        len = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
    } while (len < 0.2 || len > 1.0);
    for (int i = 0; i < 3; i++)
        o[i] /= len;
}

/* The double path's radiance of one sample (ambient + V * sun, the renderer's formulas). */
static void ref_rad(const frame *f, const sample *x, double rad[3])
{
    shade_ctx ctx;
    shade_rec rec;
    memset(&ctx, 0, sizeof(ctx));
    memset(&rec, 0, sizeof(rec));
    memcpy(ctx.sh.C, f->C, sizeof(f->C));
    ctx.ks[0] = x->ks;
    ctx.s[0] = x->s;
    memcpy(rec.n, x->n, sizeof(rec.n));
    memcpy(rec.v, x->v, sizeof(rec.v));
    memcpy(rec.a, x->a, sizeof(rec.a));
    rec.cluster = 0;
    shade_ambient(&ctx, &rec);
    shade_sun(&ctx, &rec, f->l, f->I, NULL, NULL);
    double V = shadow_sigmoid(-x->z, NULL);
    for (int c = 0; c < 3; c++)
        rad[c] = rec.amb[c] + V * (rec.diff[c] + rec.spec);
}

static void load(simd_frame *sf, simd_batch *b, const frame *f, const sample *xs, int n)
{
    env_sh sh;
    memset(&sh, 0, sizeof(sh));
    memcpy(sh.C, f->C, sizeof(f->C));
    simd_frame_init(sf, f->l, f->I, &sh);
    b->n = n;
    for (int i = 0; i < n; i++) {
        const sample *x = xs + i;
        b->nx[i] = (float)x->n[0], b->ny[i] = (float)x->n[1], b->nz[i] = (float)x->n[2];
        b->vx[i] = (float)x->v[0], b->vy[i] = (float)x->v[1], b->vz[i] = (float)x->v[2];
        for (int c = 0; c < 3; c++)
            b->a[c][i] = (float)x->a[c];
        b->ks[i] = (float)x->ks, b->s[i] = (float)x->s, b->z[i] = (float)x->z;
    }
    simd_batch_pad(b);
}

static const double W[3] = {0.7, -0.4, 1.1}; /* L = sum_c W[c] rad[c] */

static double loss_of(const frame *f, const sample *x)
{
    double r[3];
    ref_rad(f, x, r);
    return W[0] * r[0] + W[1] * r[1] + W[2] * r[2];
}

/* Central difference of loss_of w.r.t. *p (a field of f or x), step relative to |*p|. */
static double fd(const frame *f, const sample *x, double *p)
{
    double h = 1e-6 * (fabs(*p) > 1.0 ? fabs(*p) : 1.0), keep = *p;
    *p = keep + h;
    double lp = loss_of(f, x);
    *p = keep - h;
    double lm = loss_of(f, x);
    *p = keep;
    return (lp - lm) / (2.0 * h);
}

typedef struct group_err {
    double diff, scale;
} group_err;

static void group_add(group_err *g, double got, double want)
{
    double d = fabs(got - want), s = fabs(want);
    g->diff = d > g->diff ? d : g->diff;
    g->scale = s > g->scale ? s : g->scale;
}

static double group_rel(const group_err *g)
{
    return g->diff / (g->scale > 1e-9 ? g->scale : 1e-9);
}

static void random_frame(frame *f)
{
    unit_rand(f->l);
    f->I = 3.0;
    for (int c = 0; c < 3; c++)
        for (int j = 0; j < ENV_SH_N; j++)
            f->C[c][j] = j == 0 ? urand(1.0, 3.0) : urand(-1.2, 1.2);
}

static void random_sample(const frame *f, sample *x, int i)
{
    unit_rand(x->n);
    unit_rand(x->v);
    for (int c = 0; c < 3; c++)
        x->a[c] = urand(0.05, 1.0);
    x->ks = i % 5 == 0 ? 0.0 : urand(0.05, 1.0);
    x->s = i % 7 == 0 ? urand(1.0, 3.0) : urand(5.0, 300.0);
    x->z = urand(-6.0, 6.0);
    if (i % 3 == 0) /* bias towards lit, near-specular samples so the lobe is exercised */
        for (int k = 0; k < 3; k++)
            x->v[k] = 2.0 * (x->n[0] * f->l[0] + x->n[1] * f->l[1] + x->n[2] * f->l[2]) * x->n[k] - f->l[k] +
                      urand(-0.05, 0.05);
}

static void test_math(void)
{
    double worst_e = 0.0, worst_l = 0.0;
    for (double x = -120.0; x <= 120.0; x += 0.0137) {
        double r = (double)simd_exp2f((float)x) / exp2((double)(float)x) - 1.0;
        worst_e = fabs(r) > worst_e ? fabs(r) : worst_e;
    }
    for (double x = 1e-30; x < 1.0; x *= 1.0137) {
        double want = log2((double)(float)x), got = (double)simd_log2f((float)x);
        double r = fabs(got - want) / (fabs(want) > 1e-3 ? fabs(want) : 1e-3);
        worst_l = r > worst_l ? r : worst_l;
    }
    printf("exp2 worst relative error %.2e, log2 %.2e\n", worst_e, worst_l);
    CHECK(worst_e < 5e-7);
    CHECK(worst_l < 5e-6);
    CHECK(simd_log2f(1.0f) == 0.0f);
    CHECK(isfinite(simd_exp2f(1e30f)) && simd_exp2f(-1e30f) >= 0.0f && simd_exp2f(-1e30f) < 1e-37f);
}

static void test_against_double(void)
{
    static simd_batch b;
    simd_frame sf;
    frame f;
    sample xs[SIMD_BATCH - 3]; /* not a multiple of 4: the padded lanes must not leak */
    int n = SIMD_BATCH - 3;
    srand(7);
    random_frame(&f);
    for (int i = 0; i < n; i++)
        random_sample(&f, xs + i, i);
    load(&sf, &b, &f, xs, n);
    simd_shade_forward(&sf, &b);
    double worst = 0.0;
    for (int i = 0; i < n; i++) {
        double r[3];
        ref_rad(&f, xs + i, r);
        for (int c = 0; c < 3; c++) {
            /* float n.h carries ~6e-8 relative error, which (n.h)^s multiplies by s */
            double tol = 2e-6 + 1e-7 * xs[i].s;
            double e = fabs((double)b.rad[c][i] - r[c]) / (fabs(r[c]) + 1e-6) / tol;
            worst = e > worst ? e : worst;
            b.gc[c][i] = (float)W[c];
        }
    }
    printf("forward worst relative error / (2e-6 + 1e-7 s) = %.2f\n", worst);
    CHECK(worst < 1.0);
    simd_acc acc;
    memset(&acc, 0, sizeof(acc));
    simd_shade_backward(&sf, &b, &acc);
    group_err ga = {0, 0}, gn = {0, 0}, gv = {0, 0}, gz = {0, 0}, gks = {0, 0}, gs = {0, 0}, gl = {0, 0}, gI = {0, 0},
              gY = {0, 0};
    double sum_l[3] = {0, 0, 0}, sum_I = 0.0, sum_C[3][ENV_SH_N];
    memset(sum_C, 0, sizeof(sum_C));
    for (int i = 0; i < n; i++) {
        sample *x = xs + i;
        for (int k = 0; k < 3; k++) {
            group_add(&ga, (double)b.ga[k][i], fd(&f, x, &x->a[k]));
            group_add(&gn, (double)b.gn[k][i], fd(&f, x, &x->n[k]));
            group_add(&gv, (double)b.gv[k][i], fd(&f, x, &x->v[k]));
            sum_l[k] += fd(&f, x, &f.l[k]);
        }
        group_add(&gz, (double)b.gV[i] * (double)b.dVdz[i], fd(&f, x, &x->z));
        if (x->ks != 0.0) /* the double path has no ks gradient at ks = 0 either */
            group_add(&gks, (double)b.gks[i], fd(&f, x, &x->ks));
        group_add(&gs, (double)b.gs[i], fd(&f, x, &x->s));
        sum_I += fd(&f, x, &f.I);
        for (int c = 0; c < 3; c++)
            for (int j = 0; j < ENV_SH_N; j++)
                sum_C[c][j] += fd(&f, x, &f.C[c][j]);
    }
    for (int k = 0; k < 3; k++)
        group_add(&gl, acc.gl[k], sum_l[k]);
    group_add(&gI, acc.gI, sum_I);
    for (int c = 0; c < 3; c++)
        for (int j = 0; j < ENV_SH_N; j++)
            group_add(&gY, acc.gY[c][j], sum_C[c][j]);
    const group_err *all[] = {&ga, &gn, &gv, &gz, &gks, &gs, &gl, &gI, &gY};
    const char *names[] = {"albedo", "normal", "view", "shadow z", "ks", "shininess", "sun dir", "sun I", "SH"};
    for (int k = 0; k < 9; k++) {
        printf("%-10s relative error %.2e (scale %.2e)\n", names[k], group_rel(all[k]), all[k]->scale);
        CHECK_MSG(group_rel(all[k]) < 1e-3, "group %s", names[k]);
        CHECK(all[k]->scale > 0.0); /* every group was exercised */
    }
}

static int batch_finite(const simd_batch *b, const simd_acc *acc)
{
    int bad = 0;
    for (int i = 0; i < b->n; i++) {
        const float *v[] = {&b->rad[0][i], &b->rad[1][i], &b->rad[2][i], &b->ga[0][i], &b->ga[1][i], &b->ga[2][i],
                            &b->gn[0][i], &b->gn[1][i], &b->gn[2][i], &b->gv[0][i], &b->gv[1][i], &b->gv[2][i],
                            &b->gV[i], &b->dVdz[i], &b->gks[i], &b->gs[i]};
        for (size_t k = 0; k < sizeof(v) / sizeof(v[0]); k++)
            bad += !isfinite(*v[k]);
    }
    for (int k = 0; k < 3; k++)
        bad += !isfinite(acc->gl[k]);
    bad += !isfinite(acc->gI);
    for (int c = 0; c < 3; c++)
        for (int j = 0; j < ENV_SH_N; j++)
            bad += !isfinite(acc->gY[c][j]);
    return bad;
}

static void test_extremes(void)
{
    static simd_batch b;
    simd_frame sf;
    frame f;
    sample xs[SIMD_BATCH];
    srand(11);
    random_frame(&f);
    f.I = 1e5;
    for (int c = 0; c < 3; c++)
        f.C[c][0] = 1e5;
    const double s_vals[] = {1.0, 1e4, 1e4, 2.0};
    const double z_vals[] = {1e6, -1e6, 0.0, 80.5};
    const double a_vals[] = {0.0, 1.0, 1e3, 0.5};
    for (int i = 0; i < SIMD_BATCH; i++) {
        random_sample(&f, xs + i, i);
        xs[i].s = s_vals[i % 4];
        xs[i].z = z_vals[(i / 4) % 4];
        xs[i].ks = i % 2 ? 1.0 : 0.0;
        for (int c = 0; c < 3; c++)
            xs[i].a[c] = a_vals[(i / 16) % 4];
        if (i % 8 == 1) { /* n.l exactly 0, and v = -l (no half vector) */
            xs[i].n[0] = f.l[1], xs[i].n[1] = -f.l[0], xs[i].n[2] = 0.0;
            for (int k = 0; k < 3; k++)
                xs[i].v[k] = -f.l[k];
        }
        if (i % 8 == 3) /* the mirror direction: n.h = 1, P = 1 at s = 1e4 */
            for (int k = 0; k < 3; k++)
                xs[i].v[k] = f.l[k];
    }
    for (int i = 0; i < SIMD_BATCH; i += 8) {
        for (int k = 0; k < 3; k++)
            xs[i + 3].n[k] = f.l[k];
    }
    load(&sf, &b, &f, xs, SIMD_BATCH);
    simd_shade_forward(&sf, &b);
    for (int i = 0; i < SIMD_BATCH; i++)
        for (int c = 0; c < 3; c++)
            b.gc[c][i] = 1e3f;
    simd_acc acc;
    memset(&acc, 0, sizeof(acc));
    simd_shade_backward(&sf, &b, &acc);
    int bad = batch_finite(&b, &acc);
    printf("extremes: %d non-finite values\n", bad);
    CHECK(bad == 0);
    for (int i = 0; i < SIMD_BATCH; i++) {
        CHECK(b.V[i] >= 0.0f && b.V[i] <= 1.0f);
        CHECK(b.P[i] >= 0.0f && b.P[i] <= 1.0f);
    }
    CHECK(b.V[0] < 1e-30f && b.V[4] == 1.0f); /* z = 1e6 fully shadowed, -1e6 fully lit */
}

/* A head mesh in the renderer's geometry buffers, seen by a 224 x 224 camera (no shadow map). */
typedef struct surf_scene {
    sp_mesh mesh;
    render_geom geo;
    raster_camera cam;
    sp_render_scene sc;
    shade_ctx ctx;
    float albedo[16 * 12 * 3];
    uint8_t clusters[3 * 3];
} surf_scene;

static void surf_scene_init(surf_scene *z)
{
    memset(z, 0, sizeof(*z));
    double c[3] = {0, 0, 0}, eye[3] = {0.03, -0.45, 0.02}, up[3] = {0, 0, 1};
    CHECK(testmesh_head(&z->mesh, 14, 20, c, 0.08, 0.095, 0.11, 0.25) == 0);
    CHECK(geom_reserve(&z->geo, z->mesh.n_vertices, z->mesh.n_triangles) == 0);
    sp_render_scene *sc = &z->sc;
    sp_render_scene_defaults(sc);
    testmesh_look_at(&sc->camera, eye, c, up);
    for (int i = 0; i < 16 * 12 * 3; i++)
        z->albedo[i] = (float)urand(0.1, 0.9);
    for (int i = 0; i < 9; i++)
        z->clusters[i] = (uint8_t)(i == 4 ? 255 : i % 3);
    sc->mesh = &z->mesh;
    sc->albedo = (sp_render_texture){16, 12, z->albedo};
    sc->clusters = (sp_render_cluster_map){3, 3, z->clusters};
    geom_forward(&z->geo, &z->mesh, &sc->displacement, sc->camera.R, sc->camera.t);
    for (uint32_t t = 0; t < z->mesh.n_triangles; t++) { /* B x C, C x A, A x B as the rasteriser caches them */
        const double *X[3];
        for (int v = 0; v < 3; v++)
            X[v] = z->geo.xc + (size_t)z->mesh.tri_vertices[t * 3 + (uint32_t)v] * 3;
        for (int v = 0; v < 3; v++)
            v3_cross(X[(v + 1) % 3], X[(v + 2) % 3], z->geo.tri_k + (size_t)t * 9 + (size_t)v * 3);
    }
    raster_camera *cam = &z->cam;
    cam->fx = cam->fy = 200.0, cam->cx = cam->cy = 111.5;
    cam->inv_fx = cam->inv_fy = 1.0 / 200.0, cam->inv_s = 1.0, cam->supersample = 1;
    cam->sample_width = cam->sample_height = 224;
    shade_ctx *x = &z->ctx;
    x->sc = sc, x->geo = &z->geo, x->cam = cam;
    m3_tmul(sc->camera.R, sc->camera.t, x->eye);
    v3_scale(x->eye, -1.0, x->eye);
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++)
        x->ks[k] = 0.3, x->s[k] = 20.0;
}

static void surf_scene_free(surf_scene *z)
{
    geom_free(&z->geo);
    sp_mesh_free(&z->mesh);
}

static void surf_frame_of(const surf_scene *z, surf_frame *f)
{
    memset(f, 0, sizeof(*f));
    f->tex_w = 16, f->tex_h = 12, f->inv_fx = z->cam.inv_fx, f->inv_fy = z->cam.inv_fy;
    for (int k = 0; k < 9; k++)
        f->R[k] = (float)z->sc.camera.R[k];
    for (int k = 0; k < 3; k++)
        f->eye[k] = (float)z->ctx.eye[k];
}

/* A pixel whose ray passes near a random interior point of triangle t. */
static void pixel_on(const surf_scene *z, uint32_t t, int *sx, int *sy)
{
    double l0 = urand(0.05, 0.9), l1 = urand(0.05, 0.95 - l0), lam[3] = {l0, l1, 1.0 - l0 - l1}, x[3] = {0, 0, 0};
    for (int v = 0; v < 3; v++)
        v3_axpy(lam[v], z->geo.xc + (size_t)z->mesh.tri_vertices[t * 3 + (uint32_t)v] * 3, x);
    *sx = (int)floor(z->cam.fx * x[0] / x[2] + z->cam.cx + 0.5);
    *sy = (int)floor(z->cam.fy * x[1] / x[2] + z->cam.cy + 0.5);
}

static void surf_kernels(const surf_scene *z, const surf_frame *f, simd_batch *b, const float *albedo)
{
    const float l[3] = {0.0f, 0.0f, 1.0f};
    simd_batch_pad(b);
    surf_batch_pad(&b->surf, b->n);
    surf_forward_a(f, b);
    surf_shadow(&z->ctx, l, b, NULL); /* no shadow map: z = -1e30 (lit), dz = 0 */
    for (int i = 0; i < b->n; i++)
        CHECK(b->z[i] == -1e30f && b->surf.dz[0][i] == 0.0f);
    surf_gather_texels(b, albedo);
    surf_forward_b(b);
}

typedef struct surf_grads {
    double *pd, *nd, *xc, alb[16 * 12 * 3];
    shade_acc acc;
} surf_grads;

static void surf_grads_init(surf_grads *g, const surf_scene *z)
{
    memset(g, 0, sizeof(*g));
    size_t n = (size_t)z->mesh.n_vertices * 3;
    g->pd = calloc(n, sizeof(double)), g->nd = calloc(n, sizeof(double)), g->xc = calloc(n, sizeof(double));
    CHECK(g->pd && g->nd && g->xc);
    g->acc.g_pd = g->pd, g->acc.g_nd = g->nd, g->acc.g_xc = g->xc, g->acc.g_albedo = g->alb;
}

static void surf_grads_free(surf_grads *g)
{
    free(g->pd), free(g->nd), free(g->xc);
}

static void group_arrays(group_err *g, const double *got, const double *want, size_t n)
{
    for (size_t i = 0; i < n; i++)
        group_add(g, got[i], want[i]);
}

static void test_surface(void)
{
    static surf_scene z;
    static simd_batch b;
    static shade_rec rec[SIMD_BATCH];
    srand(23);
    surf_scene_init(&z);
    surf_frame sf;
    surf_frame_of(&z, &sf);
    surf_grads gf, gd;
    surf_grads_init(&gf, &z);
    surf_grads_init(&gd, &z);
    surf_acc sacc;
    memset(&sacc, 0, sizeof(sacc));
    double worst_n = 0.0, worst_v = 0.0, worst_a = 0.0;
    int clusters_differ = 0, total = 0;
    for (int round = 0; round < 8; round++) {
        int n = 0;
        while (n < SIMD_BATCH - round % 4) { /* also batches that are not a multiple of the lane count */
            uint32_t t = (uint32_t)rand() % z.mesh.n_triangles;
            int sx, sy;
            pixel_on(&z, t, &sx, &sy);
            int ok_f = surf_gather(&z.ctx, sx, sy, (int32_t)t, &b, n);
            int ok_d = shade_geometry(&z.ctx, sx, sy, (int32_t)t, rec + n);
            CHECK(ok_f == ok_d);
            n += ok_f;
        }
        b.n = n;
        surf_kernels(&z, &sf, &b, z.albedo);
        for (int i = 0; i < n; i++) {
            const float fn[3] = {b.nx[i], b.ny[i], b.nz[i]}, fv[3] = {b.vx[i], b.vy[i], b.vz[i]};
            for (int k = 0; k < 3; k++) {
                worst_n = fmax(worst_n, fabs((double)fn[k] - rec[i].n[k]));
                worst_v = fmax(worst_v, fabs((double)fv[k] - rec[i].v[k]));
                worst_a = fmax(worst_a, fabs((double)b.a[k][i] - rec[i].a[k]));
            }
            clusters_differ += b.surf.cluster[i] != rec[i].cluster;
            /* random local adjoints; the shading kernel's outputs are the surface kernel's inputs */
            sample_grad sg;
            memset(&sg, 0, sizeof(sg));
            for (int k = 0; k < 3; k++) {
                b.ga[k][i] = (float)urand(-1.0, 1.0), b.gn[k][i] = (float)urand(-1.0, 1.0);
                b.gv[k][i] = (float)urand(-1.0, 1.0), b.gc[k][i] = 1.0f;
                sg.a[k] = (double)b.ga[k][i], sg.n[k] = (double)b.gn[k][i], sg.v[k] = (double)b.gv[k][i];
            }
            b.gV[i] = b.dVdz[i] = b.gks[i] = b.gs[i] = 0.0f;
            shade_backward_surface(&z.ctx, rec + i, &sg, &gd.acc);
        }
        surf_backward(&sf, &b, &sacc);
        surf_scatter(&z.ctx, &b, &gf.acc);
        total += n;
    }
    printf("surface forward over %d samples: normal %.2e, view %.2e, albedo %.2e; %d clusters differ\n", total,
           worst_n, worst_v, worst_a, clusters_differ);
    CHECK(worst_n < 2e-5 && worst_v < 2e-5 && worst_a < 2e-5 && clusters_differ == 0);
    size_t n3 = (size_t)z.mesh.n_vertices * 3;
    /* the kernels fold the camera-space vertex adjoint into world positions and pose sums (x = R p + t) */
    double pose_d[12] = {0};
    for (uint32_t v = 0; v < z.mesh.n_vertices; v++) {
        const double *gx = gd.xc + (size_t)v * 3, *pd = z.geo.pd + (size_t)v * 3;
        double tmp[3];
        m3_tmul(z.sc.camera.R, gx, tmp);
        v3_axpy(1.0, tmp, gd.pd + (size_t)v * 3);
        for (int i = 0; i < 3; i++) {
            pose_d[9 + i] += gx[i];
            for (int k = 0; k < 3; k++)
                pose_d[i * 3 + k] += gx[i] * pd[k];
        }
    }
    double pose_f[12];
    memcpy(pose_f, sacc.g_R, sizeof(sacc.g_R));
    memcpy(pose_f + 9, sacc.g_t, sizeof(sacc.g_t));
    for (size_t i = 0; i < n3; i++)
        CHECK(gf.xc[i] == 0.0);
    group_err e_pd = {0, 0}, e_nd = {0, 0}, e_xc = {0, 0}, e_alb = {0, 0}, e_eye = {0, 0}, e_cam = {0, 0};
    group_arrays(&e_pd, gf.pd, gd.pd, n3);
    group_arrays(&e_nd, gf.nd, gd.nd, n3);
    group_arrays(&e_xc, pose_f, pose_d, 12);
    group_arrays(&e_alb, gf.alb, gd.alb, 16 * 12 * 3);
    group_arrays(&e_eye, sacc.g_eye, gd.acc.g_eye, 3);
    const double cam_f[4] = {sacc.g_fx, sacc.g_fy, sacc.g_cx, sacc.g_cy};
    const double cam_d[4] = {gd.acc.g_fx, gd.acc.g_fy, gd.acc.g_cx, gd.acc.g_cy};
    group_arrays(&e_cam, cam_f, cam_d, 4);
    const group_err *all[] = {&e_pd, &e_nd, &e_xc, &e_alb, &e_eye, &e_cam};
    const char *names[] = {"positions", "normals", "pose R, t", "albedo", "eye", "intrinsics"};
    for (int k = 0; k < 6; k++) {
        printf("surface %-10s relative error %.2e (scale %.2e)\n", names[k], group_rel(all[k]), all[k]->scale);
        CHECK_MSG(group_rel(all[k]) < 3e-4, "surface group %s", names[k]);
        CHECK(all[k]->scale > 0.0);
    }
    surf_grads_free(&gf);
    surf_grads_free(&gd);
    surf_scene_free(&z);
}

static int surf_finite(const simd_batch *b, const surf_acc *acc)
{
    int bad = 0;
    const surf_batch *s = &b->surf;
    for (int i = 0; i < b->n; i++) {
        const float v[] = {b->nx[i], b->ny[i], b->nz[i], b->vx[i], b->vy[i], b->vz[i], b->a[0][i], b->a[1][i],
                           b->a[2][i]};
        for (size_t k = 0; k < sizeof(v) / sizeof(v[0]); k++)
            bad += !isfinite(v[k]);
        for (int a = 0; a < 3; a++)
            for (int d = 0; d < 3; d++)
                bad += !isfinite(s->gpv[a][d][i]) + !isfinite(s->gmv[a][d][i]);
        for (int k = 0; k < 4; k++)
            for (int c = 0; c < 3; c++)
                bad += !isfinite(s->gal[k][c][i]);
    }
    for (int k = 0; k < 9; k++)
        bad += !isfinite(acc->g_R[k]);
    bad += !isfinite(acc->g_t[0]) + !isfinite(acc->g_t[1]) + !isfinite(acc->g_t[2]);
    bad += !isfinite(acc->g_eye[0]) + !isfinite(acc->g_eye[1]) + !isfinite(acc->g_eye[2]);
    bad += !isfinite(acc->g_fx) + !isfinite(acc->g_fy) + !isfinite(acc->g_cx) + !isfinite(acc->g_cy);
    return bad;
}

/* Bits of a float (so that NaN equals NaN and -0 differs from 0). */
static uint32_t fbits(float x)
{
    uint32_t u;
    memcpy(&u, &x, sizeof(u));
    return u;
}

/*
 * surf_shadow against shadow_eval_z, bit for bit: z, dz/dp and the texel of
 * points on and around a head's shadow map (inside, on the border texels,
 * outside, NaN), lit and unlit lanes, batches of every length up to 64.
 */
static void test_shadow_lookup(void)
{
    surf_scene z;
    surf_scene_init(&z);
    shadow_map sm;
    CHECK(shadow_map_init(&sm, 64) == 0 && shadow_map_reserve(&sm, z.mesh.n_vertices) == 0);
    double l[3] = {0.6, -0.5, 0.6}, c[3], r;
    v3_normalize(l, l);
    shadow_bounds(z.geo.pd, z.mesh.n_vertices, c, &r);
    r *= 0.6; /* a map smaller than the head: its border texels hold depths too */
    shadow_frame_init(&sm.f, l, c, r, 0.0, sm.n);
    shadow_map_render(&sm, z.geo.pd, &z.mesh);
    z.ctx.sm = &sm, z.ctx.shadow_k = 800.0, z.ctx.shadow_b = 1.0015;
    const float lf[3] = {(float)l[0], (float)l[1], (float)l[2]};
    int32_t texels[SIMD_BATCH];
    int mismatches = 0, inside = 0, lanes = 0;
    static simd_batch b;
    for (int round = 0; round < 200; round++) {
        memset(&b, 0, sizeof(b));
        b.n = 1 + round % SIMD_BATCH;
        for (int i = 0; i < b.n; i++) {
            double p[3], s = round % 4 == 0 ? 1.3 : 1.0; /* some rounds reach past the map's edge */
            for (int a = 0; a < 3; a++)
                p[a] = c[a] + s * urand(-r, r);
            if (i % 17 == 5)
                p[i % 3] = NAN;
            for (int a = 0; a < 3; a++)
                b.surf.pw[a][i] = p[a];
            double nrm[3];
            unit_rand(nrm);
            b.nx[i] = (float)nrm[0], b.ny[i] = (float)nrm[1], b.nz[i] = (float)nrm[2];
            b.surf.samp[i] = i;
        }
        surf_shadow(&z.ctx, lf, &b, texels);
        for (int i = 0; i < b.n; i++) {
            float nl = b.nx[i] * lf[0] + b.ny[i] * lf[1] + b.nz[i] * lf[2];
            double p[3] = {b.surf.pw[0][i], b.surf.pw[1][i], b.surf.pw[2][i]}, zz = -1e30, g[3] = {0, 0, 0};
            int32_t t = -1;
            if (nl > 0.0f)
                shadow_eval_z(&sm, 800.0, 1.0015, p, &zz, g, &t);
            zz = zz < -1e30 ? -1e30 : (zz > 1e30 ? 1e30 : zz);
            int same = fbits(b.z[i]) == fbits((float)zz) && texels[i] == t;
            for (int a = 0; a < 3; a++)
                same &= fbits(b.surf.dz[a][i]) == fbits((float)g[a]);
            mismatches += !same;
            inside += t >= 0;
            lanes++;
        }
    }
    printf("shadow lookup: %d lanes, %d inside the map, %d differ from shadow_eval_z\n", lanes, inside, mismatches);
    CHECK(mismatches == 0 && inside > lanes / 4 && inside < lanes);
    shadow_map_free(&sm);
    surf_scene_free(&z);
}

static void test_surface_extremes(void)
{
    static surf_scene z;
    static simd_batch b;
    srand(29);
    surf_scene_init(&z);
    surf_frame sf;
    surf_frame_of(&z, &sf);
    /* a degenerate triangle (all edge functions 0): no hit in either path */
    shade_rec rec;
    double keep[9];
    memcpy(keep, z.geo.tri_k, sizeof(keep));
    memset(z.geo.tri_k, 0, sizeof(keep));
    CHECK(surf_gather(&z.ctx, 100, 100, 0, &b, 0) == 0 && shade_geometry(&z.ctx, 100, 100, 0, &rec) == 0);
    memcpy(z.geo.tri_k, keep, sizeof(keep));
    /* cancelling vertex normals, UVs far outside the texture, any triangle (grazing ones included) */
    z.geo.nd[0] = -z.geo.nd[3], z.geo.nd[1] = -z.geo.nd[4], z.geo.nd[2] = -z.geo.nd[5];
    for (int k = 0; k < 3; k++) /* surf_gather reads geom_forward's float copy */
        z.geo.ndf[k] = (float)z.geo.nd[k];
    for (uint32_t i = 0; i < z.mesh.n_uvs * 2; i += 7)
        z.mesh.uvs[i] = i % 2 ? 1e6f : -1e6f;
    int n = 0;
    for (uint32_t t = 0; n < SIMD_BATCH && t < z.mesh.n_triangles; t += 3) {
        int sx, sy;
        pixel_on(&z, t, &sx, &sy);
        n += surf_gather(&z.ctx, sx, sy, (int32_t)t, &b, n);
    }
    b.n = n;
    surf_kernels(&z, &sf, &b, z.albedo);
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            b.ga[k][i] = 1e6f, b.gn[k][i] = -1e6f, b.gv[k][i] = 1e6f, b.gc[k][i] = 1.0f;
            b.gV[i] = 1e6f, b.dVdz[i] = -0.25f;
        }
    surf_acc acc;
    memset(&acc, 0, sizeof(acc));
    surf_backward(&sf, &b, &acc);
    int bad = surf_finite(&b, &acc);
    printf("surface extremes: %d samples, %d non-finite values\n", n, bad);
    CHECK(n == SIMD_BATCH && bad == 0);
    surf_scene_free(&z);
}

int main(void)
{
#ifdef SP_SIMD_VARIANT /* built again against another kernel set (tests/unit/meson.build) */
    const simd_kernels *k = simd_kernels_by_name(SIMD_STR(SP_SIMD_VARIANT));
    if (!k)
        SKIP("this CPU cannot run the %s kernels", SIMD_STR(SP_SIMD_VARIANT));
    printf("kernel set %s, %d lanes\n", k->name, k->lanes);
    CHECK(k->shade_forward == simd_shade_forward && k->surf_backward == surf_backward && k->lanes > 4);
#endif
    test_math();
    test_against_double();
    test_extremes();
    test_surface();
    test_surface_extremes();
    test_shadow_lookup();
    return check_exit();
}
