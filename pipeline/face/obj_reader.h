/* SPDX-License-Identifier: MIT */
/* A small Wavefront OBJ reader (v, vt, f only) that rejects malformed input with a message instead of crashing. */
#ifndef SUNPROBE_PIPELINE_FACE_OBJ_READER_H
#define SUNPROBE_PIPELINE_FACE_OBJ_READER_H

#include <stddef.h>
#include <stdint.h>

#define OBJ_NO_UV UINT32_MAX

/* Polygons keep their corner count; indices are 0-based. Arrays owned by the struct. */
typedef struct obj_data {
    uint32_t n_v, n_vt, n_faces, n_corners;
    float *v;             /* 3 * n_v, as written in the file */
    float *vt;            /* 2 * n_vt */
    uint32_t *face_start; /* n_faces + 1 offsets into the corner arrays */
    uint32_t *corner_v;   /* n_corners */
    uint32_t *corner_vt;  /* n_corners, OBJ_NO_UV where a corner has no texture coordinate */
} obj_data;

/*
 * Parses len bytes of OBJ text (borrowed). positions_only skips vt and f
 * records (fast path for blendshape files). Returns 0, -ENOMEM, or
 * SP_ECORRUPT with "line N: why" in err. *out is zeroed on error.
 */
int obj_parse(const char *text, size_t len, int positions_only, obj_data *out, char *err, size_t err_size);
/* Reads and parses a file; -errno when it cannot be read. */
int obj_read_file(const char *path, int positions_only, obj_data *out, char *err, size_t err_size);
void obj_free(obj_data *obj);

#endif
