/* SPDX-License-Identifier: MIT */
/*
 * Recorder: capture thread -> two SPSC rings (frame references, IMU batches) ->
 * writer thread -> .spcap. The capture thread only ever polls devices and
 * publishes into the rings; a full ring drops the item and counts it. The writer
 * sleeps on a semaphore the capture side posts (sem_post never blocks).
 */
#include "sunprobe/sp_recorder.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <semaphore.h>
#include <signal.h>
#include <stdio.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "capture/spsc_queue.h"
#include "common/clock.h"
#include "common/json.h"

#define MAX_IMU_BATCH 256
#define IMU_BATCH_AGE_NS 50000000 /* an IMU chunk at least every 50 ms, however few samples */

typedef struct imu_batch {
    uint32_t n;
    sp_imu_sample s[]; /* imu_batch samples */
} imu_batch;

struct sp_recorder {
    sp_recorder_settings s;
    char *path;
    sp_capture_writer *w;
    sp_spsc frames, imu;
    sem_t items;
    int sem_ready, threads_started, waited;
    pthread_t capture_thread, writer_thread;
    atomic_int stop_requested, capture_done, write_failed, finished;
    /* counters: each written by one thread, read anywhere */
    atomic_uint_fast64_t captured, written, dropped, discarded, imu_written, imu_dropped;
    int64_t first_ts, last_ts; /* writer thread */
    imu_batch *filling;        /* capture thread: the ring slot being filled, NULL if none */
    int64_t filling_since;
    sp_imu_sample *scratch;    /* capture thread: samples read while the IMU ring is full */
    sp_recorder_end end;       /* capture thread until joined */
    int error;
    int write_error;           /* writer thread until joined */
    uint64_t final_bytes;      /* file size after close */
};

void sp_recorder_default_settings(sp_recorder_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->kind = "selfie";
    s->frame_queue = 16;
    s->imu_queue = 128;
    s->imu_batch = 64;
    sp_capture_writer_default_settings(&s->writer);
}

const char *sp_recorder_end_name(sp_recorder_end end)
{
    static const char *const names[] = { "running", "duration reached", "stopped", "device lost",
                                         "disk full", "error", "source ended" };
    return (unsigned)end < sizeof(names) / sizeof(names[0]) ? names[end] : "?";
}

static void utc_now(char *buf, size_t size)
{
    struct timespec ts;
    struct tm tm;
    clock_gettime(CLOCK_REALTIME, &ts);
    gmtime_r(&ts.tv_sec, &tm);
    char secs[32];
    strftime(secs, sizeof(secs), "%Y-%m-%dT%H:%M:%S", &tm);
    int ms = (int)(ts.tv_nsec / 1000000) % 1000;
    if (snprintf(buf, size, "%s.%03dZ", secs, ms) >= (int)size)
        buf[0] = '\0';
}

static void meta_camera(sp_strbuf *b, const sp_camera_info *ci)
{
    sp_strbuf_printf(b, "\"camera\":{\"name\":");
    sp_strbuf_json_string(b, ci->desc.name);
    sp_strbuf_printf(b, ",\"driver\":"); /* FORMAT.md: the backend that delivered the frames */
    sp_strbuf_json_string(b, ci->desc.backend);
    sp_strbuf_printf(b, ",\"kernel_driver\":");
    sp_strbuf_json_string(b, ci->desc.driver);
    sp_strbuf_printf(b, ",\"id\":");
    sp_strbuf_json_string(b, ci->desc.id);
    sp_strbuf_printf(b, ",\"width\":%u,\"height\":%u,\"fps\":", ci->width, ci->height);
    sp_strbuf_json_number(b, ci->fps > 0 ? ci->fps : (double)NAN);
    sp_strbuf_printf(b, ",\"format\":\"%s\",\"exposure_locked\":%s,\"monotonic_timestamps\":%s}",
                     sp_pixfmt_name(ci->format), ci->exposure_locked ? "true" : "false",
                     ci->monotonic_timestamps ? "true" : "false");
}

static void meta_imu(sp_strbuf *b, const sp_imu_device_info *ii)
{
    sp_strbuf_printf(b, ",\"imu\":{\"name\":");
    sp_strbuf_json_string(b, ii->desc.name);
    sp_strbuf_printf(b, ",\"backend\":");
    sp_strbuf_json_string(b, ii->desc.backend);
    sp_strbuf_printf(b, ",\"id\":");
    sp_strbuf_json_string(b, ii->desc.id);
    sp_strbuf_printf(b, ",\"rate_hz\":");
    sp_strbuf_json_number(b, ii->rate_hz > 0 ? ii->rate_hz : (double)NAN);
    sp_strbuf_printf(b, ",\"buffered\":%s,\"kernel_timestamps\":%s}", ii->buffered ? "true" : "false",
                     ii->kernel_timestamps ? "true" : "false");
}

/* The opening META chunk (capture/FORMAT.md): kind, devices, start time. */
static int write_start_meta(sp_recorder *r)
{
    char utc[40];
    utc_now(utc, sizeof(utc));
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"kind\":");
    sp_strbuf_json_string(&b, r->s.kind);
    const sp_camera_info *ci = sp_camera_get_info(r->s.camera);
    char source[160];
    snprintf(source, sizeof(source), "%s:%s", ci->desc.backend, ci->desc.id);
    sp_strbuf_printf(&b, ",\"source\":");
    sp_strbuf_json_string(&b, source);
    sp_strbuf_printf(&b, ",\"utc_start\":\"%s\",", utc);
    meta_camera(&b, ci);
    if (r->s.imu)
        meta_imu(&b, sp_imu_device_get_info(r->s.imu));
    sp_strbuf_printf(&b, "}");
    int err = b.failed ? -ENOMEM : sp_capture_write_meta(r->w, sp_clock_monotonic_ns(), b.data, b.len);
    sp_strbuf_free(&b);
    return err;
}

static int check_settings(const sp_recorder_settings *s)
{
    if (!s->path || !s->camera || !s->kind || (strcmp(s->kind, "selfie") && strcmp(s->kind, "static")))
        return -EINVAL;
    if (!(s->duration_s >= 0 && s->duration_s < 1e7) || s->frame_queue == 0 || s->frame_queue > 4096 ||
        s->imu_queue == 0 || s->imu_queue > 65536 || s->imu_batch == 0 || s->imu_batch > MAX_IMU_BATCH ||
        s->writer_delay_us > 10000000)
        return -EINVAL;
    return 0;
}

int sp_recorder_open(sp_recorder **out, const sp_recorder_settings *s)
{
    if (!out || !s)
        return -EINVAL;
    *out = NULL;
    int err = check_settings(s);
    if (err < 0)
        return err;
    sp_recorder *r = calloc(1, sizeof(*r));
    if (!r)
        return -ENOMEM;
    r->s = *s;
    r->path = strdup(s->path);
    r->scratch = malloc(sizeof(sp_imu_sample) * s->imu_batch);
    err = r->path && r->scratch ? 0 : -ENOMEM;
    if (err == 0)
        err = sp_spsc_init(&r->frames, s->frame_queue, sizeof(sp_frame *));
    if (err == 0)
        err = sp_spsc_init(&r->imu, s->imu_queue, sizeof(imu_batch) + sizeof(sp_imu_sample) * s->imu_batch);
    if (err == 0)
        err = sem_init(&r->items, 0, 0) < 0 ? -errno : 0;
    r->sem_ready = err == 0;
    if (err == 0)
        err = sp_capture_writer_open(&r->w, s->path, &s->writer);
    if (err < 0) {
        sp_recorder_close(&r);
        return err;
    }
    r->s.path = r->path;
    *out = r;
    return 0;
}

/* ---- capture thread ---- */

static void wake_writer(sp_recorder *r)
{
    sem_post(&r->items);
}

static void push_frame(sp_recorder *r, sp_frame *f)
{
    atomic_fetch_add_explicit(&r->captured, 1, memory_order_relaxed);
    sp_frame **slot = sp_spsc_reserve(&r->frames);
    if (!slot) { /* the writer is behind: lose this frame, never wait */
        sp_frame_unref(&f);
        atomic_fetch_add_explicit(&r->dropped, 1, memory_order_relaxed);
        return;
    }
    *slot = f;
    sp_spsc_push(&r->frames);
    wake_writer(r);
}

static void publish_imu(sp_recorder *r)
{
    if (!r->filling)
        return;
    if (r->filling->n) {
        sp_spsc_push(&r->imu);
        wake_writer(r);
    }
    r->filling = NULL;
}

/* Reads what the IMU has now into the ring slot being filled (or counts it lost when the ring is full). */
static int poll_imu(sp_recorder *r)
{
    if (!r->filling && (r->filling = sp_spsc_reserve(&r->imu))) {
        r->filling->n = 0;
        r->filling_since = sp_clock_monotonic_ns();
    }
    uint32_t room = r->s.imu_batch - (r->filling ? r->filling->n : 0);
    sp_imu_sample *dst = r->filling ? r->filling->s + r->filling->n : r->scratch;
    size_t got = 0;
    int err = sp_imu_device_read(r->s.imu, dst, r->filling ? room : r->s.imu_batch, 0, &got);
    if (err < 0)
        return err;
    if (!r->filling) {
        atomic_fetch_add_explicit(&r->imu_dropped, got, memory_order_relaxed);
        return 0;
    }
    r->filling->n += (uint32_t)got;
    if (r->filling->n == r->s.imu_batch || sp_clock_monotonic_ns() - r->filling_since > IMU_BATCH_AGE_NS)
        publish_imu(r);
    return 0;
}

static void end_with(sp_recorder *r, sp_recorder_end end, int error)
{
    r->end = end;
    r->error = error;
}

/* One step: a frame (or a timeout), then the IMU. Returns 0 to go on, 1 when the recording is over. */
static int capture_step(sp_recorder *r, int64_t deadline)
{
    if (atomic_load(&r->stop_requested)) {
        end_with(r, SP_RECORDER_STOPPED, 0);
        return 1;
    }
    if (atomic_load(&r->write_failed))
        return 1; /* the writer recorded why */
    if (deadline && sp_clock_monotonic_ns() >= deadline) {
        end_with(r, SP_RECORDER_DURATION, 0);
        return 1;
    }
    sp_frame *f = NULL;
    int err = sp_camera_next(r->s.camera, r->s.imu ? 5 : 20, &f);
    if (err == 0)
        push_frame(r, f);
    else if (err == -ENODEV)
        end_with(r, SP_RECORDER_DEVICE_LOST, err);
    else if (err == SP_EOS)
        end_with(r, SP_RECORDER_SOURCE_END, 0);
    else if (err != -EAGAIN)
        end_with(r, SP_RECORDER_ERROR, err);
    if (err != 0 && err != -EAGAIN)
        return 1;
    if (r->s.imu && (err = poll_imu(r)) < 0) {
        end_with(r, err == -ENODEV ? SP_RECORDER_DEVICE_LOST : SP_RECORDER_ERROR, err);
        return 1;
    }
    return 0;
}

static void *capture_main(void *arg)
{
    sp_recorder *r = arg;
    int64_t deadline = 0;
    if (r->s.duration_s > 0)
        deadline = sp_clock_monotonic_ns() + (int64_t)(r->s.duration_s * 1e9);
    while (!capture_step(r, deadline)) {
    }
    publish_imu(r);
    (void)sp_camera_stop(r->s.camera);
    if (r->s.imu)
        (void)sp_imu_device_stop(r->s.imu);
    atomic_store_explicit(&r->capture_done, 1, memory_order_release);
    wake_writer(r);
    return NULL;
}

/* ---- writer thread ---- */

static int is_disk_full(int err)
{
    return err == -ENOSPC || err == -EFBIG || err == -EDQUOT;
}

static void write_failed(sp_recorder *r, int err)
{
    r->write_error = err;
    atomic_store(&r->write_failed, 1);
}

static void slow_down(const sp_recorder *r)
{
    if (r->s.writer_delay_us)
        usleep(r->s.writer_delay_us);
}

static void write_frame(sp_recorder *r, sp_frame *f)
{
    if (atomic_load_explicit(&r->write_failed, memory_order_relaxed)) {
        atomic_fetch_add_explicit(&r->discarded, 1, memory_order_relaxed);
        return;
    }
    int err = sp_capture_write_frame(r->w, f);
    if (err < 0) {
        write_failed(r, err);
        atomic_fetch_add_explicit(&r->discarded, 1, memory_order_relaxed);
        return;
    }
    if (atomic_load_explicit(&r->written, memory_order_relaxed) == 0)
        r->first_ts = f->timestamp_ns;
    r->last_ts = f->timestamp_ns;
    atomic_fetch_add_explicit(&r->written, 1, memory_order_relaxed);
    slow_down(r);
}

static void write_imu(sp_recorder *r, const imu_batch *b)
{
    if (atomic_load_explicit(&r->write_failed, memory_order_relaxed)) {
        atomic_fetch_add_explicit(&r->imu_dropped, b->n, memory_order_relaxed);
        return;
    }
    int err = sp_capture_write_imu(r->w, b->s, b->n);
    if (err < 0) {
        write_failed(r, err);
        atomic_fetch_add_explicit(&r->imu_dropped, b->n, memory_order_relaxed);
        return;
    }
    atomic_fetch_add_explicit(&r->imu_written, b->n, memory_order_relaxed);
    slow_down(r);
}

/* Writes the older of the two ring heads; 0 when both are empty. */
static int write_one(sp_recorder *r)
{
    sp_frame **fs = sp_spsc_peek(&r->frames);
    imu_batch *b = sp_spsc_peek(&r->imu);
    if (!fs && !b)
        return 0;
    if (fs && (!b || (*fs)->timestamp_ns <= b->s[0].timestamp_ns)) {
        sp_frame *f = *fs;
        sp_spsc_pop(&r->frames);
        write_frame(r, f);
        sp_frame_unref(&f);
    } else {
        write_imu(r, b);
        sp_spsc_pop(&r->imu);
    }
    return 1;
}

static void *writer_main(void *arg)
{
    sp_recorder *r = arg;
    for (;;) {
        struct timespec until;
        clock_gettime(CLOCK_REALTIME, &until);
        until.tv_nsec += 50000000;
        if (until.tv_nsec >= 1000000000) {
            until.tv_sec++;
            until.tv_nsec -= 1000000000;
        }
        (void)sem_timedwait(&r->items, &until);
        /* read `done` before looking at the rings: everything pushed before it is visible then */
        int done = atomic_load_explicit(&r->capture_done, memory_order_acquire);
        while (write_one(r)) {
        }
        if (done)
            break;
    }
    return NULL;
}

/* ---- lifecycle ---- */

static int spawn(sp_recorder *r)
{
    /* the threads take no process signals: SIGINT/SIGTERM reach the caller's handler */
    sigset_t all, old;
    sigfillset(&all);
    pthread_sigmask(SIG_SETMASK, &all, &old);
    int err = -pthread_create(&r->writer_thread, NULL, writer_main, r);
    if (err == 0) {
        err = -pthread_create(&r->capture_thread, NULL, capture_main, r);
        if (err < 0) { /* let the writer finish on its own */
            atomic_store(&r->capture_done, 1);
            wake_writer(r);
            pthread_join(r->writer_thread, NULL);
        }
    }
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    return err;
}

int sp_recorder_start(sp_recorder *r)
{
    if (!r || r->threads_started || r->waited)
        return -EINVAL;
    int err = sp_camera_start(r->s.camera);
    if (err == 0 && r->s.imu && (err = sp_imu_device_start(r->s.imu)) < 0)
        (void)sp_camera_stop(r->s.camera);
    /* the devices are streaming now, so the metadata can say what they settled on (exposure lock) */
    if (err == 0 && (err = write_start_meta(r)) < 0) {
        (void)sp_camera_stop(r->s.camera);
        if (r->s.imu)
            (void)sp_imu_device_stop(r->s.imu);
    }
    if (err == 0 && (err = spawn(r)) < 0) {
        (void)sp_camera_stop(r->s.camera);
        if (r->s.imu)
            (void)sp_imu_device_stop(r->s.imu);
    }
    if (err == 0)
        r->threads_started = 1;
    return err;
}

void sp_recorder_request_stop(sp_recorder *r)
{
    if (r)
        atomic_store(&r->stop_requested, 1);
}

int sp_recorder_finished(const sp_recorder *r)
{
    return !r || atomic_load(&((sp_recorder *)r)->capture_done);
}

void sp_recorder_get_stats(const sp_recorder *rc, sp_recorder_stats *st)
{
    if (!rc || !st)
        return;
    sp_recorder *r = (sp_recorder *)rc;
    memset(st, 0, sizeof(*st));
    st->frames_captured = atomic_load(&r->captured);
    st->frames_written = atomic_load(&r->written);
    st->frames_dropped = atomic_load(&r->dropped);
    st->frames_discarded = atomic_load(&r->discarded);
    st->device_dropped = sp_camera_dropped(r->s.camera);
    st->imu_samples_written = atomic_load(&r->imu_written);
    st->imu_samples_dropped = atomic_load(&r->imu_dropped);
    st->bytes_written = r->w ? sp_capture_writer_bytes(r->w) : r->final_bytes;
    st->end = r->waited ? r->end : SP_RECORDER_RUNNING;
    st->error = r->waited ? r->error : 0;
    if (st->frames_written > 1 && r->waited)
        st->duration_s = (double)(r->last_ts - r->first_ts) * 1e-9;
}

/* A closing META chunk with the counters, so a capture says how it ended and what it lost. */
static void write_end_meta(sp_recorder *r, const sp_recorder_stats *st)
{
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"recorder\":{\"end\":\"%s\",\"frames_written\":%llu,\"frames_dropped\":%llu,"
                     "\"device_dropped\":%llu,\"imu_samples_written\":%llu,\"imu_samples_dropped\":%llu}}",
                     sp_recorder_end_name(st->end), (unsigned long long)st->frames_written,
                     (unsigned long long)st->frames_dropped, (unsigned long long)st->device_dropped,
                     (unsigned long long)st->imu_samples_written, (unsigned long long)st->imu_samples_dropped);
    if (!b.failed)
        (void)sp_capture_write_meta(r->w, r->last_ts, b.data, b.len);
    sp_strbuf_free(&b);
}

int sp_recorder_wait(sp_recorder *r, sp_recorder_stats *stats)
{
    if (!r || !r->threads_started)
        return -EINVAL;
    if (!r->waited) {
        pthread_join(r->capture_thread, NULL);
        pthread_join(r->writer_thread, NULL);
        r->waited = 1;
        if (r->write_error) /* a failed write ends the recording whatever the capture side saw */
            end_with(r, is_disk_full(r->write_error) ? SP_RECORDER_DISK_FULL : SP_RECORDER_ERROR, r->write_error);
        sp_recorder_stats st;
        sp_recorder_get_stats(r, &st);
        if (!r->write_error)
            write_end_meta(r, &st);
        int err = sp_capture_writer_close(&r->w);
        struct stat sb;
        r->final_bytes = stat(r->path, &sb) == 0 ? (uint64_t)sb.st_size : 0;
        if (err < 0 && r->error == 0 && !r->write_error)
            end_with(r, is_disk_full(err) ? SP_RECORDER_DISK_FULL : SP_RECORDER_ERROR, err);
    }
    if (stats)
        sp_recorder_get_stats(r, stats);
    return r->error;
}

void sp_recorder_close(sp_recorder **pr)
{
    if (!pr || !*pr)
        return;
    sp_recorder *r = *pr;
    if (r->threads_started && !r->waited) {
        sp_recorder_request_stop(r);
        (void)sp_recorder_wait(r, NULL);
    }
    (void)sp_capture_writer_close(&r->w);
    sp_frame **f;
    while (r->frames.slots && (f = sp_spsc_peek(&r->frames))) { /* never started: nothing queued, but be safe */
        sp_frame_unref(f);
        sp_spsc_pop(&r->frames);
    }
    sp_spsc_free(&r->frames);
    sp_spsc_free(&r->imu);
    if (r->sem_ready)
        sem_destroy(&r->items);
    free(r->scratch);
    free(r->path);
    free(r);
    *pr = NULL;
}
