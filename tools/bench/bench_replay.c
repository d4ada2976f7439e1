/* SPDX-License-Identifier: MIT */
/*
 * Replay benchmarks. (1) Throughput: a 720p YUYV capture replayed through the
 * null stage, median of 5, against the baseline of reading the same file with
 * plain read() calls; wall time and this thread's CPU time (steadier on a
 * shared machine) are both reported. (2) Memory: peak RSS replaying a 1-minute and a 10-minute
 * capture (160x120 YUYV, 30 fps, 200 Hz IMU), each in a fresh child process. (3) CRC-32C throughput
 * (the chunk checksum), thread CPU time, median of 10, for 1 MiB and 4 KiB buffers.
 * Usage: bench_replay [WORKDIR]   (default /tmp/sp-bench); captures are cached there.
 *        bench_replay --crc       only the CRC-32C figures.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "common/clock.h"
#include "common/crc32c.h"
#include "pipeline/stages/stages.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_fake_camera.h"
#include "sunprobe/sp_replay.h"

#define RUNS 5

static int make_capture(const char *path, uint32_t w, uint32_t h, double seconds)
{
    struct stat st;
    if (stat(path, &st) == 0)
        return 0; /* cached from an earlier run */
    sp_fake_camera_settings cs;
    sp_fake_camera_default_settings(&cs);
    cs.width = w;
    cs.height = h;
    cs.pattern = SP_FAKE_PATTERN_PANORAMA;
    sp_fake_camera *cam = NULL;
    sp_capture_writer *wr = NULL;
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    ws.sync = SP_SYNC_NONE;
    char tmp[512];
    snprintf(tmp, sizeof(tmp), "%s.partial", path);
    unlink(tmp);
    int ret = sp_fake_camera_open(&cam, &cs);
    if (!ret)
        ret = sp_capture_writer_open(&wr, tmp, &ws);
    const char *meta = "{\"kind\":\"selfie\",\"source\":\"bench\",\"camera\":{\"fps\":30}}";
    if (!ret)
        ret = sp_capture_write_meta(wr, 0, meta, strlen(meta));
    uint64_t frames = (uint64_t)(seconds * 30.0);
    for (uint64_t i = 0; !ret && i < frames; i++) {
        int64_t t = (int64_t)(i * 1000000000ull / 30);
        sp_imu_sample imu[7];
        for (int k = 0; k < 7; k++) /* ~200 Hz of gyro samples between frames */
            imu[k] = (sp_imu_sample){ t + k * 4761904, SP_IMU_GYRO, { 0.0f, 0.0f, 0.6f } };
        sp_frame *f = NULL;
        /* the image changes slowly; re-render every 30th frame to keep generation fast */
        ret = sp_fake_camera_frame(cam, i, t, (double)(i / 30) * 0.2, &f);
        if (!ret)
            ret = sp_capture_write_frame(wr, f);
        sp_frame_unref(&f);
        if (!ret)
            ret = sp_capture_write_imu(wr, imu, 7);
    }
    int close_ret = sp_capture_writer_close(&wr);
    sp_fake_camera_close(&cam);
    if (!ret)
        ret = close_ret;
    if (!ret && rename(tmp, path) != 0)
        ret = -errno;
    if (ret)
        fprintf(stderr, "bench_replay: generating %s: %s\n", path, sp_strerror(ret));
    return ret;
}

/* The whole capture through the driver loop into the null stage (no tagger: raw replay throughput). */
static int replay_all(const char *path, uint64_t *frames)
{
    sp_stage st = { 0 };
    int ret = sp_stage_open(&st, &sp_stage_null, NULL);
    sp_run_settings rs;
    sp_run_default_settings(&rs);
    rs.progress = 0;
    rs.finish = 0;
    sp_run_stats stats;
    if (!ret)
        ret = sp_stage_run(path, &st, &rs, &stats);
    *frames = ret ? 0 : stats.frames;
    sp_stage_close(&st);
    return ret;
}

static int read_all(const char *path)
{
    int fd = open(path, O_RDONLY);
    if (fd < 0)
        return -errno;
    static char buf[1 << 20];
    ssize_t n;
    while ((n = read(fd, buf, sizeof(buf))) > 0) {
    }
    close(fd);
    return n < 0 ? -errno : 0;
}

static int64_t thread_cpu_ns(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts) != 0)
        return 0;
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof(double), cmp_double);
    return v[n / 2];
}

static int bench_throughput(const char *dir)
{
    char path[512];
    snprintf(path, sizeof(path), "%s/replay-720p-yuyv.spcap", dir);
    if (make_capture(path, 1280, 720, 10.0))
        return 1;
    read_all(path); /* warm the page cache so both measure the same thing */
    double t_replay[RUNS], t_read[RUNS], c_replay[RUNS], c_read[RUNS];
    uint64_t frames = 0;
    for (int i = 0; i < RUNS; i++) {
        int64_t t0 = sp_clock_monotonic_ns(), c0 = thread_cpu_ns();
        if (read_all(path))
            return 1;
        int64_t t1 = sp_clock_monotonic_ns(), c1 = thread_cpu_ns();
        if (replay_all(path, &frames))
            return 1;
        int64_t t2 = sp_clock_monotonic_ns(), c2 = thread_cpu_ns();
        t_read[i] = (double)(t1 - t0) * 1e-9;
        t_replay[i] = (double)(t2 - t1) * 1e-9;
        c_read[i] = (double)(c1 - c0) * 1e-9;
        c_replay[i] = (double)(c2 - c1) * 1e-9;
    }
    double mr = median(t_replay, RUNS), mb = median(t_read, RUNS);
    double cr = median(c_replay, RUNS), cb = median(c_read, RUNS);
    printf("replay 1280x720 YUYV, %llu frames: median %.3f s = %.0f frames/s; baseline read(): median %.3f s = "
           "%.0f frames/s; replay/baseline time ratio %.2f\n", (unsigned long long)frames, mr,
           (double)frames / mr, mb, (double)frames / mb, mr / mb);
    printf("  thread CPU time: replay median %.3f s = %.0f frames/s; read() median %.3f s; ratio %.2f\n", cr,
           cr > 0 ? (double)frames / cr : 0.0, cb, cb > 0 ? cr / cb : 0.0);
    return 0;
}

/* Peak RSS (KiB) of a child process that replays path to the end. */
static long child_peak_rss(const char *path)
{
    pid_t pid = fork();
    if (pid == 0) {
        uint64_t frames;
        int ret = replay_all(path, &frames);
        _exit(ret ? 255 : 0);
    }
    int status;
    struct rusage ru;
    if (pid < 0 || wait4(pid, &status, 0, &ru) != pid || !WIFEXITED(status) || WEXITSTATUS(status))
        return -1;
    return ru.ru_maxrss;
}

static int bench_memory(const char *dir)
{
    char p1[512], p10[512];
    snprintf(p1, sizeof(p1), "%s/replay-1min.spcap", dir);
    snprintf(p10, sizeof(p10), "%s/replay-10min.spcap", dir);
    if (make_capture(p1, 160, 120, 60.0) || make_capture(p10, 160, 120, 600.0))
        return 1;
    double r1[RUNS], r10[RUNS];
    for (int i = 0; i < RUNS; i++) {
        r1[i] = (double)child_peak_rss(p1);
        r10[i] = (double)child_peak_rss(p10);
        if (r1[i] < 0 || r10[i] < 0)
            return 1;
    }
    double m1 = median(r1, RUNS), m10 = median(r10, RUNS);
    printf("replay peak RSS (160x120 YUYV 30 fps + 200 Hz IMU): 1 min median %.1f MiB, 10 min median %.1f MiB, "
           "ratio 10min/1min %.3f\n", m1 / 1024.0, m10 / 1024.0, m10 / m1);
    return 0;
}

/* GB/s of fn over `len`-byte buffers, the median of 10 runs of ~64 MiB each, by thread CPU time. */
static double crc_gbps(uint32_t (*fn)(uint32_t, const void *, size_t), const uint8_t *buf, size_t len,
                       uint32_t *sink)
{
    enum { CRC_RUNS = 10 };
    size_t reps = ((size_t)64 << 20) / len;
    double gbps[CRC_RUNS];
    for (int r = 0; r < CRC_RUNS; r++) {
        int64_t c0 = thread_cpu_ns();
        uint32_t crc = 0;
        for (size_t i = 0; i < reps; i++)
            crc = fn(crc, buf, len); /* chained so the calls cannot be dropped or overlapped */
        int64_t dt = thread_cpu_ns() - c0;
        *sink += crc;
        gbps[r] = dt > 0 ? (double)(reps * len) / (double)dt : 0.0;
    }
    return median(gbps, CRC_RUNS);
}

static int bench_crc(void)
{
    size_t len = (size_t)1 << 20;
    uint8_t *buf = malloc(len);
    if (!buf)
        return 1;
    for (size_t i = 0; i < len; i++)
        buf[i] = (uint8_t)(i * 2654435761u >> 13);
    uint32_t sink = 0;
    double big = crc_gbps(sp_crc32c, buf, len, &sink), small = crc_gbps(sp_crc32c, buf, 4096, &sink);
    double sw = crc_gbps(sp_crc32c_sw, buf, len, &sink);
    printf("crc32c (thread CPU, median of 10): 1 MiB %.2f GB/s, 4 KiB %.2f GB/s; software fallback 1 MiB %.2f GB/s "
           "[%08x]\n", big, small, sw, (unsigned)sink);
    free(buf);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "--crc") == 0)
        return bench_crc();
    const char *dir = argc > 1 ? argv[1] : "/tmp/sp-bench";
    mkdir(dir, 0755);
    int ret = bench_throughput(dir);
    if (!ret)
        ret = bench_crc();
    if (!ret)
        ret = bench_memory(dir);
    return ret;
}
