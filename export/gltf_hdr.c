/* SPDX-License-Identifier: MIT */
/*
 * The environment map for export: resampled into the equirectangular layout of
 * Blender and three.js in the exported frame, and written as Radiance RGBE (.hdr)
 * with flat (not run-length encoded) scanlines.
 */
#include "export/gltf_internal.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>

#include "common/atomic_file.h"
#include "common/file_util.h"
#include "sunprobe/sp_render.h"

#define PI 3.14159265358979323846

/* Texel of the fit's map (renderer convention, envlight.c) holding fit-world direction w (unit). */
static size_t fit_texel(const double w[3])
{
    double theta = acos(w[2] > 1.0 ? 1.0 : w[2] < -1.0 ? -1.0 : w[2]), phi = atan2(w[1], w[0]);
    int row = (int)floor(theta / PI * SP_RENDER_ENV_H), col = (int)floor(phi / (2.0 * PI) * SP_RENDER_ENV_W);
    row = row < 0 ? 0 : row >= SP_RENDER_ENV_H ? SP_RENDER_ENV_H - 1 : row;
    col = ((col % SP_RENDER_ENV_W) + SP_RENDER_ENV_W) % SP_RENDER_ENV_W;
    return (size_t)row * SP_RENDER_ENV_W + (size_t)col;
}

void sp_export_env_equirect(const float *env, const double R[9], float *out)
{
    for (int i = 0; i < SP_RENDER_ENV_H; i++) {
        for (int j = 0; j < SP_RENDER_ENV_W; j++) {
            /* Blender/three.js: u = 0.5 + atan2(z, x) / 2pi, row 0 = +y (straight up) */
            double theta = ((double)i + 0.5) * PI / SP_RENDER_ENV_H;
            double az = (((double)j + 0.5) / SP_RENDER_ENV_W - 0.5) * 2.0 * PI;
            double g[3] = { sin(theta) * cos(az), cos(theta), sin(theta) * sin(az) }, w[3];
            for (int k = 0; k < 3; k++) /* R^T g: the exported frame back to the fit's world */
                w[k] = R[k] * g[0] + R[3 + k] * g[1] + R[6 + k] * g[2];
            size_t src = fit_texel(w), dst = (size_t)i * SP_RENDER_ENV_W + (size_t)j;
            for (int c = 0; c < 3; c++)
                out[dst * 3 + c] = env[src * 3 + c];
        }
    }
}

/* Shared-exponent encoding of one linear RGB texel; negative and non-finite values become 0. */
static void rgbe(const float *rgb, unsigned char out[4])
{
    double c[3], m = 0.0;
    for (int k = 0; k < 3; k++) {
        c[k] = isfinite(rgb[k]) && rgb[k] > 0.0f ? (double)rgb[k] : 0.0;
        m = c[k] > m ? c[k] : m;
    }
    if (m < 1e-32) {
        out[0] = out[1] = out[2] = out[3] = 0;
        return;
    }
    if (m > 1e38)
        m = 1e38;
    int e;
    double scale = frexp(m, &e) * 256.0 / m; /* m = f * 2^e, f in [0.5, 1) */
    for (int k = 0; k < 3; k++) {
        double v = (c[k] > m ? m : c[k]) * scale;
        out[k] = (unsigned char)(v >= 255.0 ? 255.0 : v);
    }
    out[3] = (unsigned char)(e + 128);
}

int sp_hdr_write(const char *path, const float *rgb, int width, int height)
{
    if (!path || !rgb || width < 1 || height < 1)
        return -EINVAL;
    sp_atomic_file af;
    int ret = sp_atomic_file_open(&af, path);
    if (ret)
        return ret;
    if (fprintf(af.file, "#?RADIANCE\n# sunprobe environment map, equirectangular\nFORMAT=32-bit_rle_rgbe\n\n"
                         "-Y %d +X %d\n", height, width) < 0)
        ret = sp_write_error();
    for (size_t i = 0; !ret && i < (size_t)width * (size_t)height; i++) {
        unsigned char px[4];
        rgbe(rgb + i * 3, px);
        if (fwrite(px, 1, 4, af.file) != 4)
            ret = sp_write_error();
    }
    return sp_atomic_file_finish(&af, ret);
}
