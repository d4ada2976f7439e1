/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe relight`'s files: environment maps read and resampled to the renderer's 16 x 32 map, the
 * image written as PNG (the capture's encoding), OpenEXR or PFM (linear), and the --passes directory.
 */
#include "relight.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cmd.h"
#include "common/file_util.h"
#include "common/pixconv.h"
#include "export/oiio_shim.h"
#include "export/png.h"
#include "export/probe_dir.h"
#include "sp_config.h"

int relight_ends_with(const char *s, const char *tail)
{
    size_t n = strlen(s), m = strlen(tail);
    return n >= m && !strcmp(s + n - m, tail);
}

static int read_raw_env(const char *path, float *env)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        int e = errno;
        fprintf(stderr, "sunprobe relight: --env %s: %s\n", path, strerror(e));
        return -e;
    }
    size_t n = fread(env, sizeof(float), SP_RENDER_ENV_FLOATS, f);
    int extra = fgetc(f) != EOF;
    fclose(f);
    if (n != SP_RENDER_ENV_FLOATS || extra) {
        fprintf(stderr, "sunprobe relight: --env %s: a raw map is 16x32x3 float32 (6144 bytes)\n", path);
        return SP_EFORMAT;
    }
    return 0;
}

/*
 * An equirectangular image (w x h, z up, row 0 straight up, u = azimuth / 2 pi from +x towards +y)
 * into the renderer's 16 x 32 map, turned by rot radians of azimuth: each texel the solid-angle
 * weighted mean of the pixels whose centres fall in it, or for a map coarser than that the pixel at
 * the texel's centre.
 */
static void resample_env(const float *px, uint32_t w, uint32_t h, double rot, float *env)
{
    double acc[SP_RENDER_ENV_FLOATS] = { 0 }, wsum[SP_RENDER_ENV_H * SP_RENDER_ENV_W] = { 0 };
    for (uint32_t y = 0; y < h; y++) {
        double theta = ((double)y + 0.5) / h * M_PI, sw = sin(theta);
        int row = (int)(theta / M_PI * SP_RENDER_ENV_H);
        row = row >= SP_RENDER_ENV_H ? SP_RENDER_ENV_H - 1 : row;
        for (uint32_t x = 0; x < w; x++) {
            double phi = fmod(((double)x + 0.5) / w * 2.0 * M_PI + rot, 2.0 * M_PI);
            phi = phi < 0.0 ? phi + 2.0 * M_PI : phi;
            int col = (int)(phi / (2.0 * M_PI) * SP_RENDER_ENV_W) % SP_RENDER_ENV_W;
            size_t t = (size_t)row * SP_RENDER_ENV_W + (size_t)col;
            for (int k = 0; k < 3; k++)
                acc[t * 3 + (size_t)k] += sw * (double)px[((size_t)y * w + x) * 3 + (size_t)k];
            wsum[t] += sw;
        }
    }
    for (int row = 0; row < SP_RENDER_ENV_H; row++)
        for (int col = 0; col < SP_RENDER_ENV_W; col++) {
            size_t t = (size_t)row * SP_RENDER_ENV_W + (size_t)col;
            if (wsum[t] > 0.0) {
                for (int k = 0; k < 3; k++)
                    env[t * 3 + (size_t)k] = (float)(acc[t * 3 + (size_t)k] / wsum[t]);
                continue;
            }
            double phi = fmod(((double)col + 0.5) / SP_RENDER_ENV_W * 2.0 * M_PI - rot + 4.0 * M_PI, 2.0 * M_PI);
            uint32_t x = (uint32_t)(phi / (2.0 * M_PI) * w) % w;
            uint32_t y = (uint32_t)(((double)row + 0.5) / SP_RENDER_ENV_H * h);
            y = y >= h ? h - 1 : y;
            for (int k = 0; k < 3; k++)
                env[t * 3 + (size_t)k] = px[((size_t)y * w + x) * 3 + (size_t)k];
        }
}

/* --env: raw .f32 or an equirectangular image; refuses other aspects, negative and non-finite light. */
int relight_read_env(const relight_args *a, float *env)
{
    int ret;
    if (relight_ends_with(a->env, ".f32")) {
        if ((ret = read_raw_env(a->env, env)))
            return ret;
        if (a->env_rotate != 0.0) { /* a raw map is an equirectangular image too */
            float raw[SP_RENDER_ENV_FLOATS];
            memcpy(raw, env, sizeof(raw));
            resample_env(raw, SP_RENDER_ENV_W, SP_RENDER_ENV_H, a->env_rotate * M_PI / 180.0, env);
        }
    } else {
        if (access(a->env, R_OK) != 0) {
            int e = errno;
            fprintf(stderr, "sunprobe relight: --env %s: %s\n", a->env, strerror(e));
            return -e;
        }
#if HAVE_OPENIMAGEIO
        float *px = NULL;
        uint32_t w = 0, h = 0;
        if ((ret = sp_image_read_rgb(a->env, &px, &w, &h))) {
            fprintf(stderr, "sunprobe relight: --env %s: not readable as an image: %s\n", a->env, sp_strerror(ret));
            return ret;
        }
        if (w != 2 * h) {
            fprintf(stderr, "sunprobe relight: --env %s is %ux%u: an equirectangular map is twice as wide as tall\n",
                    a->env, w, h);
            free(px);
            return SP_EFORMAT;
        }
        resample_env(px, w, h, a->env_rotate * M_PI / 180.0, env);
        free(px);
#else
        fprintf(stderr, "sunprobe relight: --env %s: this build reads only raw .f32 maps (no OpenImageIO)\n", a->env);
        return SP_EDISABLED;
#endif
    }
    for (int i = 0; i < SP_RENDER_ENV_FLOATS; i++)
        if (!isfinite(env[i]) || env[i] < 0.0f) {
            fprintf(stderr, "sunprobe relight: --env %s: a negative or non-finite radiance\n", a->env);
            return SP_ECORRUPT;
        }
    return 0;
}

/* RGBA of linear light in the capture's encoding: sRGB (clipped) for an sRGB capture, else the fit's tone map. */
void relight_encode(const relight_ctx *c, const float *radiance, const float *cover, size_t n, double exposure,
                    uint8_t *px)
{
    for (size_t i = 0; i < n; i++) {
        for (int k = 0; k < 3; k++) {
            double x = exposure * (double)radiance[i * 3 + (size_t)k];
            double d = c->srgb ? (x >= 1.0 ? 1.0 : (x > 0.0 ? sp_srgb_encode(x) : 0.0))
                               : sp_sunstage_linear_to_display(x);
            px[i * 4 + (size_t)k] = (uint8_t)lround(255.0 * fmin(1.0, fmax(0.0, d)));
        }
        px[i * 4 + 3] = (uint8_t)lround(255.0 * fmin(1.0, fmax(0.0, (double)cover[i])));
    }
}

static int write_png(const relight_ctx *c, const float *radiance, const float *cover, int W, int H, double exposure)
{
    size_t n = (size_t)W * (size_t)H;
    uint8_t *px = malloc(n * 4);
    if (!px)
        return -ENOMEM;
    relight_encode(c, radiance, cover, n, exposure, px);
    int ret = sp_png_write(c->a->out, px, (uint32_t)W, (uint32_t)H, (uint32_t)W * 4, 4);
    free(px);
    return ret;
}

/* Linear light times exposure, with the coverage as a fourth channel when alpha is set. */
static float *linear_pixels(const float *radiance, const float *cover, size_t n, double exposure, int alpha)
{
    int ch = alpha ? 4 : 3;
    float *px = malloc(sizeof(float) * (size_t)ch * n);
    for (size_t i = 0; px && i < n; i++) {
        for (int k = 0; k < 3; k++)
            px[i * (size_t)ch + (size_t)k] = (float)(exposure * (double)radiance[i * 3 + (size_t)k]);
        if (alpha)
            px[i * 4 + 3] = cover[i];
    }
    return px;
}

int relight_write_image(const relight_ctx *c, const float *radiance, const float *cover, int W, int H,
                        double exposure)
{
    const char *out = c->a->out;
    int exr = relight_ends_with(out, ".exr"), pfm = relight_ends_with(out, ".pfm");
    if (!exr && !pfm)
        return write_png(c, radiance, cover, W, H, exposure);
    size_t n = (size_t)W * (size_t)H;
    float *px = linear_pixels(radiance, cover, n, exposure, exr);
    if (!px)
        return -ENOMEM;
#if HAVE_OPENIMAGEIO
    int ret = exr ? sp_exr_write(out, px, (uint32_t)W, (uint32_t)H, 4) : sp_pfm_write(out, px, (uint32_t)W, (uint32_t)H, 3);
#else
    int ret = exr ? SP_EDISABLED : sp_pfm_write(out, px, (uint32_t)W, (uint32_t)H, 3); /* refused before any work */
#endif
    free(px);
    return ret;
}

static const struct {
    const char *name, *what;
    int channels, lit; /* lit: light, scaled by the exposure */
} passes[PASS_COUNT] = {
    { "beauty", "diffuse + specular + ambient of the head (premultiplied by alpha)", 3, 1 },
    { "diffuse", "sun and fill lights, Lambert, shadowed", 3, 1 },
    { "specular", "sun and fill lights, Blinn-Phong, shadowed", 3, 1 },
    { "ambient", "the sky (environment), Lambert", 3, 1 },
    { "visibility", "the sun's visibility in [0, 1] (1 = lit), times alpha", 1, 0 },
    { "normal", "world shading normal xyz (z up), times alpha", 3, 0 },
    { "albedo", "linear albedo as sampled, times alpha", 3, 0 },
    { "alpha", "the head's coverage of each pixel", 1, 0 },
    { "face", "the face's coverage: the skin and eyes the fit observed (its mask)", 1, 0 },
};

int relight_pass_channels(int pass)
{
    return passes[pass].channels;
}

static int write_pass(const char *dir, int k, const float *v, int W, int H, double exposure)
{
    size_t n = (size_t)W * (size_t)H * (size_t)passes[k].channels;
    float *px = malloc(sizeof(float) * n);
    char name[64];
    if (!px)
        return -ENOMEM;
    for (size_t i = 0; i < n; i++)
        px[i] = passes[k].lit ? (float)(exposure * (double)v[i]) : v[i];
    snprintf(name, sizeof(name), "%s.pfm", passes[k].name);
    char *path = sp_path_join_alloc(dir, name);
    int ret = path ? sp_pfm_write(path, px, (uint32_t)W, (uint32_t)H, passes[k].channels) : -ENOMEM;
#if HAVE_OPENIMAGEIO
    snprintf(name, sizeof(name), "%s.exr", passes[k].name);
    free(path);
    path = ret ? NULL : sp_path_join_alloc(dir, name);
    if (!ret)
        ret = path ? sp_exr_write(path, px, (uint32_t)W, (uint32_t)H, passes[k].channels) : -ENOMEM;
#endif
    free(path);
    free(px);
    return ret;
}

int relight_write_passes(const char *dir, float *const pass[PASS_COUNT], int W, int H, double exposure)
{
    int ret = 0;
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"width\":%d,\"height\":%d,\"exposure\":%.17g,\"formats\":[\"pfm\"%s],\"passes\":[", W, H,
                     exposure, HAVE_OPENIMAGEIO ? ",\"exr\"" : "");
    for (int k = 0; k < PASS_COUNT && !ret; k++) {
        ret = write_pass(dir, k, pass[k], W, H, exposure);
        sp_strbuf_printf(&b, "%s\n {\"name\":\"%s\",\"channels\":%d,\"exposed\":%s,\"what\":\"%s\"}", k ? "," : "",
                         passes[k].name, passes[k].channels, passes[k].lit ? "true" : "false", passes[k].what);
    }
    sp_strbuf_printf(&b, "]}\n");
    char *path = sp_path_join_alloc(dir, "passes.json");
    if (!ret)
        ret = !path || b.failed || !b.data ? -ENOMEM : sp_write_whole_file_atomic(path, b.data, b.len);
    free(path);
    sp_strbuf_free(&b);
    return ret;
}
