/* SPDX-License-Identifier: MIT */
/*
 * ICT Face Model Light importer. The data (MIT-licensed, ICT-FaceKit's
 * FaceXModel folder) is read at run time and never shipped. Steps: parse the
 * neutral OBJ, keep the face + head-and-neck vertex ranges and the eyeballs
 * (each eye's own UV tile packed into a free corner of the head's atlas),
 * split quads along their shorter diagonal, centimetres to metres, decimate
 * keeping the landmark vertices, then read each identity and expression mesh
 * as a difference from the neutral one, with a scale check.
 */
#include "sunprobe/sp_face_model.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/data_path.h"
#include "common/file_util.h"
#include "face_internal.h"
#include "face_ict_internal.h"
#include "mesh_decimate.h"
#include "pipeline/sp_face_config.h"

#define ICT_VERTICES 26719u   /* the topology the ranges below belong to */
#define CM_TO_M 0.01
#define FETCH_HINT "tools/fetch-ict-facekit.sh"

/* Inclusive vertex ranges from the ICT-FaceKit documentation. */
static const uint32_t keep_head[2] = { 0, 11247 };   /* face [0, 9408] + head and neck [9409, 11247] */
static const uint32_t keep_eyes[2] = { 21451, 24590 }; /* eyeballs: the right one, then the left, 1570 each */
#define ICT_LEFT_EYE_FIRST 23021u
/*
 * Where each eyeball's UV tile goes in the packed atlas (u over both tiles, v): the head tile's
 * top-right corner, which only the eye sockets (not kept) use: right eye, then left, side by side.
 */
static const float eye_atlas_u[2] = { 0.901f, 0.951f }, eye_atlas_w = 0.048f;
static const float eye_atlas_v = 0.76f, eye_atlas_h = 0.23f;
static const uint32_t narrow_face_end = 6705, face_end = 9408;

static const uint32_t ict_landmarks[SP_FACE_N_LANDMARKS] = {
    1225, 1888, 1052, 367,  1719, 1722, 2199, 1447, 966,  3661, 4390, 3927, 3924, 2608, 3272, 4088, 3443,
    268,  493,  1914, 2044, 1401, 3615, 4240, 4114, 2734, 2509, 978,  4527, 4942, 4857, 1140, 2075, 1147,
    4269, 3360, 1507, 1542, 1537, 1528, 1518, 1511, 3742, 3751, 3756, 3721, 3725, 3732, 5708, 5695, 2081,
    0,    4275, 6200, 6213, 6346, 6461, 5518, 5957, 5841, 5702, 5711, 5533, 6216, 6207, 6470, 5517, 5966,
};
/* Jawline substitutes for landmarks 0-16 (index 8, the chin, has none). */
static const uint32_t ict_jaw_substitutes[17] = { 1278, 1272, 12, 1834, 243, 781, 2199, 1447, UINT32_MAX,
                                                  3661, 4390, 3022, 2484, 4036, 2253, 3490, 3496 };

static const char *const ict_expressions[] = { "jawOpen",      "mouthSmile_L", "mouthSmile_R", "eyeBlink_L",
                                               "eyeBlink_R",   "browInnerUp_L", "browInnerUp_R", "mouthClose",
                                               "mouthFunnel", "mouthPucker" };
#define N_ICT_EXPRESSIONS (sizeof(ict_expressions) / sizeof(ict_expressions[0]))

void sp_face_ict_default_settings(sp_face_ict_settings *settings)
{
    if (!settings)
        return;
    memset(settings, 0, sizeof(*settings));
    settings->max_identity = 30;
    settings->keep_eyeballs = 1;
    settings->target_triangles = 10000;
    settings->cluster_width = 512;
    settings->cluster_height = 256;
}

void sp_face_ict_locate(sp_data_location *out)
{
    sp_data_locate("SP_ICT_FACEKIT_DIR", "ict-facekit", "generic_neutral_mesh.obj", SP_ICT_FACEKIT_DEFAULT_DIR, out);
}

const char *sp_face_ict_dir(void)
{
    static _Thread_local sp_data_location loc; /* a path per thread: callers keep the pointer */
    sp_face_ict_locate(&loc);
    return loc.path;
}

/* ---- the neutral mesh: crop, triangulate, scale ---- */

void ict_crop_free(cropped *c)
{
    sp_mesh_free(&c->mesh);
    free(c->to_old);
    free(c->from_old);
    memset(c, 0, sizeof(*c));
}

static int kept_vertex(uint32_t v, int keep_eyeballs)
{
    return (v >= keep_head[0] && v <= keep_head[1]) ||
           (keep_eyeballs && v >= keep_eyes[0] && v <= keep_eyes[1]);
}

static int face_kept(const obj_data *o, uint32_t f, const void *arg)
{
    int keep_eyeballs = *(const int *)arg;
    for (uint32_t c = o->face_start[f]; c < o->face_start[f + 1]; c++)
        if (!kept_vertex(o->corner_v[c], keep_eyeballs) || o->corner_vt[c] == OBJ_NO_UV)
            return 0;
    return 1;
}

static double dist2(const float *a, const float *b)
{
    double s = 0;
    for (int k = 0; k < 3; k++)
        s += ((double)a[k] - (double)b[k]) * ((double)a[k] - (double)b[k]);
    return s;
}

/* Emits polygon f as triangles (quads along the shorter diagonal, others as a fan). */
static void triangulate(const obj_data *o, uint32_t f, uint32_t *tv, uint32_t *tuv, uint32_t *nt)
{
    uint32_t s = o->face_start[f], n = o->face_start[f + 1] - s, rot = 0;
    if (n == 4 && dist2(o->v + o->corner_v[s + 1] * 3, o->v + o->corner_v[s + 3] * 3) <
                      dist2(o->v + o->corner_v[s] * 3, o->v + o->corner_v[s + 2] * 3))
        rot = 1;
    for (uint32_t k = 1; k + 1 < n; k++) {
        uint32_t c[3] = { s + rot % n, s + (k + rot) % n, s + (k + 1 + rot) % n };
        for (int j = 0; j < 3; j++) {
            tv[*nt * 3 + (uint32_t)j] = o->corner_v[c[j]];
            tuv[*nt * 3 + (uint32_t)j] = o->corner_vt[c[j]];
        }
        (*nt)++;
    }
}

/* Renumbers vertices and UVs to the ones used, scales to metres and packs UV tiles into [0, 1]. */
static int compact(const obj_data *o, uint32_t *tv, uint32_t *tuv, uint32_t nt, cropped *out)
{
    uint32_t *uv_new = malloc(sizeof(uint32_t) * ((size_t)o->n_vt + 1));
    out->from_old = malloc(sizeof(uint32_t) * ((size_t)o->n_v + 1));
    if (!uv_new || !out->from_old) {
        free(uv_new);
        return -ENOMEM;
    }
    memset(uv_new, 0xff, sizeof(uint32_t) * o->n_vt);
    memset(out->from_old, 0xff, sizeof(uint32_t) * o->n_v);
    uint32_t nv = 0, nuv = 0;
    float umax = 0;
    for (size_t i = 0; i < (size_t)nt * 3; i++) {
        if (out->from_old[tv[i]] == UINT32_MAX)
            out->from_old[tv[i]] = nv++;
        if (uv_new[tuv[i]] == UINT32_MAX)
            uv_new[tuv[i]] = nuv++;
        umax = fmaxf(umax, o->vt[tuv[i] * 2]);
    }
    int err = sp_mesh_alloc(&out->mesh, nv, nuv, nt);
    out->to_old = err ? NULL : malloc(sizeof(uint32_t) * ((size_t)nv + 1));
    if (!err && !out->to_old)
        err = -ENOMEM;
    if (!err) {
        double tiles = umax > 1.0f ? ceil((double)umax - 1e-6) : 1.0; /* ICT: face and head in two tiles */
        for (uint32_t v = 0; v < o->n_v; v++)
            if (out->from_old[v] != UINT32_MAX) {
                out->to_old[out->from_old[v]] = v;
                for (uint32_t k = 0; k < 3; k++)
                    out->mesh.positions[out->from_old[v] * 3 + k] = (float)((double)o->v[v * 3 + k] * CM_TO_M);
            }
        for (uint32_t t = 0; t < o->n_vt; t++)
            if (uv_new[t] != UINT32_MAX) {
                out->mesh.uvs[uv_new[t] * 2] = (float)((double)o->vt[t * 2] / tiles);
                out->mesh.uvs[uv_new[t] * 2 + 1] = o->vt[t * 2 + 1];
            }
        for (size_t i = 0; i < (size_t)nt * 3; i++) {
            out->mesh.tri_vertices[i] = out->from_old[tv[i]];
            out->mesh.tri_uvs[i] = uv_new[tuv[i]];
        }
    }
    free(uv_new);
    return err;
}

int ict_crop(const obj_data *o, int (*keep)(const obj_data *, uint32_t, const void *), const void *arg,
             cropped *out)
{
    memset(out, 0, sizeof(*out));
    uint32_t max_tris = o->n_corners; /* a polygon of n corners gives n - 2 triangles */
    uint32_t *tv = malloc(sizeof(uint32_t) * ((size_t)max_tris * 3 + 1));
    uint32_t *tuv = malloc(sizeof(uint32_t) * ((size_t)max_tris * 3 + 1));
    int err = tv && tuv ? 0 : -ENOMEM;
    uint32_t nt = 0;
    for (uint32_t f = 0; !err && f < o->n_faces; f++)
        if (keep(o, f, arg))
            triangulate(o, f, tv, tuv, &nt);
    if (!err && nt == 0)
        err = SP_ENODATA;
    if (!err)
        err = compact(o, tv, tuv, nt, out);
    free(tv);
    free(tuv);
    if (err)
        ict_crop_free(out);
    return err;
}

/* ---- landmarks and decimation ---- */

static int remap_landmarks(const cropped *c, uint32_t lm[SP_FACE_N_LANDMARKS])
{
    for (int j = 0; j < SP_FACE_N_LANDMARKS; j++) {
        uint32_t v = c->from_old[ict_landmarks[j]];
        if (v == UINT32_MAX && j <= 16 && ict_jaw_substitutes[j] != UINT32_MAX)
            v = c->from_old[ict_jaw_substitutes[j]];
        if (v == UINT32_MAX) {
            sp_log(SP_LOG_ERROR, FACE_LOG, "ICT landmark %d (vertex %u) was cropped away", j, ict_landmarks[j]);
            return SP_ECORRUPT;
        }
        lm[j] = v;
    }
    return 0;
}

/* The narrow face keeps most detail, the rest of the face some, the head and neck least. */
static float importance_of(uint32_t ict_vertex)
{
    /* eyeballs: as the head and neck; their UV seams stop the collapses at about 500 triangles each */
    return ict_vertex <= narrow_face_end ? 8.0f : ict_vertex <= face_end ? 3.0f : 1.0f;
}

static int is_eyeball(uint32_t ict_vertex)
{
    return ict_vertex >= keep_eyes[0] && ict_vertex <= keep_eyes[1];
}

/*
 * Moves the eyeballs' texture coordinates (each eye a whole [0, 1]^2 tile of its own, which would
 * overlap the face) into their corner of the atlas; a UV shared with skin is not expected in ICT.
 */
static int pack_eye_uvs(cropped *c)
{
    uint8_t *done = calloc((size_t)c->mesh.n_uvs + 1, 1);
    if (!done)
        return -ENOMEM;
    for (uint32_t t = 0; t < c->mesh.n_triangles; t++) {
        uint32_t v0 = c->to_old[c->mesh.tri_vertices[t * 3]];
        if (!is_eyeball(v0))
            continue;
        int left = v0 >= ICT_LEFT_EYE_FIRST;
        for (int k = 0; k < 3; k++) {
            uint32_t uv = c->mesh.tri_uvs[t * 3 + (uint32_t)k];
            if (done[uv])
                continue;
            done[uv] = 1;
            float *p = c->mesh.uvs + (size_t)uv * 2;
            /* compact() divided u by the tile count (2); the eye's tile was [0, 1] */
            float u = fminf(fmaxf(p[0] * 2.0f, 0.0f), 1.0f), v = fminf(fmaxf(p[1], 0.0f), 1.0f);
            p[0] = eye_atlas_u[left] + eye_atlas_w * u;
            p[1] = eye_atlas_v + eye_atlas_h * v;
        }
    }
    free(done);
    return 0;
}

static int decimate(cropped *c, uint32_t lm[SP_FACE_N_LANDMARKS], uint32_t target)
{
    uint32_t nv = c->mesh.n_vertices;
    uint8_t *locked = calloc((size_t)nv + 1, 1);
    float *imp = malloc(sizeof(float) * ((size_t)nv + 1));
    uint32_t *origin = NULL, *back = NULL;
    sp_mesh out = { 0 };
    int err = locked && imp ? 0 : -ENOMEM;
    for (uint32_t v = 0; !err && v < nv; v++)
        imp[v] = importance_of(c->to_old[v]);
    for (int j = 0; !err && j < SP_FACE_N_LANDMARKS; j++)
        locked[lm[j]] = 1;
    if (!err)
        err = mesh_decimate(&c->mesh, locked, imp, target, &out, &origin);
    if (!err) {
        back = malloc(sizeof(uint32_t) * ((size_t)nv + 1));
        err = back ? 0 : -ENOMEM;
    }
    if (!err) {
        memset(back, 0xff, sizeof(uint32_t) * nv);
        for (uint32_t i = 0; i < out.n_vertices; i++) {
            back[origin[i]] = i;
            origin[i] = c->to_old[origin[i]]; /* now: new vertex -> ICT vertex */
        }
        for (int j = 0; j < SP_FACE_N_LANDMARKS; j++)
            lm[j] = back[lm[j]]; /* locked, so always kept */
        sp_mesh_free(&c->mesh);
        free(c->to_old);
        c->mesh = out;
        c->to_old = origin;
        origin = NULL;
        memset(&out, 0, sizeof(out));
    }
    sp_mesh_free(&out);
    free(origin);
    free(back);
    free(locked);
    free(imp);
    return err;
}

/* ---- blendshapes ---- */

/* Reads one mesh of the same topology and stores (mesh - neutral) in metres into dst. */
int ict_read_mode(const char *dir, const char *name, const obj_data *neutral, const cropped *c,
                     double head_radius, float *dst)
{
    char path[4096], err_text[160];
    int err = sp_path_join(path, sizeof(path), dir, name);
    obj_data o;
    if (!err)
        err = obj_read_file(path, 1, &o, err_text, sizeof(err_text));
    if (err) {
        if (err == SP_ECORRUPT)
            sp_log(SP_LOG_ERROR, FACE_LOG, "%s: %s", path, err_text);
        return err;
    }
    if (o.n_v != neutral->n_v) {
        sp_log(SP_LOG_ERROR, FACE_LOG, "%s: %u vertices, the neutral mesh has %u", path, o.n_v, neutral->n_v);
        obj_free(&o);
        return SP_ECORRUPT;
    }
    double ss = 0;
    for (uint32_t i = 0; i < c->mesh.n_vertices; i++)
        for (int k = 0; k < 3; k++) {
            size_t s = (size_t)c->to_old[i] * 3 + (size_t)k;
            double dv = ((double)o.v[s] - (double)neutral->v[s]) * CM_TO_M;
            dst[(size_t)i * 3 + (size_t)k] = (float)dv;
            ss += dv * dv;
        }
    obj_free(&o);
    double rms = sqrt(ss / (double)(c->mesh.n_vertices ? c->mesh.n_vertices : 1));
    if (!(rms < 0.25 * head_radius)) { /* a mesh in other units or another frame, not a blendshape */
        sp_log(SP_LOG_ERROR, FACE_LOG, "%s moves the head by %.3g m RMS: not a blendshape at the neutral's scale",
               path, rms);
        return SP_ECORRUPT;
    }
    return 0;
}

static int file_exists(const char *dir, const char *name)
{
    char path[4096];
    return sp_path_join(path, sizeof(path), dir, name) == 0 && sp_is_regular_file(path);
}

static uint32_t count_identity_files(const char *dir, uint32_t max)
{
    uint32_t k = 0;
    for (; k < max; k++) {
        char name[32];
        snprintf(name, sizeof(name), "identity%03u.obj", k);
        if (!file_exists(dir, name))
            break;
    }
    return k;
}

double ict_bounding_radius(const sp_mesh *m)
{
    double lo[3] = { INFINITY, INFINITY, INFINITY }, hi[3] = { -INFINITY, -INFINITY, -INFINITY }, s = 0;
    for (uint32_t i = 0; i < m->n_vertices; i++)
        for (int k = 0; k < 3; k++) {
            lo[k] = fmin(lo[k], (double)m->positions[i * 3 + (uint32_t)k]);
            hi[k] = fmax(hi[k], (double)m->positions[i * 3 + (uint32_t)k]);
        }
    for (int k = 0; k < 3; k++)
        s += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    return m->n_vertices ? 0.5 * sqrt(s) : 0.0;
}

int ict_read_modes(sp_face_model *m, const char *dir, const obj_data *neutral, const cropped *c, double radius,
                   const char *const *exp_files)
{
    size_t n3 = (size_t)c->mesh.n_vertices * 3;
    int err = 0;
    for (uint32_t k = 0; !err && k < m->n_id; k++) {
        char name[32];
        snprintf(name, sizeof(name), "identity%03u.obj", k);
        err = ict_read_mode(dir, name, neutral, c, radius, m->id_basis + k * n3);
    }
    for (uint32_t k = 0; !err && k < m->n_exp; k++) {
        char name[SP_FACE_NAME_LEN + 8];
        snprintf(name, sizeof(name), "%s.obj", exp_files[k]);
        err = ict_read_mode(dir, name, neutral, c, radius, m->exp_basis + k * n3);
        face_set_exp_name(m, k, exp_files[k]);
    }
    return err;
}

/* ---- import ---- */

int ict_load_neutral(const char *dir, obj_data *o)
{
    char path[4096], err_text[160];
    int err = sp_path_join(path, sizeof(path), dir, "generic_neutral_mesh.obj");
    if (!err)
        err = obj_read_file(path, 0, o, err_text, sizeof(err_text));
    if (err == -ENOENT || err == -ENOTDIR)
        sp_log(SP_LOG_ERROR, FACE_LOG,
               "ICT Face Model not found: no %s. Download it with `" FETCH_HINT " DIR` and point "
               "SP_ICT_FACEKIT_DIR (or the settings' dir) at DIR, or put it in ~/.local/share/sunprobe/ict-facekit "
               "(`sunprobe --version --verbose` lists where it looks).", path);
    else if (err == SP_ECORRUPT)
        sp_log(SP_LOG_ERROR, FACE_LOG, "%s: %s", path, err_text);
    else if (err)
        sp_log(SP_LOG_ERROR, FACE_LOG, "%s: %s", path, sp_strerror(err));
    if (!err && o->n_v != ICT_VERTICES) {
        sp_log(SP_LOG_ERROR, FACE_LOG, "%s: %u vertices, expected the ICT topology's %u", path, o->n_v,
               ICT_VERTICES);
        obj_free(o);
        err = SP_EUNSUPPORTED;
    }
    return err;
}

static int build_model(sp_face_model *m, const sp_face_ict_settings *s, const char *dir, const obj_data *neutral,
                       const cropped *c, const uint32_t lm[SP_FACE_N_LANDMARKS])
{
    const char *exp_files[N_ICT_EXPRESSIONS];
    uint32_t n_exp = 0;
    for (size_t k = 0; k < N_ICT_EXPRESSIONS; k++) {
        char name[SP_FACE_NAME_LEN + 8];
        snprintf(name, sizeof(name), "%s.obj", ict_expressions[k]);
        if (file_exists(dir, name))
            exp_files[n_exp++] = ict_expressions[k];
        else
            sp_log(SP_LOG_WARN, FACE_LOG, "ICT expression %s missing in %s: left out", name, dir);
    }
    uint32_t n_id = count_identity_files(dir, s->max_identity);
    int err = sp_face_model_alloc(m, c->mesh.n_vertices, c->mesh.n_uvs, c->mesh.n_triangles, n_id, n_exp,
                                  s->cluster_width, s->cluster_height);
    if (err)
        return err;
    memcpy(m->mesh.positions, c->mesh.positions, sizeof(float) * 3 * c->mesh.n_vertices);
    memcpy(m->mesh.uvs, c->mesh.uvs, sizeof(float) * 2 * c->mesh.n_uvs);
    memcpy(m->mesh.tri_vertices, c->mesh.tri_vertices, sizeof(uint32_t) * 3 * c->mesh.n_triangles);
    memcpy(m->mesh.tri_uvs, c->mesh.tri_uvs, sizeof(uint32_t) * 3 * c->mesh.n_triangles);
    memcpy(m->landmarks, lm, sizeof(m->landmarks));
    for (uint32_t v = 0; v < c->mesh.n_vertices; v++)
        m->part[v] = is_eyeball(c->to_old[v]) ? SP_FACE_PART_EYE : SP_FACE_PART_SKIN;
    snprintf(m->source, sizeof(m->source), "ict-facekit v1 tri=%u id=%u exp=%u eyes=%d", c->mesh.n_triangles,
             n_id, n_exp, s->keep_eyeballs ? 1 : 0);
    err = ict_read_modes(m, dir, neutral, c, ict_bounding_radius(&c->mesh), exp_files);
    if (!err)
        err = face_regions_compute(m);
    if (!err)
        err = sp_face_model_validate(m);
    return err;
}

int sp_face_model_import_ict(sp_face_model *model, const sp_face_ict_settings *settings)
{
    sp_face_ict_settings s;
    if (!model)
        return -EINVAL;
    memset(model, 0, sizeof(*model));
    if (settings)
        s = *settings;
    else
        sp_face_ict_default_settings(&s);
    if (s.cluster_width == 0 || s.cluster_height == 0)
        return -EINVAL;
    const char *dir = s.dir ? s.dir : sp_face_ict_dir();
    obj_data neutral;
    int err = ict_load_neutral(dir, &neutral);
    if (err)
        return err;
    cropped c;
    uint32_t lm[SP_FACE_N_LANDMARKS];
    err = ict_crop(&neutral, face_kept, &s.keep_eyeballs, &c);
    if (!err && s.keep_eyeballs)
        err = pack_eye_uvs(&c);
    if (!err)
        err = remap_landmarks(&c, lm);
    if (!err && s.target_triangles && s.target_triangles < c.mesh.n_triangles)
        err = decimate(&c, lm, s.target_triangles);
    if (!err)
        err = build_model(model, &s, dir, &neutral, &c, lm);
    if (err)
        sp_face_model_free(model);
    else {
        uint32_t eye_tris = 0;
        for (uint32_t t = 0; t < model->mesh.n_triangles; t++)
            eye_tris += model->part[model->mesh.tri_vertices[t * 3]] == SP_FACE_PART_EYE;
        sp_log(SP_LOG_INFO, FACE_LOG,
               "imported ICT face model from %s: %u vertices, %u triangles (%u of them eyeballs), %u+%u modes", dir,
               model->mesh.n_vertices, model->mesh.n_triangles, eye_tris, model->n_id, model->n_exp);
    }
    ict_crop_free(&c);
    obj_free(&neutral);
    return err;
}
