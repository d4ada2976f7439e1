/* SPDX-License-Identifier: MIT */
/*
 * A face directory packed as one input (fuzz_face_dir.c, alloc_fail.c): records of one byte naming
 * the file (its value modulo the file count), a 32-bit little-endian length and the bytes (cut to
 * what is left). A file without a record is absent, except env.f32, which is then a valid one of
 * zeros: its size is fixed and large.
 */
#ifndef SUNPROBE_TESTS_FUZZ_FACE_PACK_H
#define SUNPROBE_TESTS_FUZZ_FACE_PACK_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "sunprobe/sp_sunstage.h"

/* Writes size bytes to path; aborts when the scratch file system fails. */
static void put_file(const char *path, const uint8_t *data, size_t size)
{
    FILE *f = fopen(path, "wb");
    if (!f || (size && fwrite(data, 1, size, f) != size) || fclose(f))
        abort();
}

static const char *const face_files[] = { "manifest.json", "cameras.json", "mesh.bin", "albedo.f32",
                                     "displacement.f32", "clusters.u8", "env.f32" };
#define FACE_FILES (sizeof(face_files) / sizeof(face_files[0]))

static void face_unpack(const uint8_t *d, size_t n, const char *face)
{
    char p[512];
    int seen[FACE_FILES] = { 0 };
    for (size_t i = 0; i < FACE_FILES; i++) {
        snprintf(p, sizeof(p), "%s/%s", face, face_files[i]);
        unlink(p);
    }
    while (n >= 5) {
        size_t k = d[0] % FACE_FILES, len = (size_t)d[1] | (size_t)d[2] << 8 | (size_t)d[3] << 16 | (size_t)d[4] << 24;
        d += 5, n -= 5;
        len = len < n ? len : n;
        snprintf(p, sizeof(p), "%s/%s", face, face_files[k]);
        put_file(p, d, len);
        seen[k] = 1;
        d += len, n -= len;
    }
    if (!seen[FACE_FILES - 1]) {
        static const float env[SP_RENDER_ENV_FLOATS];
        snprintf(p, sizeof(p), "%s/env.f32", face);
        put_file(p, (const uint8_t *)env, sizeof(env));
    }
}

#endif
