/* SPDX-License-Identifier: MIT */
/* Fake camera: draws RGB test patterns, then packs them into the requested pixel format. */
#include "sunprobe/sp_fake_camera.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct sp_fake_camera {
    sp_fake_camera_settings s;
    sp_frame_pool *pool;
    uint8_t *rgb; /* scratch RGB image */
    float *column_azimuth;
};

void sp_fake_camera_default_settings(sp_fake_camera_settings *s)
{
    memset(s, 0, sizeof(*s));
    s->width = 640;
    s->height = 480;
    s->fps = 30.0;
    s->format = SP_PIXFMT_YUYV;
    s->pattern = SP_FAKE_PATTERN_BARS;
    s->hfov_deg = 65.0;
    s->pool_frames = 4;
}

static void hue_rgb(double h, uint8_t out[3])
{
    /* h in [0,1): a saturated colour wheel */
    double r = fabs(h * 6.0 - 3.0) - 1.0, g = 2.0 - fabs(h * 6.0 - 2.0), b = 2.0 - fabs(h * 6.0 - 4.0);
    double c[3] = { r, g, b };
    for (int i = 0; i < 3; i++)
        out[i] = (uint8_t)(40.0 + 200.0 * fmin(fmax(c[i], 0.0), 1.0));
}

static void draw_bars(sp_fake_camera *cam, uint64_t seq)
{
    static const uint8_t bars[8][3] = { { 235, 235, 235 }, { 235, 235, 16 }, { 16, 235, 235 }, { 16, 235, 16 },
                                        { 235, 16, 235 },  { 235, 16, 16 },  { 16, 16, 235 },  { 16, 16, 16 } };
    uint32_t w = cam->s.width, h = cam->s.height;
    uint32_t block = w / 10 + 1, bx = (uint32_t)((seq * 4) % (w + 1));
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            uint8_t *p = cam->rgb + ((size_t)y * w + x) * 3;
            const uint8_t *c = bars[(size_t)x * 8 / w];
            int in_block = x >= bx && x < bx + block && y >= h / 2 && y < h / 2 + block;
            p[0] = in_block ? 128 : c[0];
            p[1] = in_block ? 128 : c[1];
            p[2] = in_block ? 128 : c[2];
        }
}

/* A horizon of 12 coloured posts around the viewer and a sun at azimuth 0, seen at `yaw`. */
static void draw_panorama(sp_fake_camera *cam, double yaw)
{
    uint32_t w = cam->s.width, h = cam->s.height;
    double two_pi = 2.0 * M_PI;
    for (uint32_t x = 0; x < w; x++) {
        double az = fmod(yaw + (double)cam->column_azimuth[x], two_pi);
        if (az < 0)
            az += two_pi;
        double post = az / two_pi * 12.0;
        int on_post = post - floor(post) < 0.25;
        uint8_t post_rgb[3];
        hue_rgb(floor(post) / 12.0, post_rgb);
        double sun_dx = fabs(remainder(az, two_pi)) * 180.0 / M_PI;
        for (uint32_t y = 0; y < h; y++) {
            uint8_t *p = cam->rgb + ((size_t)y * w + x) * 3;
            double v = (double)y / h;
            if (v < 0.55) { /* sky: brighter towards the horizon, a sun disk near azimuth 0 */
                int sun = sun_dx < 6.0 && fabs(v - 0.2) < 0.06;
                p[0] = sun ? 255 : (uint8_t)(90 + 100 * v);
                p[1] = sun ? 250 : (uint8_t)(140 + 90 * v);
                p[2] = sun ? 220 : (uint8_t)(230 - 20 * v);
            } else if (on_post && v < 0.8) {
                memcpy(p, post_rgb, 3);
            } else {
                uint8_t g = (uint8_t)(70 + 50 * (v - 0.55));
                p[0] = g;
                p[1] = (uint8_t)(g + 20);
                p[2] = (uint8_t)(g - 20);
            }
        }
    }
}

static uint8_t clamp_u8(double v)
{
    return (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v + 0.5);
}

/* BT.601 limited range, the convention the rest of sunprobe decodes with. */
static void rgb_to_yuv(const uint8_t *p, double *y, double *u, double *v)
{
    *y = 16.0 + (65.481 * p[0] + 128.553 * p[1] + 24.966 * p[2]) / 255.0;
    *u = 128.0 + (-37.797 * p[0] - 74.203 * p[1] + 112.0 * p[2]) / 255.0;
    *v = 128.0 + (112.0 * p[0] - 93.786 * p[1] - 18.214 * p[2]) / 255.0;
}

static void pack(const sp_fake_camera *cam, sp_frame *f)
{
    uint32_t w = cam->s.width, h = cam->s.height, stride = f->stride;
    const uint8_t *rgb = cam->rgb;
    for (uint32_t yy = 0; yy < h; yy++) {
        uint8_t *row = f->data + (size_t)yy * stride;
        const uint8_t *src = rgb + (size_t)yy * w * 3;
        for (uint32_t x = 0; x < w; x++) {
            double Y, U, V;
            rgb_to_yuv(src + x * 3, &Y, &U, &V);
            switch (f->format) {
            case SP_PIXFMT_GRAY8:
                row[x] = clamp_u8((Y - 16.0) * 255.0 / 219.0);
                break;
            case SP_PIXFMT_RGB24:
                memcpy(row + x * 3, src + x * 3, 3);
                break;
            case SP_PIXFMT_YUYV:
                row[x * 2] = clamp_u8(Y);
                row[x * 2 + 1] = clamp_u8(x & 1 ? V : U); /* chroma of the even pixel stands for the pair */
                break;
            default: /* NV12 */
                row[x] = clamp_u8(Y);
                if (!(yy & 1) && !(x & 1)) {
                    uint8_t *uv = f->data + (size_t)h * stride + (size_t)(yy / 2) * stride + x;
                    uv[0] = clamp_u8(U);
                    uv[1] = clamp_u8(V);
                }
            }
        }
    }
}

int sp_fake_camera_open(sp_fake_camera **out, const sp_fake_camera_settings *s)
{
    if (!out || !s)
        return -EINVAL;
    *out = NULL;
    if (s->width < 2 || s->height < 2 || s->width > 8192 || s->height > 8192 || !(s->fps > 0 && s->fps <= 1000) ||
        !(s->format == SP_PIXFMT_GRAY8 || s->format == SP_PIXFMT_RGB24 || s->format == SP_PIXFMT_YUYV ||
          s->format == SP_PIXFMT_NV12) || !(s->hfov_deg > 1 && s->hfov_deg < 179))
        return -EINVAL;
    sp_fake_camera *cam = calloc(1, sizeof(*cam));
    if (!cam)
        return -ENOMEM;
    cam->s = *s;
    if (!cam->s.pool_frames)
        cam->s.pool_frames = 4;
    size_t bytes = sp_pixfmt_image_size(s->format, s->width, s->height, sp_pixfmt_min_stride(s->format, s->width));
    cam->rgb = malloc((size_t)s->width * s->height * 3);
    cam->column_azimuth = malloc(sizeof(float) * s->width);
    int ret = cam->rgb && cam->column_azimuth ? sp_frame_pool_open(&cam->pool, cam->s.pool_frames, bytes) : -ENOMEM;
    if (ret) {
        sp_fake_camera_close(&cam);
        return ret;
    }
    double f = 0.5 * s->width / tan(0.5 * s->hfov_deg * M_PI / 180.0);
    for (uint32_t x = 0; x < s->width; x++)
        cam->column_azimuth[x] = (float)atan(((double)x + 0.5 - 0.5 * s->width) / f);
    *out = cam;
    return 0;
}

void sp_fake_camera_close(sp_fake_camera **cam)
{
    if (!cam || !*cam)
        return;
    sp_frame_pool_close(&(*cam)->pool);
    free((*cam)->rgb);
    free((*cam)->column_azimuth);
    free(*cam);
    *cam = NULL;
}

int sp_fake_camera_frame(sp_fake_camera *cam, uint64_t sequence, int64_t timestamp_ns, double yaw_rad,
                         sp_frame **out)
{
    if (!cam || !out || !isfinite(yaw_rad))
        return -EINVAL;
    sp_frame *f = NULL;
    int ret = sp_frame_pool_get(cam->pool, &f);
    if (ret)
        return ret;
    if (cam->s.pattern == SP_FAKE_PATTERN_PANORAMA)
        draw_panorama(cam, yaw_rad);
    else
        draw_bars(cam, sequence);
    f->format = cam->s.format;
    f->width = cam->s.width;
    f->height = cam->s.height;
    f->stride = sp_pixfmt_min_stride(f->format, f->width);
    f->bytes_used = sp_pixfmt_image_size(f->format, f->width, f->height, f->stride);
    f->sequence = sequence;
    f->timestamp_ns = timestamp_ns;
    f->exposure_us = (float)(1e6 / cam->s.fps / 4.0);
    f->gain = 1.0f;
    pack(cam, f);
    *out = f;
    return 0;
}
