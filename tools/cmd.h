/* SPDX-License-Identifier: MIT */
/* The sunprobe command line: one subcommand per file, shared exit codes and helpers. */
#ifndef SUNPROBE_TOOLS_CMD_H
#define SUNPROBE_TOOLS_CMD_H

#include <signal.h>
#include <stddef.h>
#include <stdint.h>

#include "sunprobe/sp_common.h"

/* Exit codes, documented in README.md and `sunprobe --help`. */
enum sp_exit {
    SP_EXIT_OK = 0,
    SP_EXIT_USAGE = 1,     /* bad command line */
    SP_EXIT_BAD_INPUT = 2, /* input file corrupt, unreadable as the expected kind, or unusable */
    SP_EXIT_IO = 3,        /* device or file-system error (missing device, disk full, permissions) */
    SP_EXIT_DISABLED = 4,  /* needs an optional feature this build left out */
    SP_EXIT_INTERNAL = 70, /* a bug: please report */
};

typedef struct sp_command {
    const char *name;
    const char *summary;
    int (*run)(int argc, char **argv);
} sp_command;

/* One row of the error -> exit code list (cmd_exit.c; README.md, "Exit codes"). */
typedef struct sp_exit_rule {
    int err;          /* 0, a negative errno or an SP_E* code */
    int code;         /* enum sp_exit */
    const char *name; /* "ENOSPC", "SP_ECORRUPT", "0" */
    const char *what; /* what it means, as README.md lists it */
} sp_exit_rule;
/* The whole list (static storage), *n rows: for the documentation and its test. */
const sp_exit_rule *sp_exit_rules(size_t *n);
/*
 * Maps a library error code to the exit code a user sees: the list's row; -EINTR/-ECANCELED after a stop
 * signal give 128 + the signal; another errno gives 3, anything else 70.
 */
int sp_exit_for_error(int err);
/* 1 when err is one only a write gives (no space, quota, size limit, read-only): the output's fault, not the input's. */
int sp_err_is_write(int err);
/* Prints "sunprobe CMD: what: error message" to stderr and returns the exit code for err. */
int sp_cmd_fail(const char *cmd, int err, const char *what);
/* "SIGINT", "SIGTERM" or "a signal", for messages about a stop. */
const char *sp_cmd_signal_name(int sig);
/* The same with what formatted (a path in it, say). */
int sp_cmd_failf(const char *cmd, int err, const char *fmt, ...) SP_PRINTF(3, 4);

/*
 * Option values (cmd_options.c): the whole string as a decimal integer / a finite number in lo..hi.
 * On failure prints "sunprobe CMD: --OPT 'VALUE': expected ... from lo to hi" and returns -1 (an empty
 * value is refused, not read as 0).
 */
int sp_opt_int(const char *cmd, const char *opt, const char *s, int lo, int hi, int *out);
int sp_opt_double(const char *cmd, const char *opt, const char *s, double lo, double hi, double *out);
/* n comma-separated finite numbers ("X,Y", "X,Y,W,H") and nothing else into v: 0, or -1 (no message). */
int sp_opt_numbers(const char *s, double *v, int n);
/* The same, each v[i] in lo[i]..hi[i]; else "sunprobe CMD: --OPT 'VALUE': expected WANT" and -1. */
int sp_opt_list(const char *cmd, const char *opt, const char *s, int n, const double *lo, const double *hi,
                double *v, const char *want);
/* WxH, each an integer from 1 to max; else the message and -1. */
int sp_opt_size(const char *cmd, const char *opt, const char *s, int max, int *w, int *h);
/* WxH, each from lo to hi (a command that explains a side's own limits after parsing); else the message, -1. */
int sp_opt_size_in(const char *cmd, const char *opt, const char *s, int lo, int hi, int *w, int *h);
/* A value of a shape of its own (keyframe:N, WxH) is bad: the same message, -1. */
int sp_opt_bad(const char *cmd, const char *opt, const char *s, const char *want);
/* sp_opt_int without the message, for a number inside a longer value. */
int sp_opt_int_in(const char *s, int lo, int hi, int *out);
/* "PATH exists (use --force to replace it)" and the exit code of -EEXIST when path exists and force is 0; else 0. */
int sp_cmd_refuse_existing(const char *cmd, const char *path, int force);
/* A count that may pass INT_MAX (frames, seeds): decimal digits only. */
int sp_opt_u64(const char *cmd, const char *opt, const char *s, uint64_t lo, uint64_t hi, uint64_t *out);
/* One of n names: *out is its index; else "expected a, b or c". */
int sp_opt_choice(const char *cmd, const char *opt, const char *s, const char *const *names, int n, int *out);
/*
 * s with its control characters (C0, DEL, C1) written as \xNN, into buf (n bytes; cut to fit): every
 * string a command prints from a file goes through it, so a crafted file cannot drive the terminal.
 */
const char *sp_cmd_printable(const char *s, char *buf, size_t n);

/*
 * Ctrl-C and SIGTERM (cmd_signal.c): while caught, sp_cmd_stop_signal holds the signal that asked the
 * command to stop (0 while none did); loops poll it and end through their usual failure path.
 */
extern volatile sig_atomic_t sp_cmd_stop_signal;
typedef struct sp_cmd_signals {
    struct sigaction old_int, old_term;
} sp_cmd_signals;
void sp_cmd_catch_signals(sp_cmd_signals *saved);
void sp_cmd_restore_signals(const sp_cmd_signals *saved);
/* 128 + the stop signal when one came, else code. */
int sp_cmd_stopped_code(int code);

int sp_cmd_version(int argc, char **argv); /* --version [--verbose]: build features, modules, data files */
int sp_cmd_info(int argc, char **argv);
int sp_cmd_verify(int argc, char **argv);
int sp_cmd_recover(int argc, char **argv);
int sp_cmd_replay(int argc, char **argv);
int sp_cmd_import(int argc, char **argv);
int sp_cmd_check(int argc, char **argv); /* a selfie capture's fitness, before fitting */
int sp_cmd_export_video(int argc, char **argv);
int sp_cmd_synth(int argc, char **argv);
int sp_cmd_synth_street(int argc, char **argv); /* `synth street`, called by sp_cmd_synth */
int sp_cmd_synth_selfie(int argc, char **argv); /* `synth selfie`, called by sp_cmd_synth */
int sp_cmd_probe(int argc, char **argv);
int sp_cmd_composite(int argc, char **argv);
int sp_cmd_retexture(int argc, char **argv); /* a new ground texture in a probed scene, shading kept */
int sp_cmd_depopulate(int argc, char **argv);
int sp_cmd_repopulate(int argc, char **argv);
int sp_cmd_cutouts(int argc, char **argv);
int sp_cmd_devices(int argc, char **argv);
int sp_cmd_record(int argc, char **argv);
int sp_cmd_fit(int argc, char **argv);
int sp_cmd_relight(int argc, char **argv);
int sp_cmd_evaluate(int argc, char **argv); /* score a face directory against a capture with ground truth */
int sp_cmd_export(int argc, char **argv); /* export a face directory (glTF / OBJ / Draco) */
int sp_cmd_texture(int argc, char **argv); /* texture synthesis from an exemplar, any size */

#endif
