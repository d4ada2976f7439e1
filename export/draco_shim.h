/* SPDX-License-Identifier: MIT */
/* C interface to Draco's mesh encoder (draco_shim.cpp, built only with HAVE_DRACO). */
#ifndef SUNPROBE_EXPORT_DRACO_SHIM_H
#define SUNPROBE_EXPORT_DRACO_SHIM_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sp_draco_out {
    uint8_t *data;   /* encoded mesh, malloc'd; free with sp_draco_out_free */
    size_t size;
    uint32_t n_points, n_faces;           /* as a decoder will see them (decoded back to check) */
    int id_position, id_normal, id_uv, id_tangent; /* unique ids for KHR_draco_mesh_compression; -1 = absent */
} sp_draco_out;

/*
 * Encodes a triangle mesh (positions, normals, uvs, optional 4-float tangents per point; 3 indices per face;
 * all borrowed) with the given quantisation bits, then decodes the result to
 * count points and faces. keep_order: sequential encoding without merging points, so the decoded
 * points are the given ones in their order (what morph targets, indexed by vertex, need; larger).
 * Returns 0, -EINVAL, -ENOMEM or SP_ECORRUPT.
 */
int sp_draco_encode_mesh(const float *positions, const float *normals, const float *uvs, const float *tangents,
                         uint32_t n_points,
                         const uint32_t *indices, uint32_t n_faces, int position_bits, int normal_bits,
                         int uv_bits, int keep_order, sp_draco_out *out);
void sp_draco_out_free(sp_draco_out *out);

#ifdef __cplusplus
}
#endif
#endif
