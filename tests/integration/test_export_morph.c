/* SPDX-License-Identifier: MIT */
/*
 * Expressions as morph targets (export/EXPORT.md, "Expressions"), on test_export's fixture (the generic
 * head, whose three expression modes are named): a plain .glb has one sparse POSITION target per mode,
 * named in mesh.extras.targetNames, default weights 0, and every corner's offset equal to the model's
 * mode at that corner's vertex (the fixture's frame maps the model's axes onto glTF's); a Draco export
 * and a face directory without the pose and expression (an older fit) or with a mesh that is not the
 * model's evaluation export without targets and say why in left_out, never failing.
 *
 *   test_export_morph SUNPROBE TEST_EXPORT
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "glb_read.h"
#include "sp_config.h"
#include "sunprobe/sp_face_model.h"
#include "sunprobe/sp_sunstage.h"

static void check_targets(const glb *g, const sp_face_model *m, const sp_mesh *mesh)
{
    const sp_json *me = sp_json_at(sp_json_get(g->json, "meshes"), 0);
    const sp_json *names = sp_json_get(sp_json_get(me, "extras"), "targetNames"), *w = sp_json_get(me, "weights");
    const sp_json *targets = sp_json_get(sp_json_at(sp_json_get(me, "primitives"), 0), "targets");
    CHECK(names && w && targets && names->count == m->n_exp && w->count == m->n_exp && targets->count == m->n_exp);
    uint32_t ni, nv;
    const uint8_t *idx = accessor_data(g, 3, 4, &ni);
    CHECK(idx && ni == mesh->n_triangles * 3);
    for (uint32_t k = 0; idx && targets && names && k < m->n_exp && k < targets->count; k++) {
        CHECK_MSG(!strcmp(sp_json_string(sp_json_at(names, k), ""), sp_face_model_exp_name(m, k)), "name %u", k);
        CHECK(sp_json_number(sp_json_at(w, k), -1) == 0.0);
        int acc = (int)sp_json_number(sp_json_get(sp_json_at(targets, k), "POSITION"), -1);
        float *d = sparse_offsets(g, acc, &nv);
        CHECK_MSG(d != NULL, "target %u: accessor %d is not a well-formed sparse accessor", k, acc);
        double worst = 0.0, biggest = 0.0;
        for (uint32_t c = 0; d && c < ni; c++) {
            uint32_t v;
            memcpy(&v, idx + 4 * (size_t)c, 4);
            const float *b = m->exp_basis + ((size_t)k * m->mesh.n_vertices + mesh->tri_vertices[c]) * 3;
            for (int a = 0; a < 3 && v < nv; a++) {
                worst = fmax(worst, fabs((double)d[(size_t)v * 3 + a] - (double)b[a]));
                biggest = fmax(biggest, fabs((double)b[a]));
            }
        }
        printf("target %u %s: largest offset %.4f m, largest error %.2g m\n", k, sp_face_model_exp_name(m, k),
               biggest, worst);
        CHECK(d && biggest > 1e-3 && worst < 1e-6);
        free(d);
    }
}

/* left_out has an "expressions" entry whose reason contains `why`, and the mesh has no targets. */
static void check_none(const char *sunprobe, const char *face, const char *out, const char *opts, const char *why)
{
    char cmd[8192];
    snprintf(cmd, sizeof(cmd), "'%s' export '%s' -o '%s' %s >/dev/null 2>&1", sunprobe, face, out, opts);
    CHECK_MSG(system(cmd) == 0, "%s", cmd);
    glb g;
    if (glb_read(&g, out)) {
        CHECK(!"readable .glb");
        return;
    }
    const sp_json *left = sp_json_get(sp_json_get(sp_json_get(sp_json_get(g.json, "asset"), "extras"), "sunprobe"),
                                      "left_out");
    const char *reason = "";
    for (size_t i = 0; left && i < left->count; i++)
        if (!strcmp(sp_json_string(sp_json_get(sp_json_at(left, i), "part"), ""), "expressions"))
            reason = sp_json_string(sp_json_get(sp_json_at(left, i), "reason"), "");
    const sp_json *prim = sp_json_at(sp_json_get(sp_json_at(sp_json_get(g.json, "meshes"), 0), "primitives"), 0);
    CHECK_MSG(strstr(reason, why) != NULL, "%s: reason \"%s\", want \"%s\"", out, reason, why);
    CHECK(prim && !sp_json_get(prim, "targets"));
    glb_free(&g);
}

/* Vertex i of b as (position, UV) bytes, for matching vertices between two files. */
static int vertex_key_cmp(const void *x, const void *y)
{
    return memcmp(x, y, 20);
}

/*
 * --reorder: the same vertices and triangles (mapped through equal position and UV), the same target offsets
 * at each vertex, vertices in first-use order, and a lower cache miss ratio than the plain export's.
 */
static void check_reorder(const glb *a, const glb *b, double acmr_a, double acmr_b)
{
    uint32_t nv, nvb, nu, ni, nib;
    const float *pa = (const float *)accessor_data(a, 0, 12, &nv), *pb = (const float *)accessor_data(b, 0, 12, &nvb);
    const float *ua = (const float *)accessor_data(a, 2, 8, &nu), *ub = (const float *)accessor_data(b, 2, 8, &nu);
    const uint32_t *ia = (const uint32_t *)accessor_data(a, 3, 4, &ni);
    const uint32_t *ib = (const uint32_t *)accessor_data(b, 3, 4, &nib);
    CHECK(pa && pb && ua && ub && ia && ib && nv == nvb && ni == nib);
    if (!pa || !pb || !ua || !ub || !ia || !ib || nv != nvb || ni != nib)
        return;
    float *keys = malloc((size_t)nv * 6 * sizeof(float)); /* x y z u v, original index */
    uint32_t *map = malloc((size_t)nv * sizeof(uint32_t)), unmatched = 0, late = 0, seen = 0;
    for (uint32_t i = 0; keys && i < nv; i++) {
        memcpy(keys + (size_t)i * 6, pa + (size_t)i * 3, 12);
        memcpy(keys + (size_t)i * 6 + 3, ua + (size_t)i * 2, 8);
        memcpy(keys + (size_t)i * 6 + 5, &i, 4);
    }
    if (keys)
        qsort(keys, nv, 24, vertex_key_cmp);
    for (uint32_t j = 0; keys && map && j < nv; j++) {
        float q[5];
        memcpy(q, pb + (size_t)j * 3, 12);
        memcpy(q + 3, ub + (size_t)j * 2, 8);
        const float *hit = bsearch(q, keys, nv, 24, vertex_key_cmp);
        unmatched += !hit;
        map[j] = hit ? *(const uint32_t *)(const void *)(hit + 5) : 0;
    }
    CHECK_MSG(keys && map && unmatched == 0, "%u reordered vertices match no original one", unmatched);
    for (uint32_t c = 0; map && c < ni; c++) { /* fetch order: each new vertex is the next index */
        late += ib[c] > seen;
        seen += ib[c] == seen;
    }
    CHECK_MSG(late == 0, "%u corners use a vertex before its turn", late);
    const sp_json *ta = sp_json_get(glb_primitive(a, 0), "targets"), *tb = sp_json_get(glb_primitive(b, 0), "targets");
    CHECK(ta && tb && ta->count == tb->count);
    for (size_t k = 0; map && ta && tb && k < ta->count && k < tb->count; k++) {
        uint32_t n1, n2, bad = 0;
        float *da = sparse_offsets(a, (int)sp_json_number(sp_json_get(sp_json_at(ta, k), "POSITION"), -1), &n1);
        float *db = sparse_offsets(b, (int)sp_json_number(sp_json_get(sp_json_at(tb, k), "POSITION"), -1), &n2);
        for (uint32_t j = 0; da && db && j < nv; j++)
            bad += memcmp(db + (size_t)j * 3, da + (size_t)map[j] * 3, 12) != 0;
        CHECK_MSG(da && db && bad == 0, "target %zu: %u reordered offsets differ", k, bad);
        free(da);
        free(db);
    }
    printf("reorder: cache miss ratio %.4f -> %.4f\n", acmr_a, acmr_b);
    CHECK(acmr_b < acmr_a && acmr_b > 0.0);
    free(keys);
    free(map);
}

static double stat_of(const char *path, const char *key)
{
    char line[256];
    double v = -1.0;
    FILE *f = fopen(path, "r");
    while (f && fgets(line, sizeof(line), f))
        if (!strncmp(line, key, strlen(key)) && line[strlen(key)] == ' ')
            v = atof(line + strlen(key) + 1);
    if (f)
        fclose(f);
    return v;
}

/* Rewrites FILE in DIR with every occurrence of `from` replaced by `to` (one line of JSON each). */
static int edit(const char *dir, const char *file, const char *from, const char *to)
{
    char cmd[8192];
    snprintf(cmd, sizeof(cmd), "sed -i 's/%s/%s/g' '%s/%s'", from, to, dir, file);
    return system(cmd);
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: test_export_morph SUNPROBE TEST_EXPORT\n");
        return 99;
    }
    sp_log_set_level(SP_LOG_ERROR);
    char tmp[] = "/tmp/sp-morph-XXXXXX", face[64], out[128], cmd[8192];
    CHECK(mkdtemp(tmp) != NULL);
    snprintf(face, sizeof(face), "%s/face", tmp);
    snprintf(cmd, sizeof(cmd), "'%s' '%s' fixture '%s'", argv[2], argv[1], face);
    sp_face_model m;
    sp_face_asset a;
    if (system(cmd) != 0 || sp_face_model_generic(&m) || sp_face_dir_read(&a, face)) {
        fprintf(stderr, "cannot make or read the fixture: %s\n", cmd);
        return 99;
    }
    snprintf(out, sizeof(out), "%s/plain.glb", tmp);
    snprintf(cmd, sizeof(cmd), "'%s' export '%s' -o '%s' --no-draco --stats | grep -q '^morph_targets %u$'", argv[1],
             face, out, m.n_exp);
    CHECK_MSG(system(cmd) == 0, "%s", cmd);
    glb g;
    if (glb_read(&g, out) == 0)
        check_targets(&g, &m, &a.mesh);
    glb_free(&g);
    if (HAVE_MESHOPTIMIZER) {
        char st1[128], st2[128], out2[128];
        snprintf(st1, sizeof(st1), "%s/plain.stats", tmp);
        snprintf(st2, sizeof(st2), "%s/reordered.stats", tmp);
        snprintf(out2, sizeof(out2), "%s/reordered.glb", tmp);
        snprintf(cmd, sizeof(cmd), "'%s' export '%s' -o '%s' --no-draco --stats >'%s' && '%s' export '%s' -o '%s' "
                 "--no-draco --reorder --stats >'%s'", argv[1], face, out, st1, argv[1], face, out2, st2);
        CHECK_MSG(system(cmd) == 0, "%s", cmd);
        glb g2;
        if (glb_read(&g, out) == 0 && glb_read(&g2, out2) == 0)
            check_reorder(&g, &g2, stat_of(st1, "acmr"), stat_of(st2, "acmr"));
        glb_free(&g);
        glb_free(&g2);
    } else { /* a build without meshoptimizer says which option */
        snprintf(cmd, sizeof(cmd), "'%s' export '%s' -o '%s/r.glb' --reorder 2>&1 | grep -q meshoptimizer", argv[1],
                 face, tmp);
        CHECK_MSG(system(cmd) == 0, "%s", cmd);
    }
    if (HAVE_DRACO) {
        snprintf(out, sizeof(out), "%s/draco.glb", tmp);
        check_none(argv[1], face, out, "", "export with --no-draco");
    }
    snprintf(out, sizeof(out), "%s/moved.glb", tmp); /* a face pose that does not place the mesh */
    CHECK(edit(face, "cameras.json", "\"face_t\":\\[0,0,-0.5\\]", "\"face_t\":[0,0,-0.49]") == 0);
    check_none(argv[1], face, out, "--no-draco", "is not the face model's evaluation (a vertex 10");
    snprintf(out, sizeof(out), "%s/old.glb", tmp); /* an older fit: no identity in the manifest */
    CHECK(edit(face, "manifest.json", "\"identity\"", "\"identity_was\"") == 0);
    check_none(argv[1], face, out, "--no-draco", "(an older fit)");
    sp_face_asset_free(&a);
    sp_face_model_free(&m);
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", tmp);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", tmp);
    return check_exit();
}
