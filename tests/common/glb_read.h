/* SPDX-License-Identifier: MIT */
/* Reading a .glb back in the export tests: the file, its JSON and BIN chunks, plain accessors. Include after check.h. */
#ifndef SUNPROBE_TESTS_GLB_READ_H
#define SUNPROBE_TESTS_GLB_READ_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/file_util.h"
#include "common/json.h"

typedef struct glb {
    uint8_t *file;
    size_t size;
    sp_json *json;
    const uint8_t *bin;
    size_t bin_size;
} glb;

/* The whole file (NUL-terminated past *n), NULL when missing or empty. */
static inline uint8_t *slurp(const char *path, size_t *n)
{
    void *d = NULL;
    *n = 0;
    if (sp_read_whole_file(path, (size_t)1 << 30, &d, n) || !*n) {
        free(d);
        *n = 0;
        return NULL;
    }
    return d;
}

static inline int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static inline int glb_read(glb *g, const char *path)
{
    memset(g, 0, sizeof(*g));
    g->file = slurp(path, &g->size);
    if (!g->file || g->size < 28)
        return -1;
    uint32_t h[5], bh[2];
    memcpy(h, g->file, 20);
    CHECK(h[0] == 0x46546C67u && h[1] == 2 && h[2] == g->size && h[4] == 0x4E4F534Au);
    CHECK(h[3] % 4 == 0 && 20 + (size_t)h[3] + 8 <= g->size);
    if (20 + (size_t)h[3] + 8 > g->size)
        return -1;
    char err[128];
    if (sp_json_parse((const char *)g->file + 20, h[3], &g->json, err, sizeof(err))) {
        fprintf(stderr, "GLB JSON: %s\n", err);
        return -1;
    }
    memcpy(bh, g->file + 20 + h[3], 8);
    CHECK(bh[1] == 0x004E4942u && 28 + (size_t)h[3] + bh[0] == g->size);
    g->bin = g->file + 28 + h[3];
    g->bin_size = bh[0];
    return 0;
}

static inline void glb_free(glb *g)
{
    sp_json_free(g->json);
    free(g->file);
}

/* Primitive i of the first mesh, NULL if none. */
static inline const sp_json *glb_primitive(const glb *g, size_t i)
{
    return sp_json_at(sp_json_get(sp_json_at(sp_json_get(g->json, "meshes"), 0), "primitives"), i);
}

/* Pointer into BIN for accessor k (plain accessors only), checking its size. */
static inline const uint8_t *accessor_data(const glb *g, int k, size_t elem, uint32_t *count)
{
    const sp_json *a = sp_json_at(sp_json_get(g->json, "accessors"), (size_t)k);
    const sp_json *v = sp_json_at(sp_json_get(g->json, "bufferViews"),
                                  (size_t)sp_json_number(sp_json_get(a, "bufferView"), 1e9));
    *count = (uint32_t)sp_json_number(sp_json_get(a, "count"), 0);
    size_t off = (size_t)sp_json_number(sp_json_get(v, "byteOffset"), 0);
    size_t len = (size_t)sp_json_number(sp_json_get(v, "byteLength"), 0);
    if (!v || len != elem * *count || off + len > g->bin_size)
        return NULL;
    return g->bin + off;
}

/* The dense offsets of a sparse accessor k (count * 3 floats, caller frees), NULL if malformed. */
static inline float *sparse_offsets(const glb *g, int k, uint32_t *count)
{
    const sp_json *a = sp_json_at(sp_json_get(g->json, "accessors"), (size_t)k), *sp = sp_json_get(a, "sparse");
    const sp_json *views = sp_json_get(g->json, "bufferViews");
    uint32_t n = (uint32_t)sp_json_number(sp_json_get(sp, "count"), 0);
    *count = (uint32_t)sp_json_number(sp_json_get(a, "count"), 0);
    const sp_json *vi = sp_json_at(views, (size_t)sp_json_number(sp_json_get(sp_json_get(sp, "indices"), "bufferView"), 1e9));
    const sp_json *vv = sp_json_at(views, (size_t)sp_json_number(sp_json_get(sp_json_get(sp, "values"), "bufferView"), 1e9));
    size_t oi = (size_t)sp_json_number(sp_json_get(vi, "byteOffset"), 0);
    size_t ov = (size_t)sp_json_number(sp_json_get(vv, "byteOffset"), 0);
    if (sp_json_get(a, "bufferView") || !n || n > *count || !vi || !vv || oi + 4 * (size_t)n > g->bin_size ||
        ov + 12 * (size_t)n > g->bin_size ||
        sp_json_number(sp_json_get(sp_json_get(sp, "indices"), "componentType"), 0) != 5125)
        return NULL;
    float *d = calloc((size_t)*count * 3, sizeof(float));
    uint32_t prev = 0;
    for (uint32_t e = 0; d && e < n; e++) {
        uint32_t i;
        memcpy(&i, g->bin + oi + 4 * (size_t)e, 4);
        if (i >= *count || (e && i <= prev)) { /* indices strictly increasing, in range */
            free(d);
            return NULL;
        }
        memcpy(d + (size_t)i * 3, g->bin + ov + 12 * (size_t)e, 12);
        prev = i;
    }
    return d;
}

#endif
