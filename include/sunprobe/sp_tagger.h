/* SPDX-License-Identifier: MIT */
/*
 * The orientation tagger: a source over a source. It runs the IMU orientation
 * filter (opened from the capture's metadata, which the source delivers first)
 * and hands every frame on with its tags (sp_frame_tags): the camera-to-world
 * rotation at the frame's time or why there is none, the frame's 2-D landmarks
 * and its true orientation when side data carried them. Stages downstream never
 * open the filter themselves.
 *
 * Events out: META and IMU events as they come (IMU samples may overtake frames
 * that wait), frames in arrival order with ev->tags set, and the side data that
 * matched no waiting frame (other kinds, or a frame already handed on).
 * A frame waits until the IMU has passed its time and a newer frame has come
 * (so its side data, written after it, has arrived), at most max_waiting frames
 * at once: when the ring is full before the filter has initialised, the frame
 * closest in time to its predecessor is dropped (the ring thins out evenly over
 * the start; counted), otherwise the oldest goes on as NOT_COVERED.
 */
#ifndef SUNPROBE_SP_TAGGER_H
#define SUNPROBE_SP_TAGGER_H

#include <stdint.h>

#include "sp_common.h"
#include "sp_orientation.h"
#include "sp_source.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sp_tagger_settings {
    /* frames held at once (2..1024, default 32: about 1 s at 30 fps, the filter's usual start-up). They are
       frame references of the inner source: a replay's pool needs this many frames on top of its own. */
    unsigned max_waiting;
    /* Camera orientation from elsewhere (e.g. the video-orientation pre-pass of a capture without an IMU):
       when set, every frame's orientation comes from it and the IMU filter is never opened. It returns 0
       with *camera_to_world, or non-zero when it has none for the frame (NOT_COVERED). NULL: the IMU. */
    int (*orientation_for)(void *user, uint64_t sequence, int64_t timestamp_ns, sp_quat *camera_to_world);
    void *orientation_user;
} sp_tagger_settings;

typedef struct sp_tagger_stats {
    uint64_t frames;          /* frames handed on */
    uint64_t imu_samples;
    uint64_t oriented;        /* frames with SP_ORIENTATION_OK */
    uint64_t no_imu;          /* ... NO_IMU */
    uint64_t not_covered;     /* ... NOT_COVERED */
    uint64_t thinned;         /* dropped while the filter initialised (see the top) */
    uint64_t side_attached;   /* side data attached to its frame */
    int have_filter;          /* an IMU sample came: `filter` holds the filter's counters */
    sp_orientation_stats filter;
} sp_tagger_stats;

SP_API void sp_tagger_default_settings(sp_tagger_settings *s);
/*
 * Wraps `inner` (borrowed: it must outlive the tagger and is not closed by it);
 * settings are copied, NULL for the defaults. The caller owns *out and closes it
 * with sp_source_close, which releases the frames still waiting.
 */
SP_API int sp_tagger_open(sp_source **out, sp_source *inner, const sp_tagger_settings *s);
/* Counters so far; -EINVAL if src is not a tagger. */
SP_API int sp_tagger_get_stats(const sp_source *src, sp_tagger_stats *out);

#ifdef __cplusplus
}
#endif
#endif
