/* SPDX-License-Identifier: MIT */
/*
 * Live cameras: one interface over every camera backend (V4L2, libcamera, the
 * fake test-pattern camera). A backend is a const table of functions with a
 * name; the registry is a static array. Frames come out as refcounted sp_frame
 * from a pool sized when the camera is opened, with CLOCK_MONOTONIC timestamps.
 */
#ifndef SUNPROBE_SP_CAMERA_H
#define SUNPROBE_SP_CAMERA_H

#include <stddef.h>
#include <stdint.h>

#include "sp_common.h"
#include "sp_frame.h"

#ifdef __cplusplus
extern "C" {
#endif

/* One camera as enumeration finds it. */
typedef struct sp_camera_desc {
    char backend[16];  /* "v4l2", "libcamera", "fake" */
    char id[128];      /* what sp_camera_settings.device accepts: "/dev/video0", a libcamera id, "fake" */
    char name[128];    /* human name: the V4L2 card, libcamera's model, ... */
    char driver[64];   /* kernel driver or pipeline handler, "" when unknown */
} sp_camera_desc;

/* One pixel format at one size, with the fastest rate the device reports for it (0 = unknown). */
typedef struct sp_camera_mode {
    enum sp_pixfmt format;
    uint32_t width, height;
    double max_fps;
} sp_camera_mode;

typedef struct sp_camera_settings {
    const char *device;     /* id or name from enumeration, "/dev/videoN", or "fake[:opts]"; borrowed for open */
    const char *backend;    /* force a backend by name; NULL picks the one that knows `device` */
    enum sp_pixfmt format;  /* NONE: first supported of YUYV, NV12, MJPEG, RGB24, GRAY8 */
    uint32_t width, height; /* 0: 640x480 (the device may adjust; see sp_camera_info) */
    double fps;             /* 0: the device's default */
    int lock_exposure;      /* lock auto exposure, gain and white balance at the values they reach ... */
    double lock_settle_s;   /* ... this long after streaming starts (frames before are not delivered);
                               default 0.5, 0 locks at once */
    unsigned buffers;       /* device buffer ring; default 4 */
    unsigned pool_frames;   /* frames the consumer may hold at once; default 8 */
} sp_camera_settings;

/* What was negotiated; valid after open. */
typedef struct sp_camera_info {
    sp_camera_desc desc;
    enum sp_pixfmt format;
    uint32_t width, height, stride;
    double fps;             /* nominal rate, 0 when the device does not say */
    int exposure_locked;    /* the lock was asked for and the device accepted it (known after start) */
    int monotonic_timestamps; /* device stamps are CLOCK_MONOTONIC (else stamped at dequeue) */
} sp_camera_info;

/*
 * A camera backend. Every function gets the backend's context from open. next()
 * waits at most timeout_ms (0 = poll) and returns 0 with a frame the caller owns,
 * -EAGAIN when none came in time, -ENODEV when the device went away, SP_EOS when
 * a finite source ended; it must not block longer than asked. The info that open
 * fills stays valid until close; start may still update exposure_locked.
 */
typedef struct sp_camera_ops {
    const char *name;
    /* Fills up to `max` descriptions, sets *count to how many exist. */
    int (*enumerate)(sp_camera_desc *out, size_t max, size_t *count);
    /* Modes of one device (by id); *count as above. */
    int (*modes)(const char *id, sp_camera_mode *out, size_t max, size_t *count);
    /* Does this backend own this device string (id, name or its own syntax)? */
    int (*claims)(const char *device);
    int (*open)(void **ctx, const sp_camera_settings *s, sp_camera_info *info);
    int (*start)(void *ctx);
    int (*next)(void *ctx, int timeout_ms, sp_frame **out);
    int (*stop)(void *ctx);
    void (*close)(void *ctx);
    /* Frames the device itself reported lost (sequence gaps, full pool); may be NULL. */
    uint64_t (*dropped)(void *ctx);
} sp_camera_ops;

/* Backends compiled into this build, in preference order; the array is static. */
SP_API const sp_camera_ops *const *sp_camera_backends(size_t *count);
SP_API const sp_camera_ops *sp_camera_backend_find(const char *name);

/*
 * Enumerates every backend's cameras into out[0..max) and sets *count to the
 * total found (may exceed max). The fake camera is listed last.
 */
SP_API int sp_camera_enumerate(sp_camera_desc *out, size_t max, size_t *count);
/* Modes of a camera found by enumeration; same counting rule. */
SP_API int sp_camera_modes(const sp_camera_desc *desc, sp_camera_mode *out, size_t max, size_t *count);

typedef struct sp_camera sp_camera;

SP_API void sp_camera_default_settings(sp_camera_settings *s);
/*
 * Opens and negotiates (format, size, rate, controls) but does not stream.
 * SP_EDISABLED when the device needs a backend this build left out, -ENOENT when
 * no backend knows the device. The caller owns *out (sp_camera_close).
 */
SP_API int sp_camera_open(sp_camera **out, const sp_camera_settings *s);
SP_API const sp_camera_info *sp_camera_get_info(const sp_camera *cam);
SP_API int sp_camera_start(sp_camera *cam);
/* See sp_camera_ops.next; the caller owns *out on success (sp_frame_unref). */
SP_API int sp_camera_next(sp_camera *cam, int timeout_ms, sp_frame **out);
SP_API int sp_camera_stop(sp_camera *cam);
/* Frames lost before they reached the caller. */
SP_API uint64_t sp_camera_dropped(const sp_camera *cam);
/* Stops if streaming, closes; frames still held stay valid. *cam becomes NULL. */
SP_API void sp_camera_close(sp_camera **cam);

#ifdef __cplusplus
}
#endif
#endif
