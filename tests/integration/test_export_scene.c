/* SPDX-License-Identifier: MIT */
/*
 * Where the exported scene puts things (export/EXPORT.md): the environment
 * map's equirectangular orientation (Blender / three.js), read back from the
 * .hdr; the sun in lux and the sky on the same scale. Uses test_export's
 * fixture face directory.
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

/* The written .hdr: a fit-world direction near +y (away from keyframe 0's camera) lands at column 7, row 5. */
static void check_env_file(const char *face, const char *tmp)
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
    snprintf(path, sizeof(path), "%s/env.env.hdr", tmp);
    CHECK(read_hdr(path, hdr) == 0);
    double d[3], g[3];
    int row, col;
    fit_texel_dir(5, 8, d);
    y_up(d, g);
    equirect_pixel(g, &row, &col);
    CHECK(row == 5 && col == 7); /* azimuth 95.6 deg from +x towards +y: u = 0.5 - 95.6 / 360 */
    int at = bright_texel(hdr);
    CHECK_MSG(at == row * ENV_W + col, "bright texel at %d (row %d col %d), want row %d col %d", at,
              at / ENV_W, at % ENV_W, row, col);
    check_photometry(face, tmp, hdr, at);
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
    check_env_file(face, tmp);
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", tmp);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", tmp);
    return check_exit();
}
