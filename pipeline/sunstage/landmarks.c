/* SPDX-License-Identifier: MIT */
/*
 * Landmark tracking (landmarks.h). dlib's HOG detector needs a face of 80 px
 * or more and its shape predictor has no confidence of its own, so:
 *  - every placement runs on a square crop resampled so the face is CROP_FACE
 *    px across, whatever its size in the frame (40 px faces are enlarged,
 *    full-frame faces reduced), with the face's grey levels stretched so a
 *    backlit face is not a few grey levels deep;
 *  - a frame is first placed from the previous frame's landmarks (the face
 *    moves little between selfie frames), then from a detection near them,
 *    then from a detection in the whole frame at growing scales;
 *  - the confidence is self-consistency: placing again from the box of the
 *    placed points must land on the same points. A good placement is a fixed
 *    point; a placement on background or a half-found face drifts.
 * The box dlib's predictor was trained with is the detector's, not the
 * points' bounding box: the relation between the two is learned from this
 * capture's own detections.
 */
#include "pipeline/sunstage/landmarks.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/data_path.h"
#include "pipeline/sunstage/dlib_shim.h"
#include "pipeline/sunstage/landmark_offsets.h"
#include "sunprobe/sp_common.h"

#define MOD "landmarks"
#define DEFAULT_MODEL "/usr/share/dlib/shape_predictor_68_face_landmarks.dat" /* where install-deps.sh puts it */
#define CROP_FACE 100.0  /* detector-box side in crop pixels: above the HOG detector's 80 px window */
#define CROP_SIDE 256    /* crop size in pixels: 2.56 face widths, room for a face that moved */
#define SEARCH_MAX_W 960 /* whole-frame detection at most this wide (larger frames are reduced first) */
#define MAX_FACES 8

void sp_dlib_model_locate(sp_data_location *out)
{
    sp_data_locate("SP_DLIB_MODEL", "shape_predictor_68_face_landmarks.dat", NULL, DEFAULT_MODEL, out);
}

struct ss_lm_tracker {
    ss_lm_settings set;
    void *dlib;
    int have_prev;
    double prev[136];
    /* detector box from the points' box: centre offset and side over the points' side (learned) */
    double box_k, box_ox, box_oy;
    int box_n;
    uint8_t *gray;   /* the frame in grey, capture size */
    size_t gray_cap;
    uint8_t *search; /* the whole-frame search image */
    size_t search_cap;
    uint8_t crop[CROP_SIDE * CROP_SIDE];
};

void ss_lm_default_settings(ss_lm_settings *s)
{
    *s = (ss_lm_settings){ .model_path = NULL, .max_drift = 0.06, .normalise = 1, .track = 1, .model_offsets = 1 };
}

double ss_lm_interocular(const double lm[136])
{
    return hypot(lm[2 * 45] - lm[2 * 36], lm[2 * 45 + 1] - lm[2 * 36 + 1]);
}

void ss_lm_apply_offsets(double lm[136])
{
    double ex = lm[2 * 45] - lm[2 * 36], ey = lm[2 * 45 + 1] - lm[2 * 36 + 1];
    for (int k = 0; k < 68; k++) { /* x along the eye line, y 90 degrees on (down the face), both scaled by it */
        if (k >= 17 && k <= 26)
            continue; /* brows: where they are is the skin's drawing, not the mesh's; the renders say nothing */
        double ox = (double)landmark_offsets[2 * k], oy = (double)landmark_offsets[2 * k + 1];
        lm[2 * k] += ox * ex - oy * ey;
        lm[2 * k + 1] += ox * ey + oy * ex;
    }
}

/* The points' bounding box as a centre and the longer side. */
static void points_box(const double lm[136], double *cx, double *cy, double *side)
{
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (int k = 0; k < 68; k++) {
        x0 = fmin(x0, lm[2 * k]), x1 = fmax(x1, lm[2 * k]);
        y0 = fmin(y0, lm[2 * k + 1]), y1 = fmax(y1, lm[2 * k + 1]);
    }
    *cx = 0.5 * (x0 + x1), *cy = 0.5 * (y0 + y1), *side = fmax(x1 - x0, y1 - y0);
}

/* The detector-style box (left, top, right, bottom) for a set of points. */
static void box_from_points(const ss_lm_tracker *t, const double lm[136], double box[4])
{
    double cx, cy, side;
    points_box(lm, &cx, &cy, &side);
    double s = t->box_k * side;
    cx += t->box_ox * side, cy += t->box_oy * side;
    box[0] = cx - 0.5 * s, box[1] = cy - 0.5 * s, box[2] = cx + 0.5 * s, box[3] = cy + 0.5 * s;
}

/* A detection and the points placed from it refine the box relation (a running mean, then slowly moving). */
static void learn_box(ss_lm_tracker *t, const double box[4], const double lm[136])
{
    double cx, cy, side;
    points_box(lm, &cx, &cy, &side);
    if (!(side > 1.0))
        return;
    double k = (box[2] - box[0]) / side;
    double ox = (0.5 * (box[0] + box[2]) - cx) / side, oy = (0.5 * (box[1] + box[3]) - cy) / side;
    t->box_n++;
    double a = 1.0 / (double)(t->box_n < 30 ? t->box_n + 1 : 31); /* +1: the default counts as one sample */
    t->box_k += a * (k - t->box_k);
    t->box_ox += a * (ox - t->box_ox);
    t->box_oy += a * (oy - t->box_oy);
}

/* A byte buffer of at least n bytes (kept between frames). */
static int reserve_bytes(uint8_t **buf, size_t *cap, size_t n)
{
    if (n <= *cap)
        return 0;
    uint8_t *b = realloc(*buf, n);
    if (!b)
        return -ENOMEM;
    *buf = b, *cap = n;
    return 0;
}

/* Grey from RGB24 (Rec. 601 weights, as dlib's own conversion). */
static int to_gray(ss_lm_tracker *t, const uint8_t *rgb, int w, int h)
{
    size_t n = (size_t)w * (size_t)h;
    int ret = reserve_bytes(&t->gray, &t->gray_cap, n);
    if (ret)
        return ret;
    for (size_t i = 0; i < n; i++) {
        const uint8_t *p = rgb + 3 * i;
        t->gray[i] = (uint8_t)((77u * p[0] + 150u * p[1] + 29u * p[2] + 128u) >> 8);
    }
    return 0;
}

/* Bilinear sample of a grey image, clamped at the border. */
static double sample(const uint8_t *g, int w, int h, double u, double v)
{
    u = fmin(fmax(u, 0.0), (double)w - 1.0), v = fmin(fmax(v, 0.0), (double)h - 1.0);
    int u0 = (int)u, v0 = (int)v;
    int u1 = u0 + 1 < w ? u0 + 1 : u0, v1 = v0 + 1 < h ? v0 + 1 : v0;
    double fu = u - u0, fv = v - v0;
    const uint8_t *r0 = g + (size_t)v0 * (size_t)w, *r1 = g + (size_t)v1 * (size_t)w;
    return (1 - fv) * ((1 - fu) * r0[u0] + fu * r0[u1]) + fv * ((1 - fu) * r1[u0] + fu * r1[u1]);
}

/*
 * Resamples src (w x h) into dst (dw x dh): dst pixel (x, y) is src around
 * ((x + 0.5) / scale + x0 - 0.5, ...), averaging n x n taps when reducing.
 */
static void resample(const uint8_t *src, int w, int h, double x0, double y0, double scale, uint8_t *dst, int dw,
                     int dh)
{
    int n = (int)ceil(1.0 / scale - 1e-9);
    n = n < 1 ? 1 : (n > 8 ? 8 : n);
    for (int y = 0; y < dh; y++)
        for (int x = 0; x < dw; x++) {
            double acc = 0.0;
            for (int j = 0; j < n; j++)
                for (int i = 0; i < n; i++)
                    acc += sample(src, w, h, x0 + ((double)x + ((double)i + 0.5) / n) / scale - 0.5,
                                  y0 + ((double)y + ((double)j + 0.5) / n) / scale - 0.5);
            dst[(size_t)y * (size_t)dw + (size_t)x] = (uint8_t)lround(acc / (n * n));
        }
}

/*
 * Stretches the crop's grey levels so the face box's 1st to 99th percentile
 * spans the range and its median lands at mid-grey (a gamma): the detector's
 * and predictor's features then see a backlit or side-lit face as they see a
 * well-lit one. Monotonic, so no edges are made up.
 */
static void normalise_crop(uint8_t *crop, const double box[4])
{
    unsigned hist[256] = { 0 };
    int x0 = (int)fmax(0.0, box[0]), x1 = (int)fmin(CROP_SIDE - 1.0, box[2]);
    int y0 = (int)fmax(0.0, box[1]), y1 = (int)fmin(CROP_SIDE - 1.0, box[3]);
    unsigned n = 0;
    for (int y = y0; y <= y1; y++)
        for (int x = x0; x <= x1; x++, n++)
            hist[crop[y * CROP_SIDE + x]]++;
    if (n < 64)
        return;
    int lo = 0, hi = 255, med = 128;
    unsigned acc = 0;
    for (int v = 0; v < 256; v++) {
        unsigned prev = acc;
        acc += hist[v];
        if (prev < n / 100 && acc >= n / 100)
            lo = v;
        if (prev < n / 2 && acc >= n / 2)
            med = v;
        if (prev < n - n / 100 && acc >= n - n / 100)
            hi = v;
    }
    if (hi - lo < 4)
        return;
    double tm = fmin(fmax(((double)med - lo) / (double)(hi - lo), 0.05), 0.95);
    double g = fmin(fmax(log(0.5) / log(tm), 0.4), 2.5);
    uint8_t lut[256];
    for (int v = 0; v < 256; v++) {
        double u = fmin(fmax(((double)v - lo) / (double)(hi - lo), 0.0), 1.0);
        lut[v] = (uint8_t)lround(255.0 * pow(u, g));
    }
    for (int i = 0; i < CROP_SIDE * CROP_SIDE; i++)
        crop[i] = lut[crop[i]];
}

/* A crop of the frame centred on box, scaled so the box is CROP_FACE px; *x0, *y0, *scale map it back. */
static void make_crop(ss_lm_tracker *t, int w, int h, const double box[4], int normalise, double *x0, double *y0,
                      double *scale, double cbox[4])
{
    double side = fmax(box[2] - box[0], 4.0);
    *scale = CROP_FACE / side;
    double cx = 0.5 * (box[0] + box[2]), cy = 0.5 * (box[1] + box[3]);
    *x0 = cx - 0.5 * CROP_SIDE / *scale;
    *y0 = cy - 0.5 * CROP_SIDE / *scale;
    resample(t->gray, w, h, *x0, *y0, *scale, t->crop, CROP_SIDE, CROP_SIDE);
    for (int k = 0; k < 4; k++)
        cbox[k] = (box[k] - ((k & 1) ? *y0 : *x0)) * *scale;
    if (normalise)
        normalise_crop(t->crop, cbox);
}

/* Crop pixels back to frame pixels (pixel centres: crop x at frame x0 + (x + 0.5) / scale - 0.5). */
static void crop_to_frame(const float *in, double x0, double y0, double scale, double out[136])
{
    for (int k = 0; k < 68; k++) {
        out[2 * k] = x0 + ((double)in[2 * k] + 0.5) / scale - 0.5;
        out[2 * k + 1] = y0 + ((double)in[2 * k + 1] + 0.5) / scale - 0.5;
    }
}

/* Places the points from box (frame pixels) and measures their drift. 0, SP_ENODATA or an error. */
static int place_on(ss_lm_tracker *t, int w, int h, const double box[4], int normalise, double lm[136], double *drift)
{
    double x0, y0, scale, cbox[4];
    make_crop(t, w, h, box, normalise, &x0, &y0, &scale, cbox);
    float p[136];
    int ret = sp_dlib_shape(t->dlib, t->crop, CROP_SIDE, CROP_SIDE, cbox, p);
    if (ret)
        return ret;
    double first[136], again_box[4], cagain[4];
    crop_to_frame(p, x0, y0, scale, first);
    box_from_points(t, first, again_box);
    for (int k = 0; k < 4; k++) /* the same crop: only the box moves */
        cagain[k] = (again_box[k] - ((k & 1) ? y0 : x0)) * scale;
    float q[136];
    if ((ret = sp_dlib_shape(t->dlib, t->crop, CROP_SIDE, CROP_SIDE, cagain, q)))
        return ret;
    crop_to_frame(q, x0, y0, scale, lm);
    double iod = ss_lm_interocular(lm), d = 0.0;
    for (int k = 0; k < 68; k++)
        d += hypot(lm[2 * k] - first[2 * k], lm[2 * k + 1] - first[2 * k + 1]) / 68.0;
    *drift = iod > 1.0 ? d / iod : (double)INFINITY;
    return 0;
}

static int place(ss_lm_tracker *t, int w, int h, const double box[4], double lm[136], double *drift)
{
    return place_on(t, w, h, box, t->set.normalise, lm, drift);
}

static double box_iou(const double a[4], const double b[4])
{
    double iw = fmin(a[2], b[2]) - fmax(a[0], b[0]), ih = fmin(a[3], b[3]) - fmax(a[1], b[1]);
    if (iw <= 0.0 || ih <= 0.0)
        return 0.0;
    double i = iw * ih;
    return i / ((a[2] - a[0]) * (a[3] - a[1]) + (b[2] - b[0]) * (b[3] - b[1]) - i);
}

/* Accepts a placement when it is consistent and lies (mostly) in the frame. */
static int acceptable(const ss_lm_tracker *t, const double lm[136], double drift, int w, int h)
{
    double cx, cy, side;
    points_box(lm, &cx, &cy, &side);
    double iod = ss_lm_interocular(lm);
    return drift <= t->set.max_drift && iod >= 4.0 && cx >= 0.0 && cy >= 0.0 && cx < w && cy < h &&
           side < 2.0 * fmax(w, h);
}

/* Tries the best detection among faces (in frame pixels) overlapping near (any when near is NULL). */
static int place_detected(ss_lm_tracker *t, int w, int h, const sp_dlib_face *faces, int n, const double *near,
                          ss_lm_source source, ss_lm_result *out)
{
    for (int i = 0; i < n; i++) {
        if (near && box_iou(faces[i].box, near) < 0.25)
            continue;
        double lm[136], drift;
        int ret = place(t, w, h, faces[i].box, lm, &drift);
        if (ret < 0)
            return ret;
        if (ret || !acceptable(t, lm, drift, w, h)) {
            if (!ret)
                out->rejected_drift = drift;
            continue;
        }
        learn_box(t, faces[i].box, lm);
        memcpy(out->lm, lm, sizeof(lm));
        out->drift = drift, out->score = faces[i].score, out->source = source;
        return 1;
    }
    return 0;
}

/*
 * Detection in the whole frame: at most SEARCH_MAX_W wide first (cheap), then at full size for a larger frame,
 * then, for a frame no wider than SEARCH_MAX_W, enlarged 2x for faces under the detector's 80 px window.
 */
static int search(ss_lm_tracker *t, int w, int h, ss_lm_result *out)
{
    double scales[3];
    int n_scales = 0;
    if (w > SEARCH_MAX_W) {
        scales[n_scales++] = (double)SEARCH_MAX_W / w;
        scales[n_scales++] = 1.0;
    } else {
        scales[n_scales++] = 1.0;
        scales[n_scales++] = 2.0;
    }
    for (int si = 0; si < n_scales; si++) {
        double s = scales[si];
        int sw = (int)lround(w * s), sh = (int)lround(h * s);
        int ret = reserve_bytes(&t->search, &t->search_cap, (size_t)sw * (size_t)sh);
        if (ret)
            return ret;
        resample(t->gray, w, h, 0.0, 0.0, s, t->search, sw, sh);
        sp_dlib_face faces[MAX_FACES];
        int n = sp_dlib_detect(t->dlib, t->search, sw, sh, 0.0, faces, MAX_FACES);
        if (n < 0)
            return n == SP_ENODATA ? 0 : n;
        for (int i = 0; i < n; i++)
            for (int k = 0; k < 4; k++)
                faces[i].box[k] = (faces[i].box[k] + 0.5) / s - 0.5;
        ret = place_detected(t, w, h, faces, n, NULL, SS_LM_SEARCHED, out);
        if (ret)
            return ret < 0 ? ret : 1;
    }
    return 0;
}

/* Near the previous face: placed from its points, else from a detection in a crop around them. */
static int track(ss_lm_tracker *t, int w, int h, ss_lm_result *out)
{
    double box[4], lm[136], drift;
    box_from_points(t, t->prev, box);
    int ret = place(t, w, h, box, lm, &drift);
    if (ret < 0)
        return ret;
    if (!ret && acceptable(t, lm, drift, w, h)) {
        memcpy(out->lm, lm, sizeof(lm));
        out->drift = drift, out->source = SS_LM_TRACKED;
        return 1;
    }
    if (!ret)
        out->rejected_drift = drift;
    double x0, y0, scale, cbox[4];
    make_crop(t, w, h, box, t->set.normalise, &x0, &y0, &scale, cbox);
    sp_dlib_face faces[MAX_FACES];
    int n = sp_dlib_detect(t->dlib, t->crop, CROP_SIDE, CROP_SIDE, -0.5, faces, MAX_FACES);
    if (n < 0)
        return n == SP_ENODATA ? 0 : n;
    for (int i = 0; i < n; i++)
        for (int k = 0; k < 4; k++)
            faces[i].box[k] = ((k & 1) ? y0 : x0) + (faces[i].box[k] + 0.5) / scale - 0.5;
    return place_detected(t, w, h, faces, n, box, SS_LM_DETECTED, out);
}

int ss_lm_tracker_frame(ss_lm_tracker *t, const uint8_t *rgb24, int w, int h, ss_lm_result *out)
{
    if (!t || !rgb24 || w <= 0 || h <= 0 || !out)
        return -EINVAL;
    *out = (ss_lm_result){ .source = SS_LM_NONE, .drift = NAN, .score = NAN, .rejected_drift = NAN };
    int ret = to_gray(t, rgb24, w, h);
    int found = 0;
    if (!ret && t->set.track && t->have_prev)
        found = track(t, w, h, out);
    if (!ret && found == 0)
        found = search(t, w, h, out);
    if (found < 0)
        return found;
    t->have_prev = found > 0;
    if (found > 0) {
        memcpy(t->prev, out->lm, sizeof(t->prev)); /* dlib's own points: the next frame is placed from them */
        if (t->set.model_offsets)
            ss_lm_apply_offsets(out->lm);
    }
    return ret;
}

int ss_lm_tracker_open(ss_lm_tracker **out, const ss_lm_settings *s)
{
    if (!out)
        return -EINVAL;
    *out = NULL;
    ss_lm_tracker *t = calloc(1, sizeof(*t));
    if (!t)
        return -ENOMEM;
    if (s)
        t->set = *s;
    else
        ss_lm_default_settings(&t->set);
    sp_data_location loc;
    sp_dlib_model_locate(&loc);
    const char *path = t->set.model_path ? t->set.model_path : loc.path;
    int ret = sp_dlib_open(&t->dlib, path);
    if (ret == SP_EDISABLED) {
        sp_log(SP_LOG_ERROR, MOD, "this build has no dlib to place landmarks (meson option -Ddlib=enabled)");
        free(t);
        return ret;
    }
    if (ret) {
        sp_log(SP_LOG_ERROR, MOD, "cannot load the dlib landmark model %s (Debian package libdlib-data): %s", path,
               sp_strerror(ret));
        free(t);
        return ret;
    }
    /* dlib's HOG box against the 68 points' box until this capture's detections say otherwise: as measured on
       synthetic renders (landmark_offsets prints it); a wrong start makes the first placements drift */
    t->box_k = 1.035, t->box_ox = 0.0, t->box_oy = -0.065;
    *out = t;
    return 0;
}

void ss_lm_tracker_box_relation(const ss_lm_tracker *t, double *side, double *dx, double *dy, int *n)
{
    *side = t->box_k, *dx = t->box_ox, *dy = t->box_oy, *n = t->box_n;
}

void ss_lm_tracker_close(ss_lm_tracker **t)
{
    if (!t || !*t)
        return;
    sp_dlib_close((*t)->dlib);
    free((*t)->gray);
    free((*t)->search);
    free(*t);
    *t = NULL;
}
