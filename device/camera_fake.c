/* SPDX-License-Identifier: MIT */
/*
 * The fake camera as a camera backend. Device string "fake[:opt,...]":
 *   bars | panorama   pattern (panorama turns 36 deg/s)
 *   unpaced           a frame whenever asked and a pooled frame is free, stamped when made
 *                     (default: paced at fps like a sensor, frames due while the consumer
 *                     held every pooled frame are dropped and counted)
 *   prerender         draw 8 frames once and copy them out (cheap frames for throughput tests)
 *   frames=N          end with SP_EOS after N frames
 */
#include "device/backends.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/clock.h"
#include "sunprobe/sp_fake_camera.h"

#define PRERENDERED 8

typedef struct fake_opts {
    enum sp_fake_pattern pattern;
    int unpaced, prerender;
    uint64_t limit; /* 0 = endless */
} fake_opts;

typedef struct fake_ctx {
    sp_fake_camera *gen;
    sp_frame_pool *pool; /* prerender mode: frames are copies of `cache` */
    uint8_t *cache;
    size_t frame_bytes;
    fake_opts o;
    double fps;
    int64_t start_ns;
    uint64_t seq, dropped;
    sp_frame proto; /* format fields copied into prerendered frames */
} fake_ctx;

static int fake_claims(const char *device)
{
    return device && !strncmp(device, "fake", 4) && (device[4] == '\0' || device[4] == ':');
}

static int parse_opts(const char *device, fake_opts *o)
{
    memset(o, 0, sizeof(*o));
    o->pattern = SP_FAKE_PATTERN_BARS;
    const char *p = device && device[4] == ':' ? device + 5 : "";
    while (*p) {
        size_t n = strcspn(p, ",");
        unsigned long long v;
        char tail;
        if (n == 4 && !strncmp(p, "bars", 4)) {
            o->pattern = SP_FAKE_PATTERN_BARS;
        } else if (n == 8 && !strncmp(p, "panorama", 8)) {
            o->pattern = SP_FAKE_PATTERN_PANORAMA;
        } else if (n == 7 && !strncmp(p, "unpaced", 7)) {
            o->unpaced = 1;
        } else if (n == 9 && !strncmp(p, "prerender", 9)) {
            o->prerender = 1;
        } else if (!strncmp(p, "frames=", 7) && sscanf(p + 7, "%llu%c", &v, &tail) >= 1 && v > 0) {
            o->limit = v;
        } else {
            sp_log(SP_LOG_ERROR, "fake-camera", "unknown option '%.*s' in '%s'", (int)n, p, device);
            return -EINVAL;
        }
        p += n;
        if (*p == ',')
            p++;
    }
    return 0;
}

static int fake_enumerate(sp_camera_desc *out, size_t max, size_t *count)
{
    *count = 1;
    if (max >= 1) {
        memset(out, 0, sizeof(*out));
        sp_dev_copy_string(out->backend, sizeof(out->backend), "fake");
        sp_dev_copy_string(out->id, sizeof(out->id), "fake");
        sp_dev_copy_string(out->name, sizeof(out->name), "sunprobe test pattern");
        sp_dev_copy_string(out->driver, sizeof(out->driver), "fake");
    }
    return 0;
}

static int fake_modes(const char *id, sp_camera_mode *out, size_t max, size_t *count)
{
    static const enum sp_pixfmt fmts[] = { SP_PIXFMT_YUYV, SP_PIXFMT_NV12, SP_PIXFMT_RGB24, SP_PIXFMT_GRAY8 };
    static const uint32_t sizes[][2] = { { 320, 240 }, { 640, 480 }, { 1280, 720 }, { 1920, 1080 } };
    size_t n = 0;
    for (size_t f = 0; f < 4; f++)
        for (size_t k = 0; k < 4; k++, n++)
            if (n < max)
                out[n] = (sp_camera_mode){ fmts[f], sizes[k][0], sizes[k][1], 1000.0 };
    *count = n;
    return 0;
}

static void fake_close(void *ctx)
{
    fake_ctx *c = ctx;
    if (!c)
        return;
    sp_fake_camera_close(&c->gen);
    sp_frame_pool_close(&c->pool);
    free(c->cache);
    free(c);
}

/* Renders PRERENDERED frames once into `cache`; later frames are copies. */
static int prerender(fake_ctx *c)
{
    c->cache = malloc(c->frame_bytes * PRERENDERED);
    if (!c->cache)
        return -ENOMEM;
    for (uint64_t i = 0; i < PRERENDERED; i++) {
        sp_frame *f = NULL;
        int err = sp_fake_camera_frame(c->gen, i, 0, 2.0 * M_PI * (double)i / PRERENDERED, &f);
        if (err < 0)
            return err;
        memcpy(c->cache + i * c->frame_bytes, f->data, c->frame_bytes);
        c->proto = *f;
        sp_frame_unref(&f);
    }
    return 0;
}

static int fake_open(void **out, const sp_camera_settings *s, sp_camera_info *info)
{
    fake_ctx *c = calloc(1, sizeof(*c));
    if (!c)
        return -ENOMEM;
    int err = parse_opts(s->device, &c->o);
    sp_fake_camera_settings fs;
    sp_fake_camera_default_settings(&fs);
    if (s->width || s->height) {
        fs.width = s->width;
        fs.height = s->height;
    }
    fs.fps = s->fps > 0 ? s->fps : 30.0;
    fs.format = s->format != SP_PIXFMT_NONE ? s->format : SP_PIXFMT_YUYV;
    fs.pattern = c->o.pattern;
    fs.pool_frames = c->o.prerender ? 1 : s->pool_frames;
    if (fs.format == SP_PIXFMT_MJPEG)
        err = SP_EUNSUPPORTED; /* the fake camera has no encoder */
    if (err == 0)
        err = sp_fake_camera_open(&c->gen, &fs);
    c->fps = fs.fps;
    uint32_t stride = sp_pixfmt_min_stride(fs.format, fs.width);
    c->frame_bytes = sp_pixfmt_image_size(fs.format, fs.width, fs.height, stride);
    if (err == 0 && c->o.prerender)
        err = prerender(c);
    if (err == 0 && c->o.prerender)
        err = sp_frame_pool_open(&c->pool, s->pool_frames, c->frame_bytes);
    if (err < 0) {
        fake_close(c);
        return err;
    }
    memset(info, 0, sizeof(*info));
    fake_enumerate(&info->desc, 1, &(size_t){ 0 });
    if (s->device)
        sp_dev_copy_string(info->desc.id, sizeof(info->desc.id), s->device);
    info->format = fs.format;
    info->width = fs.width;
    info->height = fs.height;
    info->stride = stride;
    info->fps = fs.fps;
    info->exposure_locked = s->lock_exposure != 0; /* a test pattern never changes exposure */
    info->monotonic_timestamps = 1;
    *out = c;
    return 0;
}

static int fake_start(void *ctx)
{
    fake_ctx *c = ctx;
    c->start_ns = sp_clock_monotonic_ns();
    c->seq = 0;
    return 0;
}

static int fake_stop(void *ctx)
{
    return 0;
}

static int make_frame(fake_ctx *c, int64_t ts, sp_frame **out)
{
    if (!c->o.prerender) {
        double yaw = 2.0 * M_PI * (double)(ts - c->start_ns) * 1e-9 / 10.0;
        return sp_fake_camera_frame(c->gen, c->seq, ts, yaw, out);
    }
    sp_frame *f = NULL;
    int err = sp_frame_pool_get(c->pool, &f);
    if (err < 0)
        return err;
    memcpy(f->data, c->cache + (c->seq % PRERENDERED) * c->frame_bytes, c->frame_bytes);
    f->format = c->proto.format;
    f->width = c->proto.width;
    f->height = c->proto.height;
    f->stride = c->proto.stride;
    f->bytes_used = c->frame_bytes;
    f->exposure_us = c->proto.exposure_us;
    f->gain = c->proto.gain;
    f->sequence = c->seq;
    f->timestamp_ns = ts;
    *out = f;
    return 0;
}

/* Unpaced: a frame as soon as one is free, waiting in 1 ms steps up to the timeout. */
static int next_unpaced(fake_ctx *c, int timeout_ms, sp_frame **out)
{
    int64_t deadline = sp_clock_monotonic_ns() + (int64_t)timeout_ms * 1000000;
    for (;;) {
        int err = make_frame(c, sp_clock_monotonic_ns(), out);
        if (err != -EAGAIN)
            return err;
        int64_t now = sp_clock_monotonic_ns();
        if (now >= deadline)
            return -EAGAIN;
        sp_clock_sleep_until(now + 1000000 < deadline ? now + 1000000 : deadline);
    }
}

/* Paced like a sensor: frame k is due at start + k/fps; frames missed while the consumer was away are dropped. */
static int next_paced(fake_ctx *c, int timeout_ms, sp_frame **out)
{
    double period = 1e9 / c->fps;
    int64_t now = sp_clock_monotonic_ns();
    uint64_t latest = (uint64_t)((double)(now - c->start_ns) / period);
    if (latest > c->seq + 1) { /* the consumer was away for more than a frame */
        uint64_t lost = latest - c->seq;
        if (c->o.limit && c->seq + lost > c->o.limit)
            lost = c->o.limit - c->seq;
        c->dropped += lost;
        c->seq += lost;
        if (c->o.limit && c->seq >= c->o.limit)
            return SP_EOS;
    }
    int64_t due = c->start_ns + (int64_t)llround((double)c->seq * period);
    if (due > now + (int64_t)timeout_ms * 1000000) {
        sp_clock_sleep_until(now + (int64_t)timeout_ms * 1000000);
        return -EAGAIN;
    }
    sp_clock_sleep_until(due);
    int err = make_frame(c, due, out);
    if (err == -EAGAIN) { /* every pooled frame is held: this one is lost, like a sensor with no buffer */
        c->dropped++;
        c->seq++;
    }
    return err;
}

static int fake_next(void *ctx, int timeout_ms, sp_frame **out)
{
    fake_ctx *c = ctx;
    if (c->o.limit && c->seq >= c->o.limit)
        return SP_EOS;
    int err = c->o.unpaced ? next_unpaced(c, timeout_ms, out) : next_paced(c, timeout_ms, out);
    if (err == 0)
        c->seq++;
    return err;
}

static uint64_t fake_dropped(void *ctx)
{
    return ((fake_ctx *)ctx)->dropped;
}

const sp_camera_ops sp_camera_fake_ops = {
    .name = "fake",
    .enumerate = fake_enumerate,
    .modes = fake_modes,
    .claims = fake_claims,
    .open = fake_open,
    .start = fake_start,
    .next = fake_next,
    .stop = fake_stop,
    .close = fake_close,
    .dropped = fake_dropped,
};
