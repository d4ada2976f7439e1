/* SPDX-License-Identifier: MIT */
/*
 * A stream source: the one interface that live cameras + IMUs, replayed captures,
 * importers and synthetic generators all implement, so everything downstream of
 * device/ sees the same events. The contract: the capture's metadata first
 * (whatever its timestamps), then IMU samples, frames and side data in timestamp
 * order. The orientation tagger (sp_tagger.h) is a source over a source that hands
 * frames on with their camera orientation, landmarks and ground truth attached.
 */
#ifndef SUNPROBE_SP_SOURCE_H
#define SUNPROBE_SP_SOURCE_H

#include <stddef.h>
#include <stdint.h>

#include "sp_common.h"
#include "sp_frame.h"
#include "sp_imu.h"
#include "sp_math.h"

#ifdef __cplusplus
extern "C" {
#endif

enum sp_event_type {
    SP_EVENT_FRAME = 1,
    SP_EVENT_IMU = 2,
    SP_EVENT_META = 3, /* device/calibration metadata (JSON, FORMAT.md) */
    SP_EVENT_SIDE = 4, /* per-frame side data such as 2-D landmarks */
};

struct sp_capture_meta; /* sp_meta.h */

/* Why a tagged frame has no camera orientation. */
enum sp_orientation_status {
    SP_ORIENTATION_OK = 0,          /* camera_to_world is valid */
    SP_ORIENTATION_NO_IMU = 1,      /* no IMU sample had arrived when the frame came */
    SP_ORIENTATION_NOT_COVERED = 2, /* the IMU history does not cover the frame's time (before its start,
                                       inside a long gap, past its end, or the frame waited too long) */
};

/* What the orientation tagger attaches to a frame (sp_tagger.h). */
typedef struct sp_frame_tags {
    enum sp_orientation_status orientation;
    sp_quat camera_to_world;        /* world z up, camera x right, y down, z forward; valid when OK */
    int heading_magnetic;           /* world +x is magnetic north (the filter used a magnetometer); else the
                                       heading is relative (capture/ORIENTATION.md) */
    int has_landmarks;              /* 68 2-D landmarks came as side data (SP_SIDE_LANDMARKS_2D) */
    float landmarks[136];           /* x, y pairs in capture pixels, Multi-PIE order */
    int has_true_orientation;       /* ground truth of a synthetic capture (SP_SIDE_TRUE_ORIENTATION) */
    sp_quat true_camera_to_world;
    uint64_t thinned;               /* frames the tagger dropped so far (while the IMU filter initialised) */
} sp_frame_tags;

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
    /* META: the metadata merged from this and every earlier META event (the source merges, consumers
       only read); borrowed until the next call. NULL from a source that does not parse it. */
    const struct sp_capture_meta *meta;
    const sp_frame_tags *tags; /* FRAME from a tagger: borrowed until the next call; NULL when untagged */
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
