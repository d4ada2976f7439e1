/* SPDX-License-Identifier: MIT */
/*
 * Phone and camera IMU logs through sp_import_run: the samples in tests/data (Sensor Logger directory
 * and .zip, OpenCamera-Sensors, Gyroflow .gcsv) land with the right axes, units and clock, and every
 * bad log (NaN or duplicate rows, a missing scale, a clock that never meets the frames, a zip without
 * video) fails naming file and line with nothing written. argv[1]: the tests/data directory.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "capture/opencv_shim.h"
#include "check.h"
#include "common/jpeg.h"
#include "import_util.h"
#include "sp_config.h"
#include "sunprobe/sp_import.h"
#include "sunprobe/sp_math.h"
#include "sunprobe/sp_meta.h"
#if HAVE_LIBZIP
#include <zip.h>
#endif

static const char *data_dir;

static const char *data(const char *name)
{
    static char buf[8][1024];
    static unsigned next;
    char *p = buf[next++ % 8];
    snprintf(p, sizeof(buf[0]), "%s/%s", data_dir, name);
    return p;
}

enum { MAX_SAMPLES = 4096 };
static sp_imu_sample samples[MAX_SAMPLES];
static int nsamples;

/* Every IMU sample of a capture, in file order. */
static void read_samples(const char *path)
{
    nsamples = 0;
    sp_capture_reader *r = NULL;
    CHECK_EQ_INT(sp_capture_reader_open(&r, path, NULL), 0);
    if (!r)
        return;
    sp_chunk ch;
    while (sp_capture_reader_next(r, &ch) == 0)
        for (int64_t i = 0; ch.type == SP_CHUNK_IMU && i < sp_chunk_imu_count(&ch) && nsamples < MAX_SAMPLES; i++)
            CHECK_EQ_INT(sp_chunk_imu_get(&ch, (size_t)i, &samples[nsamples++]), 0);
    sp_capture_reader_close(&r);
}

static const sp_imu_sample *first_of(uint32_t sensor)
{
    for (int i = 0; i < nsamples; i++)
        if (samples[i].sensor == sensor)
            return &samples[i];
    return NULL;
}

static int count_of(uint32_t sensor)
{
    int n = 0;
    for (int i = 0; i < nsamples; i++)
        n += samples[i].sensor == sensor;
    return n;
}

static void settings(sp_import_settings *s, const char *imu, const char *out)
{
    sp_import_default_settings(s);
    s->input = iu_path("jpg");
    s->output = iu_path(out);
    s->fps = 10;
    s->imu_csv = imu;
    s->overwrite = 1;
}

static int run_ok(sp_import_settings *s, sp_import_report *rep)
{
    int rc = sp_import_run(s, rep);
    CHECK_MSG(rc == 0, "%s: %s", s->imu_csv ? s->imu_csv : s->input, rep->message);
    return rc == 0;
}

static void expect_failure(sp_import_settings *s, int code, const char *needle)
{
    sp_import_report rep;
    char partial[400];
    snprintf(partial, sizeof(partial), "%s.partial", s->output);
    remove(s->output);
    int rc = sp_import_run(s, &rep);
    CHECK_MSG(rc == code, "returned %d (%s), expected %d; message: %s", rc, sp_strerror(rc), code, rep.message);
    CHECK_MSG(strstr(rep.message, needle) != NULL, "message '%s' lacks '%s'", rep.message, needle);
    CHECK(!iu_exists(s->output) && !iu_exists(partial));
}

/* The Sensor Logger sample: columns z,y,x, epoch ns mapped through time - seconds_elapsed, gravity added. */
static void check_sensor_logger_capture(const char *path)
{
    read_samples(path);
    CHECK_EQ_INT(count_of(SP_IMU_GYRO), 53);
    CHECK_EQ_INT(count_of(SP_IMU_ACCEL), 25);
    CHECK_EQ_INT(count_of(SP_IMU_MAG), 10);
    const sp_imu_sample *g = first_of(SP_IMU_GYRO), *a = first_of(SP_IMU_ACCEL), *m = first_of(SP_IMU_MAG);
    if (!g || !a || !m)
        return;
    CHECK_EQ_INT(g->timestamp_ns, -20000000); /* seconds_elapsed -0.02 */
    CHECK_NEAR(g->v[0], 0.1, 1e-6);
    CHECK_NEAR(g->v[1], 0.2, 1e-6);
    CHECK_NEAR(g->v[2], 0.28, 1e-6);
    CHECK_EQ_INT(a->timestamp_ns, 1000000);
    CHECK_NEAR(a->v[0], 0.11, 1e-6); /* user acceleration + gravity */
    CHECK_NEAR(a->v[1], 9.72, 1e-5);
    CHECK_NEAR(a->v[2], 0.53, 1e-6);
    CHECK_NEAR(m->v[0], 20.0, 1e-6);
    CHECK_NEAR(m->v[2], 40.5, 1e-6);
    for (int i = 1; i < nsamples; i++)
        CHECK(samples[i].timestamp_ns >= samples[i - 1].timestamp_ns);
}

static void test_sensor_logger(void)
{
    sp_import_settings s;
    sp_import_report rep;
    settings(&s, data("sensor_logger"), "sl.spcap");
    if (run_ok(&s, &rep)) {
        CHECK(strstr(rep.imu_clock, "Sensor Logger") && strstr(rep.imu_clock, "seconds_elapsed"));
        check_sensor_logger_capture(s.output);
    }
    /* one of its CSVs names the export too; --imu-format says the same */
    settings(&s, data("sensor_logger/Gyroscope.csv"), "sl1.spcap");
    s.imu_format = SP_IMPORT_IMU_SENSOR_LOGGER;
    if (run_ok(&s, &rep))
        check_sensor_logger_capture(s.output);
    /* the same export zipped (without a video: fine as --imu, refused as INPUT) */
    settings(&s, data("sensor_logger_novideo.zip"), "slz.spcap");
#if HAVE_LIBZIP
    if (run_ok(&s, &rep))
        check_sensor_logger_capture(s.output);
    settings(&s, NULL, "slz2.spcap");
    s.input = data("sensor_logger_novideo.zip");
    expect_failure(&s, SP_ENODATA, "sensor_logger_novideo.zip: the export holds no video");
#else
    expect_failure(&s, SP_EDISABLED, "-Dlibzip=enabled");
#endif
    /* its clock shifted away from the frames */
    settings(&s, data("sensor_logger"), "late.spcap");
    s.imu_offset_s = 100;
    expect_failure(&s, SP_ECORRUPT, "never overlap");
}

static void write_sl_copy(const char *dir, const char *gyro)
{
    mkdir(iu_path(dir), 0755);
    char name[48];
    snprintf(name, sizeof(name), "%.20s/Gyroscope.csv", dir);
    iu_write_text(name, gyro);
}

static void test_sensor_logger_bad(void)
{
    sp_import_settings s;
    write_sl_copy("sl_nan", "time,seconds_elapsed,z,y,x\n1000000000,0,0,0,0\n1010000000,0.01,0,nan,0\n");
    settings(&s, iu_path("sl_nan"), "bad.spcap");
    expect_failure(&s, SP_ECORRUPT, "sl_nan/Gyroscope.csv:3: column 'y': 'nan' is not a finite number");
    write_sl_copy("sl_dup", "time,seconds_elapsed,z,y,x\n1000000000,0,0,0,0\n1000000000,0,0,0,0\n");
    settings(&s, iu_path("sl_dup"), "bad.spcap");
    expect_failure(&s, SP_ECORRUPT, "sl_dup/Gyroscope.csv:3: duplicate row");
    write_sl_copy("sl_cols", "time,seconds_elapsed,a,b,c\n1000000000,0,0,0,0\n");
    settings(&s, iu_path("sl_cols"), "bad.spcap");
    expect_failure(&s, SP_ECORRUPT, "sl_cols/Gyroscope.csv:1: a Sensor Logger CSV needs the columns");
    mkdir(iu_path("sl_none"), 0755);
    iu_write_text("sl_none/readme.txt", "nothing here\n");
    settings(&s, iu_path("sl_none"), "bad.spcap");
    s.imu_format = SP_IMPORT_IMU_SENSOR_LOGGER;
    expect_failure(&s, SP_ENODATA, "no Gyroscope.csv");
    s.imu_format = SP_IMPORT_IMU_AUTO;
    expect_failure(&s, SP_ECORRUPT, "neither Sensor Logger CSVs");
}

/* Location.csv's best fix and the recording's start in UTC reach the META chunk; the user's metadata wins. */
static void check_sensor_logger_place(const char *path, double lat, double lon, double alt, const char *utc)
{
    iu_readback rb;
    if (iu_read_capture(path, &rb) != 0) {
        CHECK(0);
        return;
    }
    sp_capture_meta m;
    sp_capture_meta_init(&m);
    CHECK_EQ_INT(sp_capture_meta_merge(&m, rb.meta_json, strlen(rb.meta_json)), 0);
    CHECK_MSG(strcmp(m.utc_start, utc) == 0, "utc_start '%s', expected '%s'", m.utc_start, utc);
    CHECK_NEAR(m.latitude, lat, 1e-9);
    CHECK_NEAR(m.longitude, lon, 1e-9);
    if (isnan(alt))
        CHECK(isnan(m.altitude_m));
    else
        CHECK_NEAR(m.altitude_m, alt, 1e-9);
}

static void test_sensor_logger_place(void)
{
    sp_import_settings s;
    sp_import_report rep;
    settings(&s, data("sensor_logger"), "slp.spcap");
    /* the 0,0 row (no fix yet) and iOS's accuracy -1 (invalid) are passed over; 4.7 m beats 15.2 m */
    if (run_ok(&s, &rep))
        check_sensor_logger_place(s.output, 48.8567, 2.3523, 36.0, "2024-06-21T12:00:00.000Z");
    iu_write_text("slp_meta.json", "{\"utc_start\": \"2024-06-21T14:00:00+02:00\", "
                                   "\"location\": {\"latitude\": 10, \"longitude\": 20}}");
    s.meta_json = iu_path("slp_meta.json");
    if (run_ok(&s, &rep))
        check_sensor_logger_place(s.output, 10, 20, NAN, "2024-06-21T14:00:00+02:00");
    /* a fix outside the globe is refused with its line; a Location.csv without coordinates too */
    static const char *const gyro = "time,seconds_elapsed,z,y,x\n1718971200000000000,0,0,0,0\n"
                                    "1718971200010000000,0.01,0,0,0\n";
    write_sl_copy("sl_lat", gyro);
    iu_write_text("sl_lat/Location.csv", "time,seconds_elapsed,altitude,longitude,latitude\n"
                                         "1718971200000000000,0,1,2.35,48.85\n1718971200500000000,0.5,1,2.35,95\n");
    settings(&s, iu_path("sl_lat"), "bad.spcap");
    expect_failure(&s, SP_ECORRUPT, "sl_lat/Location.csv:3: latitude 95, longitude 2.35: outside");
    write_sl_copy("sl_loccols", gyro);
    iu_write_text("sl_loccols/Location.csv", "time,seconds_elapsed,altitude\n1718971200000000000,0,1\n");
    settings(&s, iu_path("sl_loccols"), "bad.spcap");
    expect_failure(&s, SP_ECORRUPT, "sl_loccols/Location.csv:1: a Sensor Logger Location.csv needs the columns");
}

static void test_opencamera(void)
{
    static const int64_t frames[5] = { 0, 33366000, 66733000, 116733000, 150100000 };
    sp_import_settings s;
    sp_import_report rep;
    settings(&s, data("opencamera/VID_20240621_120000_gyro.csv"), "oc.spcap");
    s.fps = 0; /* the log's frame times give both times and rate */
    if (!run_ok(&s, &rep))
        return;
    iu_readback rb;
    if (iu_read_capture(s.output, &rb) == 0)
        for (int i = 0; i < 5; i++)
            CHECK_EQ_INT(rb.frame_ts[i], frames[i]);
    CHECK_NEAR(rep.fps, 4.0 / 0.1501, 1e-6);
    read_samples(s.output);
    CHECK_EQ_INT(count_of(SP_IMU_GYRO), 105);
    CHECK_EQ_INT(count_of(SP_IMU_ACCEL), 50);
    const sp_imu_sample *g = first_of(SP_IMU_GYRO), *a = first_of(SP_IMU_ACCEL);
    if (g && a) {
        CHECK_EQ_INT(g->timestamp_ns, -20000000);
        CHECK_NEAR(g->v[2], -0.008, 1e-7);
        CHECK_EQ_INT(a->timestamp_ns, 1000000);
        CHECK_NEAR(a->v[1], 9.79, 1e-5);
    }
    /* the directory finds the same files */
    settings(&s, data("opencamera"), "oc2.spcap");
    s.fps = 0;
    CHECK(run_ok(&s, &rep) && rep.frames == 5);
    iu_write_text("short_gyro.csv", "0.1,0.2,0.3,1000\n0.1,0.2,1000\n");
    settings(&s, iu_path("short_gyro.csv"), "bad.spcap");
    expect_failure(&s, SP_ECORRUPT, "short_gyro.csv:2: 3 fields, but the first row has 4");
    iu_write_text("dup_gyro.csv", "0.1,0.2,0.3,1000\n0.1,0.2,0.3,1000\n");
    settings(&s, iu_path("dup_gyro.csv"), "bad.spcap");
    expect_failure(&s, SP_ECORRUPT, "dup_gyro.csv:2: duplicate row");
}

static void test_gcsv(void)
{
    sp_import_settings s;
    sp_import_report rep;
    settings(&s, data("gyroflow/sample.gcsv"), "g.spcap");
    if (run_ok(&s, &rep)) {
        read_samples(s.output);
        CHECK_EQ_INT(count_of(SP_IMU_GYRO), 101);
        CHECK_EQ_INT(count_of(SP_IMU_ACCEL), 101);
        const sp_imu_sample *g = first_of(SP_IMU_GYRO), *a = first_of(SP_IMU_ACCEL);
        if (g && a) {
            CHECK_EQ_INT(g->timestamp_ns, 0);
            CHECK_NEAR(g->v[0], 100 * 0.00122173047, 1e-7);
            CHECK_NEAR(g->v[1], -50 * 0.00122173047, 1e-7);
            CHECK_NEAR(a->v[1], 9.80665, 1e-5); /* 2048 x 1/2048 g */
        }
        CHECK_EQ_INT(samples[nsamples - 1].timestamp_ns, 500000000);
    }
    static const struct {
        const char *name, *text, *needle;
    } bad[] = {
        { "notscale.gcsv", "GYROFLOW IMU LOG\nversion,1.3\ngscale,0.001\nt,gx,gy,gz\n0,1,2,3\n",
          "notscale.gcsv:4: the header has no tscale, needed to read t" },
        { "nogscale.gcsv", "GYROFLOW IMU LOG\ntscale,0.001\nt,gx,gy,gz\n0,1,2,3\n",
          "nogscale.gcsv:3: the header has no gscale" },
        { "noascale.gcsv", "GYROFLOW IMU LOG\ntscale,0.001\ngscale,0.001\nt,gx,gy,gz,ax,ay,az\n0,1,2,3,4,5,6\n",
          "noascale.gcsv:4: the header has no ascale" },
        { "zero.gcsv", "GYROFLOW IMU LOG\ntscale,0\n", "zero.gcsv:2: tscale must be a positive number" },
        { "nan.gcsv", "GYROFLOW IMU LOG\ntscale,0.001\ngscale,0.001\nt,gx,gy,gz\n0,1,2,3\n1,nan,2,3\n",
          "nan.gcsv:6: column 'gx'" },
        { "dup.gcsv", "GYROFLOW IMU LOG\ntscale,0.001\ngscale,0.001\nt,gx,gy,gz\n0,1,2,3\n0,1,2,3\n",
          "dup.gcsv:6: duplicate row" },
        { "nocols.gcsv", "GYROFLOW IMU LOG\ntscale,0.001\n", "nocols.gcsv:2: the header ends" },
    };
    for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
        iu_write_text(bad[i].name, bad[i].text);
        settings(&s, iu_path(bad[i].name), "bad.spcap");
        expect_failure(&s, SP_ECORRUPT, bad[i].needle);
    }
    /* forcing a format the file is not */
    settings(&s, data("sensor_logger/Gyroscope.csv"), "bad.spcap");
    s.imu_format = SP_IMPORT_IMU_GCSV;
    expect_failure(&s, SP_ECORRUPT, "Gyroscope.csv:1: a .gcsv starts with 'GYROFLOW IMU LOG'");
}

#if HAVE_LIBZIP && HAVE_OPENCV
/* A Sensor Logger zip as a phone writes it: CSVs at the top, Camera/<epoch ms>.mp4. */
static int make_export_zip(const char *zip_path)
{
    sp_cv_video_writer *w = NULL;
    if (sp_cv_video_writer_open(&w, iu_path("1718971200000.mp4"), 16, 16, 10) != 0)
        return 0;
    for (int i = 0; i < 5; i++) {
        uint8_t *img = iu_solid_image(i, 16, 16);
        sp_cv_video_write(w, img, 16 * 3);
        free(img);
    }
    if (sp_cv_video_writer_close(&w) != 0)
        return 0;
    int err = 0;
    zip_t *z = zip_open(zip_path, ZIP_CREATE | ZIP_TRUNCATE, &err);
    CHECK(z != NULL);
    if (!z)
        return 0;
    static const char *const csvs[] = { "Gyroscope.csv", "Accelerometer.csv", "Gravity.csv", "Magnetometer.csv" };
    for (int i = 0; i < 4; i++) {
        char src[1024];
        snprintf(src, sizeof(src), "sensor_logger/%s", csvs[i]);
        CHECK(zip_file_add(z, csvs[i], zip_source_file(z, data(src), 0, 0), 0) >= 0);
    }
    CHECK(zip_file_add(z, "Camera/1718971200000.mp4", zip_source_file(z, iu_path("1718971200000.mp4"), 0, 0), 0) >= 0);
    return zip_close(z) == 0;
}

static void test_export_zip(void)
{
    if (!make_export_zip(iu_path("export.zip"))) {
        printf("skipping the zip with video: OpenCV cannot write mp4 here\n");
        return;
    }
    sp_import_settings s;
    sp_import_report rep;
    settings(&s, NULL, "export.spcap");
    s.input = iu_path("export.zip");
    s.fps = 0;
    if (run_ok(&s, &rep)) {
        CHECK_EQ_INT(rep.frames, 5);
        CHECK(strstr(rep.imu_clock, "file name") != NULL);
        check_sensor_logger_capture(s.output); /* the file name's epoch is the sample's session start */
    }
    char cmd[600];
    snprintf(cmd, sizeof(cmd), "ls -a '%s' | grep -q sp-import-video", iu_tmp);
    CHECK_MSG(system(cmd) != 0, "the unpacked video was left behind");
    settings(&s, data("sensor_logger"), "export2.spcap");
    s.input = iu_path("export.zip");
    expect_failure(&s, -EINVAL, "drop --imu");
}
#endif

static void check_axis(enum sp_import_to_camera p, sp_vec3 imu, sp_vec3 cam)
{
    double q[4];
    CHECK_EQ_INT(sp_import_to_camera_preset(p, q), 0);
    sp_vec3 r = sp_quat_rotate((sp_quat){ q[0], q[1], q[2], q[3] }, imu);
    CHECK_MSG(fabs(r.x - cam.x) + fabs(r.y - cam.y) + fabs(r.z - cam.z) < 1e-12,
              "preset %d: (%g %g %g) -> (%g %g %g), expected (%g %g %g)", (int)p, imu.x, imu.y, imu.z, r.x, r.y, r.z,
              cam.x, cam.y, cam.z);
}

/* Phone axes: x right, y up, z out of the screen (towards the user); camera: x right, y down, z forward. */
static void test_to_camera(void)
{
    const sp_vec3 up = { 0, 1, 0 }, screen_right = { 1, 0, 0 }, to_user = { 0, 0, 1 };
    for (int p = SP_IMPORT_TO_CAMERA_IDENTITY; p <= SP_IMPORT_TO_CAMERA_IOS_BACK; p++) {
        if (p == SP_IMPORT_TO_CAMERA_IDENTITY)
            continue;
        check_axis((enum sp_import_to_camera)p, up, (sp_vec3){ 0, -1, 0 }); /* upright portrait frames */
    }
    /* a back camera looks away from the user and sees the screen's right on the image's right */
    check_axis(SP_IMPORT_TO_CAMERA_ANDROID_BACK, to_user, (sp_vec3){ 0, 0, -1 });
    check_axis(SP_IMPORT_TO_CAMERA_IOS_BACK, screen_right, (sp_vec3){ 1, 0, 0 });
    /* a front camera looks at the user, who sees the screen's right on the (unmirrored) image's left */
    check_axis(SP_IMPORT_TO_CAMERA_ANDROID_FRONT, to_user, (sp_vec3){ 0, 0, 1 });
    check_axis(SP_IMPORT_TO_CAMERA_IOS_FRONT, screen_right, (sp_vec3){ -1, 0, 0 });
    check_axis(SP_IMPORT_TO_CAMERA_IDENTITY, screen_right, screen_right);
    double q[4];
    CHECK_EQ_INT(sp_import_to_camera_preset(SP_IMPORT_TO_CAMERA_KEEP, q), -EINVAL);
    CHECK_EQ_INT(sp_import_to_camera_preset((enum sp_import_to_camera)99, q), -EINVAL);

    /* the preset replaces the metadata's to_camera and keeps its other imu keys */
    iu_write_text("meta.json", "{\"imu\": {\"name\": \"phone\", \"to_camera\": [1, 0, 0, 0]}}");
    sp_import_settings s;
    sp_import_report rep;
    settings(&s, data("gyroflow/sample.gcsv"), "tc.spcap");
    s.meta_json = iu_path("meta.json");
    s.imu_to_camera = SP_IMPORT_TO_CAMERA_ANDROID_FRONT;
    iu_readback rb;
    if (run_ok(&s, &rep) && iu_read_capture(s.output, &rb) == 0) {
        sp_capture_meta m;
        sp_capture_meta_init(&m);
        CHECK_EQ_INT(sp_capture_meta_merge(&m, rb.meta_json, strlen(rb.meta_json)), 0);
        CHECK(m.imu_to_camera.w == 0 && m.imu_to_camera.x == 0 && m.imu_to_camera.y == 0 && m.imu_to_camera.z == 1);
        CHECK(strcmp(m.imu_name, "phone") == 0);
    }
    s.imu_to_camera = (enum sp_import_to_camera)42;
    expect_failure(&s, -EINVAL, "preset 42");
}

/* exposure_us and gain of every frame of a capture */
static int read_exposures(const char *path, float out[][2], int cap)
{
    sp_capture_reader *r = NULL;
    CHECK_EQ_INT(sp_capture_reader_open(&r, path, NULL), 0);
    int n = 0;
    sp_chunk ch;
    while (r && sp_capture_reader_next(r, &ch) == 0) {
        sp_frame_chunk fc;
        if (ch.type == SP_CHUNK_FRAME && n < cap && sp_chunk_parse_frame(&ch, &fc) == 0) {
            out[n][0] = fc.exposure_us;
            out[n++][1] = fc.gain;
        }
    }
    sp_capture_reader_close(&r);
    return n;
}

static void test_exposure(void)
{
    sp_import_settings s;
    sp_import_report rep;
    float e[8][2];
    /* in the frame-times CSV: shutter seconds and ISO (ISO 100 = gain 1); an empty cell is unknown */
    iu_write_text("times.csv", "t,exposure_s,iso\n0,0.01,100\n0.1,0.005,200\n0.2,,400\n0.3,0.02,\n0.4,1e-4,50\n");
    settings(&s, NULL, "ex.spcap");
    s.frame_times_csv = iu_path("times.csv");
    if (run_ok(&s, &rep) && read_exposures(s.output, e, 8) == 5) {
        CHECK_NEAR(e[0][0], 10000, 1e-3);
        CHECK_NEAR(e[0][1], 1, 0);
        CHECK_NEAR(e[1][0], 5000, 1e-3);
        CHECK_NEAR(e[1][1], 2, 0);
        CHECK(isnan(e[2][0]) && e[2][1] == 4);
        CHECK(e[3][0] == 20000 && isnan(e[3][1]));
        CHECK_NEAR(e[4][0], 100, 1e-3);
        CHECK_NEAR(e[4][1], 0.5, 0);
    }
    /* a CSV of its own, gain only; it wins over the frame-times CSV's columns */
    iu_write_text("gain.csv", "frame,gain\n0,1\n1,1.5\n2,2\n3,2.5\n4,8\n");
    s.exposure_csv = iu_path("gain.csv");
    if (run_ok(&s, &rep) && read_exposures(s.output, e, 8) == 5)
        for (int i = 0; i < 5; i++)
            CHECK(isnan(e[i][0]) && e[i][1] == (i < 4 ? 1 + 0.5f * (float)i : 8));
    static const struct {
        const char *name, *text, *needle;
    } bad[] = {
        { "both.csv", "iso,gain\n100,1\n", "both.csv:1: has both 'iso' and 'gain'" },
        { "zero.csv", "exposure_s\n0.01\n0\n", "zero.csv:3: column 'exposure_s': 0 is not in (0, 3600]" },
        { "nan.csv", "exposure_s\n0.01\nnan\n", "nan.csv:3: column 'exposure_s'" },
        { "huge.csv", "gain\n1e9\n", "huge.csv:2: column 'gain'" },
        { "none.csv", "frame\n0\n", "none.csv:1: needs a column exposure_s, iso or gain" },
        { "short.csv", "iso\n100\n100\n", "short.csv: has exposures for 2 frames, but the input has more" },
    };
    for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
        iu_write_text(bad[i].name, bad[i].text);
        settings(&s, NULL, "bad.spcap");
        s.exposure_csv = iu_path(bad[i].name);
        expect_failure(&s, SP_ECORRUPT, bad[i].needle);
    }
}

/* Horizontal image speed (px/s at 160 px) of the synthetic turn: uneven, so one shift matches best. */
static double speed(double t)
{
    return 60 * (0.6 + 0.4 * sin(2 * M_PI * t / 1.3)) * (0.5 + 0.5 * sin(2 * M_PI * t / 0.45 + 1));
}

/* 90 JPEG frames at 30 fps of a texture sliding by the integral of speed (moving 0: still; -1: flat grey). */
static void make_motion_frames(const char *dir, int moving)
{
    enum { W = 160, H = 120 };
    mkdir(iu_path(dir), 0755);
    static uint8_t rgb[W * H * 3];
    double x0 = 0;
    for (int i = 0; i < 90; i++) {
        for (int k = 0; moving > 0 && i > 0 && k < 100; k++) /* the shift since the previous frame */
            x0 += speed((i - 1 + (k + 0.5) / 100) / 30.0) / 3000.0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                double u = x - x0, v = 128 + 50 * sin(0.25 * u) + 30 * sin(0.17 * y + 0.3) + 20 * sin(0.11 * u + 0.13 * y);
                v = moving < 0 ? 128 : v;
                rgb[(y * W + x) * 3] = rgb[(y * W + x) * 3 + 1] = rgb[(y * W + x) * 3 + 2] = (uint8_t)lround(v);
            }
        sp_jpeg_buffer jb = { 0 };
        CHECK_EQ_INT(sp_jpeg_encode_rgb24(rgb, W, H, W * 3, 95, &jb), 0);
        char name[48];
        snprintf(name, sizeof(name), "%.20s/f_%03d.jpg", dir, i);
        FILE *f = fopen(iu_path(name), "wb");
        if (f && jb.data) {
            fwrite(jb.data, 1, jb.size, f);
            fclose(f);
        }
        sp_jpeg_buffer_free(&jb);
    }
}

/* A gyro log whose clock runs `late` s behind the video's: IMU time + late = video time. */
static void write_gyro(const char *name, double late, int moving)
{
    FILE *f = fopen(iu_path(name), "w");
    if (!f)
        return;
    fprintf(f, "t,gx,gy,gz\n");
    unsigned lcg = 12345;
    for (int i = -200; i <= 700; i++) { /* 200 Hz, -1 to 3.5 s, with +-0.05 rad/s of noise on every axis */
        double t = i / 200.0, n[3];
        for (int a = 0; a < 3; a++) {
            lcg = lcg * 1103515245u + 12345u;
            n[a] = 0.1 * ((double)(lcg >> 8) / (double)(1u << 24) - 0.5);
        }
        fprintf(f, "%.4f,%.6f,%.6f,%.6f\n", t, n[0], (moving ? speed(t + late) / 100 : 0.3) + n[1], n[2]);
    }
    fclose(f);
}

static void test_offset_auto(void)
{
    if (!sp_jpeg_available()) {
        printf("skipping --imu-offset auto: built without libjpeg\n");
        return;
    }
    make_motion_frames("turn", 1);
    write_gyro("late.csv", 0.3, 1);
    sp_import_settings s;
    sp_import_report rep;
    settings(&s, iu_path("late.csv"), "auto.spcap");
    s.input = iu_path("turn");
    s.fps = 30;
    s.imu_offset_auto = 1;
    if (run_ok(&s, &rep)) {
        printf("--imu-offset auto: %+.4f s for a true +0.3 s, correlation %.3f\n", rep.imu_offset_s,
               rep.imu_offset_corr);
        CHECK_MSG(fabs(rep.imu_offset_s - 0.3) < 0.01, "estimated %+.4f s, true +0.3 s (corr %.3f)", rep.imu_offset_s,
                  rep.imu_offset_corr);
        CHECK(rep.imu_offset_corr > 0.9);
        CHECK(rep.frames == 90 && rep.frames_copied == 90);
        read_samples(s.output);
        CHECK_MSG(llabs(samples[0].timestamp_ns - llround((-1.0 + rep.imu_offset_s) * 1e9)) < 2,
                  "first sample at %lld ns", (long long)samples[0].timestamp_ns);
    }
    write_gyro("early.csv", -0.75, 1);
    settings(&s, iu_path("early.csv"), "auto2.spcap");
    s.input = iu_path("turn");
    s.fps = 30;
    s.imu_offset_auto = 1;
    if (run_ok(&s, &rep) && printf("--imu-offset auto: %+.4f s for a true -0.75 s, correlation %.3f\n",
                                   rep.imu_offset_s, rep.imu_offset_corr))
        CHECK_MSG(fabs(rep.imu_offset_s + 0.75) < 0.01, "estimated %+.4f s, true -0.75 s", rep.imu_offset_s);
    /* nothing moves: nothing to match */
    make_motion_frames("still", 0);
    write_gyro("still.csv", 0, 0);
    settings(&s, iu_path("still.csv"), "bad.spcap");
    s.input = iu_path("still");
    s.fps = 30;
    s.imu_offset_auto = 1;
    expect_failure(&s, SP_ECORRUPT, "nothing to match");
    /* a flat image has no gradient to measure motion by */
    make_motion_frames("flat", -1);
    s.input = iu_path("flat");
    s.imu_csv = iu_path("late.csv");
    expect_failure(&s, SP_ENODATA, "0 frame pairs with measurable motion");
    /* a true offset beyond the search range cannot be found: refused, not guessed */
    s.imu_offset_range_s = 0.2;
    s.imu_csv = iu_path("late.csv");
    s.input = iu_path("turn");
    expect_failure(&s, SP_ECORRUPT, "no clear match");
    settings(&s, NULL, "bad.spcap");
    s.imu_offset_auto = 1;
    expect_failure(&s, -EINVAL, "needs an IMU log");
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: test_import_logs TESTS_DATA_DIR\n");
        return 99;
    }
    data_dir = argv[1];
    iu_make_tmp("import_logs");
    mkdir(iu_path("jpg"), 0755);
    for (int i = 0; i < 5; i++) {
        char name[64];
        snprintf(name, sizeof(name), "jpg/f_%d.jpg", i);
        iu_write_marked_jpeg(name, i);
    }
    test_sensor_logger();
    test_sensor_logger_bad();
    test_sensor_logger_place();
    test_opencamera();
    test_gcsv();
    test_to_camera();
    test_exposure();
    test_offset_auto();
#if HAVE_LIBZIP && HAVE_OPENCV
    test_export_zip();
#endif
    return iu_finish();
}
