/* SPDX-License-Identifier: MIT */
/*
 * Mesh decimation by half-edge collapses ordered by quadric error: every kept
 * vertex is an original vertex (so blendshape bases are subsampled exactly),
 * locked vertices survive, UV seams and borders are respected, and collapses
 * that fold a triangle in 3-D or in UV space are refused.
 */
#ifndef SUNPROBE_PIPELINE_FACE_MESH_DECIMATE_H
#define SUNPROBE_PIPELINE_FACE_MESH_DECIMATE_H

#include <stdint.h>

#include "sunprobe/sp_mesh.h"

/*
 * in: borrowed. locked: n_vertices flags (NULL = none). importance:
 * n_vertices cost multipliers >= 0 (NULL = all 1; larger keeps more detail).
 * Stops at <= target_triangles or when no valid collapse is left.
 * out: a new mesh (caller frees with sp_mesh_free). origin: *origin gets a
 * malloc'd out->n_vertices array of original vertex indices (caller frees).
 */
int mesh_decimate(const sp_mesh *in, const uint8_t *locked, const float *importance, uint32_t target_triangles,
                  sp_mesh *out, uint32_t **origin);

#endif
