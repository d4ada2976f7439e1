/* SPDX-License-Identifier: MIT */
/* The libcamera backend's ops table: thin casts onto the C++ shim. */
#include "device/backends.h"

#include "device/libcamera/libcamera_shim.h"

static int lc_open(void **ctx, const sp_camera_settings *s, sp_camera_info *info)
{
    sp_lc_camera *cam = NULL;
    int err = sp_lc_open(&cam, s, info);
    *ctx = cam;
    return err;
}

static int lc_start(void *ctx)
{
    return sp_lc_start(ctx);
}

static int lc_next(void *ctx, int timeout_ms, sp_frame **out)
{
    return sp_lc_next(ctx, timeout_ms, out);
}

static int lc_stop(void *ctx)
{
    return sp_lc_stop(ctx);
}

static void lc_close(void *ctx)
{
    sp_lc_close(ctx);
}

static uint64_t lc_dropped(void *ctx)
{
    return sp_lc_dropped(ctx);
}

const sp_camera_ops sp_camera_libcamera_ops = {
    .name = "libcamera",
    .enumerate = sp_lc_enumerate,
    .modes = sp_lc_modes,
    .claims = sp_lc_claims,
    .open = lc_open,
    .start = lc_start,
    .next = lc_next,
    .stop = lc_stop,
    .close = lc_close,
    .dropped = lc_dropped,
};
