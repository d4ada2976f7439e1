/* SPDX-License-Identifier: MIT */
/*
 * ICT importer: the OBJ reader on good and malformed input and the decimator
 * on the generic head always run; the import itself needs the ICT data
 * ($SP_ICT_FACEKIT_DIR) and is skipped (exit 77) without it.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "check.h"
#include "pipeline/face/mesh_decimate.h"
#include "pipeline/face/obj_reader.h"
#include "sunprobe/sp_face_model.h"

static int parse(const char *text, obj_data *o)
{
    char err[128];
    int rc = obj_parse(text, strlen(text), 0, o, err, sizeof(err));
    if (rc == SP_ECORRUPT)
        CHECK_MSG(strncmp(err, "line ", 5) == 0, "error text '%s'", err);
    return rc;
}

static void test_obj_good(void)
{
    obj_data o;
    const char *text = "# comment\r\nmtllib x.mtl\nv 1 2 3\nv -1.5e-2 +4 .5 1.0\r\nv\t0\t0\t1\n"
                       "vt 0.25 0.75\nvt 1 0 0\nvn 0 0 1\nusemtl M\n"
                       "f 1/1 2/2 3/1\nf -3/-2/1 -2//1 -1/2/1 1/1\nf 1 2 3 # tail comment\nf 3/1 2/2 1/1";
    CHECK_EQ_INT(parse(text, &o), 0);
    CHECK_EQ_INT(o.n_v, 3);
    CHECK_EQ_INT(o.n_vt, 2);
    CHECK_EQ_INT(o.n_faces, 4);
    CHECK_EQ_INT(o.n_corners, 13);
    CHECK_NEAR(o.v[3], -0.015, 1e-9);
    CHECK_NEAR(o.v[5], 0.5, 0);
    CHECK_NEAR(o.vt[1], 0.75, 0);
    CHECK_EQ_INT(o.corner_v[3], 0); /* -3 relative to 3 vertices */
    CHECK_EQ_INT(o.corner_vt[3], 0);
    CHECK_EQ_INT(o.corner_vt[4], OBJ_NO_UV);
    CHECK_EQ_INT(o.corner_vt[7], OBJ_NO_UV);
    CHECK_EQ_INT(o.face_start[4], 13);
    obj_free(&o);
    CHECK_EQ_INT(obj_parse("v 1 2 3\nvt 0 0\nf 1/1 1/1 1/1\n", 29, 1, &o, NULL, 0), 0);
    CHECK(o.n_v == 1 && o.n_vt == 0 && o.n_faces == 0); /* positions only */
    obj_free(&o);
    CHECK_EQ_INT(obj_parse(NULL, 0, 0, &o, NULL, 0), 0);
    CHECK_EQ_INT(o.n_v, 0);
    obj_free(&o);
}

static void test_obj_bad(void)
{
    static const char *bad[] = {
        "v 1 2\n",         "v 1 2 nan\n",      "v 1e999 0 0\n",    "v 1 2 3x\n",      "v 1 2 -\n",
        "v 1 2 3e\n",      "vt 0.5\n",         "f 1 2\n",          "f 1 2 3\n",       "v 0 0 0\nf 0 1 1\n",
        "v 0 0 0\nf 1 1 -2\n", "v 0 0 0\nf 1/1 1 1\n", "v 0 0 0\nf 1/ 1 1\n", "v 0 0 0\nf 1//x 1 1\n",
        "v 0 0 0\nf 1 1 99999999999999999999\n", "v 0 0 0\nf 1a 1 1\n", "v 1 1 1\nv inf 0 0\n",
    };
    for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
        obj_data o;
        CHECK_MSG(parse(bad[i], &o) == SP_ECORRUPT, "accepted: %s", bad[i]);
        CHECK(o.v == NULL && o.n_v == 0);
    }
    /* a 65-corner polygon is refused */
    char big[1024] = "v 0 0 0\nf";
    for (int i = 0; i < 65; i++)
        strcat(big, " 1");
    obj_data o;
    CHECK_EQ_INT(parse(big, &o), SP_ECORRUPT);
    /* not NUL-terminated: the reader must stop at len */
    char buf[8] = { 'v', ' ', '1', ' ', '2', ' ', '3', '7' };
    CHECK_EQ_INT(obj_parse(buf, 7, 0, &o, NULL, 0), 0);
    CHECK(o.n_v == 1 && o.v[2] == 3.0f);
    obj_free(&o);
    /* random garbage never crashes and only ever parses or fails cleanly */
    static const char alphabet[] = "vtf 0123456789.-+/e#\n\r";
    uint32_t state = 12345;
    char text[256];
    for (int it = 0; it < 3000; it++) {
        size_t n = (size_t)(it % 200) + 1;
        for (size_t i = 0; i < n; i++) {
            state = state * 1664525u + 1013904223u;
            text[i] = alphabet[(state >> 16) % (sizeof(alphabet) - 1)];
        }
        int rc = obj_parse(text, n, 0, &o, NULL, 0);
        CHECK(rc == 0 || rc == SP_ECORRUPT);
        if (rc == 0) {
            for (uint32_t c = 0; c < o.n_corners; c++)
                CHECK(o.corner_v[c] < o.n_v && (o.corner_vt[c] == OBJ_NO_UV || o.corner_vt[c] < o.n_vt));
            obj_free(&o);
        }
    }
}

/* No repeated corner and no zero-area triangle; returns the count of bad ones. */
static int degenerate_triangles(const sp_mesh *m)
{
    int bad = 0;
    for (uint32_t t = 0; t < m->n_triangles; t++) {
        const uint32_t *v = m->tri_vertices + t * 3;
        const float *a = m->positions + v[0] * 3, *b = m->positions + v[1] * 3, *c = m->positions + v[2] * 3;
        double e1[3], e2[3];
        for (int k = 0; k < 3; k++) {
            e1[k] = (double)b[k] - (double)a[k];
            e2[k] = (double)c[k] - (double)a[k];
        }
        double nx = e1[1] * e2[2] - e1[2] * e2[1], ny = e1[2] * e2[0] - e1[0] * e2[2],
               nz = e1[0] * e2[1] - e1[1] * e2[0];
        bad += v[0] == v[1] || v[1] == v[2] || v[0] == v[2] || !(nx * nx + ny * ny + nz * nz > 1e-24);
    }
    return bad;
}

static void test_decimate_generic(void)
{
    sp_face_model g;
    CHECK_EQ_INT(sp_face_model_generic(&g), 0);
    uint8_t *locked = calloc(g.mesh.n_vertices, 1);
    for (int j = 0; j < SP_FACE_N_LANDMARKS; j++)
        locked[g.landmarks[j]] = 1;
    sp_mesh out;
    uint32_t *origin = NULL, target = g.mesh.n_triangles / 3;
    CHECK_EQ_INT(mesh_decimate(&g.mesh, locked, NULL, target, &out, &origin), 0);
    CHECK_EQ_INT(sp_mesh_validate(&out), 0);
    CHECK_MSG(out.n_triangles <= target && out.n_triangles > target * 9 / 10, "%u triangles for %u", out.n_triangles,
              target);
    CHECK_EQ_INT(degenerate_triangles(&out), 0);
    int kept = 0, same = 1;
    for (uint32_t i = 0; i < out.n_vertices; i++) {
        kept += locked[origin[i]];
        same &= !memcmp(out.positions + i * 3, g.mesh.positions + origin[i] * 3, 12);
    }
    CHECK_EQ_INT(kept, SP_FACE_N_LANDMARKS);
    CHECK(same); /* kept vertices are original vertices */
    printf("decimated the generic head from %u to %u triangles\n", g.mesh.n_triangles, out.n_triangles);
    sp_mesh_free(&out);
    free(origin);
    free(locked);
    sp_face_model_free(&g);
    CHECK_EQ_INT(mesh_decimate(NULL, NULL, NULL, 10, &out, &origin), -EINVAL);
}

/* ---- with the data ---- */

static double seconds_since(const struct timespec *t0)
{
    struct timespec t1;
    clock_gettime(CLOCK_MONOTONIC, &t1);
    return (double)(t1.tv_sec - t0->tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0->tv_nsec);
}

/*
 * The eyeballs: two of them, behind the eye landmarks, never skin, with their texture coordinates
 * in the atlas corner no skin triangle uses (so the fit's albedo of an eye is its own).
 */
static void check_eyes(const sp_face_model *m)
{
    uint32_t n_eye = 0, left = 0;
    double c[2][3] = { { 0, 0, 0 }, { 0, 0, 0 } };
    for (uint32_t i = 0; i < m->mesh.n_vertices; i++) {
        if (m->part[i] != SP_FACE_PART_EYE)
            continue;
        CHECK(m->face_mask[i] == 0);
        const float *p = m->mesh.positions + (size_t)i * 3;
        int side = p[0] > 0;
        n_eye++;
        left += (uint32_t)side;
        for (int k = 0; k < 3; k++)
            c[side][k] += (double)p[k];
    }
    CHECK_MSG(n_eye > 100 && left > n_eye / 4 && left < 3 * n_eye / 4, "%u eyeball vertices, %u left", n_eye, left);
    for (int side = 0; side < 2 && n_eye; side++) {
        uint32_t n = side ? left : n_eye - left;
        double lm[3] = { 0, 0, 0 }; /* the mean of that eye's six landmarks */
        for (int j = 0; j < 6; j++)
            for (int k = 0; k < 3; k++)
                lm[k] += (double)m->mesh.positions[m->landmarks[(side ? 42 : 36) + j] * 3 + (uint32_t)k] / 6.0;
        double d = 0;
        for (int k = 0; k < 3; k++)
            d += (c[side][k] / n - lm[k]) * (c[side][k] / n - lm[k]);
        CHECK_MSG(sqrt(d) < 0.02, "eyeball %d centre %.1f mm from its landmarks", side, 1000 * sqrt(d));
    }
    int eye_uv_ok = 1, skin_in_corner = 0;
    for (uint32_t t = 0; t < m->mesh.n_triangles; t++) {
        int eye = m->part[m->mesh.tri_vertices[t * 3]] == SP_FACE_PART_EYE;
        for (int k = 0; k < 3; k++) {
            const float *uv = m->mesh.uvs + (size_t)m->mesh.tri_uvs[t * 3 + (uint32_t)k] * 2;
            int corner = uv[0] > 0.9f && uv[1] > 0.75f;
            eye_uv_ok &= !eye || corner;
            skin_in_corner += !eye && corner;
        }
    }
    CHECK(eye_uv_ok);
    CHECK_MSG(skin_in_corner == 0, "%d skin UVs in the eyes' atlas corner", skin_in_corner);
}

static void check_ict_model(const sp_face_model *m)
{
    CHECK_EQ_INT(sp_face_model_validate(m), 0);
    CHECK_EQ_INT(degenerate_triangles(&m->mesh), 0);
    CHECK_EQ_INT(m->n_exp, 10);
    CHECK(m->n_id >= 1 && m->n_id <= 30);
    CHECK(strcmp(sp_face_model_exp_name(m, 0), "jawOpen") == 0);
    double ymax = -INFINITY, chin = (double)m->mesh.positions[m->landmarks[8] * 3 + 1];
    for (uint32_t i = 0; i < m->mesh.n_vertices; i++)
        ymax = fmax(ymax, (double)m->mesh.positions[i * 3 + 1]);
    CHECK_MSG(ymax - chin > 0.18 && ymax - chin < 0.28, "crown to chin %g m", ymax - chin);
    for (int j = 0; j < SP_FACE_N_LANDMARKS; j++) {
        CHECK(m->landmarks[j] < m->mesh.n_vertices);
        for (int k = 0; k < j; k++)
            CHECK(m->landmarks[j] != m->landmarks[k]);
    }
    CHECK((double)m->mesh.positions[m->landmarks[36] * 3] < 0 && (double)m->mesh.positions[m->landmarks[45] * 3] > 0);
    for (int j = 0; j < SP_FACE_N_LANDMARKS; j++)
        CHECK_MSG(m->face_mask[m->landmarks[j]] == 1, "landmark %d is outside the face mask", j);
    /* the first identity mode moves the head by millimetres, not by centimetres or by nothing */
    double ss = 0;
    for (size_t i = 0; i < (size_t)m->mesh.n_vertices * 3; i++)
        ss += (double)m->id_basis[i] * (double)m->id_basis[i];
    double rms = sqrt(ss / m->mesh.n_vertices);
    CHECK_MSG(rms > 5e-4 && rms < 0.02, "identity mode 0 RMS %g m", rms);
    check_eyes(m);
}

static void test_import_full(const char *dir)
{
    sp_face_ict_settings s;
    sp_face_ict_default_settings(&s);
    s.dir = dir;
    s.target_triangles = 0;
    sp_face_model full;
    struct timespec t0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    int err = sp_face_model_import_ict(&full, &s);
    CHECK_EQ_INT(err, 0);
    if (err)
        return;
    printf("ICT import without decimation: %.2f s, %u vertices, %u UVs, %u triangles, %u + %u modes\n",
           seconds_since(&t0), full.mesh.n_vertices, full.mesh.n_uvs, full.mesh.n_triangles, full.n_id, full.n_exp);
    CHECK_EQ_INT(full.mesh.n_vertices, 11248 + 3140); /* every face, head-and-neck and eyeball vertex */
    CHECK(full.mesh.n_triangles > 26000 && full.mesh.n_triangles < 29000);
    check_ict_model(&full);

    sp_face_model dec;
    s.target_triangles = 10000;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    err = sp_face_model_import_ict(&dec, &s);
    CHECK_EQ_INT(err, 0);
    if (!err) {
        printf("ICT import decimated: %.2f s, %u vertices, %u triangles\n", seconds_since(&t0), dec.mesh.n_vertices,
               dec.mesh.n_triangles);
        CHECK(dec.mesh.n_triangles <= 10000 && dec.mesh.n_triangles > 9000);
        check_ict_model(&dec);
        /* decimation keeps original vertices: landmarks and their modes are unchanged */
        size_t nf = full.mesh.n_vertices, nd = dec.mesh.n_vertices;
        for (int j = 0; j < SP_FACE_N_LANDMARKS; j++) {
            uint32_t a = full.landmarks[j], b = dec.landmarks[j];
            CHECK(!memcmp(full.mesh.positions + a * 3, dec.mesh.positions + b * 3, 12));
            CHECK(!memcmp(full.id_basis + (5 * nf + a) * 3, dec.id_basis + (5 * nd + b) * 3, 12));
            CHECK(!memcmp(full.exp_basis + (0 * nf + a) * 3, dec.exp_basis + (0 * nd + b) * 3, 12));
        }
        sp_face_model_free(&dec);
    }
    sp_face_model_free(&full);
}

static void test_load_cached(const char *dir)
{
    char tmp[] = "/tmp/sp_face_ict_XXXXXX", cache[256];
    CHECK(mkdtemp(tmp) != NULL);
    snprintf(cache, sizeof(cache), "%s/model.spface", tmp);
    sp_face_load_settings s;
    sp_face_load_default_settings(&s);
    s.ict_dir = dir;
    s.cache_path = cache;
    sp_face_model a, b;
    CHECK_EQ_INT(sp_face_model_load(&a, &s), 0);
    struct stat st;
    CHECK(stat(cache, &st) == 0 && st.st_size > 100000);
    CHECK(strncmp(a.source, "ict-facekit", 11) == 0);
    CHECK_EQ_INT(sp_face_model_load(&b, &s), 0); /* from the cache this time */
    CHECK(strcmp(a.source, b.source) == 0 && a.mesh.n_triangles == b.mesh.n_triangles &&
          !memcmp(a.id_basis, b.id_basis, sizeof(float) * 3 * a.mesh.n_vertices * a.n_id));
    sp_face_model_free(&a);
    sp_face_model_free(&b);
    unlink(cache);
    rmdir(tmp);
}

int main(void)
{
    test_obj_good();
    test_obj_bad();
    test_decimate_generic();
    sp_face_ict_settings s;
    sp_face_ict_default_settings(&s);
    s.dir = "/nonexistent/ict-facekit";
    sp_face_model m;
    CHECK_EQ_INT(sp_face_model_import_ict(&m, &s), -ENOENT); /* logs the fetch script's name */
    if (check_failures)
        return check_exit();

    const char *dir = getenv("SP_ICT_FACEKIT_DIR");
    char neutral[4096];
    struct stat st;
    if (!dir || !dir[0])
        SKIP("SP_ICT_FACEKIT_DIR is not set (meson sets it to ../shared/face-models/ict-facekit)");
    snprintf(neutral, sizeof(neutral), "%s/generic_neutral_mesh.obj", dir);
    if (stat(neutral, &st) != 0)
        SKIP("no ICT Face Model in %s: tools/fetch-ict-facekit.sh DIR downloads it", dir);
    test_import_full(dir);
    test_load_cached(dir);
    return check_exit();
}
