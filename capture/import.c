/* SPDX-License-Identifier: MIT */
/*
 * Importers: image sequence or video (+ IMU CSV, frame times, META JSON) -> .spcap.
 * The capture is written to "<out>.partial" and renamed into place only when
 * complete, so a failed or interrupted import never leaves a file that looks valid.
 * Memory is bounded by one decoded frame, one encoded frame and one IMU batch,
 * plus the list of input file names, the frame-times table and an app's IMU log
 * (read whole). Frames are read in import_read.c, the IMU clock set in import_clock.c.
 */
#include "sunprobe/sp_import.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "capture/container_format.h"
#include "capture/import_csv.h"
#include "capture/import_ctx.h"
#include "capture/import_internal.h"
#include "capture/opencv_shim.h"
#include "common/file_util.h"
#include "common/jpeg.h"
#include "common/json.h"
#include "sp_config.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_meta.h"

#define MAX_IMU_OFFSET_S 1e6

int sp_import_fail(char *msg, size_t msg_size, int rc, const char *fmt, ...)
{
    if (msg && msg_size && msg[0] == 0) { /* the first message names the cause, later ones consequences */
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(msg, msg_size, fmt, ap);
        va_end(ap);
    }
    return rc;
}

int sp_import_to_camera_preset(enum sp_import_to_camera preset, double q[4])
{
    /* iOS and Android share the sensor axes; a back camera looks along -z (180 deg about x), a front
     * camera along +z with its image's right on the phone's left (180 deg about z) */
    static const double table[][4] = { { 1, 0, 0, 0 }, { 0, 0, 0, 1 }, { 0, 1, 0, 0 }, { 0, 0, 0, 1 }, { 0, 1, 0, 0 } };
    if (preset < SP_IMPORT_TO_CAMERA_IDENTITY || preset > SP_IMPORT_TO_CAMERA_IOS_BACK)
        return -EINVAL;
    memcpy(q, table[preset - SP_IMPORT_TO_CAMERA_IDENTITY], sizeof(table[0]));
    return 0;
}

void sp_import_default_settings(sp_import_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->store = SP_IMPORT_STORE_JPEG;
    s->quality = 92;
    s->imu_batch = 256;
    s->imu_offset_range_s = 2.0;
}

static int push_time(import_ctx *c, size_t *cap, int64_t t)
{
    if (c->ntimes == *cap) {
        size_t n = *cap ? *cap * 2 : 1024;
        int64_t *p = realloc(c->times, n * sizeof(*p));
        if (!p)
            return -ENOMEM;
        c->times = p;
        *cap = n;
    }
    c->times[c->ntimes++] = t;
    return 0;
}

int sp_import_load_frame_times(import_ctx *c, const char *path)
{
    sp_csv csv;
    int rc = sp_csv_open(&csv, path, c->rep->message, sizeof(c->rep->message));
    if (rc)
        return rc;
    int col_t, col_tns, expo_col[3];
    size_t cap = 0;
    rc = sp_csv_time_columns(&csv, &col_t, &col_tns);
    int expo = rc ? 0 : c->s->exposure_csv ? 0 : sp_import_exposure_columns(&csv, expo_col);
    rc = expo < 0 ? expo : rc;
    c->expo.path = path;
    while (!rc && (rc = sp_csv_next(&csv)) == 0) {
        int64_t t;
        rc = sp_csv_time_ns(&csv, col_t, col_tns, &t);
        if (!rc && c->ntimes && t <= c->times[c->ntimes - 1])
            rc = sp_csv_fail(&csv, SP_ECORRUPT, "frame time is not after the previous row's (times must increase)");
        if (!rc)
            rc = push_time(c, &cap, t);
        if (!rc && expo)
            rc = sp_import_exposure_row(&c->expo, &csv, expo_col);
    }
    if (rc == SP_EOS)
        rc = c->ntimes ? 0 : sp_csv_fail(&csv, SP_ENODATA, "no frame times after the header");
    c->times_src = path;
    sp_csv_close(&csv);
    return rc;
}

static int same_file(const char *path, const struct stat *st)
{
    struct stat in;
    return stat(path, &in) == 0 && in.st_dev == st->st_dev && in.st_ino == st->st_ino;
}

/* Refuses an output that is one of the inputs, by device and inode (so links and other spellings too). */
static int check_output_not_input(import_ctx *c)
{
    const sp_import_settings *s = c->s;
    struct stat out;
    if (stat(s->output, &out) != 0)
        return 0; /* not there yet: cannot be an input */
    const char *named[] = { s->input, s->frame_times_csv, s->imu_csv, s->meta_json, s->exposure_csv };
    const char *hit = NULL;
    for (size_t i = 0; !hit && i < sizeof(named) / sizeof(named[0]); i++)
        if (named[i] && same_file(named[i], &out))
            hit = named[i];
    for (size_t i = 0; !hit && i < c->images.count; i++)
        if (same_file(c->images.items[i], &out))
            hit = c->images.items[i];
    if (hit)
        return FAIL(c, -EINVAL, "%s: the output is the same file as the input %s; it would be overwritten",
                    s->output, hit);
    return 0;
}

int sp_import_frame_time(import_ctx *c, uint64_t i, int64_t *out)
{
    if (c->times) {
        if (i >= c->ntimes)
            return FAIL(c, SP_ECORRUPT, "%s: has %zu frame times, but the input has more frames",
                        c->times_src, c->ntimes);
        *out = c->times[i] - c->times[0];
        return 0;
    }
    if (c->pts_ok) {
        int64_t t = c->pts == INT64_MIN ? INT64_MIN : c->pts - c->pts0;
        if (i > 0 && t <= c->rep->last_frame_ns) { /* missing or repeated: keep the order, say so at the end */
            t = c->rep->last_frame_ns + llround(1e9 / c->fps);
            c->pts_fixed++;
        }
        *out = t;
        return 0;
    }
    *out = llround((double)i * 1e9 / c->fps);
    return 0;
}

static int write_batch(import_ctx *c)
{
    if (c->nbatch == 0)
        return 0;
    int rc = sp_capture_write_imu(c->writer, c->batch, c->nbatch);
    if (rc)
        return FAIL(c, rc, "%s: writing IMU samples: %s", c->partial.path, sp_strerror(rc));
    c->rep->imu_samples += c->nbatch;
    c->rep->imu_chunks++;
    c->nbatch = 0;
    return 0;
}

/* Writes every IMU sample up to limit_ns, so a frame follows the samples that precede it in file order. */
static int flush_imu(import_ctx *c, int64_t limit_ns)
{
    if (!c->imu.open)
        return 0;
    const sp_imu_sample *smp;
    int rc;
    while ((rc = sp_import_imu_peek(&c->imu, &smp)) == 0 && smp->timestamp_ns <= limit_ns) {
        if (c->imu_written++ == 0)
            c->imu_first = smp->timestamp_ns;
        c->imu_last = smp->timestamp_ns;
        c->batch[c->nbatch++] = *smp;
        sp_import_imu_pop(&c->imu);
        if (c->nbatch == c->s->imu_batch && (rc = write_batch(c)) != 0)
            return rc;
    }
    if (rc && rc != SP_EOS)
        return rc;
    return write_batch(c);
}

static int write_meta(import_ctx *c, uint32_t w, uint32_t h)
{
    if (c->meta.width && (c->meta.width != w || c->meta.height != h))
        return FAIL(c, SP_ECORRUPT, "%s: camera is %ux%u, but the frames are %ux%u", c->s->meta_json,
                    c->meta.width, c->meta.height, w, h);
    if (isfinite(c->meta.fps) && c->fps > 0 && fabs(c->meta.fps - c->fps) > 1e-3 * c->fps)
        sp_log(SP_LOG_WARN, "import", "%s: camera.fps %g replaced by %g, the rate of the timestamps",
               c->s->meta_json, c->meta.fps, c->fps);
    double q[4];
    int preset = sp_import_to_camera_preset(c->s->imu_to_camera, q) == 0;
    if (preset && sp_json_get(sp_json_get(c->meta_root, "imu"), "to_camera"))
        sp_log(SP_LOG_WARN, "import", "%s: imu.to_camera replaced by the --imu-to-camera preset", c->s->meta_json);
    char utc[40];
    sp_import_meta_extra extra;
    sp_import_log_extra(c, utc, sizeof(utc), &extra);
    sp_strbuf b = { 0 };
    int rc = sp_import_meta_build(c->meta_root, c->s->kind, c->s->input, w, h, c->fps, preset ? q : NULL, &extra, &b);
    if (!rc)
        rc = sp_capture_write_meta(c->writer, 0, b.data, b.len);
    sp_strbuf_free(&b);
    return rc ? FAIL(c, rc, "%s: writing metadata: %s", c->partial.path, sp_strerror(rc)) : 0;
}

/* ---- the run ---- */

static int check_settings(import_ctx *c)
{
    const sp_import_settings *s = c->s;
    if (!s->input || !*s->input || !s->output || !*s->output)
        return FAIL(c, -EINVAL, "an input and an output path are required");
    if (s->quality < 1 || s->quality > 100)
        return FAIL(c, -EINVAL, "JPEG quality %d is not in 1..100", s->quality);
    if (!isfinite(s->fps) || s->fps < 0 || (s->fps > 0 && s->fps < SP_IMPORT_MIN_FPS) || s->fps > SP_IMPORT_MAX_FPS)
        return FAIL(c, -EINVAL, "frame rate %g is not in [0.001, 10000]", s->fps);
    if (!isfinite(s->imu_offset_s) || fabs(s->imu_offset_s) > MAX_IMU_OFFSET_S)
        return FAIL(c, -EINVAL, "IMU offset %g s is not a finite number of at most 1e6 s", s->imu_offset_s);
    if (s->imu_offset_auto && !(s->imu_offset_range_s > 0 && s->imu_offset_range_s <= 60))
        return FAIL(c, -EINVAL, "IMU offset search range %g s is not in (0, 60]", s->imu_offset_range_s);
    c->offset_s = s->imu_offset_s;
    if (s->store != SP_IMPORT_STORE_JPEG && s->store != SP_IMPORT_STORE_RGB)
        return FAIL(c, -EINVAL, "unknown storage mode %d", (int)s->store);
    if (s->kind && strcmp(s->kind, "selfie") != 0 && strcmp(s->kind, "static") != 0)
        return FAIL(c, -EINVAL, "kind '%s' is neither 'selfie' nor 'static'", s->kind);
    if (s->imu_to_camera < SP_IMPORT_TO_CAMERA_KEEP || s->imu_to_camera > SP_IMPORT_TO_CAMERA_IOS_BACK)
        return FAIL(c, -EINVAL, "unknown IMU-to-camera preset %d", (int)s->imu_to_camera);
    if (s->imu_batch == 0 || s->imu_batch > (1u << 20))
        return FAIL(c, -EINVAL, "IMU batch size %u is not in 1..1048576", s->imu_batch);
    if (!s->overwrite && access(s->output, F_OK) == 0)
        return FAIL(c, -EEXIST, "%s: already exists (use --force to replace it)", s->output);
    c->batch = malloc(s->imu_batch * sizeof(*c->batch));
    return c->batch ? 0 : -ENOMEM;
}

/* A Sensor Logger export (a .zip, or a directory with Gyroscope.csv) as INPUT: its video and its IMU log. */
static int is_export(const char *in, const struct stat *st)
{
    char found[4096];
    sp_import_bundle b = { .path = in };
    if (S_ISDIR(st->st_mode))
        return sp_import_bundle_find(&b, sp_import_match_name, "Gyroscope.csv", found, sizeof(found));
    return S_ISREG(st->st_mode) && sp_import_is_zip(in);
}

static int open_export(import_ctx *c, const char *in)
{
    if (c->s->imu_csv)
        return FAIL(c, -EINVAL, "%s: a sensor-log export brings its own IMU log; drop --imu, or give its video as "
                    "INPUT", in);
    int rc = sp_import_log_load(&c->log, in, SP_IMPORT_IMU_SENSOR_LOGGER, c->s->output, 1, c->rep->message,
                                sizeof(c->rep->message));
    c->log_loaded = !rc;
    c->imu_src = in;
    return rc ? rc : sp_import_open_video(c, c->log.video);
}

static int open_input(import_ctx *c)
{
    const char *in = c->s->input;
    struct stat st;
    int rc;
    if (stat(in, &st) == 0) {
        if (is_export(in, &st))
            rc = open_export(c, in);
        else if (S_ISDIR(st.st_mode))
            rc = sp_import_list_directory(in, &c->images, c->rep->message, sizeof(c->rep->message));
        else if (sp_import_is_image_name(in))
            rc = sp_import_paths_add(&c->images, NULL, in);
        else
            rc = sp_import_open_video(c, in);
    } else if (strchr(in, '%')) {
        rc = sp_import_list_pattern(in, &c->images, c->rep->message, sizeof(c->rep->message));
    } else {
        rc = -errno;
        return FAIL(c, rc, "%s: %s", in, sp_strerror(rc));
    }
    if (!rc && !c->video)
        c->total = c->images.count;
    return rc;
}

/* --fps, else the rate of the frame-times CSV, else the video's, else camera.fps of the metadata. */
static int choose_fps(import_ctx *c)
{
    if (c->s->fps > 0) {
        c->fps = c->s->fps;
    } else if (c->times && c->ntimes >= 2) {
        double span = (double)(c->times[c->ntimes - 1] - c->times[0]);
        c->fps = span > 0 ? (double)(c->ntimes - 1) * 1e9 / span : 0;
    } else if (c->video_fps > 0) {
        c->fps = c->video_fps;
    } else if (isfinite(c->meta.fps) && c->meta.fps > 0) {
        c->fps = c->meta.fps;
    }
    if (!(c->fps > 0) && !c->times)
        return FAIL(c, -EINVAL, "%s: no frame rate known: give --fps, a frame-times CSV, or camera.fps in the "
                    "metadata", c->s->input);
    c->rep->fps = c->fps;
    return 0;
}

static int open_output(import_ctx *c)
{
    int rc = sp_partial_file_open(&c->partial, c->s->output);
    if (rc)
        return rc;
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    ws.sync = SP_SYNC_NONE; /* a conversion: one sync at the end is enough */
    ws.overwrite = 1;       /* a .partial left by an interrupted run is garbage */
    rc = sp_capture_writer_open(&c->writer, c->partial.path, &ws);
    if (rc) {
        rc = FAIL(c, rc, "%s: cannot create: %s", c->partial.path, sp_strerror(rc));
        sp_partial_forget(&c->partial); /* nothing of ours to remove */
    }
    return rc;
}

static int check_size(import_ctx *c, const sp_frame *f)
{
    if (c->index == 0) {
        c->rep->width = f->width;
        c->rep->height = f->height;
        return write_meta(c, f->width, f->height);
    }
    if (f->width == c->rep->width && f->height == c->rep->height)
        return 0;
    return FAIL(c, SP_EFORMAT, "%s: %ux%u, but the first frame is %ux%u",
                c->video ? c->s->input : c->images.items[c->index], f->width, f->height, c->rep->width,
                c->rep->height);
}

static void report_progress(import_ctx *c)
{
    if (!c->s->progress)
        return;
    uint64_t total = c->total;
    if (c->s->max_frames && (total == 0 || total > c->s->max_frames))
        total = c->s->max_frames;
    c->s->progress(c->s->progress_user, c->index, total);
}

/* A log whose span misses the frames' is on another clock or shifted: nothing downstream could use it. */
static int check_overlap(import_ctx *c)
{
    if (!c->imu_src)
        return 0;
    double f1 = (double)c->rep->last_frame_ns * 1e-9;
    if (!c->imu_written)
        return FAIL(c, SP_ENODATA, "%s: no IMU samples", c->imu_src);
    if (c->imu_first <= c->rep->last_frame_ns && c->imu_last >= 0)
        return 0;
    return FAIL(c, SP_ECORRUPT, "%s: the IMU log spans %.3f to %.3f s and the frames 0 to %.3f s on the video clock: "
                "they never overlap (%s); fix the clock with --imu-offset or --frame-times", c->imu_src,
                (double)c->imu_first * 1e-9, (double)c->imu_last * 1e-9, f1, c->rep->imu_clock);
}

static int import_frames(import_ctx *c)
{
    int rc = 0;
    while (!c->s->max_frames || c->index < c->s->max_frames) {
        if (c->s->cancel && *c->s->cancel)
            return FAIL(c, -ECANCELED, "interrupted after %llu frames", (unsigned long long)c->index);
        sp_frame f;
        if ((rc = sp_import_next_frame(c, &f)) == SP_EOS)
            break;
        if (!rc)
            rc = check_size(c, &f);
        if (!rc)
            rc = sp_import_frame_time(c, c->index, &f.timestamp_ns);
        if (!rc)
            rc = flush_imu(c, f.timestamp_ns);
        if (rc)
            return rc;
        if ((rc = sp_capture_write_frame(c->writer, &f)) != 0)
            return FAIL(c, rc, "%s: writing frame %llu: %s", c->partial.path, (unsigned long long)c->index,
                        sp_strerror(rc));
        c->rep->last_frame_ns = f.timestamp_ns;
        c->rep->frames = ++c->index;
        report_progress(c);
    }
    if (c->index == 0)
        return FAIL(c, SP_ENODATA, "%s: no frames", c->s->input);
    if (c->pts_fixed)
        sp_log(SP_LOG_WARN, "import", "%s: %d frames had no presentation time after the previous frame's; each was "
               "timed one nominal frame (1/%g s) after it", c->s->input, c->pts_fixed, c->fps);
    snprintf(c->rep->frame_clock, sizeof(c->rep->frame_clock), "%s",
             c->times ? "from the frame-times CSV" : c->pts_ok ? "the container's presentation times" : "i / fps");
    if (c->times && c->ntimes > c->index && !c->s->max_frames)
        sp_log(SP_LOG_WARN, "import", "%s: %zu frame times for %llu frames; the rest are ignored",
               c->s->frame_times_csv, c->ntimes, (unsigned long long)c->index);
    int rc2 = flush_imu(c, INT64_MAX); /* IMU samples after the last frame are kept too */
    return rc2 ? rc2 : check_overlap(c);
}

static int finish_output(import_ctx *c)
{
    int rc = sp_capture_writer_close(&c->writer);
    if (rc)
        return FAIL(c, rc, "%s: finishing the capture: %s", c->partial.path, sp_strerror(rc));
    if (c->s->cancel && *c->s->cancel) /* asked to stop after the last frame: the old OUT stays */
        return FAIL(c, -ECANCELED, "interrupted after the last frame; %s not replaced", c->s->output);
    rc = sp_partial_file_commit(&c->partial, c->s->overwrite ? SP_PARTIAL_REPLACE : 0);
    if (rc)
        return FAIL(c, rc, "%s: cannot rename to %s: %s", c->partial.path, c->s->output, sp_strerror(rc));
    return 0;
}

static void cleanup(import_ctx *c)
{
    if (c->writer)
        sp_capture_writer_close(&c->writer);
    sp_partial_file_abort(&c->partial); /* a no-op after the commit */
#if HAVE_OPENCV
    sp_cv_video_close(&c->video);
#endif
    sp_import_imu_close(&c->imu);
    sp_import_log_free(&c->log);
    sp_import_exposure_free(&c->expo);
    sp_import_paths_free(&c->images);
    sp_json_free(c->meta_root);
    sp_jpeg_buffer_free(&c->jpeg);
    free(c->times);
    free(c->batch);
    free(c->file_buf);
    free(c->rgb);
}

int sp_import_run(const sp_import_settings *s, sp_import_report *report)
{
    sp_import_report local;
    if (!report)
        report = &local;
    memset(report, 0, sizeof(*report));
    if (!s) {
        snprintf(report->message, sizeof(report->message), "no settings");
        return -EINVAL;
    }
    import_ctx c = { .s = s, .rep = report };
    sp_capture_meta_init(&c.meta);
    int rc = check_settings(&c);
    if (!rc)
        rc = open_input(&c);
    if (!rc)
        rc = check_output_not_input(&c);
    if (!rc && s->frame_times_csv)
        rc = sp_import_load_frame_times(&c, s->frame_times_csv);
    if (!rc && s->exposure_csv)
        rc = sp_import_exposure_load(&c.expo, s->exposure_csv, report->message, sizeof(report->message));
    if (!rc && s->imu_csv && !c.log_loaded)
        rc = sp_import_load_imu_log(&c);
    if (!rc && s->meta_json)
        rc = sp_import_meta_load(s->meta_json, &c.meta_root, &c.meta, report->message, sizeof(report->message));
    if (!rc)
        rc = choose_fps(&c);
    if (!rc && s->imu_csv && !c.imu_src)
        c.imu_src = s->imu_csv;
    if (!rc && s->imu_offset_auto && !c.imu_src)
        rc = FAIL(&c, -EINVAL, "--imu-offset auto needs an IMU log (--imu, or a sensor-log export as INPUT)");
    else if (!rc && s->imu_offset_auto)
        rc = sp_import_estimate_offset(&c);
    if (!rc && c.imu_src)
        rc = sp_import_open_imu(&c);
    if (!rc)
        rc = open_output(&c);
    if (!rc)
        rc = import_frames(&c);
    if (!rc)
        rc = finish_output(&c);
    if (rc && !report->message[0])
        snprintf(report->message, sizeof(report->message), "%s", sp_strerror(rc));
    cleanup(&c);
    return rc;
}
