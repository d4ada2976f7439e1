/* SPDX-License-Identifier: MIT */
/*
 * Renderer adjoint vs central finite differences, per parameter group.
 * Loss L = sum_p w_p image_p over the pixels whose visibility switches do not
 * change under the perturbation: same triangle id in the base, +eps and -eps
 * renders, same shadow-map texel footprint and same specular cluster. The
 * shadow map is held fixed (SP_RENDER_SHADOW_REUSE), as the adjoint assumes.
 * Float-stored parameters use the actually stored perturbation. The loss reads
 * the renderer's double image (the float output is its rounding): float
 * rounding over ~5k values is as large as the geometric signal at the
 * micrometre steps that sharp (k = 800) soft shadows need.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "pipeline/render/render_internal.h"
#include "pipeline/render/testmesh.h"
#include "sunprobe/sp_render.h"

enum group {
    G_ALBEDO, G_DISP, G_ENV, G_KS, G_SHININESS, G_SUN_DIR, G_SUN_I, G_EXPOSURE, G_POSITION,
    G_CAM_R, G_CAM_T, G_INTRINSICS, G_COUNT
};
static const char *group_name[G_COUNT] = {"albedo", "displacement", "env", "ks", "shininess", "sun_dir",
                                          "sun_intensity", "exposure", "positions", "camera_R", "camera_t",
                                          "intrinsics"};

typedef struct fixture {
    int W, H, S;
    sp_renderer *r;
    sp_render_scene sc;
    sp_mesh mesh;
    float *albedo, *disp, *env;
    uint8_t *clusters;
    float *w, *wm;
    double *img[3];       /* base, +, - (double display image) */
    int32_t *tri[3], *tex[3];
    float *bary[3];
    sp_render_grads g;
} fixture;

static int fail_rounding;
static uint64_t rng_state = 0x9E3779B97F4A7C15ull;

static double rnd(void)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) / 9007199254740992.0;
}

static void *xcalloc(size_t n, size_t size)
{
    void *p = calloc(n ? n : 1, size);
    if (!p) {
        fprintf(stderr, "out of memory\n");
        exit(99);
    }
    return p;
}

/* Camera on -y looking along +y at the origin, world up +z. */
static void look_from_front(sp_render_camera *c, double dist, double f, int W, int H)
{
    memset(c, 0, sizeof(*c));
    c->fx = c->fy = f;
    c->cx = 0.5 * W - 0.5 + 0.37;
    c->cy = 0.5 * H - 0.5 - 0.21;
    double R[9] = {1, 0, 0, 0, 0, -1, 0, 1, 0};
    memcpy(c->R, R, sizeof(R));
    c->t[0] = 0.0;
    c->t[1] = 0.0;
    c->t[2] = dist;
}

static void fixture_init(fixture *f, int S, double shadow_k)
{
    memset(f, 0, sizeof(*f));
    f->W = 48;
    f->H = 48;
    f->S = S;
    sp_renderer_settings set;
    sp_renderer_default_settings(&set);
    set.width = f->W;
    set.height = f->H;
    set.supersample = S;
    set.shadow_size = 256;
    if (sp_renderer_open(&f->r, &set) != 0) {
        fprintf(stderr, "renderer open failed\n");
        exit(99);
    }
    double c[3] = {0, 0, 0};
    CHECK(testmesh_head(&f->mesh, 14, 20, c, 0.08, 0.095, 0.11, 0.25) == 0);
    /* a blocker between the sun and the head's upper right, so a cast shadow lands on the face */
    sp_mesh blocker;
    double p0[3] = {0.02, -0.16, 0.10}, eu[3] = {0.09, 0.0, 0.0}, ev[3] = {0.0, 0.06, 0.03};
    CHECK(testmesh_grid(&blocker, p0, eu, ev, 2, 2) == 0);
    CHECK(testmesh_append(&f->mesh, &blocker) == 0);
    sp_mesh_free(&blocker);

    int aw = 12, ah = 10, dw = 7, dh = 6, cw = 3, ch = 3;
    f->albedo = xcalloc((size_t)aw * ah * 3, sizeof(float));
    for (int i = 0; i < aw * ah * 3; i++)
        f->albedo[i] = (float)(0.2 + 0.6 * rnd());
    f->disp = xcalloc((size_t)dw * dh, sizeof(float));
    for (int i = 0; i < dw * dh; i++)
        f->disp[i] = (float)(0.004 * (rnd() - 0.5));
    f->clusters = xcalloc((size_t)cw * ch, 1);
    for (int i = 0; i < cw * ch; i++)
        f->clusters[i] = (uint8_t)(i % 10);
    f->env = xcalloc(SP_RENDER_ENV_FLOATS, sizeof(float));
    for (int i = 0; i < SP_RENDER_ENV_FLOATS; i++)
        f->env[i] = (float)(0.1 + 0.5 * rnd() + (i < SP_RENDER_ENV_FLOATS / 2 ? 0.4 : 0.0));

    sp_render_scene *sc = &f->sc;
    sp_render_scene_defaults(sc);
    look_from_front(&sc->camera, 0.45, 82.0, f->W, f->H);
    sc->mesh = &f->mesh;
    sc->albedo = (sp_render_texture){aw, ah, f->albedo};
    sc->displacement = (sp_render_texture){dw, dh, f->disp};
    sc->clusters = (sp_render_cluster_map){cw, ch, f->clusters};
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++) {
        sc->ks[k] = 0.1 + 0.4 * rnd();
        sc->shininess[k] = 4.0 + 40.0 * rnd();
    }
    sc->env = f->env;
    sc->sun_dir[0] = 0.45;
    sc->sun_dir[1] = -0.7;
    sc->sun_dir[2] = 0.6;
    sc->sun_intensity = 2.5;
    sc->exposure = 0.8;
    sc->shadow_k = shadow_k;

    size_t np = (size_t)f->W * f->H, ns = np * (size_t)(S * S);
    f->w = xcalloc(np * 3, sizeof(float));
    f->wm = xcalloc(np * 3, sizeof(float));
    /* random plus ramps: the ramps give image shifts (camera gradients) a clear net effect on L */
    for (int y = 0; y < f->H; y++)
        for (int x = 0; x < f->W; x++)
            for (int k = 0; k < 3; k++)
                f->w[((size_t)y * f->W + x) * 3 + k] =
                    (float)(0.2 + 0.3 * rnd() + 0.6 * x / f->W + (0.4 + 0.2 * k) * y / f->H);
    for (int k = 0; k < 3; k++) {
        f->img[k] = xcalloc(np * 3, sizeof(double));
        f->tri[k] = xcalloc(ns, sizeof(int32_t));
        f->tex[k] = xcalloc(ns, sizeof(int32_t));
        f->bary[k] = xcalloc(ns * 3, sizeof(float));
    }
    f->g.albedo = xcalloc((size_t)aw * ah * 3, sizeof(double));
    f->g.displacement = xcalloc((size_t)dw * dh, sizeof(double));
    f->g.env = xcalloc(SP_RENDER_ENV_FLOATS, sizeof(double));
    f->g.positions = xcalloc((size_t)f->mesh.n_vertices * 3, sizeof(double));
}

static void fixture_free(fixture *f)
{
    sp_renderer_close(&f->r);
    sp_mesh_free(&f->mesh);
    free(f->albedo);
    free(f->disp);
    free(f->env);
    free(f->clusters);
    free(f->w);
    free(f->wm);
    for (int k = 0; k < 3; k++) {
        free(f->img[k]);
        free(f->tri[k]);
        free(f->tex[k]);
        free(f->bary[k]);
    }
    free(f->g.albedo);
    free(f->g.displacement);
    free(f->g.env);
    free(f->g.positions);
}

/* Renders and keeps a copy of the image and the per-sample switches in slot k. */
static void render_into(fixture *f, int k)
{
    sp_render_outputs out;
    int err = sp_render(f->r, &f->sc, &out);
    CHECK_EQ_INT(err, 0);
    if (err)
        exit(1);
    size_t np = (size_t)f->W * f->H, ns = (size_t)out.sample_width * out.sample_height;
    memcpy(f->img[k], render_image_f64(f->r), np * 3 * sizeof(double));
    for (size_t i = 0; i < np * 3; i++) { /* the float output is the rounded double image */
        double x = f->img[k][i];
        if ((fabs(x) < 1e-30 ? 0.0f : (float)x) != out.image[i])
            fail_rounding++;
    }
    memcpy(f->tri[k], out.tri_id, ns * sizeof(int32_t));
    memcpy(f->tex[k], out.shadow_texel, ns * sizeof(int32_t));
    memcpy(f->bary[k], out.bary, ns * 3 * sizeof(float));
}

static int sample_cluster(const fixture *f, int k, size_t s)
{
    int32_t t = f->tri[k][s];
    if (t < 0)
        return -1;
    double u = 0, v = 0;
    for (int i = 0; i < 3; i++) {
        const float *uv = f->mesh.uvs + (size_t)f->mesh.tri_uvs[(size_t)t * 3 + i] * 2;
        u += (double)f->bary[k][s * 3 + i] * (double)uv[0];
        v += (double)f->bary[k][s * 3 + i] * (double)uv[1];
    }
    const sp_render_cluster_map *cm = &f->sc.clusters;
    int x = (int)floor(u * cm->width), y = (int)floor((1.0 - v) * cm->height);
    x = x < 0 ? 0 : (x >= cm->width ? cm->width - 1 : x);
    y = y < 0 ? 0 : (y >= cm->height ? cm->height - 1 : y);
    return cm->data[y * cm->width + x];
}

/* wm = w on pixels whose samples keep triangle, shadow texel and cluster in all three renders. */
static int build_mask(fixture *f)
{
    int S = f->S, sw = f->W * S, excluded = 0;
    for (int py = 0; py < f->H; py++)
        for (int px = 0; px < f->W; px++) {
            int ok = 1;
            for (int j = 0; j < S && ok; j++)
                for (int i = 0; i < S && ok; i++) {
                    size_t s = (size_t)(py * S + j) * sw + (size_t)(px * S + i);
                    for (int k = 1; k < 3; k++) {
                        ok &= f->tri[k][s] == f->tri[0][s] && f->tex[k][s] == f->tex[0][s];
                        ok &= sample_cluster(f, k, s) == sample_cluster(f, 0, s);
                    }
                }
            size_t p = (size_t)py * f->W + px;
            for (int c = 0; c < 3; c++)
                f->wm[p * 3 + c] = ok ? f->w[p * 3 + c] : 0.0f;
            excluded += !ok;
        }
    return excluded;
}

static double masked_loss(const fixture *f, int k)
{
    double s = 0.0;
    for (size_t i = 0; i < (size_t)f->W * f->H * 3; i++)
        s += (double)f->wm[i] * f->img[k][i];
    return s;
}

/* Parameter access: returns the value actually stored after a set. */
static double param(fixture *f, int g, int idx, const double *set)
{
    sp_render_scene *sc = &f->sc;
    float *fp = NULL;
    double *dp = NULL;
    switch (g) {
    case G_ALBEDO: fp = f->albedo + idx; break;
    case G_DISP: fp = f->disp + idx; break;
    case G_ENV: fp = f->env + idx; break;
    case G_POSITION: fp = f->mesh.positions + idx; break;
    case G_KS: dp = sc->ks + idx; break;
    case G_SHININESS: dp = sc->shininess + idx; break;
    case G_SUN_DIR: dp = sc->sun_dir + idx; break;
    case G_SUN_I: dp = &sc->sun_intensity; break;
    case G_EXPOSURE: dp = &sc->exposure; break;
    case G_CAM_R: dp = sc->camera.R + idx; break;
    case G_CAM_T: dp = sc->camera.t + idx; break;
    default: dp = &sc->camera.fx + idx; break; /* fx, fy, cx, cy are contiguous */
    }
    if (fp) {
        if (set)
            *fp = (float)*set;
        return (double)*fp;
    }
    if (set)
        *dp = *set;
    return *dp;
}

static double grad_of(const fixture *f, int g, int idx)
{
    const sp_render_grads *gr = &f->g;
    switch (g) {
    case G_ALBEDO: return gr->albedo[idx];
    case G_DISP: return gr->displacement[idx];
    case G_ENV: return gr->env[idx];
    case G_POSITION: return gr->positions[idx];
    case G_KS: return gr->ks[idx];
    case G_SHININESS: return gr->shininess[idx];
    case G_SUN_DIR: return gr->sun_dir[idx];
    case G_SUN_I: return gr->sun_intensity;
    case G_EXPOSURE: return gr->exposure;
    case G_CAM_R: return gr->camera_R[idx];
    case G_CAM_T: return gr->camera_t[idx];
    default: return (&gr->fx)[idx];
    }
}

static int group_size(const fixture *f, int g)
{
    const sp_render_scene *sc = &f->sc;
    switch (g) {
    case G_ALBEDO: return sc->albedo.width * sc->albedo.height * 3;
    case G_DISP: return sc->displacement.width * sc->displacement.height;
    case G_ENV: return SP_RENDER_ENV_FLOATS;
    case G_POSITION: return (int)f->mesh.n_vertices * 3;
    case G_KS: case G_SHININESS: return SP_RENDER_CLUSTERS;
    case G_SUN_DIR: case G_CAM_T: return 3;
    case G_SUN_I: case G_EXPOSURE: return 1;
    case G_CAM_R: return 9;
    default: return 4;
    }
}

static double step_for(int g, double x)
{
    switch (g) {
    case G_ALBEDO: return 2e-3;
    case G_DISP: return 3e-5;
    case G_ENV: return 1e-2;
    case G_POSITION: return 3e-5;
    case G_KS: return 1e-3;
    case G_SHININESS: return 1e-3 * x;
    case G_SUN_DIR: return 1e-4;
    case G_SUN_I: case G_EXPOSURE: return 1e-3 * x;
    case G_CAM_R: return 3e-5;
    case G_CAM_T: return 3e-5;
    default: return 1e-3 * fabs(x);
    }
}

static void backward_with(fixture *f, const float *weights)
{
    sp_render_grads_zero(&f->g, &f->sc);
    CHECK_EQ_INT(sp_render_backward(f->r, &f->sc, weights, &f->g), 0);
}

/* One central difference with step h vs the adjoint (masked to stable pixels); relative error. */
static double check_step(fixture *f, int g, int idx, double h, double floor_abs, int *excluded)
{
    double x0 = param(f, g, idx, NULL);
    double v = x0 + h;
    double xp = param(f, g, idx, &v);
    render_into(f, 1);
    v = x0 - h;
    double xm = param(f, g, idx, &v);
    render_into(f, 2);
    param(f, g, idx, &x0);
    render_into(f, 0);
    *excluded = build_mask(f);
    double fd = (masked_loss(f, 1) - masked_loss(f, 2)) / (xp - xm);
    backward_with(f, f->wm);
    double an = grad_of(f, g, idx);
    double den = fmax(fmax(fabs(fd), fabs(an)), floor_abs);
    return fabs(an - fd) / den;
}

/*
 * Best of six step sizes (factor 0.3 apart): large steps suffer truncation
 * where the image is stiff (with k = 800 a soft shadow edge swings across a few
 * micrometres), small ones the float rounding of the image. A wrong adjoint
 * fails at every step.
 */
static double check_param(fixture *f, int g, int idx, double floor_abs, double tol, int *excluded)
{
    double x0 = param(f, g, idx, NULL), h = step_for(g, x0), best = INFINITY;
    for (int k = 0; k < 6 && best > 0.25 * tol; k++, h *= 0.3) {
        double err = check_step(f, g, idx, h, floor_abs, excluded);
        best = fmin(best, err);
    }
    return best;
}

/* Picks parameters with clearly non-zero gradients (from the full-weight adjoint) and checks them. */
static void check_group(fixture *f, int g, int n_check, double tol)
{
    int n = group_size(f, g);
    render_into(f, 0);
    backward_with(f, f->w);
    double gmax = 0.0, *full = xcalloc((size_t)n, sizeof(double));
    for (int i = 0; i < n; i++) {
        full[i] = grad_of(f, g, i);
        gmax = fmax(gmax, fabs(full[i]));
    }
    CHECK_MSG(gmax > 0.0, "group %s has an all-zero gradient", group_name[g]);
    if (!(gmax > 0.0)) {
        free(full);
        return;
    }
    double worst = 0.0;
    int tested = 0, excl_total = 0;
    for (int attempt = 0; attempt < 40 * n_check && tested < n_check; attempt++) {
        int idx = (int)(rnd() * n) % n;
        if (fabs(full[idx]) < 0.05 * gmax)
            continue;
        int excl;
        double err = check_param(f, g, idx, 1e-3 * gmax, tol, &excl);
        excl_total += excl;
        CHECK_MSG(err < tol, "%s[%d]: relative error %.3g (tol %.1g)", group_name[g], idx, err, tol);
        worst = fmax(worst, err);
        tested++;
    }
    free(full);
    CHECK_MSG(tested > 0, "no parameter of %s tested", group_name[g]);
    printf("  %-14s tested %2d  max rel err %.2e  excluded px/param %.1f\n", group_name[g], tested, worst,
           tested ? (double)excl_total / tested : 0.0);
}

static void run_config(int S, double shadow_k)
{
    fixture f;
    fixture_init(&f, S, shadow_k);
    printf("config: supersample %d, shadow k %.0f\n", S, shadow_k);
    render_into(&f, 0);
    f.sc.shadow_mode = SP_RENDER_SHADOW_REUSE;
    /* the fixture must exercise partial visibility for the shadow path to be tested */
    sp_render_outputs out;
    CHECK_EQ_INT(sp_render(f.r, &f.sc, &out), 0);
    int partial = 0, covered = 0;
    for (int i = 0; i < f.W * f.H; i++) {
        covered += out.coverage[i] > 0.99f;
        partial += out.coverage[i] > 0.99f && out.visibility[i] > 0.02f && out.visibility[i] < 0.98f;
    }
    printf("  covered px %d, partially shadowed px %d\n", covered, partial);
    CHECK(covered > 300);
    int n = S == 1 ? 4 : 1;
    for (int g = 0; g < G_COUNT; g++)
        check_group(&f, g, g == G_POSITION ? 2 * n : n, 1e-3);
    fixture_free(&f);
}

int main(void)
{
    run_config(1, 20.0);  /* soft shadows everywhere: exercises dV/dp */
    run_config(1, 800.0); /* the default sharpness */
    run_config(2, 60.0);  /* supersampled */
    CHECK_EQ_INT(fail_rounding, 0);
    return check_exit();
}
