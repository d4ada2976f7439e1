/* SPDX-License-Identifier: MIT */
/*
 * The face directory: manifest.json (sizes, lighting, flags, file names),
 * mesh.obj (for people and other tools) and mesh.bin (for relight), raw
 * little-endian float maps (albedo.f32 RGB, displacement.f32, env.f32),
 * clusters.u8, cameras.json. Files are written with atomic renames; the caller
 * writes into DIR.partial and renames the directory when everything is there.
 */
#include "sunprobe/sp_sunstage.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/file_util.h"
#include "common/json.h"
#include "pipeline/sunstage/sunstage_internal.h"

#include "common/parallel.h"

#define MESH_MAGIC "SPFMESH1"

static int write_blob(const char *dir, const char *name, const void *data, size_t size)
{
    char path[4096];
    int ret = sp_path_join(path, sizeof(path), dir, name);
    return ret ? ret : sp_write_whole_file_atomic(path, data, size);
}

static int write_text(const char *dir, const char *name, const sp_strbuf *b)
{
    if (b->failed)
        return -ENOMEM;
    return write_blob(dir, name, b->data, b->len);
}

/* Keyframe 0's face in the world, as floats. */
static int placed_mesh(const sp_sunstage *ss, float *pos)
{
    int idx[64];
    if (ss_list_frames(ss, 0, idx, 64) < 1)
        return SP_ENODATA;
    ss_scene sc;
    int ret = ss_scene_open(&sc, ss);
    if (ret)
        return ret;
    sp_render_scene scene;
    ret = ss_scene_setup(&sc, ss, &ss->res.slots[idx[0]], &scene);
    if (!ret)
        memcpy(pos, sc.pos, sizeof(float) * 3 * ss->model->mesh.n_vertices);
    ss_scene_close(&sc);
    return ret;
}

static int write_mesh(const sp_sunstage *ss, const char *dir, const float *pos)
{
    const sp_mesh *m = &ss->model->mesh;
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "# sunprobe fitted face (metres, fit world frame, z up)\n");
    for (uint32_t i = 0; i < m->n_vertices; i++)
        sp_strbuf_printf(&b, "v %.6f %.6f %.6f\n", (double)pos[i * 3], (double)pos[i * 3 + 1], (double)pos[i * 3 + 2]);
    for (uint32_t i = 0; i < m->n_uvs; i++)
        sp_strbuf_printf(&b, "vt %.6f %.6f\n", (double)m->uvs[i * 2], (double)m->uvs[i * 2 + 1]);
    for (uint32_t t = 0; t < m->n_triangles; t++) {
        const uint32_t *v = m->tri_vertices + t * 3, *u = m->tri_uvs + t * 3;
        sp_strbuf_printf(&b, "f %u/%u %u/%u %u/%u\n", v[0] + 1, u[0] + 1, v[1] + 1, u[1] + 1, v[2] + 1, u[2] + 1);
    }
    int ret = write_text(dir, "mesh.obj", &b);
    sp_strbuf_free(&b);
    if (ret)
        return ret;
    size_t size = 8 + 12 + sizeof(float) * (3 * (size_t)m->n_vertices + 2 * (size_t)m->n_uvs) +
                  sizeof(uint32_t) * 6 * (size_t)m->n_triangles;
    uint8_t *blob = malloc(size), *p = blob;
    if (!blob)
        return -ENOMEM;
    uint32_t counts[3] = { m->n_vertices, m->n_uvs, m->n_triangles };
    memcpy(p, MESH_MAGIC, 8);
    memcpy(p += 8, counts, 12);
    memcpy(p += 12, pos, sizeof(float) * 3 * m->n_vertices);
    memcpy(p += sizeof(float) * 3 * m->n_vertices, m->uvs, sizeof(float) * 2 * m->n_uvs);
    memcpy(p += sizeof(float) * 2 * m->n_uvs, m->tri_vertices, sizeof(uint32_t) * 3 * m->n_triangles);
    memcpy(p += sizeof(uint32_t) * 3 * m->n_triangles, m->tri_uvs, sizeof(uint32_t) * 3 * m->n_triangles);
    ret = write_blob(dir, "mesh.bin", blob, size);
    free(blob);
    return ret;
}

static int write_cameras(const sp_sunstage *ss, const char *dir)
{
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"frames\":[");
    int n = sp_sunstage_n_frames(ss);
    for (int i = 0; i < n; i++) {
        sp_sunstage_frame f;
        sp_sunstage_get_frame(ss, i, &f);
        double q[4] = { f.camera_to_world.w, f.camera_to_world.x, f.camera_to_world.y, f.camera_to_world.z };
        double k[4] = { f.fx, f.fy, f.cx, f.cy };
        sp_strbuf_printf(&b, "%s\n {\"sequence\":%llu,\"timestamp_ns\":%lld,\"heldout\":%s,\"width\":%d,\"height\":%d,",
                         i ? "," : "", (unsigned long long)f.sequence, (long long)f.timestamp_ns,
                         f.heldout ? "true" : "false", f.width, f.height);
        sp_strbuf_printf(&b, "\"capture_pixels_per_pixel\":");
        sp_strbuf_json_number(&b, f.scale_to_capture);
        double crop[2] = { f.crop_x, f.crop_y };
        sp_strbuf_printf(&b, ",\"crop_origin\":");
        sp_strbuf_json_numbers(&b, crop, 2);
        sp_strbuf_printf(&b, ",\"intrinsics\":");
        sp_strbuf_json_numbers(&b, k, 4);
        sp_strbuf_printf(&b, ",\"camera_to_world_wxyz\":");
        sp_strbuf_json_numbers(&b, q, 4);
        sp_strbuf_printf(&b, ",\"face_rotvec\":");
        sp_strbuf_json_numbers(&b, f.rotvec, 3);
        sp_strbuf_printf(&b, ",\"face_t\":");
        sp_strbuf_json_numbers(&b, f.t, 3);
        sp_strbuf_printf(&b, ",\"expression\":");
        sp_strbuf_json_numbers(&b, f.exp, (int)ss->model->n_exp);
        const ss_frame *sf = ss_nth_frame(ss, i); /* what the fit scaled this frame's light by */
        sp_strbuf_printf(&b, ",\"exposure\":");
        sp_strbuf_json_number(&b, sf ? sf->expo : 1.0);
        sp_strbuf_printf(&b, "}");
    }
    sp_strbuf_printf(&b, "\n]}\n");
    int ret = write_text(dir, "cameras.json", &b);
    sp_strbuf_free(&b);
    return ret;
}

/* A landmarks CSV: sequence, source, a figure of the placement, then x0,y0 .. x67,y67 (capture pixels). */
static void landmarks_header(sp_strbuf *b, const char *figure)
{
    sp_strbuf_printf(b, "sequence,source,%s", figure);
    for (int k = 0; k < 68; k++)
        sp_strbuf_printf(b, ",x%d,y%d", k, k);
    sp_strbuf_printf(b, "\n");
}

static void landmarks_row(sp_strbuf *b, uint64_t sequence, const char *source, double figure, const float *lm)
{
    sp_strbuf_printf(b, "%llu,%s,", (unsigned long long)sequence, lm ? source : "none");
    if (lm)
        sp_strbuf_printf(b, "%.5f", figure);
    for (int k = 0; k < 136; k++)
        if (lm)
            sp_strbuf_printf(b, ",%.3f", (double)lm[k]);
        else
            sp_strbuf_printf(b, ",");
    sp_strbuf_printf(b, "\n");
}

/*
 * landmarks.csv: what the tracker found on every frame it ran on (none when every frame came with landmarks);
 * landmarks_fitted.csv: the fitted model's landmark vertices on the same frames, with the fit's RMS residual.
 */
static int write_landmarks(const sp_sunstage *ss, const char *dir)
{
    static const char *const source[] = { "none", "tracked", "detected", "searched" };
    sp_strbuf b = { 0 };
    landmarks_header(&b, "drift");
    for (size_t i = 0; i < ss->fe.lm_n; i++) {
        const ss_lm_entry *e = &ss->fe.lm_log[i];
        int found = e->source > 0 && e->source < 4;
        landmarks_row(&b, e->sequence, found ? source[e->source] : "none", (double)e->drift, found ? e->lm : NULL);
    }
    int ret = write_text(dir, "landmarks.csv", &b);
    sp_strbuf_free(&b);
    if (ret || !ss->fit.lm_fitted)
        return ret;
    sp_strbuf f = { 0 };
    landmarks_header(&f, "rms_px");
    for (size_t i = 0; i < ss->fe.lm_n; i++) {
        const float *o = ss->fit.lm_fitted + SS_LM_FITTED_FLOATS * i;
        landmarks_row(&f, ss->fe.lm_log[i].sequence, "fitted", (double)o[0], isnan(o[0]) ? NULL : o + 1);
    }
    ret = write_text(dir, "landmarks_fitted.csv", &f);
    sp_strbuf_free(&f);
    return ret;
}

static void manifest_lighting(const sp_sunstage *ss, sp_strbuf *b)
{
    sp_strbuf_printf(b, "\"lighting\":{\"sun_direction\":");
    sp_strbuf_json_numbers(b, ss->fit.sun_dir, 3);
    sp_strbuf_printf(b, ",\"sun_intensity\":");
    sp_strbuf_json_number(b, ss->fit.sun_dropped || ss->fit.unobservable ? 0.0 : ss->fit.sun_I);
    sp_strbuf_printf(b, ",\"sun_dropped\":%s,\"lighting_unobservable\":%s,\"notes\":",
                     ss->fit.sun_dropped ? "true" : "false", ss->fit.unobservable ? "true" : "false");
    sp_strbuf_json_string(b, ss->fit.notes);
    sp_strbuf_printf(b, ",\"env\":\"env.f32\",\"env_height\":%d,\"env_width\":%d,\"yaw_range_deg\":",
                     SP_RENDER_ENV_H, SP_RENDER_ENV_W);
    sp_strbuf_json_number(b, ss->fit.yaw_range);
    const ss_clock_sun *c = &ss->clock;
    sp_strbuf_printf(b, ",\"sun_from_clock\":{");
    if (c->have) { /* common/SOLAR.md */
        sp_strbuf_printf(b, "\"direction_world\":");
        sp_strbuf_json_numbers(b, c->dir, 3);
        sp_strbuf_printf(b, ",\"azimuth_deg\":");
        sp_strbuf_json_number(b, c->azimuth_deg);
        sp_strbuf_printf(b, ",\"elevation_deg\":");
        sp_strbuf_json_number(b, c->elevation_deg);
        sp_strbuf_printf(b, ",\"north_from\":");
        sp_strbuf_json_string(b, c->heading_from);
        sp_strbuf_printf(b, ",\"angle_to_fitted_deg\":");
        sp_strbuf_json_number(b, c->angle_deg); /* null when there is no fitted sun */
    } else {
        sp_strbuf_printf(b, "\"unavailable\":");
        sp_strbuf_json_string(b, c->note);
    }
    sp_strbuf_printf(b, "}},\n");
}

/* "left_out": [{"part":..., "reason":...}] so readers need not infer it from zeros. */
static void manifest_left_out(const sp_sunstage *ss, sp_strbuf *b)
{
    const char *part[6], *why[6];
    int n = 0;
    const char *light = ss->fit.unobservable ? "lighting unobservable: too little camera rotation (see lighting.notes)"
                                         : "overcast: the sun does not explain the shading (see lighting.notes)";
    if (ss->fit.unobservable || ss->fit.sun_dropped || !(ss->fit.sun_I > 0.0)) {
        part[n] = "sun";
        why[n++] = light;
        part[n] = "shadows";
        why[n++] = "no sun, so no cast shadows";
    }
    double ks = 0.0;
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++)
        ks += ss->fit.ks[k] > 0.0 ? ss->fit.ks[k] : 0.0;
    if (!(ks > 0.0)) {
        why[n] = n > 0 ? "no sun to reflect" : "the fitted specular intensity is zero in every cluster";
        part[n++] = "specular";
    }
    size_t nt = (size_t)ss->fit.tw * (size_t)ss->fit.th, nz = 0;
    for (size_t i = 0; i < nt; i++)
        nz += ss->fit.disp[i] != 0.0f;
    if (!nz) {
        part[n] = "displacement";
        why[n++] = ss->fit.disp_note[0] ? ss->fit.disp_note : "displacement map not fitted";
    }
    if (ss->fit.texture_coarse) {
        part[n] = "texture detail";
        why[n++] = ss->fit.texture_note;
    }
    if (ss->fit.unobservable) {
        part[n] = "environment";
        why[n++] = "lighting unobservable: the sky is a neutral constant";
    }
    sp_strbuf_printf(b, "\"left_out\":[");
    for (int i = 0; i < n; i++) {
        sp_strbuf_printf(b, "%s{\"part\":\"%s\",\"reason\":", i ? "," : "", part[i]);
        sp_strbuf_json_string(b, why[i]);
        sp_strbuf_printf(b, "}");
    }
    sp_strbuf_printf(b, "],\n");
}

static int write_manifest(const sp_sunstage *ss, const char *dir)
{
    sp_strbuf b = { 0 };
    sp_sunstage_counts c;
    sp_sunstage_get_counts(ss, &c);
    sp_strbuf_printf(&b, "{\"format\":\"sunprobe-face\",\"version\":1,\n\"model\":");
    sp_strbuf_json_string(&b, ss->model->source);
    /* the frames' pixel encoding: renders compare with the capture after sp_sunstage_display_to_srgb when "srgb" */
    sp_strbuf_printf(&b, ",\"capture_transfer\":\"%s\"", ss->fe.srgb ? "srgb" : "sunprobe");
    sp_strbuf_printf(&b, ",\"solver\":\"%s\",\n\"mesh\":\"mesh.obj\",\"mesh_binary\":\"mesh.bin\",\"n_vertices\":%u,"
                         "\"n_triangles\":%u,\n",
                     ss->set.solver == SP_SUNSTAGE_SOLVER_ADAM ? "adam" : "fast", ss->model->mesh.n_vertices,
                     ss->model->mesh.n_triangles);
    sp_strbuf_printf(&b, "\"textures\":{\"width\":%d,\"height\":%d,\"albedo\":\"albedo.f32\",\"albedo_png\":"
                         "\"albedo.png\",%s\"displacement\":\"displacement.f32\",\"clusters\":\"clusters.u8\","
                         "\"cluster_width\":%u,\"cluster_height\":%u",
                     ss->fit.tw, ss->fit.th, ss->fit.have_observed ? "\"albedo_observed\":\"albedo_observed.u8\"," : "",
                     ss->model->cluster_width, ss->model->cluster_height);
    if (ss->fit.texture_note[0]) { /* texture_size 0: how the rows were chosen */
        sp_strbuf_printf(&b, ",\"rows_chosen\":");
        sp_strbuf_json_string(&b, ss->fit.texture_note);
    }
    sp_strbuf_printf(&b, "},\n");
    if (ss->fe.lm_n) /* the landmark tracker's record: every frame it ran on (sunprobe evaluate scores it) */
        sp_strbuf_printf(&b, "\"landmarks\":\"landmarks.csv\",\n");
    if (ss->fe.lm_n && ss->fit.lm_fitted)
        sp_strbuf_printf(&b, "\"landmarks_fitted\":\"landmarks_fitted.csv\",\n");
    sp_strbuf_printf(&b, "\"specular\":{\"ks\":");
    sp_strbuf_json_numbers(&b, ss->fit.ks, SP_RENDER_CLUSTERS);
    sp_strbuf_printf(&b, ",\"shininess\":");
    sp_strbuf_json_numbers(&b, ss->fit.shin, SP_RENDER_CLUSTERS);
    sp_strbuf_printf(&b, "},\n");
    manifest_lighting(ss, &b);
    manifest_left_out(ss, &b);
    sp_strbuf_printf(&b, "\"identity\":");
    sp_strbuf_json_numbers(&b, ss->fit.id, (int)ss->model->n_id);
    sp_strbuf_printf(&b, ",\"scale\":");
    sp_strbuf_json_number(&b, ss->fit.scale);
    sp_strbuf_printf(&b, ",\n\"cameras\":\"cameras.json\",\"fit\":{\"train_psnr\":");
    sp_strbuf_json_number(&b, ss->fit.train_psnr);
    sp_strbuf_printf(&b, ",\"heldout_psnr\":");
    sp_strbuf_json_number(&b, ss->fit.heldout_psnr);
    sp_strbuf_printf(&b, ",\"seconds\":");
    sp_strbuf_json_number(&b, ss->fit.seconds);
    sp_strbuf_printf(&b, ",\"phase_seconds\":{\"frontend\":");
    sp_strbuf_json_number(&b, ss->fit.frontend_s);
    sp_strbuf_printf(&b, ",\"align\":");
    sp_strbuf_json_number(&b, ss->fit.align_s);
    sp_strbuf_printf(&b, ",\"solve\":");
    sp_strbuf_json_number(&b, ss->fit.solve_s);
    sp_strbuf_printf(&b, ",\"refine\":");
    sp_strbuf_json_number(&b, ss->fit.refine_s);
    sp_strbuf_printf(&b, "},\"threads\":%d", ss->set.threads > 0 ? ss->set.threads : sp_cpu_count());
    sp_strbuf_printf(&b, ",\"frames\":%llu,\"keyframes\":%d,\"heldout\":%d,\"skipped\":{\"dark\":%llu,"
                         "\"saturated\":%llu,\"blurred\":%llu,\"no_face\":%llu,\"no_orientation\":%llu},"
                         "\"thinned_early\":%llu}}\n",
                     (unsigned long long)c.frames, c.keyframes, c.heldout, (unsigned long long)c.skipped_dark,
                     (unsigned long long)c.skipped_saturated, (unsigned long long)c.skipped_blurred,
                     (unsigned long long)c.skipped_no_face, (unsigned long long)c.skipped_no_orientation,
                     (unsigned long long)c.thinned_early);
    int ret = write_text(dir, "manifest.json", &b);
    sp_strbuf_free(&b);
    return ret;
}

int sp_face_dir_write(const sp_sunstage *ss, const char *dir)
{
    if (!ss || !dir || !ss->fit.fitted)
        return -EINVAL;
    const sp_face_model *m = ss->model;
    float *pos = malloc(sizeof(float) * 3 * m->mesh.n_vertices);
    if (!pos)
        return -ENOMEM;
    int ret = placed_mesh(ss, pos);
    if (!ret)
        ret = write_mesh(ss, dir, pos);
    free(pos);
    size_t nt = (size_t)ss->fit.tw * (size_t)ss->fit.th;
    if (!ret)
        ret = write_blob(dir, "albedo.f32", ss->fit.albedo, nt * 3 * sizeof(float));
    if (!ret && ss->fit.have_observed) /* 1: seen by a keyframe; 0: filled from the observed texels (albedo.c) */
        ret = write_blob(dir, "albedo_observed.u8", ss->fit.observed, nt);
    if (!ret)
        ret = write_blob(dir, "displacement.f32", ss->fit.disp, nt * sizeof(float));
    if (!ret)
        ret = write_blob(dir, "clusters.u8", m->cluster_map, (size_t)m->cluster_width * m->cluster_height);
    if (!ret)
        ret = write_blob(dir, "env.f32", ss->fit.env, sizeof(ss->fit.env));
    if (!ret)
        ret = write_cameras(ss, dir);
    if (!ret && ss->fe.lm_n)
        ret = write_landmarks(ss, dir);
    if (!ret)
        ret = write_manifest(ss, dir);
    return ret;
}
