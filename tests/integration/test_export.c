/* SPDX-License-Identifier: MIT */
/*
 * sunprobe export: a face-directory fixture (the generic head in the manifest
 * format facedir.c writes), then GLB structure, --no-draco geometry, OBJ, DRC,
 * the documented mappings, and bad input. `test_export SUNPROBE fixture DIR
 * [flat|ict|facing]` only writes the fixture (for tests/export/test_export_node.sh; facing: keyframe 0
 * looks at the face, 160 x 160, for the viewer and Blender tests).
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "glb_read.h"
#include "common/json.h"
#include "export/gltf_internal.h"
#include "sp_config.h"
#include "sunprobe/sp_export.h"
#include "sunprobe/sp_face_model.h"

static int write_file(const char *dir, const char *name, const void *p, size_t n)
{
    char path[4096];
    snprintf(path, sizeof(path), "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    if (!f)
        return -errno;
    int ok = fwrite(p, 1, n, f) == n;
    return fclose(f) == 0 && ok ? 0 : -EIO;
}

static int write_mesh(const char *dir, const sp_mesh *m)
{
    size_t n = 20 + 4 * (3 * (size_t)m->n_vertices + 2 * (size_t)m->n_uvs + 6 * (size_t)m->n_triangles);
    uint8_t *b = malloc(n);
    if (!b)
        return -ENOMEM;
    uint32_t c[3] = { m->n_vertices, m->n_uvs, m->n_triangles };
    memcpy(b, "SPFMESH1", 8);
    memcpy(b + 8, c, 12);
    uint8_t *p = b + 20;
    for (uint32_t i = 0; i < m->n_vertices; i++) { /* model frame (y up) placed 0.5 m in front, world z up */
        float w[3] = { m->positions[i * 3], 0.5f - m->positions[i * 3 + 2], m->positions[i * 3 + 1] };
        memcpy(p + 12 * (size_t)i, w, 12);
    }
    p += 12 * (size_t)m->n_vertices;
    memcpy(p, m->uvs, 8 * (size_t)m->n_uvs);
    memcpy(p += 8 * (size_t)m->n_uvs, m->tri_vertices, 12 * (size_t)m->n_triangles);
    memcpy(p + 12 * (size_t)m->n_triangles, m->tri_uvs, 12 * (size_t)m->n_triangles);
    int ret = write_file(dir, "mesh.bin", b, n);
    free(b);
    return ret;
}

static int write_maps(const char *dir, int tw, int th, int flat)
{
    size_t nt = (size_t)tw * (size_t)th;
    float *alb = malloc(nt * 12), *disp = malloc(nt * 4), env[SP_RENDER_ENV_FLOATS];
    int ret = alb && disp ? 0 : -ENOMEM;
    for (size_t i = 0; !ret && i < nt; i++) {
        double u = (double)(i % (size_t)tw) / tw, v = (double)(i / (size_t)tw) / th;
        alb[i * 3] = (float)(0.5 + 0.3 * u);
        alb[i * 3 + 1] = (float)(0.35 + 0.2 * v);
        alb[i * 3 + 2] = 0.3f;
        disp[i] = flat ? 0.0f : (float)(0.0005 * sin(20.0 * u) * cos(14.0 * v));
    }
    for (int i = 0; i < SP_RENDER_ENV_FLOATS; i++)
        env[i] = (float)(0.2 + 0.8 * (i / 3 / SP_RENDER_ENV_W < SP_RENDER_ENV_H / 2 ? 1.0 : 0.1));
    if (!ret)
        ret = write_file(dir, "albedo.f32", alb, nt * 12);
    if (!ret)
        ret = write_file(dir, "displacement.f32", disp, nt * 4);
    if (!ret)
        ret = write_file(dir, "env.f32", env, sizeof(env));
    free(alb);
    free(disp);
    return ret;
}

/*
 * A fixture face directory. flat: zero displacement, zero specular, no sun.
 * ict: the ICT model (or the generic head when its data is missing) with 256^2
 * maps, for size figures. left_out: the manifest's "left_out" list (JSON array),
 * NULL for an old manifest without it. unobservable: lighting_unobservable true.
 */
typedef struct fixture {
    int flat, ict, unobservable, facing;
    const char *left_out;
} fixture;

/* What facedir.c writes for a fit that left everything out (reasons as it words them). */
#define ALL_LEFT_OUT                                                                                            \
    "[{\"part\":\"sun\",\"reason\":\"lighting unobservable: too little camera rotation\"},"                     \
    "{\"part\":\"shadows\",\"reason\":\"no sun, so no cast shadows\"},"                                         \
    "{\"part\":\"specular\",\"reason\":\"no sun to reflect\"},"                                                 \
    "{\"part\":\"displacement\",\"reason\":\"displacement map not fitted\"},"                                   \
    "{\"part\":\"environment\",\"reason\":\"lighting unobservable: the sky is a neutral constant\"}]"

/* "0,0,...": n zeros as a JSON list body (n <= 64). */
static const char *zeros(uint32_t n)
{
    static char buf[2][160];
    static int which;
    char *b = buf[which ^= 1];
    b[0] = '\0';
    for (uint32_t i = 0; i < n && i < 64; i++)
        strcat(b, i ? ",0" : "0");
    return b;
}

/* The manifest keys facedir.c writes (and facedir_read.c needs). */
static int write_manifest(const char *dir, const sp_face_model *m, int tw, int th, const fixture *fx)
{
    char buf[8192], list[4096] = "";
    int flat = fx->flat;
    if (fx->left_out)
        snprintf(list, sizeof(list), "\"left_out\":%s,\n", fx->left_out);
    int n = snprintf(buf, sizeof(buf),
                     "{\"format\":\"sunprobe-face\",\"version\":1,\"model\":\"%s\",\"solver\":\"fast\",\n"
                     "\"mesh\":\"mesh.obj\",\"mesh_binary\":\"mesh.bin\",\"n_vertices\":%u,\"n_triangles\":%u,\n"
                     "\"textures\":{\"width\":%d,\"height\":%d,\"albedo\":\"albedo.f32\",\"albedo_png\":\"albedo.png\","
                     "\"displacement\":\"displacement.f32\",\"clusters\":\"clusters.u8\",\"cluster_width\":%u,"
                     "\"cluster_height\":%u},\n\"specular\":{\"ks\":[%s],\"shininess\":[10,20,30,40,50,60,70,80,"
                     "90,100]},\n\"lighting\":{\"sun_direction\":[0.3,-0.8,0.5],\"sun_intensity\":%s,"
                     "\"sun_dropped\":false,\"lighting_unobservable\":%s,\"notes\":\"\",\"env\":\"env.f32\","
                     "\"env_height\":16,\"env_width\":32,\"yaw_range_deg\":300},\n"
                     "%s\"identity\":[%s],\"scale\":1,\"cameras\":\"cameras.json\"}\n",
                     m->source, m->mesh.n_vertices, m->mesh.n_triangles, tw, th, m->cluster_width,
                     m->cluster_height,
                     flat ? "0,0,0,0,0,0,0,0,0,0" : "0.01,0.02,0.03,0.04,0.05,0.02,0.02,0.02,0.02,0.02",
                     flat ? "0" : "2.5", fx->unobservable ? "true" : "false", list, zeros(m->n_id));
    /*
     * write_mesh's placement is world = C (R_f x + t_f) with C keyframe 0's camera-to-world rotation. As the
     * export tests have it, C turns +90 deg about x (the camera faces away): R_f = I, t_f = (0, 0, -0.5).
     * facing, as a fit writes it (camera at the origin looking along world +y at the face, -90 deg about
     * x): R_f = 180 deg about x, t_f = (0, 0, 0.5).
     */
    char cams[4096];
    int nc = snprintf(cams, sizeof(cams), "{\"frames\":[\n {\"sequence\":0,\"timestamp_ns\":0,\"heldout\":false,"
                      "%s,\"expression\":[%s]}\n]}\n",
                      fx->facing ? "\"width\":160,\"height\":160,\"intrinsics\":[260,260,79.5,79.5],"
                                   "\"camera_to_world_wxyz\":[0.70710678118654752,-0.70710678118654752,0,0],"
                                   "\"face_rotvec\":[3.14159265358979324,0,0],\"face_t\":[0,0,0.5]"
                                 : "\"width\":128,\"height\":128,\"intrinsics\":[150,150,64,64],"
                                   "\"camera_to_world_wxyz\":[0.70710678118654752,0.70710678118654752,0,0],"
                                   "\"face_rotvec\":[0,0,0],\"face_t\":[0,0,-0.5]",
                      zeros(m->n_exp));
    int ret = write_file(dir, "manifest.json", buf, (size_t)n);
    return ret ? ret : write_file(dir, "cameras.json", cams, (size_t)nc);
}

static int make_fixture_spec(const char *dir, const fixture *fx)
{
    int flat = fx->flat, ict = fx->ict;
    sp_face_model m;
    int ret = ict ? sp_face_model_load_default(&m) : sp_face_model_generic(&m);
    if (ret)
        return ret;
    const int tw = ict ? 256 : 64, th = tw;
    mkdir(dir, 0755);
    if (!ret)
        ret = write_mesh(dir, &m.mesh);
    if (!ret)
        ret = write_maps(dir, tw, th, flat);
    if (!ret)
        ret = write_file(dir, "clusters.u8", m.cluster_map, (size_t)m.cluster_width * m.cluster_height);
    if (!ret)
        ret = write_manifest(dir, &m, tw, th, fx);
    sp_face_model_free(&m);
    return ret;
}

static int make_fixture(const char *dir, int flat)
{
    fixture fx = { .flat = flat };
    return make_fixture_spec(dir, &fx);
}

static int has_string(const sp_json *arr, const char *s)
{
    for (size_t i = 0; arr && i < arr->count; i++)
        if (!strcmp(sp_json_string(sp_json_at(arr, i), ""), s))
            return 1;
    return 0;
}

static const sp_json *extras(const glb *g);

/*
 * Every glTF triangle corner is the original mesh corner placed in the scene,
 * with flipped v: the y-up mapping (no turn: the fixture's head is in front of
 * keyframe 0's camera along world +y, so it already looks along glTF +z) plus
 * the translation in extras.fit_to_scene.
 */
static void check_plain_geometry(const glb *g, const sp_mesh *m)
{
    const sp_json *place = sp_json_get(extras(g), "fit_to_scene");
    double R[9], T[3], M[9] = { 1, 0, 0, 0, 0, 1, 0, -1, 0 };
    CHECK(sp_json_numbers(sp_json_get(place, "rotation"), R, 9) == 9);
    CHECK(sp_json_numbers(sp_json_get(place, "translation"), T, 3) == 3);
    for (int k = 0; k < 9; k++)
        CHECK_NEAR(R[k], M[k], 1e-12);
    uint32_t np, nu, ni;
    const uint8_t *pos = accessor_data(g, 0, 12, &np), *uv = accessor_data(g, 2, 8, &nu);
    const uint8_t *idx = accessor_data(g, 3, 4, &ni);
    CHECK(pos && uv && idx && np == nu && ni == m->n_triangles * 3);
    if (!pos || !uv || !idx || ni != m->n_triangles * 3)
        return;
    int bad = 0;
    for (uint32_t c = 0; c < ni; c++) {
        uint32_t i;
        float p[3], t[2];
        memcpy(&i, idx + 4 * (size_t)c, 4);
        if (i >= np) {
            bad++;
            continue;
        }
        memcpy(p, pos + 12 * (size_t)i, 12);
        memcpy(t, uv + 8 * (size_t)i, 8);
        const float *w = m->positions + 3 * (size_t)m->tri_vertices[c], *u = m->uvs + 2 * (size_t)m->tri_uvs[c];
        double want[3] = { (double)w[0] + T[0], (double)w[2] + T[1], -(double)w[1] + T[2] }, err = 0.0;
        for (int k = 0; k < 3; k++)
            err = fmax(err, fabs((double)p[k] - want[k]));
        bad += err > 1e-6 || t[0] != u[0] || t[1] != 1.0f - u[1];
    }
    CHECK_MSG(bad == 0, "%d corners differ from the face mesh", bad);
}

static int fit_part(const sp_json *entry)
{
    const char *p = sp_json_string(sp_json_get(entry, "part"), "");
    return strcmp(p, "expressions") && strcmp(p, "eyes") && strcmp(p, "mouth_interior");
}

static void check_material(const glb *g, int full)
{
    const sp_json *mat = sp_json_at(sp_json_get(g->json, "materials"), 0);
    const sp_json *spec = sp_json_get(sp_json_get(mat, "extensions"), "KHR_materials_specular");
    CHECK(sp_json_get(sp_json_get(mat, "pbrMetallicRoughness"), "baseColorTexture") != NULL);
    CHECK((sp_json_get(mat, "normalTexture") != NULL) == full);
    CHECK(spec != NULL && (sp_json_get(spec, "specularTexture") != NULL) == full);
    const sp_json *left = sp_json_get(sp_json_get(sp_json_get(sp_json_get(g->json, "asset"), "extras"), "sunprobe"),
                                      "left_out");
    size_t parts = 0; /* the fit's parts, not what the face model cannot give (fit_part) */
    for (size_t i = 0; left && i < left->count; i++)
        parts += fit_part(sp_json_at(left, i));
    CHECK(left && parts == (full ? 0u : 4u)); /* flat: sun, shadows, specular, displacement */
    const sp_json *lights = sp_json_get(sp_json_get(sp_json_get(g->json, "extensions"), "KHR_lights_punctual"),
                                        "lights");
    CHECK((lights != NULL) == full);
    if (!full)
        return;
    CHECK_NEAR(sp_json_number(sp_json_get(sp_json_at(lights, 0), "intensity"), 0), 2.5 * 1.2 * 32768.0, 1e-6);
    double q[4];
    const sp_json *sun = sp_json_at(sp_json_get(g->json, "nodes"), 2);
    CHECK(!strcmp(sp_json_string(sp_json_get(sun, "name"), ""), "sun"));
    CHECK(sp_json_numbers(sp_json_get(sun, "rotation"), q, 4) == 4);
    /* the node's +z (towards the sun) = q applied to (0,0,1): third column of the rotation matrix */
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double col[3] = { 2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y) };
    double n = sqrt(0.3 * 0.3 + 0.8 * 0.8 + 0.5 * 0.5);
    CHECK_NEAR(col[0], 0.3 / n, 1e-6);
    CHECK_NEAR(col[1], 0.5 / n, 1e-6);
    CHECK_NEAR(col[2], 0.8 / n, 1e-6);
}

static const sp_json *extras(const glb *g)
{
    return sp_json_get(sp_json_get(sp_json_get(g->json, "asset"), "extras"), "sunprobe");
}

/* The extras' left_out entry for part, or NULL. */
static const sp_json *left_entry(const glb *g, const char *part)
{
    const sp_json *list = sp_json_get(extras(g), "left_out"), *e;
    for (size_t i = 0; (e = sp_json_at(list, i)); i++)
        if (!strcmp(sp_json_string(sp_json_get(e, "part"), ""), part))
            return e;
    return NULL;
}

/* The fit's parts in left_out (the generic head adds eyes and mouth_interior, Draco its expressions). */
static size_t left_count(const glb *g)
{
    const sp_json *list = sp_json_get(extras(g), "left_out");
    size_t n = 0;
    for (size_t i = 0; list && i < list->count; i++)
        n += fit_part(sp_json_at(list, i));
    return list ? n : (size_t)-1;
}

static int reason_is(const glb *g, const char *part, const char *prefix)
{
    const char *r = sp_json_string(sp_json_get(left_entry(g, part), "reason"), NULL);
    return r && !strncmp(r, prefix, strlen(prefix));
}

/* Exports fx as a plain .glb into tmp/name.glb and checks what the face directory reader made of it. */
static int export_fixture(const char *tmp, const char *name, const fixture *fx, unsigned want_bits, int inferred,
                          sp_export_stats *st, glb *g)
{
    char dir[1024], out[1024];
    snprintf(dir, sizeof(dir), "%s/%s", tmp, name);
    snprintf(out, sizeof(out), "%s/%s.glb", tmp, name);
    CHECK(make_fixture_spec(dir, fx) == 0);
    sp_face_asset a;
    CHECK(sp_face_dir_read(&a, dir) == 0);
    CHECK_MSG(a.left_out == want_bits && a.left_out_inferred == inferred, "%s: left_out 0x%x inferred %d", name,
              a.left_out, a.left_out_inferred);
    sp_face_asset_free(&a);
    sp_export_settings s;
    sp_export_default_settings(&s);
    s.draco = 0;
    memset(g, 0, sizeof(*g));
    int ret = sp_export_face(dir, out, &s, st);
    CHECK(ret == 0);
    return ret ? ret : glb_read(g, out);
}

static int has_env_file(const char *tmp, const char *name)
{
    char path[1024];
    snprintf(path, sizeof(path), "%s/%s.env.hdr", tmp, name);
    return exists(path);
}

/*
 * The manifest's left_out list decides, not zeros: maps and ks that are not
 * zero are still left out when listed, zeros are used when the list is empty,
 * and the fit's reasons reach the .glb. Old manifests fall back to inference.
 */
static void check_left_out(const char *tmp)
{
    sp_export_stats st;
    glb g;
    const sp_json *mat, *prim;
    fixture part = { .left_out = "[{\"part\":\"specular\",\"reason\":\"specular dropped: too few highlights\"},"
                                 "{\"part\":\"displacement\",\"reason\":\"refinement reverted\"},"
                                 "{\"part\":\"environment\",\"reason\":\"sky unresolved\"}]" };
    if (export_fixture(tmp, "part", &part, SP_FACE_LEFT_OUT_SPECULAR | SP_FACE_LEFT_OUT_DISPLACEMENT |
                       SP_FACE_LEFT_OUT_ENVIRONMENT, 0, &st, &g) == 0) {
        CHECK(!st.has_normal_map && !st.has_specular_texture && st.has_sun);
        mat = sp_json_at(sp_json_get(g.json, "materials"), 0);
        prim = sp_json_at(sp_json_get(sp_json_at(sp_json_get(g.json, "meshes"), 0), "primitives"), 0);
        CHECK(mat && !sp_json_get(mat, "normalTexture"));
        CHECK(prim && !sp_json_get(sp_json_get(prim, "attributes"), "TANGENT"));
        const sp_json *spec = sp_json_get(sp_json_get(mat, "extensions"), "KHR_materials_specular");
        CHECK(spec && !sp_json_get(spec, "specularTexture"));
        CHECK(sp_json_number(sp_json_get(spec, "specularFactor"), 1) == 0);
        CHECK(sp_json_get(sp_json_get(g.json, "extensions"), "KHR_lights_punctual") != NULL);
        CHECK(left_count(&g) == 3);
        CHECK(reason_is(&g, "specular", "specular dropped: too few highlights"));
        CHECK(reason_is(&g, "displacement", "refinement reverted") && reason_is(&g, "environment", "sky unresolved"));
        CHECK(sp_json_string(sp_json_get(left_entry(&g, "displacement"), "omitted"), NULL) != NULL);
        CHECK(sp_json_number(sp_json_get(extras(&g), "left_out_inferred"), -1) == 0.0);
        CHECK(!sp_json_get(extras(&g), "environment_map") && !has_env_file(tmp, "part"));
    }
    glb_free(&g);
    fixture nosun = { .left_out = "[{\"part\":\"sun\",\"reason\":\"overcast: the sun does not explain the shading\"},"
                                  "{\"part\":\"shadows\",\"reason\":\"no sun, so no cast shadows\"}]" };
    if (export_fixture(tmp, "nosun", &nosun, SP_FACE_LEFT_OUT_SUN | SP_FACE_LEFT_OUT_SHADOWS, 0, &st, &g) == 0) {
        CHECK(st.has_normal_map && st.has_specular_texture && !st.has_sun); /* the manifest's intensity is 2.5 */
        CHECK(!sp_json_get(g.json, "extensions") && !has_string(sp_json_get(g.json, "extensionsUsed"),
                                                               "KHR_lights_punctual"));
        CHECK(left_count(&g) == 2 && sp_json_get(g.json, "nodes") && sp_json_get(g.json, "nodes")->count == 2);
        CHECK(reason_is(&g, "sun", "overcast: the sun") && reason_is(&g, "shadows", "no sun, so"));
        CHECK(sp_json_get(extras(&g), "environment_map") && has_env_file(tmp, "nosun"));
    }
    glb_free(&g);
    fixture empty = { .flat = 1, .left_out = "[]" }; /* zeros, but the fit left nothing out: no inference */
    if (export_fixture(tmp, "empty", &empty, 0, 0, &st, &g) == 0) {
        CHECK(st.has_normal_map && st.has_specular_texture && !st.has_sun);
        CHECK(left_count(&g) == 1); /* the export's own: intensity 0 is no light */
        CHECK(reason_is(&g, "sun", "the sun's direction or intensity"));
    }
    glb_free(&g);
    fixture old = { .unobservable = 1 }; /* old manifest: bits from its flags */
    if (export_fixture(tmp, "old", &old, SP_FACE_LEFT_OUT_SUN | SP_FACE_LEFT_OUT_SHADOWS | SP_FACE_LEFT_OUT_ENVIRONMENT,
                       1, &st, &g) == 0) {
        CHECK(st.has_normal_map && st.has_specular_texture && !st.has_sun && !has_env_file(tmp, "old"));
        CHECK(sp_json_number(sp_json_get(extras(&g), "left_out_inferred"), -1) == 1.0);
        CHECK(reason_is(&g, "sun", "old manifest") && reason_is(&g, "environment", "old manifest"));
        CHECK(left_count(&g) == 3);
    }
    glb_free(&g);
    fixture all = { .flat = 1, .left_out = ALL_LEFT_OUT };
    if (export_fixture(tmp, "all", &all, 0x1f, 0, &st, &g) == 0) {
        CHECK(!st.has_normal_map && !st.has_specular_texture && !st.has_sun && !has_env_file(tmp, "all"));
        CHECK(left_count(&g) == 5 && reason_is(&g, "sun", "lighting unobservable"));
    }
    glb_free(&g);
}

static void check_mappings(void)
{
    CHECK_NEAR(sp_export_roughness(0.0), 1.0, 1e-12);
    CHECK_NEAR(sp_export_roughness(2.0), pow(0.5, 0.25), 1e-12);
    CHECK_NEAR(sp_export_roughness(98.0), sqrt(sqrt(0.02)), 1e-12);
    double prev = 2.0;
    const double s[] = { 0.0, 1.0, 10.0, 100.0, 1e4, 1e300, INFINITY };
    for (size_t i = 0; i < sizeof(s) / sizeof(s[0]); i++) {
        double r = sp_export_roughness(s[i]);
        CHECK(isfinite(r) && r > 0.0 && r <= 1.0 && r <= prev);
        prev = r;
    }
    CHECK(isfinite(sp_export_roughness(NAN)) && isfinite(sp_export_roughness(-5.0)));
    CHECK(sp_export_specular(NAN) == 0.0 && sp_export_specular(-1.0) == 0.0);
    CHECK_NEAR(sp_export_specular(0.02), 0.5, 1e-12);
    CHECK(sp_export_specular(1e300) == 1.0 && sp_export_specular(INFINITY) == 1.0);
}

static int count_prefix(const char *path, const char *prefix)
{
    size_t n;
    char *t = (char *)slurp(path, &n);
    if (!t)
        return -1;
    t[n] = 0;
    int c = 0;
    size_t pl = strlen(prefix);
    for (char *l = t; l && *l; l = strchr(l, '\n') ? strchr(l, '\n') + 1 : NULL)
        c += !strncmp(l, prefix, pl);
    free(t);
    return c;
}

static void check_formats(const char *tmp, const char *face, const char *flat)
{
    char out[4096];
    sp_export_settings s;
    sp_export_stats st;
    sp_face_asset a;
    CHECK(sp_face_dir_read(&a, face) == 0);
    glb g;
    sp_export_default_settings(&s);
    s.draco = 0;
    snprintf(out, sizeof(out), "%s/plain.glb", tmp);
    CHECK(sp_export_face(face, out, &s, &st) == 0 && st.has_normal_map && st.has_specular_texture && st.has_sun);
    if (glb_read(&g, out) == 0) {
        check_plain_geometry(&g, &a.mesh);
        check_material(&g, 1);
        CHECK(sp_json_get(g.json, "extensionsRequired") == NULL);
        const sp_json *tx = sp_json_get(extras(&g), "textures"); /* the default 512, and the fitted 64 said */
        CHECK(sp_json_number(sp_json_get(tx, "fitted_width"), 0) == 64 && sp_json_number(sp_json_get(tx, "width"), 0) == 512);
    }
    glb_free(&g);
    snprintf(out, sizeof(out), "%s/plain.env.hdr", tmp);
    size_t n;
    uint8_t *hdr = slurp(out, &n);
    CHECK(hdr && n > 16 * 32 * 4 && !memcmp(hdr, "#?RADIANCE\n", 11));
    free(hdr);
    snprintf(out, sizeof(out), "%s/flat.glb", tmp);
    CHECK(sp_export_face(flat, out, &s, &st) == 0 && !st.has_normal_map && !st.has_specular_texture && !st.has_sun);
    if (glb_read(&g, out) == 0)
        check_material(&g, 0);
    glb_free(&g);
    s.format = SP_EXPORT_OBJ;
    snprintf(out, sizeof(out), "%s/face.obj", tmp);
    CHECK(sp_export_face(face, out, &s, &st) == 0);
    CHECK(count_prefix(out, "v ") == (int)st.vertices && count_prefix(out, "f ") == (int)a.mesh.n_triangles);
    snprintf(out, sizeof(out), "%s/face.mtl", tmp);
    CHECK(count_prefix(out, "map_Kd face_albedo.png") == 1 && count_prefix(out, "norm face_normal.png") == 1);
    snprintf(out, sizeof(out), "%s/face_albedo.png", tmp);
    CHECK(exists(out));
    if (HAVE_DRACO) {
        sp_export_default_settings(&s);
        snprintf(out, sizeof(out), "%s/draco.glb", tmp);
        CHECK(sp_export_face(face, out, &s, &st) == 0 && st.triangles == a.mesh.n_triangles);
        CHECK(st.geometry_bytes > 0 && st.geometry_bytes < st.raw_geometry_bytes / 3);
        printf("geometry: %zu bytes raw, %zu bytes Draco; asset %zu bytes\n", st.raw_geometry_bytes,
               st.geometry_bytes, st.total_bytes);
        if (glb_read(&g, out) == 0) {
            CHECK(has_string(sp_json_get(g.json, "extensionsRequired"), "KHR_draco_mesh_compression"));
            const sp_json *acc = sp_json_at(sp_json_get(g.json, "accessors"), 3);
            CHECK(sp_json_number(sp_json_get(acc, "count"), 0) == 3.0 * a.mesh.n_triangles);
            check_material(&g, 1);
        }
        glb_free(&g);
        s.format = SP_EXPORT_DRC;
        snprintf(out, sizeof(out), "%s/face.drc", tmp);
        CHECK(sp_export_face(face, out, &s, &st) == 0);
        uint8_t *d = slurp(out, &n);
        CHECK(d && n == st.total_bytes && !memcmp(d, "DRACO", 5));
        free(d);
    } else {
        sp_export_default_settings(&s);
        CHECK(s.draco == 0);
        s.draco = 1;
        snprintf(out, sizeof(out), "%s/nodraco.glb", tmp);
        CHECK(sp_export_face(face, out, &s, &st) == SP_EDISABLED && !exists(out));
    }
    sp_face_asset_free(&a);
}

static void patch(const char *dir, const char *name, size_t off, const void *p, size_t n)
{
    char path[4096];
    snprintf(path, sizeof(path), "%s/%s", dir, name);
    FILE *f = fopen(path, "r+b");
    CHECK(f && fseek(f, (long)off, SEEK_SET) == 0 && fwrite(p, 1, n, f) == n);
    if (f)
        fclose(f);
}

static int run_cli(const char *exe, const char *args)
{
    char cmd[8192];
    snprintf(cmd, sizeof(cmd), "'%s' export %s >/dev/null 2>&1", exe, args);
    int st = system(cmd);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static void check_bad_input(const char *exe, const char *tmp, const char *face)
{
    char dir[512], out[512], path[1024], args[4096];
    sp_export_settings s;
    sp_export_default_settings(&s);
    s.draco = 0;
    snprintf(out, sizeof(out), "%s/bad.glb", tmp);
    const float nan = NAN;
    snprintf(dir, sizeof(dir), "%s/nan-mesh", tmp);
    CHECK(make_fixture(dir, 0) == 0);
    patch(dir, "mesh.bin", 24, &nan, 4);
    CHECK(sp_export_face(dir, out, &s, NULL) == SP_ECORRUPT && !exists(out));
    snprintf(args, sizeof(args), "'%s' -o '%s' --no-draco", dir, out);
    CHECK_EQ_INT(run_cli(exe, args), 2);
    snprintf(dir, sizeof(dir), "%s/nan-disp", tmp);
    CHECK(make_fixture(dir, 0) == 0);
    patch(dir, "displacement.f32", 400, &nan, 4);
    CHECK(sp_export_face(dir, out, &s, NULL) == SP_ECORRUPT && !exists(out));
    snprintf(dir, sizeof(dir), "%s/no-albedo", tmp);
    CHECK(make_fixture(dir, 0) == 0);
    snprintf(path, sizeof(path), "%s/albedo.f32", dir);
    CHECK(unlink(path) == 0);
    /* a part missing from a face directory is incomplete input (exit 2), not a file-system fault */
    CHECK(sp_export_face(dir, out, &s, NULL) == SP_ECORRUPT && !exists(out));
    snprintf(dir, sizeof(dir), "%s/no-mesh", tmp);
    CHECK(make_fixture(dir, 0) == 0);
    snprintf(path, sizeof(path), "%s/mesh.bin", dir);
    CHECK(unlink(path) == 0);
    snprintf(args, sizeof(args), "'%s' -o '%s' --no-draco", dir, out);
    CHECK_EQ_INT(run_cli(exe, args), 2);
    CHECK(!exists(out));
    snprintf(dir, sizeof(dir), "%s/no-such-face-dir", tmp);
    CHECK(sp_export_face(dir, out, &s, NULL) == -ENOENT && !exists(out));
    snprintf(dir, sizeof(dir), "%s/short-clusters", tmp);
    CHECK(make_fixture(dir, 0) == 0);
    snprintf(path, sizeof(path), "%s/clusters.u8", dir);
    CHECK(truncate(path, 100) == 0);
    CHECK(sp_export_face(dir, out, &s, NULL) == SP_ETRUNCATED && !exists(out));
    snprintf(args, sizeof(args), "'%s' -o '%s'", dir, out);
    CHECK_EQ_INT(run_cli(exe, args), 2);
    snprintf(path, sizeof(path), "%s/no-such-dir/x.glb", tmp);
    CHECK(sp_export_face(face, path, &s, NULL) == -ENOENT && !exists(path));
    snprintf(args, sizeof(args), "'%s' -o '%s' --no-draco", face, path);
    CHECK_EQ_INT(run_cli(exe, args), 3);
    CHECK_EQ_INT(run_cli(exe, ""), 1);
    snprintf(args, sizeof(args), "'%s' -o x --format fbx", face);
    CHECK_EQ_INT(run_cli(exe, args), 1);
    s.position_bits = 0;
    CHECK(sp_export_face(face, out, &s, NULL) == -EINVAL);
    CHECK(sp_export_face(NULL, out, &s, NULL) == -EINVAL && sp_export_face(face, NULL, &s, NULL) == -EINVAL);
    snprintf(args, sizeof(args), "ls -a '%s' | grep -q '\\.tmp\\.'", tmp);
    CHECK_MSG(system(args) != 0, "a temporary file was left behind in %s", tmp);
}

/* `sunprobe relight` exit code; stderr into err (for the message). */
static int run_relight(const char *exe, const char *dir, const char *out, const char *err)
{
    char cmd[8192];
    snprintf(cmd, sizeof(cmd), "'%s' relight '%s' --sun 30,40 --scale 1 -o '%s' >/dev/null 2>'%s'", exe, dir, out, err);
    int st = system(cmd);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static int file_contains(const char *path, const char *needle)
{
    size_t n;
    char *t = (char *)slurp(path, &n);
    int found = t && (t[n] = 0, strstr(t, needle) != NULL);
    free(t);
    return found;
}

/* Face directories that would render blank are refused when read, naming the file and field. */
static void check_relight_bad(const char *exe, const char *tmp)
{
    char dir[512], out[512], err[512], path[1024], args[2048];
    snprintf(out, sizeof(out), "%s/relit.png", tmp);
    snprintf(err, sizeof(err), "%s/relight.err", tmp);
    const float nan = NAN;
    snprintf(dir, sizeof(dir), "%s/relight-nan-disp", tmp);
    CHECK(make_fixture(dir, 0) == 0);
    CHECK_EQ_INT(run_relight(exe, dir, out, err), 0); /* the fixture itself renders */
    CHECK(exists(out) && unlink(out) == 0);
    patch(dir, "displacement.f32", 400, &nan, 4);
    CHECK_EQ_INT(run_relight(exe, dir, out, err), 2);
    CHECK(!exists(out) && file_contains(err, "displacement.f32: a value is NaN"));

    snprintf(dir, sizeof(dir), "%s/relight-no-tris", tmp);
    CHECK(make_fixture(dir, 0) == 0);
    snprintf(path, sizeof(path), "%s/mesh.bin", dir);
    uint32_t c[3];
    FILE *f = fopen(path, "rb");
    CHECK(f && fseek(f, 8, SEEK_SET) == 0 && fread(c, 4, 3, f) == 3);
    if (f)
        fclose(f);
    const uint32_t zero = 0;
    patch(dir, "mesh.bin", 16, &zero, 4);
    CHECK(truncate(path, (off_t)(20 + 4 * (3 * (size_t)c[0] + 2 * (size_t)c[1]))) == 0);
    CHECK_EQ_INT(run_relight(exe, dir, out, err), 2);
    CHECK(!exists(out) && file_contains(err, "mesh.bin: triangle count is 0"));

    snprintf(dir, sizeof(dir), "%s/relight-zero-quat", tmp);
    CHECK(make_fixture(dir, 0) == 0);
    const char *cams = "{\"frames\":[{\"width\":128,\"height\":128,\"intrinsics\":[150,150,64,64],"
                       "\"camera_to_world_wxyz\":[0,0,0,0]}]}\n";
    CHECK(write_file(dir, "cameras.json", cams, strlen(cams)) == 0);
    CHECK_EQ_INT(run_relight(exe, dir, out, err), 2);
    CHECK(!exists(out) && file_contains(err, "cameras.json: frames[0].camera_to_world_wxyz"));

    /* values the renderer would refuse are refused when read, with the field named (exit 2, not 1) */
    snprintf(dir, sizeof(dir), "%s/relight-far-cx", tmp);
    CHECK(make_fixture(dir, 0) == 0);
    const char *far = "{\"frames\":[{\"width\":128,\"height\":128,\"intrinsics\":[150,150,1e308,64],"
                      "\"camera_to_world_wxyz\":[1,0,0,0]}]}\n";
    CHECK(write_file(dir, "cameras.json", far, strlen(far)) == 0);
    CHECK_EQ_INT(run_relight(exe, dir, out, err), 2);
    CHECK(!exists(out) && file_contains(err, "cameras.json: frames[0].intrinsics"));
    snprintf(dir, sizeof(dir), "%s/relight-negative-ks", tmp);
    CHECK(make_fixture(dir, 0) == 0);
    {
        char mpath[4096], fixed[8300];
        snprintf(mpath, sizeof(mpath), "%s/manifest.json", dir);
        size_t len = 0;
        char *text = (char *)slurp(mpath, &len);
        char *ks = text ? (text[len] = 0, strstr(text, "\"ks\":[0.01")) : NULL;
        CHECK(ks != NULL);
        if (ks) {
            snprintf(fixed, sizeof(fixed), "%.*s\"ks\":[-1e308%s", (int)(ks - text), text, ks + strlen("\"ks\":[0.01"));
            CHECK(write_file(dir, "manifest.json", fixed, strlen(fixed)) == 0);
        }
        free(text);
    }
    CHECK_EQ_INT(run_relight(exe, dir, out, err), 2);
    CHECK(!exists(out) && file_contains(err, "manifest.json: specular.ks"));
    snprintf(args, sizeof(args), "'%s' -o '%s' --no-draco", dir, out);
    CHECK_EQ_INT(run_cli(exe, args), 2);
    unlink(err);
}

/* `sh -c` with the output size limited to 64 blocks (SIGXFSZ ignored, so writes fail with EFBIG); stderr to err. */
static int run_limited(const char *exe, const char *args, const char *err)
{
    char cmd[8192];
    snprintf(cmd, sizeof(cmd), "ulimit -f 64; trap '' XFSZ; exec '%s' export %s >/dev/null 2>'%s'", exe, args, err);
    int st = system(cmd);
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

static int same_bytes(const char *path, const uint8_t *want, size_t want_n)
{
    size_t n;
    uint8_t *d = slurp(path, &n);
    int same = d && n == want_n && !memcmp(d, want, n);
    free(d);
    return same;
}

/* An asset is committed whole or not at all: a failed write leaves the previous set as it was, and no new file. */
static void check_asset_atomic(const char *exe, const char *tmp, const char *face)
{
    char dir[512], glb_path[512], env_path[512], path[1024], args[4096], err[512];
    snprintf(err, sizeof(err), "%s/limited.err", tmp);
    snprintf(glb_path, sizeof(glb_path), "%s/set.glb", tmp);
    snprintf(env_path, sizeof(env_path), "%s/set.env.hdr", tmp);
    snprintf(args, sizeof(args), "'%s' -o '%s' --no-draco", face, glb_path);
    CHECK_EQ_INT(run_cli(exe, args), 0);
    size_t glb_n = 0, env_n = 0;
    uint8_t *glb0 = slurp(glb_path, &glb_n), *env0 = slurp(env_path, &env_n);
    CHECK(glb0 && env0 && glb_n > 64 * 512 && env_n < 64 * 512); /* the limit stops the .glb, not the .hdr */
    snprintf(dir, sizeof(dir), "%s/other-sky", tmp);
    CHECK(make_fixture(dir, 0) == 0);
    const float sky[4] = { 3.0f, 0.1f, 0.2f, 5.0f };
    patch(dir, "env.f32", 0, sky, sizeof(sky));
    snprintf(args, sizeof(args), "'%s' -o '%s' --no-draco", dir, glb_path);
    CHECK_EQ_INT(run_limited(exe, args, err), 3);
    /* the write's own error reaches the user (a full disk says so), not a generic I/O error */
    CHECK(file_contains(err, "File too large") && !file_contains(err, "Input/output error"));
    CHECK_MSG(same_bytes(glb_path, glb0, glb_n) && same_bytes(env_path, env0, env_n),
              "the previous .glb + .env.hdr were changed by a failed export");
    free(glb0);
    free(env0);
    static const char *const obj_files[] = { "fresh.obj", "fresh.mtl", "fresh_albedo.png", "fresh_normal.png",
                                             "fresh.env.hdr" };
    snprintf(args, sizeof(args), "'%s' -o '%s/fresh.obj' --format obj", dir, tmp);
    CHECK_EQ_INT(run_limited(exe, args, err), 3);
    CHECK(file_contains(err, "File too large") && !file_contains(err, "Input/output error"));
    unlink(err);
    for (size_t i = 0; i < sizeof(obj_files) / sizeof(obj_files[0]); i++) {
        snprintf(path, sizeof(path), "%s/%s", tmp, obj_files[i]);
        CHECK_MSG(!exists(path), "%s was left by a failed export", path);
    }
    snprintf(args, sizeof(args), "ls -a '%s' | grep -q '\\.\\(tmp\\|new\\|old\\)\\.'", tmp);
    CHECK_MSG(system(args) != 0, "a temporary file was left behind in %s", tmp);
}

/*
 * The Draco geometry is no larger than Debian's draco_encoder -cl 7 makes from the same mesh and bits (the
 * OBJ export of a face without a normal map: the same positions, normals and UVs, no tangents), at 11, 12
 * and 14 position bits (UVs 12, normals 10).
 */
static void check_draco_size_at(const char *exe, const char *tmp, const char *flat, int qp)
{
    char cmd[4096], path[1024];
    snprintf(cmd, sizeof(cmd), "'%s' export '%s' -o '%s/size.glb' --position-bits %d --stats > '%s/size.txt' 2>&1",
             exe, flat, tmp, qp, tmp);
    CHECK(system(cmd) == 0);
    snprintf(path, sizeof(path), "%s/size.txt", tmp);
    long raw = -1, ours = -1, normal_map = -1;
    FILE *f = fopen(path, "r");
    char line[256];
    while (f && fgets(line, sizeof(line), f)) {
        sscanf(line, "raw_geometry_bytes %ld", &raw);
        sscanf(line, "geometry_bytes %ld", &ours);
        sscanf(line, "normal_map %ld", &normal_map);
    }
    if (f)
        fclose(f);
    CHECK(raw > 0 && ours > 0 && normal_map == 0);
    if (ours == raw || system("command -v draco_encoder >/dev/null 2>&1") != 0) {
        printf("note: SKIP the Draco size check: %s\n", ours == raw ? "this build has no Draco" : "no draco_encoder");
        return;
    }
    snprintf(cmd, sizeof(cmd), "'%s' export '%s' -o '%s/size.obj' --format obj >/dev/null 2>&1 && draco_encoder -i "
             "'%s/size.obj' -o '%s/size-ref.drc' -qp %d -qt 12 -qn 10 -cl 7 >/dev/null 2>&1", exe, flat, tmp, tmp, tmp, qp);
    CHECK(system(cmd) == 0);
    snprintf(path, sizeof(path), "%s/size-ref.drc", tmp);
    struct stat st;
    long ref = stat(path, &st) == 0 ? (long)st.st_size : -1;
    printf("draco, %d position bits: %ld bytes against draco_encoder -cl 7's %ld (%.3fx)\n", qp, ours, ref,
           ref > 0 ? (double)ours / ref : 0.0);
    CHECK_MSG(ref > 0 && ours <= ref, "%d bits: Draco geometry %ld bytes, draco_encoder -cl 7 %ld", qp, ours, ref);
}

static void check_draco_size(const char *exe, const char *tmp, const char *flat)
{
    static const int bits[] = { 11, 12, 14 };
    for (size_t i = 0; i < sizeof(bits) / sizeof(bits[0]); i++)
        check_draco_size_at(exe, tmp, flat, bits[i]);
}

int main(int argc, char **argv)
{
    if (argc >= 4 && !strcmp(argv[2], "fixture")) { /* flat: a new manifest that left everything out */
        const char *kind = argc >= 5 ? argv[4] : "";
        fixture fx = { .flat = !strcmp(kind, "flat"), .ict = !strcmp(kind, "ict"), .facing = !strcmp(kind, "facing") };
        fx.left_out = fx.flat ? ALL_LEFT_OUT : NULL;
        return make_fixture_spec(argv[3], &fx) ? 1 : 0;
    }
    if (argc < 2) {
        fprintf(stderr, "usage: test_export SUNPROBE [fixture DIR [flat|ict|facing]]\n");
        return 99;
    }
    sp_log_set_level(SP_LOG_ERROR);
    char tmp[] = "/tmp/sp-export-XXXXXX", face[64], flat[64];
    CHECK(mkdtemp(tmp) != NULL);
    snprintf(face, sizeof(face), "%s/face", tmp);
    snprintf(flat, sizeof(flat), "%s/flat", tmp);
    CHECK(make_fixture(face, 0) == 0 && make_fixture(flat, 1) == 0);
    check_mappings();
    check_formats(tmp, face, flat);
    check_left_out(tmp);
    check_bad_input(argv[1], tmp, face);
    check_relight_bad(argv[1], tmp);
    check_asset_atomic(argv[1], tmp, face);
    check_draco_size(argv[1], tmp, flat);
    char cmd[128];
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", tmp);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", tmp);
    return check_exit();
}
