/* SPDX-License-Identifier: MIT */
/*
 * Replay is a device: it turns a .spcap file back into the frame + IMU event
 * stream a live camera and IMU produce, in timestamp order across chunk types,
 * with refcounted frames from a pool and bounded memory whatever the file size.
 * The META chunks before the first frame chunk come first, whatever their
 * timestamps; each META event carries the metadata merged so far (ev->meta).
 */
#ifndef SUNPROBE_SP_REPLAY_H
#define SUNPROBE_SP_REPLAY_H

#include <stdint.h>

#include "sp_common.h"
#include "sp_meta.h"
#include "sp_source.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sp_replay_settings {
    int realtime;             /* pace events by their timestamps; default 0 (as fast as possible) */
    double speed;             /* realtime speed factor; default 1.0 */
    int skip_corrupt;         /* skip corrupt chunks (counted) instead of failing; default 0 */
    int64_t reorder_window_ns; /* events are held this long to sort frame/IMU chunks; default 250 ms */
    unsigned pool_frames;     /* frames in the pool: held by the window plus by the consumer; default 16 */
    int64_t start_ns;         /* first timestamp to deliver (seeks via the index); default INT64_MIN */
} sp_replay_settings;

typedef struct sp_replay_stats {
    uint64_t frames, imu_samples, meta_chunks, side_chunks, index_chunks, unknown_chunks;
    uint64_t corrupt_chunks;  /* skipped (skip_corrupt) */
    uint64_t late_events;     /* arrived later than the reorder window allowed: delivered out of order */
    uint64_t bytes_read;
    int truncated;            /* the file ends in a torn chunk (run `sunprobe recover`) */
    int64_t first_ns, last_ns;
    uint64_t error_offset;    /* byte offset of the chunk that stopped the replay with an error, else 0 */
} sp_replay_stats;

SP_API void sp_replay_default_settings(sp_replay_settings *s);
/* Opens `path` (borrowed) as a source; errors as sp_capture_reader_open. */
SP_API int sp_replay_open(sp_source **out, const char *path, const sp_replay_settings *s);
/* Stats so far; -EINVAL if src is not a replay source. */
SP_API int sp_replay_get_stats(const sp_source *src, sp_replay_stats *out);

#ifdef __cplusplus
}
#endif
#endif
