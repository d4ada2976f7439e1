/* SPDX-License-Identifier: MIT */
/*
 * Replay end to end through the reader's copy-free frame path: every pixel and
 * field survives (small frames held in the read-ahead, large ones read into the
 * pool frame, a pool that must grow), IMU samples interleave, a consumer that
 * holds every frame gets -EAGAIN and then the rest without loss, flipped bits in
 * pixel data fail (or are skipped and counted) and a torn tail is reported.
 */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_replay.h"

#define N_FRAMES 24
#define FRAME_NS 33333333

static char path[300];

/* Frame i: small RGB24 frames, large YUYV ones, and from frame 16 on larger still (the pool must grow). */
static void frame_shape(int i, enum sp_pixfmt *fmt, uint32_t *w, uint32_t *h)
{
    if (i % 3 == 0) {
        *fmt = SP_PIXFMT_RGB24, *w = 16, *h = 8;
    } else {
        *fmt = SP_PIXFMT_YUYV, *w = i >= 16 ? 960 : 320, *h = i >= 16 ? 540 : 180;
    }
}

static uint8_t pixel(int i, size_t k)
{
    return (uint8_t)(k * 7u + (size_t)i * 13u + (k >> 11));
}

static int write_capture(void)
{
    sp_capture_writer *w = NULL;
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    ws.sync = SP_SYNC_NONE;
    ws.overwrite = 1;
    int ret = sp_capture_writer_open(&w, path, &ws);
    const char *meta = "{\"kind\":\"selfie\",\"source\":\"test\"}";
    if (!ret)
        ret = sp_capture_write_meta(w, 0, meta, strlen(meta));
    uint8_t *buf = malloc(960 * 540 * 2);
    for (int i = 0; !ret && buf && i < N_FRAMES; i++) {
        sp_frame f = { .sequence = (uint64_t)i, .timestamp_ns = (int64_t)i * FRAME_NS, .exposure_us = 100.0f + (float)i,
                       .gain = 1.0f, .data = buf };
        frame_shape(i, &f.format, &f.width, &f.height);
        f.stride = sp_pixfmt_min_stride(f.format, f.width);
        f.bytes_used = f.capacity = sp_pixfmt_image_size(f.format, f.width, f.height, f.stride);
        for (size_t k = 0; k < f.bytes_used; k++)
            buf[k] = pixel(i, k);
        ret = sp_capture_write_frame(w, &f);
        sp_imu_sample imu[3];
        for (int k = 0; k < 3; k++)
            imu[k] = (sp_imu_sample){ f.timestamp_ns + k * 10000000, SP_IMU_GYRO, { (float)i, (float)k, 0.5f } };
        if (!ret)
            ret = sp_capture_write_imu(w, imu, 3);
    }
    free(buf);
    int cr = sp_capture_writer_close(&w);
    return ret ? ret : buf ? cr : -ENOMEM;
}

/* 1 when the frame is exactly what write_capture wrote for its sequence. */
static int frame_ok(const sp_frame *f)
{
    int i = (int)f->sequence;
    enum sp_pixfmt fmt;
    uint32_t w, h;
    frame_shape(i, &fmt, &w, &h);
    if (i < 0 || i >= N_FRAMES || f->format != fmt || f->width != w || f->height != h ||
        f->timestamp_ns != (int64_t)i * FRAME_NS || f->exposure_us != 100.0f + (float)i ||
        f->bytes_used != sp_pixfmt_image_size(fmt, w, h, sp_pixfmt_min_stride(fmt, w)))
        return 0;
    for (size_t k = 0; k < f->bytes_used; k++)
        if (f->data[k] != pixel(i, k))
            return 0;
    return 1;
}

typedef struct tally {
    int frames, bad_frames, imu, meta, eagain;
    int seen[N_FRAMES];
} tally;

/* Replays to the end (or an error); with hold the consumer keeps its frames until replay runs out of them. */
static int run(const sp_replay_settings *s, int hold, tally *t, sp_replay_stats *st)
{
    memset(t, 0, sizeof(*t));
    sp_source *src = NULL;
    int ret = sp_replay_open(&src, path, s);
    sp_frame *held[8] = { 0 };
    int nheld = 0;
    sp_event ev;
    while (!ret) {
        ret = sp_source_next(src, &ev);
        if (ret == -EAGAIN && nheld > 0) { /* the consumer has every frame: give them back */
            t->eagain++;
            while (nheld)
                sp_frame_unref(&held[--nheld]);
            ret = 0;
            continue;
        }
        if (ret)
            break;
        if (ev.type == SP_EVENT_FRAME) {
            t->frames++;
            t->bad_frames += !frame_ok(ev.frame);
            if (ev.frame->sequence < N_FRAMES)
                t->seen[ev.frame->sequence]++;
            if (hold && nheld == 8) /* frames of an outgrown pool do not count against the new one */
                while (nheld)
                    sp_frame_unref(&held[--nheld]);
            if (hold)
                held[nheld++] = ev.frame, ev.frame = NULL;
        }
        t->imu += ev.type == SP_EVENT_IMU;
        t->meta += ev.type == SP_EVENT_META;
        sp_event_release(&ev);
    }
    while (nheld)
        sp_frame_unref(&held[--nheld]);
    if (st && src)
        CHECK_EQ_INT(sp_replay_get_stats(src, st), 0);
    sp_source_close(&src);
    return ret;
}

static void test_clean(void)
{
    sp_replay_settings s;
    sp_replay_default_settings(&s);
    tally t;
    sp_replay_stats st;
    CHECK_EQ_INT(run(&s, 0, &t, &st), SP_EOS);
    CHECK_EQ_INT(t.frames, N_FRAMES);
    CHECK_EQ_INT(t.bad_frames, 0);
    CHECK_EQ_INT(t.imu, N_FRAMES * 3);
    CHECK_EQ_INT(t.meta, 1);
    CHECK_EQ_INT(st.corrupt_chunks, 0);
    CHECK(!st.truncated);

    /* a small pool and a consumer that keeps frames: -EAGAIN, then nothing lost or repeated */
    s.pool_frames = 3;
    s.reorder_window_ns = 0;
    CHECK_EQ_INT(run(&s, 1, &t, NULL), SP_EOS);
    CHECK(t.eagain > 0);
    CHECK_EQ_INT(t.frames, N_FRAMES);
    CHECK_EQ_INT(t.bad_frames, 0);
    for (int i = 0; i < N_FRAMES; i++)
        CHECK_EQ_INT(t.seen[i], 1);
}

/* Offsets of the FRAME chunks, from the plain reader. */
static int frame_offsets(uint64_t *off, uint32_t *size)
{
    sp_capture_reader *r = NULL;
    int n = 0;
    if (sp_capture_reader_open(&r, path, NULL))
        return 0;
    sp_chunk c;
    while (n < N_FRAMES && sp_capture_reader_next(r, &c) == 0)
        if (c.type == SP_CHUNK_FRAME)
            off[n] = c.offset, size[n++] = c.payload_size;
    sp_capture_reader_close(&r);
    return n;
}

static void flip(uint64_t at)
{
    int fd = open(path, O_RDWR);
    uint8_t b = 0;
    CHECK(fd >= 0 && pread(fd, &b, 1, (off_t)at) == 1);
    b ^= 0x10;
    CHECK(fd >= 0 && pwrite(fd, &b, 1, (off_t)at) == 1);
    if (fd >= 0)
        close(fd);
}

static void test_damage(void)
{
    uint64_t off[N_FRAMES];
    uint32_t size[N_FRAMES];
    CHECK_EQ_INT(frame_offsets(off, size), N_FRAMES);
    /* one bit in the pixels of a small frame (inside the read-ahead) and at the end of two large ones */
    flip(off[3] + 32 + size[3] - 5);
    flip(off[7] + 32 + size[7] - 1);
    flip(off[17] + 32 + size[17] / 2);
    sp_replay_settings s;
    sp_replay_default_settings(&s);
    tally t;
    CHECK_EQ_INT(run(&s, 0, &t, NULL), SP_ECORRUPT);
    CHECK(t.frames <= 3); /* stops at frame 3 (earlier frames may still sit in the reorder window) */

    s.skip_corrupt = 1;
    s.pool_frames = 2; /* frames read for a payload that fails its CRC must go back to the pool */
    sp_replay_stats st;
    CHECK_EQ_INT(run(&s, 0, &t, &st), SP_EOS);
    CHECK_EQ_INT(t.frames, N_FRAMES - 3);
    CHECK_EQ_INT(t.bad_frames, 0);
    CHECK(!t.seen[3] && !t.seen[7] && !t.seen[17] && t.seen[4] == 1 && t.seen[18] == 1);
    CHECK_EQ_INT(st.corrupt_chunks, 3);

    /* a torn tail: the file ends inside the last large frame */
    CHECK_EQ_INT(truncate(path, (off_t)(off[N_FRAMES - 1] + 32 + size[N_FRAMES - 1] / 3)), 0);
    CHECK_EQ_INT(run(&s, 0, &t, &st), SP_EOS);
    CHECK_EQ_INT(t.frames, N_FRAMES - 4);
    CHECK_EQ_INT(t.bad_frames, 0);
    CHECK(st.truncated);
}

int main(void)
{
    const char *tmp = getenv("TMPDIR");
    snprintf(path, sizeof(path), "%s/sp_test_replay_%ld.spcap", tmp && *tmp ? tmp : "/tmp", (long)getpid());
    int ret = write_capture();
    if (ret)
        SKIP("cannot write a capture in %s: %s", path, sp_strerror(ret));
    test_clean();
    test_damage();
    unlink(path);
    return check_exit();
}
