/* SPDX-License-Identifier: MIT */
/*
 * Linux IIO IMU backend in plain C: finds gyroscopes, accelerometers and
 * magnetometers under /sys/bus/iio/devices (name + in_anglvel_* / in_accel_* /
 * in_magn_* channels), applies each channel's scale and offset, and streams
 * either from the kernel buffer /dev/iio:deviceN (scan elements, with the
 * kernel's timestamp channel switched to CLOCK_MONOTONIC) or, where there is no
 * buffer, by polling the sysfs raw values. libiio is not needed.
 *
 * An IMU whose sensors are separate IIO devices (LSM6DSx, BMI2xx: one device for
 * the accelerometer, one for the gyroscope, often a third for a magnetometer) is
 * opened as a group, "NAME+NAME[+NAME]": each member by id or name, all read
 * together and their samples merged in time order. They must share one clock:
 * all kernel-stamped on the same clock, or all polled and stamped at read.
 */
#include "device/backends.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/clock.h"
#include "device/iio/iio_scan.h"
#include "device/node_scan.h"

#define SYSFS_ROOT "/sys/bus/iio/devices"
#define MAX_DEVICES 32
#define N_KINDS 3
#define RECORD_MAX 256 /* bytes of one scan record at most */
#define GROUP_SEP '+'  /* between the members of a split IMU's device string */

static const struct {
    const char *prefix; /* channel type in attribute names */
    enum sp_imu_sensor sensor;
    double to_si;       /* IIO units to sp_imu units: magnetometers report gauss, sunprobe microtesla */
} kinds[N_KINDS] = {
    { "anglvel", SP_IMU_GYRO, 1.0 },
    { "accel", SP_IMU_ACCEL, 1.0 },
    { "magn", SP_IMU_MAG, 100.0 },
};
static const char axes[3] = { 'x', 'y', 'z' };

typedef struct channel {
    int present;
    double scale, offset;
    int raw_fd;              /* polling */
    sp_iio_scan_type type;   /* buffered */
    uint32_t byte_offset;    /* in a buffered record */
} channel;

typedef struct iio_ctx {
    char dir[256];           /* sysfs directory of the device */
    char devnode[96];
    channel ch[N_KINDS][3];
    int buffered;
    int fd;                  /* /dev/iio:deviceN when buffered */
    sp_iio_scan_type ts_type;
    int has_ts;
    uint32_t ts_offset, record_size;
    int64_t ts_correction;   /* added to kernel stamps that are not CLOCK_MONOTONIC */
    uint8_t rec[RECORD_MAX * 32]; /* whole records read at once, plus a partial one */
    size_t rec_fill;
    double rate_hz;
    char clock[32];          /* what stamps the samples: the kernel clock's name, or "read time" */
    char label[64];          /* the device's name for messages */
} iio_ctx;

/* What an open device string is: one IIO device or several read as one IMU. */
typedef struct iio_group {
    iio_ctx *member[N_KINDS];
    size_t n;
    int buffered;            /* all members from their kernel buffers, else all polled */
    double rate_hz;          /* polling: the fastest member's rate */
    int64_t next_poll_ns;
} iio_group;

/* ---- small sysfs helpers ---- */

/* dir/name into path; -ENAMETOOLONG rather than a truncated path. */
static int join(char *path, size_t size, const char *dir, const char *name)
{
    int n = snprintf(path, size, "%s/%s", dir, name);
    return n < 0 || (size_t)n >= size ? -ENAMETOOLONG : 0;
}

static int read_attr(const char *dir, const char *name, char *buf, size_t size)
{
    char path[384];
    if (join(path, sizeof(path), dir, name) < 0)
        return -ENAMETOOLONG;
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return -errno;
    ssize_t n = read(fd, buf, size - 1);
    int err = n < 0 ? -errno : 0;
    close(fd);
    if (err < 0)
        return err;
    buf[n] = '\0';
    buf[strcspn(buf, "\n")] = '\0';
    return 0;
}

static int write_attr(const char *dir, const char *name, const char *value)
{
    char path[384];
    if (join(path, sizeof(path), dir, name) < 0)
        return -ENAMETOOLONG;
    int fd = open(path, O_WRONLY | O_TRUNC | O_CLOEXEC);
    if (fd < 0)
        return -errno;
    size_t len = strlen(value);
    ssize_t n = write(fd, value, len);
    int err = n < 0 ? -errno : (size_t)n != len ? -EIO : 0;
    close(fd);
    return err;
}

static int attr_exists(const char *dir, const char *name)
{
    char path[384];
    return join(path, sizeof(path), dir, name) == 0 && access(path, F_OK) == 0;
}

static int read_double(const char *dir, const char *name, double *out)
{
    char buf[64], *end;
    if (read_attr(dir, name, buf, sizeof(buf)) < 0)
        return -ENOENT;
    double v = strtod(buf, &end);
    if (end == buf || !isfinite(v))
        return -EINVAL;
    *out = v;
    return 0;
}

/* The first existing of the per-axis and the shared attribute, e.g. in_accel_x_scale then in_accel_scale. */
static int read_chan_attr(const char *dir, const char *type, char axis, const char *what, double *out)
{
    char name[64];
    snprintf(name, sizeof(name), "in_%s_%c_%s", type, axis, what);
    if (read_double(dir, name, out) == 0)
        return 0;
    snprintf(name, sizeof(name), "in_%s_%s", type, what);
    return read_double(dir, name, out);
}

/* ---- enumeration ---- */

static size_t list_devices(int *nums, size_t max)
{
    return sp_scan_numbered_entries(SYSFS_ROOT, "iio:device", nums, max);
}

static void append_word(char *list, size_t size, const char *word)
{
    size_t len = strlen(list);
    if (len + strlen(word) + 2 > size)
        return;
    snprintf(list + len, size - len, "%s%s", len ? " " : "", word);
}

static double device_rate(const char *dir)
{
    double r = 0;
    if (read_double(dir, "sampling_frequency", &r) == 0 && r > 0)
        return r;
    for (int k = 0; k < N_KINDS; k++) {
        char name[64];
        snprintf(name, sizeof(name), "in_%s_sampling_frequency", kinds[k].prefix);
        if (read_double(dir, name, &r) == 0 && r > 0)
            return r;
    }
    return 0;
}

/* Describes iio:deviceN; returns 0 when it has at least one motion channel. */
static int describe(int num, sp_imu_desc *d)
{
    char dir[160];
    snprintf(dir, sizeof(dir), SYSFS_ROOT "/iio:device%d", num);
    memset(d, 0, sizeof(*d));
    sp_dev_copy_string(d->backend, sizeof(d->backend), "iio");
    snprintf(d->id, sizeof(d->id), "iio:device%d", num);
    if (read_attr(dir, "name", d->name, sizeof(d->name)) < 0)
        d->name[0] = '\0';
    for (int k = 0; k < N_KINDS; k++)
        for (int a = 0; a < 3; a++) {
            char name[64], chan[32];
            snprintf(name, sizeof(name), "in_%s_%c_raw", kinds[k].prefix, axes[a]);
            if (!attr_exists(dir, name))
                continue;
            d->sensors |= SP_IMU_SENSOR_BIT(kinds[k].sensor);
            snprintf(chan, sizeof(chan), "%s_%c", kinds[k].prefix, axes[a]);
            append_word(d->channels, sizeof(d->channels), chan);
        }
    if (!d->sensors)
        return -ENODEV;
    if (attr_exists(dir, "scan_elements/in_timestamp_en"))
        append_word(d->channels, sizeof(d->channels), "timestamp");
    d->rate_hz = device_rate(dir);
    if (read_attr(dir, "sampling_frequency_available", d->rates, sizeof(d->rates)) < 0)
        d->rates[0] = '\0';
    char node[64];
    snprintf(node, sizeof(node), "/dev/iio:device%d", num);
    d->buffered = attr_exists(dir, "scan_elements") && access(node, R_OK) == 0;
    return 0;
}

static int iio_enumerate(sp_imu_desc *out, size_t max, size_t *count)
{
    int nums[MAX_DEVICES];
    size_t n_dev = list_devices(nums, MAX_DEVICES), n = 0;
    for (size_t i = 0; i < n_dev; i++) {
        sp_imu_desc d;
        if (describe(nums[i], &d) < 0)
            continue;
        if (n < max)
            out[n] = d;
        n++;
    }
    *count = n;
    return 0;
}

/* Finds the device by id ("iio:deviceN"), by name, or the first (NULL). */
static int resolve(const char *device, sp_imu_desc *found)
{
    sp_imu_desc d[MAX_DEVICES];
    size_t n = 0;
    iio_enumerate(d, MAX_DEVICES, &n);
    for (size_t i = 0; i < n && i < MAX_DEVICES; i++)
        if (!device || !strcmp(d[i].id, device) || !strcmp(d[i].name, device)) {
            *found = d[i];
            return 0;
        }
    return -ENODEV;
}

#define MAX_NAMES (N_KINDS + 1) /* one more than a group may have, to say so */

/* Splits a group's device string at '+' into member names; 0 when it is no group (or a name is empty,
 * too long, or there are more than MAX_NAMES). */
static size_t split_group(const char *device, char names[MAX_NAMES][64])
{
    if (!device || !strchr(device, GROUP_SEP))
        return 0;
    size_t n = 0;
    for (const char *p = device; n < MAX_NAMES; n++) {
        size_t len = strcspn(p, "+");
        if (len == 0 || len >= 64)
            return 0;
        memcpy(names[n], p, len);
        names[n][len] = '\0';
        if (!p[len])
            return n + 1;
        p += len + 1;
    }
    return 0;
}

static int iio_claims(const char *device)
{
    sp_imu_desc d;
    char names[MAX_NAMES][64];
    size_t n = split_group(device, names);
    if (n > 0) { /* a group when any member is an IIO device: open then names the missing ones */
        for (size_t i = 0; i < n; i++)
            if (!strncmp(names[i], "iio:device", 10) || resolve(names[i], &d) == 0)
                return 1;
        return 0;
    }
    if (device && !strncmp(device, "iio:device", 10))
        return 1;
    return resolve(device, &d) == 0;
}

/* ---- setup ---- */

static void close_raw_fds(iio_ctx *c)
{
    for (int k = 0; k < N_KINDS; k++)
        for (int a = 0; a < 3; a++)
            if (c->ch[k][a].raw_fd >= 0) {
                close(c->ch[k][a].raw_fd);
                c->ch[k][a].raw_fd = -1;
            }
}

static void close_member(iio_ctx *c)
{
    if (!c)
        return;
    close_raw_fds(c);
    if (c->fd >= 0)
        close(c->fd);
    free(c);
}

static void iio_close(void *ctx)
{
    iio_group *g = ctx;
    if (!g)
        return;
    for (size_t i = 0; i < g->n; i++)
        close_member(g->member[i]);
    free(g);
}

/* Scale and offset of every present channel; a channel without a scale is unusable. */
static int read_channels(iio_ctx *c)
{
    int any = 0;
    for (int k = 0; k < N_KINDS; k++)
        for (int a = 0; a < 3; a++) {
            channel *ch = &c->ch[k][a];
            char name[64];
            snprintf(name, sizeof(name), "in_%s_%c_raw", kinds[k].prefix, axes[a]);
            if (!attr_exists(c->dir, name))
                continue;
            if (read_chan_attr(c->dir, kinds[k].prefix, axes[a], "scale", &ch->scale) < 0) {
                sp_log(SP_LOG_WARN, "iio", "%s: %s has no scale; ignored", c->dir, name);
                continue;
            }
            if (read_chan_attr(c->dir, kinds[k].prefix, axes[a], "offset", &ch->offset) < 0)
                ch->offset = 0;
            ch->present = 1;
            any = 1;
        }
    return any ? 0 : -ENODEV;
}

static void set_rate(iio_ctx *c, double hz)
{
    char v[32];
    snprintf(v, sizeof(v), "%g", hz);
    if (write_attr(c->dir, "sampling_frequency", v) == 0)
        return;
    for (int k = 0; k < N_KINDS; k++) {
        char name[64];
        snprintf(name, sizeof(name), "in_%s_sampling_frequency", kinds[k].prefix);
        if (attr_exists(c->dir, name) && write_attr(c->dir, name, v) < 0)
            sp_log(SP_LOG_WARN, "iio", "%s: cannot set %s to %s", c->dir, name, v);
    }
}

/* Enables one scan element and reads its index and type; -ENOENT when the element does not exist. */
static int enable_element(iio_ctx *c, const char *chan, sp_iio_scan_type *type, long *index)
{
    char name[96], buf[64];
    snprintf(name, sizeof(name), "scan_elements/in_%s_en", chan);
    if (!attr_exists(c->dir, name))
        return -ENOENT;
    int err = write_attr(c->dir, name, "1");
    snprintf(name, sizeof(name), "scan_elements/in_%s_index", chan);
    if (err == 0)
        err = read_attr(c->dir, name, buf, sizeof(buf));
    if (err == 0)
        *index = strtol(buf, NULL, 10);
    snprintf(name, sizeof(name), "scan_elements/in_%s_type", chan);
    if (err == 0)
        err = read_attr(c->dir, name, buf, sizeof(buf));
    if (err == 0)
        err = sp_iio_parse_scan_type(buf, type);
    return err;
}

/* Kernel timestamps on CLOCK_MONOTONIC when the device lets us; else a fixed correction from its clock. */
static void choose_clock(iio_ctx *c)
{
    char clk[32] = "realtime";
    if (attr_exists(c->dir, "current_timestamp_clock")) {
        (void)write_attr(c->dir, "current_timestamp_clock", "monotonic");
        if (read_attr(c->dir, "current_timestamp_clock", clk, sizeof(clk)) < 0)
            snprintf(clk, sizeof(clk), "realtime");
    }
    c->ts_correction = 0;
    sp_dev_copy_string(c->clock, sizeof(c->clock), c->has_ts ? clk : "read time");
    if (c->has_ts && strcmp(clk, "monotonic") != 0) {
        sp_log(SP_LOG_WARN, "iio", "%s: timestamps on the %s clock; shifting them to monotonic", c->dir, clk);
        c->ts_correction = sp_clock_monotonic_ns() - sp_clock_realtime_ns();
    }
}

/* Gives the buffer a trigger of the device's own when it has none (e.g. "bmi160-dev0"). */
static void pick_trigger(iio_ctx *c, const char *devname, const char *id)
{
    char cur[64] = "";
    if (!attr_exists(c->dir, "trigger/current_trigger") ||
        (read_attr(c->dir, "trigger/current_trigger", cur, sizeof(cur)) == 0 && cur[0]))
        return;
    char want[160];
    int len = snprintf(want, sizeof(want), "%s-dev%s", devname, id + strlen("iio:device"));
    if (len < 0 || (size_t)len >= sizeof(want))
        return;
    DIR *d = opendir(SYSFS_ROOT);
    struct dirent *e;
    while (d && (e = readdir(d))) {
        char tdir[384], tname[96];
        if (strncmp(e->d_name, "trigger", 7) || join(tdir, sizeof(tdir), SYSFS_ROOT, e->d_name) < 0)
            continue;
        if (read_attr(tdir, "name", tname, sizeof(tname)) == 0 && !strcmp(tname, want))
            (void)write_attr(c->dir, "trigger/current_trigger", tname);
    }
    if (d)
        closedir(d);
}

typedef struct element {
    long index;
    sp_iio_scan_type type;
    int kind, axis; /* kind -1: the timestamp */
} element;

static int cmp_element(const void *a, const void *b)
{
    long x = ((const element *)a)->index, y = ((const element *)b)->index;
    return (x > y) - (x < y);
}

/* Enables our channels and the timestamp, and lays out one record as the kernel packs it. */
static int setup_scan(iio_ctx *c)
{
    element el[N_KINDS * 3 + 1];
    size_t n = 0;
    for (int k = 0; k < N_KINDS; k++)
        for (int a = 0; a < 3; a++) {
            char chan[32];
            snprintf(chan, sizeof(chan), "%s_%c", kinds[k].prefix, axes[a]);
            if (c->ch[k][a].present && enable_element(c, chan, &el[n].type, &el[n].index) == 0) {
                el[n].kind = k;
                el[n++].axis = a;
            } else {
                c->ch[k][a].present = 0; /* not in the buffer: not delivered in buffered mode */
            }
        }
    if (n == 0)
        return -ENODEV;
    if (enable_element(c, "timestamp", &el[n].type, &el[n].index) == 0) {
        el[n].kind = -1;
        el[n++].axis = 0;
    }
    qsort(el, n, sizeof(el[0]), cmp_element);
    sp_iio_scan_type types[N_KINDS * 3 + 1];
    uint32_t offsets[N_KINDS * 3 + 1];
    for (size_t i = 0; i < n; i++)
        types[i] = el[i].type;
    int size = sp_iio_layout(types, n, offsets);
    if (size <= 0 || size > RECORD_MAX)
        return -EINVAL;
    c->record_size = (uint32_t)size;
    for (size_t i = 0; i < n; i++) {
        if (el[i].kind < 0) {
            c->has_ts = 1;
            c->ts_type = el[i].type;
            c->ts_offset = offsets[i];
        } else {
            c->ch[el[i].kind][el[i].axis].type = el[i].type;
            c->ch[el[i].kind][el[i].axis].byte_offset = offsets[i];
        }
    }
    return 0;
}

static int setup_buffered(iio_ctx *c, const sp_imu_desc *d)
{
    if (attr_exists(c->dir, "buffer/enable"))
        (void)write_attr(c->dir, "buffer/enable", "0");
    int err = setup_scan(c);
    if (err < 0)
        return err;
    choose_clock(c);
    pick_trigger(c, d->name, d->id);
    if (attr_exists(c->dir, "buffer/length"))
        (void)write_attr(c->dir, "buffer/length", "256");
    c->fd = open(c->devnode, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    return c->fd < 0 ? -errno : 0;
}

static int setup_polling(iio_ctx *c)
{
    for (int k = 0; k < N_KINDS; k++)
        for (int a = 0; a < 3; a++) {
            char path[384], name[64];
            if (!c->ch[k][a].present)
                continue;
            snprintf(name, sizeof(name), "in_%s_%c_raw", kinds[k].prefix, axes[a]);
            if (join(path, sizeof(path), c->dir, name) < 0)
                return -ENAMETOOLONG;
            c->ch[k][a].raw_fd = open(path, O_RDONLY | O_CLOEXEC);
            if (c->ch[k][a].raw_fd < 0)
                return -errno;
        }
    if (!(c->rate_hz > 0))
        c->rate_hz = 100.0; /* the device does not say: poll at a rate any IMU reaches */
    sp_dev_copy_string(c->clock, sizeof(c->clock), "read time");
    return 0;
}

/* Opens one IIO device, from its kernel buffer when `buffered`, else polled. */
static int open_member(const sp_imu_desc *d, const sp_imu_device_settings *s, int buffered, iio_ctx **out)
{
    iio_ctx *c = calloc(1, sizeof(*c));
    if (!c)
        return -ENOMEM;
    c->fd = -1;
    for (int k = 0; k < N_KINDS; k++)
        for (int a = 0; a < 3; a++)
            c->ch[k][a].raw_fd = -1;
    snprintf(c->dir, sizeof(c->dir), SYSFS_ROOT "/%s", d->id);
    snprintf(c->devnode, sizeof(c->devnode), "/dev/%s", d->id);
    sp_dev_copy_string(c->label, sizeof(c->label), d->name[0] ? d->name : d->id);
    int err = read_channels(c);
    if (err == 0 && s->rate_hz > 0)
        set_rate(c, s->rate_hz);
    c->rate_hz = device_rate(c->dir);
    c->buffered = buffered;
    if (err == 0)
        err = c->buffered ? setup_buffered(c, d) : setup_polling(c);
    if (err < 0) {
        close_member(c);
        return err;
    }
    *out = c;
    return 0;
}

/* Finds each member of the device string (one, or a '+' group); logs which one is missing. */
static int resolve_members(const char *device, sp_imu_desc *d, size_t *n)
{
    char names[MAX_NAMES][64];
    *n = split_group(device, names);
    if (*n > N_KINDS) {
        sp_log(SP_LOG_ERROR, "iio", "'%s': a split IMU has at most %d members (accelerometer, gyroscope, "
               "magnetometer)", device, N_KINDS);
        return -EINVAL;
    }
    if (*n == 0) {
        *n = 1;
        if (resolve(device, &d[0]) == 0)
            return 0;
        sp_log(SP_LOG_ERROR, "iio", "no IIO motion sensor '%s'", device ? device : "(any)");
        return -ENODEV;
    }
    for (size_t i = 0; i < *n; i++)
        if (resolve(names[i], &d[i]) < 0) {
            sp_log(SP_LOG_ERROR, "iio", "no IIO motion sensor '%s' (member %zu of '%s')", names[i], i + 1, device);
            return -ENODEV;
        }
    for (size_t i = 0; i < *n; i++)
        for (size_t k = 0; k < i; k++)
            if (d[i].sensors & d[k].sensors || !strcmp(d[i].id, d[k].id)) {
                sp_log(SP_LOG_ERROR, "iio", "'%s': %s and %s both have the same kind of sensor; name each once",
                       device, d[k].name, d[i].name);
                return -EINVAL;
            }
    return 0;
}

/* One clock for every member, else the message names the two that differ. */
static int same_clock(const iio_group *g)
{
    for (size_t i = 1; i < g->n; i++)
        if (strcmp(g->member[i]->clock, g->member[0]->clock)) {
            const iio_ctx *a = g->member[0], *b = g->member[i];
            sp_log(SP_LOG_ERROR, "iio",
                   "%s is stamped by %s%s%s, %s by %s%s%s: not one clock (set both devices' "
                   "current_timestamp_clock, or poll both with the polling mode)",
                   a->label, a->has_ts ? "the kernel's " : "", a->clock, a->has_ts ? " clock" : "", b->label,
                   b->has_ts ? "the kernel's " : "", b->clock, b->has_ts ? " clock" : "");
            return -EINVAL; /* the combination asked for: `record` exits 1, naming both */
        }
    return 0;
}

/* Buffered when every member has a kernel buffer (and the mode allows it); a member without one makes
 * the whole group polled, so that all samples are stamped alike. */
static int group_buffered(const sp_imu_desc *d, size_t n, int mode)
{
    for (size_t i = 0; i < n; i++)
        if (!d[i].buffered) {
            if (mode == 1)
                sp_log(SP_LOG_ERROR, "iio", "%s (%s) has no kernel buffer (scan_elements + /dev/%s)", d[i].name,
                       d[i].id, d[i].id);
            else if (mode == 0 && n > 1)
                sp_log(SP_LOG_WARN, "iio", "%s has no kernel buffer: polling every member of the group",
                       d[i].name);
            return mode == 1 ? -ENOTSUP : 0;
        }
    return mode != 2;
}

static void describe_group(const iio_group *g, const sp_imu_desc *d, const char *device, sp_imu_device_info *info)
{
    memset(info, 0, sizeof(*info));
    info->desc = d[0];
    info->rate_hz = g->n > 1 ? (g->buffered ? 0 : g->rate_hz) : g->member[0]->rate_hz;
    info->buffered = g->buffered;
    info->kernel_timestamps = g->buffered && g->member[0]->has_ts;
    if (g->n == 1)
        return;
    sp_dev_copy_string(info->desc.id, sizeof(info->desc.id), device);
    info->desc.name[0] = info->desc.channels[0] = '\0';
    for (size_t i = 0; i < g->n; i++) {
        append_word(info->desc.name, sizeof(info->desc.name), d[i].name);
        append_word(info->desc.channels, sizeof(info->desc.channels), d[i].channels);
        info->desc.sensors |= d[i].sensors;
        if (d[i].sensors & SP_IMU_SENSOR_BIT(SP_IMU_GYRO)) /* the rate that matters for orientation */
            info->rate_hz = g->member[i]->rate_hz;
    }
    for (char *p = info->desc.name; *p; p++)
        if (*p == ' ')
            *p = GROUP_SEP;
    info->desc.buffered = g->buffered;
    info->desc.rate_hz = info->rate_hz;
    info->desc.rates[0] = '\0';
}

static int iio_open(void **out, const sp_imu_device_settings *s, sp_imu_device_info *info)
{
    sp_imu_desc d[N_KINDS];
    size_t n = 0;
    int err = resolve_members(s->device, d, &n);
    if (err < 0)
        return err;
    int buffered = group_buffered(d, n, s->mode);
    if (buffered < 0)
        return buffered;
    iio_group *g = calloc(1, sizeof(*g));
    if (!g)
        return -ENOMEM;
    g->buffered = buffered;
    for (size_t i = 0; i < n && err == 0; i++)
        if ((err = open_member(&d[i], s, buffered, &g->member[i])) == 0) {
            g->n = i + 1;
            g->rate_hz = fmax(g->rate_hz, g->member[i]->rate_hz);
        } else if (n > 1) {
            sp_log(SP_LOG_ERROR, "iio", "%s (%s): %s", d[i].name, d[i].id, sp_strerror(err));
        }
    if (err == 0)
        err = same_clock(g);
    if (err < 0) {
        iio_close(g);
        return err;
    }
    describe_group(g, d, s->device, info);
    *out = g;
    return 0;
}

static int iio_stop(void *ctx);

static int iio_start(void *ctx)
{
    iio_group *g = ctx;
    g->next_poll_ns = sp_clock_monotonic_ns();
    for (size_t i = 0; i < g->n; i++) {
        iio_ctx *c = g->member[i];
        c->rec_fill = 0;
        if (!c->buffered || !attr_exists(c->dir, "buffer/enable"))
            continue;
        int err = write_attr(c->dir, "buffer/enable", "1");
        if (err < 0) {
            (void)iio_stop(g); /* members started before this one */
            return err;
        }
    }
    return 0;
}

static int iio_stop(void *ctx)
{
    iio_group *g = ctx;
    int result = 0;
    for (size_t i = 0; i < g->n; i++) {
        iio_ctx *c = g->member[i];
        if (!c->buffered || !attr_exists(c->dir, "buffer/enable"))
            continue;
        int err = write_attr(c->dir, "buffer/enable", "0");
        if (err < 0 && err != -ENODEV && err != -ENOENT && result == 0)
            result = err;
    }
    return result;
}

/* ---- streaming ---- */

static size_t emit(const iio_ctx *c, int64_t ts, const double v[N_KINDS][3], sp_imu_sample *out, size_t room)
{
    size_t n = 0;
    for (int k = 0; k < N_KINDS && n < room; k++) {
        if (!c->ch[k][0].present && !c->ch[k][1].present && !c->ch[k][2].present)
            continue;
        sp_imu_sample *s = &out[n++];
        s->timestamp_ns = ts;
        s->sensor = (uint32_t)kinds[k].sensor;
        for (int a = 0; a < 3; a++)
            s->v[a] = c->ch[k][a].present ? (float)v[k][a] : 0.0f;
    }
    return n;
}

static size_t sensors_present(const iio_ctx *c)
{
    size_t n = 0;
    for (int k = 0; k < N_KINDS; k++)
        n += c->ch[k][0].present || c->ch[k][1].present || c->ch[k][2].present;
    return n;
}

static size_t decode_record(const iio_ctx *c, const uint8_t *rec, sp_imu_sample *out, size_t room)
{
    double v[N_KINDS][3] = { { 0 } };
    for (int k = 0; k < N_KINDS; k++)
        for (int a = 0; a < 3; a++) {
            const channel *ch = &c->ch[k][a];
            if (ch->present)
                v[k][a] = ((double)sp_iio_extract(&ch->type, rec + ch->byte_offset) + ch->offset) * ch->scale *
                          kinds[k].to_si;
        }
    int64_t ts = c->has_ts ? sp_iio_extract(&c->ts_type, rec + c->ts_offset) + c->ts_correction
                           : sp_clock_monotonic_ns();
    return emit(c, ts, v, out, room);
}

/* Reads what the kernel buffer holds, as many whole records as fit in `max` samples. */
static int drain_buffered(iio_ctx *c, sp_imu_sample *out, size_t max, size_t *count)
{
    size_t per = sensors_present(c), n = 0;
    size_t want = per ? max / per : 0;
    *count = 0;
    if (want == 0)
        return 0; /* no room left this time: the records wait in the kernel */
    if (want > sizeof(c->rec) / c->record_size)
        want = sizeof(c->rec) / c->record_size;
    size_t space = want * c->record_size - c->rec_fill;
    ssize_t got = read(c->fd, c->rec + c->rec_fill, space);
    if (got < 0)
        return errno == EAGAIN || errno == EINTR ? 0 : -errno;
    c->rec_fill += (size_t)got;
    size_t whole = c->rec_fill / c->record_size;
    for (size_t i = 0; i < whole; i++)
        n += decode_record(c, c->rec + i * c->record_size, out + n, max - n);
    size_t used = whole * c->record_size;
    memmove(c->rec, c->rec + used, c->rec_fill - used); /* keep a partial record for the next read */
    c->rec_fill -= used;
    *count = n;
    return 0;
}

static int read_raw(int fd, long long *out)
{
    char buf[32];
    ssize_t n = pread(fd, buf, sizeof(buf) - 1, 0);
    if (n <= 0)
        return n < 0 ? -errno : -EIO;
    buf[n] = '\0';
    char *end;
    *out = strtoll(buf, &end, 10);
    return end == buf ? -EIO : 0;
}

/* Samples every channel of one device now, stamped `ts`. */
static int sample_polled(iio_ctx *c, int64_t ts, sp_imu_sample *out, size_t max, size_t *count)
{
    double v[N_KINDS][3] = { { 0 } };
    for (int k = 0; k < N_KINDS; k++)
        for (int a = 0; a < 3; a++) {
            const channel *ch = &c->ch[k][a];
            long long raw = 0;
            if (!ch->present)
                continue;
            int err = read_raw(ch->raw_fd, &raw);
            if (err < 0)
                return err;
            v[k][a] = ((double)raw + ch->offset) * ch->scale * kinds[k].to_si;
        }
    *count = emit(c, ts, v, out, max);
    return 0;
}

/* Every member sampled at the group's rate, all with one read-time stamp. */
static int read_polled(iio_group *g, sp_imu_sample *out, size_t max, int timeout_ms, size_t *count)
{
    int64_t now = sp_clock_monotonic_ns();
    if (g->next_poll_ns > now) {
        if (g->next_poll_ns - now > (int64_t)timeout_ms * 1000000) {
            sp_clock_sleep_until(now + (int64_t)timeout_ms * 1000000);
            return 0;
        }
        sp_clock_sleep_until(g->next_poll_ns);
    }
    int64_t ts = sp_clock_monotonic_ns();
    for (size_t i = 0; i < g->n; i++) {
        size_t got = 0;
        int err = sample_polled(g->member[i], ts, out + *count, max - *count, &got);
        if (err < 0)
            return err;
        *count += got;
    }
    int64_t period = (int64_t)(1e9 / g->rate_hz);
    g->next_poll_ns += period;
    if (g->next_poll_ns < ts) /* fell behind: do not burst to catch up */
        g->next_poll_ns = ts + period;
    return 0;
}

/* Samples of several members in time order (each member's own already are: a merge by insertion). */
static void sort_by_time(sp_imu_sample *s, size_t n)
{
    for (size_t i = 1; i < n; i++) {
        sp_imu_sample v = s[i];
        size_t j = i;
        for (; j > 0 && s[j - 1].timestamp_ns > v.timestamp_ns; j--)
            s[j] = s[j - 1];
        s[j] = v;
    }
}

/* Waits for any member's kernel buffer, then drains every member that has records. */
static int read_buffered(iio_group *g, sp_imu_sample *out, size_t max, int timeout_ms, size_t *count)
{
    struct pollfd p[N_KINDS];
    for (size_t i = 0; i < g->n; i++) {
        if (max < sensors_present(g->member[i]))
            return -EINVAL; /* room for not even one record */
        p[i] = (struct pollfd){ .fd = g->member[i]->fd, .events = POLLIN };
    }
    int r = poll(p, g->n, timeout_ms);
    if (r < 0)
        return errno == EINTR ? 0 : -errno;
    for (size_t i = 0; i < g->n && r > 0; i++) {
        if (!p[i].revents)
            continue;
        size_t got = 0;
        int err = drain_buffered(g->member[i], out + *count, max - *count, &got);
        if (err < 0)
            return err;
        *count += got;
    }
    if (g->n > 1)
        sort_by_time(out, *count);
    return 0;
}

static int iio_read(void *ctx, sp_imu_sample *out, size_t max, int timeout_ms, size_t *count)
{
    iio_group *g = ctx;
    *count = 0;
    int err = g->buffered ? read_buffered(g, out, max, timeout_ms, count) : read_polled(g, out, max, timeout_ms, count);
    return err == -ENXIO ? -ENODEV : err;
}

const sp_imu_ops sp_imu_iio_ops = {
    .name = "iio",
    .enumerate = iio_enumerate,
    .claims = iio_claims,
    .open = iio_open,
    .start = iio_start,
    .read = iio_read,
    .stop = iio_stop,
    .close = iio_close,
};
