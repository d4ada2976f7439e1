/* SPDX-License-Identifier: MIT */
#include "sunprobe/sp_mesh.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

int sp_mesh_alloc(sp_mesh *mesh, uint32_t n_vertices, uint32_t n_uvs, uint32_t n_triangles)
{
    if (!mesh)
        return -EINVAL;
    memset(mesh, 0, sizeof(*mesh));
    mesh->positions = calloc((size_t)n_vertices * 3 + 1, sizeof(float));
    mesh->uvs = calloc((size_t)n_uvs * 2 + 1, sizeof(float));
    mesh->tri_vertices = calloc((size_t)n_triangles * 3 + 1, sizeof(uint32_t));
    mesh->tri_uvs = calloc((size_t)n_triangles * 3 + 1, sizeof(uint32_t));
    if (!mesh->positions || !mesh->uvs || !mesh->tri_vertices || !mesh->tri_uvs) {
        sp_mesh_free(mesh);
        return -ENOMEM;
    }
    mesh->n_vertices = n_vertices;
    mesh->n_uvs = n_uvs;
    mesh->n_triangles = n_triangles;
    return 0;
}

void sp_mesh_free(sp_mesh *mesh)
{
    if (!mesh)
        return;
    free(mesh->positions);
    free(mesh->uvs);
    free(mesh->tri_vertices);
    free(mesh->tri_uvs);
    memset(mesh, 0, sizeof(*mesh));
}

int sp_mesh_validate(const sp_mesh *mesh)
{
    if (!mesh || (mesh->n_triangles && (!mesh->tri_vertices || !mesh->tri_uvs)))
        return -EINVAL;
    for (size_t i = 0; i < (size_t)mesh->n_vertices * 3; i++)
        if (!isfinite(mesh->positions[i]))
            return SP_ECORRUPT;
    for (size_t i = 0; i < (size_t)mesh->n_uvs * 2; i++)
        if (!isfinite(mesh->uvs[i]))
            return SP_ECORRUPT;
    for (size_t i = 0; i < (size_t)mesh->n_triangles * 3; i++)
        if (mesh->tri_vertices[i] >= mesh->n_vertices || mesh->tri_uvs[i] >= mesh->n_uvs)
            return SP_ECORRUPT;
    return 0;
}
