/* SPDX-License-Identifier: MIT */
/*
 * The command line's option parser (tools/cmd_options.c) at its edges: empty and blank values are refused
 * (never read as 0), ends of each range are taken and one past them refused, WxH sizes and enum choices,
 * and every refusal's message names the command, the option, the value and what was expected.
 */
#include <limits.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "tools/cmd.h"

static FILE *err_file;
static int real_stderr = -1;

/* stderr into a scratch file; `said` reads back what came since the last call and forwards it to the real
   stderr, so CHECK's own failure lines are never lost. */
static void capture_stderr(void)
{
    fflush(stderr);
    err_file = tmpfile();
    real_stderr = dup(2);
    if (!err_file || real_stderr < 0 || dup2(fileno(err_file), 2) < 0) {
        perror("test_cmd_options: stderr");
        exit(1);
    }
}

static int said(const char *text)
{
    static char buf[4096];
    fflush(stderr);
    rewind(err_file);
    size_t got = fread(buf, 1, sizeof(buf) - 1, err_file);
    buf[got] = '\0';
    if (write(real_stderr, buf, got) != (ssize_t)got || ftruncate(fileno(err_file), 0) != 0)
        return 0;
    rewind(err_file);
    return strstr(buf, text) != NULL;
}

static void integers(void)
{
    int v = -7;
    CHECK(sp_opt_int("fit", "keyframes", "", 2, 64, &v) == -1 && v == -7);
    CHECK(said("sunprobe fit: --keyframes '': expected an integer from 2 to 64"));
    CHECK(sp_opt_int("fit", "keyframes", " 5", 2, 64, &v) == -1);
    CHECK(sp_opt_int("fit", "keyframes", "5 ", 2, 64, &v) == -1);
    CHECK(sp_opt_int("fit", "keyframes", "2", 2, 64, &v) == 0 && v == 2);
    CHECK(sp_opt_int("fit", "keyframes", "64", 2, 64, &v) == 0 && v == 64);
    CHECK(sp_opt_int("fit", "keyframes", "65", 2, 64, &v) == -1 && v == 64);
    CHECK(sp_opt_int("fit", "keyframes", "1", 2, 64, &v) == -1);
    CHECK(said("--keyframes '1'"));
    CHECK(sp_opt_int("x", "n", "99999999999999999999", INT_MIN, INT_MAX, &v) == -1);
    CHECK(sp_opt_int("x", "n", "-2147483648", INT_MIN, INT_MAX, &v) == 0 && v == INT_MIN);
    uint64_t u = 3;
    CHECK(sp_opt_u64("x", "seed", "18446744073709551615", 0, UINT64_MAX, &u) == 0 && u == UINT64_MAX);
    CHECK(sp_opt_u64("x", "seed", "18446744073709551616", 0, UINT64_MAX, &u) == -1);
    CHECK(sp_opt_u64("x", "seed", "-1", 0, UINT64_MAX, &u) == -1 && u == UINT64_MAX);
    CHECK(sp_opt_u64("x", "seed", "", 0, UINT64_MAX, &u) == -1);
    CHECK(said("--seed '': expected an integer from 0 to 18446744073709551615"));
}

static void numbers(void)
{
    double d = 5;
    CHECK(sp_opt_double("fit", "time-budget", "", 0, 1e6, &d) == -1 && d == 5);
    CHECK(said("sunprobe fit: --time-budget ''"));
    CHECK(sp_opt_double("fit", "time-budget", "nan", 0, 1e6, &d) == -1);
    CHECK(sp_opt_double("fit", "time-budget", "inf", 0, 1e6, &d) == -1);
    CHECK(sp_opt_double("fit", "time-budget", "1e6", 0, 1e6, &d) == 0 && d == 1e6);
    CHECK(sp_opt_double("fit", "time-budget", "1000000.001", 0, 1e6, &d) == -1);
    CHECK(sp_opt_double("fit", "time-budget", "0", 0, 1e6, &d) == 0 && d == 0);
    CHECK(sp_opt_double("fit", "time-budget", "-0.001", 0, 1e6, &d) == -1);
    double v[2] = { 0, 0 }, lo[2] = { -360, 0 }, hi[2] = { 360, 90 };
    CHECK(sp_opt_list("relight", "sun", "120,25", 2, lo, hi, v, "AZ,EL") == 0 && v[0] == 120 && v[1] == 25);
    CHECK(sp_opt_list("relight", "sun", "120,91", 2, lo, hi, v, "AZ,EL") == -1);
    CHECK(said("sunprobe relight: --sun '120,91': expected AZ,EL"));
    CHECK(sp_opt_list("relight", "sun", "120", 2, lo, hi, v, "AZ,EL") == -1);
    CHECK(sp_opt_list("relight", "sun", "120,25,3", 2, lo, hi, v, "AZ,EL") == -1);
}

static void sizes(void)
{
    int w = 0, h = 0;
    CHECK(sp_opt_size("record", "size", "640x480", 16384, &w, &h) == 0 && w == 640 && h == 480);
    CHECK(sp_opt_size("record", "size", "1X1", 16384, &w, &h) == 0 && w == 1 && h == 1);
    CHECK(sp_opt_size("record", "size", "16384x16384", 16384, &w, &h) == 0 && w == 16384);
    CHECK(sp_opt_size("record", "size", "16385x2", 16384, &w, &h) == -1);
    CHECK(said("sunprobe record: --size '16385x2': expected WxH, each from 1 to 16384"));
    CHECK(sp_opt_size("record", "size", "0x2", 16384, &w, &h) == -1);
    CHECK(sp_opt_size("record", "size", "64", 16384, &w, &h) == -1);
    CHECK(sp_opt_size("record", "size", "x64", 16384, &w, &h) == -1);
    CHECK(sp_opt_size("record", "size", "64x", 16384, &w, &h) == -1);
    CHECK(sp_opt_size("record", "size", "", 16384, &w, &h) == -1);
    CHECK(sp_opt_size("record", "size", "-1x-1", 16384, &w, &h) == -1);
    /* a side of 0 and sides past a command's limit pass to that command's own, more specific check */
    CHECK(sp_opt_size_in("texture", "size", "0x64", 0, INT_MAX, &w, &h) == 0 && w == 0 && h == 64);
    CHECK(sp_opt_size_in("texture", "size", "2147483647x1", 0, INT_MAX, &w, &h) == 0 && w == INT_MAX);
    CHECK(sp_opt_size_in("texture", "size", "2147483648x1", 0, INT_MAX, &w, &h) == -1);
    CHECK(said("sunprobe texture: --size '2147483648x1': expected WxH, each from 0 to 2147483647"));
    CHECK(sp_opt_size_in("texture", "size", "12345678901234567x1", 0, INT_MAX, &w, &h) == -1);
}

static void choices(void)
{
    static const char *const formats[] = { "glb", "obj", "drc" };
    int i = -1;
    CHECK(sp_opt_choice("export", "format", "drc", formats, 3, &i) == 0 && i == 2);
    CHECK(sp_opt_choice("export", "format", "glb", formats, 3, &i) == 0 && i == 0);
    CHECK(sp_opt_choice("export", "format", "GLB", formats, 3, &i) == -1 && i == 0);
    CHECK(said("sunprobe export: --format 'GLB': expected glb, obj or drc\n"));
    CHECK(sp_opt_choice("export", "format", "", formats, 3, &i) == -1);
    CHECK(sp_opt_choice("fit", "solver", "adam", formats + 1, 1, &i) == -1);
    CHECK(said("--solver 'adam': expected obj\n"));
}

int main(void)
{
    capture_stderr();
    integers();
    numbers();
    sizes();
    choices();
    said("");
    dup2(real_stderr, 2);
    return check_exit();
}
