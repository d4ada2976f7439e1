/* SPDX-License-Identifier: MIT */
/*
 * Per-frame front end: convert and downsample each frame once, reject dark,
 * saturated and blurred frames, wait (in a ring of SS_PENDING) for the IMU and
 * the frame's landmark side data, detect landmarks with dlib when none came,
 * then offer the frame to the yaw-binned keyframe reservoir.
 */
#include "pipeline/sunstage/sunstage_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/pixconv.h"
#include "pipeline/sunstage/dlib_shim.h"
#include "sp_config.h"
#include "sunprobe/sp_capture.h"

#define MOD "sunstage"
#define DEFAULT_DLIB_MODEL "/usr/share/dlib/shape_predictor_68_face_landmarks.dat"

void ss_dlib_close_ctx(void *ctx);
void ss_dlib_close_ctx(void *ctx)
{
#if HAVE_DLIB
    sp_dlib_close(ctx);
#else
    (void)ctx;
#endif
}

static int alloc_buffers(sp_sunstage *ss)
{
    size_t px = (size_t)ss->W * (size_t)ss->H * 3;
    ss->n_slots = ss->set.keyframes + ss->set.heldout;
    ss->slots = calloc((size_t)ss->n_slots, sizeof(ss_frame));
    if (!ss->slots)
        return -ENOMEM;
    for (int i = 0; i < ss->n_slots; i++) {
        ss->slots[i].rgb = malloc(px * sizeof(float));
        ss->slots[i].exp = calloc(ss->model->n_exp + 1, sizeof(double));
        if (!ss->slots[i].rgb || !ss->slots[i].exp)
            return -ENOMEM;
    }
    return 0;
}

/* Fixes the fit resolution and intrinsics from the first frame and the metadata. */
static int setup_geometry(sp_sunstage *ss, uint32_t w, uint32_t h)
{
    ss->cap_w = (int)w;
    ss->cap_h = (int)h;
    ss->W = ss->set.fit_width < (int)w ? ss->set.fit_width : (int)w;
    ss->H = (int)lround((double)h * ss->W / (double)w);
    if (ss->H < 16 || ss->W < 16)
        return SP_EUNSUPPORTED;
    double s = (double)ss->W / (double)w;
    double f = sp_capture_meta_focal_px(&ss->meta);
    if (!(f > 0.0)) {
        f = 1.1 * (double)w;
        sp_log(SP_LOG_WARN, MOD, "no focal length in the metadata: assuming %.0f px (about 50 deg)", f);
    }
    double fy = ss->meta.fy > 0.0 ? ss->meta.fy : f;
    double cx = isfinite(ss->meta.cx) ? ss->meta.cx : 0.5 * ((double)w - 1.0);
    double cy = isfinite(ss->meta.cy) ? ss->meta.cy : 0.5 * ((double)h - 1.0);
    ss->fx = f * s;
    ss->fy = fy * s;
    ss->cx = (cx + 0.5) * s - 0.5;
    ss->cy = (cy + 0.5) * s - 0.5;
    ss->dw = (int)w < SS_DETECT_W ? (int)w : SS_DETECT_W;
    ss->dh = (int)lround((double)h * ss->dw / (double)w);
    ss->rgb24 = malloc((size_t)w * h * 3);
    if (!ss->rgb24)
        return -ENOMEM;
    for (int i = 0; i < SS_PENDING; i++) {
        ss->pend[i].rgb = malloc((size_t)ss->W * (size_t)ss->H * 3 * sizeof(float));
        ss->pend[i].gray = malloc((size_t)ss->dw * (size_t)ss->dh);
        if (!ss->pend[i].rgb || !ss->pend[i].gray)
            return -ENOMEM;
    }
    return alloc_buffers(ss);
}

/* Box filter from the capture-size RGB24 buffer to dst (dw x dh x ch, floats or gray bytes). */
static void downsample(const uint8_t *src, int sw, int sh, int dw, int dh, float *rgb, uint8_t *gray)
{
    for (int y = 0; y < dh; y++) {
        int y0 = y * sh / dh, y1 = (y + 1) * sh / dh;
        if (y1 <= y0)
            y1 = y0 + 1;
        for (int x = 0; x < dw; x++) {
            int x0 = x * sw / dw, x1 = (x + 1) * sw / dw;
            if (x1 <= x0)
                x1 = x0 + 1;
            double acc[3] = { 0, 0, 0 };
            for (int yy = y0; yy < y1; yy++)
                for (int xx = x0; xx < x1; xx++)
                    for (int c = 0; c < 3; c++)
                        acc[c] += src[((size_t)yy * (size_t)sw + (size_t)xx) * 3 + (size_t)c];
            double n = (double)((y1 - y0) * (x1 - x0)) * 255.0;
            size_t o = (size_t)y * (size_t)dw + (size_t)x;
            if (rgb)
                for (int c = 0; c < 3; c++)
                    rgb[o * 3 + (size_t)c] = (float)(acc[c] / n);
            if (gray)
                gray[o] = (uint8_t)lround(255.0 * (0.299 * acc[0] + 0.587 * acc[1] + 0.114 * acc[2]) / n);
        }
    }
}

/* Mean luminance, saturated fraction and Laplacian energy (sharpness) of a fit-resolution frame. */
static void frame_stats(const float *rgb, int w, int h, double *mean, double *sat, double *sharp)
{
    double m = 0.0, s = 0.0, e = 0.0;
    for (int i = 0; i < w * h; i++) {
        const float *p = rgb + (size_t)i * 3;
        m += 0.299 * (double)p[0] + 0.587 * (double)p[1] + 0.114 * (double)p[2];
        s += (p[0] > 0.98f || p[1] > 0.98f || p[2] > 0.98f);
    }
    for (int y = 1; y < h - 1; y++)
        for (int x = 1; x < w - 1; x++) {
            size_t i = ((size_t)y * (size_t)w + (size_t)x) * 3 + 1;
            double l = (double)(4.0f * rgb[i] - rgb[i - 3] - rgb[i + 3] - rgb[i - (size_t)w * 3] - rgb[i + (size_t)w * 3]);
            e += l * l;
        }
    *mean = m / (w * h);
    *sat = s / (w * h);
    *sharp = e / ((w - 2) * (h - 2)) / fmax(*mean * *mean, 1e-6);
}

/* Exposure relative to the first frame from the frame's shutter time and gain; 1 when either is unknown. */
static double frame_exposure(sp_sunstage *ss, const sp_frame *frame)
{
    double e = (double)frame->exposure_us * (double)frame->gain;
    if (!(e > 0.0) || !isfinite(e))
        return 1.0;
    if (!(ss->expo_ref > 0.0))
        ss->expo_ref = e;
    return e / ss->expo_ref;
}

static ss_pending *free_pending(sp_sunstage *ss)
{
    for (int i = 0; i < SS_PENDING; i++)
        if (!ss->pend[i].used)
            return &ss->pend[i];
    return NULL;
}

/* 1 when pending frames wait only because the orientation filter has not initialised yet. */
static int waiting_for_init(sp_sunstage *ss)
{
    sp_orientation_stats st;
    return !ss->orient || (sp_orientation_get_stats(ss->orient, &st) == 0 && !st.initialized);
}

/*
 * Ring full before the filter initialised: rather than dropping the oldest
 * frame (it would get no orientation), drop the less sharp of the two pending
 * frames closest in time, so the ring thins out evenly over the start of the
 * capture; once initialised, the filter's history (states from before its
 * initialisation, re-levelled) gives every kept frame its orientation.
 */
static void thin_pending(sp_sunstage *ss)
{
    ss_pending *drop = NULL;
    int64_t best = INT64_MAX;
    for (int i = 0; i < SS_PENDING; i++) {
        ss_pending *a = &ss->pend[i], *next = NULL;
        if (!a->used)
            continue;
        for (int j = 0; j < SS_PENDING; j++) /* the next pending frame in time */
            if (ss->pend[j].used && ss->pend[j].t > a->t && (!next || ss->pend[j].t < next->t))
                next = &ss->pend[j];
        if (next && next->t - a->t < best) {
            best = next->t - a->t;
            drop = a->score < next->score ? a : next;
        }
    }
    if (drop) {
        drop->used = 0;
        ss->counts.thinned_early++;
    }
}

int ss_frontend_frame(sp_sunstage *ss, const sp_frame *frame, int64_t t)
{
    int ret;
    if (!ss->rgb24 && (ret = setup_geometry(ss, frame->width, frame->height)))
        return ret;
    if ((int)frame->width != ss->cap_w || (int)frame->height != ss->cap_h) {
        ss->counts.skipped_no_face++; /* a size change mid-capture: not fittable with one camera */
        return 0;
    }
    ret = sp_pixconv_frame_to_rgb24(frame, ss->rgb24, (size_t)ss->cap_w * (size_t)ss->cap_h * 3,
                                    (uint32_t)ss->cap_w * 3);
    if (ret)
        return ret;
    ss_pending *p = free_pending(ss);
    if (!p) {
        if (waiting_for_init(ss))
            thin_pending(ss);
        else
            ss_frontend_resolve(ss, 2); /* ring full: decide the oldest now */
        if (!(p = free_pending(ss)))
            return -ENOSPC;
    }
    downsample(ss->rgb24, ss->cap_w, ss->cap_h, ss->W, ss->H, p->rgb, NULL);
    double mean, sat, sharp;
    frame_stats(p->rgb, ss->W, ss->H, &mean, &sat, &sharp);
    if (mean < 0.03) {
        ss->counts.skipped_dark++;
        return 0;
    }
    if (sat > 0.25) {
        ss->counts.skipped_saturated++;
        return 0;
    }
    ss->sharp_n++;
    ss->sharp_mean += (sharp - ss->sharp_mean) / (double)(ss->sharp_n < 50 ? ss->sharp_n : 50);
    if (ss->sharp_n > 5 && sharp < ss->set.blur_ratio * ss->sharp_mean) {
        ss->counts.skipped_blurred++;
        return 0;
    }
    downsample(ss->rgb24, ss->cap_w, ss->cap_h, ss->dw, ss->dh, NULL, p->gray);
    p->used = 1;
    p->has_lm = 0;
    p->has_truth = 0;
    p->sequence = frame->sequence;
    p->t = t;
    p->score = sharp;
    p->expo = frame_exposure(ss, frame);
    if (frame->sequence > ss->pend_seq_max || !ss->have_pending_frame)
        ss->pend_seq_max = frame->sequence;
    ss->have_pending_frame = 1;
    return 0;
}

void ss_frontend_side(sp_sunstage *ss, const sp_event *ev)
{
    if (ev->side_kind == SP_SIDE_TRUE_ORIENTATION && ev->side_count == 4 && ev->side_values) {
        const float *v = ev->side_values;
        for (int i = 0; i < SS_PENDING; i++)
            if (ss->pend[i].used && ss->pend[i].sequence == ev->side_sequence) {
                ss->pend[i].truth_q = sp_quat_normalize((sp_quat){ v[0], v[1], v[2], v[3] });
                ss->pend[i].has_truth = 1;
            }
        return;
    }
    if (ev->side_kind != SP_SIDE_LANDMARKS_2D || ev->side_count != 136 || !ev->side_values || !ss->W)
        return;
    double s = (double)ss->W / (double)ss->cap_w;
    for (int i = 0; i < SS_PENDING; i++) {
        ss_pending *p = &ss->pend[i];
        if (!p->used || p->sequence != ev->side_sequence)
            continue;
        int ok = 1;
        for (int k = 0; k < 136; k++) {
            double v = (double)ev->side_values[k];
            ok &= isfinite(v);
            p->lm[k] = (v + 0.5) * s - 0.5;
        }
        p->has_lm = ok;
    }
}

/* dlib on the detector-size grey image; 0 with landmarks at fit resolution, SP_ENODATA without a face. */
static int detect(sp_sunstage *ss, ss_pending *p)
{
#if HAVE_DLIB
    if (!ss->dlib && !ss->dlib_failed) {
        const char *path = ss->set.dlib_model ? ss->set.dlib_model : DEFAULT_DLIB_MODEL;
        if (sp_dlib_open(&ss->dlib, path)) {
            sp_log(SP_LOG_ERROR, MOD,
                   "cannot load the dlib landmark model %s (Debian package libdlib-data); frames without "
                   "landmark side data are skipped", path);
            ss->dlib_failed = 1;
        }
    }
    if (!ss->dlib)
        return SP_ENODATA;
    float lm[136];
    if (sp_dlib_landmarks(ss->dlib, p->gray, ss->dw, ss->dh, lm))
        return SP_ENODATA;
    double s = (double)ss->W / (double)ss->dw;
    for (int k = 0; k < 136; k++)
        p->lm[k] = ((double)lm[k] + 0.5) * s - 0.5;
    return 0;
#else
    (void)p;
    if (!ss->dlib_failed)
        sp_log(SP_LOG_ERROR, MOD,
               "a frame has no landmark side data and this build has no dlib (meson option -Ddlib=enabled)");
    ss->dlib_failed = 1;
    return SP_EDISABLED;
#endif
}

static ss_pending *oldest_pending(sp_sunstage *ss)
{
    ss_pending *o = NULL;
    for (int i = 0; i < SS_PENDING; i++)
        if (ss->pend[i].used && (!o || ss->pend[i].t < o->t))
            o = &ss->pend[i];
    return o;
}

/* Decides one pending frame; returns 1 when it must wait longer. */
static int decide(sp_sunstage *ss, ss_pending *p, int final)
{
    sp_quat q;
    int ret = ss->orient ? sp_orientation_camera_at(ss->orient, p->t, &q) : -EAGAIN;
    int newer = ss->pend_seq_max > p->sequence;
    if (!final && ((ret == -EAGAIN) || (!p->has_lm && !newer)))
        return 1;
    p->used = 0;
    if (ret) {
        ss->counts.skipped_no_orientation++;
        return 0;
    }
    if (!p->has_lm && !(ss->set.use_dlib && detect(ss, p) == 0)) {
        ss->counts.skipped_no_face++;
        return 0;
    }
    ss->counts.accepted++;
    ss_reservoir_offer(ss, p->rgb, p->lm, p->score, p->expo, p->sequence, p->t, q, 0);
    for (int i = 0; i < ss->n_slots; i++) /* the slot it took, if any: attach the truth */
        if (ss->slots[i].used && ss->slots[i].sequence == p->sequence && ss->slots[i].t == p->t) {
            ss->slots[i].has_truth = p->has_truth;
            ss->slots[i].truth_q = p->truth_q;
        }
    return 0;
}

int ss_frontend_resolve(sp_sunstage *ss, int final)
{
    ss_pending *p;
    while ((p = oldest_pending(ss))) {
        if (decide(ss, p, final))
            return 0;
        if (final == 2)
            return 0; /* made room for one frame */
    }
    return 0;
}

static double heading(sp_quat q)
{
    sp_vec3 fwd = sp_quat_rotate(q, (sp_vec3){ 0, 0, 1 });
    return atan2(fwd.y, fwd.x);
}

int ss_reservoir_offer(sp_sunstage *ss, const float *rgb, const double lm[136], double score, double expo,
                       uint64_t seq, int64_t t, sp_quat q, int heldout_hint)
{
    if (!ss->slots) {
        int ret = alloc_buffers(ss);
        if (ret)
            return ret;
    }
    int K = ss->set.keyframes, Hn = ss->set.heldout;
    double yaw = heading(q);
    double u = (yaw + M_PI) / (2.0 * M_PI);
    u = u < 0.0 ? 0.0 : (u >= 1.0 ? 0.999999 : u);
    int slot = -1, held;
    if (heldout_hint >= 2) { /* direct: first free slot of the kind */
        held = heldout_hint == 2;
        for (int i = held ? K : 0; i < (held ? K + Hn : K); i++)
            if (!ss->slots[i].used) {
                slot = i;
                break;
            }
        if (slot < 0)
            return -ENOSPC;
    } else {
        held = Hn > 0 && seq % 7 == 3;
        slot = held ? K + (int)(u * Hn) : (int)(u * K);
        if (ss->slots[slot].used && ss->slots[slot].score >= score)
            return 0;
    }
    ss_frame *f = &ss->slots[slot];
    f->used = 1;
    f->heldout = held;
    f->sequence = seq;
    f->t = t;
    f->score = score;
    f->expo = expo > 0.0 && isfinite(expo) ? expo : 1.0;
    f->yaw = yaw;
    f->q_c2w = sp_quat_normalize(q);
    f->has_truth = 0;
    sp_quat_to_matrix(f->q_c2w, f->R_c2w);
    memcpy(f->rgb, rgb, (size_t)ss->W * (size_t)ss->H * 3 * sizeof(float));
    memcpy(f->lm, lm, sizeof(f->lm));
    memset(f->exp, 0, ss->model->n_exp * sizeof(double));
    return 0;
}
