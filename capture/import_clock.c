/* SPDX-License-Identifier: MIT */
/*
 * The IMU log's clock for the importers: an app's log read whole, its times mapped onto the frame
 * clock (frame times, the recording's start, or as they are), plus --imu-offset auto (IMPORT.md).
 */
#include "capture/import_ctx.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "sp_config.h"

static int adopt_log_times(import_ctx *c)
{
    if (c->times || !c->log.nframes)
        return 0;
    c->times = malloc(c->log.nframes * sizeof(*c->times));
    if (!c->times)
        return -ENOMEM;
    memcpy(c->times, c->log.frame_ns, c->log.nframes * sizeof(*c->times));
    c->ntimes = c->log.nframes;
    c->times_src = c->imu_src;
    return 0;
}

/*
 * IMU times share the clock of the frame times when there are any (the CSV's or the log's own);
 * else an epoch log is mapped through the recording's start, and a video-clock log is taken as it
 * is. The offset is added last.
 */
static int imu_base(import_ctx *c, int64_t *base, const char **what)
{
    int64_t t0 = 0;
    const char *how = "t = 0 is the first frame";
    if (c->times) {
        t0 = c->times[0];
        how = "on the clock of the frame times (t = their first)";
    } else if (c->log_loaded && c->log.clock == SP_CLOCK_EPOCH) {
        if (!c->log.has_start)
            return FAIL(c, SP_ECORRUPT, "%s: a %s log on the epoch clock, and nothing gives the video's start time: "
                        "give --frame-times on the same clock", c->imu_src, c->log.format);
        t0 = c->log.start_ns;
        how = c->log.start_from;
    }
    *base = -t0;
    *what = how;
    return 0;
}

int sp_import_open_imu(import_ctx *c)
{
    int64_t base = 0;
    const char *how = NULL;
    int rc = imu_base(c, &base, &how);
    if (rc)
        return rc;
    int64_t shift = llround(c->offset_s * 1e9) + base;
    snprintf(c->rep->imu_clock, sizeof(c->rep->imu_clock), "%s log, %s, offset %+.3f s%s",
             c->log_loaded ? c->log.format : "sunprobe CSV", how, c->offset_s,
             c->s->imu_offset_auto ? " (estimated)" : "");
    if (c->log_loaded) {
        sp_import_imu_from_log(&c->imu, &c->log, shift);
        return 0;
    }
    return sp_import_imu_open(&c->imu, c->imu_src, shift, c->rep->message, sizeof(c->rep->message));
}

/*
 * An epoch log's clock is UTC, so the first frame's time on it (the frame times', else the recording's
 * start) is the capture's utc_start. A time before 2000 is a device clock never set, not a date.
 */
void sp_import_log_extra(const import_ctx *c, char *utc, size_t n, sp_import_meta_extra *x)
{
    memset(x, 0, sizeof(*x));
    if (!c->log_loaded)
        return;
    x->has_location = c->log.has_location;
    memcpy(x->location, c->log.location, sizeof(x->location));
    int64_t t0 = c->times ? c->times[0] : c->log.start_ns;
    if (c->log.clock != SP_CLOCK_EPOCH || (!c->times && !c->log.has_start))
        return;
    time_t sec = (time_t)(t0 / 1000000000);
    struct tm tm;
    if (t0 < INT64_C(946684800000000000) || !gmtime_r(&sec, &tm)) {
        sp_log(SP_LOG_WARN, "import", "%s: the first frame's time on its clock is not a date after 2000: no utc_start",
               c->imu_src);
        return;
    }
    snprintf(utc, n, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday, tm.tm_hour,
             tm.tm_min, tm.tm_sec, (int)(t0 % 1000000000 / 1000000));
    x->utc_start = utc;
}

/* The gyro on the frame clock before any offset, for --imu-offset auto. */
static int collect_gyro(import_ctx *c, sp_import_sync *sy)
{
    int64_t base = 0;
    const char *how = NULL;
    int rc = imu_base(c, &base, &how);
    for (size_t i = 0; !rc && c->log_loaded && i < c->log.n; i++)
        if (c->log.s[i].sensor == SP_IMU_GYRO)
            rc = sp_import_sync_gyro(sy, c->log.s[i].timestamp_ns + base, c->log.s[i].v);
    if (rc || c->log_loaded)
        return rc;
    sp_import_imu r;
    const sp_imu_sample *smp;
    rc = sp_import_imu_open(&r, c->imu_src, base, c->rep->message, sizeof(c->rep->message));
    while (!rc && (rc = sp_import_imu_peek(&r, &smp)) == 0) {
        if (smp->sensor == SP_IMU_GYRO)
            rc = sp_import_sync_gyro(sy, smp->timestamp_ns, smp->v);
        sp_import_imu_pop(&r);
    }
    sp_import_imu_close(&r);
    return rc == SP_EOS ? 0 : rc;
}

/* The frames' motion, decoded but not stored, at the times the import will give them. */
static int collect_motion(import_ctx *c, sp_import_sync *sy)
{
    int rc = 0;
    c->dry = 1;
    for (c->index = 0; !rc && (!c->s->max_frames || c->index < c->s->max_frames); c->index++) {
        if (c->s->cancel && *c->s->cancel)
            rc = FAIL(c, -ECANCELED, "interrupted while estimating the IMU offset");
        sp_frame f;
        int64_t t = 0;
        if (!rc && (rc = sp_import_next_frame(c, &f)) == SP_EOS) {
            rc = 0;
            break;
        }
        if (!rc)
            rc = sp_import_frame_time(c, c->index, &t);
        if (!rc && !c->rgb_fresh && !sp_jpeg_available())
            rc = FAIL(c, SP_EDISABLED, "%s: --imu-offset auto needs the frames' pixels: rebuild with -Djpeg=enabled",
                      c->s->input);
        if (!rc && c->rgb_fresh && (c->index == 0 || (f.width == c->rep->width && f.height == c->rep->height)))
            rc = sp_import_sync_frame(sy, c->rgb, f.width, f.height, t);
        if (c->index == 0) {
            c->rep->width = f.width;
            c->rep->height = f.height;
        }
        c->rep->last_frame_ns = t;
    }
    c->dry = 0;
    return rc;
}

/* --imu-offset auto: one pass over frames and gyro, then everything rewound for the import itself. */
int sp_import_estimate_offset(import_ctx *c)
{
    sp_import_sync sy = { 0 };
    int rc = collect_gyro(c, &sy);
    if (!rc)
        rc = collect_motion(c, &sy);
    if (!rc)
        rc = sp_import_sync_estimate(&sy, 0, c->s->imu_offset_range_s, &c->offset_s, &c->rep->imu_offset_corr,
                                     c->rep->message, sizeof(c->rep->message));
    sp_import_sync_free(&sy);
    c->rep->imu_offset_s = c->offset_s;
    c->index = 0;
    c->rep->last_frame_ns = 0;
    c->rep->width = c->rep->height = 0;
    c->rep->frames_copied = 0;
    c->pts_fixed = 0;
#if HAVE_OPENCV
    if (!rc && c->video) {
        sp_cv_video_close(&c->video);
        rc = sp_import_open_video(c, c->video_path);
    }
#endif
    return rc;
}

/* An app's log is read whole; its own frame times (OpenCamera-Sensors) stand in for --frame-times. */
int sp_import_load_imu_log(import_ctx *c)
{
    const char *path = c->imu_src = c->s->imu_csv;
    int fmt;
    int rc = sp_import_log_detect(path, (int)c->s->imu_format, &fmt, c->rep->message, sizeof(c->rep->message));
    if (rc || fmt == SP_IMPORT_IMU_SUNPROBE)
        return rc;
    rc = sp_import_log_load(&c->log, path, fmt, c->s->output, 0, c->rep->message, sizeof(c->rep->message));
    c->log_loaded = !rc;
    return rc ? rc : adopt_log_times(c);
}
