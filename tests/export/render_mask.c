/* SPDX-License-Identifier: MIT */
/*
 * Reference silhouettes for the viewer test (tests/export/test_viewer.sh).
 *
 *   render_mask FACE_DIR OUT.png [W H DCX DCY YAW_DEG]
 *     renders the face directory's mesh with the project's renderer from
 *     keyframe 0's camera (optionally on a W x H image with the principal point
 *     moved by DCX, DCY pixels and the camera orbited YAW_DEG about the world's
 *     up axis through the mesh centre) and writes the coverage mask (0/255 gray
 *     PNG). Prints the same camera as the viewer's URL query, in the exported
 *     scene (y up, head at the origin).
 *   render_mask iou REF.png SHOT.png MIN
 *     prints the intersection over union of the two masks (> 127 in the first
 *     channel is inside) and exits 1 when it is below MIN or a mask is empty.
 *   render_mask differ A.png B.png MIN
 *     prints the mean absolute RGB difference (0..255) and exits 1 below MIN.
 *   render_mask near A.png B.png MAX
 *     the same, exit 1 above MAX.
 *   render_mask lum FACE_DIR [sun|sky]
 *     prints the mean linear Rec. 709 luminance of keyframe 0's view lit by the
 *     fitted sun and sky (sp_face_asset_render_radiance, before the tone map)
 *     over the pixels the face covers at least half (sun, sky: that light alone).
 *   render_mask lum-shot SHOT.png MASK.png
 *     prints the mean linear luminance of an sRGB screenshot over MASK's pixels.
 *
 * The mesh is rendered undisplaced: the glTF carries displacement only as a
 * normal map, so its silhouette is the undisplaced mesh's.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "export/gltf_internal.h"
#include "export/png.h"
#include "export/png_read.h"
#include "sunprobe/sp_math.h"
#include "sunprobe/sp_render.h"
#include "sunprobe/sp_sunstage.h"

/* Orbits the camera by yaw radians about the world z axis through c. */
static void orbit_camera(sp_render_camera *cam, const double c[3], double yaw)
{
    double q[9] = { cos(yaw), -sin(yaw), 0, sin(yaw), cos(yaw), 0, 0, 0, 1 }, R[9], C0[3], C1[3];
    for (int i = 0; i < 3; i++) /* camera centre -R^T t */
        C0[i] = -(cam->R[i] * cam->t[0] + cam->R[3 + i] * cam->t[1] + cam->R[6 + i] * cam->t[2]) - c[i];
    for (int i = 0; i < 3; i++)
        C1[i] = c[i] + q[i * 3] * C0[0] + q[i * 3 + 1] * C0[1] + q[i * 3 + 2] * C0[2];
    for (int r = 0; r < 3; r++) /* R' = R Q^T */
        for (int k = 0; k < 3; k++)
            R[r * 3 + k] = cam->R[r * 3] * q[k * 3] + cam->R[r * 3 + 1] * q[k * 3 + 1] + cam->R[r * 3 + 2] * q[k * 3 + 2];
    memcpy(cam->R, R, sizeof(R));
    for (int r = 0; r < 3; r++)
        cam->t[r] = -(R[r * 3] * C1[0] + R[r * 3 + 1] * C1[1] + R[r * 3 + 2] * C1[2]);
}

/*
 * The viewer's query: R and t for the exported scene's points g, where the fit
 * world is w = P^T (g - t_P) (P, t_P: the export's placement, gltf_internal.h).
 */
static void print_query(const sp_face_asset *a, const sp_render_camera *c, int w, int h)
{
    sp_gltf_placement p;
    sp_gltf_placement_init(&p, &a->mesh, &a->camera);
    double R[9], t[3];
    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 3; k++) /* R = R_c P^T */
            R[r * 3 + k] = c->R[r * 3] * p.R[k * 3] + c->R[r * 3 + 1] * p.R[k * 3 + 1] + c->R[r * 3 + 2] * p.R[k * 3 + 2];
    for (int r = 0; r < 3; r++)
        t[r] = c->t[r] - (R[r * 3] * p.t[0] + R[r * 3 + 1] * p.t[1] + R[r * 3 + 2] * p.t[2]);
    printf("w=%d&h=%d&fx=%.9g&fy=%.9g&cx=%.9g&cy=%.9g&R=", w, h, c->fx, c->fy, c->cx, c->cy);
    for (int k = 0; k < 9; k++)
        printf("%s%.9g", k ? "," : "", R[k]);
    printf("&t=%.9g,%.9g,%.9g\n", t[0], t[1], t[2]);
}

static int render(const sp_face_asset *a, const sp_render_camera *cam, int w, int h, const char *out)
{
    sp_renderer_settings s;
    sp_renderer_default_settings(&s);
    s.width = w;
    s.height = h;
    s.max_vertices = a->mesh.n_vertices;
    s.max_triangles = a->mesh.n_triangles;
    sp_renderer *r = NULL;
    int ret = sp_renderer_open(&r, &s);
    sp_render_scene sc;
    sp_render_scene_defaults(&sc);
    sc.camera = *cam;
    sc.mesh = &a->mesh;
    sc.albedo = (sp_render_texture){ a->tex_width, a->tex_height, a->albedo };
    sc.shadow_mode = SP_RENDER_SHADOW_OFF;
    sp_render_outputs o;
    if (!ret)
        ret = sp_render(r, &sc, &o);
    uint8_t *m = ret ? NULL : malloc((size_t)w * (size_t)h);
    if (!ret && !m)
        ret = -1;
    for (size_t i = 0; !ret && i < (size_t)w * (size_t)h; i++)
        m[i] = o.coverage[i] >= 0.5f ? 255 : 0;
    if (!ret)
        ret = sp_png_write(out, m, (uint32_t)w, (uint32_t)h, (uint32_t)w, 1);
    free(m);
    sp_renderer_close(&r);
    return ret;
}

static int cmd_render(int argc, char **argv)
{
    sp_face_asset a;
    int ret = sp_face_dir_read(&a, argv[1]);
    if (ret) {
        fprintf(stderr, "render_mask: %s: %s\n", argv[1], sp_strerror(ret));
        return 1;
    }
    sp_render_camera cam = a.camera;
    int w = a.width, h = a.height;
    if (argc == 8) {
        w = atoi(argv[3]);
        h = atoi(argv[4]);
        cam.cx += (w - a.width) * 0.5 + atof(argv[5]);
        cam.cy += (h - a.height) * 0.5 + atof(argv[6]);
        double c[3] = { 0, 0, 0 };
        for (uint32_t i = 0; i < a.mesh.n_vertices; i++)
            for (int k = 0; k < 3; k++)
                c[k] += (double)a.mesh.positions[i * 3 + k] / (double)a.mesh.n_vertices;
        orbit_camera(&cam, c, atof(argv[7]) * M_PI / 180.0);
    }
    ret = w >= 1 && h >= 1 && w <= 4096 && h <= 4096 ? render(&a, &cam, w, h, argv[2]) : -1;
    if (ret)
        fprintf(stderr, "render_mask: rendering %dx%d failed (%d)\n", w, h, ret);
    else
        print_query(&a, &cam, w, h);
    sp_face_asset_free(&a);
    return ret ? 1 : 0;
}

static int cmd_iou(char **argv)
{
    uint8_t *p[2] = { NULL, NULL };
    uint32_t w[2] = { 0, 0 }, h[2] = { 0, 0 };
    for (int k = 0; k < 2; k++)
        if (sp_png_read_rgba(argv[2 + k], &p[k], &w[k], &h[k])) {
            fprintf(stderr, "render_mask: cannot read %s\n", argv[2 + k]);
            free(p[0]);
            return 1;
        }
    size_t both = 0, any = 0, n[2] = { 0, 0 };
    int same = w[0] == w[1] && h[0] == h[1];
    for (size_t i = 0; same && i < (size_t)w[0] * h[0]; i++) {
        int a = p[0][i * 4] > 127, b = p[1][i * 4] > 127;
        both += (size_t)(a && b);
        any += (size_t)(a || b);
        n[0] += (size_t)a;
        n[1] += (size_t)b;
    }
    free(p[0]);
    free(p[1]);
    if (!same) {
        fprintf(stderr, "render_mask: sizes differ: %ux%u vs %ux%u\n", w[0], h[0], w[1], h[1]);
        return 1;
    }
    double iou = any ? (double)both / (double)any : 0.0, min = atof(argv[4]);
    printf("IoU %.4f (reference %zu px, viewer %zu px, %ux%u)\n", iou, n[0], n[1], w[0], h[0]);
    if (!n[0] || !n[1] || n[0] == (size_t)w[0] * h[0]) {
        fprintf(stderr, "render_mask: a mask is empty or full: the face is not in view\n");
        return 1;
    }
    return iou >= min ? 0 : 1;
}

/* Mean absolute difference of two same-sized screenshots (RGB, 0..255); exit 1 below MIN (near: above MAX). */
static int cmd_differ(char **argv, int near)
{
    uint8_t *p[2] = { NULL, NULL };
    uint32_t w[2] = { 0, 0 }, h[2] = { 0, 0 };
    int ok = !sp_png_read_rgba(argv[2], &p[0], &w[0], &h[0]) && !sp_png_read_rgba(argv[3], &p[1], &w[1], &h[1]) &&
             w[0] == w[1] && h[0] == h[1];
    double sum = 0.0, lit = 0.0;
    size_t n = ok ? (size_t)w[0] * h[0] : 0;
    for (size_t i = 0; i < n * 4; i++) {
        if (i % 4 == 3)
            continue;
        sum += abs((int)p[0][i] - (int)p[1][i]);
        lit += p[0][i];
    }
    free(p[0]);
    free(p[1]);
    if (!ok || !n) {
        fprintf(stderr, "render_mask: cannot compare %s and %s\n", argv[2], argv[3]);
        return 1;
    }
    double mean = sum / (3.0 * (double)n);
    printf("mean |difference| %.2f / 255 (first image mean %.2f)\n", mean, lit / (3.0 * (double)n));
    return (near ? mean <= atof(argv[4]) : mean >= atof(argv[4])) ? 0 : 1;
}

static int cmd_lum(const char *dir, const char *part)
{
    static const float black[SP_RENDER_ENV_FLOATS];
    sp_face_asset a;
    if (sp_face_dir_read(&a, dir)) {
        fprintf(stderr, "render_mask: cannot read %s\n", dir);
        return 1;
    }
    sp_face_view v;
    sp_face_view_init(&v, &a);
    if (part && !strcmp(part, "sky"))
        v.sun_intensity = 0.0;
    else if (part && !strcmp(part, "sun"))
        v.env = black;
    size_t n = (size_t)v.width * (size_t)v.height, covered = 0;
    float *rad = malloc(n * 3 * sizeof(float)), *cover = malloc(n * sizeof(float));
    int ret = rad && cover ? sp_face_asset_render_radiance(&a, &v, rad, cover) : -1;
    double sum = 0.0;
    for (size_t i = 0; !ret && i < n; i++)
        if (cover[i] >= 0.5f) {
            sum += 0.2126 * (double)rad[i * 3] + 0.7152 * (double)rad[i * 3 + 1] + 0.0722 * (double)rad[i * 3 + 2];
            covered++;
        }
    free(rad);
    free(cover);
    sp_face_asset_free(&a);
    if (ret || !covered) {
        fprintf(stderr, "render_mask: rendering %s failed or shows no face (%d)\n", dir, ret);
        return 1;
    }
    printf("sunprobe: %dx%d, %zu face pixels\nsunprobe: mean_luminance %.6g\n", v.width, v.height, covered,
           sum / (double)covered);
    return 0;
}

static int cmd_lum_shot(const char *shot, const char *mask)
{
    uint8_t *p[2] = { NULL, NULL };
    uint32_t w[2] = { 0, 0 }, h[2] = { 0, 0 };
    int ok = !sp_png_read_rgba(shot, &p[0], &w[0], &h[0]) && !sp_png_read_rgba(mask, &p[1], &w[1], &h[1]) &&
             w[0] == w[1] && h[0] == h[1];
    double sum = 0.0;
    size_t n = 0;
    for (size_t i = 0; ok && i < (size_t)w[0] * h[0]; i++)
        if (p[1][i * 4] > 127) {
            const uint8_t *c = p[0] + i * 4;
            sum += 0.2126 * sp_srgb_decode(c[0] / 255.0) + 0.7152 * sp_srgb_decode(c[1] / 255.0) +
                   0.0722 * sp_srgb_decode(c[2] / 255.0);
            n++;
        }
    free(p[0]);
    free(p[1]);
    if (!ok || !n) {
        fprintf(stderr, "render_mask: cannot measure %s over %s (sizes, or an empty mask)\n", shot, mask);
        return 1;
    }
    printf("shot: %zu face pixels\nshot: mean_luminance %.6g\n", n, sum / (double)n);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc == 4 && !strcmp(argv[1], "lum-shot"))
        return cmd_lum_shot(argv[2], argv[3]);
    if ((argc == 3 || argc == 4) && !strcmp(argv[1], "lum"))
        return cmd_lum(argv[2], argc == 4 ? argv[3] : NULL);
    if (argc == 5 && !strcmp(argv[1], "iou"))
        return cmd_iou(argv);
    if (argc == 5 && (!strcmp(argv[1], "differ") || !strcmp(argv[1], "near")))
        return cmd_differ(argv, !strcmp(argv[1], "near"));
    if (argc == 3 || argc == 8)
        return cmd_render(argc, argv);
    fprintf(stderr, "usage: render_mask FACE_DIR OUT.png [W H DCX DCY YAW_DEG]\n"
                    "       render_mask iou REF.png SHOT.png MIN\n"
                    "       render_mask differ A.png B.png MIN\n"
                    "       render_mask near A.png B.png MAX\n"
                    "       render_mask lum FACE_DIR [sun|sky]\n"
                    "       render_mask lum-shot SHOT.png MASK.png\n");
    return 2;
}
