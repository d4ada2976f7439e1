/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe import` and `sunprobe export-video` through the binary: a JPEG
 * sequence with IMU CSV and metadata JSON, PNG images and a tiny video made
 * with the OpenCV shim, read back and exported to PNGs and video files; bad
 * input exits non-zero, names the file and line, and leaves no output.
 * The exhaustive bad-input matrix runs in-process in tests/unit/test_import.c
 * (each start of the binary costs ~0.3 s of CPU loading OpenCV).
 * usage: test_import SUNPROBE [vtest]
 */
#include <dirent.h>
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
#include "export/png.h"
#include "import_util.h"
#include "sp_config.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_meta.h"

#define VTEST "/usr/share/doc/opencv-doc/examples/data/vtest.avi"

static const char *sunprobe;

/* Runs sunprobe with NULL-terminated arguments, stderr into stderr.txt, stdout into stdout.txt; returns the exit code. */
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
    const char *err_path = iu_path("stderr.txt"), *out_path = iu_path("stdout.txt");
    pid_t pid = fork();
    if (pid == 0) {
        int fd = open(err_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        int out = open(out_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0)
            dup2(fd, 2);
        if (out >= 0)
            dup2(out, 1);
        execv(sunprobe, (char *const *)argv);
        _exit(127);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

static int output_has(const char *name, const char *needle)
{
    char buf[4096] = { 0 };
    FILE *f = fopen(iu_path(name), "r");
    if (f) {
        buf[fread(buf, 1, sizeof(buf) - 1, f)] = 0;
        fclose(f);
    }
    if (strstr(buf, needle))
        return 1;
    fprintf(stderr, "%s was: %s(expected to contain '%s')\n", name, buf, needle);
    return 0;
}

static int stderr_has(const char *needle)
{
    return output_has("stderr.txt", needle);
}

#if HAVE_OPENCV /* only the video tests read stdout */
static int stdout_has(const char *needle)
{
    return output_has("stdout.txt", needle);
}
#endif

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

enum { N_SEQ = 4 };

static void make_inputs(void)
{
    mkdir(iu_path("jpg"), 0755);
    for (int i = 0; i < N_SEQ; i++) {
        char name[64];
        snprintf(name, sizeof(name), "jpg/img_%d.jpg", i * 5); /* 0, 5, 10, 15: natural order */
        iu_write_marked_jpeg(name, i);
    }
    /* IMU at 50 Hz over the 0.3 s of the frames: gyro each row, accel every second */
    FILE *f = fopen(iu_path("imu.csv"), "w");
    CHECK(f != NULL);
    if (f) {
        fprintf(f, "t,gx,gy,gz,ax,ay,az\n");
        for (int i = 0; i <= 15; i++)
            fprintf(f, i % 2 ? "%.2f,0.1,0.2,0.3,,,\n" : "%.2f,0.1,0.2,0.3,0,0,9.81\n", i * 0.02);
        fclose(f);
    }
    iu_write_text("meta.json", "{\"kind\": \"selfie\", \"camera\": {\"name\": \"cli cam\", \"fx\": 20, \"fy\": 20},"
                               " \"imu\": {\"name\": \"cli imu\", \"rate_hz\": 50}}");
    iu_write_text("nan.csv", "t,gx,gy,gz\n0,0,0,0\n0.02,0,NaN,0\n");
    iu_write_text("back.csv", "t,gx,gy,gz\n0,0,0,0\n0.2,0,0,0\n0.1,0,0,0\n");
}

static void test_import_sequence(void)
{
    CHECK_EQ_INT(run("import", iu_path("jpg"), "-o", iu_path("a.spcap"), "--fps", "10", "--imu", iu_path("imu.csv"),
                     "--meta", iu_path("meta.json"), "--kind", "static", "-q", NULL), 0);
    CHECK(!iu_exists(iu_path("a.spcap.partial")));
    iu_readback rb;
    if (iu_read_capture(iu_path("a.spcap"), &rb))
        return;
    CHECK_EQ_INT(rb.frames, N_SEQ);
    CHECK(rb.format == SP_PIXFMT_MJPEG && rb.width == FIXTURE_JPEG_W && rb.height == FIXTURE_JPEG_H);
    for (int i = 0; i < N_SEQ; i++) {
        CHECK_EQ_INT(rb.frame_ts[i], (int64_t)i * 100000000);
        CHECK_EQ_INT(rb.marker[i], i);
    }
    CHECK(rb.imu[1] == 16 && rb.imu[2] == 8 && rb.imu[3] == 0);
    CHECK(rb.order_ok && rb.imu_monotonic && rb.last_imu_ts == 300000000);
    sp_capture_meta m;
    sp_capture_meta_init(&m);
    CHECK_EQ_INT(sp_capture_meta_merge(&m, rb.meta_json, strlen(rb.meta_json)), 0);
    CHECK(strcmp(m.kind, "static") == 0 && strcmp(m.camera_name, "cli cam") == 0);
    CHECK(m.width == FIXTURE_JPEG_W && m.height == FIXTURE_JPEG_H && m.fps == 10);
    CHECK(strcmp(m.imu_name, "cli imu") == 0 && m.imu_rate_hz == 50);

    /* the output exists now: refused without --force, and left as it was */
    struct stat before, after;
    stat(iu_path("a.spcap"), &before);
    CHECK_EQ_INT(run("import", iu_path("jpg"), "-o", iu_path("a.spcap"), "--fps", "10", NULL), 1);
    CHECK(stderr_has("already exists"));
    stat(iu_path("a.spcap"), &after);
    CHECK(before.st_ino == after.st_ino && before.st_size == after.st_size);
}

static void test_bad_input(void)
{
    const char *out = iu_path("bad.spcap");
    CHECK_EQ_INT(run("import", iu_path("jpg"), "-o", out, "--fps", "10", "--imu", iu_path("nan.csv"), NULL), 2);
    CHECK(stderr_has("nan.csv:3: column 'gy'"));
    CHECK(!iu_exists(out) && !iu_exists(iu_path("bad.spcap.partial")));
    CHECK_EQ_INT(run("import", iu_path("jpg"), "-o", out, "--fps", "10", "--imu", iu_path("back.csv"), NULL), 2);
    CHECK(stderr_has("back.csv:4: time goes backwards"));
    CHECK(!iu_exists(out) && !iu_exists(iu_path("bad.spcap.partial")));
    /* an IMU log whose clock never meets the frames' is refused with both spans; --imu-offset fixes it */
    iu_write_text("late_imu.csv", "t,gx,gy,gz,ax,ay,az\n1000,0,0,0,0,0,9.81\n1000.01,0,0,0,0,0,9.81\n"
                                  "1000.02,0,0,0,0,0,9.81\n1000.03,0,0,0,0,0,9.81\n");
    CHECK_EQ_INT(run("import", iu_path("jpg"), "-o", iu_path("late.spcap"), "--fps", "10", "--imu",
                     iu_path("late_imu.csv"), "-q", NULL), 2);
    CHECK(stderr_has("late_imu.csv: the IMU log spans 1000.000 to 1000.030 s and the frames 0 to 0.300 s"));
    CHECK(stderr_has("never overlap"));
    CHECK(!iu_exists(iu_path("late.spcap")) && !iu_exists(iu_path("late.spcap.partial")));
    CHECK_EQ_INT(run("import", iu_path("jpg"), "-o", out, "--fps", "10", "--imu", iu_path("late_imu.csv"),
                     "--imu-format", "csv", NULL), 1);
    CHECK(stderr_has("imu-format"));
    CHECK_EQ_INT(run("import", iu_path("jpg"), "-o", iu_path("late.spcap"), "--fps", "10", "--imu",
                     iu_path("late_imu.csv"), "--imu-offset", "-1000", "-q", NULL), 0);
    /* META strings that are not UTF-8, or that a C string cannot hold, are refused with the byte (format: UTF-8) */
    static const char *const not_utf8[][2] = { { "{\"source\": \"caf\xe9\"}", "not UTF-8" },
                                               { "{\"source\": \"a\\u0000b\"}", "\\u0000 in a string" },
                                               { "{\"source\": \"\\ud800\"}", "lone surrogate" } };
    for (size_t i = 0; i < sizeof(not_utf8) / sizeof(not_utf8[0]); i++) {
        iu_write_text("bad_meta.json", not_utf8[i][0]);
        CHECK_EQ_INT(run("import", iu_path("jpg"), "-o", out, "--fps", "10", "--meta", iu_path("bad_meta.json"), NULL),
                     2);
        CHECK(stderr_has(not_utf8[i][1]));
        CHECK(!iu_exists(out));
    }
    /* a META file over 1 MiB is bad input (exit 2), not an I/O fault */
    {
        size_t big = (1u << 20) + 4096;
        char *text = malloc(big + 1);
        CHECK(text != NULL);
        if (text) {
            memset(text, ' ', big);
            memcpy(text, "{\"kind\": \"selfie\"}", 18);
            text[big] = 0;
            iu_write_text("big_meta.json", text);
            free(text);
            CHECK_EQ_INT(run("import", iu_path("jpg"), "-o", out, "--fps", "10", "--meta", iu_path("big_meta.json"),
                             NULL), 2);
            CHECK(stderr_has("big_meta.json: larger than 1 MiB"));
            CHECK(!iu_exists(out));
        }
    }
    CHECK_EQ_INT(run("import", iu_path("no_such_dir"), "-o", out, "--fps", "10", NULL), 3);
    CHECK(stderr_has("no_such_dir"));
    CHECK(!iu_exists(out));
    CHECK_EQ_INT(run("import", iu_path("jpg"), "--fps", "10", NULL), 1); /* no -o */
    CHECK(stderr_has("-o OUT is required"));
    CHECK_EQ_INT(run("export-video", iu_path("no.spcap"), "-o", iu_path("x"), NULL), 3);
    CHECK(!iu_exists(iu_path("x")));
}

static void test_export_pngs(void)
{
    if (!sp_jpeg_available()) {
        CHECK_EQ_INT(run("export-video", iu_path("a.spcap"), "-o", iu_path("pngs"), "-q", NULL), 4);
        CHECK(stderr_has("-Djpeg"));
        fprintf(stderr, "note: no libjpeg in this build: MJPEG export checked as disabled only\n");
        return;
    }
    CHECK_EQ_INT(run("export-video", iu_path("a.spcap"), "-o", iu_path("pngs"), "--every", "2", "--scale", "0.5",
                     "-q", NULL), 0);
    CHECK_EQ_INT(count_files(iu_path("pngs"), ".png"), 2);
    CHECK(iu_exists(iu_path("pngs/frame_000000.png")) && iu_exists(iu_path("pngs/frame_000002.png")));
#if HAVE_OPENCV
    uint8_t *buf = NULL;
    size_t cap = 0;
    uint32_t w = 0, h = 0;
    CHECK_EQ_INT(sp_cv_image_read(iu_path("pngs/frame_000002.png"), &buf, &cap, &w, &h), 0);
    CHECK(w == 8 && h == 4);
    if (buf && w == 8 && h == 4) { /* the fixture's halves, within JPEG and averaging error */
        CHECK(abs(buf[(8 + 1) * 3] - 200) <= 24 && abs(buf[(8 + 1) * 3 + 2] - 40) <= 24);
        CHECK(abs(buf[(8 + 6) * 3] - 40) <= 24 && abs(buf[(8 + 6) * 3 + 2] - 200) <= 24);
    }
    free(buf);
#endif
}

static void write_yuv_frame(sp_capture_writer *w, enum sp_pixfmt fmt, uint32_t stream, uint64_t seq, uint8_t y)
{
    uint8_t data[8 * 6 * 2];
    sp_frame f = { .format = fmt, .width = 6, .height = 4, .stride = fmt == SP_PIXFMT_YUYV ? 16 : 8, .data = data,
                   .timestamp_ns = (int64_t)seq * 1000000, .sequence = seq, .stream_id = stream,
                   .exposure_us = NAN, .gain = NAN };
    memset(data, 128, sizeof(data)); /* neutral chroma */
    for (uint32_t r = 0; r < 4; r++)
        for (uint32_t x = 0; x < 6; x++)
            data[r * f.stride + (fmt == SP_PIXFMT_YUYV ? x * 2 : x)] = y;
    f.bytes_used = fmt == SP_PIXFMT_YUYV ? 4 * 16 : 6 * 8;
    CHECK_EQ_INT(sp_capture_write_frame(w, &f), 0);
}

/* Raw YUV frames as a camera delivers them go through pixconv to PNG; another stream is left out. */
static void test_export_yuv(void)
{
    sp_capture_writer *w = NULL;
    CHECK_EQ_INT(sp_capture_writer_open(&w, iu_path("yuv.spcap"), NULL), 0);
    if (!w)
        return;
    write_yuv_frame(w, SP_PIXFMT_YUYV, 0, 0, 235); /* white */
    write_yuv_frame(w, SP_PIXFMT_YUYV, 1, 1, 16);  /* stream 1: not exported */
    write_yuv_frame(w, SP_PIXFMT_NV12, 0, 2, 16);  /* black */
    CHECK_EQ_INT(sp_capture_writer_close(&w), 0);
    CHECK_EQ_INT(run("export-video", iu_path("yuv.spcap"), "-o", iu_path("yuv"), "-q", NULL), 0);
    CHECK_EQ_INT(count_files(iu_path("yuv"), ".png"), 2);
#if HAVE_OPENCV
    static const uint8_t want[2] = { 255, 0 };
    for (int i = 0; i < 2; i++) {
        char name[32];
        snprintf(name, sizeof(name), "yuv/frame_%06d.png", i);
        uint8_t *buf = NULL;
        size_t cap = 0;
        uint32_t pw = 0, ph = 0;
        CHECK_EQ_INT(sp_cv_image_read(iu_path(name), &buf, &cap, &pw, &ph), 0);
        CHECK(pw == 6 && ph == 4);
        for (size_t k = 0; buf && k < (size_t)pw * ph * 3; k++)
            CHECK_MSG(buf[k] == want[i], "%s byte %zu = %u", name, k, buf[k]);
        free(buf);
    }
#endif
}

#if HAVE_OPENCV
static int video_frames(const char *path, uint32_t *w, uint32_t *h)
{
    sp_cv_video_reader *vr = NULL;
    sp_cv_video_info info = { 0 };
    CHECK_EQ_INT(sp_cv_video_open(&vr, path, &info), 0);
    *w = info.width;
    *h = info.height;
    uint8_t *frame = malloc((size_t)info.width * info.height * 3 + 1);
    int n = 0;
    while (vr && frame && sp_cv_video_read(vr, frame, (size_t)info.width * info.height * 3, info.width * 3) == 0)
        n++;
    free(frame);
    sp_cv_video_close(&vr);
    return n;
}
#endif

static void test_png_and_video(void)
{
    mkdir(iu_path("png"), 0755);
    for (int i = 0; i < 2; i++) {
        char name[32];
        snprintf(name, sizeof(name), "png/p%d.png", i);
        uint8_t *img = iu_solid_image(i, 30, 20);
        CHECK_EQ_INT(sp_png_write(iu_path(name), img, 30, 20, 90, 3), 0);
        free(img);
    }
#if HAVE_OPENCV
    CHECK_EQ_INT(run("import", iu_path("png"), "-o", iu_path("png.spcap"), "--fps", "2", "--store", "rgb", "-q", NULL),
                 0);
    iu_readback rb;
    if (iu_read_capture(iu_path("png.spcap"), &rb) == 0)
        CHECK(rb.frames == 2 && rb.format == SP_PIXFMT_RGB24 && rb.pixel0[1][0] == 1);

    sp_cv_video_writer *w = NULL;
    CHECK_EQ_INT(sp_cv_video_writer_open(&w, iu_path("tiny.avi"), 64, 48, 5.0), 0);
    for (int i = 0; i < 6 && w; i++) {
        uint8_t *img = iu_solid_image(i, 64, 48);
        CHECK_EQ_INT(sp_cv_video_write(w, img, 64 * 3), 0);
        free(img);
    }
    CHECK_EQ_INT(sp_cv_video_writer_close(&w), 0);
    const char *store = sp_jpeg_available() ? "jpeg" : "rgb";
    CHECK_EQ_INT(run("import", iu_path("tiny.avi"), "-o", iu_path("v.spcap"), "--store", store, "--quality", "80",
                     "-q", NULL), 0);
    if (iu_read_capture(iu_path("v.spcap"), &rb) == 0) {
        CHECK(rb.frames == 6 && rb.width == 64 && rb.height == 48);
        CHECK_EQ_INT(rb.frame_ts[5], 1000000000); /* the video's 5 fps */
    }
    /* back out to video files: MJPG .avi at full size, mp4v .mp4 at half size */
    CHECK_EQ_INT(run("export-video", iu_path("v.spcap"), "-o", iu_path("back.avi"), "-q", NULL), 0);
    CHECK_EQ_INT(run("export-video", iu_path("v.spcap"), "-o", iu_path("back.mp4"), "--scale", "0.5", "-q", NULL), 0);
    CHECK(!iu_exists(iu_path("back.partial.avi")) && !iu_exists(iu_path("back.partial.mp4")));
    uint32_t vw = 0, vh = 0;
    CHECK_EQ_INT(video_frames(iu_path("back.avi"), &vw, &vh), 6);
    CHECK(vw == 64 && vh == 48);
    CHECK_EQ_INT(video_frames(iu_path("back.mp4"), &vw, &vh), 6);
    CHECK(vw == 32 && vh == 24);
    CHECK_EQ_INT(run("export-video", iu_path("v.spcap"), "-o", iu_path("back.avi"), NULL), 1);
    CHECK(stderr_has("--force"));
#else
    CHECK_EQ_INT(run("import", iu_path("png"), "-o", iu_path("png.spcap"), "--fps", "2", NULL), 4);
    CHECK(stderr_has("-Dopencv"));
    CHECK(!iu_exists(iu_path("png.spcap")) && !iu_exists(iu_path("png.spcap.partial")));
    CHECK_EQ_INT(run("export-video", iu_path("a.spcap"), "-o", iu_path("back.avi"), NULL), 4);
    CHECK(stderr_has("-Dopencv"));
    fprintf(stderr, "note: no OpenCV in this build: PNG/video import and video export checked as disabled only\n");
#endif
}

static void test_vtest(void)
{
#if HAVE_OPENCV
    if (access(VTEST, R_OK) != 0)
        SKIP("%s not found (Debian package opencv-doc)", VTEST);
    iu_make_tmp("import_vtest");
    CHECK_EQ_INT(run("import", VTEST, "-o", iu_path("vtest.spcap"), "--max-frames", "50", "--kind", "static", "-q",
                     NULL), 0);
    iu_readback rb;
    if (iu_read_capture(iu_path("vtest.spcap"), &rb))
        return;
    CHECK_EQ_INT(rb.frames, 50);
    CHECK(rb.width == 768 && rb.height == 576);
    CHECK_EQ_INT(rb.frame_ts[49], 4900000000); /* vtest.avi declares 10 fps */
    sp_capture_meta m;
    sp_capture_meta_init(&m);
    CHECK_EQ_INT(sp_capture_meta_merge(&m, rb.meta_json, strlen(rb.meta_json)), 0);
    CHECK(strcmp(m.kind, "static") == 0 && m.width == 768 && m.height == 576 && m.fps == 10);
#else
    SKIP("built without OpenCV (-Dopencv): cannot decode %s", VTEST);
#endif
}

/*
 * A variable-frame-rate video made with ffmpeg (10 frames at 30 fps, then 10 at 15 fps): its frames keep
 * the container's times, not i / fps; --fps and --frame-times still override them.
 */
static void test_vfr(void)
{
#if HAVE_OPENCV
    if (system("command -v ffmpeg >/dev/null 2>&1") != 0)
        SKIP("ffmpeg not installed (Debian package ffmpeg): cannot make the variable-frame-rate video");
    iu_make_tmp("import_vfr");
    char cmd[1200];
    snprintf(cmd, sizeof(cmd), "ffmpeg -hide_banner -loglevel error -y -f lavfi -i testsrc=size=64x48:rate=30 "
             "-frames:v 20 -vf \"setpts='if(lt(N,10),N/30,(2*N-10)/30)/TB'\" -fps_mode vfr -c:v mpeg4 -q:v 5 '%s'",
             iu_path("vfr.mp4"));
    if (system(cmd) != 0)
        SKIP("this ffmpeg cannot write an mpeg4 .mp4 with a variable frame rate");
    CHECK_EQ_INT(run("import", iu_path("vfr.mp4"), "-o", iu_path("vfr.spcap"), NULL), 0);
    CHECK(stdout_has("the container's presentation times"));
    iu_readback rb;
    if (iu_read_capture(iu_path("vfr.spcap"), &rb) == 0 && rb.frames == 20)
        for (int i = 0; i < 20; i++) { /* the container's millisecond timestamps: within 1 ms */
            double want = (i < 10 ? i : 2 * i - 10) / 30.0;
            CHECK_MSG(fabs((double)rb.frame_ts[i] * 1e-9 - want) < 1e-3, "frame %d at %.6f s, expected %.6f s", i,
                      (double)rb.frame_ts[i] * 1e-9, want);
        }
    else
        CHECK_MSG(0, "expected 20 frames");
    CHECK_EQ_INT(run("import", iu_path("vfr.mp4"), "-o", iu_path("cfr.spcap"), "--fps", "30", "-q", NULL), 0);
    if (iu_read_capture(iu_path("cfr.spcap"), &rb) == 0)
        CHECK_EQ_INT(rb.frame_ts[19], llround(19 * 1e9 / 30));
#else
    SKIP("built without OpenCV (-Dopencv): cannot decode video");
#endif
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: test_import SUNPROBE [vtest]\n");
        return 99;
    }
    sunprobe = argv[1];
    if (access(sunprobe, X_OK) != 0) {
        fprintf(stderr, "%s: not an executable\n", sunprobe);
        return 99;
    }
    if (argc > 2 && strcmp(argv[2], "vtest") == 0) {
        test_vtest();
        return iu_finish();
    }
    if (argc > 2 && strcmp(argv[2], "vfr") == 0) {
        test_vfr();
        return iu_finish();
    }
    iu_make_tmp("import_cli");
    make_inputs();
    test_import_sequence();
    test_bad_input();
    test_export_pngs();
    test_export_yuv();
    test_png_and_video();
    return iu_finish();
}
