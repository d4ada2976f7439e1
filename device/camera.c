/* SPDX-License-Identifier: MIT */
/* Camera registry (a static array of backend tables) and the public sp_camera wrapper around one backend. */
#include "sunprobe/sp_camera.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "device/backends.h"

static const sp_camera_ops *const backends[] = {
#if HAVE_V4L2
    &sp_camera_v4l2_ops,
#endif
#if HAVE_LIBCAMERA
    &sp_camera_libcamera_ops,
#endif
    &sp_camera_fake_ops,
};
#define N_BACKENDS (sizeof(backends) / sizeof(backends[0]))

struct sp_camera {
    const sp_camera_ops *ops;
    void *ctx;
    sp_camera_info info;
    int streaming;
};

void sp_dev_copy_string(char *dst, size_t size, const char *src)
{
    if (!size)
        return;
    size_t n = src ? strnlen(src, size - 1) : 0;
    if (n)
        memcpy(dst, src, n);
    dst[n] = '\0';
}

const sp_camera_ops *const *sp_camera_backends(size_t *count)
{
    if (count)
        *count = N_BACKENDS;
    return backends;
}

const sp_camera_ops *sp_camera_backend_find(const char *name)
{
    for (size_t i = 0; name && i < N_BACKENDS; i++)
        if (!strcmp(backends[i]->name, name))
            return backends[i];
    return NULL;
}

int sp_camera_enumerate(sp_camera_desc *out, size_t max, size_t *count)
{
    if (!count || (max && !out))
        return -EINVAL;
    size_t total = 0;
    for (size_t i = 0; i < N_BACKENDS; i++) {
        size_t n = 0;
        size_t room = total < max ? max - total : 0;
        int err = backends[i]->enumerate(room ? out + total : NULL, room, &n);
        if (err < 0) /* one broken backend must not hide the others' cameras */
            sp_log(SP_LOG_WARN, "camera", "%s: enumeration failed: %s", backends[i]->name, sp_strerror(err));
        else
            total += n;
    }
    *count = total;
    return 0;
}

int sp_camera_modes(const sp_camera_desc *desc, sp_camera_mode *out, size_t max, size_t *count)
{
    if (!desc || !count || (max && !out))
        return -EINVAL;
    const sp_camera_ops *ops = sp_camera_backend_find(desc->backend);
    if (!ops)
        return -ENOENT;
    return ops->modes(desc->id, out, max, count);
}

void sp_camera_default_settings(sp_camera_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->buffers = 4;
    s->pool_frames = 8;
    s->lock_settle_s = 0.5;
}

/* The backend named by the settings, or the first that claims the device string. */
static int pick_backend(const sp_camera_settings *s, const sp_camera_ops **ops)
{
    if (s->backend) {
        *ops = sp_camera_backend_find(s->backend);
        if (*ops)
            return 0;
        if (!strcmp(s->backend, "v4l2") || !strcmp(s->backend, "libcamera")) {
            sp_log(SP_LOG_ERROR, "camera", "backend '%s' not built (meson option -D%s=enabled)", s->backend,
                   s->backend);
            return SP_EDISABLED;
        }
        return -ENOENT;
    }
    for (size_t i = 0; i < N_BACKENDS; i++)
        if (backends[i]->claims(s->device)) {
            *ops = backends[i];
            return 0;
        }
    if (s->device && !strncmp(s->device, "/dev/video", 10)) {
        sp_log(SP_LOG_ERROR, "camera", "%s needs the V4L2 backend (meson option -Dv4l2=enabled)", s->device);
        return SP_EDISABLED;
    }
    sp_log(SP_LOG_ERROR, "camera", "no camera backend knows '%s'", s->device ? s->device : "(first camera)");
    return -ENOENT;
}

int sp_camera_open(sp_camera **out, const sp_camera_settings *s)
{
    if (!out || !s)
        return -EINVAL;
    *out = NULL;
    if (s->width > 16384 || s->height > 16384 || !(s->fps >= 0 && s->fps <= 10000) ||
        (unsigned)s->format >= SP_PIXFMT_COUNT || s->buffers > 32 || s->pool_frames > 1024 ||
        !(s->lock_settle_s >= 0 && s->lock_settle_s <= 60))
        return -EINVAL;
    sp_camera_settings eff = *s;
    if (!eff.buffers)
        eff.buffers = 4;
    if (!eff.pool_frames)
        eff.pool_frames = 8;
    const sp_camera_ops *ops = NULL;
    int err = pick_backend(&eff, &ops);
    if (err < 0)
        return err;
    sp_camera *cam = calloc(1, sizeof(*cam));
    if (!cam)
        return -ENOMEM;
    cam->ops = ops;
    err = ops->open(&cam->ctx, &eff, &cam->info);
    if (err < 0) {
        free(cam);
        return err;
    }
    sp_dev_copy_string(cam->info.desc.backend, sizeof(cam->info.desc.backend), ops->name);
    *out = cam;
    return 0;
}

const sp_camera_info *sp_camera_get_info(const sp_camera *cam)
{
    return cam ? &cam->info : NULL;
}

int sp_camera_start(sp_camera *cam)
{
    if (!cam)
        return -EINVAL;
    if (cam->streaming)
        return 0;
    int err = cam->ops->start(cam->ctx);
    if (err == 0)
        cam->streaming = 1;
    return err;
}

int sp_camera_next(sp_camera *cam, int timeout_ms, sp_frame **out)
{
    if (!cam || !out || timeout_ms < 0)
        return -EINVAL;
    *out = NULL;
    if (!cam->streaming)
        return -EINVAL;
    return cam->ops->next(cam->ctx, timeout_ms, out);
}

int sp_camera_stop(sp_camera *cam)
{
    if (!cam)
        return -EINVAL;
    if (!cam->streaming)
        return 0;
    cam->streaming = 0;
    return cam->ops->stop(cam->ctx);
}

uint64_t sp_camera_dropped(const sp_camera *cam)
{
    return cam && cam->ops->dropped ? cam->ops->dropped(cam->ctx) : 0;
}

void sp_camera_close(sp_camera **cam)
{
    if (!cam || !*cam)
        return;
    sp_camera *c = *cam;
    if (c->streaming)
        (void)sp_camera_stop(c);
    if (c->ctx)
        c->ops->close(c->ctx);
    free(c);
    *cam = NULL;
}
