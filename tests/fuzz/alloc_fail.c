/* SPDX-License-Identifier: MIT */
/*
 * Allocation-failure injection (linked with -Wl,--wrap= malloc, calloc, realloc and free): the
 * container reader over a capture and the face-directory reader over a packed face directory run
 * once per allocation they make, the Nth one failing, N = 1, 2, ... until a run makes no Nth. Each
 * run must end with 0 or an error code (the failure reported, -ENOMEM for the reader's own
 * allocations), and hold no allocation of its own afterwards (a leak, counted here; ASan's leak
 * checker sees the same under the sanitizer setup); a reader that logs says "memory" when it ran out of
 * it. Usage: alloc_fail CAPTURE FACE_PACK
 */
#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "check.h"
#include "face_pack.h"
#include "fuzz_util.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_common.h"
#include "sunprobe/sp_sunstage.h"

void *__real_malloc(size_t n);
void *__real_calloc(size_t n, size_t size);
void *__real_realloc(void *p, size_t n);
void *__wrap_malloc(size_t n);
void *__wrap_calloc(size_t n, size_t size);
void *__wrap_realloc(void *p, size_t n);
void __real_free(void *p);
void __wrap_free(void *p);

/* the live allocations made through the wrappers, as an open-addressed set */
#define SLOTS (1u << 16)
static void *live[SLOTS];
static long n_live, n_calls, fail_at;

static size_t slot_of(void *p)
{
    size_t h = ((uintptr_t)p >> 4) * 0x9E3779B97F4A7C15ull;
    return h & (SLOTS - 1);
}

static void track(void *p)
{
    size_t i = slot_of(p);
    while (live[i])
        i = (i + 1) & (SLOTS - 1);
    live[i] = p;
    n_live++;
}

/* Forgets p; 0 when it was not one of ours (the C library's own, strdup's). */
static int untrack(void *p)
{
    for (size_t i = slot_of(p), k = 0; live[i] && k < SLOTS; i = (i + 1) & (SLOTS - 1), k++)
        if (live[i] == p) {
            /* re-insert the rest of the cluster so lookups stay correct */
            live[i] = NULL;
            n_live--;
            for (size_t j = (i + 1) & (SLOTS - 1); live[j]; j = (j + 1) & (SLOTS - 1)) {
                void *q = live[j];
                live[j] = NULL;
                n_live--;
                track(q);
            }
            return 1;
        }
    return 0;
}

static int fail_now(void)
{
    return fail_at && ++n_calls == fail_at;
}

void *__wrap_malloc(size_t n)
{
    if (fail_now())
        return NULL;
    void *p = __real_malloc(n);
    if (p && fail_at)
        track(p);
    return p;
}

void *__wrap_calloc(size_t n, size_t size)
{
    if (fail_now())
        return NULL;
    void *p = __real_calloc(n, size);
    if (p && fail_at)
        track(p);
    return p;
}

void *__wrap_realloc(void *p, size_t n)
{
    if (fail_now())
        return NULL; /* p stays valid, as realloc leaves it */
    int ours = p && untrack(p);
    void *q = __real_realloc(p, n);
    if (q && (ours || (!p && fail_at)))
        track(q);
    else if (!q && ours)
        track(p);
    return q;
}

void __wrap_free(void *p)
{
    if (p)
        untrack(p); /* the C library's own allocations (strdup) were never counted */
    __real_free(p);
}

/* A new run starts with nothing counted. */
static void forget_all(void)
{
    for (size_t i = 0; i < SLOTS; i++)
        live[i] = NULL;
    n_live = 0;
}

static int read_capture(const char *path)
{
    sp_capture_reader_settings rs;
    sp_capture_reader_default_settings(&rs);
    sp_capture_reader *r = NULL;
    int ret = sp_capture_reader_open(&r, path, &rs);
    sp_chunk ch;
    while (!ret && (ret = sp_capture_reader_next(r, &ch)) == 0)
        ;
    sp_capture_reader_close(&r);
    return ret == SP_EOS ? 0 : ret;
}

static int read_face(const char *dir)
{
    sp_face_asset a;
    int ret = sp_face_dir_read(&a, dir);
    sp_face_asset_free(&a);
    return ret;
}

/* fn(arg) with what it writes to stderr (sp_log) in log (n bytes) */
static int run_logged(int (*fn)(const char *), const char *arg, char *log, size_t n)
{
    char p[400];
    fflush(stderr);
    int saved = dup(2), fd = open(fuzz_path(p, sizeof(p), "log.txt"), O_RDWR | O_CREAT | O_TRUNC, 0600);
    if (saved < 0 || fd < 0 || dup2(fd, 2) < 0)
        abort();
    int ret = fn(arg);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    ssize_t got = pread(fd, log, n - 1, 0);
    log[got > 0 ? got : 0] = '\0';
    close(fd);
    return ret;
}

/* Fails allocation 1, 2, ... of fn(arg) until it completes; returns the number of allocations. */
static long sweep(const char *what, int (*fn)(const char *), const char *arg, int logs)
{
    static char log[8192];
    fail_at = 0;
    int clean = fn(arg);
    CHECK_MSG(clean == 0, "%s without failures: %s", what, sp_strerror(clean));
    long n;
    for (n = 1;; n++) {
        forget_all();
        n_calls = 0;
        fail_at = n;
        int ret = run_logged(fn, arg, log, sizeof(log));
        long calls = n_calls;
        fail_at = 0;
        if (calls < n) { /* no Nth allocation: the run above was whole */
            CHECK_MSG(ret == 0, "%s: a run without a failed allocation returned %s", what, sp_strerror(ret));
            break;
        }
        CHECK_MSG(ret < 0, "%s: allocation %ld failed and the reader returned %d", what, n, ret);
        CHECK_MSG(n_live == 0, "%s: allocation %ld failed: %ld allocation(s) never freed", what, n, n_live);
        CHECK_MSG(!logs || ret != -ENOMEM || strstr(log, "memory"), "%s: allocation %ld failed, and the message "
                  "does not say out of memory: %s", what, n, log);
    }
    printf("%s: %ld allocations, each failed once: no crash, an error every time, no leak\n", what, n - 1);
    return n - 1;
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: alloc_fail CAPTURE FACE_PACK\n");
        return 1;
    }
    size_t n = 0;
    void *pack = NULL;
    FILE *f = fopen(argv[2], "rb");
    static uint8_t buf[1 << 20];
    if (f) {
        n = fread(buf, 1, sizeof(buf), f);
        fclose(f);
        pack = buf;
    }
    CHECK(pack && n > 0);
    char face[400];
    fuzz_path(face, sizeof(face), "face");
    mkdir(face, 0755);
    face_unpack(buf, n, face);
    CHECK(sweep("container reader", read_capture, argv[1], 0) > 0); /* returns codes, logs nothing */
    CHECK(sweep("face-directory reader", read_face, face, 1) > 0);
    return check_exit();
}
