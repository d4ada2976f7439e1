/* SPDX-License-Identifier: MIT */
/* The face-model container: allocation, freeing, validation and expression names. */
#include "sunprobe/sp_face_model.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "face_internal.h"

/* Sizes past these are treated as corrupt rather than allocated. */
#define MAX_VERTICES (1u << 22)
#define MAX_TRIANGLES (1u << 23)
#define MAX_MODES 1024u
#define MAX_MAP_SIDE 8192u

static int sizes_ok(uint32_t n_vertices, uint32_t n_uvs, uint32_t n_triangles, uint32_t n_id, uint32_t n_exp,
                    uint32_t cw, uint32_t ch)
{
    return n_vertices <= MAX_VERTICES && n_uvs <= MAX_VERTICES * 4u && n_triangles <= MAX_TRIANGLES &&
           n_id <= MAX_MODES && n_exp <= MAX_MODES && cw <= MAX_MAP_SIDE && ch <= MAX_MAP_SIDE;
}

int sp_face_model_alloc(sp_face_model *model, uint32_t n_vertices, uint32_t n_uvs, uint32_t n_triangles,
                        uint32_t n_id, uint32_t n_exp, uint32_t cluster_width, uint32_t cluster_height)
{
    if (!model)
        return -EINVAL;
    memset(model, 0, sizeof(*model));
    if (!sizes_ok(n_vertices, n_uvs, n_triangles, n_id, n_exp, cluster_width, cluster_height))
        return -EINVAL;
    int err = sp_mesh_alloc(&model->mesh, n_vertices, n_uvs, n_triangles);
    if (err)
        return err;
    size_t n3 = (size_t)n_vertices * 3;
    model->id_basis = calloc(n3 * n_id + 1, sizeof(float));
    model->exp_basis = calloc(n3 * n_exp + 1, sizeof(float));
    model->exp_names = calloc((size_t)n_exp * SP_FACE_NAME_LEN + 1, 1);
    model->face_mask = calloc((size_t)n_vertices + 1, 1);
    model->part = calloc((size_t)n_vertices + 1, 1);
    model->cluster_map = calloc((size_t)cluster_width * cluster_height + 1, 1);
    if (!model->id_basis || !model->exp_basis || !model->exp_names || !model->face_mask || !model->part ||
        !model->cluster_map) {
        sp_face_model_free(model);
        return -ENOMEM;
    }
    model->n_id = n_id;
    model->n_exp = n_exp;
    model->cluster_width = cluster_width;
    model->cluster_height = cluster_height;
    return 0;
}

void sp_face_model_free(sp_face_model *model)
{
    if (!model)
        return;
    sp_mesh_free(&model->mesh);
    free(model->id_basis);
    free(model->exp_basis);
    free(model->exp_names);
    free(model->face_mask);
    free(model->part);
    free(model->cluster_map);
    memset(model, 0, sizeof(*model));
}

static int all_finite(const float *x, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(x[i]))
            return 0;
    return 1;
}

static int names_ok(const sp_face_model *m)
{
    if (memchr(m->source, 0, sizeof(m->source)) == NULL)
        return 0;
    for (uint32_t k = 0; k < m->n_exp; k++)
        if (memchr(m->exp_names + (size_t)k * SP_FACE_NAME_LEN, 0, SP_FACE_NAME_LEN) == NULL)
            return 0;
    return 1;
}

static int regions_ok(const sp_face_model *m)
{
    for (uint32_t i = 0; i < m->mesh.n_vertices; i++)
        if (m->face_mask[i] > 1 || m->part[i] >= SP_FACE_N_PARTS || (m->face_mask[i] && m->part[i]))
            return 0;
    size_t n = (size_t)m->cluster_width * m->cluster_height;
    for (size_t i = 0; i < n; i++)
        if (m->cluster_map[i] >= SP_FACE_N_CLUSTERS && m->cluster_map[i] != SP_FACE_CLUSTER_NONE)
            return 0;
    for (int j = 0; j < SP_FACE_N_LANDMARKS; j++)
        if (m->landmarks[j] >= m->mesh.n_vertices)
            return 0;
    return 1;
}

int sp_face_model_validate(const sp_face_model *model)
{
    if (!model || !model->mesh.positions || !model->id_basis || !model->exp_basis || !model->exp_names ||
        !model->face_mask || !model->part || !model->cluster_map)
        return -EINVAL;
    const sp_mesh *mesh = &model->mesh;
    if (!sizes_ok(mesh->n_vertices, mesh->n_uvs, mesh->n_triangles, model->n_id, model->n_exp,
                  model->cluster_width, model->cluster_height) ||
        mesh->n_vertices == 0 || mesh->n_triangles == 0 || model->cluster_width == 0 ||
        model->cluster_height == 0)
        return SP_ECORRUPT;
    int err = sp_mesh_validate(mesh);
    if (err)
        return err;
    size_t n3 = (size_t)mesh->n_vertices * 3;
    if (!all_finite(model->id_basis, n3 * model->n_id) || !all_finite(model->exp_basis, n3 * model->n_exp))
        return SP_ECORRUPT;
    if (!names_ok(model) || !regions_ok(model))
        return SP_ECORRUPT;
    return 0;
}

const char *sp_face_model_exp_name(const sp_face_model *model, uint32_t k)
{
    if (!model || !model->exp_names || k >= model->n_exp)
        return "";
    return model->exp_names + (size_t)k * SP_FACE_NAME_LEN;
}

void face_set_exp_name(sp_face_model *model, uint32_t k, const char *name)
{
    if (!model || !model->exp_names || k >= model->n_exp || !name)
        return;
    char *dst = model->exp_names + (size_t)k * SP_FACE_NAME_LEN;
    size_t n = strnlen(name, SP_FACE_NAME_LEN - 1);
    memcpy(dst, name, n);
    dst[n] = 0;
}
