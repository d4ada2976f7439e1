/* SPDX-License-Identifier: MIT */
/*
 * Small file helpers shared by the modules that read or write whole files:
 * read a file into memory, write one atomically, build and test paths, and
 * stage an output under a ".partial" name that is renamed into place only
 * when complete, so a failed run never leaves an output that looks valid.
 */
#ifndef SUNPROBE_COMMON_FILE_UTIL_H
#define SUNPROBE_COMMON_FILE_UTIL_H

#include <errno.h>
#include <stddef.h>
#include <sys/types.h>
#include "common/private_api.h"

/*
 * The error of the write that just failed: -errno (a full disk is -ENOSPC, a size limit -EFBIG), or -EIO
 * when the C library left none. Call it straight after the failing fwrite/fprintf/fflush/fclose.
 */
static inline int sp_write_error(void)
{
    return errno > 0 ? -errno : -EIO;
}

/*
 * Reads the whole file at path (regular files, pipes and other streams alike).
 * On success *data holds *size bytes followed by one NUL byte that *size does
 * not count (so text can be parsed in place); the caller frees *data.
 * Errors: -errno from open/read (e.g. -ENOENT, -EISDIR), -EFBIG when the file
 * holds more than max_size bytes, -ENOMEM. On error *data and *size are untouched.
 */
SP_PRIVATE int sp_read_whole_file(const char *path, size_t max_size, void **data, size_t *size);

/* Writes size bytes to path through a temporary name + fsync + rename (atomic_file.h); data borrowed. */
SP_PRIVATE int sp_write_whole_file_atomic(const char *path, const void *data, size_t size);

/* "dir/name" into buf of n bytes; -ENAMETOOLONG when it does not fit. */
int sp_path_join(char *buf, size_t n, const char *dir, const char *name);
/* "dir/name" in a new string the caller frees, or NULL when out of memory. */
SP_PRIVATE char *sp_path_join_alloc(const char *dir, const char *name);
/* 1 when path names a regular file (symlinks followed), else 0. */
SP_PRIVATE int sp_is_regular_file(const char *path);
/* Creates dir and its missing parents with mode; existing directories are fine (-ENOTDIR if a file is in the way). */
SP_PRIVATE int sp_mkdir_p(const char *dir, mode_t mode);
/* Removes path and, for a directory, everything below it (symlinks are removed, never followed). */
int sp_remove_tree(const char *path);
/* fsyncs the directory holding path, so a rename or create in it is durable. */
int sp_sync_parent_dir(const char *path);

/* An output staged under a temporary name. */
typedef struct sp_partial {
    char *path;       /* write here (owned by the struct) */
    char *final_path; /* renamed to this on commit */
    int is_dir;
} sp_partial;

/* Commit flags. */
#define SP_PARTIAL_REPLACE 1 /* replace an existing output (a directory, for a partial directory) */

/*
 * Creates the directory "<final_dir>.partial.<pid>" (mode 0755; -EEXIST if it is
 * already there) and sets pd->path to it. The pid keeps two runs apart. First
 * removes the user's own "<final_dir>.partial.<pid>" directories whose process
 * no longer runs (left by a crash or SIGKILL; logged).
 */
SP_PRIVATE int sp_partial_dir_open(sp_partial *pd, const char *final_dir);
/*
 * fsyncs every file and directory below pd->path, renames it to the final
 * name and syncs the parent. An existing empty final directory is replaced; a
 * non-empty one (or a file) only with SP_PARTIAL_REPLACE, else -EEXIST. On
 * success pd is reset; on failure the partial directory is kept (call abort).
 */
SP_PRIVATE int sp_partial_dir_commit(sp_partial *pd, int flags);
/* Removes the partial directory and all it holds; resets pd. Safe on a zeroed or committed pd. */
SP_PRIVATE void sp_partial_dir_abort(sp_partial *pd);

/*
 * Sets pf->path to "<final_path>.partial" without creating anything: the caller
 * creates and fills the file. The name has no pid on purpose, so a file left by
 * an interrupted run is simply overwritten by the next one.
 */
SP_PRIVATE int sp_partial_file_open(sp_partial *pf, const char *final_path);
/*
 * Renames the finished file (which the caller has written, synced and closed)
 * to the final name, then syncs the parent directory (a failure there is only
 * logged: the file is complete). Without SP_PARTIAL_REPLACE an existing final
 * file is kept and -EEXIST returned. On success pf is reset.
 */
SP_PRIVATE int sp_partial_file_commit(sp_partial *pf, int flags);
/* Releases pf's names without touching the file system (the partial file was never ours). */
SP_PRIVATE void sp_partial_forget(sp_partial *p);
/* Unlinks the partial file if present (a failure is logged) and resets pf. Safe on a zeroed or committed pf. */
SP_PRIVATE void sp_partial_file_abort(sp_partial *pf);

#endif
