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

static const char *read_params(const char *dir, sp_gltf_fit *f)
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

double *sp_gltf_fit_eval(const sp_face_model *m, const sp_gltf_fit *f)
{
    sp_face_params pa;
    sp_face_params_init(&pa);
    pa.id = f->id;
    pa.exp = f->exp;
    pa.s = f->s;
    memcpy(pa.rotvec, f->rotvec, sizeof(pa.rotvec));
    memcpy(pa.t, f->t, sizeof(pa.t));
    double *v = malloc((size_t)m->mesh.n_vertices * 3 * sizeof(double) + 1);
    if (!v || sp_face_model_eval(m, &pa, v)) {
        free(v);
        return NULL;
    }
    for (uint32_t i = 0; i < m->mesh.n_vertices; i++) { /* keyframe 0's camera is the world's origin */
        double w[3];
        sp_mat3_apply(f->c2w, v + (size_t)i * 3, w);
        memcpy(v + (size_t)i * 3, w, sizeof(w));
    }
    return v;
}

/* Largest distance between the model's evaluation, placed as keyframe 0 placed it, and the mesh. */
static double mismatch(const sp_face_model *m, const sp_gltf_fit *f, const sp_mesh *mesh, int *err)
{
    double *v = sp_gltf_fit_eval(m, f), worst = 0.0;
    *err = v ? 0 : -ENOMEM;
    for (uint32_t i = 0; v && i < mesh->n_vertices; i++) {
        double d2 = 0.0;
        for (int k = 0; k < 3; k++) {
            double d = v[(size_t)i * 3 + k] - (double)mesh->positions[(size_t)i * 3 + k];
            d2 += d * d;
        }
        worst = fmax(worst, sqrt(d2));
    }
    free(v);
    return worst;
}

/* Per glTF vertex of g: s R_place R_face B_k, the offset mode k of m makes at strength 1, in the exported frame. */
float *sp_gltf_fill_deltas(uint32_t n_targets, const sp_face_model *m, const sp_gltf_fit *f,
                           const sp_gltf_geom *g, const sp_gltf_placement *p)
{
    double Rf[9], R[9];
    sp_quat_to_matrix(sp_quat_from_rotvec((sp_vec3){ f->rotvec[0], f->rotvec[1], f->rotvec[2] }), Rf);
    sp_mat3_mul(f->c2w, Rf, R);
    float *deltas = malloc((size_t)n_targets * g->n_vertices * 3 * sizeof(float) + 1);
    if (!deltas)
        return NULL;
    for (uint32_t k = 0; k < n_targets; k++)
        for (uint32_t i = 0; i < g->n_vertices; i++) {
            const float *b = m->exp_basis + ((size_t)k * m->mesh.n_vertices + g->source[i]) * 3;
            double x[3] = { f->s * (double)b[0], f->s * (double)b[1], f->s * (double)b[2] }, w[3], out[3];
            sp_mat3_apply(R, x, w);
            sp_gltf_place(p, w, out, 0);
            for (int d = 0; d < 3; d++)
                deltas[((size_t)k * g->n_vertices + i) * 3 + d] = (float)out[d];
        }
    return deltas;
}

/* Why the fit's model cannot be used, or "" (and 0 / -ENOMEM in *err). */
static void check_model(sp_gltf_morphs *mo, const sp_face_model *m, const sp_gltf_fit *f, const sp_face_asset *a,
                        int *err)
{
    double off = 0.0;
    if (strcmp(m->source, f->model))
        snprintf(mo->reason, sizeof(mo->reason), "the fit's face model (%s) is not the one on this machine (%s)",
                 f->model, m->source);
    else if (m->n_exp == 0 || m->n_exp > SP_GLTF_MAX_TARGETS || m->n_exp != f->n_exp || m->n_id != f->n_id ||
             m->mesh.n_vertices != a->mesh.n_vertices)
        snprintf(mo->reason, sizeof(mo->reason), "the face model's expressions, identity or vertices do not match "
                 "the face directory (%u/%zu expressions, %u/%zu identity modes, %u/%u vertices)",
                 m->n_exp, f->n_exp, m->n_id, f->n_id, m->mesh.n_vertices, a->mesh.n_vertices);
    else if ((off = mismatch(m, f, &a->mesh, err)) > MAX_MISMATCH && !*err)
        snprintf(mo->reason, sizeof(mo->reason), "the mesh is not the face model's evaluation (a vertex %.3g mm "
                 "off)", off * 1e3);
}

int sp_gltf_morphs_build(sp_gltf_morphs *mo, const char *face_dir, const sp_face_asset *a, const sp_gltf_geom *whole,
                         const sp_gltf_placement *p, int want_parts, int reorder)
{
    memset(mo, 0, sizeof(*mo));
    mo->reorder = reorder;
    mo->n_prims = 1;
    snprintf(mo->prims[0].name, sizeof(mo->prims[0].name), "skin");
    mo->prims[0].geom = whole;
    sp_gltf_fit *f = calloc(1, sizeof(*f));
    sp_face_model m;
    memset(&m, 0, sizeof(m));
    if (!f)
        return -ENOMEM;
    const char *why = read_params(face_dir, f);
    int ret = 0;
    if (!why && load_model(&m, f->model))
        why = "the face model could not be loaded";
    if (why)
        snprintf(mo->reason, sizeof(mo->reason), "%s", why);
    else
        check_model(mo, &m, f, a, &ret);
    if (!ret && !mo->reason[0] && want_parts)
        ret = sp_gltf_parts_build(mo, face_dir, a, &m, f, p);
    else if (!ret && want_parts) {
        snprintf(mo->eyes_reason, sizeof(mo->eyes_reason), "%s", mo->reason);
        snprintf(mo->mouth_reason, sizeof(mo->mouth_reason), "%s", mo->reason);
    }
    if (!ret && !mo->reason[0]) {
        mo->n_targets = m.n_exp;
        for (uint32_t k = 0; k < m.n_exp; k++) {
            snprintf(mo->names[k], sizeof(mo->names[k]), "%s", sp_face_model_exp_name(&m, k));
            mo->fitted[k] = f->exp[k];
        }
        for (uint32_t i = 0; i < mo->n_prims && !ret; i++) { /* the mouth's come with it, from its own modes */
            sp_gltf_prim *pr = &mo->prims[i];
            if (!pr->deltas && !(pr->deltas = sp_gltf_fill_deltas(m.n_exp, &m, f, pr->geom, p)))
                ret = -ENOMEM;
        }
    }
    if (ret)
        sp_gltf_morphs_free(mo);
    sp_face_model_free(&m);
    free(f);
    return ret;
}

void sp_gltf_morphs_drop_targets(sp_gltf_morphs *mo)
{
    for (uint32_t i = 0; i < mo->n_prims; i++) {
        free(mo->prims[i].deltas);
        mo->prims[i].deltas = NULL;
    }
    mo->n_targets = 0;
}

void sp_gltf_morphs_free(sp_gltf_morphs *mo)
{
    if (!mo)
        return;
    sp_gltf_morphs_drop_targets(mo);
    for (uint32_t i = 0; i < mo->n_prims; i++)
        sp_gltf_geom_free(&mo->prims[i].own);
    mo->n_prims = 0;
}
