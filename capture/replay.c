/* SPDX-License-Identifier: MIT */
/*
 * Replay device. Chunks are read in file order and their events held in a small
 * min-heap for `reorder_window_ns`, because a writer appends IMU batches and
 * frames as they arrive, not in exact timestamp order. Memory is bounded by the
 * window and the frame pool, never by the file.
 *
 * The metadata prologue: every META chunk that stands before the first FRAME
 * chunk is read ahead at open (with a reader of its own) and delivered before
 * any other event. A phone's IMU log starts before its video, so its first
 * samples carry earlier timestamps than the META chunk; in timestamp order they
 * would reach a consumer before the calibration they need (imu.to_camera).
 */
#include "sunprobe/sp_replay.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "capture/container_format.h"
#include "common/clock.h"
#include "sunprobe/sp_capture.h"

typedef struct pending {
    int64_t t;
    uint64_t order; /* ties keep file order */
    enum sp_event_type type;
    sp_frame *frame;
    sp_imu_sample imu;
    char *meta;
    size_t meta_len;
    float *side;
    uint32_t side_count, side_kind;
    uint64_t side_sequence;
} pending;

#define PROLOGUE_MAX_CHUNKS 4096 /* leading chunks searched for META (about 1.5 h of 200 Hz IMU batches) */

typedef struct replay {
    sp_replay_settings settings;
    pending *prologue;  /* META events read ahead, delivered first */
    size_t n_prologue, next_prologue;
    uint64_t prologue_end; /* META chunks before this offset were read ahead: skipped by the main pass */
    sp_capture_reader *reader;
    sp_frame_pool *pool;
    pending *heap;
    size_t heap_len, heap_cap;
    uint64_t next_order;
    int64_t newest_t, last_emitted_t;
    int eof;
    int have_chunk; /* `chunk` was read but not yet turned into events (pool was full) */
    sp_chunk chunk;
    sp_frame *inflight; /* the frame the reader fills for `chunk` (copy-free path), or NULL */
    pending current; /* the event handed out last: its buffers live until the next call */
    int64_t pace_wall0, pace_t0;
    sp_replay_stats stats;
    sp_capture_meta meta;
} replay;

static int before(const pending *a, const pending *b)
{
    return a->t < b->t || (a->t == b->t && a->order < b->order);
}

static int heap_push(replay *r, pending *p)
{
    if (r->heap_len == r->heap_cap) {
        size_t cap = r->heap_cap ? r->heap_cap * 2 : 256;
        pending *h = realloc(r->heap, cap * sizeof(*h));
        if (!h)
            return -ENOMEM;
        r->heap = h;
        r->heap_cap = cap;
    }
    p->order = r->next_order++;
    size_t i = r->heap_len++;
    while (i > 0 && before(p, &r->heap[(i - 1) / 2])) {
        r->heap[i] = r->heap[(i - 1) / 2];
        i = (i - 1) / 2;
    }
    r->heap[i] = *p;
    if (p->t > r->newest_t)
        r->newest_t = p->t;
    return 0;
}

static pending heap_pop(replay *r)
{
    pending top = r->heap[0];
    pending last = r->heap[--r->heap_len];
    size_t i = 0;
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= r->heap_len)
            break;
        if (c + 1 < r->heap_len && before(&r->heap[c + 1], &r->heap[c]))
            c++;
        if (!before(&r->heap[c], &last))
            break;
        r->heap[i] = r->heap[c];
        i = c;
    }
    if (r->heap_len)
        r->heap[i] = last;
    return top;
}

static void pending_free(pending *p)
{
    sp_frame_unref(&p->frame);
    free(p->meta);
    free(p->side);
    memset(p, 0, sizeof(*p));
}

/* A frame from the pool big enough for `size` bytes; grows the pool when a frame outgrows it. */
static int get_frame(replay *r, size_t size, sp_frame **out)
{
    if (r->pool && sp_frame_pool_max_bytes(r->pool) < size)
        sp_frame_pool_close(&r->pool); /* frames still out keep the old pool alive */
    if (!r->pool) {
        size_t bytes = size < 65536 ? 65536 : size + size / 2;
        int ret = sp_frame_pool_open(&r->pool, r->settings.pool_frames, bytes);
        if (ret)
            return ret;
    }
    return sp_frame_pool_get(r->pool, out);
}

static void describe_frame(sp_frame *f, const sp_frame_chunk *fc, int64_t timestamp_ns)
{
    f->bytes_used = fc->data_size;
    f->format = fc->format;
    f->width = fc->width;
    f->height = fc->height;
    f->stride = fc->stride;
    f->stream_id = fc->stream_id;
    f->sequence = fc->sequence;
    f->exposure_us = fc->exposure_us;
    f->gain = fc->gain;
    f->timestamp_ns = timestamp_ns;
}

/* Queues a frame event; the frame's reference moves to the heap (or is dropped on failure). */
static int push_frame_event(replay *r, sp_frame *f, int64_t t)
{
    pending p = { .t = t, .type = SP_EVENT_FRAME, .frame = f };
    int ret = heap_push(r, &p);
    if (ret)
        sp_frame_unref(&f);
    else
        r->stats.frames++;
    return ret;
}

/* A FRAME chunk read into the reader's buffer: copied into a pool frame. */
static int push_frame(replay *r, const sp_chunk *c)
{
    sp_frame_chunk fc;
    int ret = sp_chunk_parse_frame(c, &fc);
    if (ret)
        return ret;
    sp_frame *f = NULL;
    if ((ret = get_frame(r, fc.data_size, &f)))
        return ret;
    memcpy(f->data, fc.data, fc.data_size);
    describe_frame(f, &fc, c->timestamp_ns);
    return push_frame_event(r, f, c->timestamp_ns);
}

/* The reader's sink: pixel data goes straight into a pool frame (-EAGAIN when the pool is empty). */
static int frame_dst(void *user, const sp_chunk *head, const sp_frame_chunk *fc, uint8_t **dst)
{
    replay *r = user;
    sp_frame_unref(&r->inflight); /* filled for a payload that then failed its CRC */
    sp_frame *f = NULL;
    int ret = get_frame(r, fc->data_size, &f);
    if (ret)
        return ret;
    describe_frame(f, fc, head->timestamp_ns);
    r->inflight = f;
    *dst = f->data;
    return 0;
}

static int push_imu(replay *r, const sp_chunk *c)
{
    int64_t n = sp_chunk_imu_count(c);
    if (n < 0)
        return (int)n;
    for (int64_t i = 0; i < n; i++) {
        pending p = { .type = SP_EVENT_IMU };
        int ret = sp_chunk_imu_get(c, (size_t)i, &p.imu);
        if (!ret) {
            p.t = p.imu.timestamp_ns;
            ret = heap_push(r, &p);
        }
        if (ret)
            return ret;
        r->stats.imu_samples++;
    }
    return 0;
}

/* A META chunk as a pending event (the JSON copied, NUL-terminated; merged when delivered). */
static int meta_pending(const sp_chunk *c, pending *p)
{
    *p = (pending){ .t = c->timestamp_ns, .type = SP_EVENT_META, .meta_len = c->payload_size,
                    .side_sequence = c->offset }; /* the offset names the chunk in a warning */
    p->meta = malloc(c->payload_size + 1);
    if (!p->meta)
        return -ENOMEM;
    memcpy(p->meta, c->payload, c->payload_size);
    p->meta[c->payload_size] = 0;
    return 0;
}

static int push_meta(replay *r, const sp_chunk *c)
{
    if (c->offset < r->prologue_end)
        return 0; /* read ahead and delivered first */
    pending p;
    int ret = meta_pending(c, &p);
    if (!ret && (ret = heap_push(r, &p)))
        free(p.meta);
    return ret;
}

/* Reads the META chunks before the first FRAME chunk with a reader of its own (see the top). */
static int read_prologue(replay *r, const char *path)
{
    sp_capture_reader *rd = NULL;
    sp_capture_reader_settings rs;
    sp_capture_reader_default_settings(&rs);
    int ret = sp_capture_reader_open(&rd, path, &rs);
    if (ret)
        return ret;
    sp_chunk c;
    size_t cap = 0;
    for (unsigned n = 0; n < PROLOGUE_MAX_CHUNKS; n++) {
        if (sp_capture_reader_next(rd, &c))
            break; /* the end, a torn tail or a bad chunk: the main pass meets it and reports it */
        if (c.type == SP_CHUNK_FRAME)
            break;
        if (c.type == SP_CHUNK_META) {
            if (r->n_prologue == cap) {
                cap = cap ? 2 * cap : 4;
                pending *q = realloc(r->prologue, cap * sizeof(*q));
                if (!q) {
                    ret = -ENOMEM;
                    break;
                }
                r->prologue = q;
            }
            if ((ret = meta_pending(&c, &r->prologue[r->n_prologue])))
                break;
            r->n_prologue++;
        }
        r->prologue_end = c.offset + 1;
    }
    sp_capture_reader_close(&rd);
    return ret;
}

static int push_side(replay *r, const sp_chunk *c)
{
    sp_side_chunk sc;
    int ret = sp_chunk_parse_side(c, &sc);
    if (ret)
        return ret;
    pending p = { .t = c->timestamp_ns, .type = SP_EVENT_SIDE, .side_count = sc.count, .side_kind = sc.kind,
                  .side_sequence = sc.frame_sequence };
    p.side = malloc(((size_t)sc.count + 1) * sizeof(float));
    if (!p.side)
        return -ENOMEM;
    for (uint32_t i = 0; i < sc.count; i++)
        p.side[i] = sp_side_value(&sc, i);
    if ((ret = heap_push(r, &p)))
        free(p.side);
    else
        r->stats.side_chunks++;
    return ret;
}

static int push_chunk(replay *r, const sp_chunk *c)
{
    if (r->inflight) { /* read by the copy-free path: the frame is complete and checked */
        sp_frame *f = r->inflight;
        r->inflight = NULL;
        return push_frame_event(r, f, c->timestamp_ns);
    }
    switch (c->type) {
    case SP_CHUNK_FRAME:
        return push_frame(r, c);
    case SP_CHUNK_IMU:
        return push_imu(r, c);
    case SP_CHUNK_META:
        return push_meta(r, c);
    case SP_CHUNK_SIDE:
        return push_side(r, c);
    case SP_CHUNK_INDEX:
        r->stats.index_chunks++;
        return 0;
    default:
        r->stats.unknown_chunks++; /* newer minor version: skip what we do not know */
        return 0;
    }
}

/* Reads one chunk into events: 0, -EAGAIN when the pool is full (chunk kept for later), or an error. */
static int fill_one(replay *r)
{
    if (!r->have_chunk) {
        spc_frame_sink sink = { .get_dst = frame_dst, .user = r };
        int direct = 0;
        int ret = spc_reader_next_direct(r->reader, &r->chunk, &sink, &direct);
        if (!direct)
            sp_frame_unref(&r->inflight); /* left from a frame that failed its CRC, if any */
        if (ret == -EAGAIN)
            return ret; /* pool empty: the chunk stays unread until frames come back */
        if (ret == SP_EOS || ret == SP_ETRUNCATED) {
            r->stats.truncated = ret == SP_ETRUNCATED;
            if (r->stats.truncated)
                sp_log(SP_LOG_WARN, "replay", "capture ends in a torn chunk at offset %llu; run `sunprobe recover`",
                       (unsigned long long)r->chunk.offset);
            r->eof = 1;
            return 0;
        }
        if (ret) {
            r->stats.error_offset = r->chunk.offset;
            return ret;
        }
        r->have_chunk = 1;
        r->stats.bytes_read += r->chunk.payload_size;
    }
    int ret = push_chunk(r, &r->chunk);
    if (ret == -EAGAIN)
        return ret;
    r->have_chunk = 0;
    if (ret == SP_ECORRUPT && r->settings.skip_corrupt) {
        r->stats.corrupt_chunks++;
        return 0;
    }
    if (ret)
        r->stats.error_offset = r->chunk.offset;
    return ret;
}

static int ready_to_emit(const replay *r)
{
    if (!r->heap_len)
        return 0;
    /* unsigned difference: timestamps from a file may be far apart without overflowing */
    return r->eof || (r->heap[0].t <= r->newest_t &&
                      (uint64_t)r->newest_t - (uint64_t)r->heap[0].t >= (uint64_t)r->settings.reorder_window_ns);
}

static void pace(replay *r, int64_t t)
{
    if (!r->settings.realtime)
        return;
    int64_t now = sp_clock_monotonic_ns();
    if (!r->pace_wall0) {
        r->pace_wall0 = now;
        r->pace_t0 = t;
        return;
    }
    double speed = r->settings.speed > 0 ? r->settings.speed : 1.0;
    double wait_ns = ((double)t - (double)r->pace_t0) / speed;
    if (wait_ns > 0 && wait_ns < 3.6e12) /* a jump of over an hour is a clock glitch, not a pause */
        sp_clock_sleep_until(r->pace_wall0 + (int64_t)wait_ns);
}

static void to_event(replay *r, pending *p, sp_event *ev)
{
    ev->type = p->type;
    ev->timestamp_ns = p->t;
    ev->frame = p->frame; /* ownership moves to the receiver */
    p->frame = NULL;
    ev->imu = p->imu;
    ev->meta_json = p->meta;
    ev->meta_len = p->meta_len;
    ev->side_sequence = p->side_sequence;
    ev->side_kind = p->side_kind;
    ev->side_count = p->side_count;
    ev->side_values = p->side;
    if (p->type == SP_EVENT_META) { /* merged once, here; consumers read ev->meta */
        if (sp_capture_meta_merge(&r->meta, p->meta, p->meta_len))
            sp_log(SP_LOG_WARN, "replay", "metadata chunk at offset %llu is not valid JSON metadata; ignored",
                   (unsigned long long)p->side_sequence);
        ev->meta = &r->meta;
        ev->side_sequence = 0;
        r->stats.meta_chunks++;
        return; /* metadata is not part of the time order (the prologue comes first whatever its time) */
    }
    if (p->t < r->last_emitted_t)
        r->stats.late_events++;
    else
        r->last_emitted_t = p->t;
    if (!r->stats.first_ns && !r->stats.last_ns)
        r->stats.first_ns = p->t;
    r->stats.last_ns = p->t;
}

static int replay_next(void *ctx, sp_event *ev)
{
    replay *r = ctx;
    pending_free(&r->current);
    if (r->next_prologue < r->n_prologue) {
        r->current = r->prologue[r->next_prologue];
        memset(&r->prologue[r->next_prologue++], 0, sizeof(pending));
        to_event(r, &r->current, ev);
        return 0;
    }
    for (;;) {
        int must_drain = 0;
        if (!ready_to_emit(r) && !r->eof) {
            int ret = fill_one(r);
            if (ret == -EAGAIN)
                must_drain = 1; /* pool exhausted: hand out what we hold */
            else if (ret)
                return ret;
            else
                continue;
        }
        if (!r->heap_len)
            return r->eof ? SP_EOS : -EAGAIN; /* -EAGAIN: the consumer holds every frame */
        if (!must_drain && !ready_to_emit(r))
            continue;
        r->current = heap_pop(r);
        if (r->current.t < r->settings.start_ns) {
            pending_free(&r->current);
            continue;
        }
        pace(r, r->current.t);
        to_event(r, &r->current, ev);
        return 0;
    }
}

static void replay_close(void *ctx)
{
    replay *r = ctx;
    if (!r)
        return;
    pending_free(&r->current);
    sp_frame_unref(&r->inflight);
    for (size_t i = r->next_prologue; i < r->n_prologue; i++)
        pending_free(&r->prologue[i]);
    free(r->prologue);
    while (r->heap_len) {
        pending p = heap_pop(r);
        pending_free(&p);
    }
    free(r->heap);
    sp_frame_pool_close(&r->pool);
    sp_capture_reader_close(&r->reader);
    free(r);
}

static const sp_source_ops replay_ops = {
    .name = "replay",
    .next = replay_next,
    .close = replay_close,
};

void sp_replay_default_settings(sp_replay_settings *s)
{
    memset(s, 0, sizeof(*s));
    s->speed = 1.0;
    s->reorder_window_ns = 250000000;
    s->pool_frames = 16;
    s->start_ns = INT64_MIN;
}

int sp_replay_open(sp_source **out, const char *path, const sp_replay_settings *s)
{
    if (!out || !path)
        return -EINVAL;
    *out = NULL;
    sp_replay_settings defaults;
    if (!s) {
        sp_replay_default_settings(&defaults);
        s = &defaults;
    }
    if (s->pool_frames < 2 || s->reorder_window_ns < 0)
        return -EINVAL;
    replay *r = calloc(1, sizeof(*r));
    if (!r)
        return -ENOMEM;
    r->settings = *s;
    r->newest_t = INT64_MIN;
    r->last_emitted_t = INT64_MIN;
    sp_capture_meta_init(&r->meta);
    sp_capture_reader_settings rs;
    sp_capture_reader_default_settings(&rs);
    rs.skip_corrupt = s->skip_corrupt;
    int ret = sp_capture_reader_open(&r->reader, path, &rs);
    if (!ret)
        ret = read_prologue(r, path);
    if (!ret && s->start_ns != INT64_MIN)
        ret = sp_capture_reader_seek(r->reader, s->start_ns);
    if (!ret)
        ret = sp_source_create(out, &replay_ops, r);
    if (ret)
        replay_close(r);
    return ret;
}

int sp_replay_get_stats(const sp_source *src, sp_replay_stats *out)
{
    if (!src || !out || src->ops != &replay_ops)
        return -EINVAL;
    const replay *r = src->ctx;
    *out = r->stats;
    if (r->settings.skip_corrupt)
        out->corrupt_chunks = sp_capture_reader_corrupt_count(r->reader);
    return 0;
}
