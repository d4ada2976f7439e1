/* SPDX-License-Identifier: MIT */
/*
 * Fuzz harness for the .spcap reader and recovery: the input is a whole file. It
 * is read strictly and with skip_corrupt, every FRAME/IMU/SIDE payload is parsed,
 * seeks are tried, then the file is recovered in place and the result must read
 * cleanly to its END chunk. Each input also runs a second time with its checksums
 * recomputed, so mutations get past the CRCs into the payload parsers. Built for libFuzzer with -DSP_LIBFUZZER (tools/fuzz.sh);
 * otherwise a main replays the files of corpus directories given as arguments.
 */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "capture/container_format.h"
#include "common/crc32c.h"
#include "sunprobe/sp_capture.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define MAX_STEPS 100000

/* An in-memory file (memfd) holding the input, reachable by path; temp file if memfd is missing. */
static int make_input(const uint8_t *data, size_t size, char *path, size_t cap, int *unlink_after)
{
    *unlink_after = 0;
    int fd = memfd_create("spcap-fuzz", MFD_CLOEXEC);
    if (fd >= 0) {
        snprintf(path, cap, "/proc/self/fd/%d", fd);
    } else {
        const char *dir = getenv("TMPDIR");
        snprintf(path, cap, "%s/spcap-fuzz-XXXXXX", dir && *dir ? dir : "/tmp");
        fd = mkstemp(path);
        *unlink_after = 1;
    }
    if (fd < 0)
        return -1;
    size_t done = 0;
    while (done < size) {
        ssize_t n = write(fd, data + done, size - done);
        if (n <= 0)
            break;
        done += (size_t)n;
    }
    return fd;
}

static volatile uint32_t sink; /* keeps the payload reads from being optimised away */

static void touch_payload(const sp_chunk *c)
{
    sp_frame_chunk f;
    sp_side_chunk s;
    if (c->type == SP_CHUNK_FRAME && sp_chunk_parse_frame(c, &f) == 0) {
        sink += f.data[0] + f.data[f.data_size - 1] + f.width + (uint32_t)(f.exposure_us == f.exposure_us);
    } else if (c->type == SP_CHUNK_IMU) {
        int64_t n = sp_chunk_imu_count(c);
        for (int64_t i = 0; i < n; i++) {
            sp_imu_sample smp;
            if (sp_chunk_imu_get(c, (size_t)i, &smp) != 0)
                abort(); /* count said it was there */
            sink += smp.sensor;
        }
    } else if (c->type == SP_CHUNK_SIDE && sp_chunk_parse_side(c, &s) == 0) {
        for (uint32_t i = 0; i < s.count; i++)
            sink += (uint32_t)(sp_side_value(&s, i) > 0.0f);
    } else if (c->payload_size) {
        sink += c->payload[c->payload_size - 1];
    }
}

static void read_through(const char *path, int skip)
{
    sp_capture_reader_settings s;
    sp_capture_reader_default_settings(&s);
    s.skip_corrupt = skip;
    s.max_chunk_size = 1u << 20;
    sp_capture_reader *r = NULL;
    if (sp_capture_reader_open(&r, path, &s) < 0)
        return;
    sp_chunk c;
    int64_t first_ts = 0;
    int n = 0;
    while (n < MAX_STEPS && sp_capture_reader_next(r, &c) == 0) {
        if (n++ == 0)
            first_ts = c.timestamp_ns;
        touch_payload(&c);
    }
    /* seeks must land somewhere readable or at a reported error, never crash */
    /* a chunk may carry any timestamp, INT64_MAX too: the step past the first saturates */
    const int64_t after_first = first_ts > INT64_MAX - 1000000 ? INT64_MAX : first_ts + 1000000;
    const int64_t targets[] = { INT64_MIN, first_ts, after_first, INT64_MAX };
    for (size_t i = 0; i < sizeof(targets) / sizeof(targets[0]); i++) {
        if (sp_capture_reader_seek(r, targets[i]) != 0)
            abort();
        for (int k = 0; k < 3 && sp_capture_reader_next(r, &c) == 0; k++)
            touch_payload(&c);
    }
    if (!skip && sp_capture_reader_corrupt_count(r) != 0)
        abort();
    sp_capture_reader_close(&r);
}

/* After recovery the file must read strictly, without a single error, to an END that ends the file. */
static void check_recovered(const char *path, const sp_recover_report *rep)
{
    sp_capture_reader *r = NULL;
    if (sp_capture_reader_open(&r, path, NULL) != 0)
        abort();
    sp_chunk c;
    uint64_t chunks = 0;
    int err;
    while ((err = sp_capture_reader_next(r, &c)) == 0)
        chunks++;
    if (err != SP_EOS || c.type != SP_CHUNK_END || chunks != rep->chunks_kept ||
        c.offset + 32 + c.payload_size != sp_capture_reader_info(r)->file_size)
        abort();
    sp_capture_reader_close(&r);
}

/* Makes the file header's and each chunk's CRCs match, walking chunks from the header while sync words do. */
static void fix_checksums(uint8_t *b, size_t n)
{
    if (n < SPC_HDR_SIZE || memcmp(b, SPC_MAGIC, SPC_MAGIC_LEN) != 0)
        return;
    spc_put32(b + SPC_HDR_OFF_CRC, sp_crc32c(0, b, SPC_HDR_OFF_CRC));
    size_t off = spc_get32(b + SPC_HDR_OFF_SIZE);
    if (off < SPC_HDR_SIZE || off > SPC_HDR_MAX_SIZE)
        return;
    while (off <= n && n - off >= SPC_CHUNK_HDR_SIZE && spc_get32(b + off) == SPC_SYNC) {
        uint8_t *h = b + off;
        uint32_t size = spc_get32(h + SPC_CH_OFF_SIZE);
        int whole = n - off - SPC_CHUNK_HDR_SIZE >= size;
        if (whole)
            spc_put32(h + SPC_CH_OFF_PCRC, sp_crc32c(0, h + SPC_CHUNK_HDR_SIZE, size));
        spc_put32(h + SPC_CH_OFF_HCRC, sp_crc32c(0, h, SPC_CH_OFF_HCRC));
        if (!whole)
            return;
        off += SPC_CHUNK_HDR_SIZE + (size_t)size;
    }
}

static void run_one(const uint8_t *data, size_t size)
{
    char path[256];
    int tmp;
    int fd = make_input(data, size, path, sizeof(path), &tmp);
    if (fd < 0)
        return;
    read_through(path, 0);
    read_through(path, 1);
    sp_recover_report rep;
    if (sp_capture_recover(path, NULL, &rep) == 0) {
        if (rep.valid_bytes + rep.bytes_dropped != size)
            abort();
        check_recovered(path, &rep);
    }
    close(fd);
    if (tmp)
        unlink(path);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    run_one(data, size);
    uint8_t *fixed = malloc(size ? size : 1);
    if (!fixed)
        return 0;
    memcpy(fixed, data, size);
    fix_checksums(fixed, size);
    if (size && memcmp(fixed, data, size) != 0)
        run_one(fixed, size);
    free(fixed);
    return 0;
}

#include "replay_main.h"
