/* SPDX-License-Identifier: MIT */
/*
 * The capture container (.spcap): an append-only sequence of checksummed chunks
 * after a versioned header. Writer, reader and recovery. Layout: capture/FORMAT.md.
 */
#ifndef SUNPROBE_SP_CAPTURE_H
#define SUNPROBE_SP_CAPTURE_H

#include <stddef.h>
#include <stdint.h>

#include "sp_common.h"
#include "sp_frame.h"
#include "sp_imu.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SP_CAPTURE_VERSION_MAJOR 1
#define SP_CAPTURE_VERSION_MINOR 0

/* Chunk types; values are on-disk codes. */
enum sp_chunk_type {
    SP_CHUNK_META = 1,  /* UTF-8 JSON object: devices, calibration, location (FORMAT.md) */
    SP_CHUNK_FRAME = 2, /* one camera frame as the device delivered it */
    SP_CHUNK_IMU = 3,   /* a batch of IMU samples */
    SP_CHUNK_SIDE = 4,  /* per-frame side data, e.g. 2-D landmarks */
    SP_CHUNK_INDEX = 5, /* offsets and timestamps of the chunks since the previous index */
    SP_CHUNK_END = 6,   /* clean close marker; nothing follows */
};

/* Side-data kinds. */
enum sp_side_kind {
    SP_SIDE_LANDMARKS_2D = 1, /* float x,y pairs in pixels, Multi-PIE order for 68 points */
    SP_SIDE_TRUE_ORIENTATION = 2, /* ground truth of synthetic captures: camera-to-world quaternion w,x,y,z */
};

/* ---- writer ---- */

enum sp_sync_policy {
    SP_SYNC_NONE = 0,        /* leave flushing to the kernel: survives a killed process, not power loss */
    SP_SYNC_PERIODIC = 1,    /* fdatasync when sync_interval_ms has passed since the last one */
    SP_SYNC_EVERY_CHUNK = 2, /* fdatasync after every chunk: power loss costs at most one chunk */
};

typedef struct sp_capture_writer_settings {
    enum sp_sync_policy sync;  /* default SP_SYNC_PERIODIC */
    uint32_t sync_interval_ms; /* default 1000 */
    uint32_t index_interval;   /* chunks between index chunks, default 256; 0 disables */
    int overwrite;             /* replace an existing file; default 0 (fail with -EEXIST) */
} sp_capture_writer_settings;

typedef struct sp_capture_writer sp_capture_writer;

SP_API void sp_capture_writer_default_settings(sp_capture_writer_settings *s);
/* Creates `path` and writes its header durably. `path` is borrowed for the call. */
SP_API int sp_capture_writer_open(sp_capture_writer **out, const char *path,
                                  const sp_capture_writer_settings *s);
/* Each append writes one whole chunk; when it returns 0 the chunk survives a killed process. */
SP_API int sp_capture_write_meta(sp_capture_writer *w, int64_t timestamp_ns, const char *json, size_t len);
SP_API int sp_capture_write_frame(sp_capture_writer *w, const sp_frame *frame);
/* Samples must be non-empty; the chunk's timestamp is the first sample's. */
SP_API int sp_capture_write_imu(sp_capture_writer *w, const sp_imu_sample *samples, size_t count);
/* `values` holds `count` floats for the frame with sequence `frame_sequence`. */
SP_API int sp_capture_write_side(sp_capture_writer *w, int64_t timestamp_ns, uint64_t frame_sequence,
                                 enum sp_side_kind kind, const float *values, uint32_t count);
/* Forces written chunks to stable storage now. */
SP_API int sp_capture_writer_sync(sp_capture_writer *w);
SP_API uint64_t sp_capture_writer_bytes(const sp_capture_writer *w);
/* Writes the last index and the END chunk, syncs and closes; *w becomes NULL even on error. */
SP_API int sp_capture_writer_close(sp_capture_writer **w);

/* ---- reader ---- */

typedef struct sp_capture_reader_settings {
    int skip_corrupt;        /* on a bad chunk, resynchronise and go on (counted); default 0: stop with SP_ECORRUPT */
    uint32_t max_chunk_size; /* larger payloads are treated as corrupt; default 256 MiB */
} sp_capture_reader_settings;

typedef struct sp_capture_reader sp_capture_reader;

typedef struct sp_chunk {
    uint16_t type;          /* enum sp_chunk_type; unknown types are returned, not failed */
    uint16_t flags;
    int64_t timestamp_ns;
    uint64_t offset;        /* byte offset of the chunk header in the file */
    uint32_t payload_size;
    const uint8_t *payload; /* borrowed: valid until the next call on the reader */
} sp_chunk;

typedef struct sp_capture_info {
    uint16_t version_major, version_minor;
    uint64_t file_size;
    int64_t created_utc_ns; /* wall-clock creation time from the header, 0 if unknown */
} sp_capture_info;

SP_API void sp_capture_reader_default_settings(sp_capture_reader_settings *s);
/*
 * Opens and validates the header: SP_EFORMAT for a wrong magic, SP_EVERSION for a
 * newer major version, SP_ETRUNCATED for a short header.
 */
SP_API int sp_capture_reader_open(sp_capture_reader **out, const char *path,
                                  const sp_capture_reader_settings *s);
SP_API void sp_capture_reader_close(sp_capture_reader **r);
SP_API const sp_capture_info *sp_capture_reader_info(const sp_capture_reader *r);
/*
 * Next chunk in file order. Returns 0, SP_EOS at the END chunk or a clean end of
 * file, SP_ETRUNCATED for a torn tail (chunk->offset says where), or SP_ECORRUPT
 * for a bad chunk when skip_corrupt is off (chunk->offset says where).
 */
SP_API int sp_capture_reader_next(sp_capture_reader *r, sp_chunk *chunk);
/* Chunks skipped as corrupt so far (skip_corrupt mode). */
SP_API uint64_t sp_capture_reader_corrupt_count(const sp_capture_reader *r);
/* Offset of the first corrupt chunk skipped, UINT64_MAX when none. */
SP_API uint64_t sp_capture_reader_first_corrupt_offset(const sp_capture_reader *r);
/* 1 once the reader has reached the END chunk: the writer closed the file cleanly. */
SP_API int sp_capture_reader_saw_end(const sp_capture_reader *r);
/* Repositions at the last indexed chunk at or before timestamp_ns (start of file if none). */
SP_API int sp_capture_reader_seek(sp_capture_reader *r, int64_t timestamp_ns);
/* Repositions at a chunk offset previously reported by sp_capture_reader_next. */
SP_API int sp_capture_reader_seek_offset(sp_capture_reader *r, uint64_t offset);

/* ---- payload views ---- */

typedef struct sp_frame_chunk {
    enum sp_pixfmt format;
    uint32_t width, height, stride;
    uint32_t stream_id;
    uint64_t sequence;
    float exposure_us, gain; /* NaN when unknown */
    const uint8_t *data;     /* borrowed from the chunk */
    uint32_t data_size;
} sp_frame_chunk;

/* Validates a FRAME chunk (sizes consistent with format) and describes it. */
SP_API int sp_chunk_parse_frame(const sp_chunk *chunk, sp_frame_chunk *out);
/* Number of samples in an IMU chunk, or a negative error if it is malformed. */
SP_API int64_t sp_chunk_imu_count(const sp_chunk *chunk);
/* Copies sample i out (payloads are not aligned for direct access). */
SP_API int sp_chunk_imu_get(const sp_chunk *chunk, size_t i, sp_imu_sample *out);

typedef struct sp_side_chunk {
    uint64_t frame_sequence;
    uint32_t kind; /* enum sp_side_kind */
    uint32_t count;
    const uint8_t *values; /* `count` little-endian floats, borrowed from the chunk */
} sp_side_chunk;

SP_API int sp_chunk_parse_side(const sp_chunk *chunk, sp_side_chunk *out);
SP_API float sp_side_value(const sp_side_chunk *side, uint32_t i);

/* ---- recovery ---- */

typedef struct sp_recover_report {
    uint64_t chunks_kept;
    uint64_t valid_bytes;     /* length of the valid prefix */
    uint64_t bytes_dropped;   /* torn or corrupt tail removed */
    int had_end;              /* the file was closed cleanly */
} sp_recover_report;

/*
 * Keeps the longest valid prefix of `path`: in place (truncates) when out_path is
 * NULL, else into a new file out_path, leaving `path` untouched. Adds an END chunk.
 */
SP_API int sp_capture_recover(const char *path, const char *out_path, sp_recover_report *report);

#ifdef __cplusplus
}
#endif
#endif
