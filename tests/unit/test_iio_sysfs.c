/* SPDX-License-Identifier: MIT */
/*
 * The IIO backend against a fake sysfs tree: in a private mount namespace a
 * tmpfs covers /sys/bus and /dev, holding a gyro+accelerometer with a kernel
 * buffer (its /dev/iio:device0 a plain file of scan records) and a magnetometer
 * without one (polled); and a split IMU as LSM6DSx drivers expose it (accelerometer
 * and gyroscope as two buffered devices), a magnetometer whose buffer has no
 * timestamp channel and a gyroscope whose clock cannot be switched to monotonic,
 * opened as groups "A+B[+C]". Needs root (or CAP_SYS_ADMIN); skips saying so otherwise.
 */
#include "sunprobe/sp_imu_device.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mount.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"

#define DEV0 "/sys/bus/iio/devices/iio:device0"
#define DEV1 "/sys/bus/iio/devices/iio:device1"
#define DEV2 "/sys/bus/iio/devices/iio:device2"
#define DEV3 "/sys/bus/iio/devices/iio:device3"
#define DEV4 "/sys/bus/iio/devices/iio:device4"
#define DEV5 "/sys/bus/iio/devices/iio:device5"
#define GYRO_SCALE 0.001065264
#define ACCEL_SCALE 0.000598550

static void mkdirs(const char *path)
{
    char tmp[512];
    snprintf(tmp, sizeof(tmp), "%s", path);
    for (char *p = tmp + 1; *p; p++)
        if (*p == '/') {
            *p = '\0';
            mkdir(tmp, 0755);
            *p = '/';
        }
    mkdir(tmp, 0755);
}

static void put(const char *dir, const char *name, const char *content)
{
    char path[512];
    snprintf(path, sizeof(path), "%s/%s", dir, name);
    char *slash = strrchr(path, '/');
    *slash = '\0';
    mkdirs(path);
    *slash = '/';
    FILE *f = fopen(path, "w");
    CHECK_MSG(f != NULL, "%s: %s", path, strerror(errno));
    if (f) {
        fputs(content, f);
        fclose(f);
    }
}

static void get(const char *dir, const char *name, char *buf, size_t size)
{
    char path[512];
    snprintf(path, sizeof(path), "%s/%s", dir, name);
    buf[0] = '\0';
    FILE *f = fopen(path, "r");
    if (!f)
        return;
    if (!fgets(buf, (int)size, f))
        buf[0] = '\0';
    fclose(f);
    buf[strcspn(buf, "\n")] = '\0';
}

/* An attribute of the fake tree reads `want` (what the backend wrote there). */
static void check_attr(const char *dir, const char *name, const char *want)
{
    char v[64];
    get(dir, name, v, sizeof(v));
    CHECK_MSG(!strcmp(v, want), "%s/%s is '%s', expected '%s'", dir, name, v, want);
}

static const int16_t raw[6][6] = {
    { 100, -200, 300, 0, 0, 16384 },     { 101, -201, 301, 1, -1, 16383 }, { 102, -202, 302, 2, -2, 16382 },
    { 103, -203, 303, 3, -3, 16381 },    { 104, -204, 304, 4, -4, 16380 }, { -32768, 32767, 0, 5, -5, 16379 },
};

/* One 24-byte record: six little-endian s16, 4 bytes of padding, the s64 timestamp at 16. */
static void record_bytes(int i, uint8_t rec[24])
{
    memset(rec, 0, 24);
    for (int c = 0; c < 6; c++) {
        rec[2 * c] = (uint8_t)(raw[i][c] & 0xff);
        rec[2 * c + 1] = (uint8_t)((uint16_t)raw[i][c] >> 8);
    }
    uint64_t ts = 5000000000ull + (uint64_t)i * 5000000ull;
    for (int b = 0; b < 8; b++)
        rec[16 + b] = (uint8_t)(ts >> (8 * b));
}

static void build_tree(void)
{
    put(DEV0, "name", "bmi160\n");
    put(DEV0, "sampling_frequency", "200\n");
    put(DEV0, "sampling_frequency_available", "25 50 100 200 400 800 1600\n");
    put(DEV0, "current_timestamp_clock", "realtime\n");
    put(DEV0, "buffer/enable", "0\n");
    put(DEV0, "buffer/length", "2\n");
    put(DEV0, "trigger/current_trigger", "\n");
    put("/sys/bus/iio/devices/trigger0", "name", "bmi160-dev0\n");
    const char *types[2] = { "anglvel", "accel" };
    for (int k = 0; k < 2; k++) {
        for (int a = 0; a < 3; a++) {
            char name[96], val[32];
            snprintf(name, sizeof(name), "in_%s_%c_raw", types[k], "xyz"[a]);
            snprintf(val, sizeof(val), "%d\n", raw[0][k * 3 + a]);
            put(DEV0, name, val);
            snprintf(name, sizeof(name), "scan_elements/in_%s_%c_en", types[k], "xyz"[a]);
            put(DEV0, name, "0\n");
            snprintf(name, sizeof(name), "scan_elements/in_%s_%c_index", types[k], "xyz"[a]);
            snprintf(val, sizeof(val), "%d\n", k * 3 + a);
            put(DEV0, name, val);
            snprintf(name, sizeof(name), "scan_elements/in_%s_%c_type", types[k], "xyz"[a]);
            put(DEV0, name, "le:s16/16>>0\n");
        }
    }
    put(DEV0, "in_anglvel_scale", "0.001065264\n");
    put(DEV0, "in_accel_scale", "0.000598550\n");
    put(DEV0, "in_accel_x_offset", "10\n"); /* a per-axis offset beats the (absent) shared one */
    put(DEV0, "scan_elements/in_timestamp_en", "0\n");
    put(DEV0, "scan_elements/in_timestamp_index", "6\n");
    put(DEV0, "scan_elements/in_timestamp_type", "le:s64/64>>0\n");
    /* the kernel buffer: five whole records and half of a sixth */
    FILE *f = fopen("/dev/iio:device0", "wb");
    CHECK(f != NULL);
    for (int i = 0; f && i < 6; i++) {
        uint8_t rec[24];
        record_bytes(i, rec);
        fwrite(rec, 1, i < 5 ? 24 : 12, f);
    }
    if (f)
        fclose(f);
    put(DEV1, "name", "ak8975\n");
    put(DEV1, "in_magn_x_raw", "100\n");
    put(DEV1, "in_magn_y_raw", "200\n");
    put(DEV1, "in_magn_z_raw", "-300\n");
    put(DEV1, "in_magn_scale", "0.003\n"); /* gauss per count */
}

/* One buffered single-sensor device: channels in_<type>_{x,y,z} (s16, indices 0-2), a timestamp
 * channel (index 3, s64 at byte 8) unless `clock` is NULL, and `count` records in its /dev node: axis a of
 * record i is base + 10 i + a, stamped t0_ns + i * step_ns. clock "stuck" makes current_timestamp_clock
 * a directory, so the clock can be neither read nor switched (the driver stays on realtime). */
static void build_split_member(const char *dir, int num, const char *name, const char *type, const char *scale,
                               const char *clock, int base, int count, int64_t t0_ns, int64_t step_ns)
{
    char attr[96], val[64];
    put(dir, "name", name);
    put(dir, "buffer/enable", "0\n");
    if (clock && !strcmp(clock, "stuck")) {
        snprintf(attr, sizeof(attr), "%s/current_timestamp_clock", dir);
        mkdirs(attr);
    } else if (clock) {
        put(dir, "current_timestamp_clock", clock);
    }
    snprintf(attr, sizeof(attr), "in_%s_scale", type);
    put(dir, attr, scale);
    for (int a = 0; a < 3; a++) {
        snprintf(attr, sizeof(attr), "in_%s_%c_raw", type, "xyz"[a]);
        put(dir, attr, "0\n");
        snprintf(attr, sizeof(attr), "scan_elements/in_%s_%c_en", type, "xyz"[a]);
        put(dir, attr, "0\n");
        snprintf(attr, sizeof(attr), "scan_elements/in_%s_%c_index", type, "xyz"[a]);
        snprintf(val, sizeof(val), "%d\n", a);
        put(dir, attr, val);
        snprintf(attr, sizeof(attr), "scan_elements/in_%s_%c_type", type, "xyz"[a]);
        put(dir, attr, "le:s16/16>>0\n");
    }
    if (clock) {
        put(dir, "scan_elements/in_timestamp_en", "0\n");
        put(dir, "scan_elements/in_timestamp_index", "3\n");
        put(dir, "scan_elements/in_timestamp_type", "le:s64/64>>0\n");
    }
    char node[64];
    snprintf(node, sizeof(node), "/dev/iio:device%d", num);
    FILE *f = fopen(node, "wb");
    CHECK(f != NULL);
    size_t size = clock ? 16 : 6; /* three s16, then the s64 aligned to 8 */
    for (int i = 0; f && i < count; i++) {
        uint8_t rec[16] = { 0 };
        for (int a = 0; a < 3; a++) {
            int16_t v = (int16_t)(base + 10 * i + a);
            rec[2 * a] = (uint8_t)(v & 0xff);
            rec[2 * a + 1] = (uint8_t)((uint16_t)v >> 8);
        }
        uint64_t ts = (uint64_t)(t0_ns + i * step_ns);
        for (int b = 0; b < 8; b++)
            rec[8 + b] = (uint8_t)(ts >> (8 * b));
        fwrite(rec, 1, size, f);
    }
    if (f)
        fclose(f);
}

/* An LSM6DSx-like split IMU: accelerometer at 5.000 s + 10 ms i, gyroscope at 5.005 s + 10 ms i. */
static void build_split_tree(void)
{
    build_split_member(DEV2, 2, "lsm6dsm_accel\n", "accel", "0.000598550\n", "realtime\n", 1000, 3, 5000000000ll,
                       10000000);
    build_split_member(DEV3, 3, "lsm6dsm_gyro\n", "anglvel", "0.001065264\n", "realtime\n", 2000, 3, 5005000000ll,
                       10000000);
    build_split_member(DEV4, 4, "lis3mdl\n", "magn", "0.000146\n", NULL, 300, 2, 0, 0);
    build_split_member(DEV5, 5, "old_gyro\n", "anglvel", "0.001065264\n", "stuck", 0, 1, 0, 0);
}

static void test_enumerate(void)
{
    sp_imu_desc d[8];
    size_t n = 0;
    CHECK_EQ_INT(sp_imu_device_enumerate(d, 8, &n), 0);
    CHECK_EQ_INT(n, 7); /* six IIO devices and the fake */
    if (n < 7)
        return;
    CHECK(!strcmp(d[0].id, "iio:device0") && !strcmp(d[0].name, "bmi160") && !strcmp(d[0].backend, "iio"));
    CHECK_EQ_INT(d[0].sensors, SP_IMU_SENSOR_BIT(SP_IMU_GYRO) | SP_IMU_SENSOR_BIT(SP_IMU_ACCEL));
    CHECK(strstr(d[0].channels, "anglvel_x") && strstr(d[0].channels, "accel_z") && strstr(d[0].channels, "timestamp"));
    CHECK(d[0].rate_hz == 200 && d[0].buffered && strstr(d[0].rates, "1600"));
    CHECK(!strcmp(d[1].name, "ak8975") && d[1].sensors == SP_IMU_SENSOR_BIT(SP_IMU_MAG) && !d[1].buffered);
    CHECK(!strcmp(d[2].name, "lsm6dsm_accel") && d[2].sensors == SP_IMU_SENSOR_BIT(SP_IMU_ACCEL) && d[2].buffered);
    CHECK(!strcmp(d[3].name, "lsm6dsm_gyro") && d[3].sensors == SP_IMU_SENSOR_BIT(SP_IMU_GYRO) && d[3].buffered);
    CHECK(!strcmp(d[6].backend, "fake"));
}

static void check_record(const sp_imu_sample *g, const sp_imu_sample *a, int i)
{
    int64_t ts = 5000000000ll + (int64_t)i * 5000000ll;
    CHECK(g->sensor == SP_IMU_GYRO && a->sensor == SP_IMU_ACCEL);
    CHECK(g->timestamp_ns == ts && a->timestamp_ns == ts); /* kernel stamps, clock switched to monotonic */
    for (int k = 0; k < 3; k++) {
        CHECK_NEAR(g->v[k], raw[i][k] * GYRO_SCALE, 1e-6);
        CHECK_NEAR(a->v[k], (raw[i][3 + k] + (k == 0 ? 10 : 0)) * ACCEL_SCALE, 1e-6);
    }
}

static void test_buffered(void)
{
    sp_imu_device_settings s;
    sp_imu_device_default_settings(&s);
    s.device = "bmi160";
    sp_imu_device *imu = NULL;
    CHECK_EQ_INT(sp_imu_device_open(&imu, &s), 0);
    if (!imu)
        return;
    const sp_imu_device_info *ii = sp_imu_device_get_info(imu);
    CHECK(ii->buffered && ii->kernel_timestamps && ii->rate_hz == 200);
    check_attr(DEV0, "current_timestamp_clock", "monotonic");
    check_attr(DEV0, "scan_elements/in_accel_y_en", "1");
    check_attr(DEV0, "scan_elements/in_timestamp_en", "1");
    check_attr(DEV0, "trigger/current_trigger", "bmi160-dev0");
    CHECK_EQ_INT(sp_imu_device_start(imu), 0);
    check_attr(DEV0, "buffer/enable", "1");
    sp_imu_sample out[64];
    size_t n = 0;
    CHECK_EQ_INT(sp_imu_device_read(imu, out, 64, 0, &n), 0);
    CHECK_EQ_INT(n, 10);
    for (int i = 0; i < 5 && (size_t)(2 * i + 1) < n; i++)
        check_record(&out[2 * i], &out[2 * i + 1], i);
    /* the rest of the sixth record arrives later: the half kept from before completes it */
    FILE *f = fopen("/dev/iio:device0", "ab");
    uint8_t rec[24];
    record_bytes(5, rec);
    if (f) {
        fwrite(rec + 12, 1, 12, f);
        fclose(f);
    }
    CHECK_EQ_INT(sp_imu_device_read(imu, out, 64, 0, &n), 0);
    CHECK_EQ_INT(n, 2);
    if (n == 2)
        check_record(&out[0], &out[1], 5);
    CHECK_EQ_INT(sp_imu_device_read(imu, out, 1, 0, &n), -EINVAL); /* no room for one record's samples */
    CHECK_EQ_INT(sp_imu_device_stop(imu), 0);
    check_attr(DEV0, "buffer/enable", "0");
    sp_imu_device_close(&imu);
    s.mode = 1; /* buffered only: the magnetometer has no buffer */
    s.device = "ak8975";
    CHECK_EQ_INT(sp_imu_device_open(&imu, &s), -ENOTSUP);
}

static void test_polled(void)
{
    sp_imu_device_settings s;
    sp_imu_device_default_settings(&s);
    s.device = "iio:device1";
    sp_imu_device *imu = NULL;
    CHECK_EQ_INT(sp_imu_device_open(&imu, &s), 0);
    if (!imu)
        return;
    const sp_imu_device_info *ii = sp_imu_device_get_info(imu);
    CHECK(!ii->buffered && !ii->kernel_timestamps && ii->rate_hz > 0);
    CHECK_EQ_INT(sp_imu_device_start(imu), 0);
    sp_imu_sample out[8];
    size_t n = 0, total = 0;
    for (int i = 0; i < 3; i++) {
        CHECK_EQ_INT(sp_imu_device_read(imu, out, 8, 100, &n), 0);
        total += n;
        if (n == 1) {
            CHECK(out[0].sensor == SP_IMU_MAG);
            CHECK_NEAR(out[0].v[0], 100 * 0.3, 1e-4); /* gauss to microtesla */
            CHECK_NEAR(out[0].v[1], 200 * 0.3, 1e-4);
            CHECK_NEAR(out[0].v[2], -300 * 0.3, 1e-4);
        }
    }
    CHECK(total >= 1);
    sp_imu_device_close(&imu);
}

/* stderr into a file while `open` runs, so a test can read what the backend said */
static int open_logged(const char *device, int mode, sp_imu_device **imu, char *log, size_t size)
{
    sp_imu_device_settings s;
    sp_imu_device_default_settings(&s);
    s.device = device;
    s.mode = mode;
    fflush(stderr);
    int saved = dup(2);
    FILE *tmp = tmpfile();
    if (saved < 0 || !tmp)
        abort();
    dup2(fileno(tmp), 2);
    int err = sp_imu_device_open(imu, &s);
    fflush(stderr);
    dup2(saved, 2);
    close(saved);
    rewind(tmp);
    size_t n = fread(log, 1, size - 1, tmp);
    log[n] = '\0';
    fclose(tmp);
    fputs(log, stderr);
    return err;
}

/* Accelerometer and gyroscope as two devices: one IMU, both buffers switched to the monotonic clock,
 * samples merged in time order with their own scales. */
static void test_split_buffered(void)
{
    sp_imu_device *imu = NULL;
    char log[2048];
    CHECK_EQ_INT(open_logged("lsm6dsm_accel+lsm6dsm_gyro", 0, &imu, log, sizeof(log)), 0);
    if (!imu)
        return;
    const sp_imu_device_info *ii = sp_imu_device_get_info(imu);
    CHECK(ii->buffered && ii->kernel_timestamps);
    CHECK_EQ_INT(ii->desc.sensors, SP_IMU_SENSOR_BIT(SP_IMU_GYRO) | SP_IMU_SENSOR_BIT(SP_IMU_ACCEL));
    CHECK_MSG(!strcmp(ii->desc.name, "lsm6dsm_accel+lsm6dsm_gyro"), "%s", ii->desc.name);
    CHECK(!strcmp(ii->desc.id, "lsm6dsm_accel+lsm6dsm_gyro") && !strcmp(ii->desc.backend, "iio"));
    check_attr(DEV2, "current_timestamp_clock", "monotonic");
    check_attr(DEV3, "current_timestamp_clock", "monotonic");
    CHECK_EQ_INT(sp_imu_device_start(imu), 0);
    check_attr(DEV2, "buffer/enable", "1");
    check_attr(DEV3, "buffer/enable", "1");
    sp_imu_sample out[16];
    size_t n = 0;
    CHECK_EQ_INT(sp_imu_device_read(imu, out, 16, 100, &n), 0);
    CHECK_EQ_INT(n, 6);
    for (size_t i = 0; i < n && i < 6; i++) {
        int gyro = (int)(i % 2), rec = (int)(i / 2); /* accel, gyro, accel, ... by time */
        CHECK_EQ_INT(out[i].sensor, gyro ? SP_IMU_GYRO : SP_IMU_ACCEL);
        CHECK_EQ_INT(out[i].timestamp_ns, 5000000000ll + rec * 10000000ll + gyro * 5000000ll);
        for (int a = 0; a < 3; a++)
            CHECK_NEAR(out[i].v[a], ((gyro ? 2000 : 1000) + 10 * rec + a) * (gyro ? GYRO_SCALE : ACCEL_SCALE), 1e-6);
    }
    CHECK_EQ_INT(sp_imu_device_stop(imu), 0);
    check_attr(DEV3, "buffer/enable", "0");
    sp_imu_device_close(&imu);
}

/* What cannot be one IMU says which device is at fault: a missing member, a sensor kind named twice,
 * clocks that differ (a buffer without timestamps, a clock stuck on realtime), a member without a
 * kernel buffer when buffers are demanded. */
static void test_split_refused(void)
{
    sp_imu_device *imu = NULL;
    char log[2048];
    CHECK_EQ_INT(open_logged("lsm6dsm_accel+lsm6dsm_gyrox", 0, &imu, log, sizeof(log)), -ENODEV);
    CHECK_MSG(strstr(log, "'lsm6dsm_gyrox'") != NULL, "%s", log);
    CHECK_EQ_INT(open_logged("bmi160+lsm6dsm_gyro", 0, &imu, log, sizeof(log)), -EINVAL);
    CHECK_MSG(strstr(log, "bmi160") && strstr(log, "lsm6dsm_gyro"), "%s", log);
    CHECK_EQ_INT(open_logged("lsm6dsm_gyro+lis3mdl", 0, &imu, log, sizeof(log)), -EINVAL);
    CHECK_MSG(strstr(log, "lsm6dsm_gyro is stamped by the kernel's monotonic clock, lis3mdl by read time"), "%s", log);
    CHECK_EQ_INT(open_logged("lsm6dsm_accel+old_gyro", 0, &imu, log, sizeof(log)), -EINVAL);
    CHECK_MSG(strstr(log, "old_gyro by the kernel's realtime clock"), "%s", log);
    CHECK_EQ_INT(open_logged("lsm6dsm_accel+lsm6dsm_gyro+ak8975", 1, &imu, log, sizeof(log)), -ENOTSUP);
    CHECK_MSG(strstr(log, "ak8975 (iio:device1) has no kernel buffer"), "%s", log);
    CHECK_EQ_INT(open_logged("lsm6dsm_accel+lsm6dsm_gyro+ak8975+bmi160", 0, &imu, log, sizeof(log)), -EINVAL);
    CHECK_MSG(strstr(log, "at most 3 members"), "%s", log);
    CHECK(imu == NULL);
}

/* A magnetometer without a buffer beside buffered sensors: the whole group is polled (one clock, the
 * read time), and says so. */
static void test_split_polled(void)
{
    sp_imu_device *imu = NULL;
    char log[2048];
    CHECK_EQ_INT(open_logged("lsm6dsm_accel+lsm6dsm_gyro+ak8975", 0, &imu, log, sizeof(log)), 0);
    CHECK_MSG(strstr(log, "ak8975 has no kernel buffer: polling"), "%s", log);
    if (!imu)
        return;
    const sp_imu_device_info *ii = sp_imu_device_get_info(imu);
    CHECK(!ii->buffered && !ii->kernel_timestamps && ii->rate_hz > 0);
    CHECK_EQ_INT(ii->desc.sensors, SP_IMU_SENSOR_BIT(SP_IMU_GYRO) | SP_IMU_SENSOR_BIT(SP_IMU_ACCEL) |
                                       SP_IMU_SENSOR_BIT(SP_IMU_MAG));
    CHECK_EQ_INT(sp_imu_device_start(imu), 0);
    sp_imu_sample out[8];
    size_t n = 0;
    for (int tries = 0; tries < 5 && n == 0; tries++)
        CHECK_EQ_INT(sp_imu_device_read(imu, out, 8, 100, &n), 0);
    CHECK_EQ_INT(n, 3); /* one sample of each sensor, one stamp */
    unsigned seen = 0;
    for (size_t i = 0; i < n && i < 8; i++) {
        seen |= SP_IMU_SENSOR_BIT(out[i].sensor);
        CHECK(out[i].timestamp_ns == out[0].timestamp_ns);
        if (out[i].sensor == SP_IMU_MAG)
            CHECK_NEAR(out[i].v[2], -300 * 0.3, 1e-4);
    }
    CHECK_EQ_INT(seen, ii->desc.sensors);
    sp_imu_device_close(&imu);
}

int main(void)
{
    if (geteuid() != 0)
        SKIP("needs root to mount a fake sysfs tree in a private mount namespace");
    if (unshare(CLONE_NEWNS) < 0)
        SKIP("unshare(CLONE_NEWNS) not permitted here: %s", strerror(errno));
    if (mount(NULL, "/", NULL, MS_REC | MS_PRIVATE, NULL) < 0 ||
        mount("tmpfs", "/sys/bus", "tmpfs", 0, "size=4m") < 0 || mount("tmpfs", "/dev", "tmpfs", 0, "size=4m") < 0)
        SKIP("cannot mount tmpfs over /sys/bus and /dev in a private namespace: %s", strerror(errno));
    build_tree();
    build_split_tree();
    test_enumerate();
    test_buffered();
    test_polled();
    test_split_buffered();
    test_split_refused();
    test_split_polled();
    return check_exit();
}
