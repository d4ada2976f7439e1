/* SPDX-License-Identifier: MIT */
/* SunStage fitter: lifecycle, event dispatch, keyframe reservoir access and the two-stage fit driver. */
#include "sunprobe/sp_sunstage.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/clock.h"
#include "common/parallel.h"
#include "pipeline/sunstage/sunstage_internal.h"

#include "pipeline/sunstage/landmarks.h"

#define MOD "sunstage"

void sp_sunstage_default_settings(sp_sunstage_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->solver = SP_SUNSTAGE_SOLVER_FAST;
    s->keyframes = 12;
    s->heldout = 3;
    s->fit_width = 128;
    s->texture_size = 0;
    s->adam_iterations = 300;
    s->min_rotation_deg = 90.0;
    s->blur_ratio = 0.35;
    s->use_dlib = 1;
    s->silhouette_weight = 0.5;
    s->refine_steps = 20;
}

static int check_settings(const sp_sunstage_settings *s)
{
    if (s->keyframes < 2 || s->keyframes > 64 || s->heldout < 0 || s->heldout > 16)
        return -EINVAL;
    if (s->fit_width < 16 || s->fit_width > 1024 || (s->texture_size != 0 && s->texture_size < 8) ||
        s->texture_size > 2048)
        return -EINVAL;
    if (s->adam_iterations < 0 || !(s->time_budget_s >= 0.0) || !(s->blur_ratio >= 0.0) ||
        !(s->silhouette_weight >= 0.0 && s->silhouette_weight <= 100.0) || s->refine_steps < 0 ||
        s->refine_steps > 10000)
        return -EINVAL;
    if ((s->face_crop != 0 && s->face_crop != 1) || (s->fixed_exposure != 0 && s->fixed_exposure != 1))
        return -EINVAL;
    if (s->threads < 0 || s->threads > 64)
        return -EINVAL;
    if (s->solver != SP_SUNSTAGE_SOLVER_FAST && s->solver != SP_SUNSTAGE_SOLVER_ADAM)
        return -EINVAL;
    return 0;
}

static void init_lighting(sp_sunstage *ss)
{
    for (int i = 0; i < SP_RENDER_ENV_FLOATS; i++)
        ss->fit.env[i] = 0.3f;
    ss->fit.sun_dir[0] = 0.0;
    ss->fit.sun_dir[1] = 0.0;
    ss->fit.sun_dir[2] = 1.0;
    ss->fit.sun_I = 2.0;
    for (int c = 0; c < SP_RENDER_CLUSTERS; c++) {
        ss->fit.ks[c] = 0.0;
        ss->fit.shin[c] = 16.0;
    }
}

/* Two tiles wide for two-tile UVs. */
int ss_fit_alloc_maps(sp_sunstage *ss, int rows)
{
    const sp_face_model *m = ss->model;
    free(ss->fit.albedo);
    free(ss->fit.disp);
    free(ss->fit.observed);
    ss->fit.th = rows;
    ss->fit.tw = m->cluster_width > m->cluster_height ? 2 * rows : rows;
    size_t texels = (size_t)ss->fit.tw * (size_t)ss->fit.th;
    ss->fit.albedo = malloc(texels * 3 * sizeof(float));
    ss->fit.disp = calloc(texels, sizeof(float));
    ss->fit.observed = calloc(texels, 1);
    if (!ss->fit.albedo || !ss->fit.disp || !ss->fit.observed)
        return -ENOMEM;
    for (size_t i = 0; i < texels * 3; i++)
        ss->fit.albedo[i] = 0.5f;
    return 0;
}

/*
 * Rows of a map matched to the data: one texel per face pixel of the keyframe that shows the most face.
 * Finer texels lie between every pixel's sample; the fit sets them to whatever reproduces its
 * fit-resolution frames, which at full resolution is a dot grid (measured in SUNSTAGE.md, "Map resolution").
 */
static int matched_texture_rows(sp_sunstage *ss, const int *idx, int n, int *rows)
{
    const sp_face_model *m = ss->model;
    ss_scene sc;
    int ret = ss_scene_open(&sc, ss);
    if (ret)
        return ret;
    double uv_area = 0.0; /* of the triangles the fit observes, in the unit UV square */
    for (uint32_t t = 0; t < m->mesh.n_triangles; t++) {
        if (!sc.observed_tri[t])
            continue;
        const uint32_t *tu = m->mesh.tri_uvs + (size_t)t * 3;
        const float *a = m->mesh.uvs + tu[0] * 2, *b = m->mesh.uvs + tu[1] * 2, *c = m->mesh.uvs + tu[2] * 2;
        uv_area += 0.5 * fabs((double)(b[0] - a[0]) * (double)(c[1] - a[1]) - (double)(c[0] - a[0]) * (double)(b[1] - a[1]));
    }
    long most = 0;
    for (int i = 0; i < n && !ret; i++) {
        sp_render_scene scene;
        sp_render_outputs o;
        if ((ret = ss_scene_setup(&sc, ss, &ss->res.slots[idx[i]], &scene)))
            break;
        scene.shadow_mode = SP_RENDER_SHADOW_OFF;
        if ((ret = sp_render(sc.r, &scene, &o)))
            break;
        long px = 0;
        for (int p = 0; p < ss->W * ss->H; p++)
            px += ss_scene_covers(&sc, &o, p);
        most = px > most ? px : most;
    }
    ss_scene_close(&sc);
    if (ret)
        return ret;
    double aspect = m->cluster_width > m->cluster_height ? 2.0 : 1.0;
    double r = uv_area > 0.0 ? sqrt((double)most / (aspect * uv_area)) : 128.0;
    int ri = (int)ceil(r / 8.0) * 8;
    *rows = ri < 16 ? 16 : (ri > 1024 ? 1024 : ri);
    sp_log(SP_LOG_INFO, MOD, "texture: %d rows would give one texel per face pixel (%ld face pixels in the best "
           "keyframe, %.3f of the UV square)", *rows, most, uv_area);
    return 0;
}

int sp_sunstage_open(sp_sunstage **out, const sp_sunstage_settings *s, const sp_face_model *model)
{
    if (!out || !s || !model || !model->mesh.n_vertices)
        return -EINVAL;
    *out = NULL;
    int ret = check_settings(s);
    if (ret)
        return ret;
    sp_sunstage *ss = calloc(1, sizeof(*ss));
    if (!ss)
        return -ENOMEM;
    ss->set = *s;
    ss->model = model;
    sp_capture_meta_init(&ss->meta);
    ss->fit.scale = 1.0;
    ss->fit.id = calloc(model->n_id + 1, sizeof(double));
    ss->scalp = malloc(model->mesh.n_vertices);
    if (ss->scalp && sp_face_model_scalp(model, ss->scalp)) { /* a model without a face frame: face outline only */
        free(ss->scalp);
        ss->scalp = NULL;
    }
    /* a map matched to the data (texture_size 0) is sized after stage 1; until then the old default */
    if (!ss->fit.id || ss_fit_alloc_maps(ss, s->texture_size ? s->texture_size : SS_TEXTURE_ROWS)) {
        sp_sunstage_close(&ss);
        return -ENOMEM;
    }
    init_lighting(ss);
    ss_clock_sun_init(&ss->clock);
    ss->fit.train_psnr = ss->fit.heldout_psnr = NAN;
    *out = ss;
    return 0;
}


void sp_sunstage_close(sp_sunstage **pss)
{
    if (!pss || !*pss)
        return;
    sp_sunstage *ss = *pss;
    ss_lm_tracker_close(&ss->fe.landmarks);
    free(ss->fe.lm_log);
    free(ss->fe.rgb24);
    free(ss->fe.work_rgb);
    free(ss->fe.work_clip);
    ss_reservoir_free(ss);
    free(ss->fit.id);
    free(ss->fit.albedo);
    free(ss->fit.disp);
    free(ss->fit.observed);
    free(ss->fit.lm_fitted);
    free(ss->scalp);
    free(ss);
    *pss = NULL;
}

int sp_sunstage_push(sp_sunstage *ss, const sp_event *ev)
{
    if (!ss || !ev)
        return -EINVAL;
    switch (ev->type) {
    case SP_EVENT_META:
        if (ev->meta)
            ss->meta = *ev->meta;
        return 0;
    case SP_EVENT_IMU: /* orientation comes with the frames; counted to explain a fit without it */
        if (!ss->counts.imu_samples++)
            ss->fe.imu_t[0] = ev->timestamp_ns;
        ss->fe.imu_t[1] = ev->timestamp_ns;
        return 0;
    case SP_EVENT_SIDE:
        return 0; /* what the fit uses comes attached to the frames */
    case SP_EVENT_FRAME:
        if (!ev->frame)
            return -EINVAL;
        if (!ev->tags) {
            sp_log(SP_LOG_ERROR, MOD, "frame %llu is untagged: SunStage takes frames from the orientation tagger "
                   "(sp_tagger.h)", (unsigned long long)ev->frame->sequence);
            return -EINVAL;
        }
        if (!ss->counts.frames++)
            ss->fe.frame_t[0] = ev->timestamp_ns;
        ss->fe.frame_t[1] = ev->timestamp_ns;
        ss->counts.thinned_early = ev->tags->thinned;
        ss_clock_sun_note(&ss->clock, ev->tags);
        int64_t t = sp_clock_monotonic_ns();
        int ret = ss_frontend_frame(ss, ev->frame, ev->timestamp_ns, ev->tags);
        ss->fit.frontend_s += (double)(sp_clock_monotonic_ns() - t) * 1e-9;
        if (ret == SP_ECORRUPT || ret == SP_ETRUNCATED) { /* a damaged frame costs that frame, not the fit */
            ss->counts.skipped_undecodable++;
            sp_log(SP_LOG_WARN, MOD, "frame %llu at %.3f s does not decode (%s): skipped",
                   (unsigned long long)ev->frame->sequence, (double)ev->timestamp_ns * 1e-9, sp_strerror(ret));
            ret = 0;
        }
        return ret;
    }
    return 0;
}

int sp_sunstage_end_stream(sp_sunstage *ss)
{
    return ss ? 0 : -EINVAL; /* nothing waits in the front end */
}

void sp_sunstage_get_counts(const sp_sunstage *ss, sp_sunstage_counts *out)
{
    if (!ss || !out)
        return;
    *out = ss->counts;
    out->keyframes = out->heldout = 0;
    for (int i = 0; ss->res.slots && i < ss->res.n_slots; i++)
        if (ss->res.slots[i].used) {
            if (ss->res.slots[i].heldout)
                out->heldout++;
            else
                out->keyframes++;
        }
}

void ss_frame_params(const sp_sunstage *ss, const ss_frame *f, sp_face_params *p)
{
    sp_face_params_init(p);
    p->id = ss->fit.id;
    p->exp = f->exp;
    memcpy(p->rotvec, f->rotvec, sizeof(p->rotvec));
    memcpy(p->t, f->t_face, sizeof(p->t));
    p->s = ss->fit.scale;
}

void ss_rotvec_to_matrix(const double r[3], double R[9])
{
    sp_quat q = sp_quat_from_rotvec((sp_vec3){ r[0], r[1], r[2] });
    sp_quat_to_matrix(q, R);
}

int sp_sunstage_add_keyframe(sp_sunstage *ss, const float *rgb, int width, int height, const double landmarks[136],
                             double fx, double fy, double cx, double cy, sp_quat camera_to_world, int heldout)
{
    if (!ss || !rgb || !landmarks || width < 16 || height < 16 || !(fx > 0.0) || !(fy > 0.0))
        return -EINVAL;
    if (ss->W && (ss->W != width || ss->H != height))
        return -EINVAL;
    ss->W = width;
    ss->H = height;
    ss->fe.cap_w = width;
    ss->fe.cap_h = height;
    sp_face_camera_init(&ss->cam, fx, fy, cx, cy);
    ss->cap_fx = fx, ss->cap_fy = fy, ss->cap_cx = cx, ss->cap_cy = cy;
    ss->fe.win = (ss_window){ 0.0, 0.0, 1.0 }; /* the image is the fit image */
    return ss_reservoir_offer(ss, rgb, NULL, landmarks, 1.0, 1.0, ss->counts.accepted++, 0, camera_to_world, heldout ? 2 : 3,
                              NULL);
}

/* The fast solver, then the photometric refinement of its geometry (Adam's machinery) when enabled. */
static int solve_fast(sp_sunstage *ss, sp_sunstage_callback cb, void *user)
{
    int64_t t = sp_clock_monotonic_ns();
    int ret = ss_fit_fast(ss, cb, user);
    ss->fit.solve_s = (double)(sp_clock_monotonic_ns() - t) * 1e-9;
    if (ret)
        return ret;
    if (ss->set.refine_steps <= 0) {
        snprintf(ss->fit.disp_note, sizeof(ss->fit.disp_note),
                 "the fast solver keeps the stage-1 geometry (photometric refinement off: refine_steps = 0)");
        return 0;
    }
    t = sp_clock_monotonic_ns();
    ret = ss_refine_geometry(ss, ss->set.refine_steps);
    ss->fit.refine_s = (double)(sp_clock_monotonic_ns() - t) * 1e-9;
    if (ret)
        return ret;
    if (cb) { /* the refinement leaves the PSNRs of the geometry it kept */
        double tr = ss->fit.train_psnr;
        sp_sunstage_progress p = { "photometric", SS_FAST_PHASES, SS_FAST_PHASES,
                                   (double)(sp_clock_monotonic_ns() - ss->fit.t0) * 1e-9,
                                   isfinite(tr) ? pow(10.0, -tr / 10.0) : (double)NAN, ss->fit.heldout_psnr };
        cb(user, &p);
    }
    return 0;
}

#define MIN_FACE_FRAMES 5 /* the face from several sides: fewer cannot separate shape, albedo and light */

/* Whether the stream can be fitted; when not, logs what is missing, most telling reason first. */
static int fittable(const sp_sunstage *ss, int n_keyframes)
{
    sp_sunstage_counts c;
    sp_sunstage_get_counts(ss, &c);
    unsigned long long frames = c.frames, most = c.frames - c.frames / 10; /* 90 %: "all but a few" */
    if (!frames) { /* keyframes given directly (sp_sunstage_add_keyframe), not streamed */
        if (n_keyframes >= 2)
            return 1;
        sp_log(SP_LOG_ERROR, MOD, "%d keyframe(s) and no frames streamed: nothing to fit", n_keyframes);
        return 0;
    }
    if (!c.imu_samples && c.skipped_no_orientation >= most) { /* orientation from the video tags frames without */
        sp_log(SP_LOG_ERROR, MOD, "the capture has no IMU samples: SunStage needs the camera orientation per frame");
        return 0;
    }
    if (c.accepted >= MIN_FACE_FRAMES && n_keyframes >= 2)
        return 1;
    const int64_t *ft = ss->fe.frame_t, *it = ss->fe.imu_t;
    if (c.skipped_no_orientation >= most && (it[1] < ft[0] || it[0] > ft[1]))
        sp_log(SP_LOG_ERROR, MOD,
               "the IMU samples (%.3f to %.3f s) and the frames (%.3f to %.3f s) never overlap in time: no frame has "
               "a camera orientation (import --imu-offset shifts the IMU clock)",
               (double)it[0] * 1e-9, (double)it[1] * 1e-9, (double)ft[0] * 1e-9, (double)ft[1] * 1e-9);
    else if (c.skipped_no_orientation >= most)
        sp_log(SP_LOG_ERROR, MOD, "%llu of %llu frames have no camera orientation (IMU gaps or a filter that never "
               "settled): nothing to fit", (unsigned long long)c.skipped_no_orientation, frames);
    else if (frames > 1 && ft[0] == ft[1]) /* no time between the frames, so no turn between them */
        sp_log(SP_LOG_ERROR, MOD,
               "the first and last of %llu frames carry the same timestamp (%.3f s), so they share one camera "
               "orientation: the capture's frame times are broken (import --fps or --frame-times sets them)",
               frames, (double)ft[0] * 1e-9);
    else if (c.skipped_undecodable >= most)
        sp_log(SP_LOG_ERROR, MOD, "%llu of %llu frames do not decode (damaged image data): nothing to fit",
               (unsigned long long)c.skipped_undecodable, frames);
    else if (c.skipped_dark >= most)
        sp_log(SP_LOG_ERROR, MOD, "%llu of %llu frames are too dark to fit (mean below 3%% of white): backlit to "
               "black, the lens covered, or the exposure far too short", (unsigned long long)c.skipped_dark, frames);
    else if (c.skipped_saturated >= most)
        sp_log(SP_LOG_ERROR, MOD, "%llu of %llu frames are over-exposed (a quarter of the pixels saturated)",
               (unsigned long long)c.skipped_saturated, frames);
    else if (c.accepted < MIN_FACE_FRAMES)
        sp_log(SP_LOG_ERROR, MOD,
               "a face was found in %llu of %llu frames, need at least %d seen from different sides (skipped: dark "
               "%llu, saturated %llu, blurred %llu, no face %llu, no orientation %llu)",
               (unsigned long long)c.accepted, frames, MIN_FACE_FRAMES, (unsigned long long)c.skipped_dark,
               (unsigned long long)c.skipped_saturated, (unsigned long long)c.skipped_blurred,
               (unsigned long long)c.skipped_no_face, (unsigned long long)c.skipped_no_orientation);
    else
        sp_log(SP_LOG_ERROR, MOD, "%d usable keyframe(s), need at least 2: the %llu frames with a face are all "
               "from one direction", n_keyframes, (unsigned long long)c.accepted);
    return 0;
}

/* The fast solver's overcast decision, then the Adam reference solver. */
static int solve_adam(sp_sunstage *ss, sp_sunstage_callback cb, void *user)
{
    int64_t t = sp_clock_monotonic_ns();
    int ret = ss->fit.unobservable ? 0 : ss_fast_overcast_check(ss);
    ret = ret ? ret : ss_fit_adam(ss, cb, user);
    ss->fit.solve_s = (double)(sp_clock_monotonic_ns() - t) * 1e-9;
    return ret;
}

int sp_sunstage_fit(sp_sunstage *ss, sp_sunstage_callback cb, void *user)
{
    if (!ss)
        return -EINVAL;
    ss->fit.t0 = sp_clock_monotonic_ns();
    free(ss->fit.lm_fitted); /* a record of this fit's frames only */
    ss->fit.lm_fitted = NULL;
    int idx[64];
    int n = ss_list_frames(ss, 0, idx, 64);
    if (!fittable(ss, n))
        return SP_ENODATA;
    ss->fit.yaw_range = ss_reservoir_yaw_range(ss, idx, n);
    ss->fit.unobservable = ss->fit.yaw_range < ss->set.min_rotation_deg;
    if (ss->fit.unobservable) {
        snprintf(ss->fit.notes, sizeof(ss->fit.notes),
                 "lighting unobservable: the keyframes cover %.0f deg of camera yaw (< %.0f); sun not fitted, "
                 "environment is a constant fitted to the mean shading",
                 ss->fit.yaw_range, ss->set.min_rotation_deg);
        sp_log(SP_LOG_WARN, MOD, "%s", ss->fit.notes);
    }
    int nsil = ss->set.silhouette_weight > 0.0 ? ss_silhouette_prepare(ss) : 0;
    if (nsil < 0)
        return nsil;
    sp_log(SP_LOG_INFO, MOD, "silhouette: skin-mask boundary found in %d of %d frames", nsil,
           sp_sunstage_n_frames(ss));
    double rms = ss_align_landmarks(ss, idx, n, 1, 30);
    if (rms < 0)
        return (int)rms;
    int hidx[16];
    int nh = ss_list_frames(ss, 1, hidx, 16);
    if (nh > 0 && ss_align_landmarks(ss, hidx, nh, 0, 20) < 0)
        sp_log(SP_LOG_WARN, MOD, "held-out frames could not be aligned");
    sp_log(SP_LOG_INFO, MOD, "stage 1: %d keyframes, landmark RMS %.2f px", n, rms);
    if (ss->set.texture_size == 0 && ss->set.solver == SP_SUNSTAGE_SOLVER_FAST) { /* the fast solver chooses */
        int ret = matched_texture_rows(ss, idx, n, &ss->fit.matched_rows);
        if (ret)
            return ret;
    }
    ss->fit.align_s = (double)(sp_clock_monotonic_ns() - ss->fit.t0) * 1e-9;
    ss_clock_sun_prepare(ss);
    if (cb) {
        sp_sunstage_progress p = { "align", 1, 1, (double)(sp_clock_monotonic_ns() - ss->fit.t0) * 1e-9, rms, NAN };
        cb(user, &p);
    }
    int ret = ss->set.solver == SP_SUNSTAGE_SOLVER_ADAM ? solve_adam(ss, cb, user) : solve_fast(ss, cb, user);
    if (!ret && ss_fit_logged_landmarks(ss, cb, user)) /* a record beside the fit: failing costs only it */
        sp_log(SP_LOG_WARN, MOD, "no memory for the fitted landmarks: landmarks_fitted.csv is left out");
    ss->fit.seconds = (double)(sp_clock_monotonic_ns() - ss->fit.t0) * 1e-9;
    ss->fit.fitted = ret == 0;
    ss_clock_sun_compare(ss);
    return ret;
}

int sp_sunstage_get_result(const sp_sunstage *ss, sp_sunstage_result *out)
{
    if (!ss || !out)
        return -EINVAL;
    memset(out, 0, sizeof(*out));
    out->model = ss->model;
    out->id = ss->fit.id;
    out->scale = ss->fit.scale;
    out->tex_width = ss->fit.tw;
    out->tex_height = ss->fit.th;
    out->albedo = ss->fit.albedo;
    out->displacement = ss->fit.disp;
    memcpy(out->ks, ss->fit.ks, sizeof(out->ks));
    memcpy(out->shininess, ss->fit.shin, sizeof(out->shininess));
    out->env = ss->fit.env;
    memcpy(out->sun_dir, ss->fit.sun_dir, sizeof(out->sun_dir));
    out->sun_intensity = ss->fit.sun_I;
    out->sun_dropped = ss->fit.sun_dropped;
    out->lighting_unobservable = ss->fit.unobservable;
    out->notes = ss->fit.notes;
    out->yaw_range_deg = ss->fit.yaw_range;
    int idx[64];
    out->n_frames = ss_list_frames(ss, 0, idx, 64);
    out->train_psnr = ss->fit.train_psnr;
    out->heldout_psnr = ss->fit.heldout_psnr;
    out->seconds = ss->fit.seconds;
    out->frontend_seconds = ss->fit.frontend_s;
    out->align_seconds = ss->fit.align_s;
    out->solve_seconds = ss->fit.solve_s;
    out->refine_seconds = ss->fit.refine_s;
    out->threads = ss->set.threads > 0 ? ss->set.threads : sp_cpu_count();
    out->have_clock_sun = ss->clock.have;
    memcpy(out->clock_sun_dir, ss->clock.dir, sizeof(out->clock_sun_dir));
    out->clock_sun_angle_deg = ss->clock.angle_deg;
    return 0;
}

int sp_sunstage_get_frame(const sp_sunstage *ss, int i, sp_sunstage_frame *out)
{
    const ss_frame *f = ss_nth_frame(ss, i);
    if (!f || !out)
        return -EINVAL;
    memset(out, 0, sizeof(*out));
    out->sequence = f->sequence;
    out->timestamp_ns = f->t;
    out->fx = f->cam.fx;
    out->fy = f->cam.fy;
    out->cx = f->cam.cx;
    out->cy = f->cam.cy;
    out->width = ss->W;
    out->height = ss->H;
    out->scale_to_capture = f->win.s > 0.0 ? 1.0 / f->win.s : 1.0;
    out->crop_x = f->win.x0;
    out->crop_y = f->win.y0;
    out->camera_to_world = f->q_c2w;
    memcpy(out->rotvec, f->rotvec, sizeof(out->rotvec));
    memcpy(out->t, f->t_face, sizeof(out->t));
    out->exp = f->exp;
    out->heldout = f->heldout;
    return 0;
}

const float *sp_sunstage_frame_image(const sp_sunstage *ss, int i)
{
    const ss_frame *f = ss_nth_frame(ss, i);
    return f ? f->rgb : NULL;
}

int sp_sunstage_align_world(const sp_sunstage *ss, double R[9])
{
    if (!ss || !R)
        return -EINVAL;
    sp_quat_mean mean;
    sp_quat_mean_init(&mean);
    for (int k = 0; ss->res.slots && k < ss->res.n_slots; k++) {
        const ss_frame *f = &ss->res.slots[k];
        if (f->used && f->has_truth)
            sp_quat_mean_add(&mean, sp_quat_normalize(sp_quat_mul(f->truth_q, sp_quat_conj(f->q_c2w))));
    }
    if (!mean.n)
        return SP_ENODATA;
    sp_quat_to_matrix(sp_quat_mean_get(&mean), R);
    return 0;
}

double sp_sunstage_linear_to_display(double x)
{
    return ss_tonemap(x);
}

double sp_sunstage_display_to_srgb(double display)
{
    double L = ss_tonemap_inverse(display, NULL);
    if (!(L > 0.0)) /* NaN too: black */
        return 0.0;
    if (L >= 1.0) /* clipped, as the camera would (and exactly 1, which 1.055 - 0.055 is not) */
        return 1.0;
    return sp_srgb_encode(L);
}

double sp_sunstage_exposure_reference(const sp_sunstage *ss)
{
    return ss ? ss->fe.expo_ref : 0.0;
}
