/* SPDX-License-Identifier: MIT */
/*
 * Where the exported scene puts things (export/EXPORT.md): the environment
 * map's equirectangular orientation (Blender / three.js), read back from the
 * .hdr; the sun in lux and the sky on the same scale; the scene's nodes (head at
 * the origin, keyframe 0's camera, sun). Uses test_export's fixture face
 * directory, as written and turned about the vertical.
 *
 *   test_export_scene SUNPROBE TEST_EXPORT
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "common/json.h"
#include "export/gltf_internal.h"
#include "export/oiio_shim.h"
#include "sp_config.h"
#include "sunprobe/sp_export.h"
#include "sunprobe/sp_render.h"

#define PI 3.14159265358979323846
#define ENV_W SP_RENDER_ENV_W
#define ENV_H SP_RENDER_ENV_H

static uint8_t *slurp(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    uint8_t *b = NULL;
    long len = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
    if (len > 0 && fseek(f, 0, SEEK_SET) == 0 && (b = malloc((size_t)len)) && fread(b, 1, (size_t)len, f) != (size_t)len) {
        free(b);
        b = NULL;
    }
    fclose(f);
    *n = len > 0 ? (size_t)len : 0;
    return b;
}

static int write_file(const char *path, const void *p, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return -errno;
    int ok = fwrite(p, 1, n, f) == n;
    return fclose(f) == 0 && ok ? 0 : -EIO;
}

/* The fit's texel (row, col) direction, as pipeline/render/envlight.c defines it (fit world, z up). */
static void fit_texel_dir(int row, int col, double d[3])
{
    double theta = (row + 0.5) * PI / ENV_H, phi = (col + 0.5) * 2.0 * PI / ENV_W;
    d[0] = sin(theta) * cos(phi);
    d[1] = sin(theta) * sin(phi);
    d[2] = cos(theta);
}

/* Where Blender and three.js look up direction g (y up): u = 0.5 + atan2(z, x) / 2pi, v from the top. */
static void equirect_pixel(const double g[3], int *row, int *col)
{
    double u = 0.5 + atan2(g[2], g[0]) / (2.0 * PI), v = acos(g[1]) / PI;
    *col = (int)floor(u * ENV_W) % ENV_W;
    *row = (int)floor(v * ENV_H);
}

/* Fit world (z up) -> glTF (y up): (x, y, z) -> (x, z, -y), written out here on purpose. */
static void y_up(const double w[3], double g[3])
{
    g[0] = w[0], g[1] = w[2], g[2] = -w[1];
}

/* The one texel more than 4 times as bright as the dimmest (red channel); -1 if none or several. */
static int bright_texel(const float *rgb)
{
    float lo = rgb[0];
    for (int i = 1; i < ENV_W * ENV_H; i++)
        lo = rgb[i * 3] < lo ? rgb[i * 3] : lo;
    int at = -1;
    for (int i = 0; i < ENV_W * ENV_H; i++)
        if (rgb[i * 3] > 4.0f * lo) {
            if (at >= 0)
                return -1;
            at = i;
        }
    return at;
}

/* Reads a flat (not run-length encoded) Radiance RGBE file of ENV_W x ENV_H into rgb. */
static int read_hdr(const char *path, float *rgb)
{
    size_t n;
    uint8_t *b = slurp(path, &n);
    const char *res = b ? strstr((const char *)b, "\n\n") : NULL;
    int w = 0, h = 0, ret = -1;
    if (res && sscanf(res + 2, "-Y %d +X %d", &h, &w) == 2 && w == ENV_W && h == ENV_H) {
        const uint8_t *p = memchr(res + 2, '\n', n - (size_t)((const uint8_t *)res + 2 - b));
        if (p && (size_t)(p + 1 - b) + (size_t)w * h * 4 == n) {
            for (int i = 0; i < w * h; i++) {
                const uint8_t *e = p + 1 + i * 4;
                double f = e[3] ? ldexp(1.0, e[3] - 136) : 0.0;
                for (int c = 0; c < 3; c++)
                    rgb[i * 3 + c] = (float)((e[c] + 0.5) * f);
            }
            ret = 0;
        }
    }
    free(b);
    return ret;
}

/* The JSON chunk of a .glb (caller frees), NULL if it is not one. */
static sp_json *glb_json(const char *path)
{
    size_t n;
    uint8_t *b = slurp(path, &n);
    uint32_t h[5];
    sp_json *j = NULL;
    char err[128];
    if (b && n >= 20 && (memcpy(h, b, 20), h[0] == 0x46546C67u && h[4] == 0x4E4F534Au && 20 + (size_t)h[3] <= n) &&
        sp_json_parse((const char *)b + 20, h[3], &j, err, sizeof(err)))
        fprintf(stderr, "%s: %s\n", path, err);
    free(b);
    return j;
}

static const sp_json *extras(const sp_json *root)
{
    return sp_json_get(sp_json_get(sp_json_get(root, "asset"), "extras"), "sunprobe");
}

/* The conversion itself: one bright texel per call lands where the convention puts its direction. */
static void check_env_function(void)
{
    double M[9] = { 1, 0, 0, 0, 0, 1, 0, -1, 0 }, c = cos(PI / 2), s = sin(PI / 2), T[9];
    double Ry[9] = { c, 0, s, 0, 1, 0, -s, 0, c }; /* a quarter turn about +y on top of the y-up mapping */
    for (int r = 0; r < 3; r++)
        for (int k = 0; k < 3; k++)
            T[r * 3 + k] = Ry[r * 3] * M[k] + Ry[r * 3 + 1] * M[3 + k] + Ry[r * 3 + 2] * M[6 + k];
    const int texels[][2] = { { 5, 8 }, { 0, 0 }, { 15, 31 }, { 7, 16 }, { 9, 3 } };
    static float env[SP_RENDER_ENV_FLOATS], out[SP_RENDER_ENV_FLOATS];
    for (int rot = 0; rot < 2; rot++) {
        const double *R = rot ? T : M;
        for (size_t k = 0; k < sizeof(texels) / sizeof(texels[0]); k++) {
            int i = texels[k][0], j = texels[k][1], row, col;
            for (int t = 0; t < SP_RENDER_ENV_FLOATS; t++)
                env[t] = 0.25f;
            env[(i * ENV_W + j) * 3] = 9.0f;
            sp_export_env_equirect(env, R, out);
            double d[3], g[3];
            fit_texel_dir(i, j, d);
            for (int a = 0; a < 3; a++)
                g[a] = R[a * 3] * d[0] + R[a * 3 + 1] * d[1] + R[a * 3 + 2] * d[2];
            equirect_pixel(g, &row, &col);
            int at = bright_texel(out);
            CHECK_MSG(at == row * ENV_W + col, "fit texel (%d, %d), rotation %d: at %d, want row %d col %d", i, j,
                      rot, at, row, col);
        }
    }
}

/*
 * The sun in lux in a physical range (EXPORT.md, "Photometry": a sunny fit's 0.25..5
 * fit units give 1e4..2e5 lux; the fixture's 2.5 about 1e5) and the sky in the same
 * scale: sun / sky radiance in the exported files equals the fit's, for a dim and a
 * bright texel. bright: index of the bright texel in hdr (the export's map, read back).
 */
static void check_photometry(const char *face, const char *tmp, const float *hdr, int bright)
{
    sp_face_asset a;
    CHECK(sp_face_dir_read(&a, face) == 0);
    char path[4096];
    snprintf(path, sizeof(path), "%s/env.glb", tmp);
    sp_json *j = glb_json(path);
    const sp_json *light = sp_json_at(sp_json_get(sp_json_get(sp_json_get(j, "extensions"), "KHR_lights_punctual"),
                                                  "lights"), 0);
    double lux = sp_json_number(sp_json_get(light, "intensity"), NAN);
    CHECK_MSG(lux >= 1e4 && lux <= 2e5, "sun %.6g lux", lux);
    CHECK_NEAR(sp_json_number(sp_json_get(extras(j), "lux_per_fit_unit"), NAN) * a.sun_intensity, lux, 1e-6 * lux);
    /* a dim texel (every fit texel but the bright one is 0.25) and the bright one */
    const int fit_at[2] = { 0, 5 * ENV_W + 8 }, out_at[2] = { bright == 0 ? 1 : 0, bright < 0 ? 0 : bright };
    for (int k = 0; k < 2; k++) {
        double fit = a.sun_intensity / (double)a.env[fit_at[k] * 3], out = lux / (double)hdr[out_at[k] * 3];
        CHECK_MSG(fabs(out / fit - 1.0) < 0.01, "sun/sky: exported %.6g, fit %.6g", out, fit);
    }
    sp_json_free(j);
    sp_face_asset_free(&a);
}

/* extras.sunprobe.fit_to_scene of an export: rotation R (row-major) and translation T. */
static int placement(const sp_json *root, double R[9], double T[3])
{
    const sp_json *p = sp_json_get(extras(root), "fit_to_scene");
    return sp_json_numbers(sp_json_get(p, "rotation"), R, 9) == 9 &&
                   sp_json_numbers(sp_json_get(p, "translation"), T, 3) == 3
               ? 0
               : -1;
}

/*
 * The written .hdr: a bright fit texel (row 5, column 8: azimuth 95.6 deg from +x
 * towards +y) lands where the convention puts its direction in the exported frame.
 * turned: the head was turned about the vertical (R from the export's extras);
 * otherwise R must be the plain y-up mapping and the texel lands at row 5, column 7.
 */
/* Where OpenImageIO is built, STEM.env.exr holds the .hdr's map (RGBE keeps 8 bits of mantissa: 1 %). */
static void check_env_exr(const char *tmp, const float *hdr)
{
    char path[4096];
    snprintf(path, sizeof(path), "%s/env.glb", tmp);
    sp_json *j = glb_json(path);
    const char *uri = sp_json_string(sp_json_get(sp_json_get(extras(j), "environment_map"), "exr_uri"), "");
    snprintf(path, sizeof(path), "%s/env.env.exr", tmp);
#if HAVE_OPENIMAGEIO
    float *exr = NULL;
    uint32_t w = 0, h = 0;
    CHECK(!strcmp(uri, "env.env.exr"));
    CHECK(sp_image_read_rgb(path, &exr, &w, &h) == 0 && w == ENV_W && h == ENV_H);
    double worst = 0.0;
    for (int t = 0; exr && w == ENV_W && h == ENV_H && t < SP_RENDER_ENV_FLOATS; t++)
        worst = fmax(worst, fabs((double)exr[t] - (double)hdr[t]) / fmax((double)exr[t], 1e-30));
    CHECK_MSG(exr && worst < 0.01, "the .exr differs from the .hdr by %.3g (relative)", worst);
    free(exr);
#else
    CHECK(!uri[0] && access(path, F_OK) != 0);
#endif
    sp_json_free(j);
}

static void check_env_file(const char *face, const char *tmp, int turned)
{
    static float env[SP_RENDER_ENV_FLOATS], hdr[SP_RENDER_ENV_FLOATS];
    for (int t = 0; t < SP_RENDER_ENV_FLOATS; t++)
        env[t] = 0.25f;
    env[(5 * ENV_W + 8) * 3] = env[(5 * ENV_W + 8) * 3 + 1] = env[(5 * ENV_W + 8) * 3 + 2] = 9.0f;
    char path[4096];
    snprintf(path, sizeof(path), "%s/env.f32", face);
    CHECK(write_file(path, env, sizeof(env)) == 0);
    sp_export_settings s;
    sp_export_default_settings(&s);
    s.draco = 0;
    snprintf(path, sizeof(path), "%s/env.glb", tmp);
    CHECK(sp_export_face(face, path, &s, NULL) == 0);
    sp_json *j = glb_json(path);
    double R[9], T[3], d[3], g[3];
    CHECK(placement(j, R, T) == 0);
    sp_json_free(j);
    snprintf(path, sizeof(path), "%s/env.env.hdr", tmp);
    CHECK(read_hdr(path, hdr) == 0);
    int row, col;
    fit_texel_dir(5, 8, d);
    const double M[9] = { 1, 0, 0, 0, 0, 1, 0, -1, 0 };
    if (turned) {
        for (int a = 0; a < 3; a++)
            g[a] = R[a * 3] * d[0] + R[a * 3 + 1] * d[1] + R[a * 3 + 2] * d[2];
    } else {
        y_up(d, g);
        for (int k = 0; k < 9; k++)
            CHECK_NEAR(R[k], M[k], 1e-12);
    }
    equirect_pixel(g, &row, &col);
    CHECK(turned || (row == 5 && col == 7)); /* u = 0.5 - 95.6 / 360 */
    int at = bright_texel(hdr);
    CHECK_MSG(at == row * ENV_W + col, "bright texel at %d (row %d col %d), want row %d col %d", at,
              at / ENV_W, at % ENV_W, row, col);
    check_photometry(face, tmp, hdr, at);
    check_env_exr(tmp, hdr);
}

/* Turns the fixture about the fit world's vertical by theta: the mesh and keyframe 0's camera (which looks at it). */
static void turn_fixture(const char *face, double theta)
{
    char path[4096];
    snprintf(path, sizeof(path), "%s/mesh.bin", face);
    size_t n;
    uint8_t *b = slurp(path, &n);
    uint32_t nv = 0;
    if (b && n >= 20)
        memcpy(&nv, b + 8, 4);
    CHECK(b && 20 + (size_t)nv * 12 <= n);
    for (uint32_t i = 0; b && 20 + (size_t)nv * 12 <= n && i < nv; i++) {
        float p[3];
        memcpy(p, b + 20 + (size_t)i * 12, 12);
        double x = (double)p[0], y = (double)p[1];
        p[0] = (float)(cos(theta) * x - sin(theta) * y);
        p[1] = (float)(sin(theta) * x + cos(theta) * y);
        memcpy(b + 20 + (size_t)i * 12, p, 12);
    }
    CHECK(b && write_file(path, b, n) == 0);
    free(b);
    /* camera-to-world = Rz(theta) Rx(-90 deg): looking along the turned world +y, z up */
    double c = sqrt(0.5), cz = cos(theta / 2), sz = sin(theta / 2);
    char cams[512];
    int len = snprintf(cams, sizeof(cams), "{\"frames\":[{\"sequence\":0,\"timestamp_ns\":0,\"heldout\":false,"
                       "\"width\":160,\"height\":120,\"intrinsics\":[250,260,79.5,59.5],"
                       "\"camera_to_world_wxyz\":[%.9f,%.9f,%.9f,%.9f]}]}\n", cz * c, -cz * c, -sz * c, sz * c);
    snprintf(path, sizeof(path), "%s/cameras.json", face);
    CHECK(write_file(path, cams, (size_t)len) == 0);
}

static const sp_json *node_named(const sp_json *root, const char *name, int *index)
{
    const sp_json *nodes = sp_json_get(root, "nodes"), *n;
    for (size_t i = 0; (n = sp_json_at(nodes, i)); i++)
        if (!strcmp(sp_json_string(sp_json_get(n, "name"), ""), name)) {
            *index = (int)i;
            return n;
        }
    return NULL;
}

/* Column k of the rotation of quaternion q = (x, y, z, w). */
static void quat_axis(const double q[4], int k, double v[3])
{
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double m[9] = { 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                    2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                    2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y) };
    for (int r = 0; r < 3; r++)
        v[r] = m[r * 3 + k];
}

/*
 * A scene: nodes head (the mesh), camera, sun, all in the scene; the head's
 * bounding box centred on the origin; y up (fit z -> +y); keyframe 0's camera
 * in front of the face on +z (within half an environment column, 5.625 deg),
 * looking at the head (its centre inside the field of view), with the face
 * directory's yfov and aspect; the sun node turned with the scene.
 */
static void check_scene(const char *face, const char *tmp, const char *name)
{
    sp_face_asset a;
    CHECK(sp_face_dir_read(&a, face) == 0);
    sp_export_settings s;
    sp_export_default_settings(&s);
    s.draco = 0;
    char path[4096];
    snprintf(path, sizeof(path), "%s/%s.glb", tmp, name);
    CHECK(sp_export_face(face, path, &s, NULL) == 0);
    sp_json *j = glb_json(path);
    int ih = -1, ic = -1, is = -1;
    const sp_json *head = node_named(j, "head", &ih), *cam = node_named(j, "camera", &ic),
                  *sun = node_named(j, "sun", &is), *scene = sp_json_get(sp_json_at(sp_json_get(j, "scenes"), 0), "nodes");
    CHECK(head && cam && sun && sp_json_get(j, "nodes")->count == 3 && scene && scene->count == 3);
    double nodes[3];
    CHECK(sp_json_numbers(scene, nodes, 3) == 3 && nodes[0] + nodes[1] + nodes[2] == 3.0 && ih + ic + is == 3);
    CHECK(sp_json_number(sp_json_get(head, "mesh"), -1) == 0 && !sp_json_get(head, "translation") &&
          !sp_json_get(head, "rotation"));
    const sp_json *acc = sp_json_at(sp_json_get(j, "accessors"), 0);
    double lo[3], hi[3], R[9], T[3];
    CHECK(sp_json_numbers(sp_json_get(acc, "min"), lo, 3) == 3 && sp_json_numbers(sp_json_get(acc, "max"), hi, 3) == 3);
    for (int k = 0; k < 3; k++)
        CHECK_MSG(fabs(lo[k] + hi[k]) < 2e-6, "%s: box centre %d at %.3g m", name, k, 0.5 * (lo[k] + hi[k]));
    CHECK(placement(j, R, T) == 0);
    CHECK_NEAR(R[2], 0.0, 1e-12); /* fit +z is +y */
    CHECK_NEAR(R[5], 1.0, 1e-12);
    CHECK_NEAR(R[8], 0.0, 1e-12);

    double q[4], eye[3], back[3], to_head[3], len = 0.0;
    CHECK(sp_json_numbers(sp_json_get(cam, "rotation"), q, 4) == 4);
    CHECK(sp_json_numbers(sp_json_get(cam, "translation"), eye, 3) == 3);
    quat_axis(q, 2, back); /* glTF cameras look along their -z */
    for (int k = 0; k < 3; k++)
        len += eye[k] * eye[k];
    len = sqrt(len);
    double cosang = 0.0;
    for (int k = 0; k < 3; k++) {
        to_head[k] = -eye[k] / len;
        cosang += -back[k] * to_head[k];
    }
    const sp_json *persp = sp_json_get(sp_json_at(sp_json_get(j, "cameras"), 0), "perspective");
    double yfov = sp_json_number(sp_json_get(persp, "yfov"), 0), aspect = sp_json_number(sp_json_get(persp, "aspectRatio"), 0);
    CHECK_NEAR(yfov, 2.0 * atan(0.5 * a.height / a.camera.fy), 1e-7); /* 9 digits in the JSON */
    CHECK_NEAR(aspect, (double)a.width * a.camera.fy / ((double)a.height * a.camera.fx), 1e-7);
    const sp_json *size = sp_json_get(sp_json_get(sp_json_at(sp_json_get(j, "cameras"), 0), "extras"), "sunprobe");
    CHECK(sp_json_number(sp_json_get(size, "image_width"), 0) == a.width &&
          sp_json_number(sp_json_get(size, "image_height"), 0) == a.height);
    CHECK_MSG(acos(fmin(cosang, 1.0)) < 0.5 * yfov, "%s: the head is %.1f deg off the camera's axis (half fov %.1f)",
              name, acos(fmin(cosang, 1.0)) * 180 / PI, 0.5 * yfov * 180 / PI);
    double az = atan2(eye[0], eye[2]) * 180 / PI;
    CHECK_MSG(fabs(az) <= 180.0 / ENV_W + 1e-9 && len > 0.1, "%s: camera at azimuth %.2f deg from +z", name, az);

    double sq[4], sun_axis[3], n = sqrt(a.sun_dir[0] * a.sun_dir[0] + a.sun_dir[1] * a.sun_dir[1] + a.sun_dir[2] * a.sun_dir[2]);
    CHECK(sp_json_numbers(sp_json_get(sun, "rotation"), sq, 4) == 4);
    quat_axis(sq, 2, sun_axis); /* the light shines along its -z: +z points at the sun */
    for (int r = 0; r < 3; r++)
        CHECK_NEAR(sun_axis[r], (R[r * 3] * a.sun_dir[0] + R[r * 3 + 1] * a.sun_dir[1] + R[r * 3 + 2] * a.sun_dir[2]) / n,
                   1e-6);
    sp_json_free(j);
    sp_face_asset_free(&a);
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: test_export_scene SUNPROBE TEST_EXPORT\n");
        return 99;
    }
    sp_log_set_level(SP_LOG_ERROR);
    char tmp[] = "/tmp/sp-scene-XXXXXX", face[64], cmd[8192];
    CHECK(mkdtemp(tmp) != NULL);
    snprintf(face, sizeof(face), "%s/face", tmp);
    snprintf(cmd, sizeof(cmd), "'%s' '%s' fixture '%s'", argv[2], argv[1], face);
    if (system(cmd) != 0) {
        fprintf(stderr, "cannot make the fixture: %s\n", cmd);
        return 99;
    }
    check_env_function();
    /* keyframe 0 as the fit writes it: at the origin, looking along world +y at the face */
    turn_fixture(face, 0.0);
    check_env_file(face, tmp, 0);
    check_scene(face, tmp, "front");
    turn_fixture(face, 100.0 * PI / 180.0); /* not a whole number of environment columns */
    check_env_file(face, tmp, 1);
    check_scene(face, tmp, "turned");
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", tmp);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", tmp);
    return check_exit();
}
