/* SPDX-License-Identifier: MIT */
/*
 * .spcap writer: each chunk goes to disk with one pwritev (header + payload), a
 * failed append is cut back so the file always ends after a whole chunk, and
 * fdatasync follows the settings' policy. Layout: capture/FORMAT.md.
 */
#include "sunprobe/sp_capture.h"

#include <assert.h>
#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/uio.h>
#include <unistd.h>

#include "capture/container_format.h"
#include "common/clock.h"
#include "common/crc32c.h"
#include "common/json.h"

struct sp_capture_writer {
    int fd;
    sp_capture_writer_settings s;
    uint64_t offset;        /* end of the last whole chunk == file size */
    int broken;             /* a failed append could not be cut back: refuse further appends */
    int64_t last_sync_ns;
    int64_t max_timestamp;  /* stamps INDEX and END chunks; INT64_MIN until a chunk is written */
    uint64_t chunk_count;   /* chunks written, INDEX included, END excluded */
    uint64_t prev_index;    /* offset of the last INDEX chunk, 0 = none */
    uint8_t *index;         /* pending entries, SPC_INDEX_HDR_SIZE + n * SPC_INDEX_ENTRY_SIZE bytes */
    uint32_t index_count;
    uint8_t *scratch;       /* IMU batch encoding, grown as needed */
    size_t scratch_cap;
};

void sp_capture_writer_default_settings(sp_capture_writer_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->sync = SP_SYNC_PERIODIC;
    s->sync_interval_ms = 1000;
    s->index_interval = 256;
    s->overwrite = 0;
}

int spc_pwrite_full(int fd, const void *buf, size_t len, uint64_t offset)
{
    const uint8_t *p = buf;
    while (len > 0) {
        ssize_t n = pwrite(fd, p, len, (off_t)offset);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            return -errno;
        }
        if (n == 0)
            return -EIO;
        p += n;
        len -= (size_t)n;
        offset += (uint64_t)n;
    }
    return 0;
}

int spc_sync_parent_dir(const char *path)
{
    const char *slash = strrchr(path, '/');
    char *dir = NULL;
    if (!slash)
        dir = strdup(".");
    else if (slash == path)
        dir = strdup("/");
    else
        dir = strndup(path, (size_t)(slash - path));
    if (!dir)
        return -ENOMEM;
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    free(dir);
    if (fd < 0)
        return -errno;
    int err = fsync(fd) < 0 ? -errno : 0;
    close(fd);
    /* some file systems cannot fsync a directory; the data itself is synced already */
    return err == -EINVAL ? 0 : err;
}

/* Writes all iovecs at `offset`, resuming after short writes and EINTR. */
static int pwritev_full(int fd, struct iovec *iov, int n, uint64_t offset)
{
    while (n > 0) {
        ssize_t done = pwritev(fd, iov, n, (off_t)offset);
        if (done < 0) {
            if (errno == EINTR)
                continue;
            return -errno;
        }
        if (done == 0)
            return -EIO;
        offset += (uint64_t)done;
        while (n > 0 && (size_t)done >= iov->iov_len) {
            done -= (ssize_t)iov->iov_len;
            iov++;
            n--;
        }
        if (n > 0) {
            iov->iov_base = (uint8_t *)iov->iov_base + done;
            iov->iov_len -= (size_t)done;
        }
    }
    return 0;
}

static int sync_now(sp_capture_writer *w)
{
    if (fdatasync(w->fd) < 0)
        return -errno;
    w->last_sync_ns = sp_clock_monotonic_ns();
    return 0;
}

static int sync_by_policy(sp_capture_writer *w)
{
    if (w->s.sync == SP_SYNC_EVERY_CHUNK)
        return sync_now(w);
    if (w->s.sync == SP_SYNC_PERIODIC &&
        sp_clock_monotonic_ns() - w->last_sync_ns >= (int64_t)w->s.sync_interval_ms * 1000000)
        return sync_now(w);
    return 0;
}

/*
 * Appends one chunk whose payload is the concatenation of iov[1..n-1]; iov[0] is
 * filled with the chunk header here. On failure the file is cut back to its
 * previous end, so what was there stays readable.
 */
static int append_chunk(sp_capture_writer *w, uint16_t type, int64_t ts, struct iovec *iov, int n)
{
    if (w->broken)
        return -EIO;
    uint64_t size = 0;
    uint32_t crc = 0;
    for (int i = 1; i < n; i++) {
        size += iov[i].iov_len;
        crc = sp_crc32c(crc, iov[i].iov_base, iov[i].iov_len);
    }
    if (size > SPC_MAX_PAYLOAD)
        return -EFBIG;
    uint8_t hdr[SPC_CHUNK_HDR_SIZE];
    spc_build_chunk_header(hdr, type, 0, (uint32_t)size, crc, ts);
    iov[0].iov_base = hdr;
    iov[0].iov_len = sizeof(hdr);
    int err = pwritev_full(w->fd, iov, n, w->offset);
    if (err < 0) {
        /* never leave half a chunk that a later chunk could follow */
        while (ftruncate(w->fd, (off_t)w->offset) < 0) {
            if (errno != EINTR) {
                w->broken = 1;
                break;
            }
        }
        return err;
    }
    uint64_t start = w->offset;
    w->offset += SPC_CHUNK_HDR_SIZE + size;
    if (ts > w->max_timestamp)
        w->max_timestamp = ts;
    w->chunk_count++;
    if (type == SP_CHUNK_INDEX) {
        w->prev_index = start;
    } else if (w->index && type != SP_CHUNK_END) {
        assert(w->index_count < w->s.index_interval);
        uint8_t *e = w->index + SPC_INDEX_HDR_SIZE + (size_t)w->index_count * SPC_INDEX_ENTRY_SIZE;
        spc_put64(e, start);
        spc_put64(e + 8, (uint64_t)ts);
        spc_put16(e + 16, type);
        spc_put16(e + 18, 0);
        spc_put32(e + 20, (uint32_t)size);
        w->index_count++;
    }
    return sync_by_policy(w);
}

/* INDEX and END carry the largest timestamp so far, 0 before any. */
static int64_t stamp(const sp_capture_writer *w)
{
    return w->max_timestamp == INT64_MIN ? 0 : w->max_timestamp;
}

static int write_index(sp_capture_writer *w)
{
    if (!w->index || w->index_count == 0)
        return 0;
    spc_put64(w->index, w->prev_index);
    spc_put32(w->index + 8, w->index_count);
    spc_put32(w->index + 12, SPC_INDEX_ENTRY_SIZE);
    struct iovec iov[2] = {
        { 0 },
        { w->index, SPC_INDEX_HDR_SIZE + (size_t)w->index_count * SPC_INDEX_ENTRY_SIZE },
    };
    int err = append_chunk(w, SP_CHUNK_INDEX, stamp(w), iov, 2);
    if (err == 0)
        w->index_count = 0;
    return err;
}

/* A data chunk, then an INDEX chunk when the interval is full. */
static int append_data(sp_capture_writer *w, uint16_t type, int64_t ts, struct iovec *iov, int n)
{
    int full = w->index && w->index_count >= w->s.index_interval;
    int err = full ? write_index(w) : 0; /* an index that failed earlier: retry before adding entries */
    if (err == 0)
        err = append_chunk(w, type, ts, iov, n);
    if (err < 0)
        return err;
    /* the data chunk is on disk either way; a failed index is retried at the next append */
    if (w->index && w->index_count >= w->s.index_interval)
        (void)write_index(w);
    return 0;
}

static int check_settings(const sp_capture_writer_settings *s)
{
    if (s->sync != SP_SYNC_NONE && s->sync != SP_SYNC_PERIODIC && s->sync != SP_SYNC_EVERY_CHUNK)
        return -EINVAL;
    if (s->index_interval > SPC_INDEX_MAX_INTERVAL)
        return -EINVAL;
    return 0;
}

static int write_file_header(sp_capture_writer *w, const char *path)
{
    uint8_t hdr[SPC_HDR_SIZE];
    spc_build_file_header(hdr, sp_clock_realtime_ns(), sp_clock_monotonic_ns());
    int err = spc_pwrite_full(w->fd, hdr, sizeof(hdr), 0);
    if (err == 0)
        err = sync_now(w);
    if (err == 0)
        err = spc_sync_parent_dir(path);
    if (err == 0)
        w->offset = SPC_HDR_SIZE;
    return err;
}

int sp_capture_writer_open(sp_capture_writer **out, const char *path, const sp_capture_writer_settings *s)
{
    if (!out || !path || !*path)
        return -EINVAL;
    *out = NULL;
    sp_capture_writer_settings defaults;
    sp_capture_writer_default_settings(&defaults);
    if (!s)
        s = &defaults;
    int err = check_settings(s);
    if (err < 0)
        return err;
    sp_capture_writer *w = calloc(1, sizeof(*w));
    if (!w)
        return -ENOMEM;
    w->fd = -1;
    w->s = *s;
    w->max_timestamp = INT64_MIN;
    if (s->index_interval) {
        w->index = malloc(SPC_INDEX_HDR_SIZE + (size_t)s->index_interval * SPC_INDEX_ENTRY_SIZE);
        if (!w->index) {
            err = -ENOMEM;
            goto fail;
        }
    }
    int flags = O_WRONLY | O_CREAT | O_CLOEXEC | (s->overwrite ? O_TRUNC : O_EXCL);
    w->fd = open(path, flags, 0644);
    if (w->fd < 0) {
        err = -errno;
        goto fail;
    }
    err = write_file_header(w, path);
    if (err < 0)
        goto fail;
    *out = w;
    return 0;
fail:
    if (w->fd >= 0) {
        close(w->fd);
        unlink(path); /* we created it (or truncated it under overwrite); a headerless file helps nobody */
    }
    free(w->index);
    free(w);
    return err;
}

int sp_capture_write_meta(sp_capture_writer *w, int64_t timestamp_ns, const char *json, size_t len)
{
    if (!w || !json || len == 0 || len > SPC_MAX_PAYLOAD)
        return -EINVAL;
    /* refuse what no reader could use: the payload must be one JSON object */
    sp_json *root = NULL;
    char msg[64];
    if (sp_json_parse(json, len, &root, msg, sizeof(msg)) < 0)
        return -EINVAL;
    int is_object = root->type == SP_JSON_OBJECT;
    sp_json_free(root);
    if (!is_object)
        return -EINVAL;
    struct iovec iov[2] = { { 0 }, { (void *)json, len } };
    return append_data(w, SP_CHUNK_META, timestamp_ns, iov, 2);
}

/* Same rules as sp_chunk_parse_frame, so the writer never produces a frame the reader refuses. */
static int check_frame(const sp_frame *f)
{
    if (f->format <= SP_PIXFMT_NONE || f->format >= SP_PIXFMT_COUNT || f->width == 0 || f->height == 0)
        return -EINVAL;
    if (f->bytes_used == 0 || !f->data || (f->capacity && f->bytes_used > f->capacity))
        return -EINVAL;
    if (f->bytes_used > SPC_MAX_PAYLOAD - SPC_FRAME_HDR_SIZE)
        return -EFBIG;
    if (f->format == SP_PIXFMT_MJPEG)
        return 0;
    size_t need = sp_pixfmt_image_size(f->format, f->width, f->height, f->stride);
    return need == 0 || f->bytes_used < need ? -EINVAL : 0;
}

int sp_capture_write_frame(sp_capture_writer *w, const sp_frame *frame)
{
    if (!w || !frame)
        return -EINVAL;
    int err = check_frame(frame);
    if (err < 0)
        return err;
    uint8_t h[SPC_FRAME_HDR_SIZE];
    spc_put32(h, SPC_FRAME_HDR_SIZE);
    spc_put32(h + 4, (uint32_t)frame->format);
    spc_put32(h + 8, frame->width);
    spc_put32(h + 12, frame->height);
    spc_put32(h + 16, frame->format == SP_PIXFMT_MJPEG ? 0 : frame->stride);
    spc_put32(h + 20, frame->stream_id);
    spc_put64(h + 24, frame->sequence);
    spc_putf32(h + 32, frame->exposure_us);
    spc_putf32(h + 36, frame->gain);
    spc_put32(h + 40, (uint32_t)frame->bytes_used);
    spc_put32(h + 44, 0);
    struct iovec iov[3] = { { 0 }, { h, sizeof(h) }, { frame->data, frame->bytes_used } };
    return append_data(w, SP_CHUNK_FRAME, frame->timestamp_ns, iov, 3);
}

static int reserve_scratch(sp_capture_writer *w, size_t need)
{
    if (need <= w->scratch_cap)
        return 0;
    size_t cap = w->scratch_cap ? w->scratch_cap : 4096;
    while (cap < need)
        cap *= 2;
    uint8_t *p = realloc(w->scratch, cap);
    if (!p)
        return -ENOMEM;
    w->scratch = p;
    w->scratch_cap = cap;
    return 0;
}

int sp_capture_write_imu(sp_capture_writer *w, const sp_imu_sample *samples, size_t count)
{
    if (!w || !samples || count == 0)
        return -EINVAL;
    if (count > (SPC_MAX_PAYLOAD - SPC_IMU_HDR_SIZE) / SPC_IMU_REC_SIZE)
        return -EFBIG;
    size_t size = SPC_IMU_HDR_SIZE + count * SPC_IMU_REC_SIZE;
    int err = reserve_scratch(w, size);
    if (err < 0)
        return err;
    uint8_t *p = w->scratch;
    spc_put32(p, SPC_IMU_REC_SIZE);
    spc_put32(p + 4, (uint32_t)count);
    p += SPC_IMU_HDR_SIZE;
    for (size_t i = 0; i < count; i++, p += SPC_IMU_REC_SIZE) {
        spc_put64(p, (uint64_t)samples[i].timestamp_ns);
        spc_put32(p + 8, samples[i].sensor);
        for (int k = 0; k < 3; k++)
            spc_putf32(p + 12 + 4 * k, samples[i].v[k]);
    }
    struct iovec iov[2] = { { 0 }, { w->scratch, size } };
    return append_data(w, SP_CHUNK_IMU, samples[0].timestamp_ns, iov, 2);
}

int sp_capture_write_side(sp_capture_writer *w, int64_t timestamp_ns, uint64_t frame_sequence,
                          enum sp_side_kind kind, const float *values, uint32_t count)
{
    if (!w || (count && !values) || (uint32_t)kind == 0)
        return -EINVAL;
    if (count > (SPC_MAX_PAYLOAD - SPC_SIDE_HDR_SIZE) / 4)
        return -EFBIG;
    size_t size = (size_t)count * 4;
    int err = reserve_scratch(w, size ? size : 1);
    if (err < 0)
        return err;
    for (uint32_t i = 0; i < count; i++)
        spc_putf32(w->scratch + 4 * (size_t)i, values[i]);
    uint8_t h[SPC_SIDE_HDR_SIZE];
    spc_put32(h, SPC_SIDE_HDR_SIZE);
    spc_put32(h + 4, (uint32_t)kind);
    spc_put64(h + 8, frame_sequence);
    spc_put32(h + 16, count);
    spc_put32(h + 20, 0);
    struct iovec iov[3] = { { 0 }, { h, sizeof(h) }, { w->scratch, size } };
    return append_data(w, SP_CHUNK_SIDE, timestamp_ns, iov, 3);
}

int sp_capture_writer_sync(sp_capture_writer *w)
{
    if (!w)
        return -EINVAL;
    return sync_now(w);
}

uint64_t sp_capture_writer_bytes(const sp_capture_writer *w)
{
    return w ? w->offset : 0;
}

static int write_end(sp_capture_writer *w)
{
    uint8_t p[SPC_END_SIZE];
    spc_put64(p, w->prev_index);
    spc_put64(p + 8, w->chunk_count);
    struct iovec iov[2] = { { 0 }, { p, sizeof(p) } };
    uint64_t count = w->chunk_count;
    int err = append_chunk(w, SP_CHUNK_END, stamp(w), iov, 2);
    w->chunk_count = count; /* END is not counted */
    return err;
}

int sp_capture_writer_close(sp_capture_writer **pw)
{
    if (!pw || !*pw)
        return 0;
    sp_capture_writer *w = *pw;
    *pw = NULL;
    int err = 0;
    if (w->fd >= 0) {
        err = write_index(w);
        int e2 = write_end(w);
        if (err == 0)
            err = e2;
        e2 = sync_now(w);
        if (err == 0)
            err = e2;
        if (close(w->fd) < 0 && err == 0)
            err = -errno;
    }
    free(w->index);
    free(w->scratch);
    free(w);
    return err;
}
