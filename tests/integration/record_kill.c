/* SPDX-License-Identifier: MIT */
/*
 * Kill-anywhere soak of the whole recorder: a child records the fake camera and IMU (device threads,
 * rings, writer thread, index chunks, stop and close) and is SIGKILLed at a random point, from before
 * the file exists to inside the close; the writes it completed are reported on a pipe (the writer's
 * pwrite64/pwritev64, which pwrite/pwritev are with 64-bit file offsets, are wrapped). The parent runs `sunprobe
 * recover` (into a copy, or in place) and `sunprobe verify` on the result, reads it back and checks
 * that every chunk whose write completed before the kill is there, at its offset.
 * Usage: record_kill SUNPROBE TRIALS [SEED]; prints the count of trials and of chunks checked.
 */
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_recorder.h"

ssize_t __real_pwrite64(int fd, const void *buf, size_t n, off_t off);
ssize_t __real_pwritev64(int fd, const struct iovec *iov, int cnt, off_t off);
ssize_t __wrap_pwrite64(int fd, const void *buf, size_t n, off_t off);
ssize_t __wrap_pwritev64(int fd, const struct iovec *iov, int cnt, off_t off);

#define MAX_DONE 65536
static int report_fd = -1; /* the child's end of the pipe: one (offset, length) per completed write */

static void report(off_t off, ssize_t n)
{
    if (report_fd >= 0 && n > 0) {
        int64_t r[2] = { (int64_t)off, (int64_t)n };
        if (write(report_fd, r, sizeof(r)) != (ssize_t)sizeof(r))
            _exit(9);
    }
}

ssize_t __wrap_pwrite64(int fd, const void *buf, size_t n, off_t off)
{
    ssize_t got = __real_pwrite64(fd, buf, n, off);
    report(off, got);
    return got;
}

ssize_t __wrap_pwritev64(int fd, const struct iovec *iov, int cnt, off_t off)
{
    ssize_t got = __real_pwritev64(fd, iov, cnt, off);
    report(off, got);
    return got;
}

static void child(const char *path, int fd, double duration)
{
    report_fd = fd;
    sp_camera_settings cs;
    sp_camera_default_settings(&cs);
    cs.device = "fake";
    cs.width = 64;
    cs.height = 48;
    cs.fps = 200;
    cs.pool_frames = 18;
    sp_imu_device_settings is;
    sp_imu_device_default_settings(&is);
    is.device = "fake";
    is.rate_hz = 400;
    sp_camera *cam = NULL;
    sp_imu_device *imu = NULL;
    if (sp_camera_open(&cam, &cs) || sp_imu_device_open(&imu, &is))
        _exit(2);
    sp_recorder_settings rs;
    sp_recorder_default_settings(&rs);
    rs.path = path;
    rs.camera = cam;
    rs.imu = imu;
    rs.duration_s = duration;
    rs.imu_batch = 16;
    rs.writer.index_interval = 8;
    rs.writer.sync = SP_SYNC_NONE; /* a killed process keeps what write() returned */
    sp_recorder *rec = NULL;
    sp_recorder_stats st;
    if (sp_recorder_open(&rec, &rs) || sp_recorder_start(rec) || sp_recorder_wait(rec, &st))
        _exit(3);
    sp_recorder_close(&rec);
    _exit(0);
}

static uint64_t rng = 0x2545F4914F6CDD1Dull;

static uint32_t rnd(uint32_t n)
{
    rng ^= rng << 13, rng ^= rng >> 7, rng ^= rng << 17;
    return (uint32_t)(rng % n);
}

/* Runs SP with up to three arguments; its exit code, or -1. */
static int run_sp(const char *sp, const char *a, const char *b, const char *c, const char *d)
{
    pid_t p = fork();
    if (p == 0) {
        int null = open("/dev/null", O_WRONLY);
        dup2(null, 1), dup2(null, 2);
        execl(sp, sp, a, b, c, d, (char *)NULL);
        _exit(127);
    }
    int st;
    return p > 0 && waitpid(p, &st, 0) == p && WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static int cmp_off(const void *a, const void *b)
{
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

/* Offsets of every chunk in a capture, END included (sorted as read); -1 when it does not read to its END. */
static long chunk_offsets(const char *path, int64_t *off, long max)
{
    sp_capture_reader *r = NULL;
    if (sp_capture_reader_open(&r, path, NULL))
        return -1;
    sp_chunk c;
    long n = 0;
    int ret;
    while ((ret = sp_capture_reader_next(r, &c)) == 0)
        if (n < max)
            off[n++] = (int64_t)c.offset;
    if (ret == SP_EOS && n < max) /* the END chunk: the reader stops at it */
        off[n++] = (int64_t)c.offset;
    sp_capture_reader_close(&r);
    return ret == SP_EOS ? n : -1;
}

static int64_t done[MAX_DONE][2], offs[MAX_DONE];

/* One kill: returns the number of completed chunks checked. */
static long trial(const char *sp, const char *dir, int k)
{
    char path[512], copy[512];
    snprintf(path, sizeof(path), "%s/k%d.spcap", dir, k);
    snprintf(copy, sizeof(copy), "%s/k%d.copy.spcap", dir, k);
    /* kill points: the first milliseconds (open, header), the stream, and the stop and close of a 0.1 s run */
    int early = rnd(4) == 0, closing = rnd(4) == 0;
    uint32_t us = early ? rnd(3000) : closing ? 80000 + rnd(60000) : rnd(250000);
    int fds[2];
    if (pipe(fds))
        return -1;
    pid_t p = fork();
    if (p == 0) {
        close(fds[0]);
        child(path, fds[1], closing ? 0.1 : 0.0);
    }
    close(fds[1]);
    struct timespec t = { 0, (long)us * 1000 };
    nanosleep(&t, NULL);
    kill(p, SIGKILL);
    waitpid(p, NULL, 0);
    long n = 0;
    while (n < MAX_DONE && read(fds[0], done[n], sizeof(done[n])) == (ssize_t)sizeof(done[n]))
        n++;
    close(fds[0]);
    struct stat st;
    if (stat(path, &st) != 0) { /* killed before the file was made: nothing was written */
        CHECK_MSG(n == 0, "trial %d: %ld writes reported, no file", k, n);
        return 0;
    }
    int in_place = k % 2;
    const char *out = in_place ? path : copy;
    int rc = in_place ? run_sp(sp, "recover", path, NULL, NULL) : run_sp(sp, "recover", path, "-o", copy);
    if (rc == 2 && n == 0) /* killed before the header was whole */
        return 0;
    CHECK_MSG(rc == 0, "trial %d (kill at %u us): sunprobe recover exit %d", k, us, rc);
    CHECK_MSG(run_sp(sp, "verify", out, NULL, NULL) == 0, "trial %d: sunprobe verify fails after recover", k);
    long m = chunk_offsets(out, offs, MAX_DONE);
    CHECK_MSG(m >= 0, "trial %d: the recovered capture does not read to its end", k);
    long checked = 0;
    for (long i = 0; i < n && m >= 0; i++) {
        if (done[i][0] == 0)
            continue; /* the file header */
        CHECK_MSG(bsearch(&done[i][0], offs, (size_t)m, sizeof(offs[0]), cmp_off) != NULL,
                  "trial %d (kill at %u us): the chunk written at byte %lld is not in the recovered capture", k, us,
                  (long long)done[i][0]);
        checked++;
    }
    unlink(path);
    unlink(copy);
    return checked;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: record_kill SUNPROBE TRIALS [SEED]\n");
        return 1;
    }
    int trials = atoi(argv[2]);
    if (argc > 3)
        rng ^= strtoull(argv[3], NULL, 10) * 0x9E3779B97F4A7C15ull;
    char dir[256];
    snprintf(dir, sizeof(dir), "%s/sp-record-kill.XXXXXX", getenv("TMPDIR") && *getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    if (!mkdtemp(dir))
        return 1;
    long chunks = 0, empty = 0;
    int k;
    for (k = 0; k < trials && check_failures < 5; k++) {
        long c = trial(argv[1], dir, k);
        chunks += c > 0 ? c : 0;
        empty += c == 0;
    }
    rmdir(dir);
    printf("%d SIGKILL points through the recorder, %d failed checks: %ld completed chunks found where they were "
           "written after `sunprobe recover` and `sunprobe verify` (%ld kills before the first chunk)\n", k,
           check_failures, chunks, empty);
    return check_exit();
}
