/* SPDX-License-Identifier: MIT */
/*
 * Eyes and mouth interior as primitives of their own (EXPORT.md, "Eyes and mouth"): the eyeballs the
 * fit's ICT model carries are split off the skin by the model's per-vertex part (sclera and iris by
 * the model's iris vertices), and the mouth interior the fit never uses is read from the ICT data
 * and posed with the fit's identity, keyframe 0's expression and pose, as the skin is.
 */
#include "export/gltf_internal.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/file_util.h"
#include "pipeline/face/face_interior.h"

enum { CLS_SKIN, CLS_SCLERA, CLS_IRIS, CLS_MOUTH, CLS_TEETH };

/* Linear base colours and roughness (EXPORT.md): wet eyes, a dark and rough mouth, off-white teeth. */
static const float sclera_rgb[3] = { 0.65f, 0.62f, 0.58f }, iris_default[3] = { 0.05f, 0.03f, 0.02f };
static const float mouth_rgb[3] = { 0.12f, 0.03f, 0.03f }, teeth_rgb[3] = { 0.60f, 0.56f, 0.48f };
#define EYE_ROUGHNESS 0.25f
#define MOUTH_ROUGHNESS 0.8f
#define TEETH_ROUGHNESS 0.4f
#define MIN_IRIS_TEXELS 4
#define MOUTH_NOTE "default (the fit does not see inside the mouth)"

/* The triangles of m whose first vertex has class want, as a primitive named name (none: nothing added). */
static int add_prim(sp_gltf_morphs *mo, const char *name, const sp_mesh *m, const uint8_t *cls, uint8_t want,
                    const sp_gltf_placement *p, const float rgb[3], float roughness, const char *note)
{
    uint32_t nt = 0;
    for (uint32_t t = 0; t < m->n_triangles; t++)
        nt += cls[m->tri_vertices[(size_t)t * 3]] == want;
    if (!nt || mo->n_prims >= SP_GLTF_MAX_PRIMS)
        return 0;
    sp_mesh sub = *m; /* borrows m's vertex arrays, owns its triangles */
    sub.n_triangles = nt;
    sub.tri_vertices = malloc((size_t)nt * 3 * sizeof(uint32_t));
    sub.tri_uvs = malloc((size_t)nt * 3 * sizeof(uint32_t));
    int ret = sub.tri_vertices && sub.tri_uvs ? 0 : -ENOMEM;
    for (uint32_t t = 0, k = 0; !ret && t < m->n_triangles; t++)
        if (cls[m->tri_vertices[(size_t)t * 3]] == want) {
            memcpy(sub.tri_vertices + (size_t)k * 3, m->tri_vertices + (size_t)t * 3, 3 * sizeof(uint32_t));
            memcpy(sub.tri_uvs + (size_t)k * 3, m->tri_uvs + (size_t)t * 3, 3 * sizeof(uint32_t));
            k++;
        }
    sp_gltf_prim *pr = &mo->prims[mo->n_prims];
    if (!ret && !(ret = sp_gltf_geom_build(&pr->own, &sub, p)) && mo->reorder)
        ret = sp_gltf_geom_reorder(&pr->own);
    if (!ret) {
        snprintf(pr->name, sizeof(pr->name), "%s", name);
        pr->geom = &pr->own;
        memcpy(pr->colour, rgb ? rgb : sclera_rgb, sizeof(pr->colour));
        pr->roughness = roughness;
        snprintf(pr->note, sizeof(pr->note), "%s", note);
        mo->n_prims++;
    }
    free(sub.tri_vertices);
    free(sub.tri_uvs);
    return ret == SP_ECORRUPT ? 0 : ret; /* a degenerate part is left in no primitive, never fails the export */
}

typedef struct texel {
    double luminance;
    size_t index;
} texel;

static int cmp_lum(const void *a, const void *b)
{
    double x = ((const texel *)a)->luminance, y = ((const texel *)b)->luminance;
    return (x > y) - (x < y);
}

/*
 * The iris colour: the darkest quarter of the eye texels (iris triangles' corners and centroids) that a
 * keyframe saw (albedo_observed.u8 = 1). ICT packs sclera and iris into the same texels, so a seen eye's
 * mean is mostly sclera; its darkest part is iris and pupil. Too few seen texels: the default.
 */
static void iris_colour(const char *face_dir, const sp_face_asset *a, const sp_mesh *m, const uint8_t *cls,
                        sp_gltf_prim *pr)
{
    size_t w = (size_t)a->tex_width, h = (size_t)a->tex_height, n = 0, got = 0;
    char path[4096];
    void *obs = NULL;
    texel *texels = NULL;
    memcpy(pr->colour, iris_default, sizeof(pr->colour));
    snprintf(pr->note, sizeof(pr->note), "default (the fit saw fewer than %d eye texels)", MIN_IRIS_TEXELS);
    if (sp_path_join(path, sizeof(path), face_dir, "albedo_observed.u8") ||
        sp_read_whole_file(path, w * h + 1, &obs, &got) || got != w * h ||
        !(texels = malloc(sizeof(texel) * ((size_t)m->n_triangles * 4 + 1)))) {
        free(obs);
        return;
    }
    uint8_t *o = obs;
    for (uint32_t t = 0; t < m->n_triangles; t++) {
        if (cls[m->tri_vertices[(size_t)t * 3]] != CLS_IRIS)
            continue;
        double cu = 0, cv = 0;
        for (int k = 0; k <= 3; k++) { /* three corners, then the centroid */
            const float *uv = m->uvs + (size_t)m->tri_uvs[(size_t)t * 3 + (size_t)(k % 3)] * 2;
            double u = k < 3 ? (double)uv[0] : cu / 3, v = k < 3 ? (double)uv[1] : cv / 3;
            cu += k < 3 ? u : 0, cv += k < 3 ? v : 0;
            size_t x = (size_t)fmin(fmax(u * (double)w, 0), (double)w - 1);
            size_t y = (size_t)fmin(fmax((1 - v) * (double)h, 0), (double)h - 1);
            size_t i = y * w + x;
            if (o[i] == 1) {
                const float *rgb = a->albedo + i * 3;
                o[i] = 3; /* counted once */
                texels[n++] = (texel){ 0.2126 * (double)rgb[0] + 0.7152 * (double)rgb[1] + 0.0722 * (double)rgb[2], i };
            }
        }
    }
    if (n >= MIN_IRIS_TEXELS) {
        qsort(texels, n, sizeof(texel), cmp_lum);
        size_t q = (n + 3) / 4;
        double s[3] = { 0, 0, 0 };
        for (size_t i = 0; i < q; i++)
            for (int c = 0; c < 3; c++)
                s[c] += (double)a->albedo[texels[i].index * 3 + (size_t)c];
        for (int c = 0; c < 3; c++)
            pr->colour[c] = (float)fmin(fmax(s[c] / (double)q, 0.0), 1.0);
        snprintf(pr->note, sizeof(pr->note), "fitted albedo: the darkest quarter (%zu) of %zu eye texels seen", q, n);
    }
    free(texels);
    free(obs);
}

static int add_eyes(sp_gltf_morphs *mo, const char *face_dir, const sp_face_asset *a, const sp_face_model *model,
                    const face_interior *fi, const sp_gltf_placement *p)
{
    uint8_t *cls = malloc((size_t)a->mesh.n_vertices + 1);
    if (!cls)
        return -ENOMEM;
    for (uint32_t v = 0; v < a->mesh.n_vertices; v++)
        cls[v] = model->part[v] != SP_FACE_PART_EYE ? CLS_SKIN : fi->iris[v] ? CLS_IRIS : CLS_SCLERA;
    sp_gltf_morphs skin = { .reorder = mo->reorder };
    int ret = add_prim(&skin, "skin", &a->mesh, cls, CLS_SKIN, p, NULL, 1.0f, "");
    if (!ret && skin.n_prims) { /* the skin without the eyes replaces the whole mesh */
        mo->prims[0].own = skin.prims[0].own;
        mo->prims[0].geom = &mo->prims[0].own;
    }
    if (!ret)
        ret = add_prim(mo, "eye_sclera", &a->mesh, cls, CLS_SCLERA, p, sclera_rgb, EYE_ROUGHNESS,
                       "default: a white sclera");
    if (!ret)
        ret = add_prim(mo, "eye_iris", &a->mesh, cls, CLS_IRIS, p, iris_default, EYE_ROUGHNESS, "");
    if (!ret && !strcmp(mo->prims[mo->n_prims - 1].name, "eye_iris"))
        iris_colour(face_dir, a, &a->mesh, cls, &mo->prims[mo->n_prims - 1]);
    free(cls);
    return ret;
}

/* The mouth interior posed as the skin is: world positions from the fit, then the same placement. */
static int add_mouth(sp_gltf_morphs *mo, const face_interior *fi, const sp_gltf_fit *f, const sp_gltf_placement *p)
{
    const sp_face_model *mm = &fi->mouth;
    double *v = sp_gltf_fit_eval(mm, f);
    sp_mesh world = mm->mesh;
    world.positions = malloc((size_t)mm->mesh.n_vertices * 3 * sizeof(float) + 1);
    uint8_t *cls = malloc((size_t)mm->mesh.n_vertices + 1);
    int ret = v && world.positions && cls ? 0 : -ENOMEM;
    for (uint32_t i = 0; !ret && i < mm->mesh.n_vertices; i++) {
        cls[i] = fi->teeth[i] ? CLS_TEETH : CLS_MOUTH;
        for (int k = 0; k < 3; k++)
            world.positions[(size_t)i * 3 + k] = (float)v[(size_t)i * 3 + k];
    }
    uint32_t first = mo->n_prims;
    if (!ret)
        ret = add_prim(mo, "mouth_interior", &world, cls, CLS_MOUTH, p, mouth_rgb, MOUTH_ROUGHNESS, MOUTH_NOTE);
    if (!ret)
        ret = add_prim(mo, "teeth", &world, cls, CLS_TEETH, p, teeth_rgb, TEETH_ROUGHNESS, MOUTH_NOTE);
    for (uint32_t i = first; !ret && i < mo->n_prims; i++) {
        if (mm->n_exp && !(mo->prims[i].deltas = sp_gltf_fill_deltas(mm->n_exp, mm, f, mo->prims[i].geom, p)))
            ret = -ENOMEM;
    }
    free(v);
    free(world.positions);
    free(cls);
    return ret;
}

int sp_gltf_parts_build(sp_gltf_morphs *mo, const char *face_dir, const sp_face_asset *a, const sp_face_model *model,
                        const sp_gltf_fit *f, const sp_gltf_placement *p)
{
    face_interior fi;
    int ret = face_interior_load(&fi, model);
    if (ret == -ENOMEM)
        return ret;
    if (ret == SP_ENODATA) {
        snprintf(mo->eyes_reason, sizeof(mo->eyes_reason), "the face model (%s) has no eyeballs", model->source);
        snprintf(mo->mouth_reason, sizeof(mo->mouth_reason), "the face model (%s) has no mouth interior",
                 model->source);
        return 0;
    }
    if (ret) {
        snprintf(mo->eyes_reason, sizeof(mo->eyes_reason), "the ICT face model's data could not be read (%s)",
                 sp_strerror(ret));
        snprintf(mo->mouth_reason, sizeof(mo->mouth_reason), "%s", mo->eyes_reason);
        return 0;
    }
    ret = add_eyes(mo, face_dir, a, model, &fi, p);
    if (!ret)
        ret = add_mouth(mo, &fi, f, p);
    face_interior_free(&fi);
    return ret;
}
