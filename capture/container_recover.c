/* SPDX-License-Identifier: MIT */
/*
 * .spcap recovery: keep the longest prefix of whole, checksummed chunks and close
 * it with an END chunk, in place (truncate) or into a new file (stream copy).
 * Memory is one fixed copy buffer whatever the file size. Rules: capture/FORMAT.md.
 */
#include "sunprobe/sp_capture.h"

#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "capture/container_format.h"
#include "common/crc32c.h"

#define COPY_BUFFER (1u << 20)

typedef struct walk {
    int fd, out_fd;        /* out_fd < 0: in place */
    uint64_t file_size;
    uint8_t *buf;          /* buf_size bytes: the file, or COPY_BUFFER if bigger */
    size_t buf_size;
    uint64_t pos;          /* end of the valid prefix so far */
    uint64_t chunks;       /* whole chunks before any END */
    uint64_t last_index;   /* 0 = none */
    int64_t max_timestamp; /* of the chunks kept; INT64_MIN before any */
    int had_end;
} walk;

/* Reads [off, off + len) in pieces, checksumming and (when copying) writing each piece at the same offset. */
static int stream_range(walk *w, uint64_t off, uint64_t len, uint32_t *crc)
{
    while (len > 0) {
        size_t n = len < w->buf_size ? (size_t)len : w->buf_size;
        int64_t got = spc_pread_full(w->fd, w->buf, n, off);
        if (got < 0)
            return (int)got;
        if ((size_t)got != n)
            return SP_ETRUNCATED;
        if (crc)
            *crc = sp_crc32c(*crc, w->buf, n);
        if (w->out_fd >= 0) {
            int err = spc_pwrite_full(w->out_fd, w->buf, n, off);
            if (err < 0)
                return err;
        }
        off += n;
        len -= n;
    }
    return 0;
}

/*
 * Checks the chunk at w->pos. Returns 1 and advances past it when it is whole and
 * its checksums match, 0 when the valid prefix ends here, or a negative I/O error.
 */
static int step(walk *w)
{
    uint8_t hb[SPC_CHUNK_HDR_SIZE];
    spc_chunk_header h;
    if (w->file_size - w->pos < SPC_CHUNK_HDR_SIZE)
        return 0;
    int64_t n = spc_pread_full(w->fd, hb, sizeof(hb), w->pos);
    if (n < 0)
        return (int)n;
    if (n != (int64_t)sizeof(hb) || spc_parse_chunk_header(hb, &h) < 0 || h.payload_size > SPC_MAX_PAYLOAD ||
        w->file_size - w->pos - SPC_CHUNK_HDR_SIZE < h.payload_size)
        return 0;
    uint32_t crc = 0;
    int err = stream_range(w, w->pos + SPC_CHUNK_HDR_SIZE, h.payload_size, &crc);
    if (err == SP_ETRUNCATED)
        return 0; /* the file shrank under us */
    if (err == 0 && w->out_fd >= 0)
        err = spc_pwrite_full(w->out_fd, hb, sizeof(hb), w->pos);
    if (err < 0)
        return err;
    if (crc != h.payload_crc)
        return 0;
    if (h.type == SP_CHUNK_END) {
        w->had_end = 1;
    } else {
        w->chunks++;
        if (h.type == SP_CHUNK_INDEX)
            w->last_index = w->pos;
        if (h.timestamp_ns > w->max_timestamp)
            w->max_timestamp = h.timestamp_ns;
    }
    w->pos += SPC_CHUNK_HDR_SIZE + (uint64_t)h.payload_size;
    return 1;
}

static int append_end(walk *w, int fd)
{
    uint8_t b[SPC_CHUNK_HDR_SIZE + SPC_END_SIZE];
    spc_put64(b + SPC_CHUNK_HDR_SIZE, w->last_index);
    spc_put64(b + SPC_CHUNK_HDR_SIZE + 8, w->chunks);
    spc_build_chunk_header(b, SP_CHUNK_END, 0, SPC_END_SIZE, sp_crc32c(0, b + SPC_CHUNK_HDR_SIZE, SPC_END_SIZE),
                           w->chunks ? w->max_timestamp : 0);
    return spc_pwrite_full(fd, b, sizeof(b), w->pos);
}

/*
 * Validates the file header. A file shorter than a header whose bytes agree with
 * one (a crash while the writer created it) is rebuilt from a fresh header: *fresh = 1.
 */
static int check_header(walk *w, int *fresh)
{
    uint8_t hdr[SPC_HDR_SIZE];
    int64_t n = spc_pread_full(w->fd, hdr, sizeof(hdr), 0);
    if (n < 0)
        return (int)n;
    uint16_t major, minor;
    uint32_t hs;
    int64_t created;
    int err = spc_parse_file_header(hdr, (size_t)n, &major, &minor, &hs, &created);
    *fresh = err == SP_ETRUNCATED && n < (int64_t)SPC_HDR_SIZE;
    if (*fresh) {
        spc_build_file_header(hdr, 0, 0);
        w->pos = SPC_HDR_SIZE;
        return w->out_fd >= 0 ? spc_pwrite_full(w->out_fd, hdr, SPC_HDR_SIZE, 0) : 0;
    }
    if (err < 0)
        return err;
    if (w->file_size < hs)
        return SP_ETRUNCATED;
    w->pos = hs;
    return stream_range(w, 0, hs, NULL); /* copies the header, extensions included */
}

/* In place: the fresh header replaces the torn one; otherwise cut the tail. */
static int finish_in_place(walk *w, int fresh)
{
    if (fresh) {
        uint8_t hdr[SPC_HDR_SIZE];
        spc_build_file_header(hdr, 0, 0);
        int err = spc_pwrite_full(w->fd, hdr, sizeof(hdr), 0);
        if (err < 0)
            return err;
    }
    if (w->file_size != w->pos && ftruncate(w->fd, (off_t)w->pos) < 0)
        return -errno;
    return 0;
}

static int run(walk *w, const char *out_path, sp_recover_report *rep)
{
    int fresh = 0;
    int err = check_header(w, &fresh);
    if (err < 0)
        return err;
    while (!fresh && !w->had_end && (err = step(w)) == 1) {
    }
    if (err < 0)
        return err;
    rep->chunks_kept = w->chunks;
    rep->valid_bytes = fresh ? 0 : w->pos;
    rep->bytes_dropped = w->file_size - rep->valid_bytes;
    rep->had_end = w->had_end;
    if (w->out_fd < 0)
        err = finish_in_place(w, fresh);
    else if (ftruncate(w->out_fd, (off_t)w->pos) < 0) /* drops a copied chunk that failed its check */
        err = -errno;
    if (err < 0)
        return err;
    if (w->out_fd < 0 && w->had_end && rep->bytes_dropped == 0)
        return 0; /* a clean file: nothing was changed, nothing to sync */
    int target = w->out_fd >= 0 ? w->out_fd : w->fd;
    if (!w->had_end && (err = append_end(w, target)) < 0)
        return err;
    if (fdatasync(target) < 0)
        return -errno;
    return out_path ? spc_sync_parent_dir(out_path) : 0;
}

int sp_capture_recover(const char *path, const char *out_path, sp_recover_report *report)
{
    if (!path)
        return -EINVAL;
    sp_recover_report scratch;
    sp_recover_report *rep = report ? report : &scratch;
    memset(rep, 0, sizeof(*rep));
    walk w = { .fd = -1, .out_fd = -1, .max_timestamp = INT64_MIN };
    int err = 0;
    w.fd = open(path, (out_path ? O_RDONLY : O_RDWR) | O_CLOEXEC);
    struct stat st;
    if (w.fd < 0 || fstat(w.fd, &st) < 0) {
        err = -errno;
        goto done;
    }
    w.file_size = st.st_size > 0 ? (uint64_t)st.st_size : 0;
    w.buf_size = w.file_size < COPY_BUFFER ? (size_t)w.file_size + 1 : COPY_BUFFER;
    if (!(w.buf = malloc(w.buf_size))) {
        err = -ENOMEM;
        goto done;
    }
    if (out_path && (w.out_fd = open(out_path, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644)) < 0) {
        err = -errno;
        goto done;
    }
    err = run(&w, out_path, rep);
done:
    if (w.out_fd >= 0) {
        if (close(w.out_fd) < 0 && err == 0)
            err = -errno;
        if (err < 0)
            unlink(out_path); /* we created it; never leave a half-made copy */
    }
    if (w.fd >= 0)
        close(w.fd);
    free(w.buf);
    return err;
}
