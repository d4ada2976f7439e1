/* SPDX-License-Identifier: MIT */
/*
 * The fit's face model expressions as glTF morph targets (EXPORT.md, "Expressions"). The face directory
 * keeps the model's name (manifest "model"), identity, scale and keyframe 0's face pose and expression
 * (cameras.json); the model itself is loaded here. The mesh must be that model's evaluation (checked
 * vertex by vertex), so a directory from another model, or an older one without these fields, gets no
 * targets and a reason instead.
 */
#include "export/gltf_internal.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/file_util.h"
#include "common/json.h"
#include "common/rigid.h"
#include "sunprobe/sp_face_model.h"
#include "sunprobe/sp_math.h"

/* Farthest a mesh vertex may lie from the model's evaluation (metres): float32 rounding of a head. */
#define MAX_MISMATCH 1e-5

static sp_json *read_json(const char *dir, const char *name)
{
    char path[4096], err[128];
    void *buf = NULL;
    size_t n = 0;
    sp_json *root = NULL;
    if (snprintf(path, sizeof(path), "%s/%s", dir, name) >= (int)sizeof(path) ||
        sp_read_whole_file(path, (size_t)1 << 24, &buf, &n))
        return NULL;
    if (sp_json_parse(buf, n, &root, err, sizeof(err)))
        root = NULL;
    free(buf);
    return root;
}

/* The fit's parameters: what sp_face_model_eval needs, from the manifest and keyframe 0. */
typedef struct fit_params {
    char model[128];
    double id[256], exp[SP_GLTF_MAX_TARGETS], rotvec[3], t[3], s, c2w[9];
    size_t n_id, n_exp;
} fit_params;

static const char *read_params(const char *dir, fit_params *f)
{
    sp_json *man = read_json(dir, "manifest.json"), *cams = read_json(dir, "cameras.json");
    const sp_json *k0 = sp_json_at(sp_json_get(cams, "frames"), 0);
    const sp_json *ids = sp_json_get(man, "identity"), *exps = sp_json_get(k0, "expression");
    double q[4];
    const char *why = NULL;
    snprintf(f->model, sizeof(f->model), "%s", sp_json_string(sp_json_get(man, "model"), ""));
    f->s = sp_json_number(sp_json_get(man, "scale"), 0.0);
    f->n_id = sp_json_numbers(ids, f->id, 256);
    f->n_exp = sp_json_numbers(exps, f->exp, SP_GLTF_MAX_TARGETS);
    if (!man || !cams || !f->model[0] || !ids || !exps || !(f->s > 0.0) ||
        sp_json_numbers(sp_json_get(k0, "face_rotvec"), f->rotvec, 3) != 3 ||
        sp_json_numbers(sp_json_get(k0, "face_t"), f->t, 3) != 3 ||
        sp_json_numbers(sp_json_get(k0, "camera_to_world_wxyz"), q, 4) != 4)
        why = "the face directory has no model name, identity, scale or keyframe 0 pose and expression "
              "(an older fit)";
    else
        sp_quat_to_matrix(sp_quat_normalize((sp_quat){ q[0], q[1], q[2], q[3] }), f->c2w);
    sp_json_free(man);
    sp_json_free(cams);
    return why;
}

static int load_model(sp_face_model *m, const char *name)
{
    if (!strncmp(name, "generic-head", 12))
        return sp_face_model_generic(m);
    return sp_face_model_load_default(m);
}

/* Largest distance between the model's evaluation, placed as keyframe 0 placed it, and the mesh. */
static double mismatch(const sp_face_model *m, const fit_params *f, const sp_mesh *mesh, int *err)
{
    sp_face_params pa;
    sp_face_params_init(&pa);
    pa.id = f->id;
    pa.exp = f->exp;
    pa.s = f->s;
    memcpy(pa.rotvec, f->rotvec, sizeof(pa.rotvec));
    memcpy(pa.t, f->t, sizeof(pa.t));
    double *v = malloc((size_t)m->mesh.n_vertices * 3 * sizeof(double)), worst = 0.0;
    *err = v ? sp_face_model_eval(m, &pa, v) : -ENOMEM;
    for (uint32_t i = 0; !*err && i < mesh->n_vertices; i++) {
        double w[3], d2 = 0.0;
        sp_mat3_apply(f->c2w, v + (size_t)i * 3, w); /* keyframe 0's camera is the world's origin */
        for (int k = 0; k < 3; k++)
            d2 += (w[k] - (double)mesh->positions[(size_t)i * 3 + k]) * (w[k] - (double)mesh->positions[(size_t)i * 3 + k]);
        worst = fmax(worst, sqrt(d2));
    }
    free(v);
    return worst;
}

/* Per glTF vertex: s R_place R_face B_k, the offset mode k makes at strength 1, in the exported frame. */
static int fill_deltas(sp_gltf_morphs *mo, const sp_face_model *m, const fit_params *f, const sp_gltf_geom *g,
                       const sp_gltf_placement *p)
{
    double Rf[9], R[9];
    sp_quat_to_matrix(sp_quat_from_rotvec((sp_vec3){ f->rotvec[0], f->rotvec[1], f->rotvec[2] }), Rf);
    sp_mat3_mul(f->c2w, Rf, R);
    mo->deltas = malloc((size_t)mo->n_targets * g->n_vertices * 3 * sizeof(float));
    if (!mo->deltas)
        return -ENOMEM;
    for (uint32_t k = 0; k < mo->n_targets; k++)
        for (uint32_t i = 0; i < g->n_vertices; i++) {
            const float *b = m->exp_basis + ((size_t)k * m->mesh.n_vertices + g->source[i]) * 3;
            double x[3] = { f->s * (double)b[0], f->s * (double)b[1], f->s * (double)b[2] }, w[3], out[3];
            sp_mat3_apply(R, x, w);
            sp_gltf_place(p, w, out, 0);
            for (int d = 0; d < 3; d++)
                mo->deltas[((size_t)k * g->n_vertices + i) * 3 + d] = (float)out[d];
        }
    return 0;
}

int sp_gltf_morphs_build(sp_gltf_morphs *mo, const char *face_dir, const sp_face_asset *a, const sp_gltf_geom *g,
                         const sp_gltf_placement *p)
{
    memset(mo, 0, sizeof(*mo));
    fit_params *f = calloc(1, sizeof(*f));
    sp_face_model m;
    memset(&m, 0, sizeof(m));
    if (!f)
        return -ENOMEM;
    const char *why = read_params(face_dir, f);
    int ret = 0;
    if (!why && (ret = load_model(&m, f->model)))
        why = "the face model could not be loaded";
    double off = 0.0;
    if (why)
        snprintf(mo->reason, sizeof(mo->reason), "%s", why);
    else if (strcmp(m.source, f->model))
        snprintf(mo->reason, sizeof(mo->reason), "the fit's face model (%s) is not the one on this machine (%s)",
                 f->model, m.source);
    else if (m.n_exp == 0 || m.n_exp > SP_GLTF_MAX_TARGETS || m.n_exp != f->n_exp || m.n_id != f->n_id ||
             m.mesh.n_vertices != a->mesh.n_vertices)
        snprintf(mo->reason, sizeof(mo->reason), "the face model's expressions, identity or vertices do not match "
                 "the face directory (%u/%zu expressions, %u/%zu identity modes, %u/%u vertices)",
                 m.n_exp, f->n_exp, m.n_id, f->n_id, m.mesh.n_vertices, a->mesh.n_vertices);
    else if ((off = mismatch(&m, f, &a->mesh, &ret)) > MAX_MISMATCH || ret)
        snprintf(mo->reason, sizeof(mo->reason), "the mesh is not the face model's evaluation (a vertex %.3g mm "
                 "off)", off * 1e3);
    else {
        mo->n_targets = m.n_exp;
        for (uint32_t k = 0; k < m.n_exp; k++) {
            snprintf(mo->names[k], sizeof(mo->names[k]), "%s", sp_face_model_exp_name(&m, k));
            mo->fitted[k] = f->exp[k];
        }
        ret = fill_deltas(mo, &m, f, g, p);
    }
    if (ret != -ENOMEM)
        ret = 0; /* a model that cannot be read costs the targets, not the export */
    if (ret)
        sp_gltf_morphs_free(mo);
    sp_face_model_free(&m);
    free(f);
    return ret;
}

void sp_gltf_morphs_free(sp_gltf_morphs *mo)
{
    if (!mo)
        return;
    free(mo->deltas);
    mo->deltas = NULL;
    mo->n_targets = 0;
}
