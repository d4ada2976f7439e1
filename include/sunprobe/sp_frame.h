/* SPDX-License-Identifier: MIT */
/*
 * The one frame type shared by devices, capture, pipeline and export: a
 * refcounted buffer with its metadata, so a replayed frame and a live one look alike.
 */
#ifndef SUNPROBE_SP_FRAME_H
#define SUNPROBE_SP_FRAME_H

#include <stddef.h>
#include <stdint.h>

#include "sp_common.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Pixel formats as stored in captures; values are on-disk codes, never renumber. */
enum sp_pixfmt {
    SP_PIXFMT_NONE = 0,
    SP_PIXFMT_GRAY8 = 1, /* one plane, 8-bit luma */
    SP_PIXFMT_RGB24 = 2, /* packed R,G,B bytes */
    SP_PIXFMT_YUYV = 3,  /* packed 4:2:2 Y0 U Y1 V, BT.601 limited range */
    SP_PIXFMT_NV12 = 4,  /* Y plane then interleaved UV plane at half height */
    SP_PIXFMT_MJPEG = 5, /* one JPEG image per frame, size in bytes_used */
    SP_PIXFMT_COUNT
};

SP_API const char *sp_pixfmt_name(enum sp_pixfmt fmt);
/* Format by name ("yuyv", "nv12", ...), SP_PIXFMT_NONE if unknown. */
SP_API enum sp_pixfmt sp_pixfmt_from_name(const char *name);
/* Minimum stride for a width (bytes of the first plane's row); 0 for compressed formats. */
SP_API uint32_t sp_pixfmt_min_stride(enum sp_pixfmt fmt, uint32_t width);
/* Bytes of a whole uncompressed image with this stride; 0 for compressed or invalid. */
SP_API size_t sp_pixfmt_image_size(enum sp_pixfmt fmt, uint32_t width, uint32_t height, uint32_t stride);

typedef struct sp_frame_pool sp_frame_pool;

typedef struct sp_frame {
    /* image */
    enum sp_pixfmt format;
    uint32_t width, height;
    uint32_t stride;      /* bytes per row of the first plane (NV12's UV plane shares it) */
    uint8_t *data;        /* owned by the frame's pool */
    size_t capacity;      /* bytes allocated at data */
    size_t bytes_used;    /* bytes of image in data (the JPEG size for MJPEG) */
    /* metadata */
    int64_t timestamp_ns; /* monotonic capture time of the exposure start */
    uint64_t sequence;    /* device sequence number; gaps mean drops */
    uint32_t stream_id;   /* which camera of a capture */
    float exposure_us;    /* NaN when unknown */
    float gain;           /* analogue gain, NaN when unknown */
    /* bookkeeping: private */
    int refcount;
    sp_frame_pool *pool;
} sp_frame;

/*
 * A pool of `count` frames of up to `max_bytes` each, all allocated up front so
 * the data path never calls malloc per frame. The pool lives until it is closed
 * and every frame taken from it has been released.
 */
SP_API int sp_frame_pool_open(sp_frame_pool **out, unsigned count, size_t max_bytes);
/* Drops the caller's reference; frames still held keep the pool alive. */
SP_API void sp_frame_pool_close(sp_frame_pool **pool);
/* Takes a free frame with refcount 1, or -EAGAIN when all are in use. */
SP_API int sp_frame_pool_get(sp_frame_pool *pool, sp_frame **out);
SP_API size_t sp_frame_pool_max_bytes(const sp_frame_pool *pool);
SP_API unsigned sp_frame_pool_free_count(const sp_frame_pool *pool);

/* A new reference to the same frame (thread-safe). */
SP_API sp_frame *sp_frame_ref(sp_frame *frame);
/* Drops a reference and sets *frame to NULL; the last one returns it to its pool. */
SP_API void sp_frame_unref(sp_frame **frame);

#ifdef __cplusplus
}
#endif
#endif
