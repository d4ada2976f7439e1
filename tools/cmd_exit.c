/* SPDX-License-Identifier: MIT */
/*
 * Error code -> exit code, as one explicit list (README.md, "Exit codes"): every command ends through
 * sp_exit_for_error, so the same errno means the same exit code everywhere.
 */
#include <errno.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>

#include "tools/cmd.h"

/* an errno (returned negated) or one of sunprobe's own codes, with its name for README.md's list */
#define ERRNO(e, code, what) { -(e), code, #e, what }
#define CODE(e, code, what) { e, code, #e, what }

static const sp_exit_rule rules[] = {
    CODE(0, SP_EXIT_OK, "success"),
    /* the command line asked for something that cannot be done */
    ERRNO(EINVAL, SP_EXIT_USAGE, "an option value or combination is invalid"),
    ERRNO(EEXIST, SP_EXIT_USAGE, "the output exists and --force was not given"),
    /* the input file */
    CODE(SP_ECORRUPT, SP_EXIT_BAD_INPUT, "corrupt data"),
    CODE(SP_EVERSION, SP_EXIT_BAD_INPUT, "a newer format version"),
    CODE(SP_EFORMAT, SP_EXIT_BAD_INPUT, "not a file of the expected kind"),
    CODE(SP_ETRUNCATED, SP_EXIT_BAD_INPUT, "a truncated file"),
    CODE(SP_EUNSUPPORTED, SP_EXIT_BAD_INPUT, "content this build does not handle"),
    CODE(SP_ENODATA, SP_EXIT_BAD_INPUT, "nothing usable in the input"),
    CODE(SP_EOS, SP_EXIT_BAD_INPUT, "the input ended early"),
    /* the machine: disks, devices, permissions, memory */
    ERRNO(ENOSPC, SP_EXIT_IO, "no space left on the device"),
    ERRNO(EDQUOT, SP_EXIT_IO, "disk quota exceeded"),
    ERRNO(EFBIG, SP_EXIT_IO, "file too large (ulimit -f or the file system)"),
    ERRNO(EROFS, SP_EXIT_IO, "read-only file system"),
    ERRNO(EACCES, SP_EXIT_IO, "permission denied"),
    ERRNO(EPERM, SP_EXIT_IO, "operation not permitted"),
    ERRNO(EIO, SP_EXIT_IO, "input/output error"),
    ERRNO(ENOENT, SP_EXIT_IO, "no such file or directory"),
    ERRNO(ENOTDIR, SP_EXIT_IO, "a path component is not a directory"),
    ERRNO(EISDIR, SP_EXIT_IO, "a directory where a file was expected"),
    ERRNO(ENAMETOOLONG, SP_EXIT_IO, "file name too long"),
    ERRNO(EMFILE, SP_EXIT_IO, "too many open files"),
    ERRNO(ENODEV, SP_EXIT_IO, "no such device (unplugged?)"),
    ERRNO(ENXIO, SP_EXIT_IO, "no such device or address"),
    ERRNO(EBUSY, SP_EXIT_IO, "device busy"),
    ERRNO(ENOMEM, SP_EXIT_IO, "out of memory"),
    /* the optional features */
    CODE(SP_EDISABLED, SP_EXIT_DISABLED, "needs an optional feature this build left out"),
    /* a run stopped by SIGINT/SIGTERM: 128 + the signal when one came (cmd_signal.c), else a bug */
    ERRNO(EINTR, SP_EXIT_INTERNAL, "interrupted"),
    ERRNO(ECANCELED, SP_EXIT_INTERNAL, "cancelled"),
};

const sp_exit_rule *sp_exit_rules(size_t *n)
{
    *n = sizeof(rules) / sizeof(rules[0]);
    return rules;
}

int sp_exit_for_error(int err)
{
    if ((err == -EINTR || err == -ECANCELED) && sp_cmd_stop_signal)
        return 128 + (int)sp_cmd_stop_signal;
    for (size_t i = 0; i < sizeof(rules) / sizeof(rules[0]); i++)
        if (rules[i].err == err)
            return rules[i].code;
    /* not listed: another errno is the system refusing (I/O); anything else is a bug */
    return err < 0 && err > -4096 ? SP_EXIT_IO : SP_EXIT_INTERNAL;
}

int sp_err_is_write(int err)
{
    return err == -ENOSPC || err == -EDQUOT || err == -EFBIG || err == -EROFS;
}

const char *sp_cmd_signal_name(int sig)
{
    return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : "a signal";
}

int sp_cmd_fail(const char *cmd, int err, const char *what)
{
    int code = sp_exit_for_error(err);
    if (code > 128)
        fprintf(stderr, "sunprobe %s: %s: interrupted by %s; nothing written\n", cmd, what,
                sp_cmd_signal_name(code - 128));
    else
        fprintf(stderr, "sunprobe %s: %s: %s\n", cmd, what, sp_strerror(err));
    return code == SP_EXIT_OK ? SP_EXIT_INTERNAL : code;
}

int sp_cmd_failf(const char *cmd, int err, const char *fmt, ...)
{
    char what[4200];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof(what), fmt, ap);
    va_end(ap);
    return sp_cmd_fail(cmd, err, what);
}
