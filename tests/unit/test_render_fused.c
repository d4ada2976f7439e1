/* SPDX-License-Identifier: MIT */
/*
 * The fused fitting call sp_render_fit_l2 against the classic
 * sp_render + sp_render_l2_loss + sp_render_backward: identical loss, image
 * and per-sample buffers, gradients equal to rounding in every group; central
 * finite differences of the fused loss for the shading parameters; loss-only
 * mode; sp_render_backward after a fused call; skip_outputs; argument errors.
 * Head with a blocker's cast shadow, 40 x 40, S = 1 and S = 2. The same with
 * settings.fit_float (float SoA shading kernels): loss within 1e-5 relative,
 * image within 1e-5, radiance within 1e-4 relative, gradients within 1e-3 of
 * each group's scale, identical coverage and per-sample buffers, and the same
 * finite-difference bound (1e-3) for its own loss.
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "pipeline/render/render_internal.h"
#include "pipeline/render/testmesh.h"
#include "sunprobe/sp_render.h"

#define W 40
#define H 40
#define AW 12
#define AH 10
#define DW 7
#define DH 6

typedef struct fixture {
    sp_renderer *r;
    sp_mesh mesh;
    sp_render_scene sc;
    float albedo[AW * AH * 3], disp[DW * DH], env[SP_RENDER_ENV_FLOATS], target[W * H * 3], mask[W * H];
    uint8_t clusters[9];
    int fit_float;         /* settings.fit_float of r */
} fixture;

/* One set of gradient arrays plus the scalars, as sp_render_grads points into it. */
typedef struct grad_set {
    double albedo[AW * AH * 3], disp[DW * DH], env[SP_RENDER_ENV_FLOATS];
    double *pos;
    sp_render_grads g;
} grad_set;

static uint64_t rng_state = 0x243F6A8885A308D3ull;

static double rnd(void)
{
    rng_state = rng_state * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng_state >> 11) * (1.0 / 9007199254740992.0);
}

static void grad_set_init(grad_set *gs, const fixture *f)
{
    memset(gs, 0, sizeof(*gs));
    gs->pos = calloc((size_t)f->mesh.n_vertices * 3, sizeof(double));
    if (!gs->pos) {
        fprintf(stderr, "out of memory\n");
        exit(99);
    }
    gs->g = (sp_render_grads){.albedo = gs->albedo, .displacement = gs->disp, .env = gs->env, .positions = gs->pos};
}

static void fixture_init(fixture *f, int S, int fit_float)
{
    memset(f, 0, sizeof(*f));
    f->fit_float = fit_float;
    sp_renderer_settings set;
    sp_renderer_default_settings(&set);
    set.fit_float = fit_float;
    set.width = W;
    set.height = H;
    set.supersample = S;
    if (sp_renderer_open(&f->r, &set) != 0) {
        fprintf(stderr, "renderer open failed\n");
        exit(99);
    }
    double c[3] = {0, 0, 0};
    CHECK(testmesh_head(&f->mesh, 14, 20, c, 0.08, 0.095, 0.11, 0.25) == 0);
    sp_mesh blocker;
    double p0[3] = {0.02, -0.16, 0.10}, eu[3] = {0.09, 0.0, 0.0}, ev[3] = {0.0, 0.06, 0.03};
    CHECK(testmesh_grid(&blocker, p0, eu, ev, 2, 2) == 0);
    CHECK(testmesh_append(&f->mesh, &blocker) == 0);
    sp_mesh_free(&blocker);
    for (int i = 0; i < AW * AH * 3; i++)
        f->albedo[i] = (float)(0.2 + 0.6 * rnd());
    for (int i = 0; i < DW * DH; i++)
        f->disp[i] = (float)(0.004 * (rnd() - 0.5));
    for (int i = 0; i < 9; i++)
        f->clusters[i] = (uint8_t)(i == 4 ? 255 : i); /* one "no specular" cell */
    for (int i = 0; i < SP_RENDER_ENV_FLOATS; i++)
        f->env[i] = (float)(0.1 + 0.5 * rnd() + (i < SP_RENDER_ENV_FLOATS / 2 ? 0.4 : 0.0));
    for (int i = 0; i < W * H * 3; i++)
        f->target[i] = (float)(0.2 + 0.6 * rnd());
    for (int i = 0; i < W * H; i++)
        f->mask[i] = (float)(0.5 + 0.5 * rnd());
    sp_render_scene *sc = &f->sc;
    sp_render_scene_defaults(sc);
    double eye[3] = {0.03, -0.45, 0.02}, at[3] = {0, 0, 0}, up[3] = {0, 0, 1};
    sc->camera.fx = sc->camera.fy = 70.0;
    sc->camera.cx = 0.5 * W - 0.5 + 0.37;
    sc->camera.cy = 0.5 * H - 0.5 - 0.21;
    testmesh_look_at(&sc->camera, eye, at, up);
    sc->mesh = &f->mesh;
    sc->albedo = (sp_render_texture){AW, AH, f->albedo};
    sc->displacement = (sp_render_texture){DW, DH, f->disp};
    sc->clusters = (sp_render_cluster_map){3, 3, f->clusters};
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++) {
        sc->ks[k] = 0.1 + 0.4 * rnd();
        sc->shininess[k] = 4.0 + 40.0 * rnd();
    }
    sc->env = f->env;
    sc->sun_dir[0] = 0.45, sc->sun_dir[1] = -0.7, sc->sun_dir[2] = 0.6;
    sc->sun_intensity = 2.5;
    sc->exposure = 0.8;
    sc->shadow_k = 60.0;
    sc->background[0] = 0.05, sc->background[1] = 0.1, sc->background[2] = 0.2;
}

/* max |a - b| <= tol * max |b| over n values (a group's scale, so near-zero entries do not dominate). */
static int close_group(const double *a, const double *b, size_t n, double tol, const char *name)
{
    double dmax = 0.0, bmax = 0.0;
    for (size_t i = 0; i < n; i++) {
        double d = fabs(a[i] - b[i]);
        dmax = d > dmax ? d : dmax;
        bmax = fabs(b[i]) > bmax ? fabs(b[i]) : bmax;
    }
    int ok = dmax <= tol * bmax && isfinite(dmax);
    if (!ok)
        fprintf(stderr, "group %s: max diff %.3g vs scale %.3g\n", name, dmax, bmax);
    return ok;
}

static int grads_close(const grad_set *a, const grad_set *b, size_t nv, double tol)
{
    int ok = close_group(a->albedo, b->albedo, AW * AH * 3, tol, "albedo");
    ok &= close_group(a->disp, b->disp, DW * DH, tol, "displacement");
    ok &= close_group(a->env, b->env, SP_RENDER_ENV_FLOATS, tol, "env");
    ok &= close_group(a->pos, b->pos, nv * 3, tol, "positions");
    ok &= close_group(a->g.ks, b->g.ks, SP_RENDER_CLUSTERS, tol, "ks");
    ok &= close_group(a->g.shininess, b->g.shininess, SP_RENDER_CLUSTERS, tol, "shininess");
    ok &= close_group(a->g.sun_dir, b->g.sun_dir, 3, tol, "sun_dir");
    ok &= close_group(&a->g.sun_intensity, &b->g.sun_intensity, 1, tol, "sun_intensity");
    ok &= close_group(&a->g.exposure, &b->g.exposure, 1, tol, "exposure");
    ok &= close_group(a->g.camera_R, b->g.camera_R, 9, tol, "camera_R");
    ok &= close_group(a->g.camera_t, b->g.camera_t, 3, tol, "camera_t");
    ok &= close_group(&a->g.fx, &b->g.fx, 4, tol, "intrinsics");
    return ok;
}

static double max_abs_diff(const float *a, const float *b, size_t n)
{
    double m = 0.0;
    for (size_t i = 0; i < n; i++) {
        double d = fabs((double)a[i] - (double)b[i]);
        m = d > m || d != d ? d : m;
    }
    return m;
}

static double max_rel_diff(const float *a, const float *b, size_t n)
{
    double m = 0.0;
    for (size_t i = 0; i < n; i++) {
        double d = fabs((double)a[i] - (double)b[i]) / (fabs((double)a[i]) + 1e-6);
        m = d > m || d != d ? d : m;
    }
    return m;
}

/* Classic path vs fused path on the same scene. */
static void check_equivalence(fixture *f)
{
    size_t np = (size_t)W * H, nv = f->mesh.n_vertices;
    grad_set gc, gf, gb;
    grad_set_init(&gc, f);
    grad_set_init(&gf, f);
    grad_set_init(&gb, f);
    static float dl[W * H * 3], img_c[W * H * 3], rad_c[W * H * 3], cov_c[W * H];
    sp_render_outputs o, of;
    double loss_c = -1.0, loss_f = -2.0, loss_only = -3.0;
    CHECK_EQ_INT(sp_render(f->r, &f->sc, &o), 0);
    CHECK_EQ_INT(sp_render_l2_loss(o.image, f->target, f->mask, W, H, &loss_c, dl), 0);
    CHECK_EQ_INT(sp_render_backward(f->r, &f->sc, dl, &gc.g), 0);
    memcpy(img_c, o.image, sizeof(img_c));
    memcpy(rad_c, o.radiance, sizeof(rad_c));
    memcpy(cov_c, o.coverage, sizeof(cov_c));
    size_t ns = (size_t)o.sample_width * (size_t)o.sample_height;
    int32_t *tri_c = malloc(ns * sizeof(int32_t)), *tex_c = malloc(ns * sizeof(int32_t));
    CHECK(tri_c && tex_c);
    memcpy(tri_c, o.tri_id, ns * sizeof(int32_t));
    memcpy(tex_c, o.shadow_texel, ns * sizeof(int32_t));

    CHECK_EQ_INT(sp_render_fit_l2(f->r, &f->sc, f->target, f->mask, &loss_f, &gf.g, &of), 0);
    if (f->fit_float) {
        /* float shading: documented tolerances (RENDERER.md), measured ~1e-6 / ~1e-5 */
        double di = max_abs_diff(img_c, of.image, np * 3), dr = max_rel_diff(rad_c, of.radiance, np * 3);
        printf("fit_float: loss rel diff %.2e, image max abs diff %.2e, radiance max rel diff %.2e\n",
               fabs(loss_f - loss_c) / loss_c, di, dr);
        CHECK(loss_c > 0.0 && fabs(loss_f - loss_c) <= 1e-5 * loss_c);
        CHECK(di <= 1e-5 && dr <= 1e-4);
    } else {
        CHECK(loss_f == loss_c && loss_c > 0.0);
        CHECK(memcmp(img_c, of.image, sizeof(img_c)) == 0);
        CHECK(memcmp(rad_c, of.radiance, sizeof(rad_c)) == 0);
    }
    CHECK(memcmp(cov_c, of.coverage, sizeof(cov_c)) == 0);
    CHECK(memcmp(tri_c, of.tri_id, ns * sizeof(int32_t)) == 0);
    if (f->fit_float) {
        /* fit_float skips the shadow lookup (texel -1) where n.l <= 0: V multiplies nothing there */
        size_t same = 0, skipped = 0;
        for (size_t s = 0; s < ns; s++) {
            same += of.shadow_texel[s] == tex_c[s] && tex_c[s] >= 0;
            skipped += of.shadow_texel[s] == -1 && tex_c[s] >= 0;
            CHECK(of.shadow_texel[s] == tex_c[s] || of.shadow_texel[s] == -1);
        }
        printf("fit_float: %zu shadow texels as classic, %zu skipped (facing away from the sun)\n", same, skipped);
        CHECK(same > skipped / 4 && same > 0);
    } else {
        CHECK(memcmp(tex_c, of.shadow_texel, ns * sizeof(int32_t)) == 0);
    }
    CHECK(!of.diffuse && !of.specular && !of.ambient && !of.fill && !of.visibility && !of.normal && !of.albedo);
    CHECK(f->fit_float ? of.bary == NULL : of.bary != NULL); /* fit_float computes no barycentrics */
    CHECK_MSG(grads_close(&gf, &gc, nv, f->fit_float ? 1e-3 : 1e-5), "fused gradients differ from the classic ones");
    /*
     * the classic backward after a fused call reads the same state as after
     * sp_render: identical (fit_float: the sun cache and radiance come from
     * the float kernels, so within the float tolerance)
     */
    if (f->fit_float) {
        /* fit_float keeps no double twins or sun cache: refused until the next sp_render (RENDERER.md) */
        CHECK_EQ_INT(sp_render_backward(f->r, &f->sc, dl, &gb.g), -EINVAL);
        /* sp_render on this renderer still computes barycentrics (they sum to 1 on covered samples) */
        float *bary_c = malloc(ns * 3 * sizeof(float));
        CHECK(bary_c != NULL);
        memcpy(bary_c, o.bary, ns * 3 * sizeof(float));
        size_t bad_sum = 0;
        for (size_t s = 0; s < ns; s++)
            bad_sum += tri_c[s] >= 0 && fabs((double)bary_c[s * 3] + (double)bary_c[s * 3 + 1] + (double)bary_c[s * 3 + 2] - 1.0) > 1e-5;
        CHECK(bad_sum == 0);
        sp_render_outputs o2;
        CHECK_EQ_INT(sp_render(f->r, &f->sc, &o2), 0);
        CHECK(o2.bary && memcmp(bary_c, o2.bary, ns * 3 * sizeof(float)) == 0);
        free(bary_c);
    } else {
        CHECK_EQ_INT(sp_render_backward(f->r, &f->sc, dl, &gb.g), 0);
        CHECK_MSG(grads_close(&gb, &gc, nv, 1e-12), "backward after the fused call differs");
    }
    /* loss only */
    CHECK_EQ_INT(sp_render_fit_l2(f->r, &f->sc, f->target, NULL, &loss_only, NULL, NULL), 0);
    double loss_nomask = -4.0;
    CHECK_EQ_INT(sp_render_l2_loss(img_c, f->target, NULL, W, H, &loss_nomask, NULL), 0);
    if (f->fit_float)
        CHECK(fabs(loss_only - loss_nomask) <= 1e-5 * loss_nomask);
    else
        CHECK(loss_only == loss_nomask);
    (void)np;
    free(tri_c);
    free(tex_c);
    free(gc.pos);
    free(gf.pos);
    free(gb.pos);
}

/*
 * The fused call's loss, recomputed from its double display image: the
 * analytic gradient is exact for it up to the float rounding of dL (~1e-7),
 * while the float image's rounding would swamp small FD steps.
 */
static double fused_loss(fixture *f)
{
    double L = 0.0, sum = 0.0, msum = 0.0;
    CHECK_EQ_INT(sp_render_fit_l2(f->r, &f->sc, f->target, f->mask, &L, NULL, NULL), 0);
    if (f->fit_float) {
        /*
         * fit_float tone-maps in float and keeps no double image; its loss
         * carries ~1e-7 relative rounding that does not vary smoothly, which
         * central differences of small texel steps amplify to ~2e-3. So the
         * float gradient is checked against differences of the double
         * model's loss (sp_render's double image, below), and the fused loss
         * against that loss (the 1e-6 check below).
         */
        sp_render_outputs o;
        CHECK_EQ_INT(sp_render(f->r, &f->sc, &o), 0);
    }
    const double *img = render_image_f64(f->r);
    for (size_t p = 0; p < (size_t)W * H; p++) {
        msum += (double)f->mask[p];
        for (int c = 0; c < 3; c++) {
            double d = img[p * 3 + (size_t)c] - (double)f->target[p * 3 + (size_t)c];
            sum += (double)f->mask[p] * d * d;
        }
    }
    CHECK(fabs(sum / msum - L) < 1e-6 * L); /* the reported loss is this one with a float image */
    return sum / msum;
}

/* Central difference of the fused loss for *x (best of a few steps) against the analytic g. */
static double fd_error(fixture *f, double *x, double g, double scale)
{
    const double steps[] = {1e-2, 3e-3, 1e-3, 3e-4};
    double best = INFINITY, x0 = *x;
    for (size_t i = 0; i < sizeof(steps) / sizeof(steps[0]); i++) {
        double h = steps[i] * scale;
        *x = x0 + h;
        double lp = fused_loss(f);
        *x = x0 - h;
        double lm = fused_loss(f);
        *x = x0;
        double fd = (lp - lm) / (2.0 * h);
        double err = fabs(fd - g) / fmax(fabs(g), 1e-6);
        best = err < best ? err : best;
    }
    return best;
}

/*
 * The same for a float texel (the stored perturbation is what counts); one
 * texel moves the loss little, so steps are large against the float image's
 * rounding (the loss is smooth in texels away from the clamps).
 */
static double fd_error_f(fixture *f, float *x, double g)
{
    const double steps[] = {0.1, 3e-2, 1e-2, 3e-3};
    double best = INFINITY;
    float x0 = *x;
    for (size_t i = 0; i < sizeof(steps) / sizeof(steps[0]); i++) {
        float xp = (float)((double)x0 + steps[i]), xm = (float)((double)x0 - steps[i]);
        *x = xp;
        double lp = fused_loss(f);
        *x = xm;
        double lm = fused_loss(f);
        *x = x0;
        double fd = (lp - lm) / ((double)xp - (double)xm);
        double err = fabs(fd - g) / fmax(fabs(g), 1e-6);
        best = err < best ? err : best;
    }
    return best;
}

static void check_fd(fixture *f)
{
    grad_set gs;
    grad_set_init(&gs, f);
    double L = 0.0;
    CHECK_EQ_INT(sp_render_fit_l2(f->r, &f->sc, f->target, f->mask, &L, &gs.g, NULL), 0);
    sp_render_scene *sc = &f->sc;
    double worst = 0.0, e;
    int checked = 0;
#define TRACK(expr)                                                                            \
    do {                                                                                       \
        e = (expr);                                                                            \
        if (e > 1e-4)                                                                          \
            printf("  %s: rel err %.2e\n", #expr, e);                                         \
        worst = e > worst ? e : worst;                                                         \
        checked++;                                                                             \
    } while (0)
    TRACK(fd_error(f, &sc->exposure, gs.g.exposure, sc->exposure));
    TRACK(fd_error(f, &sc->sun_intensity, gs.g.sun_intensity, sc->sun_intensity));
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++)
        if (fabs(gs.g.ks[k]) > 1e-4) {
            TRACK(fd_error(f, &sc->ks[k], gs.g.ks[k], 1.0));
            TRACK(fd_error(f, &sc->shininess[k], gs.g.shininess[k], sc->shininess[k]));
        }
    for (int i = 0; i < SP_RENDER_ENV_FLOATS; i += 97)
        TRACK(fd_error_f(f, &f->env[i], gs.env[i]));
    for (int i = 0; i < AW * AH * 3; i += 23)
        if (fabs(gs.albedo[i]) > 1e-5)
            TRACK(fd_error_f(f, &f->albedo[i], gs.albedo[i]));
#undef TRACK
    printf("fused FD: %d parameters, worst relative error %.2e\n", checked, worst);
    CHECK(checked >= 10);
    CHECK_MSG(worst < 1e-3, "fused FD relative error %.3g", worst);
    free(gs.pos);
}

static int all_finite(const double *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* Extreme but valid scenes: loss and every gradient stay finite. */
static void check_extremes(int fit_float)
{
    fixture f;
    fixture_init(&f, 1, fit_float);
    grad_set gs;
    grad_set_init(&gs, &f);
    const double exposure[] = {0.0, 1e-30, 1e12}, intensity[] = {0.0, 1e12, 1e-30};
    for (int k = 0; k < 3; k++) {
        f.sc.exposure = exposure[k];
        f.sc.sun_intensity = intensity[k];
        f.sc.shadow_k = k == 1 ? 1e7 : 0.0;
        for (int c = 0; c < SP_RENDER_CLUSTERS; c++) {
            f.sc.shininess[c] = k == 2 ? 1e9 : 0.5; /* both clamps */
            f.sc.ks[c] = k == 1 ? 1e6 : 0.0;
        }
        double L = NAN;
        sp_render_grads_zero(&gs.g, &f.sc);
        CHECK_EQ_INT(sp_render_fit_l2(f.r, &f.sc, f.target, f.mask, &L, &gs.g, NULL), 0);
        CHECK(isfinite(L) && L >= 0.0);
        CHECK(all_finite(gs.albedo, AW * AH * 3) && all_finite(gs.disp, DW * DH));
        CHECK(all_finite(gs.env, SP_RENDER_ENV_FLOATS) && all_finite(gs.pos, (size_t)f.mesh.n_vertices * 3));
        CHECK(all_finite(gs.g.ks, SP_RENDER_CLUSTERS) && all_finite(gs.g.shininess, SP_RENDER_CLUSTERS));
        CHECK(all_finite(gs.g.sun_dir, 3) && isfinite(gs.g.sun_intensity) && isfinite(gs.g.exposure));
        CHECK(all_finite(gs.g.camera_R, 9) && all_finite(gs.g.camera_t, 3) && all_finite(&gs.g.fx, 4));
    }
    free(gs.pos);
    sp_renderer_close(&f.r);
    sp_mesh_free(&f.mesh);
}

/* skip_outputs: same image, NULL decomposition pointers. */
static void check_skip_outputs(void)
{
    fixture f;
    fixture_init(&f, 1, 0);
    sp_renderer_settings set;
    sp_renderer_default_settings(&set);
    CHECK(set.skip_outputs == 0);
    set.width = W;
    set.height = H;
    set.skip_outputs = SP_RENDER_SKIP_DIFFUSE | SP_RENDER_SKIP_NORMAL;
    sp_renderer *r2 = NULL;
    CHECK_EQ_INT(sp_renderer_open(&r2, &set), 0);
    static float img[W * H * 3];
    sp_render_outputs o, o2;
    CHECK_EQ_INT(sp_render(f.r, &f.sc, &o), 0);
    memcpy(img, o.image, sizeof(img));
    CHECK(o.diffuse && o.specular && o.ambient && o.fill && o.visibility && o.normal && o.albedo);
    CHECK_EQ_INT(sp_render(r2, &f.sc, &o2), 0);
    CHECK(!o2.diffuse && !o2.normal && o2.specular && o2.ambient && o2.albedo && o2.visibility);
    CHECK(memcmp(img, o2.image, sizeof(img)) == 0);
    CHECK(memcmp(o.specular, o2.specular, sizeof(img)) == 0);
    /* errors: NULL target, fill lights (no gradients) */
    double L;
    CHECK_EQ_INT(sp_render_fit_l2(f.r, &f.sc, NULL, NULL, &L, NULL, NULL), -EINVAL);
    f.sc.n_lights = 1;
    f.sc.lights[0] = (sp_render_light){SP_RENDER_LIGHT_DIRECTIONAL, {0, -1, 0}, {1, 1, 1}};
    CHECK_EQ_INT(sp_render_fit_l2(f.r, &f.sc, f.target, NULL, &L, NULL, NULL), SP_EUNSUPPORTED);
    sp_renderer_close(&r2);
    sp_renderer_close(&f.r);
    sp_mesh_free(&f.mesh);
}

/*
 * fit_float on a wide, short frame: rows with more than SIMD_BATCH pixels,
 * long uncovered runs and covered pixels after them (the batching across a
 * row); loss against the classic path within the float tolerance.
 */
static void check_wide_rows(void)
{
    enum { WW = 150, WH = 6 };
    fixture f;
    fixture_init(&f, 1, 0);
    sp_renderer_settings set;
    sp_renderer_default_settings(&set);
    set.width = WW;
    set.height = WH;
    set.fit_float = 1;
    sp_renderer *r2 = NULL;
    CHECK_EQ_INT(sp_renderer_open(&r2, &set), 0);
    f.sc.camera.cx = 0.75 * WW + 0.3; /* the head's centre rows, right of mid-frame */
    f.sc.camera.cy = 0.5 * WH - 0.2;
    static float target[WW * WH * 3], dl[WW * WH * 3];
    for (int i = 0; i < WW * WH * 3; i++)
        target[i] = (float)(0.3 + 0.001 * (i % 97));
    sp_render_outputs o;
    double loss_c = -1.0, loss_f = -2.0;
    CHECK_EQ_INT(sp_render(r2, &f.sc, &o), 0);
    int covered = 0;
    for (int i = 0; i < WW * WH; i++)
        covered += o.coverage[i] > 0.0f;
    int longest = 0; /* the longest uncovered run in a row that then has a covered pixel */
    for (int y = 0; y < WH; y++)
        for (int x = 0, run = 0; x < WW; x++) {
            run = o.coverage[y * WW + x] > 0.0f ? 0 : run + 1;
            longest = run > longest && x + 1 < WW ? run : longest;
        }
    CHECK(covered > WH && longest > 64); /* a batch's pixel capacity is exceeded by the uncovered run */
    CHECK_EQ_INT(sp_render_l2_loss(o.image, target, NULL, WW, WH, &loss_c, dl), 0);
    grad_set gs;
    grad_set_init(&gs, &f);
    CHECK_EQ_INT(sp_render_fit_l2(r2, &f.sc, target, NULL, &loss_f, &gs.g, NULL), 0);
    printf("wide rows: %d covered pixels, longest uncovered run %d, loss rel diff %.2e\n", covered, longest, fabs(loss_f - loss_c) / loss_c);
    CHECK(loss_c > 0.0 && fabs(loss_f - loss_c) <= 1e-5 * loss_c);
    CHECK(all_finite(gs.pos, (size_t)f.mesh.n_vertices * 3) && isfinite(gs.g.exposure));
    free(gs.pos);
    sp_renderer_close(&r2);
    sp_renderer_close(&f.r);
    sp_mesh_free(&f.mesh);
}

int main(void)
{
    static fixture f;
    for (int ff = 0; ff <= 1; ff++) /* the classic double fused path, then fit_float */
        for (int S = 1; S <= 2; S++) {
            printf("fit_float %d, S = %d\n", ff, S);
            fixture_init(&f, S, ff);
            check_equivalence(&f);
            if (S == 1)
                check_fd(&f);
            sp_renderer_close(&f.r);
            sp_mesh_free(&f.mesh);
        }
    check_skip_outputs();
    check_extremes(0);
    check_extremes(1);
    check_wide_rows();
    return check_exit();
}
