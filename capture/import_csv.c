/* SPDX-License-Identifier: MIT */
/* Strict numeric CSV reading for the importers; see import_csv.h for the accepted layout. */
#include "import_csv.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "sunprobe/sp_common.h"

/* Seconds and nanoseconds are bounded so that differences of two times never overflow int64. */
#define MAX_ABS_T_S 4.0e9
#define MAX_ABS_T_NS 4000000000000000000LL

int sp_csv_fail(sp_csv *c, int rc, const char *fmt, ...)
{
    if (c->err && c->err_size) {
        int n = snprintf(c->err, c->err_size, "%s:%lu: ", c->path, c->line);
        if (n >= 0 && (size_t)n < c->err_size) {
            va_list ap;
            va_start(ap, fmt);
            vsnprintf(c->err + n, c->err_size - (size_t)n, fmt, ap);
            va_end(ap);
        }
    }
    return rc;
}

static char *trim(char *s)
{
    while (*s == ' ' || *s == '\t')
        s++;
    size_t n = strlen(s);
    while (n && (s[n - 1] == ' ' || s[n - 1] == '\t' || s[n - 1] == '\r' || s[n - 1] == '\n'))
        s[--n] = 0;
    return s;
}

/* Reads lines until one that is neither blank nor a comment; splits it at commas. */
static int read_row(sp_csv *c)
{
    for (;;) {
        errno = 0;
        ssize_t n = getline(&c->buf, &c->buf_cap, c->file);
        if (n < 0) { /* the read's own reason (EISDIR for a directory), not a bare EIO */
            int rc = errno ? -errno : -EIO;
            return rc == -ENOMEM ? rc : ferror(c->file) ? sp_csv_fail(c, rc, "read error") : SP_EOS;
        }
        c->line++;
        if ((size_t)n != strlen(c->buf))
            return sp_csv_fail(c, SP_ECORRUPT, "NUL byte in line (not a text file?)");
        char *s = trim(c->buf);
        if (*s == 0 || *s == '#')
            continue;
        c->nfields = 0;
        for (char *field = s;;) {
            if (c->nfields == c->fields_cap) {
                size_t cap = c->fields_cap ? c->fields_cap * 2 : 16;
                char **p = realloc(c->fields, cap * sizeof(*p));
                if (!p)
                    return -ENOMEM;
                c->fields = p;
                c->fields_cap = cap;
            }
            char *comma = strchr(field, ',');
            if (comma)
                *comma = 0;
            c->fields[c->nfields++] = trim(field);
            if (!comma)
                break;
            field = comma + 1;
        }
        return 0;
    }
}

static int read_header(sp_csv *c)
{
    int rc = read_row(c);
    if (rc == SP_EOS)
        return sp_csv_fail(c, SP_ENODATA, "no header row (the file holds no line of column names)");
    if (rc)
        return rc;
    c->names = calloc(c->nfields, sizeof(*c->names));
    if (!c->names)
        return -ENOMEM;
    c->nnames = c->nfields;
    for (size_t i = 0; i < c->nfields; i++) {
        char *name = c->fields[i];
        size_t n = strlen(name);
        if (n >= 2 && name[0] == '"' && name[n - 1] == '"') {
            name[n - 1] = 0;
            name++;
        }
        if (!*name)
            return sp_csv_fail(c, SP_ECORRUPT, "header column %zu has no name", i + 1);
        if (sp_csv_column(c, name) >= 0)
            return sp_csv_fail(c, SP_ECORRUPT, "header names column '%s' twice", name);
        c->names[i] = strdup(name);
        if (!c->names[i])
            return -ENOMEM;
    }
    return 0;
}

int sp_csv_open(sp_csv *c, const char *path, char *err, size_t err_size)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        int rc = -errno;
        memset(c, 0, sizeof(*c));
        c->path = path;
        c->err = err;
        c->err_size = err_size;
        return sp_csv_fail(c, rc, "cannot open: %s", sp_strerror(rc));
    }
    return sp_csv_open_stream(c, f, path, 0, 1, err, err_size);
}

/* A headerless table takes its width from the first row; its columns are named "1", "2", ... */
static int name_columns(sp_csv *c)
{
    c->names = calloc(c->nfields, sizeof(*c->names));
    if (!c->names)
        return -ENOMEM;
    c->nnames = c->nfields;
    for (size_t i = 0; i < c->nfields; i++) {
        char name[24];
        snprintf(name, sizeof(name), "%zu", i + 1);
        if (!(c->names[i] = strdup(name)))
            return -ENOMEM;
    }
    return 0;
}

int sp_csv_open_stream(sp_csv *c, FILE *f, const char *path, unsigned long lines_before, int header, char *err,
                       size_t err_size)
{
    memset(c, 0, sizeof(*c));
    c->path = path;
    c->err = err;
    c->err_size = err_size;
    c->file = f;
    c->line = lines_before;
    c->headerless = !header;
    int rc = header ? read_header(c) : 0;
    if (rc)
        sp_csv_close(c);
    return rc;
}

void sp_csv_close(sp_csv *c)
{
    if (c->file)
        fclose(c->file);
    for (size_t i = 0; i < c->nnames; i++)
        free(c->names[i]);
    free(c->names);
    free(c->fields);
    free(c->buf);
    c->file = NULL;
    c->names = NULL;
    c->fields = NULL;
    c->buf = NULL;
    c->nnames = c->nfields = 0;
}

int sp_csv_column(const sp_csv *c, const char *name)
{
    for (size_t i = 0; i < c->nnames; i++)
        if (c->names[i] && strcmp(c->names[i], name) == 0)
            return (int)i;
    return -1;
}

int sp_csv_next(sp_csv *c)
{
    int rc = read_row(c);
    if (rc)
        return rc;
    if (c->headerless && !c->names && (rc = name_columns(c)) != 0)
        return rc;
    if (c->nfields != c->nnames)
        return sp_csv_fail(c, SP_ECORRUPT, "%zu fields, but the %s has %zu", c->nfields,
                           c->headerless ? "first row" : "header", c->nnames);
    return 0;
}

int sp_csv_empty(const sp_csv *c, int col)
{
    return col < 0 || (size_t)col >= c->nfields || c->fields[col][0] == 0;
}

int sp_csv_double(sp_csv *c, int col, double *out)
{
    if (sp_csv_empty(c, col))
        return sp_csv_fail(c, SP_ECORRUPT, "column '%s' is empty", col >= 0 ? c->names[col] : "?");
    const char *s = c->fields[col];
    char *end = NULL;
    errno = 0;
    double v = strtod(s, &end);
    if (end == s || *end != 0)
        return sp_csv_fail(c, SP_ECORRUPT, "column '%s': '%s' is not a number", c->names[col], s);
    if (!isfinite(v) || errno == ERANGE)
        return sp_csv_fail(c, SP_ECORRUPT, "column '%s': '%s' is not a finite number", c->names[col], s);
    *out = v;
    return 0;
}

int sp_csv_int64(sp_csv *c, int col, int64_t *out)
{
    if (sp_csv_empty(c, col))
        return sp_csv_fail(c, SP_ECORRUPT, "column '%s' is empty", col >= 0 ? c->names[col] : "?");
    const char *s = c->fields[col];
    char *end = NULL;
    errno = 0;
    long long v = strtoll(s, &end, 10);
    if (end == s || *end != 0)
        return sp_csv_fail(c, SP_ECORRUPT, "column '%s': '%s' is not an integer", c->names[col], s);
    if (errno == ERANGE)
        return sp_csv_fail(c, SP_ECORRUPT, "column '%s': '%s' is out of range", c->names[col], s);
    *out = (int64_t)v;
    return 0;
}

int sp_csv_time_ns(sp_csv *c, int col_t, int col_tns, int64_t *out)
{
    if (col_tns >= 0) {
        int64_t v = 0;
        int rc = sp_csv_int64(c, col_tns, &v);
        if (rc)
            return rc;
        if (v > MAX_ABS_T_NS || v < -MAX_ABS_T_NS)
            return sp_csv_fail(c, SP_ECORRUPT, "t_ns %lld is out of range", (long long)v);
        *out = v;
        return 0;
    }
    double t;
    int rc = sp_csv_double(c, col_t, &t);
    if (rc)
        return rc;
    if (fabs(t) > MAX_ABS_T_S)
        return sp_csv_fail(c, SP_ECORRUPT, "t %g s is out of range", t);
    *out = llround(t * 1e9);
    return 0;
}

int sp_csv_time_columns(sp_csv *c, int *col_t, int *col_tns)
{
    *col_t = sp_csv_column(c, "t");
    *col_tns = sp_csv_column(c, "t_ns");
    if (*col_t >= 0 && *col_tns >= 0)
        return sp_csv_fail(c, SP_ECORRUPT, "has both 't' and 't_ns' columns; keep one");
    if (*col_t < 0 && *col_tns < 0)
        return sp_csv_fail(c, SP_ECORRUPT, "needs a 't' (seconds) or 't_ns' (nanoseconds) column");
    return 0;
}
