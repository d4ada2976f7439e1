/* SPDX-License-Identifier: MIT */
/*
 * sp_export_face: reads a face directory and writes a binary glTF 2.0 asset
 * (JSON + one BIN chunk holding geometry or its Draco buffer and the images),
 * or hands over to the OBJ / Draco writers. Mappings: export/EXPORT.md.
 */
#include "sunprobe/sp_export.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/atomic_file.h"
#include "common/file_set.h"
#include "common/file_util.h"
#include "common/jpeg.h"
#include "common/json.h"
#include "export/draco_shim.h"
#include "export/gltf_internal.h"
#include "export/oiio_shim.h"
#include "export/png.h"
#include "sp_config.h"

#define MOD "export"

void sp_export_default_settings(sp_export_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->format = SP_EXPORT_GLB;
    s->draco = HAVE_DRACO ? 1 : 0;
    s->jpeg_quality = 90;
    s->position_bits = 14;
    s->normal_bits = 10;
    s->uv_bits = 12;
    s->texture_size = 512;
    s->write_env = 1;
}

/* The binary chunk under construction: 4-byte aligned views. */
typedef struct bin_buf {
    uint8_t *data;
    size_t len, cap;
    int n_views;
    sp_strbuf views; /* JSON of "bufferViews" entries */
} bin_buf;

/* Appends a buffer view; returns its index or a negative error. target 0 = none. */
static int bin_add(bin_buf *b, const void *p, size_t n, int target)
{
    size_t start = (b->len + 3) & ~(size_t)3;
    if (start + n > b->cap) {
        size_t cap = (start + n) * 2 + 1024;
        uint8_t *d = realloc(b->data, cap);
        if (!d)
            return -ENOMEM;
        b->data = d;
        b->cap = cap;
    }
    memset(b->data + b->len, 0, start - b->len);
    memcpy(b->data + start, p, n);
    b->len = start + n;
    sp_strbuf_printf(&b->views, "%s{\"buffer\":0,\"byteOffset\":%zu,\"byteLength\":%zu", b->n_views ? "," : "",
                     start, n);
    if (target)
        sp_strbuf_printf(&b->views, ",\"target\":%d", target);
    sp_strbuf_printf(&b->views, "}");
    return b->n_views++;
}

/*
 * Photometric scale (EXPORT.md, "Photometry"): the fit's radiance is relative to
 * the capture's exposure, so the export assumes a camera exposed for direct sun
 * (EV100 15, "sunny 16"), whose saturation luminance 1.2 * 2^EV100 cd/m^2 is the
 * fit's display value 1. Sun (lux) and sky (cd/m^2) share the factor.
 */
#define EV100 15.0
#define LUX_PER_FIT_UNIT (1.2 * 32768.0)
#define BLENDER_LM_PER_W 683.0

/* The parts a face can leave out, in SP_FACE_LEFT_OUT_* bit order. */
#define N_PARTS 5
static const char *const part_names[N_PARTS] = { "sun", "shadows", "specular", "displacement", "environment" };

typedef struct export_ctx {
    const sp_export_settings *set;
    const char *face_dir, *out_path;
    sp_face_asset asset;
    sp_gltf_placement place; /* fit world -> exported scene */
    sp_gltf_geom geom;
    sp_gltf_morphs morphs; /* expression morph targets (plain GLB only) */
    sp_export_textures tex;
    char *reasons[N_PARTS]; /* the manifest's reason per left-out part (owned), NULL if none */
    sp_strbuf left_out;     /* JSON array body of what was left out, why, and what the export omitted */
    char env_name[256];     /* basename of the .hdr beside the output, "" if none */
    int env_exr;            /* the map was also written as STEM.env.exr */
    sp_file_set files;      /* the asset's files, committed together at the end */
    sp_export_stats st;
} export_ctx;

/* Appends {"part":..., "reason":..., "omitted":...} to the extras' left_out list. */
static void note_left_out(export_ctx *c, const char *part, const char *reason, const char *omitted)
{
    sp_strbuf_printf(&c->left_out, "%s{\"part\":", c->left_out.len ? "," : "");
    sp_strbuf_json_string(&c->left_out, part);
    sp_strbuf_printf(&c->left_out, ",\"reason\":");
    sp_strbuf_json_string(&c->left_out, reason);
    sp_strbuf_printf(&c->left_out, ",\"omitted\":");
    sp_strbuf_json_string(&c->left_out, omitted);
    sp_strbuf_printf(&c->left_out, "}");
}

/* The fit's reasons from the manifest's "left_out" list (the reader keeps only the bits). */
static int read_reasons(export_ctx *c)
{
    char path[4096], err[128];
    int ret = sp_path_join(path, sizeof(path), c->face_dir, "manifest.json");
    void *buf = NULL;
    size_t n = 0;
    if (ret || (ret = sp_read_whole_file(path, (size_t)1 << 24, &buf, &n)))
        return ret == -EFBIG ? SP_ECORRUPT : ret;
    sp_json *root = NULL;
    ret = sp_json_parse(buf, n, &root, err, sizeof(err));
    free(buf);
    if (ret)
        return ret;
    const sp_json *list = sp_json_get(root, "left_out"), *e;
    for (size_t i = 0; (e = sp_json_at(list, i)); i++) {
        const char *part = sp_json_string(sp_json_get(e, "part"), "");
        const char *why = sp_json_string(sp_json_get(e, "reason"), "");
        for (int k = 0; k < N_PARTS; k++)
            if (!strcmp(part, part_names[k]) && !c->reasons[k] && why[0] && !(c->reasons[k] = strdup(why)))
                ret = -ENOMEM;
    }
    sp_json_free(root);
    return ret;
}

/* Why part k is out: the fit's words, or what the reader inferred for an old manifest. */
static const char *reason_for(const export_ctx *c, int k)
{
    static const char *const inferred[N_PARTS] = {
        "old manifest without a left_out list: inferred from sun_dropped, lighting_unobservable or zero intensity",
        "old manifest without a left_out list: no sun, so no cast shadows",
        "old manifest without a left_out list: inferred from a specular flag or ks = 0 in every cluster",
        "old manifest without a left_out list: inferred from an all-zero displacement map",
        "old manifest without a left_out list: inferred from lighting_unobservable",
    };
    if (c->reasons[k])
        return c->reasons[k];
    return c->asset.left_out_inferred ? inferred[k] : "left out by the fit (no reason given)";
}

static int embed_image(bin_buf *b, const sp_export_image *im, int jpeg, int quality, sp_strbuf *images)
{
    uint8_t *data = NULL;
    size_t n = 0;
    int ret;
    sp_jpeg_buffer jb = { 0 };
    if (jpeg) {
        ret = sp_jpeg_encode_rgb24(im->pixels, (uint32_t)im->width, (uint32_t)im->height,
                                   (uint32_t)(im->width * 3), quality, &jb);
        data = jb.data;
        n = jb.size;
    } else {
        ret = sp_png_encode(im->pixels, (uint32_t)im->width, (uint32_t)im->height,
                            (uint32_t)(im->width * im->channels), im->channels, &data, &n);
    }
    int view = ret ? ret : bin_add(b, data, n, 0);
    if (jpeg)
        sp_jpeg_buffer_free(&jb);
    else
        free(data);
    if (view < 0)
        return view;
    sp_strbuf_printf(images, "%s{\"bufferView\":%d,\"mimeType\":\"image/%s\"}", images->len ? "," : "", view,
                     jpeg ? "jpeg" : "png");
    return 0;
}

/*
 * One primitive's accessors from acc index first on: POSITION, NORMAL, TEXCOORD_0, indices, then
 * TANGENT when the skin has a normal map; its JSON (attributes, Draco extension) goes to prim_json.
 * Returns the number of accessors added or a negative error.
 */
static int add_geometry(export_ctx *c, bin_buf *b, sp_strbuf *acc, int first, const sp_gltf_geom *g, int tangents,
                        sp_strbuf *prim_json)
{
    uint32_t nv = g->n_vertices, ni = g->n_triangles * 3;
    int n_acc = tangents ? 5 : 4;
    int views[5] = { -1, -1, -1, -1, -1 };
    char draco_ext[320] = "";
    c->st.raw_geometry_bytes += (size_t)nv * (tangents ? 48 : 32) + (size_t)ni * 4;
    if (c->set->draco) {
#if HAVE_DRACO
        sp_draco_out d;
        int ret = sp_draco_encode_mesh(g->positions, g->normals, g->uvs, tangents ? g->tangents : NULL, nv,
                                       g->indices, g->n_triangles, c->set->position_bits, c->set->normal_bits,
                                       c->set->uv_bits, c->morphs.n_targets > 0, &d);
        int view = ret ? ret : bin_add(b, d.data, d.size, 0);
        if (view < 0) {
            sp_draco_out_free(&d);
            return view;
        }
        nv = d.n_points;
        ni = d.n_faces * 3;
        c->st.geometry_bytes += d.size;
        char tan[32] = "";
        if (tangents)
            snprintf(tan, sizeof(tan), ",\"TANGENT\":%d", d.id_tangent);
        snprintf(draco_ext, sizeof(draco_ext), "\"extensions\":{\"KHR_draco_mesh_compression\":{\"bufferView\":%d,"
                                               "\"attributes\":{\"POSITION\":%d,\"NORMAL\":%d,\"TEXCOORD_0\":%d%s}}},",
                 view, d.id_position, d.id_normal, d.id_uv, tan);
        sp_draco_out_free(&d);
#else
        return SP_EDISABLED;
#endif
    } else {
        views[0] = bin_add(b, g->positions, (size_t)nv * 12, 34962);
        views[1] = bin_add(b, g->normals, (size_t)nv * 12, 34962);
        views[2] = bin_add(b, g->uvs, (size_t)nv * 8, 34962);
        views[3] = bin_add(b, g->indices, (size_t)ni * 4, 34963);
        views[4] = tangents ? bin_add(b, g->tangents, (size_t)nv * 16, 34962) : 0;
        for (int k = 0; k < 5; k++)
            if (views[k] < 0)
                return views[k];
        c->st.geometry_bytes += (size_t)nv * (tangents ? 48 : 32) + (size_t)ni * 4;
    }
    c->st.vertices += nv;
    c->st.triangles += ni / 3;
    static const char *types[5] = { "VEC3", "VEC3", "VEC2", "SCALAR", "VEC4" };
    for (int k = 0; k < n_acc; k++) {
        sp_strbuf_printf(acc, "%s{", first + k ? "," : "");
        if (views[k] >= 0)
            sp_strbuf_printf(acc, "\"bufferView\":%d,", views[k]);
        sp_strbuf_printf(acc, "\"componentType\":%d,\"count\":%u,\"type\":\"%s\"", k == 3 ? 5125 : 5126,
                         k == 3 ? ni : nv, types[k]);
        if (k == 0)
            sp_strbuf_printf(acc, ",\"min\":[%.9g,%.9g,%.9g],\"max\":[%.9g,%.9g,%.9g]", (double)g->min[0],
                             (double)g->min[1], (double)g->min[2], (double)g->max[0], (double)g->max[1],
                             (double)g->max[2]);
        sp_strbuf_printf(acc, "}");
    }
    sp_strbuf_printf(prim_json, "{%s\"attributes\":{\"POSITION\":%d,\"NORMAL\":%d,\"TEXCOORD_0\":%d", draco_ext, first,
                     first + 1, first + 2);
    if (tangents)
        sp_strbuf_printf(prim_json, ",\"TANGENT\":%d", first + 4);
    sp_strbuf_printf(prim_json, "},\"indices\":%d", first + 3);
    return n_acc;
}

/*
 * Morph targets of one primitive from accessor first on: one sparse POSITION accessor per expression (only
 * the vertices it moves; the rest are zero), appended to acc; prim gets the primitive's "targets".
 * Returns the number of accessors added or a negative error.
 */
static int add_morphs(export_ctx *c, bin_buf *b, sp_strbuf *acc, int first, const sp_gltf_prim *pr, sp_strbuf *prim)
{
    const sp_gltf_morphs *mo = &c->morphs;
    uint32_t nv = pr->geom->n_vertices;
    uint32_t *idx = malloc((size_t)nv * sizeof(uint32_t) + 1);
    float *val = malloc((size_t)nv * 3 * sizeof(float) + 1);
    int ret = idx && val ? 0 : -ENOMEM;
    for (uint32_t k = 0; !ret && pr->deltas && k < mo->n_targets; k++) {
        const float *d = pr->deltas + (size_t)k * nv * 3;
        float lo[3] = { 0, 0, 0 }, hi[3] = { 0, 0, 0 };
        uint32_t n = 0;
        for (uint32_t i = 0; i < nv; i++) {
            if (d[i * 3] == 0.0f && d[i * 3 + 1] == 0.0f && d[i * 3 + 2] == 0.0f && !(n == 0 && i == nv - 1))
                continue; /* sparse: unlisted vertices do not move (at least one entry is required) */
            idx[n] = i;
            for (int a = 0; a < 3; a++) {
                val[n * 3 + a] = d[i * 3 + a];
                lo[a] = fminf(lo[a], d[i * 3 + a]);
                hi[a] = fmaxf(hi[a], d[i * 3 + a]);
            }
            n++;
        }
        int vi = bin_add(b, idx, (size_t)n * 4, 0), vv = vi < 0 ? vi : bin_add(b, val, (size_t)n * 12, 0);
        if (vv < 0) {
            ret = vv;
            break;
        }
        sp_strbuf_printf(acc, ",{\"componentType\":5126,\"count\":%u,\"type\":\"VEC3\",\"min\":[%.9g,%.9g,%.9g],"
                              "\"max\":[%.9g,%.9g,%.9g],\"sparse\":{\"count\":%u,\"indices\":{\"bufferView\":%d,"
                              "\"componentType\":5125},\"values\":{\"bufferView\":%d}}}",
                         nv, (double)lo[0], (double)lo[1], (double)lo[2], (double)hi[0], (double)hi[1], (double)hi[2],
                         n, vi, vv);
        sp_strbuf_printf(prim, "%s{\"POSITION\":%d}", k ? "," : ",\"targets\":[", first + (int)k);
        c->st.morph_bytes += (size_t)n * 16;
    }
    free(idx);
    free(val);
    if (ret || !mo->n_targets || !pr->deltas)
        return ret;
    sp_strbuf_printf(prim, "]");
    return (int)mo->n_targets;
}

/* The mesh's weights and target names (what three.js and Blender read). */
static void add_target_names(const sp_gltf_morphs *mo, sp_strbuf *mesh)
{
    if (!mo->n_targets)
        return;
    sp_strbuf_printf(mesh, ",\"weights\":[");
    for (uint32_t k = 0; k < mo->n_targets; k++)
        sp_strbuf_printf(mesh, "%s0", k ? "," : "");
    sp_strbuf_printf(mesh, "],\"extras\":{\"targetNames\":[");
    for (uint32_t k = 0; k < mo->n_targets; k++) {
        sp_strbuf_printf(mesh, k ? "," : "");
        sp_strbuf_json_string(mesh, mo->names[k]);
    }
    sp_strbuf_printf(mesh, "],\"sunprobe\":{\"fitted_expression\":[");
    for (uint32_t k = 0; k < mo->n_targets; k++) {
        sp_strbuf_printf(mesh, k ? "," : "");
        sp_strbuf_json_number(mesh, mo->fitted[k]);
    }
    sp_strbuf_printf(mesh, "],\"note\":\"the mesh carries keyframe 0's fitted expression; weights add to it\"}}");
}

/* Every primitive of the head: geometry, targets, material i. */
static int add_primitives(export_ctx *c, bin_buf *b, sp_strbuf *acc, sp_strbuf *prims)
{
    int first = 0;
    for (uint32_t i = 0; i < c->morphs.n_prims; i++) {
        const sp_gltf_prim *pr = &c->morphs.prims[i];
        sp_strbuf_printf(prims, i ? "," : "");
        int n = add_geometry(c, b, acc, first, pr->geom, i == 0 && c->tex.has_normal, prims);
        int m = n < 0 ? n : add_morphs(c, b, acc, first + n, pr, prims);
        if (m < 0)
            return m;
        sp_strbuf_printf(prims, ",\"material\":%u,\"mode\":4}", i);
        first += n + m;
    }
    return 0;
}

static int add_material(export_ctx *c, bin_buf *b, sp_strbuf *mat, sp_strbuf *texs, sp_strbuf *images)
{
    const sp_export_textures *t = &c->tex;
    int ret = embed_image(b, &t->albedo, c->set->jpeg, c->set->jpeg_quality, images);
    int n_img = 1, spec_i = -1, norm_i = -1;
    if (!ret && t->has_specular && !(ret = embed_image(b, &t->spec_rough, 0, 0, images)))
        spec_i = n_img++;
    if (!ret && t->has_normal && !(ret = embed_image(b, &t->normal, 0, 0, images)))
        norm_i = n_img++;
    if (ret)
        return ret;
    for (int i = 0; i < n_img; i++)
        sp_strbuf_printf(texs, "%s{\"sampler\":0,\"source\":%d}", i ? "," : "", i);
    sp_strbuf_printf(mat, "{\"name\":\"skin\",\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0},"
                          "\"metallicFactor\":0,\"roughnessFactor\":1");
    if (spec_i >= 0)
        sp_strbuf_printf(mat, ",\"metallicRoughnessTexture\":{\"index\":%d}", spec_i);
    sp_strbuf_printf(mat, "}");
    if (norm_i >= 0)
        sp_strbuf_printf(mat, ",\"normalTexture\":{\"index\":%d}", norm_i);
    if (spec_i >= 0)
        sp_strbuf_printf(mat, ",\"extensions\":{\"KHR_materials_specular\":{\"specularTexture\":{\"index\":%d}}}",
                         spec_i);
    else
        sp_strbuf_printf(mat, ",\"extensions\":{\"KHR_materials_specular\":{\"specularFactor\":0}}");
    sp_strbuf_printf(mat, "}");
    for (uint32_t i = 1; i < c->morphs.n_prims; i++) { /* eyes and mouth: constant colours (EXPORT.md) */
        const sp_gltf_prim *pr = &c->morphs.prims[i];
        sp_strbuf_printf(mat, ",{\"name\":");
        sp_strbuf_json_string(mat, pr->name);
        sp_strbuf_printf(mat, ",\"pbrMetallicRoughness\":{\"baseColorFactor\":[%.6g,%.6g,%.6g,1],\"metallicFactor\":0,"
                              "\"roughnessFactor\":%.6g},\"extras\":{\"sunprobe\":{\"colour\":",
                         (double)pr->colour[0], (double)pr->colour[1], (double)pr->colour[2], (double)pr->roughness);
        sp_strbuf_json_string(mat, pr->note);
        sp_strbuf_printf(mat, "}}}");
    }
    return 0;
}

/* Quaternion (x, y, z, w) turning the node's +z onto d (unit), so the light shines along -d. */
static void rotation_to(const double d[3], double q[4])
{
    double w = 1.0 + d[2];
    if (w < 1e-9) {
        q[0] = 1.0, q[1] = q[2] = q[3] = 0.0;
        return;
    }
    double v[4] = { -d[1], d[0], 0.0, w }, n = sqrt(v[0] * v[0] + v[1] * v[1] + w * w);
    for (int k = 0; k < 4; k++)
        q[k] = v[k] / n;
}

static int sun_direction(const export_ctx *c, double g[3])
{
    const double *s = c->asset.sun_dir;
    double n = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
    if ((c->asset.left_out & SP_FACE_LEFT_OUT_SUN) || !(c->asset.sun_intensity > 0.0) ||
        !isfinite(c->asset.sun_intensity) || !(n > 1e-12) || !isfinite(n))
        return 0;
    double w[3] = { s[0] / n, s[1] / n, s[2] / n };
    sp_gltf_place(&c->place, w, g, 0);
    return 1;
}

static void add_extras(const export_ctx *c, sp_strbuf *j)
{
    sp_strbuf_printf(j, "\"extras\":{\"sunprobe\":{\"source\":\"face directory\",\"frame\":\"fit world rotated to "
                        "y up ((x, y, z) -> (x, z, -y)), turned about +y and moved: fit_to_scene; metres\",\"left_out\":[%s],\"left_out_inferred\":%s,"
                        "\"specular_clusters\":{\"ks\":[",
                     c->left_out.data ? c->left_out.data : "", c->asset.left_out_inferred ? "true" : "false");
    for (int i = 0; i < SP_RENDER_CLUSTERS; i++) {
        sp_strbuf_printf(j, i ? "," : "");
        sp_strbuf_json_number(j, c->asset.ks[i]);
    }
    sp_strbuf_printf(j, "],\"shininess\":[");
    for (int i = 0; i < SP_RENDER_CLUSTERS; i++) {
        sp_strbuf_printf(j, i ? "," : "");
        sp_strbuf_json_number(j, c->asset.shininess[i]);
    }
    sp_strbuf_printf(j, "]},\"sun_intensity_fit_units\":");
    sp_strbuf_json_number(j, c->asset.sun_intensity);
    sp_strbuf_printf(j, ",\"lux_per_fit_unit\":%.9g,\"photometry\":{\"assumed_ev100\":%g,\"why\":\"the capture "
                        "carries no absolute exposure: a camera exposed for direct sun is assumed\","
                        "\"three_js_tone_mapping_exposure\":%.9g,\"blender_film_exposure_ev\":%.6f,"
                        "\"blender_world_strength_for_env\":%.9g}",
                     LUX_PER_FIT_UNIT, EV100, 1.0 / LUX_PER_FIT_UNIT, log2(BLENDER_LM_PER_W / LUX_PER_FIT_UNIT),
                     1.0 / BLENDER_LM_PER_W);
    sp_strbuf_printf(j, ",\"textures\":{\"fitted_width\":%d,\"fitted_height\":%d,\"width\":%d,\"height\":%d,"
                        "\"note\":\"resampled from the fit's maps (Mitchell filter, linear light): no detail beyond "
                        "the fitted size\"}",
                     c->asset.tex_width, c->asset.tex_height, c->tex.albedo.width, c->tex.albedo.height);
    sp_strbuf_printf(j, ",\"fit_to_scene\":{\"rotation\":[");
    for (int k = 0; k < 9; k++)
        sp_strbuf_printf(j, "%s%.9g", k ? "," : "", c->place.R[k]);
    sp_strbuf_printf(j, "],\"translation\":[%.9g,%.9g,%.9g],\"note\":\"scene = rotation (row-major) x w + "
                        "translation for fit-world points w\"}",
                     c->place.t[0], c->place.t[1], c->place.t[2]);
    if (c->env_name[0]) {
        sp_strbuf_printf(j, ",\"environment_map\":{\"uri\":");
        sp_strbuf_json_string(j, c->env_name);
        if (c->env_exr) { /* STEM.env.hdr -> STEM.env.exr */
            char exr[sizeof(c->env_name)];
            snprintf(exr, sizeof(exr), "%.*s.exr", (int)strlen(c->env_name) - 4, c->env_name);
            sp_strbuf_printf(j, ",\"exr_uri\":");
            sp_strbuf_json_string(j, exr);
        }
        sp_strbuf_printf(j, ",\"projection\":\"equirectangular\",\"width\":%d,\"height\":%d,\"row0\":\"straight "
                            "up (+y)\",\"convention\":\"Blender and three.js: u = 0.5 + atan2(z, x) / 2pi\","
                            "\"units\":\"luminance, cd/m2 (the sun's lux per sr)\"}",
                         SP_RENDER_ENV_W, SP_RENDER_ENV_H);
    }
    sp_strbuf_printf(j, "}}");
}

/* Quaternion (x, y, z, w) of a rotation matrix (row-major), from its largest diagonal term (Shepperd). */
static void quat_from_matrix(const double m[9], double q[4])
{
    double tr = m[0] + m[4] + m[8];
    double d21 = m[7] - m[5], d02 = m[2] - m[6], d10 = m[3] - m[1];
    double s01 = m[1] + m[3], s02 = m[2] + m[6], s12 = m[5] + m[7];
    int k = tr > m[0] && tr > m[4] && tr > m[8] ? 3 : m[0] >= m[4] && m[0] >= m[8] ? 0 : m[4] >= m[8] ? 1 : 2;
    double r = sqrt(fmax(k == 3 ? 1.0 + tr : 1.0 + 2.0 * m[k * 4] - tr, 1e-300)), h = 0.5 * r, s = 0.5 / r;
    double v[4][4] = { { h, s01 * s, s02 * s, d21 * s }, { s01 * s, h, s12 * s, d02 * s },
                       { s02 * s, s12 * s, h, d10 * s }, { d21 * s, d02 * s, d10 * s, h } };
    memcpy(q, v[k], sizeof(v[k]));
}

static int camera_usable(const export_ctx *c)
{
    const sp_render_camera *k = &c->asset.camera;
    return c->asset.width > 0 && c->asset.height > 0 && k->fx > 0.0 && k->fy > 0.0 && isfinite(k->fx) &&
           isfinite(k->fy);
}

/*
 * Keyframe 0's camera node: glTF cameras look along their -z with +y up, OpenCV
 * ones along +z with y down, so node rotation = place.R * R^T * diag(1, -1, -1).
 * The principal point cannot be expressed (a centred one is assumed).
 */
static void add_camera_node(const export_ctx *c, sp_strbuf *j)
{
    const sp_render_camera *k = &c->asset.camera;
    double N[9], q[4], eye_w[3], eye[3];
    for (int r = 0; r < 3; r++)
        for (int col = 0; col < 3; col++) {
            double a = 0.0;
            for (int i = 0; i < 3; i++)
                a += c->place.R[r * 3 + i] * k->R[col * 3 + i];
            N[r * 3 + col] = col ? -a : a;
        }
    quat_from_matrix(N, q);
    for (int i = 0; i < 3; i++) /* camera centre -R^T t */
        eye_w[i] = -(k->R[i] * k->t[0] + k->R[3 + i] * k->t[1] + k->R[6 + i] * k->t[2]);
    sp_gltf_place(&c->place, eye_w, eye, 1);
    sp_strbuf_printf(j, ",{\"name\":\"camera\",\"camera\":0,\"translation\":[%.9g,%.9g,%.9g],"
                        "\"rotation\":[%.9g,%.9g,%.9g,%.9g]}",
                     eye[0], eye[1], eye[2], q[0], q[1], q[2], q[3]);
}

static void add_cameras(const export_ctx *c, sp_strbuf *j)
{
    const sp_render_camera *k = &c->asset.camera;
    double w = c->asset.width, h = c->asset.height;
    /* pixel centres at integers: the image spans h pixels; aspect keeps the horizontal field for fx != fy */
    sp_strbuf_printf(j, ",\"cameras\":[{\"name\":\"keyframe 0\",\"type\":\"perspective\",\"perspective\":"
                        "{\"yfov\":%.9g,\"aspectRatio\":%.9g,\"znear\":0.01},\"extras\":{\"sunprobe\":"
                        "{\"image_width\":%d,\"image_height\":%d}}}]",
                     2.0 * atan(0.5 * h / k->fy), w * k->fy / (h * k->fx), c->asset.width, c->asset.height);
}

static void add_scene(const export_ctx *c, sp_strbuf *j, int draco)
{
    double g[3];
    int sun = sun_direction(c, g), cam = camera_usable(c);
    sp_strbuf_printf(j, "\"asset\":{\"version\":\"2.0\",\"generator\":\"sunprobe %s\",", sp_version());
    add_extras(c, j);
    sp_strbuf_printf(j, "},\"extensionsUsed\":[\"KHR_materials_specular\"%s%s]", sun ? ",\"KHR_lights_punctual\"" : "",
                     draco ? ",\"KHR_draco_mesh_compression\"" : "");
    if (draco)
        sp_strbuf_printf(j, ",\"extensionsRequired\":[\"KHR_draco_mesh_compression\"]");
    sp_strbuf_printf(j, ",\"scene\":0,\"scenes\":[{\"name\":\"face\",\"nodes\":[0%s%s]}],"
                        "\"nodes\":[{\"name\":\"head\",\"mesh\":0}",
                     cam ? ",1" : "", sun ? (cam ? ",2" : ",1") : "");
    if (cam)
        add_camera_node(c, j);
    if (sun) {
        double q[4];
        rotation_to(g, q);
        sp_strbuf_printf(j, ",{\"name\":\"sun\",\"rotation\":[%.9g,%.9g,%.9g,%.9g],\"extensions\":"
                            "{\"KHR_lights_punctual\":{\"light\":0}}}",
                         q[0], q[1], q[2], q[3]);
    }
    sp_strbuf_printf(j, "]");
    if (cam)
        add_cameras(c, j);
    if (sun) {
        sp_strbuf_printf(j, ",\"extensions\":{\"KHR_lights_punctual\":{\"lights\":[{\"name\":\"sun\",\"type\":"
                            "\"directional\",\"color\":[1,1,1],\"intensity\":");
        sp_strbuf_json_number(j, c->asset.sun_intensity * LUX_PER_FIT_UNIT);
        sp_strbuf_printf(j, "}]}}");
    }
}

static int write_glb(const char *path, const sp_strbuf *json, const bin_buf *b, size_t *total)
{
    size_t jl = (json->len + 3) & ~(size_t)3, bl = (b->len + 3) & ~(size_t)3;
    size_t len = 12 + 8 + jl + 8 + bl;
    if (len > 0xffffffffu)
        return -EFBIG;
    uint32_t hdr[5] = { 0x46546C67u, 2u, (uint32_t)len, (uint32_t)jl, 0x4E4F534Au };
    uint32_t bh[2] = { (uint32_t)bl, 0x004E4942u };
    static const char spaces[4] = { ' ', ' ', ' ', ' ' }, zeros[4] = { 0 };
    sp_atomic_file af;
    int ret = sp_atomic_file_open(&af, path);
    if (ret)
        return ret;
    if (fwrite(hdr, 4, 5, af.file) != 5 || fwrite(json->data, 1, json->len, af.file) != json->len ||
        fwrite(spaces, 1, jl - json->len, af.file) != jl - json->len || fwrite(bh, 4, 2, af.file) != 2 ||
        fwrite(b->data, 1, b->len, af.file) != b->len || fwrite(zeros, 1, bl - b->len, af.file) != bl - b->len)
        ret = sp_write_error();
    *total = len;
    return sp_atomic_file_finish(&af, ret);
}

static int export_glb(export_ctx *c)
{
    bin_buf b = { 0 };
    sp_strbuf acc = { 0 }, mat = { 0 }, texs = { 0 }, images = { 0 }, j = { 0 };
    sp_strbuf prim = { 0 }, mesh = { 0 };
    int ret = add_primitives(c, &b, &acc, &prim);
    if (!ret)
        ret = add_material(c, &b, &mat, &texs, &images);
    if (!ret) {
        add_target_names(&c->morphs, &mesh);
        sp_strbuf_printf(&j, "{");
        add_scene(c, &j, c->set->draco);
        sp_strbuf_printf(&j, ",\"meshes\":[{\"name\":\"face\",\"primitives\":[%s]%s}]", prim.data,
                         mesh.data ? mesh.data : "");
        sp_strbuf_printf(&j, ",\"materials\":[%s],\"textures\":[%s],\"images\":[%s]", mat.data, texs.data,
                         images.data);
        sp_strbuf_printf(&j, ",\"samplers\":[{\"magFilter\":9729,\"minFilter\":9729,\"wrapS\":33071,"
                             "\"wrapT\":33071}],\"accessors\":[%s],\"bufferViews\":[%s],"
                             "\"buffers\":[{\"byteLength\":%zu}]}",
                         acc.data, b.views.data, (b.len + 3) & ~(size_t)3);
        ret = j.failed || acc.failed || mat.failed || texs.failed || images.failed || b.views.failed ||
                      prim.failed || mesh.failed ? -ENOMEM : 0;
    }
    const char *tmp;
    if (!ret)
        ret = sp_file_set_add(&c->files, c->out_path, &tmp);
    if (!ret)
        ret = write_glb(tmp, &j, &b, &c->st.total_bytes);
    free(b.data);
    sp_strbuf_free(&b.views);
    sp_strbuf_free(&acc);
    sp_strbuf_free(&mat);
    sp_strbuf_free(&texs);
    sp_strbuf_free(&images);
    sp_strbuf_free(&prim);
    sp_strbuf_free(&mesh);
    sp_strbuf_free(&j);
    return ret;
}

static int export_drc(export_ctx *c)
{
#if HAVE_DRACO
    const sp_gltf_geom *g = &c->geom;
    sp_draco_out d;
    int ret = sp_draco_encode_mesh(g->positions, g->normals, g->uvs, NULL, g->n_vertices, g->indices, g->n_triangles,
                                   c->set->position_bits, c->set->normal_bits, c->set->uv_bits, 0, &d);
    if (ret)
        return ret;
    sp_atomic_file af;
    const char *tmp;
    ret = sp_file_set_add(&c->files, c->out_path, &tmp);
    if (!ret)
        ret = sp_atomic_file_open(&af, tmp);
    if (!ret) {
        if (fwrite(d.data, 1, d.size, af.file) != d.size)
            ret = sp_write_error();
        ret = sp_atomic_file_finish(&af, ret);
    }
    c->st.raw_geometry_bytes = (size_t)g->n_vertices * 32 + (size_t)g->n_triangles * 12;
    c->st.geometry_bytes = c->st.total_bytes = d.size;
    c->st.vertices = d.n_points;
    c->st.triangles = d.n_faces;
    sp_draco_out_free(&d);
    return ret;
#else
    (void)c;
    return SP_EDISABLED;
#endif
}

static int check_settings(const sp_export_settings *s)
{
    if (s->format < SP_EXPORT_GLB || s->format > SP_EXPORT_DRC || s->position_bits < 1 || s->position_bits > 30 ||
        s->normal_bits < 1 || s->normal_bits > 30 || s->uv_bits < 1 || s->uv_bits > 30 ||
        (s->texture_size != 0 && (s->texture_size < 16 || s->texture_size > 8192)) || s->jpeg_quality < 1 ||
        s->jpeg_quality > 100)
        return -EINVAL;
    if (!HAVE_DRACO && (s->format == SP_EXPORT_DRC || (s->format == SP_EXPORT_GLB && s->draco))) {
        sp_log(SP_LOG_ERROR, MOD, "Draco compression needs a build with -Ddraco=enabled (or use --no-draco)");
        return SP_EDISABLED;
    }
    if (s->reorder && !HAVE_MESHOPTIMIZER) {
        sp_log(SP_LOG_ERROR, MOD, "--reorder needs a build with -Dmeshoptimizer=enabled (libmeshoptimizer-dev)");
        return SP_EDISABLED;
    }
    if (s->format == SP_EXPORT_GLB && s->jpeg && !sp_jpeg_available()) {
        sp_log(SP_LOG_ERROR, MOD, "JPEG textures need a build with -Djpeg=enabled");
        return SP_EDISABLED;
    }
    return 0;
}

/* The same map as 32-bit float OpenEXR (path's ".hdr" replaced), where OpenImageIO is built. */
static int write_env_exr(export_ctx *c, const char *hdr_path, const float *env)
{
#if HAVE_OPENIMAGEIO
    char path[4096];
    const char *tmp;
    snprintf(path, sizeof(path), "%.*s.exr", (int)(strlen(hdr_path) - 4), hdr_path);
    int ret = sp_file_set_add(&c->files, path, &tmp);
    if (!ret)
        ret = sp_exr_write(tmp, env, SP_RENDER_ENV_W, SP_RENDER_ENV_H, 3);
    if (ret)
        sp_log(SP_LOG_ERROR, MOD, "cannot write %s: %s", path, sp_strerror(ret));
    c->env_exr = !ret;
    return ret;
#else
    (void)c, (void)hdr_path, (void)env;
    return 0;
#endif
}

/* out_path without its extension + ".env.hdr" (and ".env.exr"); env_name gets the basename. */
static int write_env(export_ctx *c)
{
    char path[4096];
    const char *slash = strrchr(c->out_path, '/'), *dot = strrchr(c->out_path, '.');
    size_t stem = dot && (!slash || dot > slash) ? (size_t)(dot - c->out_path) : strlen(c->out_path);
    if (stem + 9 > sizeof(path))
        return -ENAMETOOLONG;
    snprintf(path, sizeof(path), "%.*s.env.hdr", (int)stem, c->out_path);
    float env[SP_RENDER_ENV_FLOATS];
    sp_export_env_equirect(c->asset.env, c->place.R, env);
    for (int k = 0; k < SP_RENDER_ENV_FLOATS; k++)
        env[k] = (float)((double)env[k] * LUX_PER_FIT_UNIT);
    const char *tmp;
    int ret = sp_file_set_add(&c->files, path, &tmp);
    if (!ret)
        ret = sp_hdr_write(tmp, env, SP_RENDER_ENV_W, SP_RENDER_ENV_H);
    if (ret) {
        sp_log(SP_LOG_ERROR, MOD, "cannot write %s: %s", path, sp_strerror(ret));
        return ret;
    }
    if ((ret = write_env_exr(c, path, env)))
        return ret;
    const char *base = strrchr(path, '/');
    base = base ? base + 1 : path;
    size_t n = strlen(base);
    if (n >= sizeof(c->env_name))
        return -ENAMETOOLONG;
    memcpy(c->env_name, base, n + 1);
    return 0;
}

/* One extras entry per part the fit left out, plus the sun light when its values are unusable. */
static void note_parts(export_ctx *c)
{
    static const char *const omitted[N_PARTS] = {
        "sun light (KHR_lights_punctual)",
        "nothing: glTF has no shadow switch (without a sun light there is nothing to cast them)",
        "specular texture (KHR_materials_specular.specularFactor 0, roughness 1)",
        "normal map and TANGENT",
        "environment map (STEM.env.hdr and extras.environment_map)",
    };
    for (int k = 0; k < N_PARTS; k++)
        if (c->asset.left_out & (1u << k))
            note_left_out(c, part_names[k], reason_for(c, k), omitted[k]);
    double g[3];
    if (!(c->asset.left_out & SP_FACE_LEFT_OUT_SUN) && !sun_direction(c, g))
        note_left_out(c, "sun", "the sun's direction or intensity is zero, NaN or Inf", omitted[0]);
    c->st.has_sun = sun_direction(c, g);
}

/* Morph targets for a plain GLB, eye and mouth primitives; a left_out entry says why for what is missing. */
static int add_expressions(export_ctx *c)
{
    int ret = sp_gltf_morphs_build(&c->morphs, c->face_dir, &c->asset, &c->geom, &c->place, 1, c->set->reorder);
    if (ret)
        return ret;
    const char *omitted = "morph targets (mesh.extras.targetNames)";
    if (!c->morphs.n_targets)
        note_left_out(c, "expressions", c->morphs.reason, omitted);
    else if (c->set->draco && !c->set->draco_expressions) {
        note_left_out(c, "expressions", "Draco's edgebreaker reorders the vertices, which morph targets index: "
                                        "export with --no-draco or --draco-expressions to get them", omitted);
        sp_gltf_morphs_drop_targets(&c->morphs);
    }
    if (c->morphs.eyes_reason[0])
        note_left_out(c, "eyes", c->morphs.eyes_reason, "eye primitives (eye_sclera, eye_iris); any eyeballs stay in "
                                                       "the skin primitive");
    if (c->morphs.mouth_reason[0])
        note_left_out(c, "mouth_interior", c->morphs.mouth_reason, "mouth interior primitives (mouth_interior, teeth)");
    c->st.morph_targets = c->morphs.n_targets;
    return 0;
}

static int prepare(export_ctx *c)
{
    int ret = sp_face_dir_read(&c->asset, c->face_dir);
    if (ret) {
        sp_log(SP_LOG_ERROR, MOD, "%s: not a readable face directory: %s", c->face_dir, sp_strerror(ret));
        struct stat st;
        /* the directory is there and a part of it is not: incomplete input, not a file-system fault */
        return ret == -ENOENT && stat(c->face_dir, &st) == 0 && S_ISDIR(st.st_mode) ? SP_ECORRUPT : ret;
    }
    if ((ret = read_reasons(c)))
        return ret;
    sp_gltf_placement_init(&c->place, &c->asset.mesh, &c->asset.camera);
    if ((ret = sp_gltf_geom_build(&c->geom, &c->asset.mesh, &c->place))) {
        sp_log(SP_LOG_ERROR, MOD, "%s: mesh is unusable (NaN, bad index or empty): %s", c->face_dir,
               sp_strerror(ret));
        return ret;
    }
    if (c->set->reorder && (ret = sp_gltf_geom_reorder(&c->geom)))
        return ret;
    if ((ret = sp_export_textures_build(&c->tex, &c->asset, c->set->texture_size, c->asset.left_out)))
        return ret;
    note_parts(c);
    if (c->set->format == SP_EXPORT_GLB && (ret = add_expressions(c)))
        return ret;
    if (c->left_out.failed)
        return -ENOMEM;
    c->st.acmr = sp_gltf_geom_acmr(c->morphs.n_prims ? c->morphs.prims[0].geom : &c->geom);
    c->st.has_specular_texture = c->tex.has_specular;
    c->st.has_normal_map = c->tex.has_normal;
    int env = c->set->write_env && c->set->format != SP_EXPORT_DRC &&
              !(c->asset.left_out & SP_FACE_LEFT_OUT_ENVIRONMENT);
    return env ? write_env(c) : 0;
}

int sp_export_face(const char *face_dir, const char *out_path, const sp_export_settings *settings,
                   sp_export_stats *stats)
{
    if (!face_dir || !out_path || !settings || !out_path[0])
        return -EINVAL;
    int ret = check_settings(settings);
    if (ret)
        return ret;
    export_ctx *c = calloc(1, sizeof(*c));
    if (!c)
        return -ENOMEM;
    c->set = settings;
    c->face_dir = face_dir;
    c->out_path = out_path;
    ret = prepare(c);
    if (!ret) {
        if (settings->format == SP_EXPORT_GLB)
            ret = export_glb(c);
        else if (settings->format == SP_EXPORT_DRC)
            ret = export_drc(c);
        else
            ret = sp_export_write_obj(out_path, &c->files, &c->geom, &c->tex, &c->st);
        if (ret)
            sp_log(SP_LOG_ERROR, MOD, "cannot write %s: %s", out_path, sp_strerror(ret));
    }
    if (!ret && settings->cancel && *settings->cancel)
        ret = -ECANCELED;
    if (!ret && (ret = sp_file_set_commit(&c->files)))
        sp_log(SP_LOG_ERROR, MOD, "cannot put %s and its companion files in place: %s", out_path, sp_strerror(ret));
    sp_file_set_abort(&c->files); /* after a failure: no part of the new asset is left */
    if (!ret && stats)
        *stats = c->st;
    sp_export_textures_free(&c->tex);
    sp_strbuf_free(&c->left_out);
    for (int k = 0; k < N_PARTS; k++)
        free(c->reasons[k]);
    sp_gltf_geom_free(&c->geom);
    sp_gltf_morphs_free(&c->morphs);
    sp_face_asset_free(&c->asset);
    free(c);
    return ret;
}
