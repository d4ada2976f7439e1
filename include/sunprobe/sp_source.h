/* SPDX-License-Identifier: MIT */
/*
 * A stream source: the one interface that live cameras + IMUs, replayed captures,
 * importers and synthetic generators all implement, so everything downstream of
 * device/ sees the same events in timestamp order.
 */
#ifndef SUNPROBE_SP_SOURCE_H
#define SUNPROBE_SP_SOURCE_H

#include <stddef.h>
#include <stdint.h>

#include "sp_common.h"
#include "sp_frame.h"
#include "sp_imu.h"

#ifdef __cplusplus
extern "C" {
#endif

enum sp_event_type {
    SP_EVENT_FRAME = 1,
    SP_EVENT_IMU = 2,
    SP_EVENT_META = 3, /* device/calibration metadata (JSON, FORMAT.md) */
    SP_EVENT_SIDE = 4, /* per-frame side data such as 2-D landmarks */
};

typedef struct sp_event {
    enum sp_event_type type;
    int64_t timestamp_ns;
    sp_frame *frame;        /* FRAME: the receiver owns one reference (sp_frame_unref) */
    sp_imu_sample imu;      /* IMU: one sample */
    const char *meta_json;  /* META: borrowed until the next call, not NUL-terminated */
    size_t meta_len;
    uint64_t side_sequence; /* SIDE: frame sequence it belongs to */
    uint32_t side_kind;     /* SIDE: enum sp_side_kind */
    uint32_t side_count;    /* SIDE: number of floats */
    const float *side_values; /* SIDE: borrowed until the next call */
} sp_event;

/* What a source implementation provides; a const table with a name. */
typedef struct sp_source_ops {
    const char *name;
    /* One non-blocking step: 0 with an event, -EAGAIN when a live device has nothing yet, SP_EOS at the end. */
    int (*next)(void *ctx, sp_event *ev);
    void (*close)(void *ctx);
} sp_source_ops;

typedef struct sp_source {
    const sp_source_ops *ops;
    void *ctx;
} sp_source;

/* Wraps an implementation; ownership of ctx moves to the source on success. */
SP_API int sp_source_create(sp_source **out, const sp_source_ops *ops, void *ctx);
SP_API int sp_source_next(sp_source *src, sp_event *ev);
SP_API const char *sp_source_name(const sp_source *src);
/* Closes the implementation and frees the source; *src becomes NULL. */
SP_API void sp_source_close(sp_source **src);
/* Releases what an event holds (the frame reference); safe on any event. */
SP_API void sp_event_release(sp_event *ev);

#ifdef __cplusplus
}
#endif
#endif
