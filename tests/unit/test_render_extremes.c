/* SPDX-License-Identifier: MIT */
/*
 * Renderer extremes: every output and every gradient must stay finite (no NaN,
 * no Inf) for the sun at the horizon and behind the head, n.l exactly 0,
 * shininess 1 and 1e4 (and out of range), k * delta = +-1e6 in the soft shadow
 * test, zero-area and sub-pixel triangles, a camera inside the near plane and
 * inside the head, black and saturated albedo (1, 1e3), black and 1e5 skies,
 * sun intensity 0 and 1e5, huge exposure and displacement, an empty mesh.
 * Bad arguments are rejected with -EINVAL.
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "pipeline/render/shadow.h"
#include "pipeline/render/testmesh.h"
#include "pipeline/render/tonemap.h"
#include "sunprobe/sp_render.h"

#define W 40
#define H 40
#define AT 8 /* albedo texture side */

typedef struct world {
    sp_renderer *r, *r_ss;
    sp_mesh head, quad, junk;
    float albedo[AT * AT * 3];
    float disp[6 * 6];
    uint8_t clusters[4 * 4];
    float env[SP_RENDER_ENV_FLOATS];
    float dl[W * H * 3];
    double g_alb[AT * AT * 3], g_disp[6 * 6], g_env[SP_RENDER_ENV_FLOATS];
    double *g_pos;
} world;

static int count_bad_f(const float *v, size_t n)
{
    int bad = 0;
    for (size_t i = 0; i < n; i++)
        bad += !isfinite(v[i]);
    return bad;
}

static int count_bad_d(const double *v, size_t n)
{
    int bad = 0;
    for (size_t i = 0; i < n; i++)
        bad += !isfinite(v[i]);
    return bad;
}

static int outputs_bad(const sp_render_outputs *o)
{
    size_t np = (size_t)o->width * o->height, ns = (size_t)o->sample_width * o->sample_height;
    const float *rgb[] = {o->image, o->radiance, o->diffuse, o->specular, o->ambient, o->fill, o->normal, o->albedo};
    int bad = 0;
    for (size_t i = 0; i < sizeof(rgb) / sizeof(rgb[0]); i++)
        bad += count_bad_f(rgb[i], np * 3);
    bad += count_bad_f(o->visibility, np) + count_bad_f(o->coverage, np);
    bad += count_bad_f(o->bary, ns * 3) + count_bad_f(o->depth, ns);
    for (size_t i = 0; i < np * 3; i++) /* display values are in [0, 1] */
        bad += !(o->image[i] >= 0.0f && o->image[i] <= 1.0f);
    for (size_t i = 0; i < np; i++)
        bad += !(o->visibility[i] >= 0.0f && o->visibility[i] <= 1.0f);
    return bad;
}

static int grads_bad(const sp_render_grads *g, const sp_render_scene *sc)
{
    int bad = count_bad_d(g->albedo, (size_t)sc->albedo.width * sc->albedo.height * 3);
    if (sc->displacement.data)
        bad += count_bad_d(g->displacement, (size_t)sc->displacement.width * sc->displacement.height);
    bad += count_bad_d(g->env, SP_RENDER_ENV_FLOATS);
    bad += count_bad_d(g->positions, (size_t)sc->mesh->n_vertices * 3);
    bad += count_bad_d(g->ks, SP_RENDER_CLUSTERS) + count_bad_d(g->shininess, SP_RENDER_CLUSTERS);
    bad += count_bad_d(g->sun_dir, 3) + count_bad_d(&g->sun_intensity, 1) + count_bad_d(&g->exposure, 1);
    bad += count_bad_d(g->camera_R, 9) + count_bad_d(g->camera_t, 3) + count_bad_d(&g->fx, 4);
    return bad;
}

/* Renders, runs the adjoint with two loss gradients, checks everything is finite. */
static void run(world *w, sp_renderer *r, const sp_render_scene *sc, const char *what)
{
    sp_render_outputs o;
    int err = sp_render(r, sc, &o);
    CHECK_MSG(err == 0, "%s: sp_render returned %d", what, err);
    if (err)
        return;
    int bad = outputs_bad(&o);
    CHECK_MSG(bad == 0, "%s: %d non-finite or out-of-range outputs", what, bad);
    sp_render_grads g = {.albedo = w->g_alb, .displacement = w->g_disp, .env = w->g_env, .positions = w->g_pos};
    for (int pass = 0; pass < 2; pass++) {
        for (int i = 0; i < W * H * 3; i++) /* ones, then an L2 gradient against grey */
            w->dl[i] = pass == 0 ? 1.0f : 2.0f * (o.image[i] - 0.5f);
        sp_render_grads_zero(&g, sc);
        err = sp_render_backward(r, sc, w->dl, &g);
        CHECK_MSG(err == 0, "%s: backward returned %d", what, err);
        bad = grads_bad(&g, sc);
        CHECK_MSG(bad == 0, "%s: %d non-finite gradients", what, bad);
    }
}

static void front_camera(sp_render_camera *c, double dist)
{
    double eye[3] = {0, -dist, 0}, at[3] = {0, 0, 0}, up[3] = {0, 0, 1};
    c->fx = c->fy = 60.0;
    c->cx = c->cy = 19.5;
    testmesh_look_at(c, eye, at, up);
}

static void base_scene(world *w, sp_render_scene *sc, const sp_mesh *mesh)
{
    sp_render_scene_defaults(sc);
    front_camera(&sc->camera, 0.5);
    sc->mesh = mesh;
    sc->albedo = (sp_render_texture){AT, AT, w->albedo};
    sc->displacement = (sp_render_texture){6, 6, w->disp};
    sc->clusters = (sp_render_cluster_map){4, 4, w->clusters};
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++) {
        sc->ks[k] = 0.3;
        sc->shininess[k] = 30.0;
    }
    sc->env = w->env;
    sc->sun_dir[0] = 0.3, sc->sun_dir[1] = -1.0, sc->sun_dir[2] = 0.5;
    sc->sun_intensity = 3.0;
}

static void world_init(world *w)
{
    memset(w, 0, sizeof(*w));
    sp_renderer_settings s;
    sp_renderer_default_settings(&s);
    s.width = W;
    s.height = H;
    s.shadow_size = 128;
    s.max_vertices = 16; /* too small on purpose: the first frame must grow the buffers */
    s.max_triangles = 16;
    CHECK(sp_renderer_open(&w->r, &s) == 0);
    s.supersample = 3;
    CHECK(sp_renderer_open(&w->r_ss, &s) == 0);
    double c[3] = {0, 0, 0};
    CHECK(testmesh_head(&w->head, 16, 24, c, 0.08, 0.095, 0.11, 0.25) == 0);
    double p0[3] = {-0.5, 0, -0.5}, eu[3] = {1, 0, 0}, ev[3] = {0, 0, 1};
    CHECK(testmesh_grid(&w->quad, p0, eu, ev, 2, 2) == 0);
    for (int i = 0; i < AT * AT * 3; i++)
        w->albedo[i] = 0.5f;
    for (int i = 0; i < 36; i++)
        w->disp[i] = 0.001f * (float)(i % 5);
    for (int i = 0; i < 16; i++)
        w->clusters[i] = (uint8_t)(i % 3 == 2 ? 255 : i % 10); /* 255: no specular */
    for (int i = 0; i < SP_RENDER_ENV_FLOATS; i++)
        w->env[i] = 0.3f;
    w->g_pos = calloc(4096 * 3, sizeof(double));
    CHECK(w->g_pos != NULL);
}

static void test_sun(world *w)
{
    sp_render_scene sc;
    base_scene(w, &sc, &w->head);
    double dirs[][3] = {{1, 0, 0}, {0, 1, 0}, {0, 1, -0.2}, {0, 0, -1}, {0, -1, 0}, {2e-12, 0, 0}};
    const char *names[] = {"sun at the horizon", "sun behind the head", "sun behind and below",
                           "sun straight down", "sun at the camera", "short sun vector"};
    for (size_t i = 0; i < sizeof(dirs) / sizeof(dirs[0]); i++) {
        memcpy(sc.sun_dir, dirs[i], sizeof(dirs[i]));
        run(w, w->r, &sc, names[i]);
    }
    base_scene(w, &sc, &w->head);
    double intens[] = {0.0, 1e5};
    for (int i = 0; i < 2; i++) {
        sc.sun_intensity = intens[i];
        run(w, w->r, &sc, i ? "sun intensity 1e5" : "sun intensity 0");
    }
}

static void test_grazing(world *w)
{
    /* quad with normal -y; a sun along +x or +z is exactly perpendicular: n.l == 0 */
    sp_render_scene sc;
    base_scene(w, &sc, &w->quad);
    sc.displacement.data = NULL;
    double dirs[][3] = {{1, 0, 0}, {0, 0, 1}, {-1, 0, 0}};
    for (int i = 0; i < 3; i++) {
        memcpy(sc.sun_dir, dirs[i], sizeof(dirs[i]));
        run(w, w->r, &sc, "n.l exactly 0");
        sp_render_outputs o;
        CHECK_EQ_INT(sp_render(w->r, &sc, &o), 0);
        CHECK(o.diffuse[(20 * W + 20) * 3] == 0.0f && o.specular[(20 * W + 20) * 3] == 0.0f);
    }
}

static void test_shininess(world *w)
{
    sp_render_scene sc;
    base_scene(w, &sc, &w->head);
    double s[] = {1.0, 1e4, 0.0, -5.0, 1e6};
    for (int i = 0; i < 5; i++) {
        for (int k = 0; k < SP_RENDER_CLUSTERS; k++) {
            sc.shininess[k] = s[i];
            sc.ks[k] = 5.0;
        }
        run(w, w->r, &sc, "shininess extreme");
    }
}

static void test_sigmoid(world *w)
{
    /* depths are O(10) bounding radii: k = 1e8 makes k * delta reach well past +-1e6 on both sides */
    sp_render_scene sc;
    base_scene(w, &sc, &w->head);
    sc.sun_dir[0] = 1.0, sc.sun_dir[1] = -0.3, sc.sun_dir[2] = 0.2;
    double ks[] = {1e8, 1e12, 0.0};
    for (int i = 0; i < 3; i++) {
        sc.shadow_k = ks[i];
        run(w, w->r, &sc, "sigmoid k * delta = +-1e6");
    }
    sc.shadow_k = 800.0;
    sc.shadow_bias = 1e-6; /* everything "in front of" the map: fully shadowed */
    run(w, w->r, &sc, "tiny bias");
    sc.shadow_bias = 1e6;
    run(w, w->r, &sc, "huge bias");
    sc.shadow_bias = 1.0015;
    sc.shadow_mode = SP_RENDER_SHADOW_OFF;
    run(w, w->r, &sc, "shadow off");
    sc.shadow_mode = SP_RENDER_SHADOW_REUSE;
    run(w, w->r, &sc, "shadow reuse without a map");
    sc.shadow_radius = 1e-9; /* a frame far too small: everything outside the map */
    sc.shadow_mode = SP_RENDER_SHADOW_RENDER;
    run(w, w->r, &sc, "tiny shadow frame");
}

static void test_degenerate_triangles(world *w)
{
    /* zero-area (repeated and collinear vertices), sub-pixel, and one far away */
    sp_mesh *m = &w->junk;
    CHECK(sp_mesh_alloc(m, 9, 3, 4) == 0);
    float pos[9 * 3] = {0, 0, 0, 0, 0, 0, 0, 0, 0,          /* one point three times */
                        -0.1f, 0, 0, 0, 0, 0, 0.1f, 0, 0,  /* collinear */
                        0, -0.1f, 0, 1e-5f, -0.1f, 0, 0, -0.1f, 1e-5f}; /* 10 um: sub-pixel */
    memcpy(m->positions, pos, sizeof(pos));
    float uv[6] = {0, 0, 1, 0, 0, 1};
    memcpy(m->uvs, uv, sizeof(uv));
    uint32_t tv[12] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 6, 8, 7};
    uint32_t tu[12] = {0, 1, 2, 0, 1, 2, 0, 1, 2, 0, 2, 1};
    memcpy(m->tri_vertices, tv, sizeof(tv));
    memcpy(m->tri_uvs, tu, sizeof(tu));
    sp_render_scene sc;
    base_scene(w, &sc, m);
    run(w, w->r, &sc, "degenerate triangles");
    run(w, w->r_ss, &sc, "degenerate triangles, supersampled");
    sc.displacement.data = NULL;
    run(w, w->r, &sc, "degenerate triangles, no displacement");
    /* a whole head shrunk to a point, and the head far away (sub-pixel triangles) */
    sp_mesh tiny;
    double c[3] = {0, 0, 0};
    CHECK(testmesh_head(&tiny, 8, 12, c, 1e-9, 1e-9, 1e-9, 0.0) == 0);
    base_scene(w, &sc, &tiny);
    run(w, w->r, &sc, "head of size 1e-9");
    base_scene(w, &sc, &w->head);
    front_camera(&sc.camera, 400.0);
    run(w, w->r_ss, &sc, "sub-pixel head");
    sp_mesh empty;
    CHECK(sp_mesh_alloc(&empty, 0, 0, 0) == 0);
    base_scene(w, &sc, &empty);
    run(w, w->r, &sc, "empty mesh");
    sp_mesh_free(&empty);
    sp_mesh_free(&tiny);
}

static void test_camera_near(world *w)
{
    sp_render_scene sc;
    base_scene(w, &sc, &w->head);
    const double eyes[][3] = {{0, 0, 0}, {0, -0.09, 0}, {0, -0.101, 0}, {0, -0.105, 0}, {0.0, -0.118, 0.0}};
    for (size_t i = 0; i < sizeof(eyes) / sizeof(eyes[0]); i++) {
        /* inside the head, on the surface, inside the near plane of the nose tip */
        double at[3] = {eyes[i][0], eyes[i][1] + 1.0, eyes[i][2]}, up[3] = {0, 0, 1};
        testmesh_look_at(&sc.camera, eyes[i], at, up);
        run(w, w->r, &sc, "camera inside the near plane");
        run(w, w->r_ss, &sc, "camera inside the near plane, supersampled");
        sc.displacement.data = NULL;
        run(w, w->r, &sc, "camera inside the head, no displacement");
        sc.displacement.data = w->disp;
    }
    /* looking away from everything, and a vertex exactly at the camera centre */
    double eye[3] = {0, -0.5, 0}, at[3] = {0, -1.5, 0}, up[3] = {0, 0, 1};
    testmesh_look_at(&sc.camera, eye, at, up);
    run(w, w->r, &sc, "camera looking away");
    const float *v = w->head.positions + 3 * 5;
    double eye2[3] = {v[0], v[1], v[2]}, at2[3] = {0, 0, 0};
    testmesh_look_at(&sc.camera, eye2, at2, up);
    run(w, w->r, &sc, "camera at a vertex");
}

static void test_radiometry(world *w)
{
    sp_render_scene sc;
    base_scene(w, &sc, &w->head);
    float vals[] = {0.0f, 1.0f, 1e3f};
    for (int i = 0; i < 3; i++) {
        for (int k = 0; k < AT * AT * 3; k++)
            w->albedo[k] = vals[i];
        run(w, w->r, &sc, "albedo extreme");
    }
    for (int k = 0; k < AT * AT * 3; k++)
        w->albedo[k] = 0.5f;
    sc.env = NULL;
    run(w, w->r, &sc, "no environment");
    float env_vals[] = {0.0f, 1e5f};
    sc.env = w->env;
    for (int i = 0; i < 2; i++) {
        for (int k = 0; k < SP_RENDER_ENV_FLOATS; k++)
            w->env[k] = env_vals[i];
        run(w, w->r, &sc, "environment extreme");
    }
    for (int k = 0; k < SP_RENDER_ENV_FLOATS; k++) /* one blazing texel: strong SH ringing */
        w->env[k] = k == 100 ? 1e5f : 0.0f;
    run(w, w->r, &sc, "single bright texel");
    for (int k = 0; k < SP_RENDER_ENV_FLOATS; k++)
        w->env[k] = 0.3f;
    double exps[] = {0.0, 1e-30, 1e8};
    for (int i = 0; i < 3; i++) {
        sc.exposure = exps[i];
        run(w, w->r, &sc, "exposure extreme");
    }
    sc.exposure = 1.0;
    for (int k = 0; k < 36; k++)
        w->disp[k] = (k % 2 ? 0.2f : -0.2f); /* folds the head inside out */
    run(w, w->r, &sc, "huge displacement");
    for (int k = 0; k < 36; k++)
        w->disp[k] = 0.001f * (float)(k % 5);
    sc.background[0] = 1e30;
    run(w, w->r, &sc, "huge background");
}

static void test_forward_only_extras(world *w)
{
    sp_render_scene sc;
    base_scene(w, &sc, &w->head);
    sc.sun_angular_radius = 0.5;
    sc.sun_samples = 1000; /* capped by max_sun_samples */
    sp_render_outputs o;
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), 0);
    CHECK_EQ_INT(outputs_bad(&o), 0);
    sc.sun_angular_radius = 0.0;
    sc.n_lights = 2;
    sc.lights[0] = (sp_render_light){SP_RENDER_LIGHT_POINT, {0, -0.09, 0}, {1e5, 1e5, 1e5}};
    sc.lights[1] = (sp_render_light){SP_RENDER_LIGHT_POINT, {0, 0, 0}, {1, 1, 1}}; /* inside the head */
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), 0);
    CHECK_EQ_INT(outputs_bad(&o), 0);
}

/* The scalar pieces at their limits, directly. */
static void test_scalar_limits(void)
{
    double d;
    double xs[] = {-1e300, -1e6, -60.5, -1.0, 0.0, 1.0, 60.5, 1e6, 1e300};
    for (size_t i = 0; i < sizeof(xs) / sizeof(xs[0]); i++) {
        double s = shadow_sigmoid(xs[i], &d);
        CHECK(isfinite(s) && s >= 0.0 && s <= 1.0 && isfinite(d) && d >= 0.0 && d <= 0.25);
    }
    CHECK(shadow_sigmoid(1e6, &d) == 1.0 && d == 0.0);
    CHECK(shadow_sigmoid(-1e6, &d) == 0.0 && d == 0.0);
    CHECK(shadow_sigmoid(0.0, &d) == 0.5 && d == 0.25);
    CHECK_NEAR(shadow_sigmoid(-30.0, NULL), exp(-30.0) / (1.0 + exp(-30.0)), 1e-25);
    double ts[] = {-1.0, 0.0, 1e-300, 1e-9, 1e-6, 0.5, 1e6, 1e300, INFINITY};
    for (size_t i = 0; i < sizeof(ts) / sizeof(ts[0]); i++) {
        double g = tonemap_eval(ts[i], &d);
        CHECK(isfinite(g) && g >= 0.0 && g <= 1.0 && isfinite(d) && d >= 0.0);
        CHECK(isfinite(tonemap_deriv(ts[i], g)));
    }
    CHECK(tonemap_eval(0.0, &d) == 0.0 && d == 0.0);
    /* the toe joins the gamma curve continuously */
    double y0 = 1e-6 / (1.0 - 1e-6);
    CHECK_NEAR(tonemap_eval(y0 * (1.0 - 1e-12), NULL), tonemap_eval(y0 * (1.0 + 1e-12), NULL), 1e-12);
    /* the table + Newton gamma: pow to ~1e-15 across all binades (incl. their edges), slope = FD */
    double worst = 0.0, prev = 0.0;
    for (int k = 1; k <= 20; k++)
        for (int j = -2; j <= 40; j++) {
            double y = ldexp(1.0, -k) * (1.0 + (double)j / 40.0) + (j == -2 ? 1e-17 : 0.0);
            if (y < 2e-6 || y >= 1.0)
                continue;
            double x = y / (1.0 - y), g = tonemap_eval(x, &d);
            double rel = fabs(g / pow(x / (1.0 + x), 1.0 / TONEMAP_GAMMA) - 1.0);
            worst = rel > worst ? rel : worst;
            double h = x * 1e-6, gp = tonemap_eval(x + h, NULL), gm = tonemap_eval(x - h, NULL);
            CHECK_NEAR((gp - gm) / (2.0 * h), d, 1e-6 * d);
        }
    CHECK(worst < 1e-14);
    for (double x = 1e-6; x < 1e7; x *= 1.001) { /* monotone, also where the exponent changes */
        double g = tonemap_eval(x, NULL);
        CHECK(g >= prev);
        prev = g;
    }
}

/*
 * A mesh edited in place after a render: the renderer skips the full
 * validation only for a mesh byte-equal (counts, positions, indices) to the
 * last validated one, so each edit below must still be refused, and the
 * restored mesh must render as before.
 */
static void test_mesh_edited_in_place(world *w)
{
    static float before[W * H * 3];
    sp_render_scene sc;
    sp_render_outputs o;
    sp_mesh *m = &w->head;
    base_scene(w, &sc, m);
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), 0);
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), 0); /* the second frame takes the unchanged-mesh path */
    memcpy(before, o.image, sizeof(before));
    float u = m->uvs[3];
    m->uvs[3] = NAN; /* not part of the unchanged-mesh key: checked on every frame */
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    m->uvs[3] = INFINITY;
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    m->uvs[3] = u;
    uint32_t nuv = m->n_uvs;
    m->n_uvs = 0; /* every tri_uvs index out of range */
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    m->n_uvs = nuv;
    float x = m->positions[4];
    m->positions[4] = NAN;
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    m->positions[4] = x;
    uint32_t t = m->tri_uvs[5];
    m->tri_uvs[5] = nuv;
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    m->tri_uvs[5] = t;
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), 0);
    CHECK(memcmp(before, o.image, sizeof(before)) == 0);
}

static void test_bad_arguments(world *w)
{
    sp_render_scene sc;
    sp_render_outputs o;
    base_scene(w, &sc, &w->head);
    CHECK_EQ_INT(sp_render(NULL, &sc, &o), -EINVAL);
    CHECK_EQ_INT(sp_render(w->r, NULL, &o), -EINVAL);
    sc.sun_dir[0] = NAN;
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    base_scene(w, &sc, &w->head);
    sc.sun_dir[0] = sc.sun_dir[1] = sc.sun_dir[2] = 0.0;
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    sc.sun_dir[0] = 1e-300; /* its normalisation would blow gradients up */
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    base_scene(w, &sc, &w->head);
    sc.sun_intensity = -1.0;
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    base_scene(w, &sc, &w->head);
    sc.camera.fx = 0.0;
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    base_scene(w, &sc, &w->head);
    sc.albedo.data = NULL;
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    base_scene(w, &sc, &w->head);
    sc.shadow_k = INFINITY;
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    base_scene(w, &sc, &w->head);
    sc.mesh = NULL;
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    base_scene(w, &sc, &w->head);
    w->head.tri_vertices[7] = 1u << 30;
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), -EINVAL);
    w->head.tri_vertices[7] = 1;
    /* backward of a different mesh than the last render */
    CHECK_EQ_INT(sp_render(w->r, &sc, &o), 0);
    base_scene(w, &sc, &w->quad);
    sp_render_grads g = {.albedo = w->g_alb, .env = w->g_env, .positions = w->g_pos};
    CHECK_EQ_INT(sp_render_backward(w->r, &sc, w->dl, &g), -EINVAL);
    sp_renderer_settings s;
    sp_renderer_default_settings(&s);
    s.supersample = 0;
    sp_renderer *r = (sp_renderer *)&s;
    CHECK_EQ_INT(sp_renderer_open(&r, &s), -EINVAL);
    CHECK(r == NULL);
    sp_renderer_close(&r);
    sp_renderer_close(NULL);
}

int main(void)
{
    static world w;
    world_init(&w);
    test_sun(&w);
    test_grazing(&w);
    test_shininess(&w);
    test_sigmoid(&w);
    test_degenerate_triangles(&w);
    test_camera_near(&w);
    test_radiometry(&w);
    test_forward_only_extras(&w);
    test_scalar_limits();
    test_mesh_edited_in_place(&w);
    test_bad_arguments(&w);
    sp_renderer_close(&w.r);
    sp_renderer_close(&w.r_ss);
    sp_mesh_free(&w.head);
    sp_mesh_free(&w.quad);
    sp_mesh_free(&w.junk);
    free(w.g_pos);
    return check_exit();
}
