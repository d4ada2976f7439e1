/* SPDX-License-Identifier: MIT */
/*
 * sp_import_run in-process: JPEG sequences with IMU, frame times and metadata,
 * ordering and batching of IMU chunks, storage modes, PNG and video inputs (or
 * their "disabled" errors), and every kind of bad input: each must fail with a
 * message naming the file (and line) and leave neither OUT nor OUT.partial.
 */
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "capture/opencv_shim.h"
#include "check.h"
#include "common/jpeg.h"
#include "common/json.h"
#include "export/png.h"
#include "import_util.h"
#include "sp_config.h"
#include "sunprobe/sp_import.h"
#include "sunprobe/sp_meta.h"

enum { N_SEQ = 5, PNG_W = 9, PNG_H = 5 };

/* f_1, f_2, f_3, f_10, f_11: byte order differs from number order, so the natural sort is tested. */
static const int seq_numbers[N_SEQ] = { 1, 2, 3, 10, 11 };
static size_t jpeg_sizes[N_SEQ];
static int imu_counts[4];

static void make_inputs(void)
{
    mkdir(iu_path("jpg"), 0755);
    for (int i = 0; i < N_SEQ; i++) {
        char name[64];
        snprintf(name, sizeof(name), "jpg/f_%d.JPG", seq_numbers[i]);
        jpeg_sizes[i] = iu_write_marked_jpeg(name, i);
    }
    iu_write_text("jpg/notes.txt", "not an image, ignored\n");
    iu_write_text("jpg/.hidden.jpg", "hidden files are ignored\n");
    mkdir(iu_path("jpg/sub.jpg"), 0755); /* a directory with an image name, ignored too */

    /* 100 Hz from -0.05 s to 0.6 s: gyro every row, accel every 2nd (empty cells otherwise), mag every 5th */
    FILE *f = fopen(iu_path("imu.csv"), "w");
    CHECK(f != NULL);
    if (!f)
        return;
    fprintf(f, "# phone log\r\n\"t\", gx, gy, gz, ax, ay, az, mx, my, mz\r\n");
    for (int i = -5; i <= 60; i++) {
        fprintf(f, "%.4f,0.1,%.3f,-0.2", i * 0.01, 0.01 * i);
        imu_counts[1]++;
        fprintf(f, i % 2 == 0 ? ",0.0,0.0,9.81" : ",,,");
        imu_counts[2] += i % 2 == 0;
        fprintf(f, i % 5 == 0 ? ",20,-5,40\r\n" : ", , ,\r\n");
        imu_counts[3] += i % 5 == 0;
        if (i == 30)
            fprintf(f, "\r\n# a comment and a blank line in the middle\r\n");
    }
    fclose(f);
    iu_write_text("meta.json",
                  "{\"kind\": \"selfie\", \"utc_start\": \"2024-06-21T12:00:00Z\",\n"
                  " \"custom\": {\"a\": [1, true, null]},\n"
                  " \"camera\": {\"name\": \"test cam\", \"fx\": 40, \"fy\": 41, \"cx\": 8.5, \"cy\": 4.5,\n"
                  "            \"fps\": 10},\n"
                  " \"imu\": {\"name\": \"fake imu\", \"rate_hz\": 100, \"to_camera\": [1, 0, 0, 0]},\n"
                  " \"location\": {\"latitude\": 48.85, \"longitude\": 2.35}}\n");
}

static void settings(sp_import_settings *s, const char *input, const char *output)
{
    sp_import_default_settings(s);
    s->input = iu_path(input);
    s->output = iu_path(output);
}

static void check_meta(const iu_readback *rb, const char *kind, uint32_t w, uint32_t h, double fps)
{
    sp_capture_meta m;
    sp_capture_meta_init(&m);
    CHECK_EQ_INT(sp_capture_meta_merge(&m, rb->meta_json, strlen(rb->meta_json)), 0);
    CHECK_MSG(strcmp(m.kind, kind) == 0, "kind '%s', expected '%s'", m.kind, kind);
    CHECK(m.width == w && m.height == h);
    CHECK_NEAR(m.fps, fps, 1e-9);
    CHECK(strncmp(m.source, "import:", 7) == 0);
}

static uint64_t progress_calls, progress_last, progress_total;

static void on_progress(void *user, uint64_t done, uint64_t total)
{
    (void)user;
    progress_calls++;
    progress_last = done;
    progress_total = total;
}

static void test_jpeg_sequence(void)
{
    sp_import_settings s;
    sp_import_report rep;
    settings(&s, "jpg", "a.spcap");
    s.fps = 10;
    s.imu_csv = iu_path("imu.csv");
    s.meta_json = iu_path("meta.json");
    s.kind = "static";
    s.imu_batch = 7; /* small batches: several chunks between frames */
    s.progress = on_progress;
    CHECK_EQ_INT(sp_import_run(&s, &rep), 0);
    CHECK_MSG(rep.message[0] == 0, "%s", rep.message);
    CHECK(rep.frames == N_SEQ && rep.frames_copied == N_SEQ && rep.width == FIXTURE_JPEG_W);
    CHECK_EQ_INT(rep.imu_samples, imu_counts[1] + imu_counts[2] + imu_counts[3]);
    CHECK_EQ_INT(rep.last_frame_ns, 400000000);
    CHECK(progress_calls == N_SEQ && progress_last == N_SEQ && progress_total == N_SEQ);
    CHECK(!iu_exists(iu_path("a.spcap.partial")));

    iu_readback rb;
    if (iu_read_capture(iu_path("a.spcap"), &rb))
        return;
    CHECK_EQ_INT(rb.frames, N_SEQ);
    CHECK(rb.format == SP_PIXFMT_MJPEG && rb.width == FIXTURE_JPEG_W && rb.height == FIXTURE_JPEG_H);
    for (int i = 0; i < N_SEQ; i++) {
        CHECK_EQ_INT(rb.frame_ts[i], (int64_t)i * 100000000);
        CHECK_EQ_INT(rb.marker[i], i);                 /* natural name order */
        CHECK_EQ_INT(rb.frame_size[i], jpeg_sizes[i]); /* stored byte-for-byte */
    }
    for (int k = 1; k <= 3; k++)
        CHECK_MSG(rb.imu[k] == imu_counts[k], "sensor %d: %d samples, expected %d", k, rb.imu[k], imu_counts[k]);
    CHECK_EQ_INT(rb.imu_chunks, rep.imu_chunks);
    CHECK(rb.imu_chunks >= (int)(rep.imu_samples / 7));
    CHECK(rb.imu_monotonic && rb.order_ok);
    CHECK_EQ_INT(rb.first_imu_ts, -50000000); /* samples before the first frame are kept */
    CHECK_EQ_INT(rb.last_imu_ts, 600000000);  /* and after the last one */
    CHECK_EQ_INT(rb.meta_chunks, 1);
    check_meta(&rb, "static", FIXTURE_JPEG_W, FIXTURE_JPEG_H, 10);
    sp_capture_meta m;
    sp_capture_meta_init(&m);
    sp_capture_meta_merge(&m, rb.meta_json, strlen(rb.meta_json));
    CHECK(strcmp(m.camera_name, "test cam") == 0 && strcmp(m.imu_name, "fake imu") == 0);
    CHECK_NEAR(m.fy, 41, 0);
    CHECK_NEAR(m.latitude, 48.85, 1e-12);
    CHECK(strcmp(m.utc_start, "2024-06-21T12:00:00Z") == 0);
    sp_json *j = NULL; /* keys the schema does not know pass through untouched */
    CHECK_EQ_INT(sp_json_parse(rb.meta_json, strlen(rb.meta_json), &j, NULL, 0), 0);
    const sp_json *a = sp_json_get(sp_json_get(j, "custom"), "a");
    CHECK(a && a->count == 3 && sp_json_at(a, 1)->type == SP_JSON_BOOL && sp_json_at(a, 2)->type == SP_JSON_NULL);
    sp_json_free(j);

    /* the output exists: refused without overwrite and left alone */
    struct stat before, after;
    stat(iu_path("a.spcap"), &before);
    CHECK_EQ_INT(sp_import_run(&s, &rep), -EEXIST);
    CHECK(strstr(rep.message, "already exists") != NULL);
    stat(iu_path("a.spcap"), &after);
    CHECK(before.st_ino == after.st_ino && before.st_size == after.st_size);

    /* overwrite, fewer frames, IMU offset: every IMU time moves by 0.05 s */
    s.overwrite = 1;
    s.max_frames = 2;
    s.imu_offset_s = 0.05;
    s.meta_json = NULL;
    s.kind = NULL;
    CHECK_EQ_INT(sp_import_run(&s, &rep), 0);
    if (iu_read_capture(iu_path("a.spcap"), &rb) == 0) {
        CHECK_EQ_INT(rb.frames, 2);
        CHECK_EQ_INT(rb.first_imu_ts, 0);
        CHECK_EQ_INT(rb.last_imu_ts, 650000000);
        CHECK(rb.order_ok);
        check_meta(&rb, "", FIXTURE_JPEG_W, FIXTURE_JPEG_H, 10);
    }
}

static void test_pattern_and_frame_times(void)
{
    iu_write_text("times.csv", "frame,t_ns\n0,1000000000\n1,1033000000\n2,1070000000\n3,1100000000\n4,1140000000\n");
    iu_write_text("imu_abs.csv", "t_ns,gx,gy,gz\n990000000,0,0,0\n1050000000,0,0,0\n");
    sp_import_settings s;
    sp_import_report rep;
    settings(&s, "jpg/f_%d.jpg", "t.spcap");
    s.frame_times_csv = iu_path("times.csv");
    s.imu_csv = iu_path("imu_abs.csv");
    CHECK_EQ_INT(sp_import_run(&s, &rep), SP_ENODATA); /* the files are .JPG: nothing matches */
    CHECK(strstr(rep.message, "f_%d.jpg: no file matches") != NULL);
    s.input = iu_path("jpg/f_%d.JPG");
    CHECK_EQ_INT(sp_import_run(&s, &rep), 0);
    iu_readback rb;
    if (iu_read_capture(iu_path("t.spcap"), &rb))
        return;
    CHECK_EQ_INT(rb.frames, 3); /* the pattern starts at 1 and stops at the first gap (f_4) */
    static const int64_t want[3] = { 0, 33000000, 70000000 };
    for (int i = 0; i < 3; i++)
        CHECK_EQ_INT(rb.frame_ts[i], want[i]);
    CHECK(rb.imu[1] == 2 && rb.first_imu_ts == -10000000 && rb.last_imu_ts == 50000000); /* frame-times clock */
    CHECK(rb.order_ok);
    check_meta(&rb, "", FIXTURE_JPEG_W, FIXTURE_JPEG_H, 4.0 / 0.14); /* 4 intervals over 0.14 s */

    /* one image file; fps from the metadata; "%%" is a literal percent sign */
    iu_write_text("fps.json", "{\"camera\": {\"fps\": 24}}");
    settings(&s, "jpg/f_2.JPG", "one.spcap");
    s.meta_json = iu_path("fps.json");
    CHECK_EQ_INT(sp_import_run(&s, &rep), 0);
    CHECK(rep.frames == 1 && rep.fps == 24);
    iu_write_marked_jpeg("pct%_1.jpg", 7);
    settings(&s, "pct%%_%d.jpg", "pct.spcap");
    s.fps = 1;
    CHECK_EQ_INT(sp_import_run(&s, &rep), 0);
    CHECK_EQ_INT(rep.frames, 1);
}

/* --store rgb needs JPEG decoding; without libjpeg it fails naming -Djpeg. */
static void test_store_rgb_from_jpeg(void)
{
    sp_import_settings s;
    sp_import_report rep;
    settings(&s, "jpg", "rgb.spcap");
    s.fps = 30;
    s.store = SP_IMPORT_STORE_RGB;
    int rc = sp_import_run(&s, &rep);
    if (!sp_jpeg_available()) {
        CHECK_EQ_INT(rc, SP_EDISABLED);
        CHECK(strstr(rep.message, "-Djpeg") != NULL);
        CHECK(!iu_exists(s.output) && !iu_exists(iu_path("rgb.spcap.partial")));
        return;
    }
    CHECK_EQ_INT(rc, 0);
    CHECK_EQ_INT(rep.frames_copied, 0);
    iu_readback rb;
    if (iu_read_capture(s.output, &rb))
        return;
    CHECK(rb.frames == N_SEQ && rb.format == SP_PIXFMT_RGB24);
    /* the fixture: left half (200, 90, 40), right half (40, 90, 200), within JPEG error */
    static const uint8_t left[3] = { 200, 90, 40 }, right[3] = { 40, 90, 200 };
    for (int c = 0; c < 3; c++) {
        CHECK_MSG(abs(rb.pixel0[0][c] - left[c]) <= 24, "left %d: %d", c, rb.pixel0[0][c]);
        CHECK_MSG(abs(rb.pixel_last[0][c] - right[c]) <= 24, "right %d: %d", c, rb.pixel_last[0][c]);
    }
}

static void test_png(void)
{
    mkdir(iu_path("png"), 0755);
    for (int i = 0; i < 3; i++) {
        char name[32];
        snprintf(name, sizeof(name), "png/p%d.png", i);
        uint8_t *img = iu_solid_image(i, PNG_W, PNG_H);
        CHECK_EQ_INT(sp_png_write(iu_path(name), img, PNG_W, PNG_H, PNG_W * 3, 3), 0);
        free(img);
    }
    sp_import_settings s;
    sp_import_report rep;
    settings(&s, "png", "png.spcap");
    s.fps = 5;
    s.store = SP_IMPORT_STORE_RGB;
    int rc = sp_import_run(&s, &rep);
#if HAVE_OPENCV
    CHECK_EQ_INT(rc, 0);
    iu_readback rb;
    if (iu_read_capture(s.output, &rb) == 0) {
        CHECK(rb.frames == 3 && rb.format == SP_PIXFMT_RGB24 && rb.width == PNG_W && rb.height == PNG_H);
        for (int i = 0; i < 3; i++) {
            uint8_t *img = iu_solid_image(i, PNG_W, PNG_H);
            CHECK(memcmp(rb.pixel0[i], img, 3) == 0 && memcmp(rb.pixel_last[i], img + 3, 3) == 0); /* lossless */
            free(img);
        }
    }
    settings(&s, "png", "pngj.spcap");
    s.fps = 5;
    s.quality = 60;
    rc = sp_import_run(&s, &rep);
    CHECK_EQ_INT(rc, sp_jpeg_available() ? 0 : SP_EDISABLED);
    if (rc == 0 && iu_read_capture(s.output, &rb) == 0)
        CHECK(rb.frames == 3 && rb.format == SP_PIXFMT_MJPEG);
#else
    CHECK_EQ_INT(rc, SP_EDISABLED);
    CHECK(strstr(rep.message, "-Dopencv") != NULL && strstr(rep.message, "p0.png") != NULL);
    CHECK(!iu_exists(s.output) && !iu_exists(iu_path("png.spcap.partial")));
#endif
}

static void test_video(void)
{
    iu_write_text("garbage.avi", "RIFF, but not a video");
    sp_import_settings s;
    sp_import_report rep;
    settings(&s, "garbage.avi", "g.spcap");
#if HAVE_OPENCV
    CHECK_EQ_INT(sp_import_run(&s, &rep), SP_EFORMAT);
    CHECK(strstr(rep.message, "garbage.avi") != NULL);
    CHECK(!iu_exists(s.output) && !iu_exists(iu_path("g.spcap.partial")));
    sp_cv_video_writer *w = NULL;
    CHECK_EQ_INT(sp_cv_video_writer_open(&w, iu_path("tiny.avi"), 32, 24, 5.0), 0);
    for (int i = 0; i < 6 && w; i++) {
        uint8_t *img = iu_solid_image(i, 32, 24);
        CHECK_EQ_INT(sp_cv_video_write(w, img, 32 * 3), 0);
        free(img);
    }
    CHECK_EQ_INT(sp_cv_video_writer_close(&w), 0);
    settings(&s, "tiny.avi", "v.spcap");
    s.store = sp_jpeg_available() ? SP_IMPORT_STORE_JPEG : SP_IMPORT_STORE_RGB;
    s.max_frames = 5;
    CHECK_EQ_INT(sp_import_run(&s, &rep), 0);
    iu_readback rb;
    if (iu_read_capture(s.output, &rb) == 0) {
        CHECK(rb.frames == 5 && rb.width == 32 && rb.height == 24);
        CHECK_EQ_INT(rb.frame_ts[4], 800000000); /* the video's own 5 fps */
        check_meta(&rb, "", 32, 24, 5.0);
    }
#else
    CHECK_EQ_INT(sp_import_run(&s, &rep), SP_EDISABLED);
    CHECK(strstr(rep.message, "-Dopencv") != NULL);
    CHECK(!iu_exists(s.output) && !iu_exists(iu_path("g.spcap.partial")));
#endif
}

/* Runs a failing import: the code, a message containing `needle`, and no output left. */
static void expect_failure(sp_import_settings *s, int code, const char *needle)
{
    sp_import_report rep;
    char partial[400];
    snprintf(partial, sizeof(partial), "%s.partial", s->output ? s->output : "");
    int rc = sp_import_run(s, &rep);
    CHECK_MSG(rc == code, "returned %d (%s), expected %d; message: %s", rc, sp_strerror(rc), code, rep.message);
    CHECK_MSG(strstr(rep.message, needle) != NULL, "message '%s' lacks '%s'", rep.message, needle);
    if (s->output)
        CHECK(!iu_exists(s->output) && !iu_exists(partial));
}

static void test_bad_imu(void)
{
    static const struct {
        const char *name, *text, *needle;
    } cases[] = {
        { "nan.csv", "t,gx,gy,gz\n0,0,0,0\n0.01,0,nan,0\n", "nan.csv:3: column 'gy': 'nan' is not a finite" },
        { "inf.csv", "t,ax,ay,az\n0,0,0,9.8\n# c\n0.02,-Inf,0,0\n", "inf.csv:4: column 'ax'" },
        { "huge.csv", "t,ax,ay,az\n0,0,0,1e300\n", "huge.csv:2:" },
        { "junk.csv", "t,ax,ay,az\n0,0,0,9.8x\n", "junk.csv:2: column 'az'" },
        { "tnan.csv", "t,gx,gy,gz\nnan,0,0,0\n", "tnan.csv:2: column 't'" },
        { "back.csv", "t_ns,gx,gy,gz\n100,0,0,0\n300,0,0,0\n200,0,0,0\n", "back.csv:4: time goes backwards" },
        /* the bad row comes after frames were written: the partial capture must still go */
        { "late.csv", "t,gx,gy,gz\n0,0,0,0\n0.35,0,0,0\n0.2,0,0,0\n", "late.csv:4: time goes backwards" },
        { "dup.csv", "t,gx,gy,gz\n0.5,0,0,0\n0.5,1,1,1\n", "dup.csv:3: second gyro sample" },
        { "cols.csv", "t,gx,gy\n0,0,0\n", "missing column 'gz'" },
        { "none.csv", "t,temp\n0,20\n", "no sensor columns" },
        { "notime.csv", "gx,gy,gz\n0,0,0\n", "needs a 't'" },
        { "twotimes.csv", "t,t_ns,gx,gy,gz\n0,0,0,0,0\n", "both 't' and 't_ns'" },
        { "partial.csv", "t,gx,gy,gz\n0,1,,3\n", "partial.csv:2: gx,gy,gz are partly empty" },
        { "nodata.csv", "t,gx,gy,gz\n0,,,\n", "nodata.csv:2: row has a time but no sensor values" },
        { "fields.csv", "t,gx,gy,gz\n0,1,2\n", "fields.csv:2: 3 fields" },
        { "empty.csv", "# only a comment\n", "no header row" },
        { "dupcol.csv", "t,gx,gy,gz,gx\n", "twice" },
        { "range.csv", "t,gx,gy,gz\n1e12,0,0,0\n", "out of range" },
    };
    for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
        iu_write_text(cases[i].name, cases[i].text);
        sp_import_settings s;
        settings(&s, "jpg", "bad.spcap");
        s.fps = 10;
        s.imu_csv = iu_path(cases[i].name);
        /* no header at all is "no data"; everything else is malformed content */
        expect_failure(&s, strcmp(cases[i].name, "empty.csv") == 0 ? SP_ENODATA : SP_ECORRUPT, cases[i].needle);
    }
    sp_import_settings s;
    settings(&s, "jpg", "bad.spcap");
    s.fps = 10;
    s.imu_csv = iu_path("missing.csv");
    expect_failure(&s, -ENOENT, "missing.csv");
}

static void test_bad_meta(void)
{
    static const struct {
        const char *name, *text, *needle;
    } cases[] = {
        { "m_type.json", "{\"camera\": {\"fx\": \"forty\"}}", "camera.fx must be a number, not a string" },
        { "m_size.json", "{\"camera\": {\"width\": 1920, \"height\": 1080}}", "camera is 1920x1080" },
        { "m_syntax.json", "{\"kind\": \"selfie\",}", "m_syntax.json: JSON" },
        { "m_kind.json", "{\"kind\": \"panorama\"}", "m_kind.json" },
        { "m_kind2.json", "{\"kind\": 3}", "kind must be a string" },
        { "m_range.json", "{\"camera\": {\"fx\": -5}}", "m_range.json: a value is out of range" },
        { "m_array.json", "[1, 2]", "one JSON object" },
        { "m_quat.json", "{\"imu\": {\"to_camera\": [1, 0, 0]}}", "imu.to_camera must be an array of 4" },
        { "m_quat2.json", "{\"imu\": {\"to_camera\": [2, 0, 0, 0]}}", "m_quat2.json" },
        { "m_loc.json", "{\"location\": \"Paris\"}", "location must be an object" },
    };
    for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
        iu_write_text(cases[i].name, cases[i].text);
        sp_import_settings s;
        settings(&s, "jpg", "bad.spcap");
        s.fps = 10;
        s.meta_json = iu_path(cases[i].name);
        expect_failure(&s, SP_ECORRUPT, cases[i].needle);
    }
}

static void test_bad_input(void)
{
    sp_import_settings s;
    settings(&s, "no_such_dir", "bad.spcap");
    s.fps = 10;
    expect_failure(&s, -ENOENT, "no_such_dir");
    mkdir(iu_path("empty_dir"), 0755);
    settings(&s, "empty_dir", "bad.spcap");
    s.fps = 10;
    expect_failure(&s, SP_ENODATA, "no .jpg");
    settings(&s, "jpg", "bad.spcap");
    expect_failure(&s, -EINVAL, "--fps"); /* a sequence needs a rate */

    iu_write_text("ft_back.csv", "t\n0\n0.1\n0.1\n");
    settings(&s, "jpg", "bad.spcap");
    s.frame_times_csv = iu_path("ft_back.csv");
    expect_failure(&s, SP_ECORRUPT, "ft_back.csv:4:");
    iu_write_text("ft_short.csv", "t\n0\n0.1\n");
    s.frame_times_csv = iu_path("ft_short.csv");
    expect_failure(&s, SP_ECORRUPT, "has 2 frame times");
    iu_write_text("ft_empty.csv", "t\n");
    s.frame_times_csv = iu_path("ft_empty.csv");
    expect_failure(&s, SP_ENODATA, "ft_empty.csv");

    /* an unreadable image after a good one: frames were written, still no output */
    mkdir(iu_path("broken"), 0755);
    iu_write_marked_jpeg("broken/a_1.jpg", 0);
    iu_write_text("broken/a_2.jpg", "this is not a JPEG");
    settings(&s, "broken", "bad.spcap");
    s.fps = 10;
    expect_failure(&s, SP_EFORMAT, "a_2.jpg: neither a JPEG nor a PNG");
    iu_write_text("broken/a_2.jpg", "\xff\xd8\xff\xe0"); /* JPEG magic, then nothing */
    expect_failure(&s, SP_EFORMAT, "a_2.jpg: not a valid JPEG");
    iu_write_text("broken/a_2.jpg", "");
    expect_failure(&s, SP_EFORMAT, "a_2.jpg: empty file");
    /* a frame of another size */
    FILE *f = fopen(iu_path("broken/a_2.jpg"), "wb");
    if (f) {
        uint8_t copy[sizeof(fixture_jpeg)];
        memcpy(copy, fixture_jpeg, sizeof(copy));
        for (size_t i = 2; i + 9 < sizeof(copy); i++)
            if (copy[i] == 0xFF && copy[i + 1] == 0xC0) {
                copy[i + 8] = 17; /* width 16 -> 17 in the SOF0 segment */
                break;
            }
        fwrite(copy, 1, sizeof(copy), f);
        fclose(f);
    }
    expect_failure(&s, SP_EFORMAT, "a_2.jpg: 17x8, but the first frame is 16x8");
    /* cut short in its scan: the header parses, but export-video and fit could not decode it later */
    if ((f = fopen(iu_path("broken/a_2.jpg"), "wb"))) {
        fwrite(fixture_jpeg, 1, sizeof(fixture_jpeg) - 8, f);
        fclose(f);
    }
    expect_failure(&s, sp_jpeg_available() ? SP_ECORRUPT : SP_ETRUNCATED, "truncated JPEG");

    /* interrupted: -ECANCELED and nothing left */
    static volatile sig_atomic_t stop = 1;
    settings(&s, "jpg", "bad.spcap");
    s.fps = 10;
    s.cancel = &stop;
    expect_failure(&s, -ECANCELED, "interrupted");

    /* settings */
    settings(&s, "jpg", "bad.spcap");
    s.fps = NAN;
    expect_failure(&s, -EINVAL, "frame rate");
    s.fps = 10;
    s.quality = 0;
    expect_failure(&s, -EINVAL, "quality");
    s.quality = 92;
    s.imu_offset_s = INFINITY;
    expect_failure(&s, -EINVAL, "IMU offset");
    s.imu_offset_s = 0;
    s.kind = "panorama";
    expect_failure(&s, -EINVAL, "panorama");
    s.kind = NULL;
    s.store = (enum sp_import_store)7;
    expect_failure(&s, -EINVAL, "storage");
    s.store = SP_IMPORT_STORE_JPEG;
    s.imu_batch = 0;
    expect_failure(&s, -EINVAL, "batch");
    s.output = NULL;
    expect_failure(&s, -EINVAL, "output");
    settings(&s, "jpg/f_%s.jpg", "bad.spcap");
    s.fps = 1;
    expect_failure(&s, -EINVAL, "one %d");
    settings(&s, "jpg/f_%d_%d.jpg", "bad.spcap");
    s.fps = 1;
    expect_failure(&s, -EINVAL, "one %d");
    sp_import_report rep;
    CHECK_EQ_INT(sp_import_run(NULL, &rep), -EINVAL);
    CHECK_EQ_INT(sp_import_run(NULL, NULL), -EINVAL);
}

int main(void)
{
    iu_make_tmp("import_unit");
    make_inputs();
    test_jpeg_sequence();
    test_pattern_and_frame_times();
    test_store_rgb_from_jpeg();
    test_png();
    test_video();
    test_bad_imu();
    test_bad_meta();
    test_bad_input();
    return iu_finish();
}
