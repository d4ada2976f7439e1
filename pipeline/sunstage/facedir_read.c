/* SPDX-License-Identifier: MIT */
/* Reads a face directory (facedir.c) back into a self-contained asset for relighting; every size is checked. */
#include "sunprobe/sp_sunstage.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/file_util.h"
#include "common/json.h"

#define MOD "sunstage"
#define MAX_FILE ((size_t)1 << 30)
#define MAX_PIXELS 1e6     /* focal length and principal point bound, pixels */
#define MAX_KS 1000.0      /* as relight's --specular-scale bound */
#define MAX_SHININESS 1e6

/* Logs "dir/file: what" for content that would render as a blank image; returns SP_ECORRUPT. */
static int bad_field(const char *dir, const char *file, const char *what)
{
    sp_log(SP_LOG_ERROR, MOD, "%s/%s: %s", dir, file, what);
    return SP_ECORRUPT;
}

/* Reads dir/name into a malloc'd buffer (NUL appended); SP_ETRUNCATED if want > 0 and the size differs. */
static int read_file(const char *dir, const char *name, size_t want, char **out, size_t *size)
{
    char path[4096];
    int ret = sp_path_join(path, sizeof(path), dir, name);
    if (ret)
        return ret;
    void *buf = NULL;
    size_t len = 0;
    ret = sp_read_whole_file(path, MAX_FILE, &buf, &len);
    if (ret == -EFBIG) {
        sp_log(SP_LOG_ERROR, MOD, "%s is larger than %zu bytes", path, MAX_FILE);
        return -EIO;
    }
    if (ret) {
        sp_log(SP_LOG_ERROR, MOD, "cannot read %s: %s", path, sp_strerror(ret));
        return ret;
    }
    if (want && len != want) {
        sp_log(SP_LOG_ERROR, MOD, "%s has %zu bytes, expected %zu", path, len, want);
        free(buf);
        return SP_ETRUNCATED;
    }
    *out = buf;
    if (size)
        *size = len;
    return 0;
}

static int read_mesh(sp_face_asset *a, const char *dir)
{
    char *buf;
    size_t size;
    int ret = read_file(dir, "mesh.bin", 0, &buf, &size);
    if (ret)
        return ret;
    uint32_t c[3];
    if (size < 20 || memcmp(buf, "SPFMESH1", 8)) {
        free(buf);
        return SP_EFORMAT;
    }
    memcpy(c, buf + 8, 12);
    size_t need = 20 + 4 * (3 * (size_t)c[0] + 2 * (size_t)c[1] + 6 * (size_t)c[2]);
    if (c[0] > 10000000 || c[1] > 10000000 || c[2] > 10000000 || need != size ||
        (ret = sp_mesh_alloc(&a->mesh, c[0], c[1], c[2]))) {
        free(buf);
        if (ret)
            sp_log(SP_LOG_ERROR, MOD, "%s/mesh.bin: %s", dir, sp_strerror(ret));
        return ret ? ret : SP_ECORRUPT;
    }
    const char *p = buf + 20;
    memcpy(a->mesh.positions, p, 12 * (size_t)c[0]);
    memcpy(a->mesh.uvs, p += 12 * (size_t)c[0], 8 * (size_t)c[1]);
    memcpy(a->mesh.tri_vertices, p += 8 * (size_t)c[1], 12 * (size_t)c[2]);
    memcpy(a->mesh.tri_uvs, p + 12 * (size_t)c[2], 12 * (size_t)c[2]);
    free(buf);
    if (c[2] == 0)
        return bad_field(dir, "mesh.bin", "triangle count is 0");
    ret = sp_mesh_validate(&a->mesh);
    return ret == SP_ECORRUPT ? bad_field(dir, "mesh.bin", "a position or UV is NaN or Inf, or an index is out of range")
                              : ret;
}

static int read_maps(sp_face_asset *a, const char *dir, const sp_json *tex)
{
    a->tex_width = (int)sp_json_number(sp_json_get(tex, "width"), 0);
    a->tex_height = (int)sp_json_number(sp_json_get(tex, "height"), 0);
    a->cluster_width = (int)sp_json_number(sp_json_get(tex, "cluster_width"), 0);
    a->cluster_height = (int)sp_json_number(sp_json_get(tex, "cluster_height"), 0);
    if (a->tex_width < 1 || a->tex_height < 1 || a->tex_width > 16384 || a->tex_height > 16384 ||
        a->cluster_width < 1 || a->cluster_height < 1 || a->cluster_width > 16384 || a->cluster_height > 16384)
        return SP_ECORRUPT;
    size_t nt = (size_t)a->tex_width * (size_t)a->tex_height;
    char *buf;
    int ret = read_file(dir, "albedo.f32", nt * 12, &buf, NULL);
    if (ret)
        return ret;
    a->albedo = (float *)(void *)buf;
    if ((ret = read_file(dir, "displacement.f32", nt * 4, &buf, NULL)))
        return ret;
    a->displacement = (float *)(void *)buf;
    if ((ret = read_file(dir, "clusters.u8", (size_t)a->cluster_width * (size_t)a->cluster_height, &buf, NULL)))
        return ret;
    a->clusters = (uint8_t *)buf;
    if ((ret = read_file(dir, "env.f32", sizeof(a->env), &buf, NULL)))
        return ret;
    memcpy(a->env, buf, sizeof(a->env));
    free(buf);
    for (size_t i = 0; i < nt * 3; i++)
        if (!isfinite(a->albedo[i]))
            return bad_field(dir, "albedo.f32", "a value is NaN or Inf");
    for (size_t i = 0; i < nt; i++)
        if (!isfinite(a->displacement[i]))
            return bad_field(dir, "displacement.f32", "a value is NaN or Inf");
    return 0;
}

static int read_camera(sp_face_asset *a, const char *dir)
{
    char *buf, err[128] = "";
    size_t size;
    int ret = read_file(dir, "cameras.json", 0, &buf, &size);
    if (ret)
        return ret;
    sp_json *root = NULL;
    ret = sp_json_parse(buf, size, &root, err, sizeof(err));
    free(buf);
    if (ret) {
        sp_log(SP_LOG_ERROR, MOD, "%s/cameras.json: %s", dir, err[0] ? err : sp_strerror(ret));
        return ret;
    }
    const sp_json *f = sp_json_at(sp_json_get(root, "frames"), 0);
    double k[4], q[4];
    if (!f || sp_json_numbers(sp_json_get(f, "intrinsics"), k, 4) != 4 ||
        sp_json_numbers(sp_json_get(f, "camera_to_world_wxyz"), q, 4) != 4) {
        sp_json_free(root);
        return SP_ECORRUPT;
    }
    a->width = (int)sp_json_number(sp_json_get(f, "width"), 0);
    a->height = (int)sp_json_number(sp_json_get(f, "height"), 0);
    sp_json_free(root);
    if (a->width < 1 || a->height < 1 || a->width > 16384 || a->height > 16384)
        return bad_field(dir, "cameras.json", "frames[0].width/height is not in 1..16384");
    /* a focal length or principal point beyond a million pixels is no camera a face was seen with */
    if (!(k[0] > 0.0 && k[0] < MAX_PIXELS && k[1] > 0.0 && k[1] < MAX_PIXELS) || !(fabs(k[2]) < MAX_PIXELS) ||
        !(fabs(k[3]) < MAX_PIXELS))
        return bad_field(dir, "cameras.json", "frames[0].intrinsics: fx, fy must be in (0, 1e6), |cx|, |cy| below 1e6");
    double qn = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(qn > 1e-9 && qn < 1e150)) /* zero, NaN or Inf: no rotation to normalise */
        return bad_field(dir, "cameras.json", "frames[0].camera_to_world_wxyz is zero, NaN or Inf");
    double R[9];
    sp_quat_to_matrix(sp_quat_normalize((sp_quat){ q[0], q[1], q[2], q[3] }), R);
    a->camera.fx = k[0];
    a->camera.fy = k[1];
    a->camera.cx = k[2];
    a->camera.cy = k[3];
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            a->camera.R[r * 3 + c] = R[c * 3 + r];
    a->camera.t[0] = a->camera.t[1] = a->camera.t[2] = 0.0;
    return 0;
}

static int read_manifest(sp_face_asset *a, const char *dir, sp_json **root)
{
    char *buf, err[128] = "";
    size_t size;
    int ret = read_file(dir, "manifest.json", 0, &buf, &size);
    if (ret)
        return ret;
    ret = sp_json_parse(buf, size, root, err, sizeof(err));
    free(buf);
    if (ret) { /* out of memory leaves err empty */
        sp_log(SP_LOG_ERROR, MOD, "%s/manifest.json: %s", dir, err[0] ? err : sp_strerror(ret));
        return ret;
    }
    if (strcmp(sp_json_string(sp_json_get(*root, "format"), ""), "sunprobe-face"))
        return SP_EFORMAT;
    if (sp_json_number(sp_json_get(*root, "version"), 0) > 1)
        return SP_EVERSION;
    const sp_json *spec = sp_json_get(*root, "specular"), *light = sp_json_get(*root, "lighting");
    if (sp_json_numbers(sp_json_get(spec, "ks"), a->ks, SP_RENDER_CLUSTERS) != SP_RENDER_CLUSTERS ||
        sp_json_numbers(sp_json_get(spec, "shininess"), a->shininess, SP_RENDER_CLUSTERS) != SP_RENDER_CLUSTERS ||
        sp_json_numbers(sp_json_get(light, "sun_direction"), a->sun_dir, 3) != 3)
        return SP_ECORRUPT;
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++) {
        if (!(a->ks[k] >= 0.0 && a->ks[k] <= MAX_KS))
            return bad_field(dir, "manifest.json", "specular.ks: each must be in [0, 1000]");
        if (!(a->shininess[k] > 0.0 && a->shininess[k] <= MAX_SHININESS))
            return bad_field(dir, "manifest.json", "specular.shininess: each must be in (0, 1e6]");
    }
    a->sun_intensity = sp_json_number(sp_json_get(light, "sun_intensity"), 0.0);
    if (!(a->sun_intensity >= 0.0 && a->sun_intensity < 1e30))
        return bad_field(dir, "manifest.json", "lighting.sun_intensity must be finite and >= 0");
    if (!(isfinite(a->sun_dir[0]) && isfinite(a->sun_dir[1]) && isfinite(a->sun_dir[2])))
        return bad_field(dir, "manifest.json", "lighting.sun_direction must be finite");
    return 0;
}

/* "left_out" of the manifest into bits; 0 when the manifest has the list, SP_ENODATA for an old manifest. */
static int read_left_out(sp_face_asset *a, const sp_json *root)
{
    static const char *names[] = { "sun", "shadows", "specular", "displacement", "environment" };
    const sp_json *list = sp_json_get(root, "left_out");
    if (!list)
        return SP_ENODATA;
    const sp_json *e;
    for (size_t i = 0; (e = sp_json_at(list, i)); i++) {
        const char *part = sp_json_string(sp_json_get(e, "part"), "");
        for (unsigned k = 0; k < sizeof(names) / sizeof(names[0]); k++)
            if (!strcmp(part, names[k]))
                a->left_out |= 1u << k;
    }
    return 0;
}

/*
 * Old manifests (no "left_out" list): what was left out, from the flags they
 * did carry (sun_dropped, lighting_unobservable, specular left_out/dropped/
 * disabled) and from zeros (no sun intensity, ks = 0, flat displacement).
 */
static void infer_left_out(sp_face_asset *a, const sp_json *root)
{
    const sp_json *light = sp_json_get(root, "lighting"), *spec = sp_json_get(root, "specular");
    int unobservable = sp_json_number(sp_json_get(light, "lighting_unobservable"), 0.0) != 0.0;
    int dropped = sp_json_number(sp_json_get(light, "sun_dropped"), 0.0) != 0.0;
    static const char *spec_keys[] = { "left_out", "dropped", "disabled" };
    int spec_off = 0;
    for (size_t k = 0; k < sizeof(spec_keys) / sizeof(spec_keys[0]); k++)
        spec_off |= sp_json_number(sp_json_get(spec, spec_keys[k]), 0.0) != 0.0;
    double ks = 0.0;
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++)
        ks += a->ks[k] > 0.0 ? a->ks[k] : 0.0;
    if (unobservable || dropped || !(a->sun_intensity > 0.0))
        a->left_out |= SP_FACE_LEFT_OUT_SUN | SP_FACE_LEFT_OUT_SHADOWS;
    if (unobservable)
        a->left_out |= SP_FACE_LEFT_OUT_ENVIRONMENT;
    if (spec_off || !(ks > 0.0))
        a->left_out |= SP_FACE_LEFT_OUT_SPECULAR;
    int flat = 1;
    for (size_t i = 0; flat && i < (size_t)a->tex_width * (size_t)a->tex_height; i++)
        flat = a->displacement[i] == 0.0f;
    if (flat)
        a->left_out |= SP_FACE_LEFT_OUT_DISPLACEMENT;
    a->left_out_inferred = 1;
}

int sp_face_dir_read(sp_face_asset *a, const char *dir)
{
    if (!a || !dir)
        return -EINVAL;
    memset(a, 0, sizeof(*a));
    sp_json *root = NULL;
    int ret = read_manifest(a, dir, &root);
    if (!ret)
        ret = read_maps(a, dir, sp_json_get(root, "textures"));
    if (!ret && read_left_out(a, root))
        infer_left_out(a, root);
    sp_json_free(root);
    if (!ret)
        ret = read_mesh(a, dir);
    if (!ret)
        ret = read_camera(a, dir);
    if (ret)
        sp_face_asset_free(a);
    return ret;
}

void sp_face_asset_free(sp_face_asset *a)
{
    if (!a)
        return;
    sp_mesh_free(&a->mesh);
    free(a->albedo);
    free(a->displacement);
    free(a->clusters);
    memset(a, 0, sizeof(*a));
}
