/* SPDX-License-Identifier: MIT */
/*
 * The recorder: a capture thread pulls frames from a camera and samples from an
 * IMU and hands references to a writer thread through bounded lock-free queues,
 * so the capture side never waits on the disk. When a queue is full the item is
 * dropped and counted. The writer appends to a .spcap container (sp_capture.h).
 * Stops on request (async-signal-safe), at the duration, when the camera goes
 * away (-ENODEV) or when the disk fills (-ENOSPC); the file is valid in every case.
 */
#ifndef SUNPROBE_SP_RECORDER_H
#define SUNPROBE_SP_RECORDER_H

#include <stdint.h>

#include "sp_camera.h"
#include "sp_capture.h"
#include "sp_common.h"
#include "sp_imu_device.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sp_recorder_settings {
    const char *path;          /* output .spcap; borrowed for open */
    sp_camera *camera;         /* opened, not started; borrowed until close */
    sp_imu_device *imu;        /* opened, not started, or NULL; borrowed until close */
    const char *kind;          /* "selfie" or "static" (META); default "selfie" */
    double duration_s;         /* stop after this long; 0 = until stopped */
    unsigned frame_queue;      /* frames in flight to the writer; default 16 */
    unsigned imu_queue;        /* IMU batches in flight; default 128 */
    unsigned imu_batch;        /* samples per IMU chunk (at most 256); default 64 */
    uint32_t writer_delay_us;  /* test knob: the writer sleeps this long per chunk (a slow disk) */
    sp_capture_writer_settings writer;
} sp_recorder_settings;

typedef enum sp_recorder_end {
    SP_RECORDER_RUNNING = 0,
    SP_RECORDER_DURATION = 1,   /* the duration elapsed */
    SP_RECORDER_STOPPED = 2,    /* sp_recorder_request_stop (e.g. SIGINT) */
    SP_RECORDER_DEVICE_LOST = 3, /* the camera went away: everything before it kept */
    SP_RECORDER_DISK_FULL = 4,  /* ENOSPC or EFBIG: everything before it kept */
    SP_RECORDER_ERROR = 5,      /* another device or write error; see sp_recorder_stats.error */
    SP_RECORDER_SOURCE_END = 6, /* a finite camera source ended */
} sp_recorder_end;

typedef struct sp_recorder_stats {
    uint64_t frames_captured;  /* taken from the camera */
    uint64_t frames_written;
    uint64_t frames_dropped;   /* queue full: the writer fell behind */
    uint64_t frames_discarded; /* queued but not written because writing had failed */
    uint64_t device_dropped;   /* lost inside the camera backend */
    uint64_t imu_samples_written;
    uint64_t imu_samples_dropped;
    uint64_t bytes_written;
    double duration_s;         /* first to last frame timestamp */
    sp_recorder_end end;
    int error;                 /* first error that ended the recording, 0 if none */
} sp_recorder_stats;

typedef struct sp_recorder sp_recorder;

SP_API void sp_recorder_default_settings(sp_recorder_settings *s);
SP_API const char *sp_recorder_end_name(sp_recorder_end end);
/* Creates the file and writes the header; no threads yet. The caller owns *out. */
SP_API int sp_recorder_open(sp_recorder **out, const sp_recorder_settings *s);
/* Starts the devices, writes the opening META (devices as negotiated), starts both threads. */
SP_API int sp_recorder_start(sp_recorder *rec);
/* Asks both threads to finish; async-signal-safe, callable from any thread. */
SP_API void sp_recorder_request_stop(sp_recorder *rec);
/* Has the recording ended (without waiting)? */
SP_API int sp_recorder_finished(const sp_recorder *rec);
/*
 * Waits for the end, closes the file (INDEX + END) and fills *stats (may be NULL).
 * Returns 0 when the recording ended by duration or request, else the error that
 * ended it (-ENODEV, -ENOSPC, ...); the file is valid either way.
 */
SP_API int sp_recorder_wait(sp_recorder *rec, sp_recorder_stats *stats);
/* Live counters while recording (approximate, read without locks). */
SP_API void sp_recorder_get_stats(const sp_recorder *rec, sp_recorder_stats *stats);
/* Stops and waits if still running, frees; *rec becomes NULL. */
SP_API void sp_recorder_close(sp_recorder **rec);

#ifdef __cplusplus
}
#endif
#endif
