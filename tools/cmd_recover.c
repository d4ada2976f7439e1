/* SPDX-License-Identifier: MIT */
/* `sunprobe recover`: keep the longest valid prefix of a capture after a crash or power loss. */
#include <getopt.h>
#include <inttypes.h>
#include <stdio.h>

#include "capture_open.h"
#include "cmd.h"

static void usage(FILE *out)
{
    fprintf(out, "usage: sunprobe recover CAPTURE [-o COPY]\n\n"
                 "Finds the longest prefix of whole, checksum-valid chunks and ends it with an END chunk:\n"
                 "in place (truncating CAPTURE) or, with -o, into a new file COPY leaving CAPTURE untouched.\n"
                 "  -o, --output COPY   write the recovered capture here instead of truncating\n"
                 "Exit 0 on success, 2 when CAPTURE is not a capture, 3 on I/O errors.\n");
}

int sp_cmd_recover(int argc, char **argv)
{
    static const struct option opts[] = { { "help", no_argument, NULL, 'h' },
                                          { "output", required_argument, NULL, 'o' }, { 0 } };
    const char *out = NULL;
    int c;
    while ((c = getopt_long(argc, argv, "ho:", opts, NULL)) != -1) {
        if (c == 'h') {
            usage(stdout);
            return SP_EXIT_OK;
        }
        if (c != 'o') {
            usage(stderr);
            return SP_EXIT_USAGE;
        }
        out = optarg;
    }
    if (optind != argc - 1) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    const char *path = argv[optind];
    sp_recover_report rep = { 0 };
    int ret = sp_capture_recover(path, out, &rep);
    if (ret && out && sp_exit_for_error(ret) == SP_EXIT_IO) {
        /* a file-system error with the input readable is the copy's: name it, not the input */
        FILE *in = fopen(path, "rb");
        if (in) {
            fclose(in);
            return sp_cmd_failf("recover", ret, "writing the recovered copy %s", out);
        }
    }
    if (ret)
        return sp_tool_capture_error("recover", path, ret, 0);
    printf("%s: kept %" PRIu64 " chunks (%" PRIu64 " bytes), dropped %" PRIu64 " bytes%s\n", out ? out : path,
           rep.chunks_kept, rep.valid_bytes, rep.bytes_dropped, rep.had_end ? " (file was closed cleanly)" : "");
    return SP_EXIT_OK;
}
