/* SPDX-License-Identifier: MIT */
/*
 * The IIO backend against a fake sysfs tree: in a private mount namespace a
 * tmpfs covers /sys/bus and /dev, holding a gyro+accelerometer with a kernel
 * buffer (its /dev/iio:device0 a plain file of scan records) and a magnetometer
 * without one (polled). Needs root (or CAP_SYS_ADMIN); skips saying so otherwise.
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

static void test_enumerate(void)
{
    sp_imu_desc d[8];
    size_t n = 0;
    CHECK_EQ_INT(sp_imu_device_enumerate(d, 8, &n), 0);
    CHECK_EQ_INT(n, 3); /* two IIO devices and the fake */
    if (n < 3)
        return;
    CHECK(!strcmp(d[0].id, "iio:device0") && !strcmp(d[0].name, "bmi160") && !strcmp(d[0].backend, "iio"));
    CHECK_EQ_INT(d[0].sensors, SP_IMU_SENSOR_BIT(SP_IMU_GYRO) | SP_IMU_SENSOR_BIT(SP_IMU_ACCEL));
    CHECK(strstr(d[0].channels, "anglvel_x") && strstr(d[0].channels, "accel_z") && strstr(d[0].channels, "timestamp"));
    CHECK(d[0].rate_hz == 200 && d[0].buffered && strstr(d[0].rates, "1600"));
    CHECK(!strcmp(d[1].name, "ak8975") && d[1].sensors == SP_IMU_SENSOR_BIT(SP_IMU_MAG) && !d[1].buffered);
    CHECK(!strcmp(d[2].backend, "fake"));
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
    char v[64];
    get(DEV0, "current_timestamp_clock", v, sizeof(v));
    CHECK(!strcmp(v, "monotonic"));
    get(DEV0, "scan_elements/in_accel_y_en", v, sizeof(v));
    CHECK(!strcmp(v, "1"));
    get(DEV0, "scan_elements/in_timestamp_en", v, sizeof(v));
    CHECK(!strcmp(v, "1"));
    get(DEV0, "trigger/current_trigger", v, sizeof(v));
    CHECK(!strcmp(v, "bmi160-dev0"));
    CHECK_EQ_INT(sp_imu_device_start(imu), 0);
    get(DEV0, "buffer/enable", v, sizeof(v));
    CHECK(!strcmp(v, "1"));
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
    get(DEV0, "buffer/enable", v, sizeof(v));
    CHECK(!strcmp(v, "0"));
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
    test_enumerate();
    test_buffered();
    test_polled();
    return check_exit();
}
