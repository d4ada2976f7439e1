/* SPDX-License-Identifier: MIT */
/*
 * A strict little CSV reader for the importers' numeric tables: a header row of
 * column names, then rows with the same number of comma-separated fields.
 * Blank lines and lines starting with '#' are skipped; fields are trimmed; no
 * quoting (names may be wrapped in double quotes). Every error message names the
 * file and line. Internal, not installed.
 */
#ifndef SUNPROBE_CAPTURE_IMPORT_CSV_H
#define SUNPROBE_CAPTURE_IMPORT_CSV_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "common/private_api.h"

typedef struct sp_csv {
    FILE *file;
    const char *path;      /* borrowed from the caller for the reader's life */
    unsigned long line;    /* 1-based line number of the current row */
    char *buf;
    size_t buf_cap;
    char **fields;         /* the current row, pointing into buf */
    size_t nfields, fields_cap;
    char **names;          /* header names (owned copies) */
    size_t nnames;
    int headerless;        /* no header row: the first row's width counts */
    char *err;             /* message buffer of the caller */
    size_t err_size;
} sp_csv;

/*
 * Opens path and reads its header row. Errors (with a message in err):
 * -ENOENT/-EACCES etc. when it cannot be opened, SP_ENODATA when there is no
 * header, SP_ECORRUPT for an empty or duplicate column name.
 */
SP_PRIVATE int sp_csv_open(sp_csv *c, const char *path, char *err, size_t err_size);
/*
 * The same for an open stream (ownership moves to c, closed by sp_csv_close, also on failure), whose
 * first lines_before lines were already read by the caller (messages count them). header 0: no header
 * row; every row must have as many fields as the first, and columns are named "1", "2", ...
 */
int sp_csv_open_stream(sp_csv *c, FILE *f, const char *path, unsigned long lines_before, int header, char *err,
                       size_t err_size);
SP_PRIVATE void sp_csv_close(sp_csv *c);
/* Column index of name, or -1. */
SP_PRIVATE int sp_csv_column(const sp_csv *c, const char *name);
/* Reads the next data row: 0, SP_EOS at the end, SP_ECORRUPT for a wrong field count. */
SP_PRIVATE int sp_csv_next(sp_csv *c);
/* 1 when field col of the current row is empty. */
int sp_csv_empty(const sp_csv *c, int col);
/* A finite number from field col; SP_ECORRUPT (NaN, Inf, empty, junk) with a message naming line and column. */
SP_PRIVATE int sp_csv_double(sp_csv *c, int col, double *out);
/* A decimal integer from field col; SP_ECORRUPT when malformed or out of range. */
SP_PRIVATE int sp_csv_int64(sp_csv *c, int col, int64_t *out);
/* Finds the time column: exactly one of `t` (seconds) and `t_ns` (nanoseconds), the other -1. */
int sp_csv_time_columns(sp_csv *c, int *col_t, int *col_tns);
/* A time in ns from a `t` (seconds) or `t_ns` column, whichever exists (col_t/col_tns, -1 if absent). */
int sp_csv_time_ns(sp_csv *c, int col_t, int col_tns, int64_t *out);
/* Formats "PATH:LINE: " + message into err and returns rc (for callers' own checks). */
SP_PRIVATE int sp_csv_fail(sp_csv *c, int rc, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

#endif
