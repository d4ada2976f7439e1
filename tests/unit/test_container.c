/* SPDX-License-Identifier: MIT */
/*
 * capture container: round trips of every chunk type and pixel format, index and
 * seek, header errors, single-bit damage everywhere, a torn tail at every byte,
 * recovery in place and to a copy, absurd lengths, and a full disk.
 */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "capture/container_format.h"
#include "check.h"
#include "common/crc32c.h"
#include "common/file_util.h"
#include "sunprobe/sp_capture.h"

static char tmpdir[256];

static const char *tmp_path(const char *name)
{
    static char paths[8][sizeof(tmpdir) + 300];
    static int next;
    char *p = paths[next++ % 8];
    snprintf(p, sizeof(paths[0]), "%s/%s", tmpdir, name);
    return p;
}

static void make_tmpdir(void)
{
    const char *base = getenv("TMPDIR");
    snprintf(tmpdir, sizeof(tmpdir), "%s/sp_container_XXXXXX", base && *base ? base : "/tmp");
    if (!mkdtemp(tmpdir))
        SKIP("cannot create a temporary directory under %s", base ? base : "/tmp");
}

static void remove_tmpdir(void)
{
    DIR *d = opendir(tmpdir);
    if (!d)
        return;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0)
            unlink(tmp_path(e->d_name));
    closedir(d);
    rmdir(tmpdir);
}

/* ---- whole-file helpers ---- */

/* The whole file, or NULL (and *len 0) when it cannot be read; the caller frees it. */
static uint8_t *read_file(const char *path, size_t *len)
{
    void *b = NULL;
    *len = 0;
    return sp_read_whole_file(path, (size_t)1 << 30, &b, len) == 0 ? b : NULL;
}

static void write_file(const char *path, const uint8_t *b, size_t len)
{
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    CHECK(fd >= 0);
    if (fd < 0)
        return;
    CHECK((size_t)write(fd, b, len) == len);
    close(fd);
}

static uint64_t file_size(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 ? (uint64_t)st.st_size : UINT64_MAX;
}

/* A chunk as a reader returned it, payload copied. */
typedef struct rec {
    uint16_t type;
    int64_t ts;
    uint64_t offset;
    uint32_t size;
    uint8_t *payload;
} rec;

typedef struct recs {
    rec r[2048];
    int n;
    int last;             /* code that ended the walk */
    uint64_t last_offset; /* chunk.offset at that code */
} recs;

static void recs_free(recs *v)
{
    for (int i = 0; i < v->n; i++)
        free(v->r[i].payload);
    v->n = 0;
}

/* Reads every chunk (END included) into v; returns the open error or 0. */
static int read_all(const char *path, int skip, recs *v, uint64_t *corrupt, uint64_t *first_bad)
{
    sp_capture_reader_settings s;
    sp_capture_reader_default_settings(&s);
    s.skip_corrupt = skip;
    sp_capture_reader *r = NULL;
    v->n = 0;
    int err = sp_capture_reader_open(&r, path, &s);
    if (err < 0)
        return err;
    sp_chunk c;
    for (;;) {
        memset(&c, 0, sizeof(c));
        err = sp_capture_reader_next(r, &c);
        if ((err == 0 || (err == SP_EOS && c.type == SP_CHUNK_END)) && v->n < 2048) {
            rec *e = &v->r[v->n++];
            e->type = c.type;
            e->ts = c.timestamp_ns;
            e->offset = c.offset;
            e->size = c.payload_size;
            e->payload = malloc(c.payload_size + 1u);
            memcpy(e->payload, c.payload, c.payload_size);
        }
        if (err != 0)
            break;
    }
    v->last = err;
    v->last_offset = c.offset;
    if (corrupt)
        *corrupt = sp_capture_reader_corrupt_count(r);
    if (first_bad)
        *first_bad = sp_capture_reader_first_corrupt_offset(r);
    CHECK_EQ_INT(sp_capture_reader_saw_end(r), err == SP_EOS && c.type == SP_CHUNK_END);
    /* after the end the reader stays at the end */
    if (err == SP_EOS)
        CHECK_EQ_INT(sp_capture_reader_next(r, &c), SP_EOS);
    sp_capture_reader_close(&r);
    CHECK(r == NULL);
    return 0;
}

static int rec_equal(const rec *a, const rec *b)
{
    return a->type == b->type && a->ts == b->ts && a->offset == b->offset && a->size == b->size &&
           memcmp(a->payload, b->payload, a->size) == 0;
}

/* ---- a small file holding every chunk type ---- */

static sp_frame make_frame(enum sp_pixfmt fmt, uint32_t w, uint32_t h, uint32_t stride, size_t bytes, uint64_t seq)
{
    sp_frame f;
    memset(&f, 0, sizeof(f));
    f.format = fmt;
    f.width = w;
    f.height = h;
    f.stride = stride;
    f.bytes_used = bytes;
    f.capacity = bytes;
    f.data = malloc(bytes);
    for (size_t i = 0; i < bytes; i++)
        f.data[i] = (uint8_t)(i * 7 + seq * 13 + 1);
    f.timestamp_ns = 1000000 * (int64_t)seq + 5;
    f.sequence = seq;
    f.stream_id = (uint32_t)(seq % 2);
    f.exposure_us = seq % 2 ? NAN : 1000.5f + (float)seq;
    f.gain = seq % 3 ? 2.25f : NAN;
    return f;
}

static sp_capture_writer *open_writer(const char *path, uint32_t index_interval)
{
    sp_capture_writer_settings s;
    sp_capture_writer_default_settings(&s);
    s.index_interval = index_interval;
    s.sync = SP_SYNC_NONE;
    s.overwrite = 1;
    sp_capture_writer *w = NULL;
    CHECK_EQ_INT(sp_capture_writer_open(&w, path, &s), 0);
    return w;
}

static const char small_meta[] = "{\"kind\":\"selfie\",\"source\":\"test\"}";

/* Writes meta, frames, IMU and side chunks; index every `interval` chunks. */
static void write_small(const char *path, uint32_t interval, int frames)
{
    sp_capture_writer *w = open_writer(path, interval);
    if (!w)
        return;
    CHECK_EQ_INT(sp_capture_write_meta(w, 1, small_meta, strlen(small_meta)), 0);
    for (int i = 0; i < frames; i++) {
        sp_frame f = make_frame(SP_PIXFMT_GRAY8, 4, 3, 5, 15, (uint64_t)i);
        CHECK_EQ_INT(sp_capture_write_frame(w, &f), 0);
        free(f.data);
        sp_imu_sample s[2] = { { f.timestamp_ns - 3, SP_IMU_GYRO, { 0.1f, -0.2f, 0.3f } },
                               { f.timestamp_ns - 1, SP_IMU_ACCEL, { 0.0f, 9.81f, (float)i } } };
        CHECK_EQ_INT(sp_capture_write_imu(w, s, 1 + (size_t)(i % 2)), 0);
        float lm[4] = { 1.5f, 2.5f, (float)i, -1.0f };
        CHECK_EQ_INT(sp_capture_write_side(w, f.timestamp_ns, f.sequence, SP_SIDE_LANDMARKS_2D, lm, 4), 0);
    }
    CHECK_EQ_INT(sp_capture_writer_close(&w), 0);
    CHECK(w == NULL);
}

/* ---- round trips ---- */

static void check_frame_chunk(const sp_chunk *c, const sp_frame *f)
{
    sp_frame_chunk fc;
    CHECK_EQ_INT(sp_chunk_parse_frame(c, &fc), 0);
    CHECK_EQ_INT(fc.format, f->format);
    CHECK_EQ_INT(fc.width, f->width);
    CHECK_EQ_INT(fc.height, f->height);
    if (f->format != SP_PIXFMT_MJPEG)
        CHECK_EQ_INT(fc.stride, f->stride);
    CHECK_EQ_INT(fc.stream_id, f->stream_id);
    CHECK_EQ_INT(fc.sequence, f->sequence);
    CHECK(isnan(f->exposure_us) ? isnan(fc.exposure_us) : fc.exposure_us == f->exposure_us);
    CHECK(isnan(f->gain) ? isnan(fc.gain) : fc.gain == f->gain);
    CHECK_EQ_INT(fc.data_size, f->bytes_used);
    CHECK(memcmp(fc.data, f->data, f->bytes_used) == 0);
    CHECK_EQ_INT(c->timestamp_ns, f->timestamp_ns);
}

static void test_roundtrip(void)
{
    const char *path = tmp_path("roundtrip.spcap");
    sp_frame frames[] = {
        make_frame(SP_PIXFMT_GRAY8, 7, 5, 8, 40, 0),
        make_frame(SP_PIXFMT_RGB24, 5, 3, 16, 48, 1),
        make_frame(SP_PIXFMT_YUYV, 5, 2, 12, 24, 2),   /* odd width rounds up to 6 pixels */
        make_frame(SP_PIXFMT_NV12, 4, 3, 4, 20, 3),    /* odd height: 3 + 2 rows */
        make_frame(SP_PIXFMT_MJPEG, 640, 480, 0, 333, 4),
        make_frame(SP_PIXFMT_GRAY8, 2, 2, 2, 10, 5),   /* more bytes than the image: kept */
    };
    size_t nf = sizeof(frames) / sizeof(frames[0]);
    sp_imu_sample imu[3] = { { -7, SP_IMU_GYRO, { 1e-9f, -0.0f, INFINITY } },
                             { 3, SP_IMU_ACCEL, { 0, 9.81f, -1 } },
                             { INT64_MAX, SP_IMU_MAG, { 40, NAN, 3e38f } } };
    float lm[136];
    for (int i = 0; i < 136; i++)
        lm[i] = (float)i * 0.5f - 3;
    sp_capture_writer *w = open_writer(path, 3);
    CHECK_EQ_INT(sp_capture_write_meta(w, -5, small_meta, strlen(small_meta)), 0);
    for (size_t i = 0; i < nf; i++)
        CHECK_EQ_INT(sp_capture_write_frame(w, &frames[i]), 0);
    CHECK_EQ_INT(sp_capture_write_imu(w, imu, 3), 0);
    CHECK_EQ_INT(sp_capture_write_side(w, 42, 4, SP_SIDE_LANDMARKS_2D, lm, 136), 0);
    CHECK_EQ_INT(sp_capture_write_side(w, 43, 5, SP_SIDE_LANDMARKS_2D, NULL, 0), 0);
    CHECK_EQ_INT(sp_capture_writer_sync(w), 0);
    uint64_t before_close = sp_capture_writer_bytes(w);
    CHECK_EQ_INT(before_close, file_size(path));
    CHECK_EQ_INT(sp_capture_writer_close(&w), 0);
    CHECK(file_size(path) > before_close);

    sp_capture_reader *r = NULL;
    CHECK_EQ_INT(sp_capture_reader_open(&r, path, NULL), 0);
    if (!r)
        return;
    const sp_capture_info *info = sp_capture_reader_info(r);
    CHECK_EQ_INT(info->version_major, SP_CAPTURE_VERSION_MAJOR);
    CHECK_EQ_INT(info->version_minor, SP_CAPTURE_VERSION_MINOR);
    CHECK_EQ_INT(info->file_size, file_size(path));
    CHECK(info->created_utc_ns > 1500000000LL * 1000000000LL); /* after 2017: a real wall clock */
    sp_chunk c;
    int idx = 0, indexes = 0, err;
    size_t fi = 0;
    while ((err = sp_capture_reader_next(r, &c)) == 0) {
        if (c.type == SP_CHUNK_INDEX) {
            indexes++;
            continue;
        }
        if (idx == 0) {
            CHECK_EQ_INT(c.type, SP_CHUNK_META);
            CHECK_EQ_INT(c.timestamp_ns, -5);
            CHECK(c.payload_size == strlen(small_meta) && memcmp(c.payload, small_meta, c.payload_size) == 0);
        } else if (c.type == SP_CHUNK_FRAME && fi < nf) {
            check_frame_chunk(&c, &frames[fi++]);
        } else if (c.type == SP_CHUNK_IMU) {
            CHECK_EQ_INT(sp_chunk_imu_count(&c), 3);
            CHECK_EQ_INT(c.timestamp_ns, -7);
            for (size_t k = 0; k < 3; k++) {
                sp_imu_sample s;
                CHECK_EQ_INT(sp_chunk_imu_get(&c, k, &s), 0);
                CHECK_EQ_INT(s.timestamp_ns, imu[k].timestamp_ns);
                CHECK_EQ_INT(s.sensor, imu[k].sensor);
                for (int a = 0; a < 3; a++)
                    CHECK(memcmp(&s.v[a], &imu[k].v[a], 4) == 0); /* bit exact, NaN and -0 included */
            }
            sp_imu_sample s;
            CHECK_EQ_INT(sp_chunk_imu_get(&c, 3, &s), -EINVAL);
        } else if (c.type == SP_CHUNK_SIDE) {
            sp_side_chunk sd;
            CHECK_EQ_INT(sp_chunk_parse_side(&c, &sd), 0);
            CHECK_EQ_INT(sd.kind, SP_SIDE_LANDMARKS_2D);
            if (sd.frame_sequence == 4) {
                CHECK_EQ_INT(sd.count, 136);
                for (uint32_t k = 0; k < 136; k++)
                    CHECK(sp_side_value(&sd, k) == lm[k]);
                CHECK(isnan(sp_side_value(&sd, 136)));
            } else {
                CHECK_EQ_INT(sd.frame_sequence, 5);
                CHECK_EQ_INT(sd.count, 0);
                CHECK(isnan(sp_side_value(&sd, 0)));
            }
        } else {
            CHECK_MSG(0, "unexpected chunk type %u at %d", c.type, idx);
        }
        idx++;
    }
    CHECK_EQ_INT(err, SP_EOS);
    CHECK_EQ_INT(c.type, SP_CHUNK_END);
    CHECK_EQ_INT(c.timestamp_ns, frames[nf - 1].timestamp_ns); /* the largest written */
    CHECK_EQ_INT(c.offset + SPC_CHUNK_HDR_SIZE + c.payload_size, file_size(path)); /* END is last */
    CHECK_EQ_INT(idx, 1 + (int)nf + 3);
    CHECK_EQ_INT(fi, nf);
    CHECK_EQ_INT(indexes, 4); /* 10 indexed chunks at 3 per index: 3 full + 1 at close */
    CHECK_EQ_INT(sp_capture_reader_corrupt_count(r), 0);
    CHECK(sp_capture_reader_first_corrupt_offset(r) == UINT64_MAX);
    sp_capture_reader_close(&r);
    sp_capture_reader_close(&r); /* idempotent */
    for (size_t i = 0; i < nf; i++)
        free(frames[i].data);
}

/* A file built by hand: a newer minor version with a longer header and an unknown chunk type. */
static void test_forward_compat(void)
{
    uint8_t b[512];
    memset(b, 0, sizeof(b));
    spc_build_file_header(b, 123, 0);
    spc_put16(b + SPC_HDR_OFF_MINOR, 7);
    spc_put32(b + SPC_HDR_OFF_SIZE, 128);
    memset(b + 64, 0xEE, 64); /* extension bytes a 1.0 reader skips */
    spc_put32(b + SPC_HDR_OFF_CRC, sp_crc32c(0, b, SPC_HDR_OFF_CRC));
    size_t pos = 128;
    const char payload[] = "future";
    spc_build_chunk_header(b + pos, 77, 0x8001, 6, sp_crc32c(0, payload, 6), 9);
    memcpy(b + pos + 32, payload, 6);
    pos += 38;
    spc_build_chunk_header(b + pos, SP_CHUNK_META, 0, 2, sp_crc32c(0, "{}", 2), 10);
    memcpy(b + pos + 32, "{}", 2);
    pos += 34;
    const char *path = tmp_path("compat.spcap");
    write_file(path, b, pos);
    recs v;
    CHECK_EQ_INT(read_all(path, 0, &v, NULL, NULL), 0);
    CHECK_EQ_INT(v.n, 2);
    CHECK_EQ_INT(v.r[0].type, 77);
    CHECK_EQ_INT(v.r[0].offset, 128);
    CHECK_EQ_INT(v.r[1].type, SP_CHUNK_META);
    CHECK_EQ_INT(v.last, SP_EOS); /* no END: a clean end of file */
    recs_free(&v);
    sp_capture_reader *r = NULL;
    CHECK_EQ_INT(sp_capture_reader_open(&r, path, NULL), 0);
    if (r) {
        CHECK_EQ_INT(sp_capture_reader_info(r)->version_minor, 7);
        CHECK_EQ_INT(sp_capture_reader_info(r)->created_utc_ns, 123);
    }
    sp_capture_reader_close(&r);
    /* recovery keeps the unknown chunk and the header extension */
    sp_recover_report rep;
    CHECK_EQ_INT(sp_capture_recover(path, NULL, &rep), 0);
    CHECK_EQ_INT(rep.chunks_kept, 2);
    CHECK_EQ_INT(rep.valid_bytes, pos);
    size_t len;
    uint8_t *after = read_file(path, &len);
    CHECK(after && len == pos + 48 && memcmp(after, b, pos) == 0);
    free(after);
}

/* ---- argument and payload checks ---- */

static void test_writer_errors(void)
{
    const char *path = tmp_path("errors.spcap");
    sp_capture_writer_settings s;
    sp_capture_writer_default_settings(&s);
    CHECK_EQ_INT(s.sync, SP_SYNC_PERIODIC);
    CHECK_EQ_INT(s.sync_interval_ms, 1000);
    CHECK_EQ_INT(s.index_interval, 256);
    CHECK_EQ_INT(s.overwrite, 0);
    sp_capture_writer *w = NULL;
    CHECK_EQ_INT(sp_capture_writer_open(NULL, path, &s), -EINVAL);
    CHECK_EQ_INT(sp_capture_writer_open(&w, tmp_path("no/such/dir.spcap"), &s), -ENOENT);
    s.index_interval = SPC_INDEX_MAX_INTERVAL + 1;
    CHECK_EQ_INT(sp_capture_writer_open(&w, path, &s), -EINVAL);
    s.index_interval = 256;
    s.sync = (enum sp_sync_policy)9;
    CHECK_EQ_INT(sp_capture_writer_open(&w, path, &s), -EINVAL);
    s.sync = SP_SYNC_EVERY_CHUNK;
    CHECK_EQ_INT(sp_capture_writer_open(&w, path, &s), 0);
    sp_capture_writer *w2 = NULL;
    CHECK_EQ_INT(sp_capture_writer_open(&w2, path, &s), -EEXIST);
    CHECK(w2 == NULL);

    CHECK_EQ_INT(sp_capture_write_meta(w, 0, "[1]", 3), -EINVAL);
    CHECK_EQ_INT(sp_capture_write_meta(w, 0, "{\"a\":", 5), -EINVAL);
    CHECK_EQ_INT(sp_capture_write_meta(w, 0, "{}", 0), -EINVAL);
    CHECK_EQ_INT(sp_capture_write_imu(w, NULL, 1), -EINVAL);
    sp_imu_sample one = { 0, SP_IMU_GYRO, { 0, 0, 0 } };
    CHECK_EQ_INT(sp_capture_write_imu(w, &one, 0), -EINVAL);
    CHECK_EQ_INT(sp_capture_write_side(w, 0, 0, SP_SIDE_LANDMARKS_2D, NULL, 2), -EINVAL);
    sp_frame f = make_frame(SP_PIXFMT_YUYV, 4, 2, 8, 16, 1);
    f.stride = 7; /* below 2 bytes per pixel */
    CHECK_EQ_INT(sp_capture_write_frame(w, &f), -EINVAL);
    f.stride = 8;
    f.bytes_used = 15; /* short of the image */
    CHECK_EQ_INT(sp_capture_write_frame(w, &f), -EINVAL);
    f.bytes_used = 16;
    f.format = SP_PIXFMT_NONE;
    CHECK_EQ_INT(sp_capture_write_frame(w, &f), -EINVAL);
    f.format = SP_PIXFMT_MJPEG;
    f.width = 0;
    CHECK_EQ_INT(sp_capture_write_frame(w, &f), -EINVAL);
    f.width = 4;
    CHECK_EQ_INT(sp_capture_write_frame(w, &f), 0);
    uint64_t bytes = sp_capture_writer_bytes(w);
    CHECK_EQ_INT(bytes, file_size(path)); /* rejected appends left nothing behind */
    CHECK_EQ_INT(sp_capture_writer_close(&w), 0);
    CHECK_EQ_INT(sp_capture_writer_close(&w), 0);
    CHECK_EQ_INT(sp_capture_writer_close(NULL), 0);
    free(f.data);

    /* overwrite replaces; periodic sync with a zero interval syncs every chunk */
    s.overwrite = 1;
    s.sync = SP_SYNC_PERIODIC;
    s.sync_interval_ms = 0;
    CHECK_EQ_INT(sp_capture_writer_open(&w, path, &s), 0);
    CHECK_EQ_INT(sp_capture_write_meta(w, -100, "{}", 2), 0);
    CHECK_EQ_INT(sp_capture_writer_close(&w), 0);
    recs v;
    CHECK_EQ_INT(read_all(path, 0, &v, NULL, NULL), 0);
    CHECK_EQ_INT(v.n, 3); /* META, INDEX, END */
    CHECK_EQ_INT(v.r[0].type, SP_CHUNK_META);
    CHECK_EQ_INT(v.r[1].type, SP_CHUNK_INDEX);
    CHECK_EQ_INT(v.r[2].type, SP_CHUNK_END);
    CHECK(v.r[1].ts == -100 && v.r[2].ts == -100); /* INDEX and END carry the latest timestamp */
    recs_free(&v);
}

static sp_chunk chunk_of(uint16_t type, const uint8_t *p, uint32_t size)
{
    sp_chunk c = { .type = type, .payload = p, .payload_size = size };
    return c;
}

static void test_payload_checks(void)
{
    uint8_t p[128];
    memset(p, 0, sizeof(p));
    sp_frame_chunk fc;
    sp_chunk c = chunk_of(SP_CHUNK_IMU, p, 64);
    CHECK_EQ_INT(sp_chunk_parse_frame(&c, &fc), -EINVAL); /* wrong type */
    CHECK_EQ_INT(sp_chunk_parse_frame(NULL, &fc), -EINVAL);
    c = chunk_of(SP_CHUNK_FRAME, p, 47);
    CHECK_EQ_INT(sp_chunk_parse_frame(&c, &fc), SP_ECORRUPT);
    /* a valid 4x2 GRAY8 frame, then break each field */
    spc_put32(p, 48);
    spc_put32(p + 4, SP_PIXFMT_GRAY8);
    spc_put32(p + 8, 4);
    spc_put32(p + 12, 2);
    spc_put32(p + 16, 4);
    spc_put32(p + 40, 8);
    c = chunk_of(SP_CHUNK_FRAME, p, 56);
    CHECK_EQ_INT(sp_chunk_parse_frame(&c, &fc), 0);
    CHECK_EQ_INT(fc.data_size, 8);
    c.payload_size = 55; /* data_size disagrees with the payload */
    CHECK_EQ_INT(sp_chunk_parse_frame(&c, &fc), SP_ECORRUPT);
    spc_put32(p + 40, 7);
    CHECK_EQ_INT(sp_chunk_parse_frame(&c, &fc), SP_ECORRUPT); /* consistent but short of 4x2 */
    spc_put32(p + 40, 8);
    c.payload_size = 56;
    spc_put32(p + 16, 3); /* stride below width */
    CHECK_EQ_INT(sp_chunk_parse_frame(&c, &fc), SP_ECORRUPT);
    spc_put32(p + 16, 4);
    spc_put32(p + 4, 99);
    CHECK_EQ_INT(sp_chunk_parse_frame(&c, &fc), SP_EUNSUPPORTED);
    spc_put32(p + 4, SP_PIXFMT_GRAY8);
    spc_put32(p, 0xFFFFFFF0u); /* header size beyond the payload */
    CHECK_EQ_INT(sp_chunk_parse_frame(&c, &fc), SP_ECORRUPT);
    spc_put32(p, 52); /* a longer header from a newer minor version: data follows it */
    spc_put32(p + 40, 4);
    spc_put32(p + 12, 1);
    CHECK_EQ_INT(sp_chunk_parse_frame(&c, &fc), 0);
    CHECK(fc.data == p + 52);

    memset(p, 0, sizeof(p));
    c = chunk_of(SP_CHUNK_IMU, p, 7);
    CHECK_EQ_INT(sp_chunk_imu_count(&c), SP_ECORRUPT);
    spc_put32(p, 24);
    spc_put32(p + 4, 2);
    c.payload_size = 8 + 48;
    CHECK_EQ_INT(sp_chunk_imu_count(&c), 2);
    c.payload_size = 8 + 47;
    CHECK_EQ_INT(sp_chunk_imu_count(&c), SP_ECORRUPT);
    spc_put32(p + 4, 0x80000000u); /* count * record size overflows 32 bits */
    c.payload_size = 8;
    CHECK_EQ_INT(sp_chunk_imu_count(&c), SP_ECORRUPT);
    spc_put32(p + 4, 0);
    CHECK_EQ_INT(sp_chunk_imu_count(&c), SP_ECORRUPT); /* empty batch */
    spc_put32(p, 23);
    spc_put32(p + 4, 1);
    c.payload_size = 8 + 23;
    CHECK_EQ_INT(sp_chunk_imu_count(&c), SP_ECORRUPT); /* record shorter than v1.0's */
    c.type = SP_CHUNK_SIDE;
    CHECK_EQ_INT(sp_chunk_imu_count(&c), -EINVAL);

    sp_side_chunk sd;
    memset(p, 0, sizeof(p));
    c = chunk_of(SP_CHUNK_SIDE, p, 23);
    CHECK_EQ_INT(sp_chunk_parse_side(&c, &sd), SP_ECORRUPT);
    spc_put32(p, 24);
    spc_put32(p + 16, 0x40000001u); /* count * 4 wraps 32 bits to 4 */
    c.payload_size = 28;
    CHECK_EQ_INT(sp_chunk_parse_side(&c, &sd), SP_ECORRUPT);
    spc_put32(p + 16, 1);
    CHECK_EQ_INT(sp_chunk_parse_side(&c, &sd), 0);
    CHECK(isnan(sp_side_value(NULL, 0)));
}

/* ---- header errors ---- */

static int open_code(const char *path)
{
    sp_capture_reader *r = NULL;
    int err = sp_capture_reader_open(&r, path, NULL);
    CHECK((err == 0) == (r != NULL));
    sp_capture_reader_close(&r);
    return err;
}

static void test_header_errors(void)
{
    const char *path = tmp_path("hdr.spcap");
    CHECK_EQ_INT(open_code(tmp_path("missing.spcap")), -ENOENT);
    uint8_t h[SPC_HDR_SIZE];
    spc_build_file_header(h, 0, 0);
    for (size_t n = 0; n < SPC_HDR_SIZE; n++) {
        write_file(path, h, n);
        CHECK_MSG(open_code(path) == SP_ETRUNCATED, "header cut at %zu", n);
    }
    write_file(path, h, SPC_HDR_SIZE);
    CHECK_EQ_INT(open_code(path), 0);

    uint8_t bad[SPC_HDR_SIZE];
    memcpy(bad, h, sizeof(bad));
    bad[1] = 'X';
    write_file(path, bad, sizeof(bad));
    CHECK_EQ_INT(open_code(path), SP_EFORMAT);
    write_file(path, (const uint8_t *)"PK\3\4", 4); /* a short file of another kind */
    CHECK_EQ_INT(open_code(path), SP_EFORMAT);

    memcpy(bad, h, sizeof(bad));
    spc_put16(bad + SPC_HDR_OFF_MAJOR, SP_CAPTURE_VERSION_MAJOR + 1);
    spc_put32(bad + SPC_HDR_OFF_CRC, sp_crc32c(0, bad, SPC_HDR_OFF_CRC));
    write_file(path, bad, sizeof(bad));
    CHECK_EQ_INT(open_code(path), SP_EVERSION);
    write_file(path, bad, 12); /* even a truncated newer header says "version" */
    CHECK_EQ_INT(open_code(path), SP_EVERSION);
    sp_recover_report rep;
    CHECK_EQ_INT(sp_capture_recover(path, NULL, &rep), SP_EVERSION);
    CHECK_EQ_INT(file_size(path), 12); /* recovery never touches what it does not understand */

    memcpy(bad, h, sizeof(bad));
    spc_put16(bad + SPC_HDR_OFF_MINOR, 99); /* newer minor: fine */
    spc_put32(bad + SPC_HDR_OFF_CRC, sp_crc32c(0, bad, SPC_HDR_OFF_CRC));
    write_file(path, bad, sizeof(bad));
    CHECK_EQ_INT(open_code(path), 0);

    memcpy(bad, h, sizeof(bad));
    bad[20] ^= 4; /* creation time damaged */
    write_file(path, bad, sizeof(bad));
    CHECK_EQ_INT(open_code(path), SP_ECORRUPT);

    memcpy(bad, h, sizeof(bad));
    spc_put32(bad + SPC_HDR_OFF_SIZE, 1u << 20); /* absurd header size, valid CRC */
    spc_put32(bad + SPC_HDR_OFF_CRC, sp_crc32c(0, bad, SPC_HDR_OFF_CRC));
    write_file(path, bad, sizeof(bad));
    CHECK_EQ_INT(open_code(path), SP_ECORRUPT);
    spc_put32(bad + SPC_HDR_OFF_SIZE, 1024); /* plausible but the file ends first */
    spc_put32(bad + SPC_HDR_OFF_CRC, sp_crc32c(0, bad, SPC_HDR_OFF_CRC));
    write_file(path, bad, sizeof(bad));
    CHECK_EQ_INT(open_code(path), SP_ETRUNCATED);

    sp_capture_reader_settings rs;
    sp_capture_reader_default_settings(&rs);
    CHECK_EQ_INT(rs.max_chunk_size, 256u << 20);
    CHECK_EQ_INT(rs.skip_corrupt, 0);
    rs.max_chunk_size = 0;
    sp_capture_reader *r = NULL;
    CHECK_EQ_INT(sp_capture_reader_open(&r, path, &rs), -EINVAL);
}

/* ---- damage ---- */

/* Index of the chunk holding byte `pos`, or -1 for the file header. */
static int chunk_at(const recs *ref, uint64_t pos)
{
    for (int i = 0; i < ref->n; i++)
        if (pos >= ref->r[i].offset && pos < ref->r[i].offset + SPC_CHUNK_HDR_SIZE + ref->r[i].size)
            return i;
    return -1;
}

/* Flips one bit; strict reading stops at the damaged chunk, skipping drops exactly that chunk. */
static void check_flip(const char *path, const recs *ref, uint64_t bit)
{
    int fd = open(path, O_RDWR);
    uint8_t byte;
    CHECK(pread(fd, &byte, 1, (off_t)(bit / 8)) == 1);
    byte ^= (uint8_t)(1u << (bit % 8));
    CHECK(pwrite(fd, &byte, 1, (off_t)(bit / 8)) == 1);
    int k = chunk_at(ref, bit / 8);
    recs v;
    uint64_t count = 0, first = 0;
    if (k < 0) {
        int err = open_code(path);
        CHECK_MSG(err == SP_ECORRUPT || err == SP_EFORMAT || err == SP_EVERSION, "header bit %llu: %d",
                  (unsigned long long)bit, err);
    } else {
        CHECK_EQ_INT(read_all(path, 0, &v, NULL, NULL), 0);
        CHECK_MSG(v.n == k && v.last == SP_ECORRUPT && v.last_offset == ref->r[k].offset,
                  "bit %llu: %d chunks, %d at %llu", (unsigned long long)bit, v.n, v.last,
                  (unsigned long long)v.last_offset);
        for (int i = 0; i < v.n && i < k; i++)
            CHECK(rec_equal(&v.r[i], &ref->r[i]));
        recs_free(&v);
        CHECK_EQ_INT(read_all(path, 1, &v, &count, &first), 0);
        CHECK_MSG(count == 1 && first == ref->r[k].offset && v.n == ref->n - 1, "skip, bit %llu: %d chunks",
                  (unsigned long long)bit, v.n);
        for (int i = 0, j = 0; i < ref->n && j < v.n; i++)
            if (i != k)
                CHECK(rec_equal(&v.r[j++], &ref->r[i]));
        /* a lost END leaves either a clean end of file or a damaged tail */
        CHECK(v.last == SP_EOS || (k == ref->n - 1 && v.last == SP_ETRUNCATED && v.last_offset == ref->r[k].offset));
        recs_free(&v);
    }
    byte ^= (uint8_t)(1u << (bit % 8));
    CHECK(pwrite(fd, &byte, 1, (off_t)(bit / 8)) == 1);
    close(fd);
}

static void test_bit_flips(void)
{
    const char *path = tmp_path("flip.spcap");
    write_small(path, 4, 3);
    recs ref;
    CHECK_EQ_INT(read_all(path, 0, &ref, NULL, NULL), 0);
    CHECK_EQ_INT(ref.last, SP_EOS);
    uint64_t size = file_size(path);
    /* every bit of the file: no flip goes unnoticed, none costs more than its chunk */
    for (uint64_t bit = 0; bit < size * 8; bit++)
        check_flip(path, &ref, bit);
    recs_free(&ref);
}

/* Damage in a big file's middle: resynchronisation finds the next chunk by scanning. */
static void test_resync_far(void)
{
    const char *path = tmp_path("resync.spcap");
    sp_capture_writer *w = open_writer(path, 0);
    for (int i = 0; i < 4; i++) {
        sp_frame f = make_frame(SP_PIXFMT_GRAY8, 500, 400, 500, 200000, (uint64_t)i);
        CHECK_EQ_INT(sp_capture_write_frame(w, &f), 0);
        free(f.data);
    }
    CHECK_EQ_INT(sp_capture_writer_close(&w), 0);
    recs ref;
    CHECK_EQ_INT(read_all(path, 0, &ref, NULL, NULL), 0);
    CHECK_EQ_INT(ref.n, 5);
    /* wipe chunk 1's header: the scan must cross 200 KB of frame data to chunk 2 */
    int fd = open(path, O_RDWR);
    uint8_t zero[16] = { 0 };
    CHECK(pwrite(fd, zero, sizeof(zero), (off_t)ref.r[1].offset + 4) == (ssize_t)sizeof(zero));
    close(fd);
    recs v;
    uint64_t count, first;
    CHECK_EQ_INT(read_all(path, 1, &v, &count, &first), 0);
    CHECK_EQ_INT(count, 1);
    CHECK_EQ_INT(first, ref.r[1].offset);
    CHECK_EQ_INT(v.n, 4);
    CHECK(v.n == 4 && rec_equal(&v.r[1], &ref.r[2]) && rec_equal(&v.r[3], &ref.r[4]));
    recs_free(&v);
    recs_free(&ref);
}

/* ---- torn tails ---- */

static void check_recovered(const char *path, const recs *ref, int kept)
{
    recs v;
    CHECK_EQ_INT(read_all(path, 0, &v, NULL, NULL), 0);
    CHECK_MSG(v.n == kept + 1 && v.last == SP_EOS, "kept %d: read %d, last %d", kept, v.n, v.last);
    for (int i = 0; i < kept && i < v.n; i++)
        CHECK(rec_equal(&v.r[i], &ref->r[i]));
    if (v.n == kept + 1) {
        const rec *end = &v.r[kept];
        CHECK_EQ_INT(end->type, SP_CHUNK_END);
        CHECK_EQ_INT(end->offset + SPC_CHUNK_HDR_SIZE + end->size, file_size(path));
        uint64_t want = kept ? ref->r[kept - 1].offset + SPC_CHUNK_HDR_SIZE + ref->r[kept - 1].size : SPC_HDR_SIZE;
        CHECK_EQ_INT(end->offset, want);
        if (end->size == SPC_END_SIZE)
            CHECK_EQ_INT(spc_get64(end->payload + 8), kept);
    }
    recs_free(&v);
}

static void test_torn_tail(void)
{
    const char *path = tmp_path("torn_full.spcap");
    write_small(path, 3, 3);
    recs ref;
    CHECK_EQ_INT(read_all(path, 0, &ref, NULL, NULL), 0);
    size_t size;
    uint8_t *full = read_file(path, &size);
    CHECK(full && ref.n > 8 && ref.r[ref.n - 1].type == SP_CHUNK_END);
    const char *cut = tmp_path("torn.spcap"), *copy = tmp_path("torn_copy.spcap");
    for (size_t len = 0; full && len <= size; len++) {
        write_file(cut, full, len);
        /* complete chunks in the prefix, and where the first incomplete one starts */
        int whole = 0;
        while (whole < ref.n && ref.r[whole].offset + SPC_CHUNK_HDR_SIZE + ref.r[whole].size <= len)
            whole++;
        uint64_t boundary = whole ? ref.r[whole - 1].offset + SPC_CHUNK_HDR_SIZE + ref.r[whole - 1].size
                                  : SPC_HDR_SIZE;
        if (len < SPC_HDR_SIZE) {
            CHECK_EQ_INT(open_code(cut), SP_ETRUNCATED);
        } else {
            for (int skip = 0; skip < 2; skip++) {
                recs v;
                uint64_t count = 9;
                CHECK_EQ_INT(read_all(cut, skip, &v, &count, NULL), 0);
                CHECK_MSG(v.n == whole, "len %zu: %d chunks, want %d", len, v.n, whole);
                if (len == boundary)
                    CHECK_EQ_INT(v.last, SP_EOS);
                else
                    CHECK_MSG(v.last == SP_ETRUNCATED && v.last_offset == boundary, "len %zu: %d at %llu", len,
                              v.last, (unsigned long long)v.last_offset);
                CHECK_EQ_INT(count, 0); /* a torn tail is not corruption */
                recs_free(&v);
            }
        }
        /* alternate in place and to a copy */
        int in_place = len % 2 == 0;
        sp_recover_report rep;
        unlink(copy);
        CHECK_EQ_INT(sp_capture_recover(cut, in_place ? NULL : copy, &rep), 0);
        int kept = whole == ref.n ? whole - 1 : whole; /* the END is not counted */
        uint64_t valid = len < SPC_HDR_SIZE ? 0 : boundary;
        CHECK_MSG(rep.chunks_kept == (uint64_t)kept && rep.valid_bytes == valid, "len %zu: kept %llu valid %llu",
                  len, (unsigned long long)rep.chunks_kept, (unsigned long long)rep.valid_bytes);
        CHECK_EQ_INT(rep.bytes_dropped, len - valid);
        CHECK_EQ_INT(rep.had_end, whole == ref.n);
        check_recovered(in_place ? cut : copy, &ref, kept);
        if (!in_place) {
            size_t n;
            uint8_t *src = read_file(cut, &n);
            CHECK(src && n == len && memcmp(src, full, len) == 0); /* the source is untouched */
            free(src);
        }
        /* recovering a recovered file changes nothing */
        const char *again = in_place ? cut : copy;
        uint64_t before = file_size(again);
        CHECK_EQ_INT(sp_capture_recover(again, NULL, &rep), 0);
        CHECK(rep.had_end && rep.bytes_dropped == 0 && file_size(again) == before);
    }
    free(full);
    recs_free(&ref);
}

static void test_recover_cases(void)
{
    const char *path = tmp_path("rec.spcap"), *copy = tmp_path("rec_copy.spcap");
    write_small(path, 3, 2);
    recs ref;
    CHECK_EQ_INT(read_all(path, 0, &ref, NULL, NULL), 0);
    uint64_t size = file_size(path);
    sp_recover_report rep;
    CHECK_EQ_INT(sp_capture_recover(NULL, NULL, &rep), -EINVAL);
    CHECK_EQ_INT(sp_capture_recover(tmp_path("none.spcap"), NULL, &rep), -ENOENT);
    /* clean file: nothing to do */
    CHECK_EQ_INT(sp_capture_recover(path, NULL, &rep), 0);
    CHECK(rep.had_end && rep.bytes_dropped == 0 && rep.valid_bytes == size && file_size(path) == size);
    CHECK_EQ_INT(rep.chunks_kept, (uint64_t)ref.n - 1);
    /* junk after END goes */
    int fd = open(path, O_WRONLY | O_APPEND);
    CHECK(write(fd, "junkjunk", 8) == 8);
    close(fd);
    CHECK_EQ_INT(sp_capture_recover(path, copy, &rep), 0);
    CHECK(rep.had_end && rep.bytes_dropped == 8 && file_size(copy) == size && file_size(path) == size + 8);
    /* an existing target is never overwritten */
    CHECK_EQ_INT(sp_capture_recover(path, copy, &rep), -EEXIST);
    CHECK_EQ_INT(file_size(copy), size);
    CHECK_EQ_INT(sp_capture_recover(path, NULL, NULL), 0);
    CHECK_EQ_INT(file_size(path), size);
    /* damage in the middle: the valid prefix ends before it */
    int k = 4;
    fd = open(path, O_RDWR);
    uint8_t byte = 0;
    off_t where = (off_t)ref.r[k].offset + SPC_CHUNK_HDR_SIZE + 1;
    CHECK(pread(fd, &byte, 1, where) == 1);
    byte ^= 0x10;
    CHECK(pwrite(fd, &byte, 1, where) == 1);
    close(fd);
    unlink(copy);
    CHECK_EQ_INT(sp_capture_recover(path, copy, &rep), 0);
    CHECK_EQ_INT(rep.chunks_kept, k);
    CHECK_EQ_INT(rep.valid_bytes, ref.r[k].offset);
    CHECK(!rep.had_end);
    check_recovered(copy, &ref, k);
    /* a file of another kind is refused and left alone */
    uint8_t text[100];
    memset(text, 'a', sizeof(text));
    write_file(path, text, sizeof(text));
    CHECK_EQ_INT(sp_capture_recover(path, NULL, &rep), SP_EFORMAT);
    CHECK_EQ_INT(file_size(path), sizeof(text));
    unlink(copy);
    CHECK_EQ_INT(sp_capture_recover(path, copy, &rep), SP_EFORMAT);
    CHECK(access(copy, F_OK) < 0); /* a failed copy is removed */
    recs_free(&ref);
}

/* ---- absurd lengths ---- */

static void test_absurd_lengths(void)
{
    const char *path = tmp_path("absurd.spcap");
    write_small(path, 0, 1);
    recs ref;
    CHECK_EQ_INT(read_all(path, 0, &ref, NULL, NULL), 0);
    size_t size;
    uint8_t *b = read_file(path, &size);
    CHECK(b && ref.n >= 3);
    if (!b)
        return;
    uint64_t at = ref.r[1].offset;
    /* a header that checks out yet claims 4 GiB: refused before any allocation */
    uint8_t *h = b + at;
    spc_build_chunk_header(h, SP_CHUNK_FRAME, 0, 0xFFFFFFF0u, spc_get32(h + SPC_CH_OFF_PCRC), 1);
    write_file(path, b, size);
    recs v;
    uint64_t count;
    CHECK_EQ_INT(read_all(path, 0, &v, NULL, NULL), 0);
    CHECK(v.n == 1 && v.last == SP_ECORRUPT && v.last_offset == at);
    recs_free(&v);
    CHECK_EQ_INT(read_all(path, 1, &v, &count, NULL), 0);
    CHECK(v.n == 1 && count == 1 && v.last == SP_EOS);
    recs_free(&v);
    /* 200 MiB is under the limit but past the end of the file: a torn tail, nothing allocated */
    spc_build_chunk_header(h, SP_CHUNK_FRAME, 0, 200u << 20, 0, 1);
    write_file(path, b, size);
    CHECK_EQ_INT(read_all(path, 0, &v, NULL, NULL), 0);
    CHECK(v.n == 1 && v.last == SP_ETRUNCATED && v.last_offset == at);
    recs_free(&v);
    sp_recover_report rep;
    CHECK_EQ_INT(sp_capture_recover(path, NULL, &rep), 0);
    CHECK(rep.chunks_kept == 1 && rep.valid_bytes == at);
    /* a reader with a small limit treats bigger chunks as corrupt */
    write_small(path, 0, 1);
    sp_capture_reader_settings s;
    sp_capture_reader_default_settings(&s);
    s.max_chunk_size = 40;
    sp_capture_reader *r = NULL;
    CHECK_EQ_INT(sp_capture_reader_open(&r, path, &s), 0);
    sp_chunk c;
    CHECK_EQ_INT(sp_capture_reader_next(r, &c), 0); /* META: 34 bytes */
    CHECK_EQ_INT(sp_capture_reader_next(r, &c), SP_ECORRUPT); /* FRAME: 63 bytes */
    CHECK_EQ_INT(c.offset, at);
    sp_capture_reader_close(&r);
    free(b);
    recs_free(&ref);
}

/* ---- index and seek ---- */

typedef struct seek_ref {
    uint64_t offset;
    int64_t ts;
} seek_ref;

/* The chunk seek should land on: greatest timestamp <= t, earliest on ties; -1 = start of file. */
static int expected_seek(const seek_ref *all, int n, int64_t t)
{
    int best = -1;
    for (int i = 0; i < n; i++)
        if (all[i].ts <= t && (best < 0 || all[i].ts > all[best].ts))
            best = i;
    return best;
}

static void check_seeks(const char *path, const seek_ref *all, int n, int indexed)
{
    sp_capture_reader *r = NULL;
    CHECK_EQ_INT(sp_capture_reader_open(&r, path, NULL), 0);
    if (!r)
        return;
    sp_chunk c;
    for (int64_t t = -3000000; t <= 700000000; t += 1234567) {
        CHECK_EQ_INT(sp_capture_reader_seek(r, t), 0);
        int want = expected_seek(all, indexed, t);
        int err = sp_capture_reader_next(r, &c);
        CHECK_EQ_INT(err, 0);
        uint64_t want_off = want < 0 ? SPC_HDR_SIZE : all[want].offset;
        CHECK_MSG(c.offset == want_off, "t=%lld: at %llu, want %llu", (long long)t, (unsigned long long)c.offset,
                  (unsigned long long)want_off);
    }
    /* seek_offset to any reported chunk, and refusals */
    for (int i = 0; i < n; i += 97) {
        CHECK_EQ_INT(sp_capture_reader_seek_offset(r, all[i].offset), 0);
        CHECK(sp_capture_reader_next(r, &c) == 0 && c.offset == all[i].offset && c.timestamp_ns == all[i].ts);
    }
    CHECK_EQ_INT(sp_capture_reader_seek_offset(r, 10), -EINVAL);
    CHECK_EQ_INT(sp_capture_reader_seek_offset(r, UINT64_MAX / 2), -EINVAL);
    /* after reaching the END, a seek makes the file readable again */
    while (sp_capture_reader_next(r, &c) == 0) {
    }
    CHECK_EQ_INT(sp_capture_reader_seek(r, INT64_MIN), 0);
    CHECK(sp_capture_reader_next(r, &c) == 0 && c.offset == SPC_HDR_SIZE);
    sp_capture_reader_close(&r);
}

static void test_seek(void)
{
    const char *path = tmp_path("seek.spcap");
    sp_capture_writer *w = open_writer(path, 16);
    enum { N = 1210 }; /* not a multiple of the interval: the last index comes at close */
    static seek_ref all[N];
    int n = 0;
    for (int i = 0; i < N / 2; i++) {
        sp_frame f = make_frame(SP_PIXFMT_GRAY8, 2, 2, 2, 4, (uint64_t)i);
        CHECK_EQ_INT(sp_capture_write_frame(w, &f), 0);
        free(f.data);
        /* IMU batches start slightly before the frame they follow: timestamps are not monotonic in file order */
        sp_imu_sample s = { f.timestamp_ns - 400000, SP_IMU_GYRO, { 0, 0, 0 } };
        CHECK_EQ_INT(sp_capture_write_imu(w, &s, 1), 0);
    }
    CHECK_EQ_INT(sp_capture_writer_close(&w), 0);
    sp_capture_reader *r = NULL;
    CHECK_EQ_INT(sp_capture_reader_open(&r, path, NULL), 0);
    sp_chunk c;
    int indexes = 0;
    uint64_t end_offset = 0;
    while (r && sp_capture_reader_next(r, &c) == 0) {
        if (c.type == SP_CHUNK_INDEX) {
            indexes++;
            end_offset = c.offset;
        } else if (n < N) {
            all[n++] = (seek_ref){ c.offset, c.timestamp_ns };
        }
    }
    sp_capture_reader_close(&r);
    CHECK_EQ_INT(n, N);
    CHECK_EQ_INT(indexes, N / 16 + 1);
    check_seeks(path, all, n, n);
    /* a crashed file (no END, no final index): seek finds the indexes by walking the headers */
    size_t size;
    uint8_t *b = read_file(path, &size);
    const char *crashed = tmp_path("seek_crashed.spcap");
    write_file(crashed, b, (size_t)end_offset);
    free(b);
    check_seeks(crashed, all, n, n - (N % 16));
}

/* ---- full disk ---- */

/* In a child with a file size limit, frames are appended until the limit bites. */
static void test_disk_full(void)
{
    const char *path = tmp_path("full.spcap");
    int fds[2];
    CHECK(pipe(fds) == 0);
    pid_t pid = fork();
    if (pid == 0) {
        close(fds[0]);
        signal(SIGXFSZ, SIG_IGN);
        struct rlimit rl = { 20000, 20000 };
        setrlimit(RLIMIT_FSIZE, &rl);
        sp_capture_writer *w = open_writer(path, 2);
        int32_t ok = 0, err = 0;
        for (int i = 0; w && i < 100 && err == 0; i++) {
            sp_frame f = make_frame(SP_PIXFMT_GRAY8, 30, 100, 30, 3000 + (size_t)i * 10, (uint64_t)i);
            err = sp_capture_write_frame(w, &f);
            free(f.data);
            ok += err == 0;
        }
        uint64_t bytes = sp_capture_writer_bytes(w);
        int32_t msg[4] = { ok, err, (int32_t)bytes, (int32_t)file_size(path) };
        CHECK(write(fds[1], msg, sizeof(msg)) == (ssize_t)sizeof(msg));
        sp_capture_writer_close(&w); /* END may not fit: that is fine */
        _exit(0);
    }
    close(fds[1]);
    int32_t msg[4] = { 0 };
    CHECK(read(fds[0], msg, sizeof(msg)) == (ssize_t)sizeof(msg));
    close(fds[0]);
    int status;
    waitpid(pid, &status, 0);
    CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    CHECK_EQ_INT(msg[1], -EFBIG);
    CHECK(msg[0] >= 3 && msg[0] < 10);
    CHECK_EQ_INT(msg[2], msg[3]); /* the failed append was cut back */
    recs v;
    CHECK_EQ_INT(read_all(path, 0, &v, NULL, NULL), 0);
    int frames = 0;
    for (int i = 0; i < v.n; i++)
        frames += v.r[i].type == SP_CHUNK_FRAME;
    CHECK_EQ_INT(frames, msg[0]); /* every frame that returned 0 is there, whole */
    CHECK(v.last == SP_EOS);
    recs_free(&v);
}

int main(void)
{
    make_tmpdir();
    test_roundtrip();
    test_forward_compat();
    test_writer_errors();
    test_payload_checks();
    test_header_errors();
    test_bit_flips();
    test_resync_far();
    test_torn_tail();
    test_recover_cases();
    test_absurd_lengths();
    test_seek();
    test_disk_full();
    remove_tmpdir();
    return check_exit();
}
