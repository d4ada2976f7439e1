/* SPDX-License-Identifier: MIT */
/*
 * OBJ parsing with an explicit end pointer (input need not be NUL-terminated),
 * a locale-independent number parser, 1-based and negative (relative) indices,
 * and growth checks on every array. Anything it does not understand in v, vt
 * or f records is an error with a line number; other records are ignored.
 */
#include "obj_reader.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/file_util.h"
#include "sunprobe/sp_common.h"

#define MAX_POLY 64
#define MAX_ITEMS (1u << 26)
#define MAX_OBJ_BYTES ((size_t)1 << 31)

typedef struct cursor {
    const char *p, *end;
    size_t line;
} cursor;

typedef struct grow {
    void *data;
    uint32_t n, cap;
} grow;

static int grow_reserve(grow *g, uint32_t more, size_t elem)
{
    if (g->n + (uint64_t)more <= g->cap)
        return 0;
    uint64_t cap = g->cap ? (uint64_t)g->cap * 2 : 1024;
    while (cap < g->n + (uint64_t)more)
        cap *= 2;
    if (cap > MAX_ITEMS)
        return -E2BIG;
    void *d = realloc(g->data, (size_t)cap * elem);
    if (!d)
        return -ENOMEM;
    g->data = d;
    g->cap = (uint32_t)cap;
    return 0;
}

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

static void skip_space(cursor *c)
{
    while (c->p < c->end && is_space(*c->p))
        c->p++;
}

static int at_line_end(const cursor *c) { return c->p >= c->end || *c->p == '\n' || *c->p == '#'; }

static void skip_line(cursor *c)
{
    while (c->p < c->end && *c->p != '\n')
        c->p++;
    if (c->p < c->end)
        c->p++;
    c->line++;
}

static double pow10_int(int e)
{
    static const double small[] = { 1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                    1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22 };
    return e >= 0 && e <= 22 ? small[e] : pow(10.0, e);
}

/* [-+]digits[.digits][(e|E)[-+]digits]; finite results only. */
static int parse_number(cursor *c, double *out)
{
    const char *p = c->p, *end = c->end;
    int neg = 0, digits = 0, exp10 = 0;
    uint64_t mant = 0;
    if (p < end && (*p == '-' || *p == '+'))
        neg = *p++ == '-';
    for (; p < end && *p >= '0' && *p <= '9'; p++, digits++) {
        if (mant < 100000000000000000ull)
            mant = mant * 10 + (uint64_t)(*p - '0');
        else
            exp10++; /* digits past 17 only shift the scale */
    }
    if (p < end && *p == '.')
        for (p++; p < end && *p >= '0' && *p <= '9'; p++, digits++)
            if (mant < 100000000000000000ull) {
                mant = mant * 10 + (uint64_t)(*p - '0');
                exp10--;
            }
    if (!digits)
        return -1;
    if (p < end && (*p == 'e' || *p == 'E')) {
        p++;
        int eneg = 0, e = 0, edigits = 0;
        if (p < end && (*p == '-' || *p == '+'))
            eneg = *p++ == '-';
        for (; p < end && *p >= '0' && *p <= '9'; p++, edigits++)
            if (e < 10000)
                e = e * 10 + (*p - '0');
        if (!edigits)
            return -1;
        exp10 += eneg ? -e : e;
    }
    if (p < end && !is_space(*p) && *p != '\n' && *p != '/' && *p != '#')
        return -1;
    double v = exp10 < 0 ? (double)mant / pow10_int(-exp10) : (double)mant * pow10_int(exp10);
    if (!isfinite(v) || fabs(v) > 3e38)
        return -1;
    *out = neg ? -v : v;
    c->p = p;
    return 0;
}

static int parse_int(cursor *c, long long *out)
{
    const char *p = c->p;
    int neg = 0;
    long long v = 0;
    if (p < c->end && (*p == '-' || *p == '+'))
        neg = *p++ == '-';
    const char *start = p;
    for (; p < c->end && *p >= '0' && *p <= '9'; p++)
        if ((v = v * 10 + (*p - '0')) > (long long)MAX_ITEMS * 4)
            return -1;
    if (p == start)
        return -1;
    *out = neg ? -v : v;
    c->p = p;
    return 0;
}

typedef struct parser {
    grow v, vt, fstart, cv, cvt;
    int positions_only;
    char *err;
    size_t err_size;
} parser;

static int fail(parser *ps, const cursor *c, const char *fmt, ...) SP_PRINTF(3, 4);
static int fail(parser *ps, const cursor *c, const char *fmt, ...)
{
    if (ps->err && ps->err_size) {
        int n = snprintf(ps->err, ps->err_size, "line %zu: ", c->line);
        va_list ap;
        va_start(ap, fmt);
        if (n >= 0 && (size_t)n < ps->err_size)
            vsnprintf(ps->err + n, ps->err_size - (size_t)n, fmt, ap);
        va_end(ap);
    }
    return SP_ECORRUPT;
}

/* Reads `want` numbers (more are allowed and ignored: w, colours). */
static int parse_floats(parser *ps, cursor *c, grow *g, int want)
{
    int err = grow_reserve(g, (uint32_t)want, sizeof(float));
    if (err)
        return err;
    float *dst = (float *)g->data + g->n;
    for (int k = 0; k < want; k++) {
        double x;
        skip_space(c);
        if (parse_number(c, &x) != 0)
            return fail(ps, c, "expected %d finite numbers", want);
        dst[k] = (float)x;
    }
    while (skip_space(c), !at_line_end(c)) {
        double x;
        if (parse_number(c, &x) != 0)
            return fail(ps, c, "unexpected text after the numbers");
    }
    g->n += (uint32_t)want;
    return 0;
}

/* OBJ index (1-based, or negative = relative to the end so far) to 0-based. */
static int resolve(long long idx, uint32_t count, uint32_t *out)
{
    long long r = idx > 0 ? idx - 1 : idx < 0 ? (long long)count + idx : -1;
    if (r < 0 || r >= (long long)count)
        return -1;
    *out = (uint32_t)r;
    return 0;
}

static int parse_corner(parser *ps, cursor *c, uint32_t *vi, uint32_t *ti)
{
    long long a, b;
    uint32_t n_v = ps->v.n / 3, n_vt = ps->vt.n / 2;
    if (parse_int(c, &a) != 0 || resolve(a, n_v, vi) != 0)
        return fail(ps, c, "bad or out-of-range vertex index");
    *ti = OBJ_NO_UV;
    if (c->p < c->end && *c->p == '/') {
        c->p++;
        if (c->p < c->end && *c->p != '/') {
            if (parse_int(c, &b) != 0 || resolve(b, n_vt, ti) != 0)
                return fail(ps, c, "bad or out-of-range texture index");
        }
        if (c->p < c->end && *c->p == '/') { /* normal index: checked for syntax, not used */
            c->p++;
            if (parse_int(c, &b) != 0)
                return fail(ps, c, "bad normal index");
        }
    }
    if (c->p < c->end && !is_space(*c->p) && *c->p != '\n' && *c->p != '#')
        return fail(ps, c, "unexpected character in a face corner");
    return 0;
}

static int parse_face(parser *ps, cursor *c)
{
    uint32_t vi[MAX_POLY], ti[MAX_POLY];
    int n = 0;
    while (skip_space(c), !at_line_end(c)) {
        if (n == MAX_POLY)
            return fail(ps, c, "polygon with more than %d corners", MAX_POLY);
        int err = parse_corner(ps, c, &vi[n], &ti[n]);
        if (err)
            return err;
        n++;
    }
    if (n < 3)
        return fail(ps, c, "face with fewer than 3 corners");
    int err = grow_reserve(&ps->cv, (uint32_t)n, 4);
    if (!err)
        err = grow_reserve(&ps->cvt, (uint32_t)n, 4);
    if (!err)
        err = grow_reserve(&ps->fstart, 2, 4);
    if (err)
        return err;
    uint32_t *fs = ps->fstart.data;
    if (ps->fstart.n == 0)
        fs[ps->fstart.n++] = 0;
    memcpy((uint32_t *)ps->cv.data + ps->cv.n, vi, sizeof(uint32_t) * (size_t)n);
    memcpy((uint32_t *)ps->cvt.data + ps->cvt.n, ti, sizeof(uint32_t) * (size_t)n);
    ps->cv.n += (uint32_t)n;
    ps->cvt.n += (uint32_t)n;
    fs[ps->fstart.n++] = ps->cv.n;
    return 0;
}

static int parse_line(parser *ps, cursor *c)
{
    skip_space(c);
    const char *p = c->p;
    size_t left = (size_t)(c->end - p);
    if (left >= 2 && p[0] == 'v' && is_space(p[1])) {
        c->p += 2;
        return parse_floats(ps, c, &ps->v, 3);
    }
    if (ps->positions_only)
        return 0;
    if (left >= 3 && p[0] == 'v' && p[1] == 't' && is_space(p[2])) {
        c->p += 3;
        return parse_floats(ps, c, &ps->vt, 2);
    }
    if (left >= 2 && p[0] == 'f' && is_space(p[1])) {
        c->p += 2;
        return parse_face(ps, c);
    }
    return 0; /* comments, vn, o, g, s, usemtl, mtllib, blank lines */
}

static void parser_free(parser *ps)
{
    free(ps->v.data);
    free(ps->vt.data);
    free(ps->fstart.data);
    free(ps->cv.data);
    free(ps->cvt.data);
}

int obj_parse(const char *text, size_t len, int positions_only, obj_data *out, char *err, size_t err_size)
{
    if (!out || (!text && len))
        return -EINVAL;
    memset(out, 0, sizeof(*out));
    if (err && err_size)
        err[0] = 0;
    parser ps = { .positions_only = positions_only, .err = err, .err_size = err_size };
    cursor c = { text, text + len, 1 };
    int rc = 0;
    while (!rc && c.p < c.end) {
        rc = parse_line(&ps, &c);
        if (!rc)
            skip_line(&c);
    }
    if (rc == -E2BIG)
        rc = fail(&ps, &c, "too many elements");
    if (rc) {
        parser_free(&ps);
        return rc;
    }
    out->n_v = ps.v.n / 3;
    out->n_vt = ps.vt.n / 2;
    out->n_faces = ps.fstart.n ? ps.fstart.n - 1 : 0;
    out->n_corners = ps.cv.n;
    out->v = ps.v.data;
    out->vt = ps.vt.data;
    out->face_start = ps.fstart.data;
    out->corner_v = ps.cv.data;
    out->corner_vt = ps.cvt.data;
    return 0;
}

int obj_read_file(const char *path, int positions_only, obj_data *out, char *err, size_t err_size)
{
    if (!path || !out)
        return -EINVAL;
    memset(out, 0, sizeof(*out));
    void *buf = NULL;
    size_t size = 0;
    int rc = sp_read_whole_file(path, MAX_OBJ_BYTES, &buf, &size);
    if (!rc)
        rc = obj_parse(buf, size, positions_only, out, err, err_size);
    free(buf);
    return rc;
}

void obj_free(obj_data *obj)
{
    if (!obj)
        return;
    free(obj->v);
    free(obj->vt);
    free(obj->face_start);
    free(obj->corner_v);
    free(obj->corner_vt);
    memset(obj, 0, sizeof(*obj));
}
