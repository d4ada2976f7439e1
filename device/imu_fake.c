/* SPDX-License-Identifier: MIT */
/*
 * The synthetic IMU (sp_fake_imu.h) as a live IMU backend: samples are released
 * in real time on CLOCK_MONOTONIC, and the turn repeats for as long as it is read.
 */
#include "device/backends.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "common/clock.h"
#include "sunprobe/sp_fake_imu.h"

typedef struct fake_imu_ctx {
    sp_fake_imu_settings fs;
    sp_fake_imu *gen;
    sp_imu_sample pending; /* the next sample, not yet due */
    int have_pending;
} fake_imu_ctx;

static int fake_claims(const char *device)
{
    return device && !strcmp(device, "fake");
}

static void describe(sp_imu_desc *d, double rate)
{
    memset(d, 0, sizeof(*d));
    sp_dev_copy_string(d->backend, sizeof(d->backend), "fake");
    sp_dev_copy_string(d->id, sizeof(d->id), "fake");
    sp_dev_copy_string(d->name, sizeof(d->name), "sunprobe synthetic IMU");
    d->sensors = SP_IMU_SENSOR_BIT(SP_IMU_GYRO) | SP_IMU_SENSOR_BIT(SP_IMU_ACCEL) | SP_IMU_SENSOR_BIT(SP_IMU_MAG);
    sp_dev_copy_string(d->channels, sizeof(d->channels),
                       "anglvel_x anglvel_y anglvel_z accel_x accel_y accel_z magn_x magn_y magn_z timestamp");
    d->rate_hz = rate;
    sp_dev_copy_string(d->rates, sizeof(d->rates), "any up to 10000");
    d->buffered = 1;
}

static int fake_enumerate(sp_imu_desc *out, size_t max, size_t *count)
{
    if (max >= 1)
        describe(out, 200.0);
    *count = 1;
    return 0;
}

static int fake_open(void **out, const sp_imu_device_settings *s, sp_imu_device_info *info)
{
    if (s->rate_hz > 10000)
        return -EINVAL;
    fake_imu_ctx *c = calloc(1, sizeof(*c));
    if (!c)
        return -ENOMEM;
    sp_fake_imu_default_settings(&c->fs);
    if (s->rate_hz > 0)
        c->fs.rate_hz = s->rate_hz;
    c->fs.magnetometer = 1;
    memset(info, 0, sizeof(*info));
    describe(&info->desc, c->fs.rate_hz);
    info->rate_hz = c->fs.rate_hz;
    info->buffered = 1;
    info->kernel_timestamps = 1; /* stamped by the generator at the sample's own time */
    *out = c;
    return 0;
}

/* (Re)starts the motion so that its first sample falls at start_ns. */
static int restart(fake_imu_ctx *c, int64_t start_ns)
{
    sp_fake_imu_close(&c->gen);
    c->fs.start_ns = start_ns;
    c->have_pending = 0;
    return sp_fake_imu_open(&c->gen, &c->fs);
}

static int fake_start(void *ctx)
{
    fake_imu_ctx *c = ctx;
    return restart(c, sp_clock_monotonic_ns());
}

static int peek(fake_imu_ctx *c)
{
    if (c->have_pending)
        return 0;
    int err = sp_fake_imu_next(c->gen, &c->pending);
    if (err == SP_EOS) { /* the turn is over: turn again from the next tick */
        int64_t next = c->pending.timestamp_ns + (int64_t)(1e9 / c->fs.rate_hz);
        err = restart(c, next);
        if (err == 0)
            err = sp_fake_imu_next(c->gen, &c->pending);
    }
    if (err == 0)
        c->have_pending = 1;
    return err;
}

static int fake_read(void *ctx, sp_imu_sample *out, size_t max, int timeout_ms, size_t *count)
{
    fake_imu_ctx *c = ctx;
    int64_t deadline = sp_clock_monotonic_ns() + (int64_t)timeout_ms * 1000000;
    size_t n = 0;
    int err = peek(c);
    if (err == 0 && c->pending.timestamp_ns > sp_clock_monotonic_ns())
        sp_clock_sleep_until(c->pending.timestamp_ns < deadline ? c->pending.timestamp_ns : deadline);
    int64_t now = sp_clock_monotonic_ns();
    while (err == 0 && n < max && c->pending.timestamp_ns <= now) {
        out[n++] = c->pending;
        c->have_pending = 0;
        err = peek(c);
    }
    *count = n;
    return err;
}

static int fake_stop(void *ctx)
{
    return 0;
}

static void fake_close(void *ctx)
{
    fake_imu_ctx *c = ctx;
    if (!c)
        return;
    sp_fake_imu_close(&c->gen);
    free(c);
}

const sp_imu_ops sp_imu_fake_ops = {
    .name = "fake",
    .enumerate = fake_enumerate,
    .claims = fake_claims,
    .open = fake_open,
    .start = fake_start,
    .read = fake_read,
    .stop = fake_stop,
    .close = fake_close,
};
