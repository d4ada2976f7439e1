/* SPDX-License-Identifier: MIT */
/*
 * Removal from one image against the truth's empty street: PSNR and SSIM in
 * the removed region (every pixel the truth says an object or its shadow
 * changed, and every pixel either method changed) for exemplar inpainting on
 * the grown masks (objects from boxes + their shadows) against OpenCV's Telea
 * on the object masks alone (the baseline), with the two ablations between
 * them, and two oracles (each fill on the truth's own region: what a perfect mask would give); then the
 * time of one 1280x720 depopulation on one core. Each frame's line also says how much of the truth's object
 * and shadow pixels our mask left, and where our squared error lies: left in, filled, and of the filled part
 * how much lies outside the truth's region (and there, in the objects' own masks).
 *
 * With --camera (and --sun, the truth's sun as azimuth from the view direction to the right and
 * elevation), also the sun from each frame's shadows (depop_sun.c) and its error.
 *
 * usage: bench_depopulate [--whole-boxes] [--time FRAME.png BACKGROUND.png] [--camera F,CX,CY,PITCH [--sun AZ,EL]]
 *   [--clock-sun AZ,EL] (the sun the command gets from --utc, --location and --heading; masks use it where
 *   no closed shadow tells the sun)
 *   (--time runs with the camera when one is given, as the commands do)
 *                         LABEL FRAME BACKGROUND IDS SHADOWS ...
 *   IDS "-": objects are the pixels that differ from the background and are no shadow of it;
 *   SHADOWS "-": the removed region is every pixel that differs from the background (noise-free
 *   frames), else the IDS and SHADOWS images' nonzero pixels (grainy frames)
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench_util.h"
#include "common/image_metrics.h"
#include "export/png.h"
#include "export/png_read.h"
#include "pipeline/probe/depopulate.h"
#include "pipeline/probe/opencv_probe_shim.h"
#include "pipeline/probe/probe_internal.h"
#include "sp_config.h"

#define MAX_OBJ 64
#define N_METHODS 6
#define OURS 3

/* the last two are oracles: what each fill makes of the truth's own region (what a perfect mask would give) */
static const char *const method_names[N_METHODS] = {
    "Telea, object boxes alone (baseline)", "Telea, silhouettes alone",          "Telea, grown masks",
    "exemplar, grown masks (ours)",         "oracle: Telea, the truth's region", "oracle: exemplar, the truth's region"
};

typedef struct sun_eval {
    int on, truth;
    sp_depop_camera cam;
    double az, el;            /* the truth */
    double err_az[256], err_el[256];       /* every frame with an answer */
    double closed_az[256], closed_el[256]; /* the frames whose answer is from closed shadows */
    int frames, found, closed;
} sun_eval;

static sun_eval sun;
static sp_depop_sun clock_sun; /* --clock-sun: what the command is given with --utc, --location and --heading */
static int whole_boxes;        /* --whole-boxes: every method removes the boxes as given (no silhouettes) */
static int timing;             /* in time_one: no sun figures */

typedef struct scene {
    uint8_t *rgb, *bg, *objpx; /* objpx: the truth's object pixels */
    uint32_t w, h;
    sp_depop_object obj[MAX_OBJ];
    size_t n;
    uint8_t *changed; /* the truth's removed region: objects and their shadows */
} scene;

static int load_ids(scene *s, const char *ids)
{
    uint8_t *rgba = NULL;
    uint32_t w, h;
    int ret = sp_png_read_rgba(ids, &rgba, &w, &h);
    if (ret || w != s->w || h != s->h) {
        free(rgba);
        return ret ? ret : -EINVAL;
    }
    for (size_t i = 0; i < (size_t)w * h; i++)
        s->objpx[i] = rgba[4 * i] ? rgba[4 * i] : 0;
    free(rgba);
    return 0;
}

/* Objects without an id image: changed pixels that are no shadow of the background. */
static void objects_from_background(scene *s)
{
    for (size_t i = 0; i < (size_t)s->w * s->h; i++) {
        const uint8_t *p = s->rgb + 3 * i, *q = s->bg + 3 * i;
        int d = abs(p[0] - q[0]) + abs(p[1] - q[1]) + abs(p[2] - q[2]);
        s->objpx[i] = d > 12 && !probe_shadow_of(p, q, 200, 1000, 40, 3) ? 1 : 0;
    }
}

/* Boxes: 8-connected components of the object pixels (ids apart), closed over 2 pixels, 20 px or more. */
static void boxes(scene *s)
{
    int w = (int)s->w, h = (int)s->h;
    int32_t *lab = calloc((size_t)w * h, sizeof(int32_t)), *q = malloc((size_t)w * h * sizeof(int32_t));
    int32_t next = 0;
    for (int y = 0; y < h && lab && q; y++)
        for (int x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            if (!s->objpx[i] || lab[i])
                continue;
            size_t head = 0, n = 0;
            int x0 = x, y0 = y, x1 = x, y1 = y;
            lab[i] = ++next, q[n++] = (int32_t)i;
            while (head < n) {
                int32_t k = q[head++];
                int u0 = k % w, v0 = k / w;
                x0 = u0 < x0 ? u0 : x0, x1 = u0 > x1 ? u0 : x1, y0 = v0 < y0 ? v0 : y0, y1 = v0 > y1 ? v0 : y1;
                for (int v = v0 - 2; v <= v0 + 2; v++)
                    for (int u = u0 - 2; u <= u0 + 2; u++) {
                        size_t j = (size_t)v * w + u;
                        if (u >= 0 && v >= 0 && u < w && v < h && !lab[j] && s->objpx[j] == s->objpx[i])
                            lab[j] = next, q[n++] = (int32_t)j;
                    }
            }
            if (n >= 20 && s->n < MAX_OBJ)
                s->obj[s->n++] = (sp_depop_object){ .x0 = x0, .y0 = y0, .x1 = x1, .y1 = y1 };
        }
    free(lab), free(q);
}

/* The truth's removed region from its object and shadow images (nonzero pixels). */
static int load_region(scene *s, const char *shadows)
{
    uint8_t *rgba = NULL;
    uint32_t w, h;
    int ret = sp_png_read_rgba(shadows, &rgba, &w, &h);
    if (!ret && (w != s->w || h != s->h))
        ret = -EINVAL;
    for (size_t i = 0; !ret && i < (size_t)w * h; i++)
        s->changed[i] = s->objpx[i] || rgba[4 * i];
    free(rgba);
    return ret;
}

static int load(scene *s, const char *frame, const char *bgpath, const char *ids, const char *shadows)
{
    uint32_t w, h;
    int ret = sp_image_read_rgb8(frame, &s->rgb, &s->w, &s->h);
    if (!ret)
        ret = sp_image_read_rgb8(bgpath, &s->bg, &w, &h);
    if (!ret && (w != s->w || h != s->h))
        ret = -EINVAL;
    size_t n = (size_t)s->w * s->h;
    if (!ret && (!(s->objpx = calloc(n, 1)) || !(s->changed = calloc(n, 1))))
        ret = -ENOMEM;
    if (!ret && ids && strcmp(ids, "-"))
        ret = load_ids(s, ids);
    else if (!ret)
        objects_from_background(s);
    if (!ret && shadows && strcmp(shadows, "-"))
        ret = load_region(s, shadows);
    else
        for (size_t i = 0; !ret && i < n; i++) {
            const uint8_t *p = s->rgb + 3 * i, *q = s->bg + 3 * i;
            s->changed[i] = s->objpx[i] || abs(p[0] - q[0]) + abs(p[1] - q[1]) + abs(p[2] - q[2]) > 24;
        }
    if (ret)
        return ret;
    boxes(s);
    return 0;
}

static void to_float(const uint8_t *rgb, float *f, size_t n)
{
    for (size_t i = 0; i < 3 * n; i++)
        f[i] = rgb[i] / 255.0f;
}

/* The sun from the frame's grown masks, against the truth's. */
static void sun_frame(const sp_depop_object *obj, size_t n)
{
    sp_depop_sun e;
    if (sp_depop_sun_estimate(obj, n, &sun.cam, &e) || sun.frames >= 256)
        return;
    sun.frames++;
    if (!e.found) {
        printf("  sun: no sun shadows\n");
        return;
    }
    double da = fabs(e.azimuth_deg - sun.az);
    da = da > 180 ? 360 - da : da;
    sun.err_az[sun.found] = da, sun.err_el[sun.found] = fabs(e.elevation_deg - sun.el);
    sun.found++;
    if (e.closed)
        sun.closed_az[sun.closed] = da, sun.closed_el[sun.closed++] = sun.err_el[sun.found - 1];
    printf("  sun: azimuth %7.1f elevation %5.1f from %u %s shadows (spread %.1f, %.1f)%s", e.azimuth_deg,
           e.elevation_deg, e.used, e.closed ? "closed" : "open", e.azimuth_spread_deg, e.elevation_spread_deg,
           sun.truth ? "" : "\n");
    if (sun.truth)
        printf("; error %.1f, %.1f deg\n", da, sun.err_el[sun.found - 1]);
}

/* Fills mask's pixels of out (the frame) by our exemplar inpainting or by OpenCV's Telea. */
static int fill(const scene *s, int exemplar, uint8_t *out, const uint8_t *mask)
{
    if (exemplar)
        return sp_inpaint_exemplar(out, s->w, s->h, s->w * 3, mask, NULL, NULL);
#if HAVE_OPENCV
    return sp_cv_inpaint_telea(out, s->w, s->h, s->w * 3, mask, 3);
#else
    return SP_EDISABLED;
#endif
}

/* Runs one method into out; mask_out gets the pixels it replaced. */
static int run_method(const scene *s, int m, uint8_t *out, uint8_t *mask)
{
    size_t n = (size_t)s->w * s->h;
    if (m >= 4) { /* the oracles */
        memcpy(mask, s->changed, n);
        memcpy(out, s->rgb, 3 * n);
        return fill(s, m == 5, out, mask);
    }
    sp_depop_settings ds;
    sp_depop_default_settings(&ds);
    ds.camera = sun.on ? &sun.cam : NULL;
    ds.clock_sun = sun.on && clock_sun.found ? &clock_sun : NULL;
    ds.shadows = m >= 2;
    sp_depop_object obj[MAX_OBJ];
    memcpy(obj, s->obj, sizeof(obj));
    size_t cut = 0;
    uint8_t *silhouettes = malloc(n);
    int ret = silhouettes ? 0 : -ENOMEM;
    if (!ret && m >= 1 && !whole_boxes)
        ret = sp_depop_segment(s->rgb, s->w, s->h, s->w * 3, obj, s->n, silhouettes, &cut);
    if (!ret)
        ret = sp_depop_mask(s->rgb, s->w, s->h, s->w * 3, obj, s->n, &ds, mask);
    memcpy(out, s->rgb, 3 * n);
    if (!ret && m == 3 && sun.on && !timing)
        sun_frame(obj, s->n);
    free(silhouettes);
    return ret ? ret : fill(s, m == OURS, out, mask);
}

static int score(const char *label, const scene *s, double psnr[N_METHODS], double ssim[N_METHODS])
{
    size_t n = (size_t)s->w * s->h;
    uint8_t *out[N_METHODS], *mask[N_METHODS], *region = malloc(n);
    float *a = malloc(3 * n * sizeof(float)), *b = malloc(3 * n * sizeof(float));
    int ret = region && a && b ? 0 : -ENOMEM;
    for (int m = 0; m < N_METHODS; m++) {
        out[m] = malloc(3 * n), mask[m] = malloc(n);
        if (!ret && out[m] && mask[m])
            ret = run_method(s, m, out[m], mask[m]);
        else if (!ret)
            ret = -ENOMEM;
    }
    for (size_t i = 0; !ret && i < n; i++) {
        region[i] = s->changed[i];
        for (int m = 0; m < N_METHODS; m++)
            region[i] |= mask[m][i] != 0;
    }
    if (!ret)
        to_float(s->bg, b, n);
    for (int m = 0; m < N_METHODS && !ret; m++) {
        to_float(out[m], a, n);
        psnr[m] = sp_psnr_masked(a, b, region, (int)s->w, (int)s->h);
        ssim[m] = sp_ssim_masked(a, b, region, (int)s->w, (int)s->h);
    }
    const char *dump = getenv("SP_BENCH_DUMP"); /* a folder: each method's result, and the masks, to look at */
    for (int m = 0; m < N_METHODS && !ret && dump; m++) {
        char path[4096];
        snprintf(path, sizeof(path), "%s/%s.%d.png", dump, label, m);
        sp_png_write(path, out[m], s->w, s->h, s->w * 3, 3);
    }
    if (!ret && dump) { /* our grown mask against the truth's region: both green, truth only red, ours only blue */
        char path[4096];
        memcpy(out[0], s->rgb, 3 * n);
        for (size_t i = 0; i < n; i++)
            if (s->changed[i] || mask[OURS][i]) {
                uint8_t *p = out[0] + 3 * i;
                p[0] = s->changed[i] && !mask[OURS][i] ? 255 : p[0] / 3;
                p[1] = s->changed[i] && mask[OURS][i] ? 255 : p[1] / 3;
                p[2] = !s->changed[i] ? 255 : p[2] / 3;
            }
        snprintf(path, sizeof(path), "%s/%s.masks.png", dump, label);
        sp_png_write(path, out[0], s->w, s->h, s->w * 3, 3);
    }
    /* our squared error where the truth changed and we kept the pixel, where we filled it, and where we filled
       a pixel the truth did not change (a mask larger than needed) */
    double err_missed = 0, err_filled = 0, err_extra = 0, err_extra_obj = 0;
    for (size_t i = 0; !ret && i < n; i++)
        for (int c = 0; c < 3; c++) {
            double d = ((double)out[OURS][3 * i + c] - s->bg[3 * i + c]) / 255.0;
            err_missed += s->changed[i] && !mask[OURS][i] ? d * d : 0, err_filled += mask[OURS][i] ? d * d : 0;
            err_extra += !s->changed[i] && mask[OURS][i] ? d * d : 0;
            err_extra_obj += !s->changed[i] && mask[OURS][i] == 1 ? d * d : 0; /* sp_depop_mask: 1 object, 2 shadow */
        }
    size_t truth = 0, hit = 0, extra = 0, objs = 0, objs_left = 0;
    for (size_t i = 0; !ret && i < n; i++) {
        truth += s->changed[i], hit += s->changed[i] && mask[OURS][i], extra += !s->changed[i] && mask[OURS][i];
        objs += s->changed[i] && s->objpx[i], objs_left += s->changed[i] && s->objpx[i] && !mask[OURS][i];
    }
    size_t shadows = truth - objs, shadows_left = truth - hit - objs_left;
    if (!ret)
        printf("%-28s %2zu objects  Telea %6.2f dB %.3f  ours %6.2f dB %.3f  (grown mask holds %.1f%% of the truth's "
               "region, %.1f%% more; left: %.0f%% of its object pixels, %.0f%% of its shadow pixels; of our squared "
               "error %.0f%% is left in, %.0f%% filled, %.0f%% of it outside the truth's region, of that %.0f%% in "
               "object masks)\n",
               label, s->n, psnr[0], ssim[0], psnr[OURS], ssim[OURS], 100.0 * hit / truth, 100.0 * extra / truth,
               100.0 * objs_left / (objs ? objs : 1), 100.0 * shadows_left / (shadows ? shadows : 1),
               100.0 * err_missed / (err_missed + err_filled + 1e-30),
               100.0 * err_filled / (err_missed + err_filled + 1e-30), 100.0 * err_extra / (err_filled + 1e-30),
               100.0 * err_extra_obj / (err_extra + 1e-30));
    for (int m = 0; m < N_METHODS; m++)
        free(out[m]), free(mask[m]);
    free(region), free(a), free(b);
    return ret;
}

static void scene_free(scene *s)
{
    free(s->rgb), free(s->bg), free(s->objpx), free(s->changed);
}

/* CPU time of one depopulation (masks + inpainting) of the frame with the truth's boxes, median of 3. */
static void time_one(const char *frame, const char *bgpath)
{
    scene s = { 0 };
    if (load(&s, frame, bgpath, "-", "-")) {
        fprintf(stderr, "bench_depopulate: cannot read %s / %s\n", frame, bgpath);
        return;
    }
    size_t n = (size_t)s.w * s.h;
    uint8_t *out = malloc(3 * n), *mask = malloc(n);
    double t[3][2];
    timing = 1;
    for (int r = 0; r < 3 && out && mask; r++)
        for (int m = 0; m < 2; m++) {
            int64_t t0 = bench_thread_cpu_ns();
            run_method(&s, m ? 3 : 0, out, mask);
            t[r][m] = (bench_thread_cpu_ns() - t0) * 1e-9;
        }
    timing = 0;
    double ours[3] = { t[0][1], t[1][1], t[2][1] }, telea[3] = { t[0][0], t[1][0], t[2][0] };
    uint64_t holes = 0;
    for (size_t i = 0; i < n && mask; i++)
        holes += mask[i] != 0;
    printf("time %ux%u, %zu objects, %llu hole pixels: ours %.3f s CPU (median of 3), Telea on the object boxes "
           "%.3f s; ratio %.2f\n", s.w, s.h, s.n, (unsigned long long)holes, bench_median(ours, 3),
           bench_median(telea, 3), bench_median(ours, 3) / bench_median(telea, 3));
    free(out), free(mask);
    scene_free(&s);
}

int main(int argc, char **argv)
{
#if HAVE_OPENCV
    sp_cv_set_threads(1);
#endif
    double psnr[256][N_METHODS], ssim[256][N_METHODS];
    int k = 0, i = 1;
    if (i < argc && !strcmp(argv[i], "--whole-boxes"))
        whole_boxes = 1, i++;
    const char *time_frame = NULL, *time_bg = NULL;
    if (i + 2 < argc && !strcmp(argv[i], "--time"))
        time_frame = argv[i + 1], time_bg = argv[i + 2], i += 3;
    double v[4];
    if (i + 1 < argc && !strcmp(argv[i], "--camera") &&
        sscanf(argv[i + 1], "%lf,%lf,%lf,%lf", &v[0], &v[1], &v[2], &v[3]) == 4) {
        sun.on = 1, sun.cam = (sp_depop_camera){ v[0], v[1], v[2], v[3] };
        i += 2;
    }
    if (i + 1 < argc && !strcmp(argv[i], "--sun") && sscanf(argv[i + 1], "%lf,%lf", &sun.az, &sun.el) == 2) {
        sun.truth = 1;
        i += 2;
    }
    if (i + 1 < argc && !strcmp(argv[i], "--clock-sun") &&
        sscanf(argv[i + 1], "%lf,%lf", &clock_sun.azimuth_deg, &clock_sun.elevation_deg) == 2) {
        clock_sun.found = 1;
        i += 2;
    }
    if (time_frame) /* with the camera when given: the one-sun search and the strips are timed too */
        time_one(time_frame, time_bg);
    for (; i + 4 < argc && k < 256; i += 5) {
        scene s = { 0 };
        if (load(&s, argv[i + 1], argv[i + 2], argv[i + 3], argv[i + 4]) || !s.n ||
            score(argv[i], &s, psnr[k], ssim[k]))
            fprintf(stderr, "bench_depopulate: %s: skipped (unreadable, no objects or no OpenCV)\n", argv[i]);
        else
            k++;
        scene_free(&s);
    }
    for (int m = 0; m < N_METHODS && k; m++) {
        double p[256], q[256];
        for (int j = 0; j < k; j++)
            p[j] = psnr[j][m], q[j] = ssim[j][m];
        printf("median over %d frames: %-38s PSNR %6.2f dB  SSIM %.3f\n", k, method_names[m], bench_median(p, k),
               bench_median(q, k));
    }
    if (k) { /* paired: each frame's region is the same for every method, so its difference is the fair one */
        double d[256];
        for (int j = 0; j < k; j++)
            d[j] = psnr[j][OURS] - psnr[j][0];
        printf("median over %d frames of ours minus the baseline, frame by frame: %+.2f dB\n", k, bench_median(d, k));
    }
    if (sun.on && sun.truth && sun.found) {
        printf("sun over %d frames: %d with shadows; median error azimuth %.1f deg, elevation %.1f deg\n", sun.frames,
               sun.found, bench_median(sun.err_az, sun.found), bench_median(sun.err_el, sun.found));
        if (sun.closed)
            printf("sun over %d frames: %d with closed shadows; median error azimuth %.1f deg, elevation %.1f deg\n",
                   sun.frames, sun.closed, bench_median(sun.closed_az, sun.closed),
                   bench_median(sun.closed_el, sun.closed));
    } else if (sun.on && sun.frames) {
        printf("sun over %d frames: %d with shadows, %d of them closed\n", sun.frames, sun.found, sun.closed);
    }
    return 0;
}
