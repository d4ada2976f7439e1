/* SPDX-License-Identifier: MIT */
/* `sunprobe recover`: keep the longest valid prefix of a capture after a crash or power loss. */
#include <errno.h>
#include <getopt.h>
#include <inttypes.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

#include "capture_open.h"
#include "cmd.h"
#include "common/file_util.h"

static void usage(FILE *out)
{
    fprintf(out, "usage: sunprobe recover CAPTURE [-o COPY [-f]]\n\n"
                 "Finds the longest prefix of whole, checksum-valid chunks and ends it with an END chunk:\n"
                 "in place (truncating CAPTURE) or, with -o, into a new file COPY leaving CAPTURE untouched.\n"
                 "  -o, --output COPY   write the recovered capture here instead of truncating (made under\n"
                 "                      COPY.partial, renamed when complete)\n"
                 "  -f, --force         replace COPY if it exists (never CAPTURE itself)\n"
                 "Exit 0 on success, 1 usage (COPY exists without --force), 2 when CAPTURE is not a capture,\n"
                 "3 on I/O errors.\n");
}

/* COPY may replace an older file only with --force, and never the capture it is made from */
static int check_copy(const char *path, const char *out, int force)
{
    struct stat in, o;
    if (lstat(out, &o) != 0)
        return 0;
    if (stat(path, &in) == 0 && stat(out, &o) == 0 && in.st_dev == o.st_dev && in.st_ino == o.st_ino) {
        fprintf(stderr, "sunprobe recover: -o %s is CAPTURE itself: leave out -o to recover in place\n", out);
        return SP_EXIT_USAGE;
    }
    if (force)
        return 0;
    fprintf(stderr, "sunprobe recover: %s exists (use --force to replace it)\n", out);
    return sp_exit_for_error(-EEXIST);
}

/* The copy under COPY.partial, renamed over COPY only when whole */
static int recover_copy(const char *path, const char *out, int force, sp_recover_report *rep)
{
    sp_partial pf;
    int ret = sp_partial_file_open(&pf, out);
    if (ret)
        return ret;
    unlink(pf.path); /* an interrupted run's: the recovery makes it anew */
    ret = sp_capture_recover(path, pf.path, rep);
    if (!ret && sp_cmd_stop_signal) /* a stop signal: COPY as it was */
        ret = -ECANCELED;
    if (!ret)
        ret = sp_partial_file_commit(&pf, force ? SP_PARTIAL_REPLACE : 0);
    if (ret)
        sp_partial_file_abort(&pf);
    return ret;
}

int sp_cmd_recover(int argc, char **argv)
{
    static const struct option opts[] = { { "help", no_argument, NULL, 'h' },
                                          { "output", required_argument, NULL, 'o' },
                                          { "force", no_argument, NULL, 'f' }, { 0 } };
    const char *out = NULL;
    int c, force = 0;
    while ((c = getopt_long(argc, argv, "ho:f", opts, NULL)) != -1) {
        if (c == 'h') {
            usage(stdout);
            return SP_EXIT_OK;
        }
        if (c != 'o' && c != 'f') {
            usage(stderr);
            return SP_EXIT_USAGE;
        }
        if (c == 'f')
            force = 1;
        else
            out = optarg;
    }
    if (optind != argc - 1 || (force && !out)) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    const char *path = argv[optind];
    int code = out ? check_copy(path, out, force) : 0;
    if (code)
        return code;
    sp_recover_report rep = { 0 };
    sp_cmd_signals sig; /* caught for the copy only: in place, the capture is cut by one truncate */
    if (out)
        sp_cmd_catch_signals(&sig);
    int ret = out ? recover_copy(path, out, force, &rep) : sp_capture_recover(path, NULL, &rep);
    if (out)
        sp_cmd_restore_signals(&sig);
    if (ret == -ECANCELED)
        return sp_cmd_fail("recover", ret, out);
    if (ret == -EEXIST && out) {
        fprintf(stderr, "sunprobe recover: %s exists (use --force to replace it)\n", out);
        return sp_exit_for_error(ret);
    }
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
