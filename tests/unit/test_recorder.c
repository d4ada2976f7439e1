/* SPDX-License-Identifier: MIT */
/*
 * The recorder end to end with the fake camera and IMU: everything captured is
 * either written or counted as dropped, a slow writer drops (counted) instead of
 * stalling capture, a stop request ends with a valid file, and a full disk
 * (RLIMIT_FSIZE, and a tiny tmpfs where mounting is permitted) keeps every chunk
 * written before it.
 */
#include "sunprobe/sp_recorder.h"

#include <errno.h>
#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "sunprobe/sp_meta.h"

typedef struct file_summary {
    uint64_t frames, imu_samples, bad_order;
    int had_end, result, kind_ok;
    int64_t last_ts;
    uint64_t last_seq;
} file_summary;

/* Reads a capture strictly (no skipping): counts, order and how it ends. */
static void summarise(const char *path, const char *kind, file_summary *s)
{
    memset(s, 0, sizeof(*s));
    sp_capture_reader *r = NULL;
    s->result = sp_capture_reader_open(&r, path, NULL);
    if (s->result)
        return;
    sp_capture_meta meta;
    sp_capture_meta_init(&meta);
    sp_chunk c;
    int64_t last_imu = 0;
    while ((s->result = sp_capture_reader_next(r, &c)) == 0) {
        sp_frame_chunk f;
        if (c.type == SP_CHUNK_META)
            CHECK_EQ_INT(sp_capture_meta_merge(&meta, (const char *)c.payload, c.payload_size), 0);
        if (c.type == SP_CHUNK_FRAME && sp_chunk_parse_frame(&c, &f) == 0) {
            if (s->frames && (c.timestamp_ns <= s->last_ts || f.sequence <= s->last_seq))
                s->bad_order++;
            s->last_ts = c.timestamp_ns;
            s->last_seq = f.sequence;
            s->frames++;
        }
        int64_t n = c.type == SP_CHUNK_IMU ? sp_chunk_imu_count(&c) : 0;
        for (int64_t i = 0; i < n; i++) {
            sp_imu_sample smp;
            CHECK_EQ_INT(sp_chunk_imu_get(&c, (size_t)i, &smp), 0);
            if (smp.timestamp_ns < last_imu)
                s->bad_order++;
            last_imu = smp.timestamp_ns;
            s->imu_samples++;
        }
    }
    if (s->result == SP_EOS && c.type == SP_CHUNK_END) /* the reader reports END as the end of stream */
        s->had_end = 1;
    s->kind_ok = !strcmp(meta.kind, kind) && meta.camera_name[0] != '\0';
    sp_capture_reader_close(&r);
}

static sp_camera *open_camera(const char *device, uint32_t w, uint32_t h, double fps, unsigned pool)
{
    sp_camera_settings cs;
    sp_camera_default_settings(&cs);
    cs.device = device;
    cs.width = w;
    cs.height = h;
    cs.fps = fps;
    cs.pool_frames = pool;
    sp_camera *cam = NULL;
    CHECK_EQ_INT(sp_camera_open(&cam, &cs), 0);
    return cam;
}

static int record(const char *path, sp_camera *cam, sp_imu_device *imu, unsigned queue, uint32_t delay_us,
                  double duration, sp_recorder_stats *st)
{
    sp_recorder_settings rs;
    sp_recorder_default_settings(&rs);
    rs.path = path;
    rs.camera = cam;
    rs.imu = imu;
    rs.kind = "static";
    rs.frame_queue = queue;
    rs.writer_delay_us = delay_us;
    rs.duration_s = duration;
    rs.writer.overwrite = 1;
    sp_recorder *rec = NULL;
    int err = sp_recorder_open(&rec, &rs);
    if (err == 0)
        err = sp_recorder_start(rec);
    if (err == 0)
        err = sp_recorder_wait(rec, st);
    sp_recorder_close(&rec);
    return err;
}

/* A finite source: every frame is written or counted; with an IMU, samples interleave in order. */
static void test_everything_accounted(const char *dir)
{
    char path[512];
    snprintf(path, sizeof(path), "%s/rec_all.spcap", dir);
    sp_camera *cam = open_camera("fake:frames=40", 160, 120, 100.0, 8);
    sp_imu_device_settings is;
    sp_imu_device_default_settings(&is);
    is.device = "fake";
    is.rate_hz = 400;
    sp_imu_device *imu = NULL;
    CHECK_EQ_INT(sp_imu_device_open(&imu, &is), 0);
    sp_recorder_stats st;
    CHECK_EQ_INT(record(path, cam, imu, 16, 0, 0, &st), 0);
    CHECK_EQ_INT(st.end, SP_RECORDER_SOURCE_END);
    CHECK_EQ_INT(st.frames_written + st.frames_dropped + st.device_dropped, 40);
    CHECK_EQ_INT(st.frames_written, st.frames_captured - st.frames_dropped);
    CHECK(st.frames_written > 0);
    CHECK(st.imu_samples_written > 0);
    file_summary fs;
    summarise(path, "static", &fs);
    CHECK_EQ_INT(fs.result, SP_EOS);
    CHECK(fs.had_end && fs.kind_ok);
    CHECK_EQ_INT(fs.frames, st.frames_written);
    CHECK_EQ_INT(fs.imu_samples, st.imu_samples_written);
    CHECK_EQ_INT(fs.bad_order, 0);
    sp_imu_device_close(&imu);
    sp_camera_close(&cam);
}

/* A writer slower than the camera: capture keeps its pace and the overflow is counted, not queued forever. */
static void test_slow_writer_drops(const char *dir)
{
    char path[512];
    snprintf(path, sizeof(path), "%s/rec_slow.spcap", dir);
    /* an unpaced camera with more pooled frames than queue slots outruns a writer taking 30 ms a chunk */
    sp_camera *cam = open_camera("fake:unpaced,prerender,frames=60", 160, 120, 30.0, 16);
    sp_recorder_stats st;
    CHECK_EQ_INT(record(path, cam, NULL, 2, 30000, 0, &st), 0);
    CHECK(st.frames_dropped > 0);
    CHECK_EQ_INT(st.device_dropped, 0);
    CHECK_EQ_INT(st.frames_written + st.frames_dropped + st.device_dropped, 60);
    file_summary fs;
    summarise(path, "static", &fs);
    CHECK_EQ_INT(fs.result, SP_EOS);
    CHECK_EQ_INT(fs.frames, st.frames_written);
    CHECK_EQ_INT(fs.bad_order, 0);
    sp_camera_close(&cam);
}

/* Stop from another context (what the SIGINT handler does) while recording without a duration. */
static void test_stop_request(const char *dir)
{
    char path[512];
    snprintf(path, sizeof(path), "%s/rec_stop.spcap", dir);
    sp_camera *cam = open_camera("fake", 160, 120, 50.0, 8);
    sp_recorder_settings rs;
    sp_recorder_default_settings(&rs);
    rs.path = path;
    rs.camera = cam;
    rs.writer.overwrite = 1;
    sp_recorder *rec = NULL;
    CHECK_EQ_INT(sp_recorder_open(&rec, &rs), 0);
    CHECK_EQ_INT(sp_recorder_start(rec), 0);
    CHECK_EQ_INT(sp_recorder_start(rec), -EINVAL);
    sp_recorder_stats st;
    for (int i = 0; i < 500; i++) { /* until something is on disk, however slow the machine */
        sp_recorder_get_stats(rec, &st);
        if (st.frames_written > 2)
            break;
        nanosleep(&(struct timespec){ 0, 10000000 }, NULL);
    }
    CHECK(!sp_recorder_finished(rec));
    sp_recorder_request_stop(rec);
    CHECK_EQ_INT(sp_recorder_wait(rec, &st), 0);
    CHECK_EQ_INT(st.end, SP_RECORDER_STOPPED);
    CHECK(st.frames_written > 0);
    sp_recorder_close(&rec);
    file_summary fs;
    summarise(path, "selfie", &fs);
    CHECK_EQ_INT(fs.result, SP_EOS);
    CHECK(fs.had_end);
    CHECK_EQ_INT(fs.frames, st.frames_written);
    sp_camera_close(&cam);
}

static void test_bad_settings(const char *dir)
{
    sp_recorder_settings rs;
    sp_recorder_default_settings(&rs);
    sp_recorder *rec = NULL;
    CHECK_EQ_INT(sp_recorder_open(&rec, &rs), -EINVAL); /* no path, no camera */
    sp_camera *cam = open_camera("fake", 160, 120, 30.0, 4);
    char path[512];
    snprintf(path, sizeof(path), "%s/rec_bad.spcap", dir);
    rs.path = path;
    rs.camera = cam;
    rs.kind = "movie";
    CHECK_EQ_INT(sp_recorder_open(&rec, &rs), -EINVAL);
    rs.kind = "static";
    rs.imu_batch = 100000;
    CHECK_EQ_INT(sp_recorder_open(&rec, &rs), -EINVAL);
    CHECK(rec == NULL);
    sp_recorder_close(&rec);
    sp_camera_close(&cam);
}

/* Child: records until the file system refuses; reports frames written through its exit status. */
static int disk_full_child(const char *path)
{
    /* fewer pooled frames than queue slots: the unpaced camera waits for the writer, never drops */
    sp_camera *cam = open_camera("fake:unpaced,prerender,frames=400", 320, 240, 30.0, 4);
    sp_recorder_stats st;
    int err = record(path, cam, NULL, 8, 0, 0, &st);
    sp_camera_close(&cam);
    if (st.end != SP_RECORDER_DISK_FULL || (err != -ENOSPC && err != -EFBIG) || st.frames_written == 0 ||
        st.frames_written > 250) {
        fprintf(stderr, "child: end %s err %d, %llu frames\n", sp_recorder_end_name(st.end), err,
                (unsigned long long)st.frames_written);
        return 255;
    }
    return (int)st.frames_written;
}

/* After a full disk the capture holds exactly the frames the recorder says it wrote, and nothing torn. */
static void check_disk_full_file(const char *path, int status)
{
    CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) != 255, "status %d", status);
    if (!WIFEXITED(status) || WEXITSTATUS(status) == 255)
        return;
    file_summary fs;
    summarise(path, "static", &fs);
    CHECK_MSG(fs.result == SP_EOS, "reader ended with %s", sp_strerror(fs.result));
    CHECK_EQ_INT(fs.frames, WEXITSTATUS(status));
    CHECK_EQ_INT(fs.bad_order, 0);
}

static void test_fsize_limit(const char *dir)
{
    char path[512];
    snprintf(path, sizeof(path), "%s/rec_full.spcap", dir);
    pid_t pid = fork();
    if (pid == 0) {
        signal(SIGXFSZ, SIG_IGN); /* writes past the limit fail with EFBIG instead of killing us */
        struct rlimit rl = { 2000000, 2000000 };
        setrlimit(RLIMIT_FSIZE, &rl);
        _exit(disk_full_child(path));
    }
    int status = 0;
    waitpid(pid, &status, 0);
    check_disk_full_file(path, status);
}

/* ENOSPC from a real file system: a 2 MB tmpfs in a private mount namespace, when root may make one. */
static void test_tmpfs_full(void)
{
    int pipefd[2];
    char mnt[] = "/tmp/sp_rec_tmpfs_XXXXXX";
    if (!mkdtemp(mnt) || pipe(pipefd) < 0)
        return;
    pid_t pid = fork();
    if (pid == 0) {
        int ok = unshare(CLONE_NEWNS) == 0 && mount(NULL, "/", NULL, MS_REC | MS_PRIVATE, NULL) == 0 &&
                 mount("tmpfs", mnt, "tmpfs", 0, "size=2m") == 0;
        if (!ok) {
            fprintf(stderr, "note: tmpfs ENOSPC case not run (no private mount namespace: %s)\n", strerror(errno));
            _exit(254);
        }
        char path[600];
        snprintf(path, sizeof(path), "%s/full.spcap", mnt);
        int n = disk_full_child(path);
        /* hand the file to the parent (the mount vanishes with this namespace) */
        int fd = open(path, O_RDONLY);
        char buf[65536];
        ssize_t got;
        while (fd >= 0 && (got = read(fd, buf, sizeof(buf))) > 0)
            if (write(pipefd[1], buf, (size_t)got) != got)
                break;
        _exit(n);
    }
    close(pipefd[1]);
    char copy[] = "/tmp/sp_rec_tmpfs_copy_XXXXXX";
    int out = mkstemp(copy);
    char buf[65536];
    ssize_t got;
    while ((got = read(pipefd[0], buf, sizeof(buf))) > 0)
        if (out < 0 || write(out, buf, (size_t)got) != got)
            break;
    close(pipefd[0]);
    if (out >= 0)
        close(out);
    int status = 0;
    waitpid(pid, &status, 0);
    if (!(WIFEXITED(status) && WEXITSTATUS(status) == 254))
        check_disk_full_file(copy, status);
    unlink(copy);
    rmdir(mnt); /* the tmpfs went with the child's namespace */
}

int main(void)
{
    char dir[] = "/tmp/sp_test_recorder_XXXXXX";
    if (!mkdtemp(dir))
        SKIP("cannot create a temporary directory");
    test_bad_settings(dir);
    test_everything_accounted(dir);
    test_slow_writer_drops(dir);
    test_stop_request(dir);
    test_fsize_limit(dir);
    test_tmpfs_full();
    const char *names[] = { "rec_all.spcap", "rec_slow.spcap", "rec_stop.spcap", "rec_full.spcap", "rec_bad.spcap" };
    for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++) {
        char p[600];
        snprintf(p, sizeof(p), "%s/%s", dir, names[i]);
        unlink(p);
    }
    if (!getenv("SP_KEEP")) rmdir(dir);
    return check_exit();
}
