/* SPDX-License-Identifier: MIT */
/*
 * Shared by the harnesses whose reader takes a path: one scratch directory per process (removed at
 * exit with what the harness put in it) and the input written there under a name.
 */
#ifndef SUNPROBE_TESTS_FUZZ_UTIL_H
#define SUNPROBE_TESTS_FUZZ_UTIL_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* A broken invariant: where, then abort (libFuzzer keeps the input) */
#define FUZZ_FAIL(why) (fprintf(stderr, "%s:%d: %s\n", __FILE__, __LINE__, why), abort())

static char fuzz_dir_path[256];

static void fuzz_dir_remove(void)
{
    char cmd[300];
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", fuzz_dir_path);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", fuzz_dir_path);
}

/* The scratch directory, made on the first call. */
static inline const char *fuzz_dir(void)
{
    if (!fuzz_dir_path[0]) {
        snprintf(fuzz_dir_path, sizeof(fuzz_dir_path), "%s/sp-fuzz.XXXXXX", getenv("TMPDIR") && *getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
        if (!mkdtemp(fuzz_dir_path))
            abort();
        atexit(fuzz_dir_remove);
    }
    return fuzz_dir_path;
}

/* "DIR/name" into p (n bytes). */
static inline const char *fuzz_path(char *p, size_t n, const char *name)
{
    snprintf(p, n, "%s/%s", fuzz_dir(), name);
    return p;
}

/* Writes size bytes to DIR/name (replacing it); aborts when the scratch file system fails. */
static inline void fuzz_put(const char *name, const uint8_t *data, size_t size)
{
    char p[400];
    FILE *f = fopen(fuzz_path(p, sizeof(p), name), "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f))
        abort();
}

#endif
