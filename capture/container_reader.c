/* SPDX-License-Identifier: MIT */
/*
 * .spcap reader: pread-based, one reusable buffer bounded by max_chunk_size
 * plus a read-ahead window, so memory stays flat on multi-GB files. Each read
 * also fetches the bytes after the chunk, so the next header and small chunks
 * (IMU, metadata) come from memory: about one syscall per frame. Replay can
 * have pixel data read straight into its frames (spc_reader_next_direct).
 * Also the payload views and the header checks shared with recovery.
 * Layout: capture/FORMAT.md.
 */
#include "sunprobe/sp_capture.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>

#include "capture/container_format.h"
#include "common/crc32c.h"

#define SCAN_WINDOW (64u << 10)
#define MIN_BUFFER (4u << 10)
#define READ_AHEAD (64u << 10) /* read past each chunk: the next headers and small chunks */

struct sp_capture_reader {
    int fd;
    sp_capture_reader_settings s;
    sp_capture_info info;
    uint64_t header_size;   /* offset of the first chunk */
    uint64_t pos;           /* offset of the next chunk to read */
    int ended;              /* an END chunk was returned */
    uint8_t *buf;           /* file bytes [win_off, win_off + win_len): the last payload and read-ahead */
    size_t buf_cap;
    uint64_t win_off;
    size_t win_len;
    uint8_t *scan;          /* resynchronisation window, allocated on first use */
    uint64_t corrupt_count;
    uint64_t first_corrupt;
    int last_index_known;
    uint64_t last_index;    /* offset of the last INDEX chunk, 0 = none */
};

/* ---- shared with the writer and recovery ---- */

int64_t spc_pread_full(int fd, void *buf, size_t len, uint64_t offset)
{
    uint8_t *p = buf;
    size_t done = 0;
    while (done < len) {
        ssize_t n = pread(fd, p + done, len - done, (off_t)(offset + done));
        if (n < 0) {
            if (errno == EINTR)
                continue;
            return -errno;
        }
        if (n == 0)
            break;
        done += (size_t)n;
    }
    return (int64_t)done;
}

void spc_build_file_header(uint8_t out[SPC_HDR_SIZE], int64_t created_utc_ns, int64_t created_mono_ns)
{
    memset(out, 0, SPC_HDR_SIZE);
    memcpy(out + SPC_HDR_OFF_MAGIC, SPC_MAGIC, SPC_MAGIC_LEN);
    spc_put16(out + SPC_HDR_OFF_MAJOR, SP_CAPTURE_VERSION_MAJOR);
    spc_put16(out + SPC_HDR_OFF_MINOR, SP_CAPTURE_VERSION_MINOR);
    spc_put32(out + SPC_HDR_OFF_SIZE, SPC_HDR_SIZE);
    spc_put64(out + SPC_HDR_OFF_CREATED, (uint64_t)created_utc_ns);
    spc_put64(out + SPC_HDR_OFF_CREATED_MONO, (uint64_t)created_mono_ns);
    spc_put32(out + SPC_HDR_OFF_CRC, sp_crc32c(0, out, SPC_HDR_OFF_CRC));
}

int spc_parse_file_header(const uint8_t *buf, size_t len, uint16_t *major, uint16_t *minor,
                          uint32_t *header_size, int64_t *created)
{
    if (len < SPC_MAGIC_LEN)
        return memcmp(buf, SPC_MAGIC, len) == 0 ? SP_ETRUNCATED : SP_EFORMAT;
    if (memcmp(buf, SPC_MAGIC, SPC_MAGIC_LEN) != 0)
        return SP_EFORMAT;
    if (len < SPC_HDR_OFF_MAJOR + 2)
        return SP_ETRUNCATED;
    /* the version comes before the checksum: a newer major may lay out the rest differently */
    uint16_t maj = spc_get16(buf + SPC_HDR_OFF_MAJOR);
    if (maj > SP_CAPTURE_VERSION_MAJOR)
        return SP_EVERSION;
    if (maj == 0)
        return SP_EFORMAT;
    if (len < SPC_HDR_SIZE)
        return SP_ETRUNCATED;
    if (spc_get32(buf + SPC_HDR_OFF_CRC) != sp_crc32c(0, buf, SPC_HDR_OFF_CRC))
        return SP_ECORRUPT;
    uint32_t hs = spc_get32(buf + SPC_HDR_OFF_SIZE);
    if (hs < SPC_HDR_SIZE || hs > SPC_HDR_MAX_SIZE)
        return SP_ECORRUPT;
    *major = maj;
    *minor = spc_get16(buf + SPC_HDR_OFF_MINOR);
    *header_size = hs;
    *created = (int64_t)spc_get64(buf + SPC_HDR_OFF_CREATED);
    return 0;
}

void spc_build_chunk_header(uint8_t out[SPC_CHUNK_HDR_SIZE], uint16_t type, uint16_t flags,
                            uint32_t payload_size, uint32_t payload_crc, int64_t timestamp_ns)
{
    spc_put32(out + SPC_CH_OFF_SYNC, SPC_SYNC);
    spc_put16(out + SPC_CH_OFF_TYPE, type);
    spc_put16(out + SPC_CH_OFF_FLAGS, flags);
    spc_put32(out + SPC_CH_OFF_SIZE, payload_size);
    spc_put32(out + SPC_CH_OFF_PCRC, payload_crc);
    spc_put64(out + SPC_CH_OFF_TIME, (uint64_t)timestamp_ns);
    spc_put32(out + SPC_CH_OFF_RESERVED, 0);
    spc_put32(out + SPC_CH_OFF_HCRC, sp_crc32c(0, out, SPC_CH_OFF_HCRC));
}

int spc_parse_chunk_header(const uint8_t *buf, spc_chunk_header *out)
{
    if (spc_get32(buf + SPC_CH_OFF_SYNC) != SPC_SYNC ||
        spc_get32(buf + SPC_CH_OFF_HCRC) != sp_crc32c(0, buf, SPC_CH_OFF_HCRC))
        return SP_ECORRUPT;
    out->type = spc_get16(buf + SPC_CH_OFF_TYPE);
    out->flags = spc_get16(buf + SPC_CH_OFF_FLAGS);
    out->payload_size = spc_get32(buf + SPC_CH_OFF_SIZE);
    out->payload_crc = spc_get32(buf + SPC_CH_OFF_PCRC);
    out->timestamp_ns = (int64_t)spc_get64(buf + SPC_CH_OFF_TIME);
    return 0;
}

/* ---- reader ---- */

void sp_capture_reader_default_settings(sp_capture_reader_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->skip_corrupt = 0;
    s->max_chunk_size = SPC_MAX_PAYLOAD;
}

/* Re-reads the file size, which grows while a writer appends. */
static int refresh_size(sp_capture_reader *r)
{
    struct stat st;
    if (fstat(r->fd, &st) < 0)
        return -errno;
    r->info.file_size = st.st_size > 0 ? (uint64_t)st.st_size : 0;
    return 0;
}

/* True when [off, off + len) lies inside the file, re-checking the size once if not. */
static int available(sp_capture_reader *r, uint64_t off, uint64_t len)
{
    if (off <= r->info.file_size && len <= r->info.file_size - off)
        return 1;
    if (refresh_size(r) < 0)
        return 0;
    return off <= r->info.file_size && len <= r->info.file_size - off;
}

static int read_header(sp_capture_reader *r)
{
    uint8_t hdr[SPC_HDR_SIZE];
    int64_t n = spc_pread_full(r->fd, hdr, sizeof(hdr), 0);
    if (n < 0)
        return (int)n;
    uint32_t hs = 0;
    int err = spc_parse_file_header(hdr, (size_t)n, &r->info.version_major, &r->info.version_minor, &hs,
                                    &r->info.created_utc_ns);
    if (err < 0)
        return err;
    if (!available(r, 0, hs))
        return SP_ETRUNCATED;
    r->header_size = hs;
    r->pos = hs;
    return 0;
}

int sp_capture_reader_open(sp_capture_reader **out, const char *path, const sp_capture_reader_settings *s)
{
    if (!out || !path)
        return -EINVAL;
    *out = NULL;
    sp_capture_reader_settings defaults;
    sp_capture_reader_default_settings(&defaults);
    if (!s)
        s = &defaults;
    if (s->max_chunk_size == 0)
        return -EINVAL;
    sp_capture_reader *r = calloc(1, sizeof(*r));
    if (!r)
        return -ENOMEM;
    r->s = *s;
    r->first_corrupt = UINT64_MAX;
    r->fd = open(path, O_RDONLY | O_CLOEXEC);
    int err = r->fd < 0 ? -errno : refresh_size(r);
    if (err == 0) /* mostly read front to back: ask for a larger kernel read-ahead (advice only) */
        (void)posix_fadvise(r->fd, 0, 0, POSIX_FADV_SEQUENTIAL);
    if (err == 0)
        err = read_header(r);
    if (err < 0) {
        sp_capture_reader_close(&r);
        return err;
    }
    *out = r;
    return 0;
}

void sp_capture_reader_close(sp_capture_reader **pr)
{
    if (!pr || !*pr)
        return;
    sp_capture_reader *r = *pr;
    if (r->fd >= 0)
        close(r->fd);
    free(r->buf);
    free(r->scan);
    free(r);
    *pr = NULL;
}

const sp_capture_info *sp_capture_reader_info(const sp_capture_reader *r)
{
    return r ? &r->info : NULL;
}

/* Grows buf to hold need bytes, keeping its contents; never beyond the largest chunk plus the read-ahead. */
static int reserve(sp_capture_reader *r, size_t need)
{
    if (need <= r->buf_cap)
        return 0;
    size_t limit = (size_t)r->s.max_chunk_size + SPC_CHUNK_HDR_SIZE + READ_AHEAD;
    size_t cap = r->buf_cap ? r->buf_cap : MIN_BUFFER;
    while (cap < need)
        cap *= 2;
    if (cap > limit)
        cap = need > limit ? need : limit;
    uint8_t *p = realloc(r->buf, cap);
    if (!p)
        return -ENOMEM;
    r->buf = p;
    r->buf_cap = cap;
    return 0;
}

/*
 * Makes buf hold the file from `off` on, at least `need` bytes unless the file
 * ends first, reading READ_AHEAD more when it has to read. Returns how many
 * bytes from off are held, at *at, or a negative errno.
 */
static int64_t window(sp_capture_reader *r, uint64_t off, size_t need, const uint8_t **at)
{
    size_t keep = 0;
    if (off >= r->win_off && off - r->win_off <= r->win_len) {
        size_t skip = (size_t)(off - r->win_off);
        keep = r->win_len - skip;
        *at = r->buf + skip;
        if (keep >= need)
            return (int64_t)keep;
        memmove(r->buf, r->buf + skip, keep); /* at most the read-ahead: the rest follows it */
    }
    size_t want = need + READ_AHEAD;
    int err = reserve(r, want);
    if (err < 0)
        return err;
    r->win_off = off;
    r->win_len = keep;
    *at = r->buf;
    int64_t n = spc_pread_full(r->fd, r->buf + keep, want - keep, off + keep);
    if (n < 0)
        return n;
    r->win_len += (size_t)n;
    return (int64_t)r->win_len;
}

static void drop_window(sp_capture_reader *r)
{
    r->win_len = 0;
}

/* The chunk header at `off` (in the window afterwards): 0, SP_EOS, SP_ETRUNCATED, SP_ECORRUPT or an error. */
static int read_header_at(sp_capture_reader *r, uint64_t off, spc_chunk_header *h, uint64_t *extent)
{
    *extent = 0;
    if (!available(r, off, 1))
        return SP_EOS;
    const uint8_t *at;
    int64_t n = window(r, off, SPC_CHUNK_HDR_SIZE, &at);
    if (n < 0)
        return (int)n;
    if (n < (int64_t)SPC_CHUNK_HDR_SIZE)
        return SP_ETRUNCATED;
    if (spc_parse_chunk_header(at, h) < 0)
        return SP_ECORRUPT;
    *extent = SPC_CHUNK_HDR_SIZE + (uint64_t)h->payload_size;
    if (h->payload_size > r->s.max_chunk_size)
        return SP_ECORRUPT;
    if (!available(r, off, *extent))
        return SP_ETRUNCATED;
    return 0;
}

static void fill_chunk(sp_chunk *c, const spc_chunk_header *h, uint64_t off, const uint8_t *payload)
{
    c->type = h->type;
    c->flags = h->flags;
    c->timestamp_ns = h->timestamp_ns;
    c->offset = off;
    c->payload_size = h->payload_size;
    c->payload = payload;
}

/* The whole chunk in buf: header, then payload, CRC checked. */
static int read_buffered(sp_capture_reader *r, uint64_t off, const spc_chunk_header *h, sp_chunk *c)
{
    const uint8_t *at;
    int64_t n = window(r, off, SPC_CHUNK_HDR_SIZE + (size_t)h->payload_size, &at);
    if (n < 0)
        return (int)n;
    if (n < (int64_t)(SPC_CHUNK_HDR_SIZE + (uint64_t)h->payload_size))
        return SP_ETRUNCATED; /* the file shrank under us */
    const uint8_t *payload = at + SPC_CHUNK_HDR_SIZE;
    if (sp_crc32c(0, payload, h->payload_size) != h->payload_crc)
        return SP_ECORRUPT;
    fill_chunk(c, h, off, payload);
    return 0;
}

/* Reads len bytes at off into dst and what follows into the window, one preadv per pass. */
static int read_into(sp_capture_reader *r, uint8_t *dst, size_t len, uint64_t off)
{
    size_t got = 0;
    r->win_len = 0;
    while (got < len) {
        struct iovec iov[2] = { { dst + got, len - got }, { r->buf, READ_AHEAD } };
        ssize_t n = preadv(r->fd, iov, 2, (off_t)(off + got));
        if (n < 0 && errno == EINTR)
            continue;
        if (n < 0)
            return -errno;
        if (n == 0)
            return SP_ETRUNCATED; /* the file shrank under us */
        if ((size_t)n > len - got) {
            r->win_off = off + len;
            r->win_len = (size_t)n - (len - got);
        }
        got = (size_t)n > len - got ? len : got + (size_t)n;
    }
    return 0;
}

/*
 * A FRAME chunk with its pixel data read into the caller's memory. Returns 1
 * when this path does not apply (the caller reads the chunk into buf instead).
 */
static int read_direct(sp_capture_reader *r, uint64_t off, const spc_chunk_header *h, sp_chunk *c,
                       const spc_frame_sink *sink)
{
    size_t size = h->payload_size;
    const uint8_t *at;
    int64_t n = window(r, off, SPC_CHUNK_HDR_SIZE + (size < SPC_FRAME_HDR_SIZE ? size : SPC_FRAME_HDR_SIZE), &at);
    if (n < 0)
        return (int)n;
    const uint8_t *payload = at + SPC_CHUNK_HDR_SIZE;
    size_t held = (size_t)n - SPC_CHUNK_HDR_SIZE, hs = size >= 4 && held >= 4 ? spc_get32(payload) : 0;
    sp_frame_chunk fc;
    sp_chunk head = { 0 };
    fill_chunk(&head, h, off, payload);
    /* headers that do not check out (or do not fit the window) take the ordinary path and fail there */
    if (hs == 0 || hs > held || sp_chunk_parse_frame(&head, &fc) != 0)
        return 1;
    fc.data = NULL;
    uint8_t *dst = NULL;
    int err = sink->get_dst(sink->user, &head, &fc, &dst);
    if (err)
        return err;
    size_t in_win = held - hs < fc.data_size ? held - hs : fc.data_size;
    uint32_t crc = sp_crc32c(0, payload, hs);
    memcpy(dst, payload + hs, in_win);
    err = read_into(r, dst + in_win, fc.data_size - in_win, off + SPC_CHUNK_HDR_SIZE + hs + in_win);
    if (err)
        return err;
    if (sp_crc32c(crc, dst, fc.data_size) != h->payload_crc)
        return SP_ECORRUPT;
    fill_chunk(c, h, off, NULL);
    return 0;
}

/*
 * Reads and checks the chunk at `off`. Returns 0, SP_EOS (at the end of the
 * file), SP_ETRUNCATED, SP_ECORRUPT or an I/O error. *extent is set to the
 * chunk's total size when its header checked out (so a bad payload can be
 * stepped over), else 0. With a sink, a FRAME chunk's pixel data may go to the
 * sink's memory (*direct = 1; c->payload is then NULL).
 */
static int read_chunk_once(sp_capture_reader *r, uint64_t off, sp_chunk *c, uint64_t *extent,
                           const spc_frame_sink *sink, int *direct)
{
    spc_chunk_header h = { 0 };
    *direct = 0;
    int err = read_header_at(r, off, &h, extent);
    if (err)
        return err;
    if (sink && h.type == SP_CHUNK_FRAME) {
        err = read_direct(r, off, &h, c, sink);
        if (err != 1) {
            *direct = err == 0;
            return err;
        }
    }
    return read_buffered(r, off, &h, c);
}

static int read_chunk_at(sp_capture_reader *r, uint64_t off, sp_chunk *c, uint64_t *extent,
                         const spc_frame_sink *sink, int *direct)
{
    int cached = off >= r->win_off && off - r->win_off < r->win_len;
    int err = read_chunk_once(r, off, c, extent, sink, direct);
    /*
     * Bytes held from an earlier read may be stale: a writer that failed
     * mid-chunk truncates the torn tail and writes it again. Failures seen in
     * held bytes are checked once more against the file itself.
     */
    if (cached && (err == SP_ECORRUPT || err == SP_ETRUNCATED)) {
        drop_window(r);
        err = read_chunk_once(r, off, c, extent, sink, direct);
    }
    return err;
}

/* Offset of the next chunk header at or after `from` whose sync word and CRC check out, or UINT64_MAX. */
static uint64_t scan_for_chunk(sp_capture_reader *r, uint64_t from)
{
    if (!r->scan && !(r->scan = malloc(SCAN_WINDOW + SPC_CHUNK_HDR_SIZE)))
        return UINT64_MAX;
    spc_chunk_header h;
    for (uint64_t off = from;;) {
        /* windows overlap by one header so a header across a window edge is still seen */
        int64_t n = spc_pread_full(r->fd, r->scan, SCAN_WINDOW + SPC_CHUNK_HDR_SIZE - 1, off);
        if (n < (int64_t)SPC_CHUNK_HDR_SIZE)
            return UINT64_MAX;
        size_t last = (size_t)n - SPC_CHUNK_HDR_SIZE;
        for (size_t i = 0; i <= last; i++) {
            const uint8_t *p = memchr(r->scan + i, 0x8A, last + 1 - i);
            if (!p)
                break;
            i = (size_t)(p - r->scan);
            if (spc_parse_chunk_header(p, &h) == 0)
                return off + i;
        }
        off += last + 1;
    }
}

static void note_corrupt(sp_capture_reader *r, uint64_t off)
{
    r->corrupt_count++;
    if (r->first_corrupt == UINT64_MAX)
        r->first_corrupt = off;
}

static int next_chunk(sp_capture_reader *r, sp_chunk *chunk, const spc_frame_sink *sink, int *direct)
{
    for (;;) {
        *direct = 0;
        if (r->ended)
            return SP_EOS;
        uint64_t extent;
        int err = read_chunk_at(r, r->pos, chunk, &extent, sink, direct);
        if (err == 0) {
            r->pos += SPC_CHUNK_HDR_SIZE + chunk->payload_size;
            if (chunk->type == SP_CHUNK_INDEX)
                r->last_index = r->last_index > chunk->offset ? r->last_index : chunk->offset;
            if (chunk->type != SP_CHUNK_END)
                return 0;
            r->ended = 1;
            return SP_EOS;
        }
        if (err != SP_ECORRUPT || !r->s.skip_corrupt) {
            if (err == SP_ECORRUPT || err == SP_ETRUNCATED)
                chunk->offset = r->pos;
            return err;
        }
        note_corrupt(r, r->pos);
        /* a header that checked out gives the extent; otherwise hunt for the next sync word */
        uint64_t next = extent ? r->pos + extent : scan_for_chunk(r, r->pos + 1);
        if (next == UINT64_MAX) {
            chunk->offset = r->pos;
            r->pos = r->info.file_size > r->pos ? r->info.file_size : r->pos;
            return SP_ETRUNCATED;
        }
        r->pos = next;
    }
}

int sp_capture_reader_next(sp_capture_reader *r, sp_chunk *chunk)
{
    if (!r || !chunk)
        return -EINVAL;
    int direct;
    return next_chunk(r, chunk, NULL, &direct);
}

int spc_reader_next_direct(sp_capture_reader *r, sp_chunk *chunk, const spc_frame_sink *sink, int *direct)
{
    if (!r || !chunk || !sink || !sink->get_dst || !direct)
        return -EINVAL;
    return next_chunk(r, chunk, sink, direct);
}

uint64_t sp_capture_reader_corrupt_count(const sp_capture_reader *r)
{
    return r ? r->corrupt_count : 0;
}

uint64_t sp_capture_reader_first_corrupt_offset(const sp_capture_reader *r)
{
    return r ? r->first_corrupt : UINT64_MAX;
}

int sp_capture_reader_saw_end(const sp_capture_reader *r)
{
    return r ? r->ended : 0;
}

int sp_capture_reader_seek_offset(sp_capture_reader *r, uint64_t offset)
{
    if (!r || offset < r->header_size || !available(r, offset, 0))
        return -EINVAL;
    r->pos = offset;
    r->ended = 0;
    return 0;
}

/* The END chunk of a cleanly closed file names the last index. */
static int last_index_from_end(sp_capture_reader *r, uint64_t *out)
{
    uint64_t size = r->info.file_size, len = SPC_CHUNK_HDR_SIZE + SPC_END_SIZE;
    if (size < r->header_size + len)
        return SP_ENODATA;
    uint8_t b[SPC_CHUNK_HDR_SIZE + SPC_END_SIZE];
    spc_chunk_header h;
    if (spc_pread_full(r->fd, b, sizeof(b), size - len) != (int64_t)sizeof(b) ||
        spc_parse_chunk_header(b, &h) < 0 || h.type != SP_CHUNK_END || h.payload_size != SPC_END_SIZE ||
        sp_crc32c(0, b + SPC_CHUNK_HDR_SIZE, SPC_END_SIZE) != h.payload_crc)
        return SP_ENODATA;
    uint64_t last = spc_get64(b + SPC_CHUNK_HDR_SIZE);
    if (last != 0 && (last < r->header_size || last >= size - len))
        return SP_ENODATA;
    *out = last;
    return 0;
}

/* Without an END chunk, walk the chunk headers (payloads unread) to the last INDEX. */
static uint64_t last_index_by_walk(sp_capture_reader *r)
{
    uint64_t last = 0;
    uint8_t b[SPC_CHUNK_HDR_SIZE];
    spc_chunk_header h;
    for (uint64_t off = r->header_size;;) {
        if (spc_pread_full(r->fd, b, sizeof(b), off) != (int64_t)sizeof(b) || spc_parse_chunk_header(b, &h) < 0)
            break;
        uint64_t extent = SPC_CHUNK_HDR_SIZE + (uint64_t)h.payload_size;
        if (extent > r->info.file_size - off || h.type == SP_CHUNK_END)
            break;
        if (h.type == SP_CHUNK_INDEX)
            last = off;
        off += extent;
    }
    return last;
}

typedef struct seek_best {
    uint64_t offset;
    int64_t timestamp;
    int found;
} seek_best;

/* Folds one INDEX chunk's entries into best; returns its link to the previous index or 0. */
static uint64_t scan_index(const sp_chunk *c, uint64_t header_size, int64_t t, seek_best *best)
{
    if (c->type != SP_CHUNK_INDEX || c->payload_size < SPC_INDEX_HDR_SIZE)
        return 0;
    const uint8_t *p = c->payload;
    uint64_t prev = spc_get64(p);
    uint32_t count = spc_get32(p + 8), esize = spc_get32(p + 12);
    if (esize < SPC_INDEX_ENTRY_SIZE || (uint64_t)count * esize > c->payload_size - SPC_INDEX_HDR_SIZE)
        return 0;
    for (uint32_t i = 0; i < count; i++) {
        const uint8_t *e = p + SPC_INDEX_HDR_SIZE + (size_t)i * esize;
        uint64_t off = spc_get64(e);
        int64_t ts = (int64_t)spc_get64(e + 8);
        if (off < header_size || off >= c->offset || ts > t)
            continue;
        if (!best->found || ts > best->timestamp || (ts == best->timestamp && off < best->offset)) {
            best->found = 1;
            best->timestamp = ts;
            best->offset = off;
        }
    }
    /* links must go strictly backwards, so a damaged chain cannot loop */
    return prev < c->offset && prev >= header_size ? prev : 0;
}

int sp_capture_reader_seek(sp_capture_reader *r, int64_t timestamp_ns)
{
    if (!r)
        return -EINVAL;
    if (!r->last_index_known) {
        uint64_t last = 0;
        if (refresh_size(r) < 0 || last_index_from_end(r, &last) < 0)
            last = last_index_by_walk(r);
        r->last_index = last > r->last_index ? last : r->last_index;
        r->last_index_known = 1;
    }
    seek_best best = { 0 };
    sp_chunk c;
    uint64_t extent;
    int direct;
    for (uint64_t off = r->last_index; off != 0;) {
        if (read_chunk_at(r, off, &c, &extent, NULL, &direct) < 0)
            break; /* a damaged index only makes the seek land earlier */
        off = scan_index(&c, r->header_size, timestamp_ns, &best);
    }
    r->pos = best.found ? best.offset : r->header_size;
    r->ended = 0;
    return 0;
}

/* ---- payload views ---- */

int sp_chunk_parse_frame(const sp_chunk *c, sp_frame_chunk *out)
{
    if (!c || !out || c->type != SP_CHUNK_FRAME || (c->payload_size && !c->payload))
        return -EINVAL;
    if (c->payload_size < SPC_FRAME_HDR_SIZE)
        return SP_ECORRUPT;
    const uint8_t *p = c->payload;
    uint32_t hs = spc_get32(p), data_size = spc_get32(p + 40);
    if (hs < SPC_FRAME_HDR_SIZE || hs > c->payload_size || data_size != c->payload_size - hs || data_size == 0)
        return SP_ECORRUPT;
    uint32_t fmt = spc_get32(p + 4);
    if (fmt == SP_PIXFMT_NONE || fmt >= SP_PIXFMT_COUNT)
        return SP_EUNSUPPORTED;
    sp_frame_chunk f = {
        .format = (enum sp_pixfmt)fmt,
        .width = spc_get32(p + 8),
        .height = spc_get32(p + 12),
        .stride = spc_get32(p + 16),
        .stream_id = spc_get32(p + 20),
        .sequence = spc_get64(p + 24),
        .exposure_us = spc_getf32(p + 32),
        .gain = spc_getf32(p + 36),
        .data = p + hs,
        .data_size = data_size,
    };
    if (f.width == 0 || f.height == 0)
        return SP_ECORRUPT;
    if (f.format != SP_PIXFMT_MJPEG) {
        size_t need = sp_pixfmt_image_size(f.format, f.width, f.height, f.stride);
        if (need == 0 || data_size < need)
            return SP_ECORRUPT;
    }
    *out = f;
    return 0;
}

int64_t sp_chunk_imu_count(const sp_chunk *c)
{
    if (!c || c->type != SP_CHUNK_IMU || (c->payload_size && !c->payload))
        return -EINVAL;
    if (c->payload_size < SPC_IMU_HDR_SIZE)
        return SP_ECORRUPT;
    uint32_t rec = spc_get32(c->payload), count = spc_get32(c->payload + 4);
    if (rec < SPC_IMU_REC_SIZE || count == 0 ||
        (uint64_t)count * rec != (uint64_t)c->payload_size - SPC_IMU_HDR_SIZE)
        return SP_ECORRUPT;
    return count;
}

int sp_chunk_imu_get(const sp_chunk *c, size_t i, sp_imu_sample *out)
{
    int64_t n = sp_chunk_imu_count(c);
    if (n < 0)
        return (int)n;
    if (!out || i >= (uint64_t)n)
        return -EINVAL;
    const uint8_t *p = c->payload + SPC_IMU_HDR_SIZE + i * spc_get32(c->payload);
    out->timestamp_ns = (int64_t)spc_get64(p);
    out->sensor = spc_get32(p + 8);
    for (int k = 0; k < 3; k++)
        out->v[k] = spc_getf32(p + 12 + 4 * k);
    return 0;
}

int sp_chunk_parse_side(const sp_chunk *c, sp_side_chunk *out)
{
    if (!c || !out || c->type != SP_CHUNK_SIDE || (c->payload_size && !c->payload))
        return -EINVAL;
    if (c->payload_size < SPC_SIDE_HDR_SIZE)
        return SP_ECORRUPT;
    const uint8_t *p = c->payload;
    uint32_t hs = spc_get32(p), count = spc_get32(p + 16);
    if (hs < SPC_SIDE_HDR_SIZE || hs > c->payload_size || (uint64_t)count * 4 != c->payload_size - hs)
        return SP_ECORRUPT;
    out->frame_sequence = spc_get64(p + 8);
    out->kind = spc_get32(p + 4);
    out->count = count;
    out->values = p + hs;
    return 0;
}

float sp_side_value(const sp_side_chunk *side, uint32_t i)
{
    if (!side || !side->values || i >= side->count)
        return NAN;
    return spc_getf32(side->values + 4 * (size_t)i);
}
