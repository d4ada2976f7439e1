/* SPDX-License-Identifier: MIT */
/*
 * New views of the fitted face for evaluation (relighting, novel views): the
 * view's landmarks align the face pose (stage 1 on one frame, shared parameters
 * fixed), then the scene of the current fit is rendered with the view's camera.
 */
#include "sunprobe/sp_sunstage.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline/sunstage/sunstage_internal.h"

int sp_sunstage_render_view(sp_sunstage *ss, const sp_sunstage_view *v, float *rgb, float *mask)
{
    if (!ss || !v || !v->landmarks || !rgb || !ss->res.slots || !(v->fx > 0.0) || !(v->fy > 0.0))
        return -EINVAL;
    /* the view's window: its face crop (face-crop mode) or the whole frame, like the keyframes' */
    ss_window win;
    ss_window_of(ss, v->landmarks, &win);
    ss_frame f;
    memset(&f, 0, sizeof(f));
    double *exp = calloc(ss->model->n_exp + 1, sizeof(double));
    if (!exp)
        return -ENOMEM;
    f.exp = exp;
    f.expo = v->exposure > 0.0 ? v->exposure : 1.0;
    f.q_c2w = sp_quat_normalize(v->camera_to_world);
    sp_quat_to_matrix(f.q_c2w, f.R_c2w);
    ss_window_landmarks(&win, v->landmarks, f.lm);
    /* the view's own intrinsics, in its window, drive its alignment and rendering */
    sp_face_camera_init(&f.cam, v->fx * win.s, v->fy * win.s, (v->cx + 0.5 - win.x0) * win.s - 0.5,
                        (v->cy + 0.5 - win.y0) * win.s - 0.5);
    f.win = win; /* the alignment's pixel unit reads it in face-crop mode */
    ss_scene sc;
    int ret = ss_align_one(ss, &f, 20) < 0 ? -EINVAL : ss_scene_open(&sc, ss);
    if (!ret) {
        sp_render_scene scene;
        sp_render_outputs o;
        ret = ss_scene_setup(&sc, ss, &f, &scene);
        if (!ret) {
            memcpy(scene.sun_dir, v->sun_dir, sizeof(scene.sun_dir));
            scene.sun_intensity = v->sun_intensity;
            scene.shadow_mode = v->sun_intensity > 0.0 ? SP_RENDER_SHADOW_RENDER : SP_RENDER_SHADOW_OFF;
            if (v->env)
                scene.env = v->env;
            ret = sp_render(sc.r, &scene, &o);
        }
        if (!ret) {
            memcpy(rgb, o.image, sizeof(float) * 3 * (size_t)ss->W * (size_t)ss->H);
            if (mask)
                ss_scene_mask(&sc, &o, o.image, mask);
        }
        ss_scene_close(&sc);
    }
    free(exp);
    return ret;
}
