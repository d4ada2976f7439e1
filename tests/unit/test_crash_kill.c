/* SPDX-License-Identifier: MIT */
/*
 * Crash safety under SIGKILL: a child appends deterministic chunks and reports
 * each one that returned; the parent kills it at a random point, recovers the file
 * (in place or to a copy) and checks that every reported chunk survived intact and
 * that nothing but whole chunks did.
 */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "sunprobe/sp_capture.h"

#define TRIALS 240
#define MAX_CHUNKS 480
#define CLOSED_MARK 0xFFFFFFFFu
#define END_CHUNK_BYTES 48 /* 32-byte header + 16-byte payload (FORMAT.md) */

static char tmpdir[256];

/* ---- the deterministic chunk sequence ---- */

enum kind { K_FRAME, K_IMU, K_SIDE, K_META };

static enum kind kind_of(uint32_t k)
{
    uint32_t m = k % 10;
    return m < 5 ? K_FRAME : m < 8 ? K_IMU : m == 8 ? K_SIDE : K_META;
}

static int64_t ts_of(uint32_t k)
{
    return 1000000 * (int64_t)k + 17;
}

static void frame_of(uint32_t k, sp_frame *f, uint8_t *pixels)
{
    memset(f, 0, sizeof(*f));
    f->format = SP_PIXFMT_GRAY8;
    if (k % 41 == 7) { /* a few ~100 KB frames: long writes a kill can interrupt */
        f->width = 320;
        f->height = 320;
    } else {
        f->width = 8 + (k * 37) % 120;
        f->height = 4 + (k * 11) % 60;
    }
    f->stride = f->width;
    f->bytes_used = (size_t)f->width * f->height;
    f->data = pixels;
    for (size_t i = 0; i < f->bytes_used; i++)
        pixels[i] = (uint8_t)(i * 31 + k * 7);
    f->timestamp_ns = ts_of(k);
    f->sequence = k;
    f->exposure_us = k % 3 ? (float)k : NAN;
    f->gain = 1.0f;
}

static size_t imu_of(uint32_t k, sp_imu_sample *s)
{
    size_t n = 1 + (k * 13) % 60;
    for (size_t i = 0; i < n; i++) {
        s[i].timestamp_ns = ts_of(k) + (int64_t)i * 1000;
        s[i].sensor = i % 2 ? SP_IMU_ACCEL : SP_IMU_GYRO;
        for (int a = 0; a < 3; a++)
            s[i].v[a] = (float)k * 0.25f + (float)i - (float)a;
    }
    return n;
}

static void side_of(uint32_t k, float *v)
{
    for (int i = 0; i < 136; i++)
        v[i] = (float)(k % 500) + (float)i * 0.5f;
}

static size_t meta_of(uint32_t k, char *buf, size_t cap)
{
    int n = snprintf(buf, cap, "{\"source\":\"crash\",\"k\":%u,\"pad\":\"", k);
    size_t len = (size_t)n;
    for (uint32_t i = 0; i < (k * 97) % 900 && len + 3 < cap; i++)
        buf[len++] = (char)('a' + i % 26);
    buf[len++] = '"';
    buf[len++] = '}';
    return len;
}

typedef struct scratch {
    uint8_t pixels[320 * 320];
    sp_imu_sample imu[64];
    float side[136];
    char meta[1024];
} scratch;

static int write_chunk(sp_capture_writer *w, uint32_t k, scratch *s)
{
    sp_frame f;
    switch (kind_of(k)) {
    case K_FRAME:
        frame_of(k, &f, s->pixels);
        return sp_capture_write_frame(w, &f);
    case K_IMU:
        return sp_capture_write_imu(w, s->imu, imu_of(k, s->imu));
    case K_SIDE:
        side_of(k, s->side);
        return sp_capture_write_side(w, ts_of(k), k, SP_SIDE_LANDMARKS_2D, s->side, 136);
    default:
        return sp_capture_write_meta(w, ts_of(k), s->meta, meta_of(k, s->meta, sizeof(s->meta)));
    }
}

/* True when the chunk read back is exactly chunk k of the sequence. */
static int chunk_matches(const sp_chunk *c, uint32_t k, scratch *s)
{
    if (c->timestamp_ns != ts_of(k))
        return 0;
    switch (kind_of(k)) {
    case K_FRAME: {
        sp_frame f;
        sp_frame_chunk fc;
        frame_of(k, &f, s->pixels);
        return c->type == SP_CHUNK_FRAME && sp_chunk_parse_frame(c, &fc) == 0 && fc.width == f.width &&
               fc.height == f.height && fc.sequence == k && fc.data_size == f.bytes_used &&
               (isnan(f.exposure_us) ? isnan(fc.exposure_us) : fc.exposure_us == f.exposure_us) &&
               memcmp(fc.data, f.data, f.bytes_used) == 0;
    }
    case K_IMU: {
        size_t n = imu_of(k, s->imu);
        if (c->type != SP_CHUNK_IMU || sp_chunk_imu_count(c) != (int64_t)n)
            return 0;
        for (size_t i = 0; i < n; i++) {
            sp_imu_sample got;
            if (sp_chunk_imu_get(c, i, &got) < 0 || got.timestamp_ns != s->imu[i].timestamp_ns ||
                got.sensor != s->imu[i].sensor || memcmp(got.v, s->imu[i].v, sizeof(got.v)) != 0)
                return 0;
        }
        return 1;
    }
    case K_SIDE: {
        sp_side_chunk sd;
        side_of(k, s->side);
        if (c->type != SP_CHUNK_SIDE || sp_chunk_parse_side(c, &sd) < 0 || sd.count != 136 || sd.frame_sequence != k)
            return 0;
        for (uint32_t i = 0; i < 136; i++)
            if (sp_side_value(&sd, i) != s->side[i])
                return 0;
        return 1;
    }
    default: {
        size_t n = meta_of(k, s->meta, sizeof(s->meta));
        return c->type == SP_CHUNK_META && c->payload_size == n && memcmp(c->payload, s->meta, n) == 0;
    }
    }
}

/* ---- one trial ---- */

static void child(const char *path, int fd)
{
    static scratch s;
    sp_capture_writer_settings set;
    sp_capture_writer_default_settings(&set);
    set.sync = SP_SYNC_NONE; /* a killed process keeps what write() returned */
    set.index_interval = 8;
    sp_capture_writer *w = NULL;
    if (sp_capture_writer_open(&w, path, &set) < 0)
        _exit(2);
    for (uint32_t k = 0; k < MAX_CHUNKS; k++) {
        if (write_chunk(w, k, &s) < 0)
            _exit(3);
        if (write(fd, &k, sizeof(k)) != sizeof(k))
            _exit(4);
    }
    uint32_t mark = CLOSED_MARK;
    if (sp_capture_writer_close(&w) < 0 || write(fd, &mark, sizeof(mark)) != sizeof(mark))
        _exit(5);
    _exit(0);
}

static uint64_t rng_state = 0x9E3779B97F4A7C15ull;

static uint32_t rnd(uint32_t n)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return n ? (uint32_t)(rng_state % n) : 0;
}

static void sleep_us(uint32_t us)
{
    struct timespec t = { 0, (long)us * 1000 };
    while (nanosleep(&t, &t) < 0 && errno == EINTR) {
    }
}

typedef struct outcome {
    uint32_t reported; /* chunks the child saw return 0 */
    int closed;        /* the child finished and closed cleanly */
    int exited;        /* the child exited on its own (a failure unless closed) */
} outcome;

/* Reads reports until the child has reported chunk `target`, or ended. */
static int read_until(int fd, outcome *o, int64_t target)
{
    uint32_t k;
    while ((int64_t)o->reported <= target) {
        ssize_t n = read(fd, &k, sizeof(k));
        if (n < 0 && errno == EINTR)
            continue;
        if (n != (ssize_t)sizeof(k))
            return 0;
        if (k == CLOSED_MARK) {
            o->closed = 1;
            continue;
        }
        CHECK_EQ_INT(k, o->reported); /* reports arrive in order */
        o->reported++;
    }
    return 1;
}

/* Forks the writer, kills it somewhere, collects its reports. */
static int run_child(const char *path, int trial, outcome *o)
{
    int fds[2];
    if (pipe(fds) < 0)
        return -errno;
    pid_t pid = fork();
    if (pid < 0)
        return -errno;
    if (pid == 0) {
        close(fds[0]);
        child(path, fds[1]);
    }
    close(fds[1]);
    memset(o, 0, sizeof(*o));
    if (trial % 8 == 0) {
        sleep_us(rnd(400)); /* early: while the file is created and its header written */
    } else {
        read_until(fds[0], o, (int64_t)rnd(MAX_CHUNKS + 20) - 10);
        sleep_us(rnd(250)); /* then somewhere in the following writes */
    }
    kill(pid, SIGKILL);
    int status = 0;
    waitpid(pid, &status, 0);
    read_until(fds[0], o, INT64_MAX);
    close(fds[0]);
    o->exited = WIFEXITED(status);
    CHECK_MSG(!o->exited || (WEXITSTATUS(status) == 0 && o->closed), "child failed with %d", WEXITSTATUS(status));
    return 0;
}

static uint8_t *slurp(const char *path, size_t *len)
{
    *len = 0;
    int fd = open(path, O_RDONLY);
    if (fd < 0)
        return NULL;
    struct stat st;
    uint8_t *b = NULL;
    if (fstat(fd, &st) == 0 && (b = malloc((size_t)st.st_size + 1)) &&
        read(fd, b, (size_t)st.st_size) == st.st_size)
        *len = (size_t)st.st_size;
    close(fd);
    return b;
}

typedef struct stats {
    int no_file, fresh_header, torn, clean_close, cut_at_boundary;
    uint64_t chunks;
} stats;

/* Reads the recovered file strictly; returns the number of data chunks, all matching the sequence. */
static uint32_t verify(const char *path, const uint8_t *orig, size_t orig_len, const sp_recover_report *rep)
{
    static scratch s;
    sp_capture_reader *r = NULL;
    CHECK_EQ_INT(sp_capture_reader_open(&r, path, NULL), 0);
    if (!r)
        return 0;
    sp_chunk c;
    uint32_t k = 0;
    uint64_t chunks = 0, end_at = 0;
    int err;
    while ((err = sp_capture_reader_next(r, &c)) == 0) {
        chunks++;
        if (c.type == SP_CHUNK_INDEX)
            continue;
        CHECK_MSG(chunk_matches(&c, k, &s), "chunk %u differs", k);
        k++;
    }
    CHECK_EQ_INT(err, SP_EOS);
    CHECK_EQ_INT(c.type, SP_CHUNK_END);
    end_at = c.offset;
    sp_capture_reader_close(&r);
    CHECK_EQ_INT(chunks, rep->chunks_kept);
    /* exactly the valid prefix, byte for byte, then one END */
    size_t len = 0;
    uint8_t *got = slurp(path, &len);
    CHECK_EQ_INT(len, end_at + END_CHUNK_BYTES);
    if (rep->valid_bytes > 0) {
        CHECK(rep->valid_bytes <= orig_len && got && memcmp(got, orig, rep->valid_bytes) == 0);
        CHECK_EQ_INT(end_at, rep->had_end ? rep->valid_bytes - END_CHUNK_BYTES : rep->valid_bytes);
    }
    free(got);
    return k;
}

static void trial(int t, stats *st)
{
    char path[320], copy[330];
    snprintf(path, sizeof(path), "%s/kill%d.spcap", tmpdir, t);
    snprintf(copy, sizeof(copy), "%s/copy%d.spcap", tmpdir, t);
    outcome o;
    CHECK_EQ_INT(run_child(path, t, &o), 0);
    size_t orig_len = 0;
    uint8_t *orig = slurp(path, &orig_len);
    if (!orig) { /* killed before the file existed */
        CHECK_EQ_INT(o.reported, 0);
        st->no_file++;
        return;
    }
    int in_place = t % 2 == 0;
    sp_recover_report rep;
    CHECK_EQ_INT(sp_capture_recover(path, in_place ? NULL : copy, &rep), 0);
    const char *result = in_place ? path : copy;
    uint32_t found = verify(result, orig, orig_len, &rep);
    /* every reported chunk is there; at most the one being reported when killed is extra */
    CHECK_MSG(found >= o.reported && found <= o.reported + 1, "trial %d: found %u, reported %u", t, found,
              o.reported);
    CHECK(!o.closed || (rep.had_end && rep.bytes_dropped == 0 && found == MAX_CHUNKS));
    CHECK_EQ_INT(rep.bytes_dropped, orig_len - rep.valid_bytes);
    if (!in_place) {
        size_t n = 0;
        uint8_t *src = slurp(path, &n);
        CHECK(src && n == orig_len && memcmp(src, orig, n) == 0); /* source untouched */
        free(src);
    }
    /* the result is clean: recovering it again changes nothing */
    sp_recover_report again;
    CHECK_EQ_INT(sp_capture_recover(result, NULL, &again), 0);
    CHECK(again.had_end && again.bytes_dropped == 0 && again.chunks_kept == rep.chunks_kept);
    st->fresh_header += rep.valid_bytes == 0;
    st->torn += rep.valid_bytes > 0 && rep.bytes_dropped > 0;
    st->cut_at_boundary += !rep.had_end && rep.valid_bytes > 0 && rep.bytes_dropped == 0;
    st->clean_close += rep.had_end;
    st->chunks += found;
    free(orig);
    unlink(path);
    unlink(copy);
}

int main(void)
{
    const char *base = getenv("TMPDIR");
    snprintf(tmpdir, sizeof(tmpdir), "%s/sp_crash_XXXXXX", base && *base ? base : "/tmp");
    if (!mkdtemp(tmpdir))
        SKIP("cannot create a temporary directory");
    const char *seed = getenv("SP_TEST_SEED");
    if (seed)
        rng_state = strtoull(seed, NULL, 0) | 1;
    fprintf(stderr, "seed 0x%llx\n", (unsigned long long)rng_state);
    stats st = { 0 };
    for (int t = 0; t < TRIALS; t++)
        trial(t, &st);
    rmdir(tmpdir);
    /* where the kills landed: informative, it depends on timing */
    fprintf(stderr,
            "%d trials: %d before the file existed, %d with a torn header, %d torn tails, %d cut between chunks, "
            "%d closed cleanly; %llu chunks verified\n",
            TRIALS, st.no_file, st.fresh_header, st.torn, st.cut_at_boundary, st.clean_close,
            (unsigned long long)st.chunks);
    CHECK(st.chunks > 0);
    return check_exit();
}
