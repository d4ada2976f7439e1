/* SPDX-License-Identifier: MIT */
/* A small JSON reader (into a tree) and writer helpers, for metadata and manifests. */
#ifndef SUNPROBE_COMMON_JSON_H
#define SUNPROBE_COMMON_JSON_H

#include <stddef.h>

#include "sunprobe/sp_common.h"
#include "common/private_api.h"

typedef enum sp_json_type {
    SP_JSON_NULL,
    SP_JSON_BOOL,
    SP_JSON_NUMBER,
    SP_JSON_STRING,
    SP_JSON_ARRAY,
    SP_JSON_OBJECT,
} sp_json_type;

typedef struct sp_json sp_json;
struct sp_json {
    sp_json_type type;
    double number;  /* NUMBER, and BOOL as 0/1 */
    char *string;   /* STRING, NUL-terminated */
    size_t count;   /* ARRAY/OBJECT members */
    sp_json *items; /* ARRAY/OBJECT values */
    char **keys;    /* OBJECT keys */
};

/*
 * Parses len bytes (need not be NUL-terminated). Returns 0 and a tree the caller
 * frees with sp_json_free, or SP_ECORRUPT with a message naming the byte offset in err.
 */
SP_PRIVATE int sp_json_parse(const char *text, size_t len, sp_json **out, char *err, size_t err_size);
SP_PRIVATE void sp_json_free(sp_json *root);

/* Member of an object by key, NULL if absent or not an object. */
SP_PRIVATE const sp_json *sp_json_get(const sp_json *obj, const char *key);
/* Element i of an array, NULL if out of range. */
SP_PRIVATE const sp_json *sp_json_at(const sp_json *arr, size_t i);
/* Value or fallback when v is NULL or of another type. */
SP_PRIVATE double sp_json_number(const sp_json *v, double fallback);
SP_PRIVATE const char *sp_json_string(const sp_json *v, const char *fallback);
/* Reads up to n numbers of an array into out; returns how many were numbers. */
SP_PRIVATE size_t sp_json_numbers(const sp_json *arr, double *out, size_t n);

/* A growing string; `failed` latches on allocation failure so writers check once at the end. */
typedef struct sp_strbuf {
    char *data;
    size_t len, cap;
    int failed;
} sp_strbuf;

SP_PRIVATE void sp_strbuf_printf(sp_strbuf *b, const char *fmt, ...) SP_PRINTF(2, 3);
void sp_strbuf_append(sp_strbuf *b, const char *s, size_t n);
/* Appends a quoted, escaped JSON string. */
SP_PRIVATE void sp_strbuf_json_string(sp_strbuf *b, const char *s);
/* Appends a number, or null when it is not finite (JSON has no NaN). */
SP_PRIVATE void sp_strbuf_json_number(sp_strbuf *b, double v);
/* Appends a JSON array of n numbers (non-finite ones as null). */
SP_PRIVATE void sp_strbuf_json_numbers(sp_strbuf *b, const double *v, int n);
SP_PRIVATE void sp_strbuf_free(sp_strbuf *b);

#endif
