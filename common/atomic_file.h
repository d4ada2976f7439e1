/* SPDX-License-Identifier: MIT */
/* Write a file under a temporary name and rename it into place, so a reader never sees half a file. */
#ifndef SUNPROBE_COMMON_ATOMIC_FILE_H
#define SUNPROBE_COMMON_ATOMIC_FILE_H

#include <stdio.h>
#include "common/private_api.h"

typedef struct sp_atomic_file {
    FILE *file;      /* write here */
    char *final_path;
    char *temp_path; /* NULL when writing a special file in place */
} sp_atomic_file;

/*
 * Opens "<path>.tmp.<pid>" beside path. An existing path that is neither a
 * regular file nor a directory (a device such as /dev/stdout, a FIFO) is
 * opened and written in place instead: temp_path is then NULL.
 */
SP_PRIVATE int sp_atomic_file_open(sp_atomic_file *af, const char *path);
/*
 * status 0: flush, fsync and rename into place; otherwise (or if any of those
 * fail) remove the temporary. Returns status, or the first error of finishing.
 */
SP_PRIVATE int sp_atomic_file_finish(sp_atomic_file *af, int status);

#endif
