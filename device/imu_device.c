/* SPDX-License-Identifier: MIT */
/* IMU registry (a static array of backend tables) and the public sp_imu_device wrapper around one backend. */
#include "sunprobe/sp_imu_device.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "device/backends.h"

static const sp_imu_ops *const backends[] = {
    &sp_imu_iio_ops,
    &sp_imu_fake_ops,
};
#define N_BACKENDS (sizeof(backends) / sizeof(backends[0]))

struct sp_imu_device {
    const sp_imu_ops *ops;
    void *ctx;
    sp_imu_device_info info;
    int streaming;
};

const sp_imu_ops *const *sp_imu_backends(size_t *count)
{
    if (count)
        *count = N_BACKENDS;
    return backends;
}

const sp_imu_ops *sp_imu_backend_find(const char *name)
{
    for (size_t i = 0; name && i < N_BACKENDS; i++)
        if (!strcmp(backends[i]->name, name))
            return backends[i];
    return NULL;
}

int sp_imu_device_enumerate(sp_imu_desc *out, size_t max, size_t *count)
{
    if (!count || (max && !out))
        return -EINVAL;
    size_t total = 0;
    for (size_t i = 0; i < N_BACKENDS; i++) {
        size_t n = 0, room = total < max ? max - total : 0;
        int err = backends[i]->enumerate(room ? out + total : NULL, room, &n);
        if (err < 0)
            sp_log(SP_LOG_WARN, "imu", "%s: enumeration failed: %s", backends[i]->name, sp_strerror(err));
        else
            total += n;
    }
    *count = total;
    return 0;
}

void sp_imu_device_default_settings(sp_imu_device_settings *s)
{
    if (s)
        memset(s, 0, sizeof(*s));
}

static int pick_backend(const sp_imu_device_settings *s, const sp_imu_ops **ops)
{
    if (s->backend) {
        *ops = sp_imu_backend_find(s->backend);
        return *ops ? 0 : -ENOENT;
    }
    for (size_t i = 0; i < N_BACKENDS; i++)
        if (backends[i]->claims(s->device)) {
            *ops = backends[i];
            return 0;
        }
    sp_log(SP_LOG_ERROR, "imu", "no IMU backend knows '%s'", s->device ? s->device : "(first IMU)");
    return -ENOENT;
}

int sp_imu_device_open(sp_imu_device **out, const sp_imu_device_settings *s)
{
    if (!out || !s)
        return -EINVAL;
    *out = NULL;
    if (!(s->rate_hz >= 0 && s->rate_hz <= 1e5) || s->mode < 0 || s->mode > 2)
        return -EINVAL;
    const sp_imu_ops *ops = NULL;
    int err = pick_backend(s, &ops);
    if (err < 0)
        return err;
    sp_imu_device *imu = calloc(1, sizeof(*imu));
    if (!imu)
        return -ENOMEM;
    imu->ops = ops;
    err = ops->open(&imu->ctx, s, &imu->info);
    if (err < 0) {
        free(imu);
        return err;
    }
    sp_dev_copy_string(imu->info.desc.backend, sizeof(imu->info.desc.backend), ops->name);
    *out = imu;
    return 0;
}

const sp_imu_device_info *sp_imu_device_get_info(const sp_imu_device *imu)
{
    return imu ? &imu->info : NULL;
}

int sp_imu_device_start(sp_imu_device *imu)
{
    if (!imu)
        return -EINVAL;
    if (imu->streaming)
        return 0;
    int err = imu->ops->start(imu->ctx);
    if (err == 0)
        imu->streaming = 1;
    return err;
}

int sp_imu_device_read(sp_imu_device *imu, sp_imu_sample *out, size_t max, int timeout_ms, size_t *count)
{
    if (!imu || !out || !count || max == 0 || timeout_ms < 0)
        return -EINVAL;
    *count = 0;
    if (!imu->streaming)
        return -EINVAL;
    return imu->ops->read(imu->ctx, out, max, timeout_ms, count);
}

int sp_imu_device_stop(sp_imu_device *imu)
{
    if (!imu)
        return -EINVAL;
    if (!imu->streaming)
        return 0;
    imu->streaming = 0;
    return imu->ops->stop(imu->ctx);
}

void sp_imu_device_close(sp_imu_device **imu)
{
    if (!imu || !*imu)
        return;
    sp_imu_device *d = *imu;
    if (d->streaming)
        (void)sp_imu_device_stop(d);
    if (d->ctx)
        d->ops->close(d->ctx);
    free(d);
    *imu = NULL;
}
