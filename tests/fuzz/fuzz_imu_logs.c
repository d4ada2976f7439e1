/* SPDX-License-Identifier: MIT */
/*
 * Fuzz harness for the importers' IMU log readers: the input is one file, read as a Gyroflow
 * .gcsv, an OpenCamera-Sensors *_gyro.csv, a Sensor Logger Gyroscope.csv, the sunprobe IMU CSV and
 * a per-frame exposure CSV. Each must fail cleanly or give time-sorted, finite samples. Built for
 * libFuzzer with -DSP_LIBFUZZER; otherwise a main replays the corpus (tests/data).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "capture/import_internal.h"
#include "sunprobe/sp_import.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static char dir[256];

static void put(const char *name, const uint8_t *data, size_t size)
{
    char p[400];
    snprintf(p, sizeof(p), "%s/%s", dir, name);
    FILE *f = fopen(p, "wb");
    if (!f)
        abort();
    if (size && fwrite(data, 1, size, f) != size)
        abort();
    fclose(f);
}

static void check_log(const sp_import_log *log)
{
    for (size_t i = 0; i < log->n; i++) {
        const sp_imu_sample *s = &log->s[i];
        if (!isfinite(s->v[0]) || !isfinite(s->v[1]) || !isfinite(s->v[2]) ||
            (i && s->timestamp_ns < log->s[i - 1].timestamp_ns))
            abort();
    }
}

static void read_as(int format, const char *name)
{
    char p[400], msg[512] = "";
    snprintf(p, sizeof(p), "%s/%s", dir, name);
    sp_import_log log;
    if (sp_import_log_load(&log, p, format, p, 0, msg, sizeof(msg)) == 0)
        check_log(&log);
    else if (!msg[0])
        abort(); /* every failure names its cause */
    sp_import_log_free(&log);
}

static void read_csv(void)
{
    char p[400], msg[512] = "";
    snprintf(p, sizeof(p), "%s/s.csv", dir);
    sp_import_imu r;
    const sp_imu_sample *smp;
    int64_t last = INT64_MIN;
    if (sp_import_imu_open(&r, p, 0, msg, sizeof(msg)) == 0)
        while (sp_import_imu_peek(&r, &smp) == 0) {
            if (smp->timestamp_ns < last || !isfinite(smp->v[0]))
                abort();
            last = smp->timestamp_ns;
            sp_import_imu_pop(&r);
        }
    sp_import_imu_close(&r);
    sp_import_exposure x = { 0 };
    msg[0] = 0;
    if (sp_import_exposure_load(&x, p, msg, sizeof(msg)) != 0 && !msg[0])
        abort();
    sp_import_exposure_free(&x);
}

static void remove_dir(void)
{
    static const char *const names[] = { "x.gcsv", "VID_gyro.csv", "sl/Gyroscope.csv", "s.csv", "sl", "" };
    char p[400];
    for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++) {
        snprintf(p, sizeof(p), "%s/%s", dir, names[i]);
        remove(p);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (!dir[0]) {
        snprintf(dir, sizeof(dir), "%s/sp-fuzz-logs.XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
        if (!mkdtemp(dir))
            abort();
        atexit(remove_dir);
        char sl[300];
        snprintf(sl, sizeof(sl), "%s/sl", dir);
        mkdir(sl, 0755);
    }
    put("x.gcsv", data, size);
    put("VID_gyro.csv", data, size);
    put("sl/Gyroscope.csv", data, size);
    put("s.csv", data, size);
    read_as(SP_IMPORT_IMU_GCSV, "x.gcsv");
    read_as(SP_IMPORT_IMU_OPENCAMERA, "VID_gyro.csv");
    read_as(SP_IMPORT_IMU_SENSOR_LOGGER, "sl");
    read_csv();
    return 0;
}

#include "replay_main.h"
