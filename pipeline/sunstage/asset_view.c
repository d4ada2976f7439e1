/* SPDX-License-Identifier: MIT */
/*
 * A fitted face asset rendered in any view (sp_face_view, sp_sunstage.h): the
 * mesh moved by asset_to_world, the environment map resampled into the world
 * by env_to_world (bilinear in the equirectangular map), then one sp_render.
 */
#include "sunprobe/sp_sunstage.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline/render/envlight.h"

void sp_face_view_init(sp_face_view *v, const sp_face_asset *a)
{
    if (!v)
        return;
    memset(v, 0, sizeof(*v));
    v->supersample = 2;
    v->exposure = 1.0;
    v->asset_to_world[0] = v->asset_to_world[5] = v->asset_to_world[10] = 1.0;
    v->env_to_world[0] = v->env_to_world[4] = v->env_to_world[8] = 1.0;
    if (!a)
        return;
    v->width = a->width;
    v->height = a->height;
    v->camera = a->camera;
    memcpy(v->sun_dir, a->sun_dir, sizeof(v->sun_dir));
    v->sun_intensity = a->left_out & SP_FACE_LEFT_OUT_SUN ? 0.0 : a->sun_intensity;
}

static int finite_n(const double *x, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(x[i]))
            return 0;
    return 1;
}

/* Equirectangular lookup (rows from +z down, columns from +x towards +y), bilinear, wrapping in azimuth. */
static void env_lookup(const float *env, const double d[3], float out[3])
{
    double theta = acos(fmax(-1.0, fmin(1.0, d[2]))), phi = atan2(d[1], d[0]);
    if (phi < 0.0)
        phi += 2.0 * M_PI;
    double r = theta / M_PI * SP_RENDER_ENV_H - 0.5, c = phi / (2.0 * M_PI) * SP_RENDER_ENV_W - 0.5;
    int r0 = (int)floor(r), c0 = (int)floor(c);
    double fr = r - r0, fc = c - c0;
    for (int k = 0; k < 3; k++)
        out[k] = 0.0f;
    for (int i = 0; i < 2; i++)
        for (int j = 0; j < 2; j++) {
            int rr = r0 + i < 0 ? 0 : (r0 + i >= SP_RENDER_ENV_H ? SP_RENDER_ENV_H - 1 : r0 + i);
            int cc = ((c0 + j) % SP_RENDER_ENV_W + SP_RENDER_ENV_W) % SP_RENDER_ENV_W;
            double w = (i ? fr : 1.0 - fr) * (j ? fc : 1.0 - fc);
            const float *t = env + ((size_t)rr * SP_RENDER_ENV_W + (size_t)cc) * 3;
            for (int k = 0; k < 3; k++)
                out[k] += (float)(w * (double)t[k]);
        }
}

/* world[texel] = env(R^T d(texel)): the environment turned by R into the world. */
static void env_rotate(const float *env, const double R[9], float *world)
{
    for (int row = 0; row < SP_RENDER_ENV_H; row++)
        for (int col = 0; col < SP_RENDER_ENV_W; col++) {
            double d[3], e[3];
            env_texel_dir(row, col, d); /* the renderer's own texel directions */
            for (int i = 0; i < 3; i++)
                e[i] = R[i] * d[0] + R[3 + i] * d[1] + R[6 + i] * d[2];
            env_lookup(env, e, world + ((size_t)row * SP_RENDER_ENV_W + (size_t)col) * 3);
        }
}

/* The fraction of each pixel's samples that land on a face triangle (all three vertices in vmask). */
static void face_coverage(const sp_render_outputs *o, const sp_mesh *m, const uint8_t *vmask, float *mask)
{
    if (!vmask) {
        memcpy(mask, o->coverage, sizeof(float) * (size_t)o->width * (size_t)o->height);
        return;
    }
    int ss = o->sample_width / o->width;
    for (int y = 0; y < o->height; y++)
        for (int x = 0; x < o->width; x++) {
            int hit = 0;
            for (int sy = 0; sy < ss; sy++)
                for (int sx = 0; sx < ss; sx++) {
                    int32_t t = o->tri_id[(size_t)(y * ss + sy) * (size_t)o->sample_width + (size_t)(x * ss + sx)];
                    const uint32_t *v = t >= 0 ? m->tri_vertices + (size_t)t * 3 : NULL;
                    hit += v && vmask[v[0]] && vmask[v[1]] && vmask[v[2]];
                }
            mask[(size_t)y * (size_t)o->width + (size_t)x] = (float)hit / (float)(ss * ss);
        }
}

/* out[i] = in[i] for n values when both are there. */
static void copy_out(float *out, const float *in, size_t n)
{
    if (out && in)
        memcpy(out, in, sizeof(float) * n);
}

static int render_view(const sp_face_asset *a, const sp_face_view *v, float *rgb, const sp_face_passes *ps)
{
    const sp_face_passes none = { 0 };
    const sp_face_passes *p = ps ? ps : &none;
    int decomposed = p->diffuse || p->specular || p->ambient || p->visibility || p->normal || p->albedo;
    if (!a || !v || !(rgb || p->radiance || p->mask || p->coverage || p->depth || decomposed) || !a->mesh.n_vertices || v->width < 1 || v->height < 1 || v->width > 8192 ||
        v->height > 8192 || v->supersample < 1 || v->supersample > 4 || !(v->camera.fx > 0.0) ||
        !(v->camera.fy > 0.0) || !finite_n(v->asset_to_world, 12) || !finite_n(v->env_to_world, 9) ||
        !finite_n(v->camera.R, 9) || !finite_n(v->camera.t, 3) || !(v->sun_intensity >= 0.0) ||
        !(v->sun_angular_radius >= 0.0 && v->sun_angular_radius <= 0.5 * M_PI) || !finite_n(v->sun_position, 3))
        return -EINVAL;
    size_t nv = a->mesh.n_vertices;
    float *pos = malloc(sizeof(float) * 3 * nv);
    float *env = malloc(sizeof(float) * SP_RENDER_ENV_FLOATS);
    sp_renderer *r = NULL;
    int ret = pos && env ? 0 : -ENOMEM;
    sp_renderer_settings rs;
    sp_renderer_default_settings(&rs);
    rs.width = v->width;
    rs.height = v->height;
    rs.supersample = v->supersample;
    rs.skip_outputs = decomposed ? 0u : SP_RENDER_SKIP_DECOMPOSITION;
    if (!ret)
        ret = sp_renderer_open(&r, &rs);
    if (ret)
        goto done;
    const double *M = v->asset_to_world;
    for (size_t i = 0; i < nv; i++) {
        const float *q = a->mesh.positions + i * 3;
        double x[3] = { q[0], q[1], q[2] };
        for (int k = 0; k < 3; k++)
            pos[i * 3 + (size_t)k] = (float)(M[k * 4] * x[0] + M[k * 4 + 1] * x[1] + M[k * 4 + 2] * x[2] + M[k * 4 + 3]);
    }
    env_rotate(v->env ? v->env : a->env, v->env_to_world, env);
    sp_mesh mesh = a->mesh;
    mesh.positions = pos;
    sp_render_scene sc;
    sp_render_scene_defaults(&sc);
    sc.camera = v->camera;
    sc.mesh = &mesh;
    sc.albedo = (sp_render_texture){ a->tex_width, a->tex_height, a->albedo };
    sc.displacement = (sp_render_texture){ a->tex_width, a->tex_height, a->displacement };
    sc.clusters = (sp_render_cluster_map){ a->cluster_width, a->cluster_height, a->clusters };
    int no_spec = (a->left_out & SP_FACE_LEFT_OUT_SPECULAR) != 0;
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++) {
        sc.ks[k] = no_spec ? 0.0 : a->ks[k];
        sc.shininess[k] = a->shininess[k];
    }
    sc.env = env;
    memcpy(sc.sun_dir, v->sun_dir, sizeof(sc.sun_dir));
    sc.sun_intensity = v->sun_intensity;
    sc.sun_soft_radius = v->sun_intensity > 0.0 ? v->sun_angular_radius : 0.0;
    sc.sun_is_point = v->sun_is_point != 0;
    memcpy(sc.sun_position, v->sun_position, sizeof(sc.sun_position));
    sc.shadow_mode = v->sun_intensity > 0.0 ? SP_RENDER_SHADOW_RENDER : SP_RENDER_SHADOW_OFF;
    sc.exposure = v->exposure > 0.0 ? v->exposure : 1.0;
    sp_render_outputs o;
    if ((ret = sp_render(r, &sc, &o)))
        goto done;
    size_t npx = (size_t)v->width * (size_t)v->height;
    copy_out(rgb, o.image, 3 * npx);
    copy_out(p->radiance, o.radiance, 3 * npx);
    copy_out(p->diffuse, o.diffuse, 3 * npx);
    copy_out(p->specular, o.specular, 3 * npx);
    copy_out(p->ambient, o.ambient, 3 * npx);
    copy_out(p->visibility, o.visibility, npx);
    copy_out(p->normal, o.normal, 3 * npx);
    copy_out(p->albedo, o.albedo, 3 * npx);
    copy_out(p->coverage, o.coverage, npx);
    int ss = o.sample_width / o.width;
    for (int y = 0; p->depth && y < o.height; y++) /* the sample nearest the pixel's centre */
        for (int x = 0; x < o.width; x++)
            p->depth[(size_t)y * (size_t)o.width + (size_t)x] =
                o.depth[(size_t)(y * ss + ss / 2) * (size_t)o.sample_width + (size_t)(x * ss + ss / 2)];
    if (p->mask)
        face_coverage(&o, &a->mesh, v->vertex_mask, p->mask);
done:
    sp_renderer_close(&r);
    free(pos);
    free(env);
    return ret;
}

int sp_face_asset_render(const sp_face_asset *a, const sp_face_view *v, float *rgb, float *mask)
{
    sp_face_passes p = { .mask = mask };
    return rgb ? render_view(a, v, rgb, &p) : -EINVAL;
}

int sp_face_asset_render_radiance(const sp_face_asset *a, const sp_face_view *v, float *radiance, float *mask)
{
    sp_face_passes p = { .radiance = radiance, .mask = mask };
    return radiance ? render_view(a, v, NULL, &p) : -EINVAL;
}

int sp_face_asset_render_passes(const sp_face_asset *a, const sp_face_view *v, const sp_face_passes *p)
{
    return p ? render_view(a, v, NULL, p) : -EINVAL;
}
