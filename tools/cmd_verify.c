/* SPDX-License-Identifier: MIT */
/* `sunprobe verify`: check every chunk's checksums and payload structure; list what is bad. */
#include <getopt.h>
#include <inttypes.h>
#include <stdio.h>

#include "capture_open.h"
#include "cmd.h"

static void usage(FILE *out)
{
    fprintf(out, "usage: sunprobe verify [--quiet] CAPTURE\n\n"
                 "Reads every chunk, checks header and payload CRC-32C and that frame, IMU and side-data\n"
                 "payloads are well formed. Prints each problem with its byte offset.\n"
                 "Exit 0 when the file is intact, 2 when anything is corrupt or the tail is torn.\n");
}

/* Structural check beyond the checksum: does the payload parse as its type says? */
static int payload_ok(const sp_chunk *c)
{
    sp_frame_chunk f;
    sp_side_chunk s;
    switch (c->type) {
    case SP_CHUNK_FRAME:
        return sp_chunk_parse_frame(c, &f) == 0;
    case SP_CHUNK_IMU:
        return sp_chunk_imu_count(c) > 0;
    case SP_CHUNK_SIDE:
        return sp_chunk_parse_side(c, &s) == 0;
    default:
        return 1;
    }
}

int sp_cmd_verify(int argc, char **argv)
{
    static const struct option opts[] = { { "help", no_argument, NULL, 'h' }, { "quiet", no_argument, NULL, 'q' },
                                          { 0 } };
    int c, quiet = 0;
    while ((c = getopt_long(argc, argv, "hq", opts, NULL)) != -1) {
        if (c == 'h') {
            usage(stdout);
            return SP_EXIT_OK;
        }
        if (c != 'q') {
            usage(stderr);
            return SP_EXIT_USAGE;
        }
        quiet = 1;
    }
    if (optind != argc - 1) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    const char *path = argv[optind];
    sp_capture_reader *r = NULL;
    int code = sp_tool_open_capture("verify", path, 1, &r);
    if (code)
        return code;
    uint64_t chunks = 0, bad = 0;
    sp_chunk chunk;
    int ret;
    while ((ret = sp_capture_reader_next(r, &chunk)) == 0) {
        chunks++;
        if (!payload_ok(&chunk)) {
            printf("malformed chunk of type %u at byte %" PRIu64 "\n", chunk.type, chunk.offset);
            bad++;
        }
    }
    uint64_t corrupt = sp_capture_reader_corrupt_count(r);
    if (corrupt) {
        printf("%" PRIu64 " corrupt chunk(s) skipped, the first at byte %" PRIu64 "\n", corrupt,
               sp_capture_reader_first_corrupt_offset(r));
        bad += corrupt;
    }
    if (ret == SP_ETRUNCATED) {
        printf("torn tail at byte %" PRIu64 " (run `sunprobe recover %s`)\n", chunk.offset, path);
        bad++;
    } else if (ret != SP_EOS) {
        code = sp_tool_capture_error("verify", path, ret, chunk.offset);
    }
    sp_capture_reader_close(&r);
    if (code)
        return code;
    if (!quiet)
        printf("%s: %" PRIu64 " chunks checked, %" PRIu64 " problems: %s\n", path, chunks, bad, bad ? "CORRUPT" : "OK");
    return bad ? SP_EXIT_BAD_INPUT : SP_EXIT_OK;
}
