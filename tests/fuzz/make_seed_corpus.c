/* SPDX-License-Identifier: MIT */
/*
 * Writes the seed corpus of the .spcap reader fuzzer into the directory given as
 * argument: valid captures made with the writer, and broken variants of them (torn,
 * flipped bits, wrong magic, newer version, absurd lengths, junk). Generated at build
 * time so no binary seeds live in the repository.
 */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "capture/container_format.h"
#include "common/crc32c.h"
#include "sunprobe/sp_capture.h"

static const char *outdir;

static int put(const char *name, const uint8_t *b, size_t len)
{
    char path[4096];
    snprintf(path, sizeof(path), "%s/%s", outdir, name);
    FILE *f = fopen(path, "wb");
    if (!f || fwrite(b, 1, len, f) != len || fclose(f) != 0) {
        fprintf(stderr, "%s: %s\n", path, strerror(errno));
        return -1;
    }
    return 0;
}

static int write_frames(sp_capture_writer *w)
{
    static const struct {
        enum sp_pixfmt fmt;
        uint32_t w, h, stride, bytes;
    } kinds[] = {
        { SP_PIXFMT_GRAY8, 6, 4, 6, 24 }, { SP_PIXFMT_RGB24, 3, 2, 9, 18 }, { SP_PIXFMT_YUYV, 3, 2, 8, 16 },
        { SP_PIXFMT_NV12, 4, 3, 4, 20 },  { SP_PIXFMT_MJPEG, 16, 16, 0, 12 },
    };
    uint8_t data[64];
    for (size_t i = 0; i < sizeof(data); i++)
        data[i] = (uint8_t)(i * 29 + 3);
    int err = 0;
    for (size_t i = 0; i < sizeof(kinds) / sizeof(kinds[0]) && err == 0; i++) {
        sp_frame f;
        memset(&f, 0, sizeof(f));
        f.format = kinds[i].fmt;
        f.width = kinds[i].w;
        f.height = kinds[i].h;
        f.stride = kinds[i].stride;
        f.data = data;
        f.bytes_used = kinds[i].bytes;
        f.timestamp_ns = 1000000 * (int64_t)i;
        f.sequence = i;
        f.exposure_us = i % 2 ? NAN : 500.0f;
        f.gain = 1.5f;
        err = sp_capture_write_frame(w, &f);
        sp_imu_sample s[3] = { { f.timestamp_ns - 2000, SP_IMU_GYRO, { 0.01f, 0.02f, -0.03f } },
                               { f.timestamp_ns - 1000, SP_IMU_ACCEL, { 0.1f, 9.8f, 0.2f } },
                               { f.timestamp_ns, SP_IMU_MAG, { 20, -5, 40 } } };
        if (err == 0)
            err = sp_capture_write_imu(w, s, 1 + i % 3);
        float lm[8] = { 1, 2, 3, 4, 5, 6, 7, (float)i };
        if (err == 0)
            err = sp_capture_write_side(w, f.timestamp_ns, i, SP_SIDE_LANDMARKS_2D, lm, 8);
    }
    return err;
}

/* A small valid capture with every chunk type; its META stamped meta_ns (any int64 is valid). */
static uint8_t *make_valid(uint32_t index_interval, int64_t meta_ns, size_t *len)
{
    char path[4096];
    snprintf(path, sizeof(path), "%s/.tmp-valid", outdir);
    sp_capture_writer_settings s;
    sp_capture_writer_default_settings(&s);
    s.sync = SP_SYNC_NONE;
    s.overwrite = 1;
    s.index_interval = index_interval;
    sp_capture_writer *w = NULL;
    const char meta[] = "{\"kind\":\"static\",\"source\":\"seed\",\"camera\":{\"width\":6,\"height\":4}}";
    int err = sp_capture_writer_open(&w, path, &s);
    if (err == 0)
        err = sp_capture_write_meta(w, meta_ns, meta, strlen(meta));
    if (err == 0)
        err = write_frames(w);
    int cerr = sp_capture_writer_close(&w);
    uint8_t *b = NULL;
    struct stat st;
    int fd = open(path, O_RDONLY);
    if (err == 0 && cerr == 0 && fd >= 0 && fstat(fd, &st) == 0 && (b = malloc((size_t)st.st_size)) &&
        read(fd, b, (size_t)st.st_size) == st.st_size) {
        *len = (size_t)st.st_size;
    } else {
        free(b);
        b = NULL;
    }
    if (fd >= 0)
        close(fd);
    unlink(path);
    return b;
}

/* Offset of the n-th chunk (0 = first) of a valid file, walking the headers. */
static size_t chunk_offset(const uint8_t *b, size_t len, int n)
{
    size_t off = SPC_HDR_SIZE;
    for (int i = 0; i < n && off + SPC_CHUNK_HDR_SIZE <= len; i++)
        off += SPC_CHUNK_HDR_SIZE + spc_get32(b + off + SPC_CH_OFF_SIZE);
    return off;
}

static int broken_variants(const uint8_t *v, size_t len)
{
    uint8_t *b = malloc(len + 64);
    if (!b)
        return -1;
    int err = 0;
    size_t c3 = chunk_offset(v, len, 3);
    err |= put("torn_tail.spcap", v, c3 + 40);
    err |= put("torn_header.spcap", v, 30);
    err |= put("no_end.spcap", v, len - SPC_CHUNK_HDR_SIZE - SPC_END_SIZE);
    err |= put("empty.spcap", v, 0);
    memcpy(b, v, len);
    b[c3 + SPC_CHUNK_HDR_SIZE + 5] ^= 0x20;
    err |= put("flip_payload.spcap", b, len);
    memcpy(b, v, len);
    b[c3 + SPC_CH_OFF_SIZE] ^= 0x01;
    err |= put("flip_header.spcap", b, len);
    memcpy(b, v, len);
    memset(b + c3, 0, 64); /* a zero-filled hole, as power loss can leave */
    err |= put("zero_hole.spcap", b, len);
    memcpy(b, v, len);
    b[2] = 'X';
    err |= put("wrong_magic.spcap", b, len);
    memcpy(b, v, len);
    spc_put16(b + SPC_HDR_OFF_MAJOR, SP_CAPTURE_VERSION_MAJOR + 1);
    spc_put32(b + SPC_HDR_OFF_CRC, sp_crc32c(0, b, SPC_HDR_OFF_CRC));
    err |= put("newer_major.spcap", b, len);
    memcpy(b, v, len);
    spc_build_chunk_header(b + c3, SP_CHUNK_FRAME, 0, 0xFFFFFFF0u, 0, 1); /* checks out, claims 4 GiB */
    err |= put("absurd_length.spcap", b, len);
    memcpy(b, v, len);
    memcpy(b + len, "trailing junk after the END chunk", 33);
    err |= put("junk_after_end.spcap", b, len + 33);
    free(b);
    return err;
}

/* A newer minor version: longer header, an unknown chunk type with flags, then a META. */
static int future_minor(void)
{
    uint8_t b[256];
    memset(b, 0, sizeof(b));
    spc_build_file_header(b, 1, 2);
    spc_put16(b + SPC_HDR_OFF_MINOR, 3);
    spc_put32(b + SPC_HDR_OFF_SIZE, 96);
    spc_put32(b + SPC_HDR_OFF_CRC, sp_crc32c(0, b, SPC_HDR_OFF_CRC));
    size_t pos = 96;
    spc_build_chunk_header(b + pos, 42, 0x8000, 4, sp_crc32c(0, "abcd", 4), 5);
    memcpy(b + pos + SPC_CHUNK_HDR_SIZE, "abcd", 4);
    pos += SPC_CHUNK_HDR_SIZE + 4;
    spc_build_chunk_header(b + pos, SP_CHUNK_META, 0, 2, sp_crc32c(0, "{}", 2), 6);
    memcpy(b + pos + SPC_CHUNK_HDR_SIZE, "{}", 2);
    pos += SPC_CHUNK_HDR_SIZE + 2;
    return put("future_minor.spcap", b, pos);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: %s OUTDIR\n", argv[0]);
        return 2;
    }
    outdir = argv[1];
    if (mkdir(outdir, 0755) < 0 && errno != EEXIST) {
        fprintf(stderr, "%s: %s\n", outdir, strerror(errno));
        return 1;
    }
    size_t len = 0, len2 = 0, len3 = 0;
    uint8_t *valid = make_valid(3, 0, &len);
    uint8_t *plain = make_valid(0, 0, &len2);
    uint8_t *latest = make_valid(3, INT64_MAX, &len3); /* seeks step past the first timestamp */
    if (!valid || !plain || !latest) {
        fprintf(stderr, "cannot write a capture in %s\n", outdir);
        return 1;
    }
    int err = put("valid_indexed.spcap", valid, len);
    err |= put("valid_no_index.spcap", plain, len2);
    err |= put("valid_latest_time.spcap", latest, len3);
    err |= broken_variants(valid, len);
    err |= future_minor();
    free(valid);
    free(plain);
    free(latest);
    return err ? 1 : 0;
}
