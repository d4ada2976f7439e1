/* SPDX-License-Identifier: MIT */
/*
 * Renderer sanity against analytic expectations: a flat quad facing the sun
 * (Lambert, SH ambient of a uniform sky, Blinn-Phong, tone map), cosine
 * fall-off on a sphere, a blocker's cast shadow on a plane, perspective-correct
 * UVs on a slanted quad, supersampled coverage, fill lights, background,
 * the area sun and the L2 loss helper.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "pipeline/render/testmesh.h"
#include "sunprobe/sp_render.h"

#define PI 3.14159265358979323846

static double tonemap_ref(double x)
{
    if (x <= 0.0)
        return 0.0;
    return pow(x / (1.0 + x), 1.0 / 2.2);
}

static sp_renderer *open_renderer(int w, int h, int s)
{
    sp_renderer_settings set;
    sp_renderer_default_settings(&set);
    set.width = w;
    set.height = h;
    set.supersample = s;
    sp_renderer *r = NULL;
    if (sp_renderer_open(&r, &set) != 0) {
        fprintf(stderr, "renderer open failed\n");
        exit(99);
    }
    return r;
}

/* World ray (origin = camera centre) through pixel (u, v). */
static void pixel_ray(const sp_render_camera *c, double u, double v, double o[3], double d[3])
{
    double dc[3] = {(u - c->cx) / c->fx, (v - c->cy) / c->fy, 1.0};
    for (int i = 0; i < 3; i++) {
        o[i] = -(c->R[0 * 3 + i] * c->t[0] + c->R[1 * 3 + i] * c->t[1] + c->R[2 * 3 + i] * c->t[2]);
        d[i] = c->R[0 * 3 + i] * dc[0] + c->R[1 * 3 + i] * dc[1] + c->R[2 * 3 + i] * dc[2];
    }
}

static void normalize3(double v[3])
{
    double n = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    for (int i = 0; i < 3; i++)
        v[i] /= n;
}

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Camera on -y at distance dist looking at the origin, principal point on pixel (w/2, h/2) for odd sizes. */
static void front_camera(sp_render_camera *c, double dist, double f, int w, int h)
{
    double eye[3] = {0, -dist, 0}, at[3] = {0, 0, 0}, up[3] = {0, 0, 1};
    c->fx = c->fy = f;
    c->cx = 0.5 * (w - 1);
    c->cy = 0.5 * (h - 1);
    testmesh_look_at(c, eye, at, up);
}

static sp_mesh facing_quad(double half, int n)
{
    sp_mesh m;
    double p0[3] = {-half, 0, -half}, eu[3] = {2 * half, 0, 0}, ev[3] = {0, 0, 2 * half};
    CHECK(testmesh_grid(&m, p0, eu, ev, n, n) == 0);
    return m;
}

/* The scene of a quad m seen head-on from 1 m (40 deg field), one albedo alb (borrowed). */
static void quad_scene(sp_render_scene *sc, const sp_mesh *m, const float *alb, int W, int H)
{
    sp_render_scene_defaults(sc);
    front_camera(&sc->camera, 1.0, 40.0, W, H);
    sc->mesh = m;
    sc->albedo = (sp_render_texture){1, 1, alb};
}

/*
 * A point sun h = 0.5 m in front of the quad with intensity I h^2 lights the point straight below it as the
 * directional sun of I does (1/d^2 at normal incidence) and the rest less (cos / d^2); no gradients.
 */
static void test_point_sun(void)
{
    const int W = 33, H = 33;
    sp_renderer *r = open_renderer(W, H, 1);
    sp_mesh m = facing_quad(0.5, 2);
    float alb[3] = { 0.5f, 0.4f, 0.3f };
    sp_render_scene sc;
    quad_scene(&sc, &m, alb, W, H);
    sc.sun_dir[1] = -1.0, sc.sun_dir[2] = 0.0;
    sc.sun_intensity = 2.0;
    sp_render_outputs o;
    CHECK_EQ_INT(sp_render(r, &sc, &o), 0);
    double centre = (double)o.diffuse[(16 * W + 16) * 3], corner = (double)o.diffuse[0];
    sc.sun_is_point = 1;
    sc.sun_position[1] = -0.5;
    sc.sun_intensity = 2.0 * 0.25;
    CHECK_EQ_INT(sp_render(r, &sc, &o), 0);
    CHECK_NEAR(o.diffuse[(16 * W + 16) * 3], centre, 1e-5 * centre);
    CHECK_MSG((double)o.diffuse[0] < 0.9 * corner && o.diffuse[0] > 0.0f, "corner %g, directional %g",
              (double)o.diffuse[0], corner);
    static float dl[33 * 33 * 3];
    sp_render_grads g;
    memset(&g, 0, sizeof(g));
    CHECK_EQ_INT(sp_render_backward(r, &sc, dl, &g), SP_EUNSUPPORTED);
    sc.sun_position[0] = NAN;
    CHECK(sp_render(r, &sc, &o) != 0);
    sp_mesh_free(&m);
    sp_renderer_close(&r);
}

static void test_flat_quad(void)
{
    const int W = 33, H = 33;
    sp_renderer *r = open_renderer(W, H, 1);
    sp_mesh m = facing_quad(0.5, 2);
    float alb[3] = {0.5f, 0.4f, 0.3f};
    static float env[SP_RENDER_ENV_FLOATS];
    for (int i = 0; i < SP_RENDER_ENV_FLOATS; i++)
        env[i] = 0.2f;
    sp_render_scene sc;
    quad_scene(&sc, &m, alb, W, H);
    sc.env = env;
    sc.sun_dir[0] = 0, sc.sun_dir[1] = -3.0, sc.sun_dir[2] = 0; /* any length */
    sc.sun_intensity = 2.0;
    sc.exposure = 0.7;
    sp_render_outputs o;
    CHECK_EQ_INT(sp_render(r, &sc, &o), 0);
    int bad_d = 0, bad_a = 0, bad_i = 0, bad_v = 0;
    for (int p = 0; p < W * H; p++) {
        CHECK(o.coverage[p] == 1.0f);
        bad_v += !(o.visibility[p] > 0.9999f);
        for (int c = 0; c < 3; c++) {
            double d = (double)alb[c] / PI * 2.0 * (double)o.visibility[p], a = (double)alb[c] * 0.2;
            bad_d += fabs((double)o.diffuse[p * 3 + c] - d) > 1e-5 * d;
            bad_a += fabs((double)o.ambient[p * 3 + c] - a) > 2e-3 * a; /* SH of a uniform sky: E = pi L */
            double img = tonemap_ref(0.7 * ((double)o.diffuse[p * 3 + c] + (double)o.ambient[p * 3 + c]));
            bad_i += fabs((double)o.image[p * 3 + c] - img) > 1e-5;
        }
    }
    CHECK_EQ_INT(bad_v, 0);
    CHECK_EQ_INT(bad_d, 0);
    CHECK_EQ_INT(bad_a, 0);
    CHECK_EQ_INT(bad_i, 0);
    /* depth of the on-axis pixel is the distance to the plane */
    CHECK_NEAR(o.depth[16 * W + 16], 1.0, 1e-6);

    /* normalised Blinn-Phong: per-pixel n.h from the analytic hit point */
    sc.ks[0] = 0.3;
    sc.shininess[0] = 100.0;
    CHECK_EQ_INT(sp_render(r, &sc, &o), 0);
    int bad_s = 0;
    double l[3] = {0, -1, 0}, n[3] = {0, -1, 0};
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double org[3], d[3], p[3], v[3], h[3];
            pixel_ray(&sc.camera, x, y, org, d);
            double t = -org[1] / d[1];
            for (int i = 0; i < 3; i++) {
                p[i] = org[i] + t * d[i];
                v[i] = org[i] - p[i];
            }
            normalize3(v);
            for (int i = 0; i < 3; i++)
                h[i] = l[i] + v[i];
            normalize3(h);
            double s = 0.3 * 102.0 / (2.0 * PI) * pow(dot3(n, h), 100.0) * 2.0 * (double)o.visibility[y * W + x];
            bad_s += fabs((double)o.specular[(y * W + x) * 3] - s) > 1e-5 * s + 1e-9;
        }
    CHECK_EQ_INT(bad_s, 0);
    CHECK_NEAR(o.specular[(16 * W + 16) * 3], 0.3 * 102.0 / (2.0 * PI) * 2.0, 1e-4);
    CHECK(o.specular[(16 * W + 4) * 3] < 0.5f * o.specular[(16 * W + 16) * 3]);
    sp_mesh_free(&m);
    sp_renderer_close(&r);
    CHECK(r == NULL);
}

static void test_sphere_cosine(void)
{
    const int W = 64, H = 64;
    sp_renderer *r = open_renderer(W, H, 1);
    sp_mesh m;
    double c0[3] = {0, 0, 0};
    CHECK(testmesh_head(&m, 64, 96, c0, 0.1, 0.1, 0.1, 0.0) == 0);
    float alb[3] = {0.6f, 0.6f, 0.6f};
    sp_render_scene sc;
    sp_render_scene_defaults(&sc);
    front_camera(&sc.camera, 0.6, 150.0, W, H);
    sc.mesh = &m;
    sc.albedo = (sp_render_texture){1, 1, alb};
    double l[3] = {1.0, 0.2, 0.4};
    normalize3(l);
    memcpy(sc.sun_dir, l, sizeof(l));
    sc.sun_intensity = 3.0;
    sp_render_outputs o;
    CHECK_EQ_INT(sp_render(r, &sc, &o), 0);
    int lit = 0, dark = 0, bad = 0, acne = 0, bad_dark = 0;
    double scale = 0.6 / PI * 3.0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int p = y * W + x;
            if (o.coverage[p] < 1.0f)
                continue;
            double org[3], d[3], n[3];
            pixel_ray(&sc.camera, x, y, org, d);
            normalize3(d);
            double b = dot3(org, d), cc = dot3(org, org) - 0.01, disc = b * b - cc;
            if (disc < 0.0)
                continue; /* hit the tessellation outside the true sphere's silhouette */
            double t = -b - sqrt(disc);
            for (int i = 0; i < 3; i++)
                n[i] = (org[i] + t * d[i]) / 0.1;
            double cosl = dot3(n, l);
            if (cosl > 0.3) {
                lit++;
                bad += fabs((double)o.diffuse[p * 3] - scale * cosl) > 0.02 * scale;
                acne += o.visibility[p] < 0.99f;
            } else if (cosl < -0.05) {
                dark++;
                bad_dark += o.diffuse[p * 3] != 0.0f;
            }
        }
    printf("sphere: lit %d dark %d off-cosine %d acne %d\n", lit, dark, bad, acne);
    CHECK(lit > 300 && dark > 300);
    CHECK_EQ_INT(bad, 0);
    CHECK_EQ_INT(acne, 0);
    CHECK_EQ_INT(bad_dark, 0);
    sp_mesh_free(&m);
    sp_renderer_close(&r);
}

/* Plane z = 0 (16 x 16 cells, 0.4 m) plus a 4 x 6 cm blocker at z = 5 cm; returns the plane's triangle count. */
static uint32_t shadow_scene(sp_mesh *m)
{
    double p0[3] = {-0.2, -0.2, 0}, eu[3] = {0.4, 0, 0}, ev[3] = {0, 0.4, 0};
    CHECK(testmesh_grid(m, p0, eu, ev, 16, 16) == 0);
    uint32_t n_plane = m->n_triangles;
    sp_mesh b;
    double q0[3] = {0.0, -0.03, 0.05}, bu[3] = {0.04, 0, 0}, bv[3] = {0, 0.06, 0};
    CHECK(testmesh_grid(&b, q0, bu, bv, 1, 1) == 0);
    CHECK(testmesh_append(m, &b) == 0);
    sp_mesh_free(&b);
    return n_plane;
}

static void shadow_camera(sp_render_scene *sc, int W, int H)
{
    double eye[3] = {0, 0, 0.6}, at[3] = {0, 0, 0}, up[3] = {0, 1, 0};
    sc->camera.fx = sc->camera.fy = 120.0;
    sc->camera.cx = 0.5 * (W - 1);
    sc->camera.cy = 0.5 * (H - 1);
    testmesh_look_at(&sc->camera, eye, at, up);
}

/* Counts fully shadowed / lit / partial plane pixels; checks them against the analytic shadow region. */
static void count_shadow(const sp_render_scene *sc, const sp_render_outputs *o, uint32_t n_plane, int W, int H,
                         int *in, int *out, int *partial, int *bad)
{
    *in = *out = *partial = *bad = 0;
    const double m = 0.004; /* penumbra margin: a few shadow texels */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int p = y * W + x;
            if (o->tri_id[p] < 0 || (uint32_t)o->tri_id[p] >= n_plane)
                continue;
            double org[3], d[3];
            pixel_ray(&sc->camera, x, y, org, d);
            double t = -org[2] / d[2], px = org[0] + t * d[0], py = org[1] + t * d[1];
            /* sun (1, 0, 1): the blocker [0, 0.04] x [-0.03, 0.03] at z = 0.05 shadows x - 0.05 */
            int inside = px > -0.05 + m && px < -0.01 - m && fabs(py) < 0.03 - m;
            int outside = px < -0.05 - m || px > -0.01 + m || fabs(py) > 0.03 + m;
            float v = o->visibility[p];
            *partial += v > 0.05f && v < 0.95f;
            if (inside) {
                (*in)++;
                *bad += !(v < 0.02f) || !(o->diffuse[p * 3] < 1e-3f);
            } else if (outside) {
                (*out)++;
                *bad += !(v > 0.98f);
            }
        }
}

/*
 * The soft sun (one shadow map, percentage-closer): a radius of 1e-9 is the point sun bit for bit; 0.08 rad
 * softens the edge about as the 16-sample area sun does; pi/2 has no dark umbra left and, at 1e5 times the
 * light, stays finite; only forward. sc renders the point sun, partial0 its partly lit pixels.
 */
static void test_soft_sun(sp_renderer *r, sp_render_scene *sc, sp_render_outputs *o, uint32_t n_plane, int partial0,
                          sp_render_grads *g)
{
    const int W = o->width, H = o->height;
    size_t n = (size_t)W * (size_t)H * 3;
    float *point = malloc(sizeof(float) * n);
    CHECK_EQ_INT(sp_render(r, sc, o), 0);
    if (point)
        memcpy(point, o->radiance, sizeof(float) * n);
    sc->sun_soft_radius = 1e-9;
    CHECK_EQ_INT(sp_render(r, sc, o), 0);
    CHECK_MSG(point && !memcmp(point, o->radiance, sizeof(float) * n), "a soft sun of 1e-9 rad is not the point sun");
    int in, out, partial, bad;
    sc->sun_soft_radius = 0.08;
    CHECK_EQ_INT(sp_render(r, sc, o), 0);
    count_shadow(sc, o, n_plane, W, H, &in, &out, &partial, &bad);
    printf("soft sun: partial %d (point sun %d)\n", partial, partial0);
    CHECK(partial > partial0 + 20);
    static float dl[64 * 64 * 3];
    CHECK_EQ_INT(sp_render_backward(r, sc, dl, g), SP_EUNSUPPORTED);
    sc->sun_soft_radius = 0.5 * PI;
    sc->sun_intensity = 1e5;
    CHECK_EQ_INT(sp_render(r, sc, o), 0);
    float vmin = 1.0f;
    int finite = 1;
    for (size_t i = 0; i < n; i++)
        finite &= isfinite(o->radiance[i]) && o->radiance[i] >= 0.0f;
    for (int i = 0; i < W * H; i++)
        if (o->coverage[i] > 0.999f && o->visibility)
            vmin = o->visibility[i] < vmin ? o->visibility[i] : vmin;
    CHECK_MSG(finite && vmin > 0.05f, "a 90-deg soft sun at 1e5: finite %d, darkest visibility %g", finite, (double)vmin);
    sc->sun_soft_radius = 2.0;
    CHECK(sp_render(r, sc, o) != 0); /* beyond pi/2 */
    sc->sun_soft_radius = 0.0;
    sc->sun_intensity = 2.0;
    free(point);
}

static void test_cast_shadow(void)
{
    const int W = 64, H = 64;
    sp_renderer *r = open_renderer(W, H, 1);
    sp_mesh m;
    uint32_t n_plane = shadow_scene(&m);
    float alb[3] = {0.5f, 0.5f, 0.5f};
    sp_render_scene sc;
    sp_render_scene_defaults(&sc);
    shadow_camera(&sc, W, H);
    sc.mesh = &m;
    sc.albedo = (sp_render_texture){1, 1, alb};
    sc.sun_dir[0] = 1.0, sc.sun_dir[1] = 0.0, sc.sun_dir[2] = 1.0;
    sc.sun_intensity = 2.0;
    sp_render_outputs o;
    CHECK_EQ_INT(sp_render(r, &sc, &o), 0);
    int in, out, partial, bad;
    count_shadow(&sc, &o, n_plane, W, H, &in, &out, &partial, &bad);
    printf("shadow: in %d out %d partial %d bad %d\n", in, out, partial, bad);
    CHECK(in > 40 && out > 1000);
    CHECK_EQ_INT(bad, 0);

    /* an area sun softens the edge: more partially lit pixels, the same shadow overall */
    sc.sun_angular_radius = 0.08;
    sc.sun_samples = 16;
    CHECK_EQ_INT(sp_render(r, &sc, &o), 0);
    int in2, out2, partial2, bad2;
    count_shadow(&sc, &o, n_plane, W, H, &in2, &out2, &partial2, &bad2);
    printf("area sun: partial %d (point sun %d)\n", partial2, partial);
    CHECK(partial2 > partial + 20);
    /* gradients are forward-only for the area sun */
    static float dl[64 * 64 * 3];
    sp_render_grads g;
    memset(&g, 0, sizeof(g));
    CHECK_EQ_INT(sp_render_backward(r, &sc, dl, &g), SP_EUNSUPPORTED);
    sc.sun_angular_radius = 0.0;
    sc.sun_samples = 1;
    test_soft_sun(r, &sc, &o, n_plane, partial, &g);
    sp_mesh_free(&m);
    sp_renderer_close(&r);
}

/* Screen-space affine barycentrics of pixel (x, y) in a projected triangle: the wrong answer on purpose. */
static void affine_uv(const sp_render_scene *sc, uint32_t tri, double x, double y, double uv[2])
{
    double px[3], py[3];
    const sp_mesh *m = sc->mesh;
    const sp_render_camera *c = &sc->camera;
    for (int k = 0; k < 3; k++) {
        const float *p = m->positions + (size_t)m->tri_vertices[tri * 3 + k] * 3;
        double q[3];
        for (int i = 0; i < 3; i++)
            q[i] = c->R[i * 3] * (double)p[0] + c->R[i * 3 + 1] * (double)p[1] + c->R[i * 3 + 2] * (double)p[2] +
                   c->t[i];
        px[k] = c->fx * q[0] / q[2] + c->cx;
        py[k] = c->fy * q[1] / q[2] + c->cy;
    }
    double area = (px[1] - px[0]) * (py[2] - py[0]) - (py[1] - py[0]) * (px[2] - px[0]);
    double b1 = ((x - px[0]) * (py[2] - py[0]) - (y - py[0]) * (px[2] - px[0])) / area;
    double b2 = ((px[1] - px[0]) * (y - py[0]) - (py[1] - py[0]) * (x - px[0])) / area;
    double b[3] = {1.0 - b1 - b2, b1, b2};
    uv[0] = uv[1] = 0.0;
    for (int k = 0; k < 3; k++) {
        const float *t = m->uvs + (size_t)m->tri_uvs[tri * 3 + k] * 2;
        uv[0] += b[k] * (double)t[0];
        uv[1] += b[k] * (double)t[1];
    }
}

static void test_perspective_uv(void)
{
    const int W = 48, H = 48, T = 64;
    sp_renderer *r = open_renderer(W, H, 1);
    double a = 60.0 * PI / 180.0;
    double eu[3] = {0.6, 0, 0}, ev[3] = {0, 0.6 * sin(a), 0.6 * cos(a)};
    double p0[3] = {-0.3, -0.3 * sin(a), -0.3 * cos(a)};
    sp_mesh m;
    CHECK(testmesh_grid(&m, p0, eu, ev, 1, 1) == 0);
    /* texels hold their own centre's (u, v): bilinear lookups reproduce the UV exactly */
    float *tex = calloc((size_t)T * T * 3, sizeof(float));
    CHECK(tex != NULL);
    if (!tex)
        return;
    for (int j = 0; j < T; j++)
        for (int i = 0; i < T; i++) {
            tex[(j * T + i) * 3 + 0] = (float)((i + 0.5) / T);
            tex[(j * T + i) * 3 + 1] = (float)(1.0 - (j + 0.5) / T);
            tex[(j * T + i) * 3 + 2] = 0.5f;
        }
    sp_render_scene sc;
    sp_render_scene_defaults(&sc);
    front_camera(&sc.camera, 0.8, 45.0, W, H);
    sc.mesh = &m;
    sc.albedo = (sp_render_texture){T, T, tex};
    sp_render_outputs o;
    CHECK_EQ_INT(sp_render(r, &sc, &o), 0);
    int checked = 0, bad = 0;
    double worst_affine = 0.0, worst = 0.0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int p = y * W + x;
            if (o.tri_id[p] < 0)
                continue;
            double org[3], d[3];
            pixel_ray(&sc.camera, x, y, org, d);
            /* plane through the origin with normal e_u x e_v */
            double nrm[3] = {0, -cos(a), sin(a)};
            double t = -dot3(org, nrm) / dot3(d, nrm), q[3];
            for (int i = 0; i < 3; i++)
                q[i] = org[i] + t * d[i] - p0[i];
            double s = dot3(q, eu) / 0.36, tt = dot3(q, ev) / 0.36;
            if (s < 0.02 || s > 0.98 || tt < 0.02 || tt > 0.98)
                continue;
            checked++;
            double e = fmax(fabs((double)o.albedo[p * 3] - s), fabs((double)o.albedo[p * 3 + 1] - tt));
            worst = fmax(worst, e);
            bad += e > 1e-4;
            double auv[2];
            affine_uv(&sc, (uint32_t)o.tri_id[p], x, y, auv);
            worst_affine = fmax(worst_affine, fmax(fabs(auv[0] - s), fabs(auv[1] - tt)));
        }
    printf("perspective: %d px, max UV error %.2e (affine interpolation would be %.3f)\n", checked, worst,
           worst_affine);
    CHECK(checked > 300);
    CHECK_EQ_INT(bad, 0);
    CHECK(worst_affine > 0.01); /* the scene is slanted enough for the check to mean something */
    free(tex);
    sp_mesh_free(&m);
    sp_renderer_close(&r);
}

static void test_supersample_coverage(void)
{
    const int W = 33, H = 33, S = 4;
    sp_renderer *r = open_renderer(W, H, S);
    sp_mesh m;
    double p0[3] = {0.0, 0, -0.5}, eu[3] = {1.0, 0, 0}, ev[3] = {0, 0, 1.0};
    CHECK(testmesh_grid(&m, p0, eu, ev, 1, 1) == 0);
    float alb[3] = {0.5f, 0.5f, 0.5f};
    sp_render_scene sc;
    quad_scene(&sc, &m, alb, W, H);
    sc.background[0] = sc.background[1] = sc.background[2] = 0.25;
    sc.exposure = 2.0;
    sp_render_outputs o;
    CHECK_EQ_INT(sp_render(r, &sc, &o), 0);
    CHECK_EQ_INT(o.sample_width, W * S);
    for (int y = 4; y < H - 4; y++) {
        CHECK(o.coverage[y * W + 15] == 0.0f);
        CHECK(o.coverage[y * W + 16] == 0.5f); /* the quad's edge x = 0 projects onto the pixel centre */
        CHECK(o.coverage[y * W + 17] == 1.0f);
    }
    /* uncovered pixels show the exposed, tone-mapped background; half-covered ones the box average */
    CHECK_NEAR(o.image[(10 * W + 3) * 3], tonemap_ref(0.5), 1e-6);
    CHECK_NEAR(o.radiance[(10 * W + 16) * 3], 0.5 * 0.25, 1e-6);
    sp_mesh_free(&m);
    sp_renderer_close(&r);
}

static void test_fill_lights(void)
{
    const int W = 33, H = 33;
    sp_renderer *r = open_renderer(W, H, 1);
    sp_mesh m = facing_quad(0.5, 2);
    float alb[3] = {0.5f, 0.4f, 0.3f};
    sp_render_scene sc;
    quad_scene(&sc, &m, alb, W, H);
    sc.n_lights = 2;
    sc.lights[0] = (sp_render_light){SP_RENDER_LIGHT_DIRECTIONAL, {0, -1, 0}, {1.0, 0.5, 0.25}};
    sc.lights[1] = (sp_render_light){SP_RENDER_LIGHT_POINT, {0, -0.5, 0}, {1.0, 1.0, 1.0}};
    sp_render_outputs o;
    CHECK_EQ_INT(sp_render(r, &sc, &o), 0);
    int p = 16 * W + 16;
    double rgb[3] = {1.0, 0.5, 0.25};
    for (int c = 0; c < 3; c++) /* directional: a/pi E; point at 0.5 m: a/pi * 1 / 0.25 */
        CHECK_NEAR(o.fill[p * 3 + c], (double)alb[c] / PI * (rgb[c] + 4.0), 1e-5);
    CHECK(o.diffuse[p * 3] == 0.0f); /* sun intensity 0 */
    static float dl[33 * 33 * 3];
    sp_render_grads g;
    memset(&g, 0, sizeof(g));
    CHECK_EQ_INT(sp_render_backward(r, &sc, dl, &g), SP_EUNSUPPORTED);
    sp_mesh_free(&m);
    sp_renderer_close(&r);
}

static void test_l2_loss(void)
{
    float img[2 * 3] = {0.5f, 0.2f, 0.1f, 0.9f, 0.3f, 0.0f};
    float tgt[2 * 3] = {0.4f, 0.2f, 0.3f, 0.0f, 0.0f, 0.0f};
    float mask[2] = {1.0f, 0.0f}, g[6];
    double loss;
    CHECK_EQ_INT(sp_render_l2_loss(img, tgt, mask, 2, 1, &loss, g), 0);
    CHECK_NEAR(loss, 0.01 + 0.04, 1e-7);
    CHECK_NEAR(g[0], 0.2, 1e-6);
    CHECK_NEAR(g[2], -0.4, 1e-6);
    CHECK(g[3] == 0.0f && g[4] == 0.0f);
    /* finite difference on one value, no mask */
    CHECK_EQ_INT(sp_render_l2_loss(img, tgt, NULL, 2, 1, &loss, g), 0);
    double h = 1e-3, lp, lm;
    img[1] += (float)h;
    sp_render_l2_loss(img, tgt, NULL, 2, 1, &lp, NULL);
    img[1] -= (float)(2 * h);
    sp_render_l2_loss(img, tgt, NULL, 2, 1, &lm, NULL);
    CHECK_NEAR((lp - lm) / (2 * h), g[1], 1e-4);
    CHECK_EQ_INT(sp_render_l2_loss(NULL, tgt, NULL, 2, 1, &loss, g), -22);
}

/* Renders sc with r into a copy of its image and triangle ids (npix / nsamp entries). */
static void render_copy(sp_renderer *r, const sp_render_scene *sc, float *img, int32_t *ids, size_t npix)
{
    sp_render_outputs o;
    CHECK_EQ_INT(sp_render(r, sc, &o), 0);
    memcpy(img, o.image, npix * 3 * sizeof(float));
    memcpy(ids, o.tri_id, npix * sizeof(int32_t));
}

/* Compares r's render of sc with a fresh renderer's; returns 1 when image and ids are bit-identical. */
static int same_as_fresh(sp_renderer *r, const sp_render_scene *sc, float *img, int32_t *ids, int W, int H)
{
    size_t n = (size_t)W * (size_t)H;
    float *img2 = calloc(n * 3, sizeof(float));
    int32_t *ids2 = calloc(n, sizeof(int32_t));
    CHECK(img2 && ids2);
    sp_renderer *fresh = open_renderer(W, H, 1);
    render_copy(r, sc, img, ids, n);
    render_copy(fresh, sc, img2, ids2, n);
    int same = memcmp(img, img2, n * 3 * sizeof(float)) == 0 && memcmp(ids, ids2, n * sizeof(int32_t)) == 0;
    sp_renderer_close(&fresh);
    free(img2);
    free(ids2);
    return same;
}

/*
 * The renderer keeps mesh-only data (UV copies, coarse normals) while the
 * positions and indices are unchanged: a mesh edited in place between frames
 * (one vertex moved, one UV index changed, then restored) must render exactly
 * like a fresh renderer, and the edits must be visible at all.
 */
static void test_mesh_edited_in_place(void)
{
    const int W = 64, H = 64, T = 32;
    size_t n = (size_t)W * (size_t)H;
    sp_mesh m;
    double c0[3] = {0, 0, 0}, eye[3] = {0.0, -0.5, 0.05}, up[3] = {0, 0, 1};
    CHECK(testmesh_head(&m, 24, 32, c0, 0.08, 0.1, 0.11, 0.2) == 0);
    float *disp = calloc((size_t)T * T, sizeof(float)), alb[3] = {0.6f, 0.5f, 0.4f};
    float *img0 = calloc(n * 3, sizeof(float)), *img = calloc(n * 3, sizeof(float));
    int32_t *ids0 = calloc(n, sizeof(int32_t)), *ids = calloc(n, sizeof(int32_t));
    CHECK(disp && img0 && img && ids0 && ids);
    for (int i = 0; i < T * T; i++)
        disp[i] = (float)(0.004 * sin(0.7 * (double)i));
    sp_render_scene sc;
    sp_render_scene_defaults(&sc);
    sc.camera.fx = sc.camera.fy = 90.0;
    sc.camera.cx = sc.camera.cy = 31.5;
    testmesh_look_at(&sc.camera, eye, c0, up);
    sc.mesh = &m;
    sc.albedo = (sp_render_texture){1, 1, alb};
    sc.displacement = (sp_render_texture){T, T, disp};
    sc.sun_dir[0] = 0.3, sc.sun_dir[1] = -1.0, sc.sun_dir[2] = 0.5;
    sc.sun_intensity = 2.0;
    sp_renderer *r = open_renderer(W, H, 1);
    render_copy(r, &sc, img0, ids0, n);
    uint32_t front = 0; /* the vertex nearest the camera (most negative y) */
    for (uint32_t v = 1; v < m.n_vertices; v++)
        if (m.positions[v * 3 + 1] < m.positions[front * 3 + 1])
            front = v;
    float keep_y = m.positions[front * 3 + 1];
    m.positions[front * 3 + 1] -= 0.02f;
    CHECK(same_as_fresh(r, &sc, img, ids, W, H));
    CHECK(memcmp(img, img0, n * 3 * sizeof(float)) != 0);
    m.positions[front * 3 + 1] = keep_y; /* back to the first mesh: the first frame again, bit for bit */
    render_copy(r, &sc, img, ids, n);
    CHECK(memcmp(img, img0, n * 3 * sizeof(float)) == 0 && memcmp(ids, ids0, n * sizeof(int32_t)) == 0);
    size_t corner = 0; /* a corner of the front vertex gets another vertex's UV: its displacement changes */
    while (m.tri_vertices[corner] != front)
        corner++;
    uint32_t keep_uv = m.tri_uvs[corner];
    m.tri_uvs[corner] = m.tri_uvs[(corner + 3) % ((size_t)m.n_triangles * 3)];
    CHECK(same_as_fresh(r, &sc, img, ids, W, H));
    CHECK(memcmp(img, img0, n * 3 * sizeof(float)) != 0);
    m.tri_uvs[corner] = keep_uv;
    render_copy(r, &sc, img, ids, n);
    CHECK(memcmp(img, img0, n * 3 * sizeof(float)) == 0 && memcmp(ids, ids0, n * sizeof(int32_t)) == 0);
    sp_renderer_close(&r);
    sp_mesh_free(&m);
    free(disp);
    free(img0);
    free(img);
    free(ids0);
    free(ids);
}

int main(void)
{
    test_flat_quad();
    test_point_sun();
    test_sphere_cosine();
    test_cast_shadow();
    test_perspective_uv();
    test_supersample_coverage();
    test_fill_lights();
    test_l2_loss();
    test_mesh_edited_in_place();
    return check_exit();
}
