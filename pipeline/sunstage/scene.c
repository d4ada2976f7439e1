/* SPDX-License-Identifier: MIT */
/*
 * One keyframe of the current fit as a renderer scene. The face is evaluated
 * in the camera frame (stage-1 parameters), then carried into the world with the
 * IMU's camera-to-world rotation; the camera sits at the world origin. Sun and
 * sky live in the world, so a turning person sees them move across the face.
 * The per-frame face mask is the rendered skin region of the current fit.
 */
#include "pipeline/sunstage/sunstage_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

int ss_scene_open(ss_scene *sc, const sp_sunstage *ss)
{
    memset(sc, 0, sizeof(*sc));
    const sp_face_model *m = ss->model;
    sp_renderer_settings rs;
    sp_renderer_default_settings(&rs);
    rs.width = ss->W;
    rs.height = ss->H;
    rs.shadow_size = 256;
    rs.max_vertices = m->mesh.n_vertices;
    rs.max_triangles = m->mesh.n_triangles;
    int ret = sp_renderer_open(&sc->r, &rs);
    if (ret)
        return ret;
    sc->pos = malloc(sizeof(float) * 3 * m->mesh.n_vertices);
    sc->posd = malloc(sizeof(double) * 3 * m->mesh.n_vertices);
    sc->observed_tri = malloc(m->mesh.n_triangles ? m->mesh.n_triangles : 1);
    if (!sc->pos || !sc->posd || !sc->observed_tri) {
        ss_scene_close(sc);
        return -ENOMEM;
    }
    for (uint32_t t = 0; t < m->mesh.n_triangles; t++) {
        const uint32_t *v = m->mesh.tri_vertices + (size_t)t * 3;
        /* the face's skin and the eyeballs are what the fit sees (the eyes' own albedo texels) */
        int skin = m->face_mask[v[0]] && m->face_mask[v[1]] && m->face_mask[v[2]];
        int eye = m->part[v[0]] == SP_FACE_PART_EYE && m->part[v[1]] == SP_FACE_PART_EYE &&
                  m->part[v[2]] == SP_FACE_PART_EYE;
        sc->observed_tri[t] = skin || eye;
    }
    sc->mesh = m->mesh;
    sc->mesh.positions = sc->pos;
    sc->white[0] = sc->white[1] = sc->white[2] = 1.0f;
    return 0;
}

void ss_scene_close(ss_scene *sc)
{
    sp_renderer_close(&sc->r);
    free(sc->pos);
    free(sc->posd);
    free(sc->observed_tri);
    memset(sc, 0, sizeof(*sc));
}

int ss_scene_setup(ss_scene *sc, const sp_sunstage *ss, const ss_frame *f, sp_render_scene *scene)
{
    const sp_face_model *m = ss->model;
    sp_face_params p;
    ss_frame_params(ss, f, &p);
    int ret = sp_face_model_eval(m, &p, sc->posd);
    if (ret)
        return ret;
    const double *R = f->R_c2w;
    for (uint32_t i = 0; i < m->mesh.n_vertices; i++) {
        const double *x = sc->posd + (size_t)i * 3;
        for (int r = 0; r < 3; r++)
            sc->pos[(size_t)i * 3 + (size_t)r] = (float)(R[r * 3] * x[0] + R[r * 3 + 1] * x[1] + R[r * 3 + 2] * x[2]);
    }
    sp_render_scene_defaults(scene);
    scene->camera.fx = f->cam.fx;
    scene->camera.fy = f->cam.fy;
    scene->camera.cx = f->cam.cx;
    scene->camera.cy = f->cam.cy;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++)
            scene->camera.R[r * 3 + c] = R[c * 3 + r];
    scene->camera.t[0] = scene->camera.t[1] = scene->camera.t[2] = 0.0;
    scene->mesh = &sc->mesh;
    scene->albedo = (sp_render_texture){ ss->fit.tw, ss->fit.th, ss->fit.albedo };
    scene->displacement = (sp_render_texture){ ss->fit.tw, ss->fit.th, ss->fit.disp };
    scene->clusters = (sp_render_cluster_map){ (int)m->cluster_width, (int)m->cluster_height, m->cluster_map };
    memcpy(scene->ks, ss->fit.ks, sizeof(scene->ks));
    memcpy(scene->shininess, ss->fit.shin, sizeof(scene->shininess));
    scene->env = ss->fit.env;
    memcpy(scene->sun_dir, ss->fit.sun_dir, sizeof(scene->sun_dir));
    scene->sun_intensity = ss->fit.sun_dropped || ss->fit.unobservable ? 0.0 : ss->fit.sun_I;
    scene->exposure = f->expo;
    scene->shadow_mode = scene->sun_intensity > 0.0 ? SP_RENDER_SHADOW_RENDER : SP_RENDER_SHADOW_OFF;
    return 0;
}

int ss_scene_covers(const ss_scene *sc, const sp_render_outputs *o, int i)
{
    int32_t t = o->tri_id[i];
    return t >= 0 && sc->observed_tri[t] && o->coverage[i] > 0.999f;
}

/*
 * The rim pixel of the seen region is left out of every fit: there the model's outline error (a pixel
 * of it is a few millimetres), grazing normals and the capture's own edge blend (hair, background, the
 * eyelids) meet. On the five path-traced selfies (SUNSTAGE.md, "Where the fit stands") relighting and
 * novel views gain 0.19 and 0.22 dB on average and SSIM on all five.
 */
int ss_scene_inside(const ss_scene *sc, const sp_render_outputs *o, int i)
{
    int w = o->width, x = i % w, y = i / w;
    return x > 0 && y > 0 && x < w - 1 && y < o->height - 1 && ss_scene_covers(sc, o, i) &&
           ss_scene_covers(sc, o, i - 1) && ss_scene_covers(sc, o, i + 1) && ss_scene_covers(sc, o, i - w) &&
           ss_scene_covers(sc, o, i + w);
}

int ss_scene_is_observed(const ss_scene *sc, const sp_render_outputs *o, const float *target, int i)
{
    const float *g = target + (size_t)i * 3;
    int sat = g[0] > 0.98f || g[1] > 0.98f || g[2] > 0.98f;
    return ss_scene_inside(sc, o, i) && !sat;
}

void ss_scene_mask(const ss_scene *sc, const sp_render_outputs *o, const float *target, float *mask)
{
    int n = o->width * o->height;
    for (int i = 0; i < n; i++)
        mask[i] = ss_scene_is_observed(sc, o, target, i) ? 1.0f : 0.0f;
}

double ss_psnr(const float *img, const float *target, const float *mask, int n)
{
    double se = 0.0, m = 0.0;
    for (int i = 0; i < n; i++) {
        if (mask && !(mask[i] > 0.0f))
            continue;
        double w = mask ? (double)mask[i] : 1.0;
        for (int c = 0; c < 3; c++) {
            double d = (double)img[(size_t)i * 3 + (size_t)c] - (double)target[(size_t)i * 3 + (size_t)c];
            se += w * d * d;
        }
        m += 3.0 * w;
    }
    if (!(m > 0.0))
        return NAN;
    double mse = se / m;
    return mse > 1e-12 ? -10.0 * log10(mse) : 120.0;
}

/* Pooled PSNR over a set of frames. */
static double pooled(sp_sunstage *ss, ss_scene *sc, const int *idx, int n, float *mask)
{
    double se = 0.0, cnt = 0.0;
    for (int i = 0; i < n; i++) {
        ss_frame *f = &ss->res.slots[idx[i]];
        sp_render_scene scene;
        sp_render_outputs o;
        if (ss_scene_setup(sc, ss, f, &scene) || sp_render(sc->r, &scene, &o))
            continue;
        ss_scene_mask(sc, &o, f->rgb, mask);
        double p = ss_psnr(o.image, f->rgb, mask, ss->W * ss->H);
        double m = 0.0;
        for (int k = 0; k < ss->W * ss->H; k++)
            m += (double)mask[k];
        if (isfinite(p) && m > 0.0) {
            se += pow(10.0, -p / 10.0) * m;
            cnt += m;
        }
    }
    return cnt > 0.0 && se > 0.0 ? -10.0 * log10(se / cnt) : (double)NAN;
}

int ss_evaluate(sp_sunstage *ss, ss_scene *sc, double *train, double *heldout)
{
    int idx[64];
    float *mask = malloc(sizeof(float) * (size_t)ss->W * (size_t)ss->H);
    if (!mask)
        return -ENOMEM;
    int n = ss_list_frames(ss, 0, idx, 64);
    if (train)
        *train = pooled(ss, sc, idx, n, mask);
    n = ss_list_frames(ss, 1, idx, 64);
    if (heldout)
        *heldout = n ? pooled(ss, sc, idx, n, mask) : (double)NAN;
    free(mask);
    return 0;
}
