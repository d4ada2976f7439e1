/* SPDX-License-Identifier: MIT */
/*
 * On-disk layout of the .spcap container (capture/FORMAT.md is the spec) and the
 * little-endian helpers and chunk checks shared by the writer, reader and recovery.
 * Internal: not installed.
 */
#ifndef SUNPROBE_CAPTURE_CONTAINER_FORMAT_H
#define SUNPROBE_CAPTURE_CONTAINER_FORMAT_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "sunprobe/sp_capture.h"

/* ---- file header (64 bytes; header_size may grow in later minor versions) ---- */
#define SPC_MAGIC "\x89SPCAP\r\n"
#define SPC_MAGIC_LEN 8
#define SPC_HDR_SIZE 64u       /* fixed part, CRC-protected */
#define SPC_HDR_MAX_SIZE 4096u /* largest header_size a reader accepts */
enum {
    SPC_HDR_OFF_MAGIC = 0,       /* 8 bytes */
    SPC_HDR_OFF_MAJOR = 8,       /* u16 */
    SPC_HDR_OFF_MINOR = 10,      /* u16 */
    SPC_HDR_OFF_SIZE = 12,       /* u32: offset of the first chunk */
    SPC_HDR_OFF_CREATED = 16,    /* i64: wall-clock ns since 1970, 0 = unknown */
    SPC_HDR_OFF_CREATED_MONO = 24, /* i64: monotonic clock at creation */
    SPC_HDR_OFF_FLAGS = 32,      /* u32, 0 */
    SPC_HDR_OFF_CRC = 60,        /* u32: CRC32C of bytes 0..59 */
};

/* ---- chunk header (32 bytes) ---- */
#define SPC_SYNC 0x4B43538Au /* bytes 8A 'S' 'C' 'K' on disk */
#define SPC_CHUNK_HDR_SIZE 32u
enum {
    SPC_CH_OFF_SYNC = 0,     /* u32 */
    SPC_CH_OFF_TYPE = 4,     /* u16 */
    SPC_CH_OFF_FLAGS = 6,    /* u16 */
    SPC_CH_OFF_SIZE = 8,     /* u32 payload bytes */
    SPC_CH_OFF_PCRC = 12,    /* u32 CRC32C of the payload */
    SPC_CH_OFF_TIME = 16,    /* i64 ns */
    SPC_CH_OFF_RESERVED = 24, /* u32, 0 */
    SPC_CH_OFF_HCRC = 28,    /* u32 CRC32C of bytes 0..27 */
};

/* The writer refuses, and recovery does not keep, payloads above this (the reader's default limit). */
#define SPC_MAX_PAYLOAD (256u << 20)

/* ---- payload layouts ---- */
#define SPC_FRAME_HDR_SIZE 48u /* u32 hdr_size, format, width, height, stride, stream_id, u64 seq,
                                  f32 exposure, f32 gain, u32 data_size, u32 reserved */
#define SPC_IMU_HDR_SIZE 8u    /* u32 record_size, u32 count */
#define SPC_IMU_REC_SIZE 24u   /* i64 t, u32 sensor, f32 x, y, z */
#define SPC_SIDE_HDR_SIZE 24u  /* u32 hdr_size, u32 kind, u64 frame_seq, u32 count, u32 reserved */
#define SPC_INDEX_HDR_SIZE 16u /* u64 prev_index_offset (0 = none), u32 count, u32 entry_size */
#define SPC_INDEX_ENTRY_SIZE 24u /* u64 offset, i64 t, u16 type, u16 flags, u32 payload_size */
#define SPC_END_SIZE 16u       /* u64 last_index_offset (0 = none), u64 chunks before END */
#define SPC_INDEX_MAX_INTERVAL (1u << 16)

/* ---- little-endian helpers (unaligned, any host byte order) ---- */
static inline void spc_put16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

static inline void spc_put32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static inline void spc_put64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static inline void spc_putf32(uint8_t *p, float f)
{
    uint32_t v;
    memcpy(&v, &f, 4);
    spc_put32(p, v);
}

static inline uint16_t spc_get16(const uint8_t *p)
{
    return (uint16_t)(p[0] | (p[1] << 8));
}

static inline uint32_t spc_get32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

static inline uint64_t spc_get64(const uint8_t *p)
{
    return (uint64_t)spc_get32(p) | ((uint64_t)spc_get32(p + 4) << 32);
}

static inline float spc_getf32(const uint8_t *p)
{
    uint32_t v = spc_get32(p);
    float f;
    memcpy(&f, &v, 4);
    return f;
}

/* ---- shared checks (container_reader.c) ---- */

/* A chunk header as decoded from disk. */
typedef struct spc_chunk_header {
    uint16_t type, flags;
    uint32_t payload_size;
    uint32_t payload_crc;
    int64_t timestamp_ns;
} spc_chunk_header;

/*
 * Validates the file header in `buf` of `len` bytes (the first bytes of the file).
 * Returns 0 with *major, *minor, *header_size and *created set, or SP_EFORMAT,
 * SP_EVERSION, SP_ETRUNCATED (len too short) or SP_ECORRUPT.
 */
int spc_parse_file_header(const uint8_t *buf, size_t len, uint16_t *major, uint16_t *minor,
                          uint32_t *header_size, int64_t *created);
/* Fills a 64-byte file header for this library's version. */
void spc_build_file_header(uint8_t out[SPC_HDR_SIZE], int64_t created_utc_ns, int64_t created_mono_ns);
/* Decodes 32 bytes; 0 if sync word and header CRC check out, else SP_ECORRUPT. */
int spc_parse_chunk_header(const uint8_t *buf, spc_chunk_header *out);
void spc_build_chunk_header(uint8_t out[SPC_CHUNK_HDR_SIZE], uint16_t type, uint16_t flags,
                            uint32_t payload_size, uint32_t payload_crc, int64_t timestamp_ns);
/* pread of exactly len bytes unless the file ends first; returns bytes read or a negative errno. */
int64_t spc_pread_full(int fd, void *buf, size_t len, uint64_t offset);
/* Writes len bytes at offset, retrying short writes and EINTR; 0 or a negative errno. */
int spc_pwrite_full(int fd, const void *buf, size_t len, uint64_t offset);
/* fsync of the directory holding path, so a new name is durable. */
int spc_sync_parent_dir(const char *path);

/*
 * Replay's copy-free path. get_dst is called for a FRAME chunk whose chunk and
 * frame headers checked out (fc->data is NULL: nothing read yet; head->payload
 * holds only the frame header). It returns 0 with *dst pointing at
 * fc->data_size writable bytes, -EAGAIN to leave the chunk unread for a later
 * call, or an error. It may be called again for another chunk (or the same one
 * re-read) before spc_reader_next_direct returns, when a payload fails its CRC.
 */
typedef struct spc_frame_sink {
    int (*get_dst)(void *user, const sp_chunk *head, const sp_frame_chunk *fc, uint8_t **dst);
    void *user;
} spc_frame_sink;

/*
 * sp_capture_reader_next, except that a FRAME chunk's pixel data may be read
 * straight into the sink's memory and CRC-checked there. *direct = 1 then, and
 * the chunk's payload is NULL (payload_size is still the whole payload's);
 * otherwise the chunk is as sp_capture_reader_next returns it.
 */
int spc_reader_next_direct(sp_capture_reader *r, sp_chunk *chunk, const spc_frame_sink *sink, int *direct);

#endif
