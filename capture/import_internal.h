/* SPDX-License-Identifier: MIT */
/*
 * Pieces of the importers shared between import.c (the run), import_files.c (input
 * lists), import_imu.c (IMU CSV) and import_meta.c (META JSON). Every function that
 * can fail writes a message naming the file (and line) into msg, unless msg already
 * holds one: the first message names the cause. Internal, not installed.
 */
#ifndef SUNPROBE_CAPTURE_IMPORT_INTERNAL_H
#define SUNPROBE_CAPTURE_IMPORT_INTERNAL_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "capture/import_csv.h"
#include "common/json.h"
#include "sunprobe/sp_common.h"
#include "sunprobe/sp_imu.h"
#include "sunprobe/sp_meta.h"

/* Formats into msg when it is still empty; returns rc. */
int sp_import_fail(char *msg, size_t msg_size, int rc, const char *fmt, ...) SP_PRINTF(4, 5);

/* ---- input lists (import_files.c) ---- */

typedef struct sp_import_paths {
    char **items; /* owned */
    size_t count, cap;
} sp_import_paths;

/* Appends "dir/name" (or name when dir is NULL). */
int sp_import_paths_add(sp_import_paths *l, const char *dir, const char *name);
void sp_import_paths_free(sp_import_paths *l);
/* A name ending in .jpg, .jpeg or .png, any case. */
int sp_import_is_image_name(const char *name);
/* strcmp, except that runs of digits compare as numbers: "img_2" < "img_10". */
int sp_import_natural_cmp(const char *a, const char *b);
/* Image files of dir (hidden ones and directories skipped) in natural order; SP_ENODATA if none. */
int sp_import_list_directory(const char *dir, sp_import_paths *out, char *msg, size_t msg_size);
/* Files of a pattern with one %d/%Nd/%0Nd, from the first existing index in 0..4 to the first gap. */
int sp_import_list_pattern(const char *pattern, sp_import_paths *out, char *msg, size_t msg_size);

/* ---- IMU CSV (import_imu.c) ---- */

typedef struct sp_import_log sp_import_log; /* below */

/* The IMU CSV read one row at a time; a row yields up to one sample per sensor. */
typedef struct sp_import_imu {
    sp_csv csv;
    int open;
    int col_t, col_tns;
    int cols[3][3];   /* [gyro, accel, mag][x, y, z] column indices, -1 when absent */
    int64_t shift_ns; /* added to every CSV time */
    int64_t last_row_ns;
    int64_t last_ns[3];
    int have_row, have_sensor[3];
    sp_imu_sample row[3];
    int nrow, irow;
    int eof;
    const sp_import_log *log; /* when set, samples come from it instead of the CSV */
    size_t ilog;
} sp_import_imu;

/* Opens path and checks its header: a time column and at least one complete sensor. */
int sp_import_imu_open(sp_import_imu *r, const char *path, int64_t shift_ns, char *msg, size_t msg_size);
/* Serves a log read whole (borrowed until close) through the same peek/pop, shifted by shift_ns. */
void sp_import_imu_from_log(sp_import_imu *r, const sp_import_log *log, int64_t shift_ns);
/* The next sample in file order without taking it: 0, SP_EOS, or SP_ECORRUPT (message set). */
int sp_import_imu_peek(sp_import_imu *r, const sp_imu_sample **out);
/* Takes the sample the last peek returned. */
void sp_import_imu_pop(sp_import_imu *r);
void sp_import_imu_close(sp_import_imu *r);

/* ---- sensor-log exports: a directory or a .zip (import_bundle.c) ---- */

typedef struct sp_import_bundle {
    const char *path; /* borrowed */
    void *zip;        /* libzip archive, NULL for a directory */
} sp_import_bundle;

/* 1 when path is a file starting with a zip local-file signature. */
int sp_import_is_zip(const char *path);
/* Opens a directory or a zip (SP_EDISABLED without libzip). */
int sp_import_bundle_open(sp_import_bundle *b, const char *path, char *msg, size_t msg_size);
void sp_import_bundle_close(sp_import_bundle *b);
/* The first file whose base name passes match (top level or one directory down) into out: 1, or 0 none. */
int sp_import_bundle_find(sp_import_bundle *b, int (*match)(const char *, const void *), const void *arg, char *out,
                          size_t out_size);
int sp_import_match_name(const char *name, const void *want); /* want: a base name, any case */
int sp_import_match_video(const char *name, const void *unused); /* .mp4 or .mov */
/* A found file as a stream (caller closes; a zip entry is copied into an anonymous temporary file). */
int sp_import_bundle_fopen(sp_import_bundle *b, const char *name, FILE **out, char *msg, size_t msg_size);
/* Copies a zip entry to a new temporary file in near's directory; its path in out (caller removes it). */
int sp_import_bundle_extract(sp_import_bundle *b, const char *name, const char *near, char *out, size_t out_size,
                             char *msg, size_t msg_size);

/* ---- IMU logs of other apps, read whole (import_logs.c) ---- */

enum sp_import_clock {
    SP_CLOCK_VIDEO, /* t = 0 is the first frame (sunprobe CSV, gcsv) */
    SP_CLOCK_EPOCH, /* ns since 1970 (Sensor Logger) */
    SP_CLOCK_SHARED /* a device clock that the log's own frame times share (OpenCamera-Sensors) */
};

struct sp_import_log {
    sp_imu_sample *s;   /* sorted by time, on the log's clock */
    size_t n, cap;
    enum sp_import_clock clock;
    int has_start;      /* start_ns: the video's first frame on the log's clock */
    int64_t start_ns;
    const char *start_from; /* what start_ns was taken from, for the log */
    int64_t *frame_ns;  /* per-frame times on the log's clock, or NULL */
    size_t nframes;
    const char *format; /* "Sensor Logger", ... for messages */
    char video[4096];   /* a video inside the export (Sensor Logger), else empty */
    int video_temp;     /* video is a temporary copy the caller removes */
    int has_location;   /* a GNSS fix from the export (Sensor Logger's Location.csv) */
    double location[3]; /* latitude, longitude (degrees), altitude (m, NaN unknown) */
    double location_accuracy_m; /* its horizontal accuracy, NaN unknown */
};

/* Which reader a path needs: by --imu-format, else by content. */
int sp_import_log_detect(const char *path, int format, int *out, char *msg, size_t msg_size);
/*
 * Reads a log of format (not SP_IMPORT_IMU_SUNPROBE, which streams) whole into log. near: the
 * output path, beside which a zip's video is unpacked when want_video.
 */
int sp_import_log_load(sp_import_log *log, const char *path, int format, const char *near, int want_video, char *msg,
                       size_t msg_size);
void sp_import_log_free(sp_import_log *log);
/* Appends one sample (values converted to float). */
int sp_import_log_push(sp_import_log *log, int64_t t, uint32_t sensor, const double v[3]);
/* Gyroflow .gcsv (import_gcsv.c). */
int sp_import_log_gcsv(sp_import_log *log, const char *path, char *msg, size_t msg_size);

/* ---- per-frame exposure (import_exposure.c) ---- */

typedef struct sp_import_exposure {
    float (*v)[2];    /* per frame: exposure_us, gain (NaN unknown) */
    size_t n, cap;
    const char *path; /* borrowed */
} sp_import_exposure;

/* col[] = exposure_s, iso, gain (-1 absent): 1 when any is there, 0 none, SP_ECORRUPT for iso and gain both. */
int sp_import_exposure_columns(sp_csv *csv, int col[3]);
/* Appends the current row's exposure (empty cells: unknown). */
int sp_import_exposure_row(sp_import_exposure *x, sp_csv *csv, const int col[3]);
/* A CSV of its own (--exposure): one row per frame. */
int sp_import_exposure_load(sp_import_exposure *x, const char *path, char *msg, size_t msg_size);
void sp_import_exposure_free(sp_import_exposure *x);

/* ---- --imu-offset auto (import_sync.c) ---- */

typedef struct sp_sync_pair {
    double t0, t1; /* the two frames' times, ns */
    double m;      /* visual motion between them, px/s of a grey thumbnail */
} sp_sync_pair;

typedef struct sp_import_sync {
    sp_sync_pair *pairs;
    size_t n, cap;
    float *prev, *cur; /* thumbnails */
    int tw, th, have_prev;
    int64_t prev_t;
    double *gt, *gw;   /* gyro times (ns, shifted by the base offset) and rate magnitudes (rad/s) */
    size_t gn, gcap;
} sp_import_sync;

/* Adds a frame (RGB24, borrowed) at t_ns on the frame clock. */
int sp_import_sync_frame(sp_import_sync *s, const uint8_t *rgb, uint32_t w, uint32_t h, int64_t t_ns);
/* Adds a gyro sample (rad/s) at t_ns, in time order. */
int sp_import_sync_gyro(sp_import_sync *s, int64_t t_ns, const float v[3]);
/*
 * The offset (s, added to IMU times) in base_s +- range_s maximising the correlation (into *corr).
 * SP_ENODATA too little data or overlap, SP_ECORRUPT no clear peak (messages say so).
 */
int sp_import_sync_estimate(const sp_import_sync *s, double base_s, double range_s, double *offset_s, double *corr,
                            char *msg, size_t msg_size);
void sp_import_sync_free(sp_import_sync *s);

/* ---- metadata (import_meta.c) ---- */

/*
 * Reads a META JSON file: parsed into *root (caller frees with sp_json_free),
 * known keys type-checked, then merged into meta exactly as readers will judge it.
 */
int sp_import_meta_load(const char *path, sp_json **root, sp_capture_meta *meta, char *msg, size_t msg_size);
/* What a sensor log says about the capture beyond its samples; the user's metadata wins over it. */
typedef struct sp_import_meta_extra {
    const char *utc_start; /* ISO 8601 UTC of the first frame, or NULL */
    int has_location;
    double location[3];    /* latitude, longitude, altitude_m (NaN: left out) */
} sp_import_meta_extra;

/*
 * The META chunk: root's members (root may be NULL) with kind (NULL: root's), source (root's,
 * else "import:INPUT"), camera width/height/fps (fps only if > 0) and imu.to_camera (w, x, y, z;
 * NULL: root's) put over them; extra's utc_start and location where root has none (extra may be NULL).
 */
int sp_import_meta_build(const sp_json *root, const char *kind, const char *input, uint32_t w, uint32_t h,
                         double fps, const double *to_camera, const sp_import_meta_extra *extra, sp_strbuf *b);

#endif
