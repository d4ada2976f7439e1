/* SPDX-License-Identifier: MIT */
/*
 * Importers: an image sequence or a video file, optionally with an IMU CSV,
 * per-frame times and metadata JSON, into a .spcap capture. Input layouts and
 * examples: capture/IMPORT.md.
 */
#ifndef SUNPROBE_SP_IMPORT_H
#define SUNPROBE_SP_IMPORT_H

#include <signal.h>
#include <stddef.h>
#include <stdint.h>

#include "sp_common.h"

#ifdef __cplusplus
extern "C" {
#endif

/* How frames that are not already JPEG files are stored. */
enum sp_import_store {
    SP_IMPORT_STORE_JPEG = 0, /* MJPEG re-encoded at `quality` (needs libjpeg) */
    SP_IMPORT_STORE_RGB = 1,  /* raw RGB24; JPEG files are decoded too (needs libjpeg for those) */
};

/* The IMU log's layout (capture/IMPORT.md, "IMU logs"). */
enum sp_import_imu_format {
    SP_IMPORT_IMU_AUTO = 0,      /* by content */
    SP_IMPORT_IMU_SUNPROBE,      /* the CSV with t/t_ns, gx..mz */
    SP_IMPORT_IMU_SENSOR_LOGGER, /* Sensor Logger: a directory or .zip of per-sensor CSVs */
    SP_IMPORT_IMU_OPENCAMERA,    /* OpenCamera-Sensors: *_gyro.csv, *_accel.csv, *_timestamps.csv */
    SP_IMPORT_IMU_GCSV,          /* Gyroflow .gcsv */
};

/*
 * IMU-to-camera rotation presets for phones (capture/IMPORT.md, "IMU to camera"): the phone's sensor
 * axes (x right, y up, z out of the screen, held in portrait) into camera axes (x right, y down, z
 * forward) for frames shown upright in portrait.
 */
enum sp_import_to_camera {
    SP_IMPORT_TO_CAMERA_KEEP = 0,  /* the metadata's imu.to_camera (identity when absent) */
    SP_IMPORT_TO_CAMERA_IDENTITY,
    SP_IMPORT_TO_CAMERA_ANDROID_FRONT,
    SP_IMPORT_TO_CAMERA_ANDROID_BACK,
    SP_IMPORT_TO_CAMERA_IOS_FRONT,
    SP_IMPORT_TO_CAMERA_IOS_BACK,
};

/* The preset's unit quaternion (w, x, y, z) into q; -EINVAL for KEEP or an unknown value. */
SP_API int sp_import_to_camera_preset(enum sp_import_to_camera preset, double q[4]);

/* The --fps range: what a capture's META camera.fps may hold (capture/FORMAT.md). */
#define SP_IMPORT_MIN_FPS 1e-3
#define SP_IMPORT_MAX_FPS 1e4

typedef struct sp_import_settings {
    /*
     * A directory of .jpg/.jpeg/.png files (sorted by name, digit runs compared
     * as numbers), a printf-style pattern such as "shots/img_%04d.png" (first
     * index 0..4, up to the first missing number), one image, a video file, or a
     * Sensor Logger export (a .zip, or a directory with Gyroscope.csv: its video and IMU).
     */
    const char *input;
    /* The capture to create. Written as "<output>.partial", renamed when complete, removed on failure. */
    const char *output;
    /*
     * Frames per second for timestamps, SP_IMPORT_MIN_FPS..SP_IMPORT_MAX_FPS; 0: the
     * frame-times CSV, else the video's rate, else camera.fps. -EINVAL outside.
     */
    double fps;
    const char *frame_times_csv; /* optional: one row per frame, column t (s) or t_ns; exposure_s, iso or gain too */
    const char *exposure_csv;    /* optional: one row per frame, columns exposure_s and/or iso or gain */
    const char *imu_csv;         /* optional: the sunprobe CSV or an app's log (imu_format; IMPORT.md) */
    double imu_offset_s;         /* added to every IMU time (seconds, |x| <= 1e6); default 0 */
    int imu_offset_auto;         /* estimate the offset from gyro and frames instead (imu_offset_s unused) */
    double imu_offset_range_s;   /* its search range, +- seconds around the clock's mapping; default 2 */
    enum sp_import_imu_format imu_format; /* default SP_IMPORT_IMU_AUTO */
    enum sp_import_to_camera imu_to_camera; /* default KEEP; a preset replaces the metadata's imu.to_camera */
    const char *meta_json;       /* optional: META JSON (capture/FORMAT.md), merged with what the import knows */
    const char *kind;            /* "selfie", "static" or NULL to keep the metadata's */
    enum sp_import_store store;  /* default SP_IMPORT_STORE_JPEG; JPEG files are always copied byte-for-byte */
    int quality;                 /* JPEG quality 1..100 for re-encoded frames, default 92 */
    uint64_t max_frames;         /* stop after this many frames; 0 = all */
    int overwrite;               /* replace an existing output; default 0: fail with -EEXIST */
    uint32_t imu_batch;          /* most samples per IMU chunk, default 256 */
    /* Polled between frames: non-zero stops the import with -ECANCELED (e.g. set from a signal handler). */
    const volatile sig_atomic_t *cancel;
    /* Called after each frame, may be NULL; total is 0 when unknown. */
    void (*progress)(void *user, uint64_t done, uint64_t total);
    void *progress_user;
} sp_import_settings;

typedef struct sp_import_report {
    uint64_t frames;        /* frames written */
    uint64_t frames_copied; /* of those, JPEG files stored byte-for-byte */
    uint64_t imu_samples;   /* samples written (one per sensor per CSV row) */
    uint64_t imu_chunks;
    uint32_t width, height;
    double fps;             /* the nominal rate written to the metadata */
    int64_t last_frame_ns;  /* timestamp of the last frame; the first is 0 */
    char frame_clock[64];   /* where the frame times came from */
    double imu_offset_s;    /* with imu_offset_auto: the estimate */
    double imu_offset_corr; /* and its correlation, -1..1 */
    char imu_clock[256];    /* how the IMU log's clock was mapped to the frames', for the user */
    /* On failure: what went wrong, naming the file and line where there is one. */
    char message[512];
} sp_import_report;

SP_API void sp_import_default_settings(sp_import_settings *s);
/*
 * Runs the import described by s (borrowed for the call) and fills report (may
 * be NULL). Returns 0; -EINVAL for bad settings; -EEXIST when the output exists;
 * -ENOENT for a missing input; SP_ENODATA for an empty sequence; SP_EFORMAT for
 * unreadable images or video; SP_ECORRUPT for bad CSV/JSON content (NaN/Inf,
 * non-monotonic times or duplicate rows, missing columns or scales, wrong types,
 * an IMU log that never overlaps the frames, no clear --imu-offset auto estimate);
 * SP_EDISABLED when the input needs OpenCV (`-Dopencv`), libjpeg (`-Djpeg`) or
 * libzip (`-Dlibzip`) and the build has none; -ECANCELED when *cancel became
 * non-zero. On any failure no output file is left (nor an unpacked video).
 */
SP_API int sp_import_run(const sp_import_settings *s, sp_import_report *report);

#ifdef __cplusplus
}
#endif
#endif
