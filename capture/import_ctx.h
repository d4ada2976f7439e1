/* SPDX-License-Identifier: MIT */
/*
 * The state of one import run, shared by import.c (the run, frame times, output), import_read.c
 * (images and video frames) and import_clock.c (the IMU log's clock and --imu-offset auto).
 * Internal, not installed.
 */
#ifndef SUNPROBE_CAPTURE_IMPORT_CTX_H
#define SUNPROBE_CAPTURE_IMPORT_CTX_H

#include <stddef.h>
#include <stdint.h>

#include "capture/container_format.h"
#include "capture/import_internal.h"
#include "capture/opencv_shim.h"
#include "common/file_util.h"
#include "common/jpeg.h"
#include "common/json.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_import.h"
#include "sunprobe/sp_meta.h"

#define MAX_IMAGE_FILE (SPC_MAX_PAYLOAD - SPC_FRAME_HDR_SIZE)

typedef struct import_ctx {
    const sp_import_settings *s;
    sp_import_report *rep;
    sp_import_paths images;  /* image sequence, or empty for a video */
    sp_cv_video_reader *video;
    uint32_t video_w, video_h;
    double video_fps;        /* as the video declares it, 0 if unknown */
    int pts_ok;              /* the container gives presentation times, used for the frame times */
    int64_t pts, pts0;       /* the current and the first frame's presentation time */
    int pts_fixed;           /* frames whose time did not increase, timed a nominal frame later */
    const char *video_path;
    int dry;                 /* the --imu-offset auto pass: frames decoded into rgb, not stored */
    int rgb_fresh;           /* rgb holds the current frame */
    double offset_s;         /* added to IMU times: --imu-offset, or its estimate */
    uint64_t total;          /* frames expected, 0 if unknown */
    uint64_t index;          /* next frame */
    double fps;
    int64_t *times;          /* frame-times CSV in ns, or NULL */
    size_t ntimes;
    const char *times_src;   /* where the frame times came from */
    sp_import_exposure expo; /* per-frame exposure, or empty */
    const char *imu_src;     /* the IMU log: --imu, or INPUT when it is a sensor-log export */
    sp_import_log log;       /* an app's IMU log read whole (import_logs.c) */
    int log_loaded;
    int64_t imu_first, imu_last; /* span of the samples written, on the frame clock */
    uint64_t imu_written;
    sp_import_imu imu;
    sp_imu_sample *batch;
    size_t nbatch;
    sp_json *meta_root;      /* the user's META JSON, or NULL */
    sp_capture_meta meta;
    sp_capture_writer *writer;
    sp_partial partial;      /* the output while it is written */
    uint8_t *file_buf;
    size_t file_cap, file_size;
    uint8_t *rgb;
    size_t rgb_cap;
    sp_jpeg_buffer jpeg;
} import_ctx;

/* A failure with its message (the first one set wins), for the run's report. */
#define FAIL(c, rc, ...) sp_import_fail((c)->rep->message, sizeof((c)->rep->message), rc, __VA_ARGS__)

/* ---- import_read.c ---- */
/* Opens a video (OpenCV); path borrowed for the run. */
int sp_import_open_video(import_ctx *c, const char *path);
/* The next frame (image file or video), with its exposure; SP_EOS after the last. */
int sp_import_next_frame(import_ctx *c, sp_frame *f);

/* ---- import.c ---- */
/*
 * The frame-times CSV at path into c->times (strictly increasing, at least one row) and, unless
 * c->s->exposure_csv, its exposure columns into c->expo; the message in c->rep. Uses c->s and c->rep.
 */
int sp_import_load_frame_times(import_ctx *c, const char *path);
/* Frame i's time on the frame clock (frame-times CSV, container time or i / fps). */
int sp_import_frame_time(import_ctx *c, uint64_t i, int64_t *out);

/* ---- import_clock.c ---- */
/* Reads --imu when it is an app's log (not the sunprobe CSV, which streams). */
int sp_import_load_imu_log(import_ctx *c);
/* --imu-offset auto: sets c->offset_s from a first pass over gyro and frames, then rewinds. */
int sp_import_estimate_offset(import_ctx *c);
/* Sets up c->imu on the frame clock. */
int sp_import_open_imu(import_ctx *c);
/* The first frame's UTC (into utc, n >= 32) and the place from an epoch-clock log, for the META chunk. */
void sp_import_log_extra(const import_ctx *c, char *utc, size_t n, sp_import_meta_extra *x);

#endif
