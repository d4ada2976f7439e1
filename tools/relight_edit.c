/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe relight`'s edits of the picture: a background (the face's own frame of the capture, or any
 * image) the head is composited into, and paint over the albedo in UV space.
 */
#include "relight.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "capture_open.h"
#include "cmd.h"
#include "common/file_util.h"
#include "common/pixconv.h"
#include "export/oiio_shim.h"
#include "export/png_read.h"
#include "sp_config.h"
#include "sunprobe/sp_capture.h"

/* Keyframe N's frame of --capture, decoded to linear RGB into c->bg; 0 or an exit code (message printed). */
int relight_read_background(relight_ctx *c)
{
    const relight_args *a = c->a;
    const sp_json *kf = sp_json_at(sp_json_get(c->cams, "frames"), (size_t)a->background_keyframe);
    double seq = sp_json_number(sp_json_get(kf, "sequence"), -1.0);
    if (!kf || !(seq >= 0.0)) {
        fprintf(stderr, "sunprobe relight: --background capture:%d: %s/cameras.json has no such keyframe with a "
                        "\"sequence\"\n", a->background_keyframe, a->dir);
        return SP_EXIT_USAGE;
    }
    double crop[2];
    if (sp_json_numbers(sp_json_get(kf, "crop_origin"), crop, 2) == 2)
        memcpy(c->bg_crop, crop, sizeof(crop));
    sp_capture_reader *r = NULL;
    int ret = sp_tool_open_capture("relight", a->capture, 0, &r);
    if (ret)
        return ret;
    sp_chunk ch;
    int rc, found = 0;
    while (!found && (rc = sp_capture_reader_next(r, &ch)) == 0) {
        sp_frame_chunk fc;
        if (ch.type != SP_CHUNK_FRAME || sp_chunk_parse_frame(&ch, &fc) || (double)fc.sequence != seq)
            continue;
        double ts = sp_json_number(sp_json_get(kf, "timestamp_ns"), NAN);
        if (isfinite(ts) && fabs((double)ch.timestamp_ns - ts) > 1e3) {
            fprintf(stderr, "sunprobe relight: %s: frame %.0f is at %lld ns, keyframe %d of %s at %.0f ns: not the "
                            "fitted capture\n", a->capture, seq, (long long)ch.timestamp_ns, a->background_keyframe,
                    a->dir, ts);
            sp_capture_reader_close(&r);
            return SP_EXIT_BAD_INPUT;
        }
        found = 1;
        size_t n = (size_t)fc.width * fc.height * 3;
        uint8_t *rgb = malloc(n);
        sp_pixconv_src src = { fc.format, fc.width, fc.height, fc.stride, fc.data, fc.data_size };
        rc = rgb ? sp_pixconv_to_rgb24(&src, rgb, n, fc.width * 3) : -ENOMEM;
        c->bg = rc ? NULL : malloc(sizeof(float) * n);
        rc = rc ? rc : (c->bg ? 0 : -ENOMEM);
        for (size_t i = 0; !rc && i < n; i++) { /* the frame's own encoding back to linear light */
            /* a "sunprobe" frame holds the fit's tone map: back through sRGB (clipped at 1, as a camera) */
            double b = rgb[i] / 255.0;
            c->bg[i] = (float)sp_srgb_decode(c->srgb ? b : sp_sunstage_display_to_srgb(b));
        }
        free(c->bg_raw);
        c->bg_raw = rgb; /* as decoded, for the panel's input tile */
        c->bg_w = fc.width;
        c->bg_h = fc.height;
        c->bg_is_capture = 1;
        if (rc) {
            fprintf(stderr, "sunprobe relight: %s: frame %.0f: %s\n", a->capture, seq, sp_strerror(rc));
            sp_capture_reader_close(&r);
            return sp_exit_for_error(rc);
        }
    }
    sp_capture_reader_close(&r);
    if (!found) {
        fprintf(stderr, "sunprobe relight: %s has no frame %.0f (keyframe %d of %s): not the fitted capture?\n",
                a->capture, seq, a->background_keyframe, a->dir);
        return SP_EXIT_BAD_INPUT;
    }
    return 0;
}

/* out = the (2R+1)-wide box mean of in along x (vertical 0) or y (1), clamped at the borders. */
static void box_blur(const float *in, float *out, int W, int H, int R, int vertical)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double s = 0.0;
            for (int d = -R; d <= R; d++) {
                int xx = vertical ? x : (x + d < 0 ? 0 : (x + d >= W ? W - 1 : x + d));
                int yy = vertical ? (y + d < 0 ? 0 : (y + d >= H ? H - 1 : y + d)) : y;
                s += (double)in[(size_t)yy * (size_t)W + (size_t)xx];
            }
            out[(size_t)y * (size_t)W + (size_t)x] = (float)(s / (2 * R + 1));
        }
}

/* out = the minimum of in over the (2R+1)^2 box, 0 outside the picture. */
static void erode(const float *in, float *out, int W, int H, int R)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            float m = 1.0f;
            for (int dy = -R; dy <= R; dy++)
                for (int dx = -R; dx <= R; dx++) {
                    int xx = x + dx, yy = y + dy;
                    float v = xx < 0 || yy < 0 || xx >= W || yy >= H ? 0.0f : in[(size_t)yy * (size_t)W + (size_t)xx];
                    m = v < m ? v : m;
                }
            out[(size_t)y * (size_t)W + (size_t)x] = m;
        }
}

/* The background at output pixel (x, y) of a W x H picture: bilinear in c->bg, pixel centres aligned. */
static void background_at(const relight_ctx *c, int x, int y, int W, int H, double out[3])
{
    double fx = ((double)x + 0.5) * c->bg_w / W - 0.5, fy = ((double)y + 0.5) * c->bg_h / H - 0.5;
    fx = fmin(fmax(fx, 0.0), (double)c->bg_w - 1.0);
    fy = fmin(fmax(fy, 0.0), (double)c->bg_h - 1.0);
    uint32_t x0 = (uint32_t)fx, y0 = (uint32_t)fy;
    uint32_t x1 = x0 + 1 < c->bg_w ? x0 + 1 : x0, y1 = y0 + 1 < c->bg_h ? y0 + 1 : y0;
    double ax = fx - x0, ay = fy - y0;
    for (int k = 0; k < 3; k++) {
        const float *b = c->bg + (size_t)k;
        double b00 = b[((size_t)y0 * c->bg_w + x0) * 3], b01 = b[((size_t)y0 * c->bg_w + x1) * 3];
        double b10 = b[((size_t)y1 * c->bg_w + x0) * 3], b11 = b[((size_t)y1 * c->bg_w + x1) * 3];
        double top = (1 - ax) * b00 + ax * b01, bot = (1 - ax) * b10 + ax * b11;
        out[k] = (1 - ay) * top + ay * bot;
    }
}

/*
 * The head over the background, in linear light. Into the face's own frame (capture:N) alpha is the
 * face mask's coverage (the model's face_mask vertices where the asset has the model's topology, else
 * the whole mesh) eroded by the feather radius and then box-blurred by it twice, so the edge fades
 * inside the face instead of a halo; over any other picture it is the head's coverage (premultiplied
 * over), the picture stretched to W x H.
 */
void relight_composite(const relight_ctx *c, float *sum, const float *cover, int W, int H, double exposure)
{
    int R = (int)lround(fmax(1.0, W / 240.0)); /* 2 px at 480 wide */
    size_t n = (size_t)W * (size_t)H;
    float *al = malloc(sizeof(float) * n), *tmp = malloc(sizeof(float) * n);
    if (!al || !tmp) {
        free(al);
        free(tmp);
        return;
    }
    if (c->bg_is_capture) {
        erode(cover, al, W, H, R);
        for (int pass = 0; pass < 4; pass++) /* a separable box blur along x, y, x, y: a tent */
            box_blur(pass % 2 ? tmp : al, pass % 2 ? al : tmp, W, H, R, pass % 2);
    } else {
        memcpy(al, cover, sizeof(float) * n);
    }
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            size_t i = (size_t)y * (size_t)W + (size_t)x;
            double bg[3], a = (double)al[i];
            background_at(c, x, y, W, H, bg);
            for (int k = 0; k < 3; k++) /* the capture blends the face; a premultiplied head goes over */
                sum[i * 3 + (size_t)k] = (float)((c->bg_is_capture ? a : 1.0) * (double)sum[i * 3 + (size_t)k] +
                                                 (1.0 - a) * bg[k] / exposure);
        }
    free(al);
    free(tmp);
}

/* A picture as linear RGB floats (*out malloc'd): PNG (sRGB), or through OpenImageIO (.exr, .hdr, .pfm as
   linear, anything else as sRGB); 0 or a negative error. */
static int read_picture(const char *path, float **out, uint32_t *w, uint32_t *h)
{
    uint8_t *rgba = NULL;
    int ret;
    if (relight_ends_with(path, ".png") || relight_ends_with(path, ".PNG")) {
        if ((ret = sp_png_read_rgba(path, &rgba, w, h)))
            return ret;
        size_t n = (size_t)*w * *h;
        *out = malloc(sizeof(float) * 3 * n);
        for (size_t i = 0; *out && i < n; i++)
            for (int k = 0; k < 3; k++)
                (*out)[i * 3 + (size_t)k] = (float)sp_srgb_decode(rgba[i * 4 + (size_t)k] / 255.0);
        free(rgba);
        return *out ? 0 : -ENOMEM;
    }
#if HAVE_OPENIMAGEIO
    if ((ret = sp_image_read_rgb(path, out, w, h)))
        return ret;
    int linear = relight_ends_with(path, ".exr") || relight_ends_with(path, ".hdr") || relight_ends_with(path, ".pfm");
    for (size_t i = 0; !linear && i < (size_t)*w * *h * 3; i++)
        (*out)[i] = (float)sp_srgb_decode(fmin(1.0, fmax(0.0, (double)(*out)[i])));
    return 0;
#else
    return SP_EDISABLED;
#endif
}

int relight_read_background_file(relight_ctx *c)
{
    const char *path = c->a->background_file;
    int ret = read_picture(path, &c->bg, &c->bg_w, &c->bg_h);
    if (ret == SP_EDISABLED) {
        fprintf(stderr, "sunprobe relight: --background %s: this build reads only PNG backgrounds (no OpenImageIO: "
                        "-Dopenimageio=enabled)\n", path);
        return SP_EXIT_DISABLED;
    }
    if (ret) {
        fprintf(stderr, "sunprobe relight: --background %s: %s\n", path, sp_strerror(ret));
        return sp_exit_for_error(ret == -ENOENT ? SP_EFORMAT : ret);
    }
    for (size_t i = 0; i < (size_t)c->bg_w * c->bg_h * 3; i++)
        if (!isfinite(c->bg[i]) || c->bg[i] < 0.0f) {
            fprintf(stderr, "sunprobe relight: --background %s: a negative or non-finite value\n", path);
            return SP_EXIT_BAD_INPUT;
        }
    return 0;
}

/*
 * --albedo-paint PNG: an RGBA picture in the albedo's UV layout (albedo.png's: row 0 = top, v = 1; any
 * size, sampled bilinearly at each texel's centre), its colour sRGB, alpha straight, laid over the albedo.
 */
/* An RGBA PNG that must carry alpha (option opt names it in messages); 0 or an exit code (message printed). */
static int read_paint(const char *opt, const char *path, uint8_t **rgba, uint32_t *w, uint32_t *h)
{
    void *buf = NULL;
    size_t size = 0;
    int ret = sp_read_whole_file(path, 512u << 20, &buf, &size), alpha = 0;
    if (!ret && (alpha = sp_png_has_alpha(buf, size)) < 0)
        ret = alpha;
    if (!ret && !alpha) {
        fprintf(stderr, "sunprobe relight: %s %s: the PNG has no alpha channel (paint is RGBA: alpha 0 keeps the "
                        "albedo)\n", opt, path);
        free(buf);
        return SP_EXIT_BAD_INPUT;
    }
    if (!ret)
        ret = sp_png_decode_rgba(buf, size, rgba, w, h);
    free(buf);
    if (ret) {
        fprintf(stderr, "sunprobe relight: %s %s: %s\n", opt, path, sp_strerror(ret));
        return sp_exit_for_error(ret == -ENOENT ? SP_EFORMAT : ret);
    }
    return 0;
}

int relight_paint(relight_ctx *c)
{
    const char *path = c->a->paint;
    uint8_t *rgba = NULL;
    uint32_t w = 0, h = 0;
    int ret = read_paint("--albedo-paint", path, &rgba, &w, &h);
    if (ret)
        return ret;
    float lut[256];
    for (int i = 0; i < 256; i++)
        lut[i] = (float)sp_srgb_decode(i / 255.0);
    sp_face_asset *fa = &c->fa;
    for (int y = 0; y < fa->tex_height; y++)
        for (int x = 0; x < fa->tex_width; x++) {
            double fx = fmin(fmax(((double)x + 0.5) * w / fa->tex_width - 0.5, 0.0), (double)w - 1.0);
            double fy = fmin(fmax(((double)y + 0.5) * h / fa->tex_height - 0.5, 0.0), (double)h - 1.0);
            uint32_t x0 = (uint32_t)fx, y0 = (uint32_t)fy, x1 = x0 + 1 < w ? x0 + 1 : x0, y1 = y0 + 1 < h ? y0 + 1 : y0;
            double ax = fx - x0, ay = fy - y0, p[4] = { 0 };
            const uint32_t xs[2] = { x0, x1 }, ys[2] = { y0, y1 };
            for (int j = 0; j < 4; j++) { /* premultiplied, so a transparent neighbour lends no colour */
                const uint8_t *q = rgba + ((size_t)ys[j / 2] * w + xs[j % 2]) * 4;
                double wt = (j % 2 ? ax : 1 - ax) * (j / 2 ? ay : 1 - ay) * q[3] / 255.0;
                for (int k = 0; k < 3; k++)
                    p[k] += wt * (double)lut[q[k]];
                p[3] += wt;
            }
            float *al = fa->albedo + ((size_t)y * (size_t)fa->tex_width + (size_t)x) * 3;
            for (int k = 0; k < 3; k++)
                al[k] = (float)(p[k] + (1.0 - p[3]) * (double)al[k]);
        }
    free(rgba);
    return 0;
}

/* The albedo texel (x, y) painted with the sRGB RGBA pixel q (alpha straight). */
static void paint_texel(sp_face_asset *fa, int x, int y, const uint8_t *q)
{
    float *al = fa->albedo + ((size_t)y * (size_t)fa->tex_width + (size_t)x) * 3;
    double a = q[3] / 255.0;
    for (int k = 0; k < 3; k++)
        al[k] = (float)(a * sp_srgb_decode(q[k] / 255.0) + (1.0 - a) * (double)al[k]);
}

/* World point of barycentrics b on triangle t of the asset where view v puts it. */
static void tri_point(const sp_face_asset *fa, const sp_face_view *v, uint32_t t, const double b[3], double w[3])
{
    const double *M = v->asset_to_world;
    w[0] = w[1] = w[2] = 0.0;
    for (int i = 0; i < 3; i++) {
        const float *p = fa->mesh.positions + (size_t)fa->mesh.tri_vertices[t * 3 + (uint32_t)i] * 3;
        for (int k = 0; k < 3; k++)
            w[k] += b[i] * (M[k * 4] * (double)p[0] + M[k * 4 + 1] * (double)p[1] + M[k * 4 + 2] * (double)p[2] +
                            M[k * 4 + 3]);
    }
}

/* Triangle t's texels seen in view v (depth: its per-pixel z) take the paint's pixel they project to. */
static void project_triangle(sp_face_asset *fa, const sp_face_view *v, const float *depth, const uint8_t *rgba,
                             uint32_t t)
{
    double u[3], s[3];
    for (int i = 0; i < 3; i++) { /* texel coordinates, centres at integers; row 0 is v = 1 */
        const float *uv = fa->mesh.uvs + (size_t)fa->mesh.tri_uvs[t * 3 + (uint32_t)i] * 2;
        u[i] = (double)uv[0] * fa->tex_width - 0.5;
        s[i] = (1.0 - (double)uv[1]) * fa->tex_height - 0.5;
    }
    double area = (u[1] - u[0]) * (s[2] - s[0]) - (u[2] - u[0]) * (s[1] - s[0]);
    if (!(fabs(area) > 1e-12))
        return;
    int x0 = (int)fmax(0.0, ceil(fmin(u[0], fmin(u[1], u[2])))), x1 = (int)fmin(fa->tex_width - 1, floor(fmax(u[0], fmax(u[1], u[2]))));
    int y0 = (int)fmax(0.0, ceil(fmin(s[0], fmin(s[1], s[2])))), y1 = (int)fmin(fa->tex_height - 1, floor(fmax(s[0], fmax(s[1], s[2]))));
    const sp_render_camera *cam = &v->camera;
    for (int y = y0; y <= y1; y++)
        for (int x = x0; x <= x1; x++) {
            double b1 = ((x - u[0]) * (s[2] - s[0]) - (u[2] - u[0]) * (y - s[0])) / area;
            double b2 = ((u[1] - u[0]) * (y - s[0]) - (x - u[0]) * (s[1] - s[0])) / area;
            double b[3] = { 1.0 - b1 - b2, b1, b2 }, w[3], q[3];
            if (b[0] < 0.0 || b1 < 0.0 || b2 < 0.0)
                continue;
            tri_point(fa, v, t, b, w);
            for (int k = 0; k < 3; k++)
                q[k] = cam->R[k * 3] * w[0] + cam->R[k * 3 + 1] * w[1] + cam->R[k * 3 + 2] * w[2] + cam->t[k];
            if (!(q[2] > 1e-6))
                continue;
            long px = lround(cam->fx * q[0] / q[2] + cam->cx), py = lround(cam->fy * q[1] / q[2] + cam->cy);
            if (px < 0 || py < 0 || px >= v->width || py >= v->height)
                continue;
            size_t i = (size_t)py * (size_t)v->width + (size_t)px;
            /* seen: the nearest surface at that pixel, within 5 mm (a pixel's footprint on a face at arm's length) */
            if (depth[i] > 0.0f && fabs(q[2] - (double)depth[i]) < 0.005)
                paint_texel(fa, x, y, rgba + i * 4);
        }
}

int relight_paint_image(relight_ctx *c, const sp_face_view *v, const float *depth, const char *path)
{
    uint8_t *rgba = NULL;
    uint32_t w = 0, h = 0;
    int ret = read_paint("--albedo-paint-image", path, &rgba, &w, &h);
    if (ret)
        return ret;
    if (w != (uint32_t)v->width || h != (uint32_t)v->height) {
        fprintf(stderr, "sunprobe relight: --albedo-paint-image %s is %ux%u: keyframe %d's frame is %dx%d\n", path, w,
                h, c->a->paint_keyframe, v->width, v->height);
        free(rgba);
        return SP_EXIT_BAD_INPUT;
    }
    for (uint32_t t = 0; t < c->fa.mesh.n_triangles; t++)
        project_triangle(&c->fa, v, depth, rgba, t);
    free(rgba);
    return 0;
}
