/* SPDX-License-Identifier: MIT */
/*
 * A triangle mesh with UV seams: positions and UVs are indexed separately per
 * triangle corner, so a seam vertex has one position and several UVs.
 * Units are metres. UV (0,0) is the bottom-left of a texture image: texel row
 * y = (1 - v) * height, as in glTF-after-flip and OpenGL.
 */
#ifndef SUNPROBE_SP_MESH_H
#define SUNPROBE_SP_MESH_H

#include <stdint.h>

#include "sp_common.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sp_mesh {
    uint32_t n_vertices;
    uint32_t n_uvs;
    uint32_t n_triangles;
    float *positions;       /* 3 * n_vertices */
    float *uvs;             /* 2 * n_uvs */
    uint32_t *tri_vertices; /* 3 * n_triangles, indices into positions, counter-clockwise seen from outside */
    uint32_t *tri_uvs;      /* 3 * n_triangles, indices into uvs */
} sp_mesh;

/* Allocates zeroed arrays for the given sizes; free with sp_mesh_free. */
SP_API int sp_mesh_alloc(sp_mesh *mesh, uint32_t n_vertices, uint32_t n_uvs, uint32_t n_triangles);
/* Frees the arrays and zeroes the struct; safe on a zeroed or half-allocated mesh. */
SP_API void sp_mesh_free(sp_mesh *mesh);
/* 0 if every index is in range and every value finite, else SP_ECORRUPT. */
SP_API int sp_mesh_validate(const sp_mesh *mesh);

#ifdef __cplusplus
}
#endif
#endif
