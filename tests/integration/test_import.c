/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe import` and `sunprobe export-video` end to end: makes JPEG and PNG
 * images, a tiny video, an IMU CSV, frame times and metadata JSON; imports them
 * with the binary; reads the captures back (frames, timestamps, IMU counts and
 * order, META); exports PNGs and a video; and checks that bad input fails with
 * a message naming the file and line and leaves no output behind.
 * usage: test_import SUNPROBE [vtest]
 */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "capture/opencv_shim.h"
#include "check.h"
#include "common/jpeg.h"
#include "common/json.h"
#include "export/png.h"
#include "fixture_jpeg.h"
#include "sp_config.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_meta.h"

#define VTEST "/usr/share/doc/opencv-doc/examples/data/vtest.avi"

static const char *sunprobe;
static char tmp[256];

static const char *path_in(const char *name)
{
    static char bufs[8][512];
    static int next;
    char *p = bufs[next++ % 8];
    snprintf(p, 512, "%s/%s", tmp, name);
    return p;
}

static int file_exists(const char *path)
{
    return access(path, F_OK) == 0;
}

static void write_text(const char *name, const char *text)
{
    FILE *f = fopen(path_in(name), "w");
    CHECK(f != NULL);
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

/* Runs sunprobe with NULL-terminated arguments, stderr into tmp/stderr.txt; returns the exit code. */
static int run(const char *arg0, ...)
{
    const char *argv[32] = { sunprobe, arg0 };
    int n = 2;
    va_list ap;
    va_start(ap, arg0);
    const char *a;
    while (n < 31 && (a = va_arg(ap, const char *)) != NULL)
        argv[n++] = a;
    va_end(ap);
    argv[n] = NULL;
    pid_t pid = fork();
    if (pid == 0) {
        int fd = open(path_in("stderr.txt"), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0)
            dup2(fd, 2);
        int devnull = open("/dev/null", O_WRONLY);
        if (devnull >= 0)
            dup2(devnull, 1);
        execv(sunprobe, (char *const *)argv);
        _exit(127);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

static int stderr_has(const char *needle)
{
    FILE *f = fopen(path_in("stderr.txt"), "r");
    char buf[4096] = { 0 };
    if (f) {
        size_t n = fread(buf, 1, sizeof(buf) - 1, f);
        buf[n] = 0;
        fclose(f);
    }
    int found = strstr(buf, needle) != NULL;
    if (!found)
        fprintf(stderr, "stderr was: %s\n(expected to contain '%s')\n", buf, needle);
    return found;
}

/* Colour of test frame i: distinct per frame so order can be checked after a lossy round trip. */
static void frame_colour(int i, uint8_t rgb[3])
{
    rgb[0] = (uint8_t)(20 + 45 * (i % 5));
    rgb[1] = (uint8_t)(230 - 40 * (i % 6));
    rgb[2] = (uint8_t)(60 + 25 * (i % 7));
}

static uint8_t *solid_image(int i, uint32_t w, uint32_t h)
{
    uint8_t *img = malloc((size_t)w * h * 3), c[3];
    frame_colour(i, c);
    for (size_t p = 0; p < (size_t)w * h; p++)
        memcpy(img + p * 3, c, 3);
    img[0] = (uint8_t)i; /* one marked pixel: lossless storage must keep it exactly */
    return img;
}

/* ---- reading captures back ---- */

typedef struct readback {
    int frames, imu_chunks, imu[4], order_ok;
    int64_t frame_ts[64];
    enum sp_pixfmt format;
    uint32_t width, height;
    uint32_t frame_size[64];
    uint8_t first_pixel[64][3];
    int marker[64]; /* the N of a "frame N" JPEG comment in the payload, -1 if none */
    char meta_json[4096];
    int64_t last_imu_ts;
    int imu_monotonic;
} readback;

static void read_frame_chunk(readback *rb, const sp_chunk *ch)
{
    sp_frame_chunk fc;
    CHECK_EQ_INT(sp_chunk_parse_frame(ch, &fc), 0);
    if (rb->frames < 64) {
        rb->frame_ts[rb->frames] = ch->timestamp_ns;
        rb->frame_size[rb->frames] = fc.data_size;
        if (fc.format == SP_PIXFMT_RGB24)
            memcpy(rb->first_pixel[rb->frames], fc.data, 3);
        rb->marker[rb->frames] = -1;
        if (fc.format == SP_PIXFMT_MJPEG && fc.data_size > 20 && fc.data[2] == 0xFF && fc.data[3] == 0xFE)
            sscanf((const char *)fc.data + 6, "frame %d", &rb->marker[rb->frames]);
    }
    CHECK_EQ_INT(fc.sequence, rb->frames);
    rb->format = fc.format;
    rb->width = fc.width;
    rb->height = fc.height;
    rb->frames++;
}

static void read_imu_chunk(readback *rb, const sp_chunk *ch, int64_t last_frame_ts)
{
    int64_t n = sp_chunk_imu_count(ch);
    CHECK(n > 0);
    rb->imu_chunks++;
    for (int64_t i = 0; i < n; i++) {
        sp_imu_sample s;
        CHECK_EQ_INT(sp_chunk_imu_get(ch, (size_t)i, &s), 0);
        if (s.sensor >= 1 && s.sensor <= 3)
            rb->imu[s.sensor]++;
        if (s.timestamp_ns < rb->last_imu_ts)
            rb->imu_monotonic = 0;
        rb->last_imu_ts = s.timestamp_ns;
        /* interleaving: a sample written after frame k is later than frame k */
        if (rb->frames > 0 && s.timestamp_ns <= last_frame_ts)
            rb->order_ok = 0;
        CHECK(isfinite(s.v[0]) && isfinite(s.v[1]) && isfinite(s.v[2]));
    }
}

static int read_capture(const char *name, readback *rb)
{
    memset(rb, 0, sizeof(*rb));
    rb->order_ok = rb->imu_monotonic = 1;
    rb->last_imu_ts = INT64_MIN;
    sp_capture_reader *r = NULL;
    int rc = sp_capture_reader_open(&r, path_in(name), NULL);
    CHECK_EQ_INT(rc, 0);
    if (rc)
        return rc;
    sp_chunk ch;
    int64_t last_frame_ts = INT64_MIN;
    while ((rc = sp_capture_reader_next(r, &ch)) == 0) {
        if (ch.type == SP_CHUNK_META && !rb->meta_json[0] && ch.payload_size < sizeof(rb->meta_json))
            memcpy(rb->meta_json, ch.payload, ch.payload_size);
        if (ch.type == SP_CHUNK_FRAME) {
            read_frame_chunk(rb, &ch);
            last_frame_ts = ch.timestamp_ns;
        }
        if (ch.type == SP_CHUNK_IMU)
            read_imu_chunk(rb, &ch, last_frame_ts);
    }
    CHECK_EQ_INT(rc, SP_EOS);
    sp_capture_reader_close(&r);
    return 0;
}

static int count_files(const char *dir, const char *suffix)
{
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)) != NULL) {
        size_t len = strlen(e->d_name), sl = strlen(suffix);
        n += len > sl && strcmp(e->d_name + len - sl, suffix) == 0;
    }
    if (d)
        closedir(d);
    return n;
}

/* ---- inputs ---- */

enum { PNG_W = 33, PNG_H = 21, N_SEQ = 5 };

/* f_1, f_2, f_3, f_10, f_11: name order differs from byte order, so the natural sort is tested. */
static const int seq_numbers[N_SEQ] = { 1, 2, 3, 10, 11 };

/* The fixture JPEG with a "frame N" comment segment after SOI: still valid, and its bytes say which file it was. */
static size_t write_marked_jpeg(const char *name, int n)
{
    char com[32];
    int len = snprintf(com, sizeof(com), "frame %d", n);
    uint8_t seg[4] = { 0xFF, 0xFE, 0, (uint8_t)(len + 2) };
    FILE *f = fopen(path_in(name), "wb");
    CHECK(f != NULL);
    if (!f)
        return 0;
    fwrite(fixture_jpeg, 1, 2, f);
    fwrite(seg, 1, 4, f);
    fwrite(com, 1, (size_t)len, f);
    fwrite(fixture_jpeg + 2, 1, sizeof(fixture_jpeg) - 2, f);
    fclose(f);
    return sizeof(fixture_jpeg) + 4 + (size_t)len;
}

static size_t jpeg_sizes[N_SEQ];

static void make_jpegs(void)
{
    mkdir(path_in("jpg"), 0755);
    for (int i = 0; i < N_SEQ; i++) {
        char name[64];
        snprintf(name, sizeof(name), "jpg/f_%d.JPG", seq_numbers[i]);
        jpeg_sizes[i] = write_marked_jpeg(name, i);
    }
    write_text("jpg/notes.txt", "not an image, must be ignored\n");
    mkdir(path_in("jpg/sub.jpg"), 0755); /* a directory with an image name, ignored too */
}

static void make_pngs(void)
{
    mkdir(path_in("png"), 0755);
    for (int i = 0; i < N_SEQ; i++) {
        char name[64];
        snprintf(name, sizeof(name), "png/f_%d.png", seq_numbers[i]);
        uint8_t *img = solid_image(i, PNG_W, PNG_H);
        CHECK_EQ_INT(sp_png_write(path_in(name), img, PNG_W, PNG_H, PNG_W * 3, 3), 0);
        free(img);
    }
}

#if HAVE_OPENCV
static void make_video(const char *name, int frames, double fps)
{
    sp_cv_video_writer *w = NULL;
    CHECK_EQ_INT(sp_cv_video_writer_open(&w, path_in(name), 64, 48, fps), 0);
    for (int i = 0; i < frames && w; i++) {
        uint8_t *img = solid_image(i, 64, 48);
        CHECK_EQ_INT(sp_cv_video_write(w, img, 64 * 3), 0);
        free(img);
    }
    CHECK_EQ_INT(sp_cv_video_writer_close(&w), 0);
}
#endif

/*
 * IMU at 100 Hz from t=-0.05 s to 0.6 s: gyro every row, accel every second row (empty cells
 * otherwise), mag every fifth. Fills the expected count per sensor.
 */
static void make_imu_csv(int counts[4])
{
    FILE *f = fopen(path_in("imu.csv"), "w");
    CHECK(f != NULL);
    if (!f)
        return;
    fprintf(f, "# phone log\r\nt,gx,gy,gz,ax,ay,az,mx,my,mz\r\n");
    memset(counts, 0, 4 * sizeof(int));
    for (int i = -5; i <= 60; i++) {
        fprintf(f, "%.4f,0.1,%.3f,-0.2", i * 0.01, 0.01 * i);
        counts[1]++;
        if (i % 2 == 0) {
            fprintf(f, ",0.0,0.0,9.81");
            counts[2]++;
        } else {
            fprintf(f, ",,,");
        }
        if (i % 5 == 0) {
            fprintf(f, ",20,-5,40\r\n");
            counts[3]++;
        } else {
            fprintf(f, ", , ,\r\n");
        }
        if (i == 30)
            fprintf(f, "\r\n# a comment and a blank line in the middle\r\n");
    }
    fclose(f);
}

static const char meta_text[] =
    "{\"kind\": \"selfie\", \"utc_start\": \"2024-06-21T12:00:00Z\", \"custom\": {\"a\": [1, 2, true, null]},\n"
    " \"camera\": {\"name\": \"test cam\", \"fx\": 40, \"fy\": 41, \"cx\": 8.5, \"cy\": 4.5},\n"
    " \"imu\": {\"name\": \"fake imu\", \"rate_hz\": 100, \"to_camera\": [1, 0, 0, 0]},\n"
    " \"location\": {\"latitude\": 48.85, \"longitude\": 2.35}}\n";

/* ---- the cases ---- */

static void check_meta(const readback *rb, const char *kind, uint32_t w, uint32_t h, double fps)
{
    sp_capture_meta m;
    sp_capture_meta_init(&m);
    CHECK_EQ_INT(sp_capture_meta_merge(&m, rb->meta_json, strlen(rb->meta_json)), 0);
    CHECK_MSG(strcmp(m.kind, kind) == 0, "kind '%s'", m.kind);
    CHECK(m.width == w && m.height == h);
    CHECK_NEAR(m.fps, fps, 1e-9);
    CHECK(strncmp(m.source, "import:", 7) == 0);
}

/* JPEG directory + IMU CSV + metadata: works in every build, JPEG files need no decoding. */
static void test_jpeg_sequence(const int imu_counts[4])
{
    CHECK_EQ_INT(run("import", path_in("jpg"), "-o", path_in("jpg.spcap"), "--fps", "10", "--imu",
                     path_in("imu.csv"), "--meta", path_in("meta.json"), "--kind", "static", "-q", NULL), 0);
    CHECK(!file_exists(path_in("jpg.spcap.partial")));
    readback rb;
    if (read_capture("jpg.spcap", &rb))
        return;
    CHECK_EQ_INT(rb.frames, N_SEQ);
    CHECK(rb.format == SP_PIXFMT_MJPEG && rb.width == FIXTURE_JPEG_W && rb.height == FIXTURE_JPEG_H);
    for (int i = 0; i < N_SEQ && i < rb.frames; i++) {
        CHECK_EQ_INT(rb.frame_ts[i], (int64_t)i * 100000000);
        CHECK_EQ_INT(rb.marker[i], i);                 /* natural name order */
        CHECK_EQ_INT(rb.frame_size[i], jpeg_sizes[i]); /* stored byte-for-byte */
    }
    for (int k = 1; k <= 3; k++)
        CHECK_MSG(rb.imu[k] == imu_counts[k], "sensor %d: %d samples, expected %d", k, rb.imu[k], imu_counts[k]);
    CHECK(rb.imu_monotonic);
    CHECK(rb.order_ok);
    CHECK_EQ_INT(rb.last_imu_ts, 600000000);
    check_meta(&rb, "static", FIXTURE_JPEG_W, FIXTURE_JPEG_H, 10);
    sp_capture_meta m;
    sp_capture_meta_init(&m);
    sp_capture_meta_merge(&m, rb.meta_json, strlen(rb.meta_json));
    CHECK(strcmp(m.camera_name, "test cam") == 0 && strcmp(m.imu_name, "fake imu") == 0);
    CHECK_NEAR(m.fy, 41, 0);
    CHECK_NEAR(m.latitude, 48.85, 1e-12);
    CHECK(strcmp(m.utc_start, "2024-06-21T12:00:00Z") == 0);
    /* keys the schema does not know pass through untouched */
    sp_json *j = NULL;
    CHECK_EQ_INT(sp_json_parse(rb.meta_json, strlen(rb.meta_json), &j, NULL, 0), 0);
    const sp_json *a = sp_json_get(sp_json_get(j, "custom"), "a");
    CHECK(a && a->count == 4 && sp_json_at(a, 2)->type == SP_JSON_BOOL);
    sp_json_free(j);

    /* the output exists now: a second import without --force must not touch it */
    struct stat before, after;
    stat(path_in("jpg.spcap"), &before);
    CHECK_EQ_INT(run("import", path_in("jpg"), "-o", path_in("jpg.spcap"), "--fps", "10", NULL), 3);
    CHECK(stderr_has("already exists"));
    stat(path_in("jpg.spcap"), &after);
    CHECK(before.st_size == after.st_size && before.st_ino == after.st_ino);
    /* --force replaces it; the IMU offset shifts every sample */
    CHECK_EQ_INT(run("import", path_in("jpg"), "-o", path_in("jpg.spcap"), "--fps", "10", "--imu",
                     path_in("imu.csv"), "--imu-offset", "0.25", "--max-frames", "2", "-f", "-q", NULL), 0);
    if (read_capture("jpg.spcap", &rb) == 0) {
        CHECK_EQ_INT(rb.frames, 2);
        CHECK_EQ_INT(rb.last_imu_ts, 850000000);
        CHECK(rb.order_ok);
        check_meta(&rb, "", FIXTURE_JPEG_W, FIXTURE_JPEG_H, 10);
    }
}

static void test_frame_times(void)
{
    write_text("times.csv", "frame,t_ns\n0,1000000000\n1,1033000000\n2,1070000000\n3,1100000000\n4,1140000000\n");
    write_text("imu_abs.csv", "t_ns,gx,gy,gz\n990000000,0,0,0\n1050000000,0,0,0\n");
    CHECK_EQ_INT(run("import", path_in("jpg/f_%d.jpg"), "-o", path_in("times.spcap"), "--frame-times",
                     path_in("times.csv"), "--imu", path_in("imu_abs.csv"), "-q", NULL), 2);
    CHECK(stderr_has("f_%d.jpg: no file matches")); /* the files are called .JPG */
    CHECK_EQ_INT(run("import", path_in("jpg/f_%d.JPG"), "-o", path_in("times.spcap"), "--frame-times",
                     path_in("times.csv"), "--imu", path_in("imu_abs.csv"), "-q", NULL), 0);
    readback rb;
    if (read_capture("times.spcap", &rb))
        return;
    /* the pattern starts at 1 and stops at the first gap (f_4): three frames */
    CHECK_EQ_INT(rb.frames, 3);
    static const int64_t want[3] = { 0, 33000000, 70000000 };
    for (int i = 0; i < 3; i++)
        CHECK_EQ_INT(rb.frame_ts[i], want[i]);
    CHECK_EQ_INT(rb.imu[1], 2);
    CHECK_EQ_INT(rb.last_imu_ts, 50000000); /* IMU on the frame-times clock */
    CHECK(rb.order_ok);
    check_meta(&rb, "", FIXTURE_JPEG_W, FIXTURE_JPEG_H, 4.0 / 0.14); /* nominal: 4 intervals over 0.14 s */
}

static void test_export(void)
{
    if (!sp_jpeg_available()) {
        CHECK_EQ_INT(run("export-video", path_in("times.spcap"), "-o", path_in("out_all"), "-q", NULL), 4);
        CHECK(stderr_has("-Djpeg"));
        fprintf(stderr, "note: no libjpeg in this build: MJPEG export checked as disabled only\n");
        return;
    }
    CHECK_EQ_INT(run("export-video", path_in("times.spcap"), "-o", path_in("out_all"), "-q", NULL), 0);
    CHECK_EQ_INT(count_files(path_in("out_all"), ".png"), 3);
    CHECK_EQ_INT(run("export-video", path_in("times.spcap"), "-o", path_in("out_half"), "--every", "2", "--scale",
                     "0.5", "-q", NULL), 0);
    CHECK_EQ_INT(count_files(path_in("out_half"), ".png"), 2);
    CHECK(file_exists(path_in("out_half/frame_000002.png")));
    CHECK_EQ_INT(run("export-video", path_in("times.spcap"), "-o", path_in("out_one"), "--max-frames", "1", "-q",
                     NULL), 0);
    CHECK_EQ_INT(count_files(path_in("out_one"), ".png"), 1);
#if HAVE_OPENCV
    /* the exported pixels are the fixture's two halves (within JPEG error), at half size 8x4 */
    uint8_t *buf = NULL;
    size_t cap = 0;
    uint32_t w = 0, h = 0;
    CHECK_EQ_INT(sp_cv_image_read(path_in("out_half/frame_000002.png"), &buf, &cap, &w, &h), 0);
    CHECK(w == 8 && h == 4);
    if (buf && w == 8 && h == 4) {
        static const uint8_t left[3] = { 200, 90, 40 }, right[3] = { 40, 90, 200 };
        for (int c = 0; c < 3; c++) {
            CHECK_MSG(abs(buf[(1 * 8 + 1) * 3 + c] - left[c]) <= 24, "left %d: %d", c, buf[(8 + 1) * 3 + c]);
            CHECK_MSG(abs(buf[(1 * 8 + 6) * 3 + c] - right[c]) <= 24, "right %d: %d", c, buf[(8 + 6) * 3 + c]);
        }
    }
    free(buf);
#endif
}

static void test_png_sequence(void)
{
    make_pngs();
#if HAVE_OPENCV
    CHECK_EQ_INT(run("import", path_in("png"), "-o", path_in("rgb.spcap"), "--fps", "25", "--store", "rgb",
                     "--max-frames", "4", "-q", NULL), 0);
    readback rb;
    if (read_capture("rgb.spcap", &rb) == 0) {
        CHECK_EQ_INT(rb.frames, 4);
        CHECK(rb.format == SP_PIXFMT_RGB24 && rb.width == PNG_W && rb.height == PNG_H);
        for (int i = 0; i < 4; i++) {
            CHECK_EQ_INT(rb.first_pixel[i][0], i); /* lossless, in natural name order */
            CHECK_EQ_INT(rb.frame_ts[i], (int64_t)i * 40000000);
        }
    }
    int rc = run("import", path_in("png"), "-o", path_in("pngj.spcap"), "--fps", "25", "--quality", "70", "-q", NULL);
    if (sp_jpeg_available()) {
        CHECK_EQ_INT(rc, 0);
        if (read_capture("pngj.spcap", &rb) == 0)
            CHECK(rb.frames == N_SEQ && rb.format == SP_PIXFMT_MJPEG);
    } else {
        CHECK_EQ_INT(rc, 4);
        CHECK(stderr_has("-Djpeg"));
    }
#else
    CHECK_EQ_INT(run("import", path_in("png"), "-o", path_in("rgb.spcap"), "--fps", "25", NULL), 4);
    CHECK(stderr_has("-Dopencv"));
    CHECK(!file_exists(path_in("rgb.spcap")) && !file_exists(path_in("rgb.spcap.partial")));
    fprintf(stderr, "note: no OpenCV in this build: PNG import checked as disabled only\n");
#endif
}

static void test_video(void)
{
    write_text("garbage.avi", "RIFF but not really a video");
#if HAVE_OPENCV
    CHECK_EQ_INT(run("import", path_in("garbage.avi"), "-o", path_in("g.spcap"), NULL), 2);
    CHECK(stderr_has("garbage.avi"));
    CHECK(!file_exists(path_in("g.spcap")) && !file_exists(path_in("g.spcap.partial")));
    make_video("tiny.avi", 8, 5.0);
    const char *store = sp_jpeg_available() ? "jpeg" : "rgb";
    CHECK_EQ_INT(run("import", path_in("tiny.avi"), "-o", path_in("video.spcap"), "--store", store, "-q", NULL), 0);
    readback rb;
    if (read_capture("video.spcap", &rb))
        return;
    CHECK_EQ_INT(rb.frames, 8);
    CHECK(rb.width == 64 && rb.height == 48);
    CHECK(rb.format == (sp_jpeg_available() ? SP_PIXFMT_MJPEG : SP_PIXFMT_RGB24));
    CHECK_EQ_INT(rb.frame_ts[7], 1400000000); /* 7 frames at the video's 5 fps */
    check_meta(&rb, "", 64, 48, 5.0);
    /* and back out to a video file, written under a temporary name first */
    CHECK_EQ_INT(run("export-video", path_in("video.spcap"), "-o", path_in("back.avi"), "-q", NULL), 0);
    CHECK(!file_exists(path_in("back.partial.avi")));
    CHECK_EQ_INT(run("export-video", path_in("video.spcap"), "-o", path_in("back.mp4"), "--scale", "0.5", "-q",
                     NULL), 0);
    const char *files[2] = { "back.avi", "back.mp4" };
    const uint32_t widths[2] = { 64, 32 };
    for (int f = 0; f < 2; f++) {
        sp_cv_video_reader *vr = NULL;
        sp_cv_video_info info;
        CHECK_EQ_INT(sp_cv_video_open(&vr, path_in(files[f]), &info), 0);
        CHECK(info.width == widths[f] && info.height == widths[f] * 3 / 4);
        uint8_t frame[64 * 48 * 3];
        int n = 0;
        while (vr && sp_cv_video_read(vr, frame, sizeof(frame), info.width * 3) == 0)
            n++;
        CHECK_MSG(n == 8, "%s: %d frames", files[f], n);
        sp_cv_video_close(&vr);
    }
    CHECK_EQ_INT(run("export-video", path_in("video.spcap"), "-o", path_in("back.avi"), "-q", NULL), 3);
    CHECK(stderr_has("--force"));
#else
    CHECK_EQ_INT(run("import", path_in("garbage.avi"), "-o", path_in("g.spcap"), "--fps", "5", NULL), 4);
    CHECK(stderr_has("-Dopencv"));
    CHECK(!file_exists(path_in("g.spcap")) && !file_exists(path_in("g.spcap.partial")));
    CHECK_EQ_INT(run("export-video", path_in("jpg.spcap"), "-o", path_in("back.avi"), NULL), 4);
    CHECK(stderr_has("-Dopencv"));
    fprintf(stderr, "note: no OpenCV in this build: video import/export checked as disabled only\n");
#endif
}

/* A failing import exits non-zero, names the problem, and leaves neither OUT nor OUT.partial. */
static void expect_imu_failure(const char *csv_name, const char *csv_text, const char *needle, int code)
{
    if (csv_text)
        write_text(csv_name, csv_text);
    const char *out = path_in("bad.spcap");
    int rc = run("import", path_in("jpg"), "-o", out, "--fps", "10", "--imu", path_in(csv_name), "-q", NULL);
    CHECK_MSG(rc == code, "%s: exit %d, expected %d", csv_name, rc, code);
    CHECK(stderr_has(needle));
    CHECK(!file_exists(out) && !file_exists(path_in("bad.spcap.partial")));
}

static void test_bad_imu(void)
{
    expect_imu_failure("nan.csv", "t,gx,gy,gz\n0,0,0,0\n0.01,0,nan,0\n", "nan.csv:3: column 'gy': 'nan' is not a finite",
                       2);
    expect_imu_failure("inf.csv", "t,ax,ay,az\n0,0,0,9.8\n# c\n0.02,-Inf,0,0\n", "inf.csv:4:", 2);
    expect_imu_failure("junk.csv", "t,ax,ay,az\n0,0,0,9.8x\n", "junk.csv:2: column 'az'", 2);
    expect_imu_failure("back.csv", "t_ns,gx,gy,gz\n100,0,0,0\n300,0,0,0\n200,0,0,0\n", "back.csv:4: time goes backwards",
                       2);
    /* the bad row comes after frames were written: the partial capture must still go */
    expect_imu_failure("late.csv", "t,gx,gy,gz\n0,0,0,0\n0.35,0,0,0\n0.2,0,0,0\n", "late.csv:4:", 2);
    expect_imu_failure("dup.csv", "t,gx,gy,gz\n0.5,0,0,0\n0.5,1,1,1\n", "dup.csv:3: second gyro sample", 2);
    expect_imu_failure("cols.csv", "t,gx,gy\n0,0,0\n", "missing column 'gz'", 2);
    expect_imu_failure("none.csv", "t,temp\n0,20\n", "no sensor columns", 2);
    expect_imu_failure("notime.csv", "gx,gy,gz\n0,0,0\n", "needs a 't'", 2);
    expect_imu_failure("twotimes.csv", "t,t_ns,gx,gy,gz\n0,0,0,0,0\n", "both 't' and 't_ns'", 2);
    expect_imu_failure("partial.csv", "t,gx,gy,gz\n0,1,,3\n", "partial.csv:2:", 2);
    expect_imu_failure("fields.csv", "t,gx,gy,gz\n0,1,2\n", "fields.csv:2: 3 fields", 2);
    expect_imu_failure("empty.csv", "", "no header row", 2);
    expect_imu_failure("dupcol.csv", "t,gx,gy,gz,gx\n", "twice", 2);
    expect_imu_failure("missing.csv", NULL, "missing.csv", 3);
}

static void test_bad_input(void)
{
    const char *out = path_in("bad.spcap");
    CHECK_EQ_INT(run("import", path_in("no_such_dir"), "-o", out, "--fps", "10", NULL), 3);
    CHECK(stderr_has("no_such_dir"));
    mkdir(path_in("empty_dir"), 0755);
    CHECK_EQ_INT(run("import", path_in("empty_dir"), "-o", out, "--fps", "10", NULL), 2);
    CHECK(stderr_has("no .jpg"));
    CHECK_EQ_INT(run("import", path_in("jpg"), "-o", out, NULL), 1); /* an image sequence needs a rate */
    CHECK(stderr_has("--fps"));
    /* frame times: non-monotonic, and too few for the frames */
    write_text("ft_back.csv", "t\n0\n0.1\n0.1\n");
    CHECK_EQ_INT(run("import", path_in("jpg"), "-o", out, "--frame-times", path_in("ft_back.csv"), NULL), 2);
    CHECK(stderr_has("ft_back.csv:4:"));
    write_text("ft_short.csv", "t\n0\n0.1\n");
    CHECK_EQ_INT(run("import", path_in("jpg"), "-o", out, "--frame-times", path_in("ft_short.csv"), NULL), 2);
    CHECK(stderr_has("has 2 frame times"));
    /* metadata: wrong type, size contradicting the frames, syntax error, unknown kind, out of range */
    static const struct {
        const char *name, *text, *needle;
    } metas[] = {
        { "m_type.json", "{\"camera\": {\"fx\": \"forty\"}}", "camera.fx must be a number" },
        { "m_size.json", "{\"camera\": {\"width\": 1920, \"height\": 1080}}", "1920x1080" },
        { "m_syntax.json", "{\"kind\": \"selfie\",}", "m_syntax.json" },
        { "m_kind.json", "{\"kind\": \"panorama\"}", "m_kind.json" },
        { "m_range.json", "{\"camera\": {\"fx\": -5}}", "m_range.json" },
        { "m_array.json", "[1, 2]", "one JSON object" },
        { "m_quat.json", "{\"imu\": {\"to_camera\": [1, 0, 0]}}", "imu.to_camera must be an array of 4" },
    };
    for (size_t i = 0; i < sizeof(metas) / sizeof(metas[0]); i++) {
        write_text(metas[i].name, metas[i].text);
        CHECK_MSG(run("import", path_in("jpg"), "-o", out, "--fps", "10", "--meta", path_in(metas[i].name), NULL) == 2,
                  "%s", metas[i].name);
        CHECK(stderr_has(metas[i].needle));
    }
    /* an unreadable image in the middle of a sequence: fails after a frame was written, still no output */
    mkdir(path_in("broken"), 0755);
    write_marked_jpeg("broken/a_1.jpg", 0);
    write_text("broken/a_2.jpg", "this is not a JPEG");
    CHECK_EQ_INT(run("import", path_in("broken"), "-o", out, "--fps", "10", NULL), 2);
    CHECK(stderr_has("a_2.jpg"));
    CHECK(!file_exists(out) && !file_exists(path_in("bad.spcap.partial")));
    /* command-line mistakes */
    CHECK_EQ_INT(run("import", path_in("jpg"), "--fps", "10", NULL), 1);
    CHECK_EQ_INT(run("import", path_in("jpg"), "-o", out, "--fps", "-3", NULL), 1);
    CHECK_EQ_INT(run("import", path_in("jpg"), "-o", out, "--fps", "nan", NULL), 1);
    CHECK_EQ_INT(run("import", path_in("jpg"), "-o", out, "--quality", "101", NULL), 1);
    CHECK_EQ_INT(run("import", path_in("jpg"), "-o", out, "--kind", "other", "--fps", "1", NULL), 1);
    CHECK_EQ_INT(run("import", path_in("jpg"), "-o", out, "--store", "png", "--fps", "1", NULL), 1);
    CHECK_EQ_INT(run("export-video", path_in("no.spcap"), "-o", path_in("x"), NULL), 3);
    CHECK(!file_exists(path_in("x")));
    CHECK_EQ_INT(run("export-video", path_in("jpg.spcap"), "-o", path_in("x"), "--scale", "0", NULL), 1);
    CHECK(!file_exists(out));
}

static void remove_tree(const char *dir)
{
    char cmd[600];
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", dir);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", dir);
}

static void make_tmp(void)
{
    const char *base = getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp";
    snprintf(tmp, sizeof(tmp), "%s/sp_import_XXXXXX", base);
    if (!mkdtemp(tmp)) {
        perror("mkdtemp");
        exit(99);
    }
}

static void test_vtest(void)
{
#if HAVE_OPENCV
    if (!file_exists(VTEST))
        SKIP("%s not found (Debian package opencv-doc)", VTEST);
    make_tmp();
    CHECK_EQ_INT(run("import", VTEST, "-o", path_in("vtest.spcap"), "--max-frames", "50", "--kind", "static", "-q",
                     NULL), 0);
    readback rb;
    if (read_capture("vtest.spcap", &rb))
        return;
    CHECK_EQ_INT(rb.frames, 50);
    CHECK(rb.width == 768 && rb.height == 576);
    CHECK_EQ_INT(rb.frame_ts[49], 4900000000); /* vtest.avi declares 10 fps */
    check_meta(&rb, "static", 768, 576, 10.0);
#else
    SKIP("built without OpenCV (-Dopencv): cannot decode %s", VTEST);
#endif
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: test_import SUNPROBE [vtest]\n");
        return 99;
    }
    sunprobe = argv[1];
    if (argc > 2 && strcmp(argv[2], "vtest") == 0) {
        test_vtest();
    } else {
        int imu_counts[4];
        make_tmp();
        make_jpegs();
        make_imu_csv(imu_counts);
        write_text("meta.json", meta_text);
        test_jpeg_sequence(imu_counts);
        test_frame_times();
        test_export();
        test_png_sequence();
        test_video();
        test_bad_imu();
        test_bad_input();
    }
    int code = check_exit();
    if (code == 0)
        remove_tree(tmp);
    else
        fprintf(stderr, "inputs and outputs kept in %s\n", tmp);
    return code;
}
