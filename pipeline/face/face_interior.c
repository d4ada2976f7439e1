/* SPDX-License-Identifier: MIT */
/*
 * The ICT mouth interior and irises for export (face_interior.h). The mouth is cropped from the
 * neutral OBJ by the documented vertex ranges, decimated like the head (every kept vertex an
 * original one, so the modes are subsampled exactly) and given the head's identity and expression
 * modes from the same files. The irises are found by position: the head model keeps original
 * eyeball vertices, and the neutral OBJ's iris groups are known ranges.
 */
#include "face_interior.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "face_ict_internal.h"
#include "face_internal.h"
#include "mesh_decimate.h"

/* Inclusive ICT vertex ranges (ICT-FaceKit's documentation; the iris ones are the OBJ's M_Iris* groups). */
static const uint32_t mouth_socket[2] = { 11248, 13293 }, gums_tongue[2] = { 14062, 17038 };
static const uint32_t teeth_range[2] = { 17039, 21450 };
static const uint32_t iris_ranges[2][2] = { { 22221, 23020 }, { 23791, 24590 } };
#define CM_TO_M 0.01

static int in(uint32_t v, const uint32_t r[2])
{
    return v >= r[0] && v <= r[1];
}

/* Mouth polygons: socket, gums, tongue and teeth, and the socket's ring on the lips. */
static int mouth_kept(const obj_data *o, uint32_t f, const void *arg)
{
    (void)arg;
    int inside = 0;
    for (uint32_t c = o->face_start[f]; c < o->face_start[f + 1]; c++) {
        uint32_t v = o->corner_v[c];
        int interior = in(v, mouth_socket) || in(v, gums_tongue) || in(v, teeth_range);
        if ((!interior && v >= mouth_socket[0]) || o->corner_vt[c] == OBJ_NO_UV)
            return 0;
        inside |= interior;
    }
    return inside;
}

static int cmp_pos(const void *a, const void *b)
{
    return memcmp(a, b, 3 * sizeof(float));
}

/* iris[v] = 1 where the head's eyeball vertex v sits exactly on an ICT iris vertex. */
static int find_irises(face_interior *fi, const sp_face_model *head, const obj_data *o)
{
    size_t n = 0, cap = 0;
    for (int r = 0; r < 2; r++)
        cap += iris_ranges[r][1] - iris_ranges[r][0] + 1;
    float *p = malloc(cap * 3 * sizeof(float));
    fi->iris = calloc((size_t)head->mesh.n_vertices + 1, 1);
    if (!p || !fi->iris) {
        free(p);
        return -ENOMEM;
    }
    for (int r = 0; r < 2; r++)
        for (uint32_t v = iris_ranges[r][0]; v <= iris_ranges[r][1] && v < o->n_v; v++, n++)
            for (int k = 0; k < 3; k++) /* as the importer scales them */
                p[n * 3 + (size_t)k] = (float)((double)o->v[(size_t)v * 3 + (size_t)k] * CM_TO_M);
    qsort(p, n, 3 * sizeof(float), cmp_pos);
    uint32_t found = 0;
    for (uint32_t v = 0; v < head->mesh.n_vertices; v++)
        if (head->part[v] == SP_FACE_PART_EYE && bsearch(head->mesh.positions + (size_t)v * 3, p, n,
                                                         3 * sizeof(float), cmp_pos))
            fi->iris[v] = 1, found++;
    free(p);
    return found ? 0 : SP_ENODATA;
}

/* Decimates c in place (origins mapped back to ICT vertices). */
static int decimate_mouth(cropped *c)
{
    sp_mesh out = { 0 };
    uint32_t *origin = NULL;
    int err = mesh_decimate(&c->mesh, NULL, NULL, FACE_INTERIOR_TRIANGLES, &out, &origin);
    if (err)
        return err;
    for (uint32_t i = 0; i < out.n_vertices; i++)
        origin[i] = c->to_old[origin[i]];
    sp_mesh_free(&c->mesh);
    free(c->to_old);
    free(c->from_old);
    c->mesh = out;
    c->to_old = origin;
    c->from_old = NULL;
    return 0;
}

/* The head's modes at the mouth's vertices; the scale check uses the head's radius (jawOpen moves the mouth a lot). */
static int read_mouth_modes(face_interior *fi, const sp_face_model *head, const char *dir, const obj_data *o,
                            const cropped *c)
{
    const char **names = malloc(sizeof(char *) * ((size_t)head->n_exp + 1));
    if (!names)
        return -ENOMEM;
    for (uint32_t k = 0; k < head->n_exp; k++)
        names[k] = sp_face_model_exp_name(head, k);
    int err = ict_read_modes(&fi->mouth, dir, o, c, ict_bounding_radius(&head->mesh), names);
    free(names);
    return err;
}

static int build_mouth(face_interior *fi, const sp_face_model *head, const char *dir, const obj_data *o)
{
    cropped c;
    int err = ict_crop(o, mouth_kept, NULL, &c);
    if (!err && c.mesh.n_triangles > FACE_INTERIOR_TRIANGLES)
        err = decimate_mouth(&c);
    if (!err)
        err = sp_face_model_alloc(&fi->mouth, c.mesh.n_vertices, c.mesh.n_uvs, c.mesh.n_triangles, head->n_id,
                                  head->n_exp, 1, 1);
    if (!err && !(fi->teeth = calloc((size_t)c.mesh.n_vertices + 1, 1)))
        err = -ENOMEM;
    if (!err) {
        sp_mesh *m = &fi->mouth.mesh;
        memcpy(m->positions, c.mesh.positions, sizeof(float) * 3 * c.mesh.n_vertices);
        memcpy(m->uvs, c.mesh.uvs, sizeof(float) * 2 * c.mesh.n_uvs);
        memcpy(m->tri_vertices, c.mesh.tri_vertices, sizeof(uint32_t) * 3 * c.mesh.n_triangles);
        memcpy(m->tri_uvs, c.mesh.tri_uvs, sizeof(uint32_t) * 3 * c.mesh.n_triangles);
        for (uint32_t v = 0; v < c.mesh.n_vertices; v++)
            fi->teeth[v] = (uint8_t)in(c.to_old[v], teeth_range);
        snprintf(fi->mouth.source, sizeof(fi->mouth.source), "ict-facekit mouth interior tri=%u",
                 c.mesh.n_triangles);
        err = read_mouth_modes(fi, head, dir, o, &c);
    }
    ict_crop_free(&c);
    return err;
}

int face_interior_load(face_interior *fi, const sp_face_model *head)
{
    if (!fi || !head)
        return -EINVAL;
    memset(fi, 0, sizeof(*fi));
    uint32_t eyes = 0;
    for (uint32_t v = 0; head->part && v < head->mesh.n_vertices; v++)
        eyes += head->part[v] == SP_FACE_PART_EYE;
    if (strncmp(head->source, "ict-facekit", 11) || !eyes)
        return SP_ENODATA;
    obj_data o;
    const char *dir = sp_face_ict_dir();
    int err = ict_load_neutral(dir, &o);
    if (err)
        return err;
    err = find_irises(fi, head, &o);
    if (!err)
        err = build_mouth(fi, head, dir, &o);
    obj_free(&o);
    if (err)
        face_interior_free(fi);
    return err;
}

void face_interior_free(face_interior *fi)
{
    if (!fi)
        return;
    sp_face_model_free(&fi->mouth);
    free(fi->teeth);
    free(fi->iris);
    memset(fi, 0, sizeof(*fi));
}
