/* SPDX-License-Identifier: MIT */
/* Option values shared by the commands: one parser, one message that names the option and its range. */
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "tools/cmd.h"

/* strtod/strtol skip leading blanks; an empty or blank value is not a number, whatever they return */
static int blank_start(const char *s)
{
    return !s || !*s || *s == ' ' || *s == '\t' || *s == '\n';
}

int sp_opt_bad(const char *cmd, const char *opt, const char *s, const char *want)
{
    fprintf(stderr, "sunprobe %s: --%s '%s': expected %s\n", cmd, opt, s ? s : "", want);
    return -1;
}

int sp_opt_int_in(const char *s, int lo, int hi, int *out)
{
    char *end = NULL;
    errno = 0;
    long v = blank_start(s) ? 0 : strtol(s, &end, 10);
    if (blank_start(s) || *end || errno == ERANGE || v < lo || v > hi)
        return -1;
    *out = (int)v;
    return 0;
}

int sp_opt_int(const char *cmd, const char *opt, const char *s, int lo, int hi, int *out)
{
    if (!sp_opt_int_in(s, lo, hi, out))
        return 0;
    fprintf(stderr, "sunprobe %s: --%s '%s': expected an integer from %d to %d\n", cmd, opt, s ? s : "", lo, hi);
    return -1;
}

int sp_opt_double(const char *cmd, const char *opt, const char *s, double lo, double hi, double *out)
{
    char *end = NULL;
    double v = blank_start(s) ? 0.0 : strtod(s, &end);
    if (blank_start(s) || *end || !(v >= lo && v <= hi)) {
        fprintf(stderr, "sunprobe %s: --%s '%s': expected a number from %g to %g\n", cmd, opt, s ? s : "", lo, hi);
        return -1;
    }
    *out = v;
    return 0;
}

int sp_opt_u64(const char *cmd, const char *opt, const char *s, uint64_t lo, uint64_t hi, uint64_t *out)
{
    char *end = NULL;
    errno = 0;
    /* strtoull takes "-1" as a huge number: only digits are a count */
    unsigned long long v = blank_start(s) || *s < '0' || *s > '9' ? 0 : strtoull(s, &end, 10);
    if (!end || *end || errno == ERANGE || v < lo || v > hi) {
        fprintf(stderr, "sunprobe %s: --%s '%s': expected an integer from %llu to %llu\n", cmd, opt, s ? s : "",
                (unsigned long long)lo, (unsigned long long)hi);
        return -1;
    }
    *out = v;
    return 0;
}

int sp_opt_choice(const char *cmd, const char *opt, const char *s, const char *const *names, int n, int *out)
{
    for (int i = 0; s && i < n; i++)
        if (!strcmp(s, names[i])) {
            *out = i;
            return 0;
        }
    fprintf(stderr, "sunprobe %s: --%s '%s': expected ", cmd, opt, s ? s : "");
    for (int i = 0; i < n; i++)
        fprintf(stderr, "%s%s", names[i], i + 2 < n ? ", " : i + 2 == n ? " or " : "\n");
    return -1;
}

const char *sp_cmd_printable(const char *s, char *buf, size_t n)
{
    static const char hex[] = "0123456789abcdef";
    size_t o = 0;
    for (const unsigned char *p = (const unsigned char *)(s ? s : ""); *p && o + 5 < n; p++) {
        /* C0 controls and DEL, and the C1 controls as UTF-8 (0xc2 0x80..0x9f: 0x9b is a CSI on some terminals) */
        int c1 = p[0] == 0xc2 && p[1] >= 0x80 && p[1] <= 0x9f;
        if (*p < 0x20 || *p == 0x7f || c1) {
            unsigned char v = c1 ? *++p : *p;
            buf[o++] = '\\', buf[o++] = 'x', buf[o++] = hex[v >> 4], buf[o++] = hex[v & 15];
        } else {
            buf[o++] = (char)*p;
        }
    }
    buf[o] = '\0';
    return buf;
}

int sp_opt_size(const char *cmd, const char *opt, const char *s, int max, int *w, int *h)
{
    return sp_opt_size_in(cmd, opt, s, 1, max, w, h);
}

int sp_opt_size_in(const char *cmd, const char *opt, const char *s, int lo, int hi, int *w, int *h)
{
    const char *x = s ? strpbrk(s, "xX") : NULL;
    char first[16];
    if (x && x - s < (ptrdiff_t)sizeof(first)) {
        snprintf(first, sizeof(first), "%.*s", (int)(x - s), s);
        if (!sp_opt_int_in(first, lo, hi, w) && !sp_opt_int_in(x + 1, lo, hi, h))
            return 0;
    }
    fprintf(stderr, "sunprobe %s: --%s '%s': expected WxH, each from %d to %d\n", cmd, opt, s ? s : "", lo, hi);
    return -1;
}

int sp_opt_list(const char *cmd, const char *opt, const char *s, int n, const double *lo, const double *hi,
                double *v, const char *want)
{
    int ok = !blank_start(s) && !sp_opt_numbers(s, v, n);
    for (int i = 0; ok && i < n; i++)
        ok = v[i] >= lo[i] && v[i] <= hi[i];
    return ok ? 0 : sp_opt_bad(cmd, opt, s, want);
}

int sp_opt_numbers(const char *s, double *v, int n)
{
    const char *p = s;
    for (int i = 0; i < n; i++) {
        char *end;
        v[i] = strtod(p, &end);
        if (end == p || !isfinite(v[i]) || (i + 1 < n ? *end != ',' : *end != 0))
            return -1;
        p = end + 1;
    }
    return 0;
}

int sp_cmd_refuse_existing(const char *cmd, const char *path, int force)
{
    if (force || access(path, F_OK) != 0)
        return 0;
    fprintf(stderr, "sunprobe %s: %s exists (use --force to replace it)\n", cmd, path);
    return sp_exit_for_error(-EEXIST);
}
