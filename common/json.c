/* SPDX-License-Identifier: MIT */
/* Recursive-descent JSON parser with a depth limit, and string-building helpers. */
#include "json.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_DEPTH 64

typedef struct parser {
    const char *p, *start, *end;
    char *err;
    size_t err_size;
    int failed;
} parser;

static void fail(parser *ps, const char *what)
{
    if (!ps->failed && ps->err && ps->err_size)
        snprintf(ps->err, ps->err_size, "JSON: %s at byte %zu", what, (size_t)(ps->p - ps->start));
    ps->failed = 1;
}

static void skip_ws(parser *ps)
{
    while (ps->p < ps->end && (*ps->p == ' ' || *ps->p == '\t' || *ps->p == '\n' || *ps->p == '\r'))
        ps->p++;
}

static int parse_value(parser *ps, sp_json *v, int depth);

static void put_utf8(sp_strbuf *b, unsigned cp)
{
    char u[4];
    size_t n;
    if (cp < 0x80) {
        u[0] = (char)cp;
        n = 1;
    } else if (cp < 0x800) {
        u[0] = (char)(0xC0 | (cp >> 6));
        u[1] = (char)(0x80 | (cp & 0x3F));
        n = 2;
    } else if (cp < 0x10000) {
        u[0] = (char)(0xE0 | (cp >> 12));
        u[1] = (char)(0x80 | ((cp >> 6) & 0x3F));
        u[2] = (char)(0x80 | (cp & 0x3F));
        n = 3;
    } else {
        u[0] = (char)(0xF0 | (cp >> 18));
        u[1] = (char)(0x80 | ((cp >> 12) & 0x3F));
        u[2] = (char)(0x80 | ((cp >> 6) & 0x3F));
        u[3] = (char)(0x80 | (cp & 0x3F));
        n = 4;
    }
    sp_strbuf_append(b, u, n);
}

static int hex4(parser *ps, unsigned *out)
{
    unsigned v = 0;
    for (int i = 0; i < 4; i++) {
        if (ps->p >= ps->end) {
            fail(ps, "truncated \\u escape");
            return -1;
        }
        char c = *ps->p++;
        v <<= 4;
        if (c >= '0' && c <= '9')
            v |= (unsigned)(c - '0');
        else if (c >= 'a' && c <= 'f')
            v |= (unsigned)(c - 'a' + 10);
        else if (c >= 'A' && c <= 'F')
            v |= (unsigned)(c - 'A' + 10);
        else {
            fail(ps, "bad \\u escape");
            return -1;
        }
    }
    *out = v;
    return 0;
}

/*
 * Length of the well-formed UTF-8 sequence at p (lead byte c already read, at p[-1]), or 0: no overlong
 * forms, no surrogates (CESU-8), nothing above U+10FFFF (RFC 3629).
 */
static size_t utf8_tail(unsigned char c, const char *p, const char *end)
{
    size_t n = c >= 0xC2 && c <= 0xDF ? 1 : (c >= 0xE0 && c <= 0xEF ? 2 : (c >= 0xF0 && c <= 0xF4 ? 3 : 0));
    if (!n || end - p < (ptrdiff_t)n)
        return 0;
    const unsigned char *q = (const unsigned char *)p;
    unsigned lo = 0x80, hi = 0xBF; /* the first continuation byte's range, narrowed where the lead needs it */
    if (c == 0xE0)
        lo = 0xA0;
    else if (c == 0xED)
        hi = 0x9F;
    else if (c == 0xF0)
        lo = 0x90;
    else if (c == 0xF4)
        hi = 0x8F;
    if (q[0] < lo || q[0] > hi)
        return 0;
    for (size_t i = 1; i < n; i++)
        if (q[i] < 0x80 || q[i] > 0xBF)
            return 0;
    return n;
}

static char *parse_string(parser *ps)
{
    sp_strbuf b = { 0 };
    ps->p++; /* opening quote */
    while (ps->p < ps->end && *ps->p != '"') {
        unsigned char c = (unsigned char)*ps->p++;
        if (c < 0x20) {
            fail(ps, "control character in string");
            break;
        }
        if (c >= 0x80) {
            size_t n = utf8_tail(c, ps->p, ps->end);
            if (!n) {
                fail(ps, "not UTF-8 (a bad, overlong or surrogate byte sequence)");
                break;
            }
            sp_strbuf_append(&b, ps->p - 1, n + 1);
            ps->p += n;
            continue;
        }
        if (c != '\\') {
            sp_strbuf_append(&b, (const char *)&c, 1);
            continue;
        }
        if (ps->p >= ps->end)
            break;
        char e = *ps->p++;
        static const char from[] = "\"\\/bfnrt", to[] = "\"\\/\b\f\n\r\t";
        const char *k = strchr(from, e);
        if (e && k) {
            sp_strbuf_append(&b, &to[k - from], 1);
        } else if (e == 'u') {
            unsigned cp;
            if (hex4(ps, &cp))
                break;
            if (cp >= 0xD800 && cp < 0xDC00 && ps->end - ps->p >= 6 && ps->p[0] == '\\' && ps->p[1] == 'u') {
                unsigned lo;
                ps->p += 2;
                if (hex4(ps, &lo))
                    break;
                if (lo >= 0xDC00 && lo < 0xE000)
                    cp = 0x10000 + ((cp - 0xD800) << 10) + (lo - 0xDC00);
            }
            /* strings here are NUL-terminated C strings and UTF-8: a NUL would cut one short, a lone
               surrogate would become CESU-8 */
            if (cp == 0) {
                fail(ps, "\\u0000 in a string");
                break;
            }
            if (cp >= 0xD800 && cp < 0xE000) {
                fail(ps, "a lone surrogate \\u escape");
                break;
            }
            put_utf8(&b, cp);
        } else {
            fail(ps, "bad escape");
            break;
        }
    }
    if (!ps->failed && ps->p >= ps->end)
        fail(ps, "unterminated string");
    if (ps->failed || b.failed) {
        if (b.failed)
            fail(ps, "out of memory");
        sp_strbuf_free(&b);
        return NULL;
    }
    ps->p++; /* closing quote */
    if (!b.data) {
        b.data = calloc(1, 1);
        if (!b.data)
            fail(ps, "out of memory");
    }
    return b.data;
}

static int parse_number(parser *ps, sp_json *v)
{
    char buf[64];
    size_t n = 0;
    while (ps->p + n < ps->end && n < sizeof(buf) - 1 && strchr("+-0123456789.eE", ps->p[n]))
        n++;
    memcpy(buf, ps->p, n);
    buf[n] = 0;
    char *endp;
    double d = strtod(buf, &endp);
    if (n == 0 || endp != buf + n) {
        fail(ps, "bad number");
        return -1;
    }
    ps->p += n;
    v->type = SP_JSON_NUMBER;
    v->number = d;
    return 0;
}

static int grow(sp_json *v, size_t *cap, int with_keys)
{
    if (v->count < *cap)
        return 0;
    size_t ncap = *cap ? *cap * 2 : 4;
    sp_json *items = realloc(v->items, ncap * sizeof(*items));
    if (!items)
        return -1;
    v->items = items;
    if (with_keys) {
        char **keys = realloc(v->keys, ncap * sizeof(*keys));
        if (!keys)
            return -1;
        v->keys = keys;
    }
    *cap = ncap;
    return 0;
}

static int parse_container(parser *ps, sp_json *v, int depth, int is_object)
{
    char close = is_object ? '}' : ']';
    size_t cap = 0;
    v->type = is_object ? SP_JSON_OBJECT : SP_JSON_ARRAY;
    ps->p++;
    skip_ws(ps);
    if (ps->p < ps->end && *ps->p == close) {
        ps->p++;
        return 0;
    }
    for (;;) {
        char *key = NULL;
        if (is_object) {
            skip_ws(ps);
            if (ps->p >= ps->end || *ps->p != '"') {
                fail(ps, "expected object key");
                return -1;
            }
            if (!(key = parse_string(ps)))
                return -1;
            skip_ws(ps);
            if (ps->p >= ps->end || *ps->p != ':') {
                free(key);
                fail(ps, "expected ':'");
                return -1;
            }
            ps->p++;
        }
        if (grow(v, &cap, is_object)) {
            free(key);
            fail(ps, "out of memory");
            return -1;
        }
        sp_json *item = &v->items[v->count];
        memset(item, 0, sizeof(*item));
        if (is_object)
            v->keys[v->count] = key;
        v->count++;
        if (parse_value(ps, item, depth + 1))
            return -1;
        skip_ws(ps);
        if (ps->p < ps->end && *ps->p == ',') {
            ps->p++;
            continue;
        }
        if (ps->p < ps->end && *ps->p == close) {
            ps->p++;
            return 0;
        }
        fail(ps, is_object ? "expected ',' or '}'" : "expected ',' or ']'");
        return -1;
    }
}

static int literal(parser *ps, const char *word)
{
    size_t n = strlen(word);
    if ((size_t)(ps->end - ps->p) < n || memcmp(ps->p, word, n) != 0) {
        fail(ps, "unexpected token");
        return -1;
    }
    ps->p += n;
    return 0;
}

static int parse_value(parser *ps, sp_json *v, int depth)
{
    if (depth > MAX_DEPTH) {
        fail(ps, "nesting too deep");
        return -1;
    }
    skip_ws(ps);
    if (ps->p >= ps->end) {
        fail(ps, "unexpected end");
        return -1;
    }
    switch (*ps->p) {
    case '{':
        return parse_container(ps, v, depth, 1);
    case '[':
        return parse_container(ps, v, depth, 0);
    case '"':
        v->type = SP_JSON_STRING;
        v->string = parse_string(ps);
        return v->string ? 0 : -1;
    case 't':
        v->type = SP_JSON_BOOL;
        v->number = 1;
        return literal(ps, "true");
    case 'f':
        v->type = SP_JSON_BOOL;
        return literal(ps, "false");
    case 'n':
        v->type = SP_JSON_NULL;
        return literal(ps, "null");
    default:
        return parse_number(ps, v);
    }
}

static void free_value(sp_json *v)
{
    for (size_t i = 0; i < v->count; i++) {
        free_value(&v->items[i]);
        if (v->keys)
            free(v->keys[i]);
    }
    free(v->items);
    free(v->keys);
    free(v->string);
}

void sp_json_free(sp_json *root)
{
    if (!root)
        return;
    free_value(root);
    free(root);
}

int sp_json_parse(const char *text, size_t len, sp_json **out, char *err, size_t err_size)
{
    if (!out || (!text && len))
        return -EINVAL;
    *out = NULL;
    parser ps = { text, text, text + len, err, err_size, 0 };
    sp_json *root = calloc(1, sizeof(*root));
    if (!root)
        return -ENOMEM;
    if (parse_value(&ps, root, 0) == 0) {
        skip_ws(&ps);
        if (ps.p != ps.end)
            fail(&ps, "trailing characters");
    }
    if (ps.failed) {
        sp_json_free(root);
        return SP_ECORRUPT;
    }
    *out = root;
    return 0;
}

const sp_json *sp_json_get(const sp_json *obj, const char *key)
{
    if (!obj || obj->type != SP_JSON_OBJECT || !key)
        return NULL;
    for (size_t i = obj->count; i-- > 0;) /* last duplicate wins */
        if (strcmp(obj->keys[i], key) == 0)
            return &obj->items[i];
    return NULL;
}

const sp_json *sp_json_at(const sp_json *arr, size_t i)
{
    if (!arr || arr->type != SP_JSON_ARRAY || i >= arr->count)
        return NULL;
    return &arr->items[i];
}

double sp_json_number(const sp_json *v, double fallback)
{
    return v && (v->type == SP_JSON_NUMBER || v->type == SP_JSON_BOOL) ? v->number : fallback;
}

const char *sp_json_string(const sp_json *v, const char *fallback)
{
    return v && v->type == SP_JSON_STRING ? v->string : fallback;
}

size_t sp_json_numbers(const sp_json *arr, double *out, size_t n)
{
    size_t got = 0;
    for (size_t i = 0; i < n; i++) {
        const sp_json *e = sp_json_at(arr, i);
        if (e && e->type == SP_JSON_NUMBER) {
            out[i] = e->number;
            got++;
        }
    }
    return got;
}

static int reserve(sp_strbuf *b, size_t extra)
{
    if (b->failed)
        return -1;
    if (b->len + extra + 1 <= b->cap)
        return 0;
    size_t ncap = b->cap ? b->cap : 64;
    while (ncap < b->len + extra + 1)
        ncap *= 2;
    char *d = realloc(b->data, ncap);
    if (!d) {
        b->failed = 1;
        return -1;
    }
    b->data = d;
    b->cap = ncap;
    return 0;
}

void sp_strbuf_append(sp_strbuf *b, const char *s, size_t n)
{
    if (reserve(b, n))
        return;
    memcpy(b->data + b->len, s, n);
    b->len += n;
    b->data[b->len] = 0;
}

void sp_strbuf_printf(sp_strbuf *b, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0 || reserve(b, (size_t)n))
        return;
    va_start(ap, fmt);
    vsnprintf(b->data + b->len, (size_t)n + 1, fmt, ap);
    va_end(ap);
    b->len += (size_t)n;
}

void sp_strbuf_json_string(sp_strbuf *b, const char *s)
{
    sp_strbuf_append(b, "\"", 1);
    for (; s && *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') {
            char e[2] = { '\\', (char)c };
            sp_strbuf_append(b, e, 2);
        } else if (c < 0x20) {
            sp_strbuf_printf(b, "\\u%04x", c);
        } else {
            sp_strbuf_append(b, (const char *)&c, 1);
        }
    }
    sp_strbuf_append(b, "\"", 1);
}

void sp_strbuf_json_number(sp_strbuf *b, double v)
{
    if (isfinite(v))
        sp_strbuf_printf(b, "%.17g", v);
    else
        sp_strbuf_append(b, "null", 4);
}

void sp_strbuf_json_numbers(sp_strbuf *b, const double *v, int n)
{
    sp_strbuf_append(b, "[", 1);
    for (int i = 0; i < n; i++) {
        if (i)
            sp_strbuf_append(b, ",", 1);
        sp_strbuf_json_number(b, v[i]);
    }
    sp_strbuf_append(b, "]", 1);
}

void sp_strbuf_free(sp_strbuf *b)
{
    free(b->data);
    memset(b, 0, sizeof(*b));
}
