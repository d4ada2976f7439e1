/* SPDX-License-Identifier: MIT */
/*
 * Eyes and mouth interior as primitives of their own (export/EXPORT.md, "Eyes and mouth"), on
 * test_export's ICT fixture; skipped (77) without the ICT data. Checked against the ICT OBJ files read
 * here: every vertex of the skin, eye_sclera, eye_iris, mouth_interior and teeth primitives is an
 * original vertex of its documented range, placed as the fixture places the head, and the teeth's
 * jawOpen target is that file's offset; materials are named after their primitives; the iris colour
 * comes from the albedo the fit saw, else the default; Draco keeps the primitives; the generic head and
 * an older fit export one primitive and list eyes and mouth_interior in left_out, never failing.
 *
 *   test_export_parts SUNPROBE TEST_EXPORT
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "common/rigid.h"
#include "glb_read.h"
#include "sp_config.h"
#include "sunprobe/sp_face_model.h"
#include "sunprobe/sp_math.h"

/* Positions (centimetres) of an OBJ's `v` records; NULL when unreadable. */
static float *obj_positions(const char *dir, const char *name, uint32_t *n)
{
    char path[4096], line[256];
    snprintf(path, sizeof(path), "%s/%s", dir, name);
    FILE *f = fopen(path, "r");
    float *v = NULL;
    size_t cap = 0;
    *n = 0;
    while (f && fgets(line, sizeof(line), f)) {
        float x, y, z;
        if (line[0] != 'v' || line[1] != ' ' || sscanf(line + 2, "%f %f %f", &x, &y, &z) != 3)
            continue;
        if (*n == cap) {
            float *g = realloc(v, (cap = cap ? cap * 2 : 32768) * 3 * sizeof(float));
            if (!g)
                break;
            v = g;
        }
        v[*n * 3] = x, v[*n * 3 + 1] = y, v[*n * 3 + 2] = z;
        (*n)++;
    }
    if (f)
        fclose(f);
    return v;
}

/* The fixture's model -> scene map: scene = A (x + t_f) + T, x in metres (test_export.c, write_manifest). */
typedef struct placing {
    double A[9], t[3], T[3];
} placing;

static int read_placing(const glb *g, placing *p)
{
    const sp_json *fs = sp_json_get(sp_json_get(sp_json_get(sp_json_get(g->json, "asset"), "extras"), "sunprobe"),
                                    "fit_to_scene");
    double R[9], C[9];
    sp_quat_to_matrix((sp_quat){ 0.70710678118654752, 0.70710678118654752, 0, 0 }, C);
    if (sp_json_numbers(sp_json_get(fs, "rotation"), R, 9) != 9 ||
        sp_json_numbers(sp_json_get(fs, "translation"), p->T, 3) != 3)
        return -1;
    sp_mat3_mul(R, C, p->A);
    p->t[0] = p->t[1] = 0.0, p->t[2] = -0.5;
    return 0;
}

/* The ICT vertex in [lo, hi] at scene position q (within 1 um), or -1. */
static long find_vertex(const float *v, uint32_t lo, uint32_t hi, const placing *pl, const float *q)
{
    for (uint32_t i = lo; i <= hi; i++) {
        double x[3], s[3], d = 0.0;
        for (int k = 0; k < 3; k++)
            x[k] = (double)v[i * 3 + k] * 0.01 + pl->t[k];
        sp_mat3_apply(pl->A, x, s);
        for (int k = 0; k < 3; k++)
            d = fmax(d, fabs(s[k] + pl->T[k] - (double)q[k]));
        if (d < 1e-6)
            return (long)i;
    }
    return -1;
}

typedef struct ict_files {
    float *neutral, *jaw;
    uint32_t n;
} ict_files;

/* Primitive i's vertices are all original ICT vertices in [lo, hi]; with jaw_target >= 0 its offsets too. */
static void check_prim(const glb *g, int i, const ict_files *f, uint32_t lo, uint32_t hi, int jaw_target,
                       uint32_t *moved)
{
    const sp_json *prim = glb_primitive(g, (size_t)i);
    placing pl;
    uint32_t nv, nt = 0;
    const float *pos = (const float *)accessor_data(g, (int)sp_json_number(sp_json_get(sp_json_get(prim, "attributes"),
                                                                                          "POSITION"), -1), 12, &nv);
    CHECK(pos && read_placing(g, &pl) == 0);
    if (!pos || read_placing(g, &pl))
        return;
    float *d = NULL;
    if (jaw_target >= 0) {
        const sp_json *target = sp_json_at(sp_json_get(prim, "targets"), (size_t)jaw_target);
        int k = (int)sp_json_number(sp_json_get(target, "POSITION"), -1);
        d = sparse_offsets(g, k, &nt);
        CHECK_MSG(d && nt == nv, "primitive %d: jawOpen target unreadable", i);
    }
    uint32_t bad = 0, bad_offset = 0;
    for (uint32_t j = 0; j < nv; j++) {
        long o = find_vertex(f->neutral, lo, hi, &pl, pos + (size_t)j * 3);
        bad += o < 0;
        if (o < 0 || !d)
            continue;
        double x[3], s[3], e = 0.0, len = 0.0;
        for (int k = 0; k < 3; k++)
            x[k] = ((double)f->jaw[o * 3 + k] - (double)f->neutral[o * 3 + k]) * 0.01;
        sp_mat3_apply(pl.A, x, s);
        for (int k = 0; k < 3; k++) {
            e = fmax(e, fabs(s[k] - (double)d[j * 3 + k]));
            len += s[k] * s[k];
        }
        bad_offset += e > 1e-6;
        *moved += sqrt(len) > 1e-3;
    }
    CHECK_MSG(nv > 0 && bad == 0, "primitive %d: %u of %u vertices are no ICT vertex in [%u, %u]", i, bad, nv, lo, hi);
    CHECK_MSG(bad_offset == 0, "primitive %d: %u jawOpen offsets differ from the OBJ's", i, bad_offset);
    free(d);
}

static const char *prim_material(const glb *g, int i)
{
    const sp_json *prim = glb_primitive(g, (size_t)i);
    size_t k = (size_t)sp_json_number(sp_json_get(prim, "material"), 1e9);
    const sp_json *mat = sp_json_at(sp_json_get(g->json, "materials"), k);
    return sp_json_string(sp_json_get(mat, "name"), "");
}

static size_t n_prims(const glb *g)
{
    const sp_json *p = sp_json_get(sp_json_at(sp_json_get(g->json, "meshes"), 0), "primitives");
    return p ? p->count : 0;
}

/* The reason left_out gives for part, "" if none. */
static const char *left_reason(const glb *g, const char *part)
{
    const sp_json *s = sp_json_get(sp_json_get(sp_json_get(g->json, "asset"), "extras"), "sunprobe");
    const sp_json *l = sp_json_get(s, "left_out");
    for (size_t i = 0; l && i < l->count; i++)
        if (!strcmp(sp_json_string(sp_json_get(sp_json_at(l, i), "part"), ""), part))
            return sp_json_string(sp_json_get(sp_json_at(l, i), "reason"), "");
    return "";
}

static int export_to(const char *sunprobe, const char *face, const char *out, const char *opts, glb *g)
{
    char cmd[8192];
    snprintf(cmd, sizeof(cmd), "'%s' export '%s' -o '%s' %s", sunprobe, face, out, opts);
    int rc = system(cmd);
    CHECK_MSG(rc == 0, "%s", cmd);
    return rc == 0 && glb_read(g, out) == 0 ? 0 : -1;
}

/* A generic head and an older fit: one primitive, eyes and mouth_interior in left_out. */
static void check_without(const char *sunprobe, const char *fixture, const char *tmp, const char *ict)
{
    char face[256], out[256], cmd[8192];
    glb g;
    snprintf(face, sizeof(face), "%s/generic", tmp);
    snprintf(out, sizeof(out), "%s/generic.glb", tmp);
    snprintf(cmd, sizeof(cmd), "'%s' '%s' fixture '%s'", fixture, sunprobe, face);
    CHECK(system(cmd) == 0);
    if (export_to(sunprobe, face, out, "--no-draco", &g) == 0) {
        CHECK(n_prims(&g) == 1 && strstr(left_reason(&g, "eyes"), "has no eyeballs") &&
              strstr(left_reason(&g, "mouth_interior"), "has no mouth interior"));
        glb_free(&g);
    }
    snprintf(cmd, sizeof(cmd), "sed -i 's/\"identity\"/\"identity_was\"/' '%s/manifest.json'", ict);
    CHECK(system(cmd) == 0);
    snprintf(out, sizeof(out), "%s/old.glb", tmp);
    if (export_to(sunprobe, ict, out, "--no-draco", &g) == 0) {
        CHECK(n_prims(&g) == 1 && strstr(left_reason(&g, "eyes"), "(an older fit)") &&
              strstr(left_reason(&g, "mouth_interior"), "(an older fit)"));
        glb_free(&g);
    }
}

/* Material 2's (the iris's) base colour into c (4) and its colour note. */
static const char *iris_of(const glb *g, double c[4])
{
    const sp_json *mat = sp_json_at(sp_json_get(g->json, "materials"), 2);
    CHECK(sp_json_numbers(sp_json_get(sp_json_get(mat, "pbrMetallicRoughness"), "baseColorFactor"), c, 4) == 4);
    return sp_json_string(sp_json_get(sp_json_get(sp_json_get(mat, "extras"), "sunprobe"), "colour"), "");
}

static void check_iris(const char *sunprobe, const char *face, const char *tmp, const glb *plain)
{
    double c[4];
    iris_of(plain, c); /* the fixture has no albedo_observed.u8: the default */
    CHECK(fabs(c[0] - 0.05) < 1e-6 && fabs(c[1] - 0.03) < 1e-6 && fabs(c[2] - 0.02) < 1e-6);
    char path[512], out[512];
    snprintf(path, sizeof(path), "%s/albedo_observed.u8", face);
    FILE *f = fopen(path, "wb");
    for (int i = 0; f && i < 256 * 256; i++)
        fputc(1, f);
    CHECK(f && fclose(f) == 0);
    snprintf(out, sizeof(out), "%s/seen.glb", tmp);
    glb g;
    if (export_to(sunprobe, face, out, "--no-draco", &g))
        return;
    const char *note = iris_of(&g, c);
    /* the fixture's albedo is (0.5 + 0.3 u, 0.35 + 0.2 row/256, 0.3); the eyes' texels are u 0.90..1, v 0.76..0.99 */
    CHECK_MSG(!strncmp(note, "fitted albedo", 13) && c[0] > 0.76 && c[0] < 0.80 && c[1] > 0.35 && c[1] < 0.40 &&
              fabs(c[2] - 0.3) < 1e-6, "iris colour (%g, %g, %g): %s", c[0], c[1], c[2], note);
    remove(path);
    glb_free(&g);
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: test_export_parts SUNPROBE TEST_EXPORT\n");
        return 99;
    }
    const char *dir = sp_face_ict_dir();
    ict_files f = { 0 };
    uint32_t nj = 0;
    f.neutral = obj_positions(dir, "generic_neutral_mesh.obj", &f.n);
    f.jaw = obj_positions(dir, "jawOpen.obj", &nj);
    if (!f.neutral || !f.jaw || f.n != 26719 || nj != f.n)
        SKIP("no ICT face model data in %s (tools/fetch-ict-facekit.sh)", dir);
    char tmp[] = "/tmp/sp-parts-XXXXXX", face[64], out[128], cmd[8192];
    CHECK(mkdtemp(tmp) != NULL);
    snprintf(face, sizeof(face), "%s/ict", tmp);
    snprintf(cmd, sizeof(cmd), "'%s' '%s' fixture '%s' ict", argv[2], argv[1], face);
    CHECK(system(cmd) == 0);
    snprintf(out, sizeof(out), "%s/plain.glb", tmp);
    glb g;
    if (export_to(argv[1], face, out, "--no-draco", &g) == 0) {
        static const char *const names[5] = { "skin", "eye_sclera", "eye_iris", "mouth_interior", "teeth" };
        CHECK_EQ_INT((int)n_prims(&g), 5);
        for (int i = 0; i < 5; i++)
            CHECK_MSG(!strcmp(prim_material(&g, i), names[i]), "primitive %d: material %s", i, prim_material(&g, i));
        CHECK(!left_reason(&g, "eyes")[0] && !left_reason(&g, "mouth_interior")[0]);
        uint32_t moved = 0, ignored = 0;
        check_prim(&g, 0, &f, 0, 11247, -1, &ignored);     /* face, head and neck */
        check_prim(&g, 1, &f, 21451, 24590, -1, &ignored); /* eyeballs ... */
        check_prim(&g, 2, &f, 21451, 24590, -1, &ignored);
        check_prim(&g, 3, &f, 0, 17038, 0, &ignored);      /* lips' inner ring, mouth socket, gums, tongue */
        check_prim(&g, 4, &f, 17039, 21450, 0, &moved);    /* teeth */
        CHECK_MSG(moved > 10, "jawOpen moves %u teeth vertices by more than 1 mm", moved);
        check_iris(argv[1], face, tmp, &g);
        glb_free(&g);
    }
    if (HAVE_DRACO) {
        snprintf(out, sizeof(out), "%s/draco.glb", tmp);
        if (export_to(argv[1], face, out, "", &g) == 0) {
            CHECK_EQ_INT((int)n_prims(&g), 5);
            for (size_t i = 0; i < n_prims(&g); i++)
                CHECK(sp_json_get(sp_json_get(glb_primitive(&g, i), "extensions"), "KHR_draco_mesh_compression"));
            glb_free(&g);
        }
    }
    check_without(argv[1], argv[2], tmp, face);
    free(f.neutral);
    free(f.jaw);
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", tmp);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", tmp);
    return check_exit();
}
