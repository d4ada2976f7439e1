/* SPDX-License-Identifier: MIT */
/*
 * Live IMUs: one interface over IMU backends (Linux IIO through sysfs and
 * /dev/iio:deviceN, the synthetic fake IMU). Samples come out in SI units
 * (sp_imu.h) stamped on CLOCK_MONOTONIC, the clock camera frames use.
 */
#ifndef SUNPROBE_SP_IMU_DEVICE_H
#define SUNPROBE_SP_IMU_DEVICE_H

#include <stddef.h>
#include <stdint.h>

#include "sp_common.h"
#include "sp_imu.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Bit for a sensor in sp_imu_desc.sensors: SP_IMU_SENSOR_BIT(SP_IMU_GYRO). */
#define SP_IMU_SENSOR_BIT(sensor) (1u << (unsigned)(sensor))

typedef struct sp_imu_desc {
    char backend[16];   /* "iio", "fake" */
    char id[64];        /* what sp_imu_device_settings.device accepts: "iio:device0", "fake" */
    char name[64];      /* the device's own name (IIO "name" attribute) */
    unsigned sensors;   /* SP_IMU_SENSOR_BIT of each sensor kind present */
    char channels[256]; /* channel names, space separated ("anglvel_x ... timestamp") */
    double rate_hz;     /* current sampling rate, 0 when unknown */
    char rates[96];     /* available rates as the device lists them, "" when unknown */
    int buffered;       /* can stream through a kernel buffer */
} sp_imu_desc;

typedef struct sp_imu_device_settings {
    const char *device;  /* id or name; "fake"; NULL = first found; borrowed for open */
    const char *backend; /* force a backend; NULL picks the one that knows `device` */
    double rate_hz;      /* 0: leave the device's rate (fake: 200) */
    int mode;            /* 0 auto (buffered when possible), 1 buffered only, 2 polling only */
} sp_imu_device_settings;

typedef struct sp_imu_device_info {
    sp_imu_desc desc;
    double rate_hz;      /* rate in use, 0 when unknown */
    int buffered;        /* 1 kernel buffer, 0 polling sysfs */
    int kernel_timestamps; /* samples carry the kernel's timestamps (else stamped at read) */
} sp_imu_device_info;

/*
 * An IMU backend. read() copies up to `max` samples into `out`, waiting at most
 * timeout_ms for the first; 0 with *count (possibly 0), -ENODEV when the device
 * went away.
 */
typedef struct sp_imu_ops {
    const char *name;
    int (*enumerate)(sp_imu_desc *out, size_t max, size_t *count);
    int (*claims)(const char *device);
    int (*open)(void **ctx, const sp_imu_device_settings *s, sp_imu_device_info *info);
    int (*start)(void *ctx);
    int (*read)(void *ctx, sp_imu_sample *out, size_t max, int timeout_ms, size_t *count);
    int (*stop)(void *ctx);
    void (*close)(void *ctx);
} sp_imu_ops;

SP_API const sp_imu_ops *const *sp_imu_backends(size_t *count);
SP_API const sp_imu_ops *sp_imu_backend_find(const char *name);
/* Every backend's IMUs; *count is the total found (may exceed max); the fake IMU last. */
SP_API int sp_imu_device_enumerate(sp_imu_desc *out, size_t max, size_t *count);

typedef struct sp_imu_device sp_imu_device;

SP_API void sp_imu_device_default_settings(sp_imu_device_settings *s);
/* Opens and configures, not streaming yet. The caller owns *out (sp_imu_device_close). */
SP_API int sp_imu_device_open(sp_imu_device **out, const sp_imu_device_settings *s);
SP_API const sp_imu_device_info *sp_imu_device_get_info(const sp_imu_device *imu);
SP_API int sp_imu_device_start(sp_imu_device *imu);
/* See sp_imu_ops.read; `out` is the caller's storage for `max` samples. */
SP_API int sp_imu_device_read(sp_imu_device *imu, sp_imu_sample *out, size_t max, int timeout_ms, size_t *count);
SP_API int sp_imu_device_stop(sp_imu_device *imu);
SP_API void sp_imu_device_close(sp_imu_device **imu);

#ifdef __cplusplus
}
#endif
#endif
