/* SPDX-License-Identifier: MIT */
/*
 * Per-frame front end: frames come from the orientation tagger with their camera
 * orientation and landmarks attached (sp_frame_tags). Convert and downsample each
 * frame once, detect landmarks with dlib when none came (on every frame, kept or
 * not: the tracker follows the face from frame to frame and its record covers the
 * capture), reject dark, saturated and blurred frames, frames without an
 * orientation and frames without a face, then offer the frame to the yaw-binned
 * keyframe reservoir. Nothing waits here: one frame at a time.
 */
#include "pipeline/sunstage/sunstage_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/pixconv.h"
#include "pipeline/sunstage/landmarks.h"
#include "sunprobe/sp_capture.h"

#define MOD "sunstage"

/* Fixes the fit resolution and intrinsics from the first frame and the metadata. */
static int setup_geometry(sp_sunstage *ss, uint32_t w, uint32_t h)
{
    ss->fe.cap_w = (int)w;
    ss->fe.cap_h = (int)h;
    if (ss->set.face_crop) { /* square crops, resampled to fit_width whatever the capture size */
        ss->W = ss->H = ss->set.fit_width;
    } else {
        ss->W = ss->set.fit_width < (int)w ? ss->set.fit_width : (int)w;
        ss->H = (int)lround((double)h * ss->W / (double)w);
    }
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
    ss->cap_fx = f, ss->cap_fy = fy, ss->cap_cx = cx, ss->cap_cy = cy;
    ss->fe.win = (ss_window){ 0.0, 0.0, s };
    ss_window_camera(ss, &ss->fe.win, &ss->cam);
    /* pixel encoding: sRGB unless the capture says it is the synthesiser's own (capture/FORMAT.md) */
    ss->fe.srgb = strcmp(ss->meta.transfer, "sunprobe") != 0;
    for (int v = 0; v < 256; v++)
        ss->fe.lut[v] = (float)sp_srgb_decode(v / 255.0);
    sp_log(SP_LOG_INFO, MOD, "pixel encoding: %s", ss->fe.srgb ? "sRGB (decoded to linear light)" : "sunprobe's own");
    ss->fe.rgb24 = malloc((size_t)w * h * 3);
    if (!ss->fe.rgb24)
        return -ENOMEM;
    ss->fe.work_rgb = malloc((size_t)ss->W * (size_t)ss->H * 3 * sizeof(float));
    ss->fe.work_clip = malloc((size_t)ss->W * (size_t)ss->H * SS_CLIP_FLOATS * sizeof(float));
    if (!ss->fe.work_rgb || !ss->fe.work_clip)
        return -ENOMEM;
    return ss_reservoir_alloc(ss);
}

/*
 * The fit works in the renderer's display encoding, gamma 2.2 of x / (1 + x) (ss_tonemap). A capture in
 * that encoding (the synthesiser's) is averaged as it is; an sRGB one is decoded to linear light first
 * (averaging encoded values would bias every footprint that spans an edge), then encoded for the fit. A
 * footprint touching a clipped (255) value is marked saturated (1.0), which the face mask drops: clipped
 * light has no known radiance; its lower bound goes to the clip buffer (SS_CLIP_FLOATS).
 */
typedef struct pixel_sum {
    double acc[3];
    int clipped;  /* bit c: channel c touched 255 */
    int outside;  /* part of the footprint lies outside the frame: nothing known, not even a bound */
} pixel_sum;

static void pixel_add(pixel_sum *p, const float *lut, const uint8_t *px, double wt)
{
    for (int c = 0; c < 3; c++) {
        p->acc[c] += wt * (lut ? (double)lut[px[c]] : (double)px[c]);
        p->clipped |= (lut && px[c] == 255 && wt > 0.0) << c;
    }
}

static void pixel_store(const pixel_sum *p, const float *lut, double wsum, float *out, float *clip)
{
    for (int c = 0; c < 3; c++) {
        out[c] = lut ? (p->clipped ? 1.0f : (float)ss_tonemap(p->acc[c] / wsum)) : (float)(p->acc[c] / (255.0 * wsum));
        clip[c] = p->clipped && !p->outside ? (float)ss_tonemap(p->acc[c] / wsum) : 0.0f;
    }
    clip[3] = p->outside ? 0.0f : (float)p->clipped;
}

/* Box filter from the capture-size RGB24 buffer to dst (dw x dh RGB floats in the fit's encoding). */
static void downsample(const uint8_t *src, int sw, int sh, int dw, int dh, const float *lut, float *rgb, float *clip)
{
    for (int y = 0; y < dh; y++) {
        int y0 = y * sh / dh, y1 = (y + 1) * sh / dh;
        if (y1 <= y0)
            y1 = y0 + 1;
        for (int x = 0; x < dw; x++) {
            int x0 = x * sw / dw, x1 = (x + 1) * sw / dw;
            if (x1 <= x0)
                x1 = x0 + 1;
            pixel_sum p = { { 0, 0, 0 }, 0, 0 };
            for (int yy = y0; yy < y1; yy++)
                for (int xx = x0; xx < x1; xx++)
                    pixel_add(&p, lut, src + ((size_t)yy * (size_t)sw + (size_t)xx) * 3, 1.0);
            size_t i = (size_t)y * (size_t)dw + (size_t)x;
            pixel_store(&p, lut, (double)((y1 - y0) * (x1 - x0)), rgb + i * 3, clip + i * SS_CLIP_FLOATS);
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

double ss_exposure_product(double exposure_us, double gain)
{
    int te = exposure_us > 0.0 && isfinite(exposure_us), tg = gain > 0.0 && isfinite(gain);
    /* an import may know the shutter time and not the gain (or the ISO alone): what is known still counts */
    return te || tg ? (te ? exposure_us : 1.0) * (tg ? gain : 1.0) : 0.0;
}

/* Exposure relative to the first frame from the frame's shutter time and gain; 1 when both are unknown. */
static double frame_exposure(sp_sunstage *ss, const sp_frame *frame)
{
    double e = ss_exposure_product((double)frame->exposure_us, (double)frame->gain);
    if (!(e > 0.0) || !isfinite(e))
        return 1.0;
    if (!(ss->fe.expo_ref > 0.0))
        ss->fe.expo_ref = e;
    return e / ss->fe.expo_ref;
}

void ss_window_camera(const sp_sunstage *ss, const ss_window *w, sp_face_camera *cam)
{
    sp_face_camera_init(cam, ss->cap_fx * w->s, ss->cap_fy * w->s, (ss->cap_cx + 0.5 - w->x0) * w->s - 0.5,
                        (ss->cap_cy + 0.5 - w->y0) * w->s - 0.5);
}

#define CROP_MARGIN 1.8 /* crop side over the landmarks' extent: room for the scalp, ears and silhouette */

void ss_window_around(const sp_sunstage *ss, const double *lm, ss_window *w)
{
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (int k = 0; k < 68; k++) {
        x0 = fmin(x0, (double)lm[2 * k]);
        x1 = fmax(x1, (double)lm[2 * k]);
        y0 = fmin(y0, (double)lm[2 * k + 1]);
        y1 = fmax(y1, (double)lm[2 * k + 1]);
    }
    double side = fmax(8.0, CROP_MARGIN * fmax(x1 - x0, y1 - y0));
    /* the landmarks run from the brows to the chin: centre a little above them for the forehead */
    double cx = 0.5 * (x0 + x1) + 0.5, cy = 0.5 * (y0 + y1) + 0.5 - 0.08 * side;
    w->x0 = cx - 0.5 * side;
    w->y0 = cy - 0.5 * side;
    w->s = (double)ss->W / side;
}

void ss_window_of(const sp_sunstage *ss, const double *lm, ss_window *w)
{
    *w = (ss_window){ 0.0, 0.0, (double)ss->W / (double)ss->fe.cap_w };
    if (ss->set.face_crop)
        ss_window_around(ss, lm, w);
}

/* Capture pixels (x, y) into the window's fit pixels. */
void ss_window_landmarks(const ss_window *w, const double *src, double lm[136])
{
    for (int k = 0; k < 68; k++) {
        lm[2 * k] = ((double)src[2 * k] + 0.5 - w->x0) * w->s - 0.5;
        lm[2 * k + 1] = ((double)src[2 * k + 1] + 0.5 - w->y0) * w->s - 0.5;
    }
}

/* Landmarks from the frame's side data, at fit resolution. */
static void tag_landmarks(const sp_sunstage *ss, const sp_frame_tags *tags, double lm[136])
{
    double cap[136];
    for (int k = 0; k < 136; k++)
        cap[k] = (double)tags->landmarks[k];
    ss_window_landmarks(&ss->fe.win, cap, lm);
}

/*
 * The window of the capture-size RGB24 frame into out (W x H floats): each fit
 * pixel averages n x n bilinear taps over its footprint (n = capture pixels per
 * fit pixel, at least 1). Outside the frame: white, which the face mask drops
 * as saturated.
 */
static void resample_window(const uint8_t *src, int sw, int sh, const ss_window *w, int W, int H, const float *lut,
                            float *out, float *clip)
{
    static const uint8_t white[3] = { 255, 255, 255 };
    int n = (int)ceil(1.0 / w->s - 1e-9);
    n = n < 1 ? 1 : (n > 8 ? 8 : n);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            pixel_sum p = { { 0, 0, 0 }, 0, 0 };
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++) {
                    double u = w->x0 + ((double)x + ((double)i + 0.5) / n) / w->s - 0.5;
                    double v = w->y0 + ((double)y + ((double)j + 0.5) / n) / w->s - 0.5;
                    if (u < -0.5 || v < -0.5 || u > sw - 0.5 || v > sh - 0.5) {
                        pixel_add(&p, lut, white, 1.0);
                        p.clipped = 1; /* outside the frame: nothing known */
                        p.outside = 1;
                        continue;
                    }
                    int u0 = (int)floor(u), v0 = (int)floor(v);
                    double fu = u - u0, fv = v - v0;
                    for (int q = 0; q < 4; q++) {
                        int uu = u0 + (q & 1), vv = v0 + (q >> 1);
                        uu = uu < 0 ? 0 : (uu >= sw ? sw - 1 : uu);
                        vv = vv < 0 ? 0 : (vv >= sh ? sh - 1 : vv);
                        double wt = ((q & 1) ? fu : 1.0 - fu) * ((q >> 1) ? fv : 1.0 - fv);
                        pixel_add(&p, lut, src + ((size_t)vv * (size_t)sw + (size_t)uu) * 3, wt);
                    }
                }
            size_t i = (size_t)y * (size_t)W + (size_t)x;
            pixel_store(&p, lut, (double)(n * n), out + i * 3, clip + i * SS_CLIP_FLOATS);
        }
}

/* Dark, saturated or blurred: counted and 1 when the frame is skipped (the sharpness mean is updated). */
static int skip_by_quality(sp_sunstage *ss, const float *rgb, double *sharp)
{
    double mean, sat;
    frame_stats(rgb, ss->W, ss->H, &mean, &sat, sharp);
    if (mean < 0.03) {
        ss->counts.skipped_dark++;
        return 1;
    }
    if (sat > 0.25) {
        ss->counts.skipped_saturated++;
        return 1;
    }
    ss->fe.sharp_n++;
    ss->fe.sharp_mean += (*sharp - ss->fe.sharp_mean) / (double)(ss->fe.sharp_n < 50 ? ss->fe.sharp_n : 50);
    if (ss->fe.sharp_n > 5 && *sharp < ss->set.blur_ratio * ss->fe.sharp_mean) {
        ss->counts.skipped_blurred++;
        return 1;
    }
    return 0;
}

static int detect(sp_sunstage *ss, uint64_t sequence, double lm[136]);

/* Offers the frame in ss->fe.work_rgb and attaches its truth when it takes a slot. */
static int offer(sp_sunstage *ss, const sp_frame *frame, int64_t t, const sp_frame_tags *tags, const double lm[136],
                 double sharp, double expo)
{
    ss->counts.accepted++;
    int slot = -1;
    int ret = ss_reservoir_offer(ss, ss->fe.work_rgb, ss->fe.work_clip, lm, sharp, expo, frame->sequence, t,
                                 tags->camera_to_world, 0, &slot);
    if (!ret && slot >= 0) {
        ss->res.slots[slot].has_truth = tags->has_true_orientation;
        ss->res.slots[slot].truth_q = tags->true_camera_to_world;
    }
    return ret;
}

/* Face-crop mode: landmarks first (they place the crop), then the crop's quality checks. */
static int crop_frame(sp_sunstage *ss, const sp_frame *frame, int64_t t, const sp_frame_tags *tags)
{
    double lmc[136];
    for (int k = 0; tags->has_landmarks && k < 136; k++)
        lmc[k] = (double)tags->landmarks[k];
    int face = tags->has_landmarks || (ss->set.use_dlib && detect(ss, frame->sequence, lmc) == 0);
    if (tags->orientation != SP_ORIENTATION_OK) {
        ss->counts.skipped_no_orientation++;
        return 0;
    }
    if (!face) {
        ss->counts.skipped_no_face++;
        return 0;
    }
    ss_window_around(ss, lmc, &ss->fe.win);
    resample_window(ss->fe.rgb24, ss->fe.cap_w, ss->fe.cap_h, &ss->fe.win, ss->W, ss->H, ss->fe.srgb ? ss->fe.lut : NULL,
                    ss->fe.work_rgb, ss->fe.work_clip);
    double sharp;
    if (skip_by_quality(ss, ss->fe.work_rgb, &sharp))
        return 0;
    double lm[136];
    ss_window_landmarks(&ss->fe.win, lmc, lm);
    return offer(ss, frame, t, tags, lm, sharp, frame_exposure(ss, frame));
}

int ss_frontend_frame(sp_sunstage *ss, const sp_frame *frame, int64_t t, const sp_frame_tags *tags)
{
    int ret;
    if (!ss->fe.rgb24 && (ret = setup_geometry(ss, frame->width, frame->height)))
        return ret;
    if ((int)frame->width != ss->fe.cap_w || (int)frame->height != ss->fe.cap_h) {
        ss->counts.skipped_no_face++; /* a size change mid-capture: not fittable with one camera */
        return 0;
    }
    ret = sp_pixconv_frame_to_rgb24(frame, ss->fe.rgb24, (size_t)ss->fe.cap_w * (size_t)ss->fe.cap_h * 3,
                                    (uint32_t)ss->fe.cap_w * 3);
    if (ret)
        return ret;
    if (ss->set.face_crop)
        return crop_frame(ss, frame, t, tags);
    downsample(ss->fe.rgb24, ss->fe.cap_w, ss->fe.cap_h, ss->W, ss->H, ss->fe.srgb ? ss->fe.lut : NULL,
               ss->fe.work_rgb, ss->fe.work_clip);
    double sharp, expo = 1.0;
    int skipped = skip_by_quality(ss, ss->fe.work_rgb, &sharp);
    if (!skipped)
        expo = frame_exposure(ss, frame);
    if (!skipped && tags->orientation != SP_ORIENTATION_OK) {
        ss->counts.skipped_no_orientation++;
        skipped = 1;
    }
    /* the tracker sees every frame, kept or not: it tracks from the frame before, and landmarks.csv covers them all */
    double lm[136], found[136];
    int face = tags->has_landmarks || (ss->set.use_dlib && detect(ss, frame->sequence, found) == 0);
    if (skipped)
        return 0;
    if (!face) {
        ss->counts.skipped_no_face++;
        return 0;
    }
    if (tags->has_landmarks)
        tag_landmarks(ss, tags, lm);
    else
        ss_window_landmarks(&ss->fe.win, found, lm);
    return offer(ss, frame, t, tags, lm, sharp, expo);
}

/* Keeps the tracker's result for the face directory; failing to keep it costs only the record. */
static void log_landmarks(sp_sunstage *ss, uint64_t sequence, const ss_lm_result *r)
{
    ss_frontend *fe = &ss->fe;
    if (fe->lm_n == fe->lm_cap) {
        size_t cap = fe->lm_cap ? 2 * fe->lm_cap : 256;
        ss_lm_entry *e = realloc(fe->lm_log, cap * sizeof(*e));
        if (!e)
            return;
        fe->lm_log = e, fe->lm_cap = cap;
    }
    ss_lm_entry *e = &fe->lm_log[fe->lm_n++];
    e->sequence = sequence;
    e->source = (int)r->source;
    e->drift = (float)r->drift;
    for (int k = 0; k < 136; k++)
        e->lm[k] = (float)r->lm[k];
}

/* The landmark tracker on the capture-size frame; 0 with landmarks in capture pixels, SP_ENODATA without a face. */
static int detect(sp_sunstage *ss, uint64_t sequence, double lm_out[136])
{
    if (!ss->fe.landmarks && !ss->fe.landmarks_failed) {
        ss_lm_settings ls;
        ss_lm_default_settings(&ls);
        ls.model_path = ss->set.dlib_model;
        if (ss_lm_tracker_open(&ss->fe.landmarks, &ls)) { /* the tracker logged why */
            sp_log(SP_LOG_ERROR, MOD, "frames without landmark side data are skipped");
            ss->fe.landmarks_failed = 1;
        }
    }
    if (!ss->fe.landmarks)
        return SP_ENODATA;
    ss_lm_result r;
    int ret = ss_lm_tracker_frame(ss->fe.landmarks, ss->fe.rgb24, ss->fe.cap_w, ss->fe.cap_h, &r);
    if (ret)
        return ret;
    log_landmarks(ss, sequence, &r);
    if (r.source == SS_LM_NONE)
        return SP_ENODATA;
    memcpy(lm_out, r.lm, sizeof(r.lm));
    return 0;
}
