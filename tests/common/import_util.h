/* SPDX-License-Identifier: MIT */
/*
 * Helpers shared by the import tests: a scratch directory, input files (marked
 * JPEGs from a fixture, text files, solid images) and reading a capture back
 * into counts and per-frame facts. Include after check.h.
 */
#ifndef SUNPROBE_TESTS_IMPORT_UTIL_H
#define SUNPROBE_TESTS_IMPORT_UTIL_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fixture_jpeg.h"
#include "sunprobe/sp_capture.h"

static char iu_tmp[256];

/* Paths live until the test exits: every call takes a fresh slot. */
static inline const char *iu_path(const char *name)
{
    static char pool[512][320];
    static unsigned next;
    char *p = pool[next++ % 512];
    snprintf(p, sizeof(pool[0]), "%s/%s", iu_tmp, name);
    return p;
}

static inline void iu_make_tmp(const char *tag)
{
    const char *base = getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp";
    snprintf(iu_tmp, sizeof(iu_tmp), "%s/sp_%s_XXXXXX", base, tag);
    if (!mkdtemp(iu_tmp)) {
        perror("mkdtemp");
        exit(99);
    }
}

/* Removes the scratch directory when the test passed, keeps it for inspection otherwise. */
static inline int iu_finish(void)
{
    int code = check_exit();
    if (code) {
        fprintf(stderr, "inputs and outputs kept in %s\n", iu_tmp);
        return code;
    }
    char cmd[600];
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", iu_tmp);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", iu_tmp);
    return 0;
}

static inline int iu_exists(const char *path)
{
    return access(path, F_OK) == 0;
}

static inline void iu_write_text(const char *name, const char *text)
{
    FILE *f = fopen(iu_path(name), "w");
    CHECK(f != NULL);
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

/* The fixture JPEG with a "frame N" comment after SOI: still valid, and its bytes tell which file it was. */
static inline size_t iu_write_marked_jpeg(const char *name, int n)
{
    char com[32];
    int len = snprintf(com, sizeof(com), "frame %d", n);
    uint8_t seg[4] = { 0xFF, 0xFE, 0, (uint8_t)(len + 2) };
    FILE *f = fopen(iu_path(name), "wb");
    CHECK(f != NULL);
    if (!f)
        return 0;
    fwrite(fixture_jpeg, 1, 2, f);
    fwrite(seg, 1, 4, f);
    fwrite(com, 1, (size_t)len, f);
    fwrite(fixture_jpeg + 2, 1, sizeof(fixture_jpeg) - 2, f);
    fclose(f);
    return sizeof(fixture_jpeg) + 4 + (size_t)len;
}

/* A solid image with a per-index colour and pixel 0's red channel set to the index. */
static inline uint8_t *iu_solid_image(int i, uint32_t w, uint32_t h)
{
    uint8_t *img = malloc((size_t)w * h * 3);
    if (!img)
        abort();
    const uint8_t c[3] = { (uint8_t)(20 + 45 * (i % 5)), (uint8_t)(230 - 40 * (i % 6)), (uint8_t)(60 + 25 * (i % 7)) };
    for (size_t p = 0; p < (size_t)w * h; p++)
        memcpy(img + p * 3, c, 3);
    img[0] = (uint8_t)i;
    return img;
}

#define IU_MAX_FRAMES 64

typedef struct iu_readback {
    int frames, imu_chunks, imu[4];
    int order_ok;        /* no IMU sample written after a frame is at or before that frame's time */
    int imu_monotonic;
    int64_t last_imu_ts, first_imu_ts;
    enum sp_pixfmt format;
    uint32_t width, height;
    int64_t frame_ts[IU_MAX_FRAMES];
    uint32_t frame_size[IU_MAX_FRAMES];
    int marker[IU_MAX_FRAMES];    /* N of a "frame N" JPEG comment, -1 if none */
    uint8_t pixel0[IU_MAX_FRAMES][3]; /* first pixel of RGB24 frames */
    uint8_t pixel_last[IU_MAX_FRAMES][3];
    char meta_json[4096];         /* the first META chunk */
    int meta_chunks;
} iu_readback;

static inline void iu_read_frame(iu_readback *rb, const sp_chunk *ch)
{
    sp_frame_chunk fc;
    CHECK_EQ_INT(sp_chunk_parse_frame(ch, &fc), 0);
    CHECK_EQ_INT(fc.sequence, rb->frames);
    int i = rb->frames++;
    rb->format = fc.format;
    rb->width = fc.width;
    rb->height = fc.height;
    if (i >= IU_MAX_FRAMES)
        return;
    rb->frame_ts[i] = ch->timestamp_ns;
    rb->frame_size[i] = fc.data_size;
    rb->marker[i] = -1;
    if (fc.format == SP_PIXFMT_RGB24 && fc.data_size >= 3) {
        memcpy(rb->pixel0[i], fc.data, 3);
        memcpy(rb->pixel_last[i], fc.data + (size_t)(fc.height - 1) * fc.stride + (fc.width - 1) * 3, 3);
    }
    if (fc.format == SP_PIXFMT_MJPEG && fc.data_size > 20 && fc.data[2] == 0xFF && fc.data[3] == 0xFE)
        sscanf((const char *)fc.data + 6, "frame %d", &rb->marker[i]);
}

static inline void iu_read_imu(iu_readback *rb, const sp_chunk *ch, int64_t last_frame_ts)
{
    int64_t n = sp_chunk_imu_count(ch);
    CHECK(n > 0);
    rb->imu_chunks++;
    for (int64_t i = 0; i < n; i++) {
        sp_imu_sample s;
        CHECK_EQ_INT(sp_chunk_imu_get(ch, (size_t)i, &s), 0);
        if (s.sensor >= 1 && s.sensor <= 3)
            rb->imu[s.sensor]++;
        if (s.timestamp_ns < rb->last_imu_ts)
            rb->imu_monotonic = 0;
        if (rb->last_imu_ts == INT64_MIN)
            rb->first_imu_ts = s.timestamp_ns;
        rb->last_imu_ts = s.timestamp_ns;
        if (rb->frames > 0 && s.timestamp_ns <= last_frame_ts)
            rb->order_ok = 0;
        CHECK(isfinite(s.v[0]) && isfinite(s.v[1]) && isfinite(s.v[2]));
    }
}

/* Reads a whole capture; 0 when it opened and ended cleanly. */
static inline int iu_read_capture(const char *path, iu_readback *rb)
{
    memset(rb, 0, sizeof(*rb));
    rb->order_ok = rb->imu_monotonic = 1;
    rb->last_imu_ts = rb->first_imu_ts = INT64_MIN;
    sp_capture_reader *r = NULL;
    int rc = sp_capture_reader_open(&r, path, NULL);
    CHECK_MSG(rc == 0, "%s: %s", path, sp_strerror(rc));
    if (rc)
        return rc;
    sp_chunk ch;
    int64_t last_frame_ts = INT64_MIN;
    while ((rc = sp_capture_reader_next(r, &ch)) == 0) {
        if (ch.type == SP_CHUNK_META && rb->meta_chunks++ == 0 && ch.payload_size < sizeof(rb->meta_json))
            memcpy(rb->meta_json, ch.payload, ch.payload_size);
        if (ch.type == SP_CHUNK_FRAME) {
            iu_read_frame(rb, &ch);
            last_frame_ts = ch.timestamp_ns;
        }
        if (ch.type == SP_CHUNK_IMU)
            iu_read_imu(rb, &ch, last_frame_ts);
    }
    CHECK_EQ_INT(rc, SP_EOS);
    sp_capture_reader_close(&r);
    return rc == SP_EOS ? 0 : rc;
}

#endif
