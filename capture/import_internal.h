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
} sp_import_imu;

/* Opens path and checks its header: a time column and at least one complete sensor. */
int sp_import_imu_open(sp_import_imu *r, const char *path, int64_t shift_ns, char *msg, size_t msg_size);
/* The next sample in file order without taking it: 0, SP_EOS, or SP_ECORRUPT (message set). */
int sp_import_imu_peek(sp_import_imu *r, const sp_imu_sample **out);
/* Takes the sample the last peek returned. */
void sp_import_imu_pop(sp_import_imu *r);
void sp_import_imu_close(sp_import_imu *r);

/* ---- metadata (import_meta.c) ---- */

/*
 * Reads a META JSON file: parsed into *root (caller frees with sp_json_free),
 * known keys type-checked, then merged into meta exactly as readers will judge it.
 */
int sp_import_meta_load(const char *path, sp_json **root, sp_capture_meta *meta, char *msg, size_t msg_size);
/*
 * The META chunk: root's members (root may be NULL) with kind (NULL: root's),
 * source (root's, else "import:INPUT") and camera width/height/fps (fps only if > 0) put over them.
 */
int sp_import_meta_build(const sp_json *root, const char *kind, const char *input, uint32_t w, uint32_t h,
                         double fps, sp_strbuf *b);

#endif
