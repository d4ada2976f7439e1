/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe synth street`, `probe` and `composite` end to end, against the
 * synthetic ground truth and on OpenCV's vtest.avi.
 *   test_probe SUNPROBE sunny     occluder recall, plane height error, shadow direction,
 *                                 compositing behind/in front of the pole, removal
 *   test_probe SUNPROBE seeds     occluder recall and false rate on two more synth street seeds
 *   test_probe SUNPROBE overcast  the shadow model is left out, the plane still fits
 *   test_probe SUNPROBE bad       moving camera, nothing moving, 3 frames, timestamps at the
 *                                 end of the int64 clock, missing file:
 *                                 a message, exit code 2/3, no output left behind
 *   test_probe SUNPROBE vtest     lamp post and sign occlude the people behind them; the
 *                                 height prediction error on the second half (skips without
 *                                 vtest.avi or OpenCV)
 */
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "common/file_util.h"
#include "common/json.h"
#include "export/legend.h"
#include "export/png.h"
#include "export/png_read.h"
#include "export/probe_dir.h"
#include "sp_config.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_probe.h"

#define VTEST "/usr/share/doc/opencv-doc/examples/data/vtest.avi"

static const char *sunprobe;
static char tmp[256];

static const char *path_in(const char *name)
{
    static char bufs[16][512];
    static int next;
    char *p = bufs[next++ % 16];
    snprintf(p, 512, "%s/%s", tmp, name);
    return p;
}

/* Runs sunprobe with NULL-terminated arguments; stdout and stderr into tmp/out.txt, err.txt. */
static int run(const char *arg0, ...)
{
    const char *argv[40] = { sunprobe, arg0 };
    int n = 2;
    va_list ap;
    va_start(ap, arg0);
    const char *a;
    while (n < 39 && (a = va_arg(ap, const char *)) != NULL)
        argv[n++] = a;
    va_end(ap);
    argv[n] = NULL;
    pid_t pid = fork();
    if (pid == 0) {
        int out = open(path_in("out.txt"), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        int err = open(path_in("err.txt"), O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (out >= 0)
            dup2(out, 1);
        if (err >= 0)
            dup2(err, 2);
        execv(sunprobe, (char *const *)argv);
        _exit(127);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

/* The whole file, NUL-terminated (common/file_util.h); NULL when it cannot be read. */
static char *slurp(const char *path, size_t *len)
{
    void *data = NULL;
    size_t n = 0;
    if (sp_read_whole_file(path, (size_t)1 << 30, &data, &n))
        return NULL;
    if (len)
        *len = n;
    return data;
}

static int file_has(const char *name, const char *needle)
{
    char *s = slurp(path_in(name), NULL);
    int yes = s && strstr(s, needle);
    if (!yes)
        fprintf(stderr, "%s does not contain '%s':\n%s\n", name, needle, s ? s : "(missing)");
    free(s);
    return yes;
}

static int exists(const char *name)
{
    return access(path_in(name), F_OK) == 0;
}

/* No PROBE_DIR.partial.* or other leftovers of a failed run. */
static int no_partial_left(void)
{
    DIR *d = opendir(tmp);
    struct dirent *e;
    int found = 0;
    while (d && (e = readdir(d)) != NULL)
        found += strstr(e->d_name, ".partial") != NULL;
    if (d)
        closedir(d);
    return !found;
}

/* 16-bit PGM as written by synth street. */
static uint16_t *read_pgm16(const char *name, uint32_t *w, uint32_t *h)
{
    size_t len = 0;
    char *s = slurp(path_in(name), &len);
    unsigned ww, hh, mx;
    int off = 0;
    if (!s || sscanf(s, "P5 %u %u %u%n", &ww, &hh, &mx, &off) != 3 || (size_t)off + 1 + 2ull * ww * hh > len) {
        free(s);
        return NULL;
    }
    uint16_t *v = malloc(2ull * ww * hh);
    const uint8_t *p = (const uint8_t *)s + off + 1;
    for (size_t i = 0; v && i < (size_t)ww * hh; i++)
        v[i] = (uint16_t)(p[2 * i] << 8 | p[2 * i + 1]);
    free(s);
    *w = ww, *h = hh;
    return v;
}

static sp_json *read_json(const char *name)
{
    size_t len = 0;
    char *s = slurp(path_in(name), &len);
    sp_json *root = NULL;
    char err[128];
    if (s && sp_json_parse(s, len, &root, err, sizeof(err)))
        root = NULL;
    free(s);
    return root;
}

/* ---- sunny: truth checks ---- */

/* The truth files synth street wrote beside PREFIX.spcap. */
static uint16_t *read_truth(const char *prefix, const char *suffix, uint32_t *w, uint32_t *h)
{
    char name[128];
    snprintf(name, sizeof(name), "%s.%s.pgm", prefix, suffix);
    return read_pgm16(name, w, h);
}

static void check_occlusion_bounds(const sp_probe_dir *d, const char *prefix, double min_recall, double max_false)
{
    uint32_t w, h;
    uint16_t *far = read_truth(prefix, "hidden-far", &w, &h), *cnt = read_truth(prefix, "hidden-count", &w, &h);
    uint16_t *seen = read_truth(prefix, "seen-far", &w, &h);
    CHECK(far && cnt && seen && w == d->width && h == d->height);
    if (!far || !cnt || !seen)
        return;
    size_t n = 0, hit = 0, n3 = 0, hit3 = 0, n_seen = 0, wrong = 0;
    for (size_t i = 0; i < (size_t)w * h; i++) {
        if (far[i]) {
            /* recalled: a figure standing where the farthest hidden one stood would be hidden (2 rows slack) */
            int ok = d->occlusion[i] >= 0 && d->occlusion[i] >= (float)(far[i] - 1) - 2.0f;
            n++, hit += (size_t)ok;
            if (cnt[i] >= 3)
                n3++, hit3 += (size_t)ok;
        }
        if (seen[i]) { /* wrongly hidden: the map would hide a figure that was seen right there */
            n_seen++;
            wrong += d->occlusion[i] >= (float)(seen[i] - 1) + 2.0f;
        }
    }
    double recall = (double)hit / (double)(n ? n : 1), recall3 = (double)hit3 / (double)(n3 ? n3 : 1);
    double false_rate = (double)wrong / (double)(n_seen ? n_seen : 1);
    printf("%s: occluder recall %.3f of %zu pixels figures passed behind (%.3f of %zu hidden in 3+ frames); "
           "%.4f of %zu pixels where figures were seen would wrongly hide them\n",
           prefix, recall, n, recall3, n3, false_rate, n_seen);
    CHECK_MSG(n > 500, "%zu occluder pixels in the truth", n);
    CHECK_MSG(recall >= min_recall, "occluder recall %.3f", recall);
    CHECK_MSG(false_rate <= max_false, "false occluder rate %.4f", false_rate);
    free(far), free(cnt), free(seen);
}

static void check_occlusion_min(const sp_probe_dir *d, const char *prefix, double min_recall)
{
    check_occlusion_bounds(d, prefix, min_recall, 0.01);
}

/* the bound; seeds 1-10 give 0.908-0.994 (PROBE.md, occlusion figures) */
static void check_occlusion(const sp_probe_dir *d, const char *prefix)
{
    check_occlusion_min(d, prefix, 0.90);
}

/* The plane against the truth's sample points; sunny 1: the shadow model too, 0: left out as overcast, -1: neither. */
static void check_plane_and_shadow_in(const sp_probe_dir *d, const char *truth, int sunny)
{
    sp_json *t = read_json(truth);
    const sp_json *samples = sp_json_get(t, "samples");
    CHECK(samples && samples->count > 20);
    double err[512], ang[512];
    size_t n = 0, na = 0;
    for (size_t i = 0; samples && i < samples->count && n < 512; i++) {
        const sp_json *s = sp_json_at(samples, i);
        double x = sp_json_number(sp_json_get(s, "x"), NAN), y = sp_json_number(sp_json_get(s, "y"), NAN);
        double th = sp_json_number(sp_json_get(s, "height"), NAN), h = sp_probe_plane_height(&d->plane, x, y);
        err[n++] = fabs(h - th) / th; /* NaN (no model there) sorts last and fails the median */
        double sdx = sp_json_number(sp_json_get(s, "shadow_dx"), 0), sdy = sp_json_number(sp_json_get(s, "shadow_dy"), 0);
        if (d->shadow.present && hypot(sdx, sdy) > 0) {
            double u = x / d->width, v = y / d->height;
            double dx = d->shadow.ox[0] + d->shadow.ox[1] * u + d->shadow.ox[2] * v;
            double dy = d->shadow.oy[0] + d->shadow.oy[1] * u + d->shadow.oy[2] * v;
            double a = fabs(atan2(dy, dx) - atan2(sdy, sdx)) * 180 / M_PI;
            ang[na++] = a > 180 ? 360 - a : a;
        }
    }
    for (size_t i = 1; i < n; i++) /* insertion sorts: medians */
        for (size_t j = i; j > 0 && !(err[j - 1] <= err[j]); j--) {
            double tt = err[j];
            err[j] = err[j - 1], err[j - 1] = tt;
        }
    for (size_t i = 1; i < na; i++)
        for (size_t j = i; j > 0 && ang[j - 1] > ang[j]; j--) {
            double tt = ang[j];
            ang[j] = ang[j - 1], ang[j - 1] = tt;
        }
    double med = n ? err[n / 2] : (double)NAN;
    printf("%s: plane median relative height error %.4f over %zu ground points\n", truth, med, n);
    CHECK_MSG(med <= 0.05, "plane height error %.4f", med);
    if (sunny > 0) {
        double mang = na ? ang[na / 2] : (double)NAN;
        printf("sunny: shadow direction median error %.2f degrees over %zu points, ratio %.2f %.2f %.2f\n", mang, na,
               d->shadow.ratio[0], d->shadow.ratio[1], d->shadow.ratio[2]);
        CHECK_MSG(d->shadow.present, "%s", d->shadow.note);
        CHECK_MSG(mang <= 10.0, "shadow direction error %.2f", mang);
        /* synth street: lit ground 0.55 + 1.25 sin(40 deg) = 1.35, shadow 0.55 */
        CHECK_NEAR(d->shadow.ratio[1], 0.55 / 1.353, 0.06);
    } else if (sunny == 0) {
        CHECK_MSG(!d->shadow.present && strstr(d->shadow.note, "overcast"), "%s", d->shadow.note);
    }
    sp_json_free(t);
}

static void check_plane_and_shadow(const sp_probe_dir *d, int sunny)
{
    check_plane_and_shadow_in(d, sunny ? "st.truth.json" : "oc.truth.json", sunny);
}


/* Mean absolute difference of two PNGs of the same size, -1 when unreadable. */
static double png_diff(const char *a, const char *b)
{
    uint8_t *pa = NULL, *pb = NULL;
    uint32_t wa, ha, wb, hb;
    double sum = -1;
    if (!sp_png_read_rgba(path_in(a), &pa, &wa, &ha) && !sp_png_read_rgba(path_in(b), &pb, &wb, &hb) && wa == wb &&
        ha == hb) {
        sum = 0;
        for (size_t i = 0; i < (size_t)wa * ha * 4; i++)
            sum += abs(pa[i] - pb[i]);
        sum /= (double)wa * ha * 3;
    }
    free(pa), free(pb);
    return sum;
}

/* The pole of synth street (occluder 0) in the image: column and the row of its base. */
static void pole_in_image(double *u, double *v, double gx, double gy)
{
    sp_json *t = read_json("st.truth.json");
    const sp_json *cam = sp_json_get(t, "camera");
    double f = sp_json_number(sp_json_get(cam, "fx"), 0), cx = sp_json_number(sp_json_get(cam, "cx"), 0);
    double cy = sp_json_number(sp_json_get(cam, "cy"), 0), hc = sp_json_number(sp_json_get(cam, "height_m"), 0);
    double th = sp_json_number(sp_json_get(cam, "pitch_deg"), 0) * M_PI / 180;
    /* camera looking along +y, pitched down by th: depth and height of the point in camera axes */
    double zc = gy * cos(th) + hc * sin(th), yc = -gy * sin(th) + hc * cos(th);
    *u = cx + f * gx / zc - 0.5;
    *v = cy + f * yc / zc - 0.5;
    sp_json_free(t);
}

static void check_composite(const sp_probe_dir *d)
{
    uint8_t cut[12 * 30 * 4];
    for (int i = 0; i < 12 * 30; i++)
        cut[4 * i] = 250, cut[4 * i + 1] = 20, cut[4 * i + 2] = 240, cut[4 * i + 3] = 255;
    CHECK(sp_png_write(path_in("cut.png"), cut, 12, 30, 48, 4) == 0);
    double pu, pv, bu, bv, fu, fv;
    pole_in_image(&pu, &pv, 1.0, 11.0);  /* the lamp pole's base */
    pole_in_image(&bu, &bv, 1.0, 13.0);  /* a spot behind it */
    pole_in_image(&fu, &fv, 1.0, 9.0);   /* and one in front */
    char at_b[64], at_f[64];
    snprintf(at_b, sizeof(at_b), "%.1f,%.1f", bu, bv);
    snprintf(at_f, sizeof(at_f), "%.1f,%.1f", fu, fv);
    CHECK(run("composite", path_in("stp"), "--object", path_in("cut.png"), "--at", at_b, "-o", path_in("behind.png"),
              NULL) == 0);
    CHECK(run("composite", path_in("stp"), "--object", path_in("cut.png"), "--at", at_f, "-o", path_in("front.png"),
              NULL) == 0);
    CHECK(file_has("out.txt", "shadow pixels"));
    uint8_t *b = NULL, *f = NULL;
    uint32_t w, h;
    CHECK(sp_png_read_rgba(path_in("behind.png"), &b, &w, &h) == 0);
    CHECK(sp_png_read_rgba(path_in("front.png"), &f, &w, &h) == 0);
    if (b && f) {
        double hb = sp_probe_plane_height(&d->plane, bu, bv), hf = sp_probe_plane_height(&d->plane, fu, fv);
        /* 3/4 up the body behind: the line of sight passes the pole above its sign */
        int rb = (int)(bv - 0.75 * hb), rf = (int)(fv - 0.4 * hf), col = (int)lrint(pu);
        const uint8_t *plate = d->clean_plate;
        /* behind: the pole's column keeps the plate, a column beside it shows the magenta cut-out */
        int hidden = !memcmp(b + 4 * ((size_t)rb * w + col), plate + 3 * ((size_t)rb * w + col), 3);
        int beside = b[4 * ((size_t)rb * w + col - 4)] >= 200 && b[4 * ((size_t)rb * w + col - 4) + 1] < 100;
        int front = f[4 * ((size_t)rf * w + col)] >= 200 && f[4 * ((size_t)rf * w + col) + 1] < 100;
        CHECK_MSG(hidden, "behind the pole at (%d, %d): not hidden", col, rb);
        CHECK_MSG(beside, "beside the pole at (%d, %d): not drawn", col - 4, rb);
        CHECK_MSG(front, "in front of the pole at (%d, %d): not drawn", col, rf);
    }
    free(b), free(f);
    CHECK(run("composite", path_in("stp"), "--object", path_in("cut.png"), "--at", "5000,3", "-o", path_in("x.png"),
              NULL) == 1);
    CHECK(run("composite", path_in("stp"), "--object", path_in("missing.png"), "--at", at_f, "-o", path_in("x.png"),
              NULL) == 3);
}

/*
 * occlusion_confidence.pfm: 0..1, above 0 wherever the map occludes (a value needs an agreeing event); a directory
 * without it (written before it existed) still loads, one with a damaged one does not.
 */
static void check_confidence(const sp_probe_dir *d)
{
    CHECK(d->occlusion_confidence != NULL);
    if (!d->occlusion_confidence)
        return;
    size_t bad = 0, occluding = 0;
    double sum = 0;
    for (size_t i = 0; i < (size_t)d->width * d->height; i++) {
        float c = d->occlusion_confidence[i];
        bad += !(c >= 0 && c <= 1) || (d->occlusion[i] >= 0 && c <= 0);
        if (d->occlusion[i] >= 0)
            occluding++, sum += (double)c;
    }
    printf("occlusion confidence: mean %.3f over %zu occluding pixels\n", sum / (double)(occluding ? occluding : 1),
           occluding);
    CHECK_MSG(bad == 0, "%zu confidence values out of range or 0 where the map occludes", bad);
    CHECK(exists("stp/occlusion_confidence.png"));
    CHECK(run("probe", path_in("st.spcap"), "-o", path_in("stp2"), "-q", "--max-frames", "200", NULL) == 0);
    CHECK(unlink(path_in("stp2/occlusion_confidence.pfm")) == 0);
    sp_probe_dir old;
    CHECK(sp_probe_dir_load(path_in("stp2"), &old) == 0 && old.occlusion_confidence == NULL);
    sp_probe_dir_free(&old);
    FILE *f = fopen(path_in("stp2/occlusion_confidence.pfm"), "wb");
    CHECK(f && fputs("Pf\n3 3\n-1.0\n", f) >= 0 && fclose(f) == 0);
    CHECK(sp_probe_dir_load(path_in("stp2"), &old) == SP_ETRUNCATED);
    static const float nine[9] = { 0 }; /* whole, but 3x3: not this probe's map */
    CHECK(sp_pfm_write(path_in("stp2/occlusion_confidence.pfm"), nine, 3, 3, 1) == 0);
    CHECK(sp_probe_dir_load(path_in("stp2"), &old) == SP_ECORRUPT);
}

static void test_sunny(void)
{
    CHECK(run("synth", "street", "-o", path_in("st.spcap"), NULL) == 0);
    CHECK(run("probe", path_in("st.spcap"), "-o", path_in("stp"), "--empty-frame", "200", "-q", NULL) == 0);
    sp_probe_dir d;
    int ret = sp_probe_dir_load(path_in("stp"), &d);
    CHECK_MSG(ret == 0, "loading the probe directory: %s", sp_strerror(ret));
    if (ret)
        return;
    CHECK(exists("stp/convergence.csv") && exists("stp/convergence.svg") && exists("stp/occlusion.png"));
    /* the previews are the map (kept pixel for pixel) with a legend strip under it */
    for (int k = 0; k < 2; k++) {
        uint8_t *rgba = NULL;
        uint32_t pw = 0, ph = 0;
        CHECK(sp_png_read_rgba(path_in(k ? "stp/lighting.png" : "stp/occlusion.png"), &rgba, &pw, &ph) == 0);
        CHECK_MSG(pw == d.width && ph == d.height + sp_legend_height(d.width), "preview %ux%u", pw, ph);
        for (size_t i = 0; rgba && k == 0 && i < (size_t)d.width * d.height; i++)
            if ((d.occlusion[i] < 0) != (rgba[4 * i] == 24 && rgba[4 * i + 1] == 24 && rgba[4 * i + 2] == 24)) {
                CHECK_MSG(0, "occlusion.png pixel %zu does not show the map", i);
                break;
            }
        free(rgba);
    }
    if (HAVE_OPENIMAGEIO) { /* the float maps as OpenEXR too */
        size_t n = 0;
        char *exr = slurp(path_in("stp/occlusion.exr"), &n);
        CHECK(exr && !memcmp(exr, "v/1\x01", 4));
        /* no clock time in the header (OpenImageIO stamps capDate unless told not to), so a run's bytes
           are the next run's: signal-anywhere compares outputs byte for byte */
        static const char cap_date[] = "capDate\0string"; /* name, type, then a 4-byte size */
        const char *at = exr ? memmem(exr, n, cap_date, sizeof(cap_date)) : NULL;
        CHECK_MSG(!at ||
                      ((size_t)(at - exr) + sizeof(cap_date) + 4 <= n && !memcmp(at + sizeof(cap_date), "\0\0\0\0", 4)),
                  "occlusion.exr carries a capture date");
        free(exr);
    } else {
        CHECK(!exists("stp/occlusion.exr"));
    }
    check_confidence(&d);
    check_occlusion(&d, "st");
    check_plane_and_shadow(&d, 1);
    /* removal: the emptied frame is the empty street; the frame itself is not */
    double de = png_diff("stp/empty_000200.png", "st.background.png"), df = png_diff("stp/frame_000200.png", "st.background.png");
    printf("removal: emptied frame differs from the empty street by %.2f levels, the frame by %.2f\n", de, df);
    CHECK(de >= 0 && de < 1.5 && df > de * 1.5);
    check_composite(&d);
    /* the same directory again: refused without --force, replaced with it */
    CHECK(run("probe", path_in("st.spcap"), "-o", path_in("stp"), "-q", NULL) == 1);
    CHECK(run("probe", path_in("st.spcap"), "-o", path_in("stp"), "-q", "-f", "--max-frames", "200", "--objects",
              NULL) == 0);
    CHECK(!exists("stp/empty_000200.png") && exists("stp/probe.json"));
    /* --objects: a row per object of each probed frame, people among them; probe.json counts the classes */
    char *objects = slurp(path_in("stp/objects.csv"), NULL), *params = slurp(path_in("stp/probe.json"), NULL);
    CHECK(objects && !strncmp(objects, "frame,t_ns,class,x0,y0,x1,y1,foot_x,foot_y,height,area,touches_border\n", 69));
    CHECK(objects && strstr(objects, ",person,") != NULL);
    CHECK(params && strstr(params, "\"objects\":{\"observations\":") != NULL);
    free(objects), free(params);
    sp_probe_dir_free(&d);
}

/*
 * People who stop: 16 figures over 120 s, every other one standing still once for 5-60 s. Nobody may
 * end up in the clean plate (with the median alone the plate differs from the empty street by 1.8
 * levels on average and by more than 30 at 3,394 pixels: the people who stood), and the occlusion map
 * holds up as it does for walkers.
 */
static void test_linger(void)
{
    CHECK(run("synth", "street", "-o", path_in("lg.spcap"), "--seed", "3", "--linger", "60", "--figures", "16",
              "--seconds", "120", NULL) == 0);
    CHECK(run("probe", path_in("lg.spcap"), "-o", path_in("lgp"), "-q", "--settle", "120", NULL) == 0);
    double dp = png_diff("lgp/clean_plate.png", "lg.background.png");
    printf("lingering: clean plate differs from the empty street by %.3f levels\n", dp);
    CHECK_MSG(dp >= 0 && dp < 0.8, "clean plate off by %.3f levels", dp);
    sp_probe_dir d;
    int ret = sp_probe_dir_load(path_in("lgp"), &d);
    CHECK_MSG(ret == 0, "loading the probe directory: %s", sp_strerror(ret));
    if (ret)
        return;
    check_occlusion(&d, "lg");
    sp_probe_dir_free(&d);
}

/* Two more scenes: seeds 4 and 5 were the worst of 1-6 (0.883 and 0.815 before the leaning cuts). */
static void test_seeds(void)
{
    static const char *const seeds[] = { "4", "5" };
    for (int i = 0; i < 2; i++) {
        char cap[32], dir[32];
        snprintf(cap, sizeof(cap), "s%s.spcap", seeds[i]);
        snprintf(dir, sizeof(dir), "s%sp", seeds[i]);
        CHECK(run("synth", "street", "-o", path_in(cap), "--seed", seeds[i], NULL) == 0);
        CHECK(run("probe", path_in(cap), "-o", path_in(dir), "-q", NULL) == 0);
        sp_probe_dir d;
        int ret = sp_probe_dir_load(path_in(dir), &d);
        CHECK_MSG(ret == 0, "loading the probe directory of seed %s: %s", seeds[i], sp_strerror(ret));
        if (ret)
            continue;
        cap[strlen(cap) - strlen(".spcap")] = '\0';
        check_occlusion(&d, cap);
        sp_probe_dir_free(&d);
    }
}

/*
 * Sensor noise of 3 levels per channel (synth street --noise): with every pixel classified as it is,
 * seed 1 gave recall 0.844 and a false rate of 1.27%, seed 4 0.795, the plane 10% and 6.5% off and the
 * shadow 7 degrees; the grainy path (denoised change test, noise-scaled shadow tests) is held to
 * recall 0.85 here (0.916 and 0.894 measured) and to the walkers' plane, shadow and false-rate bounds.
 */
/*
 * Frames stored as JPEG at quality 70 (synth street --jpeg): ringing around the figures and blocks inside
 * their cast shadows made lone object pixels that widened people into "other" (207 of 664 objects called
 * person against 568 of 661 uncompressed) and marked 7.4% of where figures were seen (recall 0.619). Lone
 * pixels are dropped where they are many (segment.c, drop_specks): recall 0.867, false 2.1%; occluder groups
 * on plain plate are dropped (occluders.c): false 0.75%. Held to 0.8 and the 1%.
 */
static void test_compressed(void)
{
    if (!HAVE_JPEG) {
        printf("compressed frames: skipped, this build has no libjpeg\n");
        return;
    }
    CHECK(run("synth", "street", "-o", path_in("jq.spcap"), "--seed", "1", "--jpeg", "70", NULL) == 0);
    CHECK(run("probe", path_in("jq.spcap"), "-o", path_in("jqp"), "-q", NULL) == 0);
    sp_probe_dir d;
    int ret = sp_probe_dir_load(path_in("jqp"), &d);
    CHECK_MSG(ret == 0, "loading the probe directory of the compressed street: %s", sp_strerror(ret));
    if (ret)
        return;
    check_occlusion_bounds(&d, "jq", 0.8, 0.01);
    sp_probe_dir_free(&d);
}

static void test_noise(void)
{
    static const char *const seeds[] = { "1", "4" };
    for (int i = 0; i < 2; i++) {
        char cap[32], dir[32], truth[48];
        snprintf(cap, sizeof(cap), "nz%s.spcap", seeds[i]);
        snprintf(dir, sizeof(dir), "nz%sp", seeds[i]);
        snprintf(truth, sizeof(truth), "nz%s.truth.json", seeds[i]);
        CHECK(run("synth", "street", "-o", path_in(cap), "--seed", seeds[i], "--noise", "3", NULL) == 0);
        CHECK(run("probe", path_in(cap), "-o", path_in(dir), "-q", NULL) == 0);
        sp_probe_dir d;
        int ret = sp_probe_dir_load(path_in(dir), &d);
        CHECK_MSG(ret == 0, "loading the probe directory of noisy seed %s: %s", seeds[i], sp_strerror(ret));
        if (ret)
            continue;
        cap[strlen(cap) - strlen(".spcap")] = '\0';
        check_occlusion_min(&d, cap, 0.85);
        check_plane_and_shadow_in(&d, truth, 1);
        sp_probe_dir_free(&d);
    }
    test_compressed();
}

/*
 * The contact shadow the overcast street draws at each figure's feet (truth.json "contact": the ground times
 * 1 - depth (1 - r / (reach h))^2), against the probe's rings (k at (k + 0.5) / 4 x 0.25 h from the foot). The
 * probe measures it across the foot row, and the figures' pixels, their legs' edges and the plate's grain
 * blur it: it must be there, darkest at the feet, and off the truth by at most 0.08 on average over the
 * rings (seeds 1-3 measured 0.057, 0.043, 0.024; a probe that saw no darkening at all would be 0.11 off).
 */
static void check_contact(const sp_probe_dir *d, const char *truth)
{
    sp_json *t = read_json(truth);
    const sp_json *c = sp_json_get(t, "contact");
    double depth = sp_json_number(sp_json_get(c, "depth"), NAN), reach = sp_json_number(sp_json_get(c, "reach"), NAN);
    CHECK(depth > 0 && reach > 0);
    CHECK_MSG(d->shadow.contact_present, "%s", d->shadow.contact_note);
    double off = 0;
    for (int k = 0; k < SP_PROBE_CONTACT_BINS; k++) {
        double q = fmin(1, 0.25 * (k + 0.5) / 4 / reach), want = 1 - depth * (1 - q) * (1 - q);
        printf("overcast: contact ring %d: %.3f, truth %.3f\n", k, d->shadow.contact[k], want);
        off += fabs(d->shadow.contact[k] - want) / SP_PROBE_CONTACT_BINS;
    }
    CHECK_MSG(off <= 0.08, "contact rings off the truth by %.3f on average", off);
    CHECK(d->shadow.contact[0] < d->shadow.contact[3] && d->shadow.contact[3] <= d->shadow.contact[5]);
    sp_json_free(t);
}

static void test_overcast(void)
{
    CHECK(run("synth", "street", "-o", path_in("oc.spcap"), "--overcast", "--seconds", "30", NULL) == 0);
    CHECK(run("probe", path_in("oc.spcap"), "-o", path_in("ocp"), NULL) == 0);
    CHECK(file_has("out.txt", "left out: overcast"));
    sp_probe_dir d;
    CHECK(sp_probe_dir_load(path_in("ocp"), &d) == 0);
    check_plane_and_shadow(&d, 0);
    check_contact(&d, "oc.truth.json");
    sp_probe_dir_free(&d);
}

/* Copies src's META and frames to dst, frame i at end - (n - 1 - i) * step ns: at the end of the clock. */
static int retime(const char *src, const char *dst, int64_t end, int64_t step)
{
    sp_capture_reader *r = NULL;
    sp_capture_writer *w = NULL;
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    int rc = sp_capture_reader_open(&r, src, NULL);
    uint64_t n = 0;
    sp_chunk ch;
    while (!rc && (rc = sp_capture_reader_next(r, &ch)) == 0)
        n += ch.type == SP_CHUNK_FRAME;
    sp_capture_reader_close(&r);
    if (rc == SP_EOS)
        rc = sp_capture_reader_open(&r, src, NULL);
    if (!rc)
        rc = sp_capture_writer_open(&w, dst, &ws);
    uint64_t i = 0;
    while (!rc && (rc = sp_capture_reader_next(r, &ch)) == 0) {
        sp_frame_chunk fc;
        if (ch.type == SP_CHUNK_META)
            rc = sp_capture_write_meta(w, end - (int64_t)(n - 1) * step, (const char *)ch.payload, ch.payload_size);
        if (ch.type != SP_CHUNK_FRAME || rc || (rc = sp_chunk_parse_frame(&ch, &fc)))
            continue;
        sp_frame f = { .format = fc.format, .width = fc.width, .height = fc.height, .stride = fc.stride,
                       .data = (uint8_t *)fc.data, .capacity = fc.data_size, .bytes_used = fc.data_size,
                       .timestamp_ns = end - (int64_t)(n - 1 - i) * step, .sequence = i,
                       .stream_id = fc.stream_id, .exposure_us = fc.exposure_us, .gain = fc.gain };
        rc = sp_capture_write_frame(w, &f);
        i++;
    }
    sp_capture_reader_close(&r);
    int crc = w ? sp_capture_writer_close(&w) : 0;
    return rc == SP_EOS ? crc : rc;
}

/* n grey RGB24 frames: frame i is w x h (w2 x h2 from frame `resize_at` on), at i * 0.1 s except frame `back_at`. */
static int raw_capture(const char *dst, int n, uint32_t w, uint32_t h, int resize_at, uint32_t w2, uint32_t h2,
                       int back_at)
{
    sp_capture_writer *wr = NULL;
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    int rc = sp_capture_writer_open(&wr, dst, &ws);
    uint8_t *px = calloc((size_t)(w > w2 ? w : w2) * (h > h2 ? h : h2) * 3, 1);
    for (int i = 0; !rc && px && i < n; i++) {
        uint32_t fw = i >= resize_at ? w2 : w, fh = i >= resize_at ? h2 : h;
        memset(px, 100 + (i % 5), (size_t)fw * fh * 3);
        int64_t t = (int64_t)i * 100000000 - (i == back_at ? 250000000 : 0);
        sp_frame f = { .format = SP_PIXFMT_RGB24, .width = fw, .height = fh, .stride = fw * 3, .data = px,
                       .capacity = (size_t)fw * fh * 3, .bytes_used = (size_t)fw * fh * 3, .timestamp_ns = t,
                       .sequence = (uint64_t)i };
        rc = sp_capture_write_frame(wr, &f);
    }
    int oom = !px;
    free(px);
    int crc = wr ? sp_capture_writer_close(&wr) : 0;
    return rc ? rc : (oom ? -ENOMEM : crc);
}

static void test_bad(void)
{
    /* what a static camera's probe cannot take is refused before any work, with the frame named (exit 2, not 1) */
    CHECK_EQ_INT(raw_capture(path_in("resize.spcap"), 40, 64, 48, 20, 80, 60, -1), 0);
    CHECK_EQ_INT(run("probe", path_in("resize.spcap"), "-o", path_in("resizep"), NULL), 2);
    CHECK(file_has("err.txt", "frame 21 is 80x60, the first was 64x48") && !exists("resizep") && no_partial_left());
    CHECK_EQ_INT(raw_capture(path_in("back.spcap"), 40, 64, 48, 99, 64, 48, 10), 0);
    CHECK_EQ_INT(run("probe", path_in("back.spcap"), "-o", path_in("backp"), NULL), 2);
    CHECK(file_has("err.txt", "frame 11's timestamp is before") && !exists("backp") && no_partial_left());
    CHECK_EQ_INT(raw_capture(path_in("tiny.spcap"), 10, 8, 8, 99, 8, 8, -1), 0);
    CHECK_EQ_INT(run("probe", path_in("tiny.spcap"), "-o", path_in("tinyp"), NULL), 2);
    CHECK(file_has("err.txt", "frames are 8x8; the probe takes 16..16384") && !exists("tinyp") && no_partial_left());
    CHECK(run("synth", "street", "-o", path_in("pan.spcap"), "--pan", "4", "--seconds", "6", NULL) == 0);
    CHECK(run("probe", path_in("pan.spcap"), "-o", path_in("panp"), NULL) == 2);
    CHECK(file_has("err.txt", "camera moves") && !exists("panp") && no_partial_left());
    CHECK(run("synth", "street", "-o", path_in("empty.spcap"), "--figures", "0", "--seconds", "10", NULL) == 0);
    CHECK(run("probe", path_in("empty.spcap"), "-o", path_in("emptyp"), NULL) == 2);
    CHECK(file_has("err.txt", "no moving objects") && !exists("emptyp") && no_partial_left());
    CHECK(run("synth", "street", "-o", path_in("three.spcap"), "--seconds", "0.3", NULL) == 0);
    CHECK(run("probe", path_in("three.spcap"), "-o", path_in("threep"), NULL) == 2);
    CHECK(file_has("err.txt", "too short") && !exists("threep") && no_partial_left());
    /* frames at the end of int64's clock: the plate's next sampling time would overflow */
    CHECK(run("synth", "street", "-o", path_in("street.spcap"), "--seconds", "8", NULL) == 0);
    CHECK_EQ_INT(retime(path_in("street.spcap"), path_in("late.spcap"), INT64_MAX - 1000, 100000000), 0);
    CHECK_EQ_INT(run("probe", path_in("late.spcap"), "-o", path_in("latep"), NULL), 2);
    CHECK(file_has("err.txt", "overflow") && !exists("latep") && no_partial_left());
    CHECK(run("probe", path_in("nothing.spcap"), "-o", path_in("nop"), NULL) == 3);
    CHECK(run("probe", path_in("three.spcap"), NULL) == 1);
    CHECK(run("probe", path_in("three.spcap"), "-o", path_in("x"), "--samples", "4", NULL) == 1);
    CHECK(run("composite", path_in("nop"), "--object", "a.png", "--at", "1,1", "-o", path_in("x.png"), NULL) == 3);
}

/* ---- vtest.avi ---- */

typedef struct region {
    const char *name;
    int x0, x1, y0, y1;
} region;

static void region_stats(const sp_probe_dir *d, const region *r, double *frac, double *median_z)
{
    size_t n = 0, k = 0;
    static float z[20000];
    for (int y = r->y0; y <= r->y1; y++)
        for (int x = r->x0; x <= r->x1; x++, n++) {
            float v = d->occlusion[(size_t)y * d->width + (size_t)x];
            if (v >= 0 && k < 20000)
                z[k++] = v;
        }
    for (size_t i = 1; i < k; i++)
        for (size_t j = i; j > 0 && z[j - 1] > z[j]; j--) {
            float t = z[j];
            z[j] = z[j - 1], z[j - 1] = t;
        }
    *frac = (double)k / (double)n;
    *median_z = k ? (double)z[k / 2] : -1;
}

/*
 * People walk on the road behind the lamp post (feet at rows 250-300) and
 * behind the sign; nobody walks on the lawn in front.
 */
static const region vt_post = { "lamp post", 426, 432, 250, 360 }, vt_sign = { "sign", 416, 442, 208, 238 };

static void vtest_or_skip(void)
{
    if (access(VTEST, R_OK) != 0)
        SKIP("%s is not installed (Debian package opencv-doc)", VTEST);
    if (!HAVE_OPENCV)
        SKIP("importing vtest.avi needs OpenCV (-Dopencv=enabled)");
    if (!HAVE_JPEG)
        SKIP("the imported frames are MJPEG: decoding needs libjpeg (-Djpeg=enabled)");
}

/*
 * The first 300 frames alone: people crowd the sign from the first frame, so the plate's warm-up samples
 * show them; the held plate must not keep them (holding from the start: sign 43%, lamp post 33%).
 */
static void test_vtest_start(void)
{
    CHECK(run("probe", path_in("vtest.spcap"), "-o", path_in("vp300"), "--max-frames", "300", NULL) == 0);
    sp_probe_dir d;
    if (sp_probe_dir_load(path_in("vp300"), &d)) {
        CHECK(!"probe directory of the first 300 frames");
        return;
    }
    double f_post, z_post, f_sign, z_sign;
    region_stats(&d, &vt_post, &f_post, &z_post);
    region_stats(&d, &vt_sign, &f_sign, &z_sign);
    printf("vtest, first 300 frames: occluding %.2f of the lamp post, %.2f of the sign\n", f_post, f_sign);
    CHECK_MSG(f_sign >= 0.9 && f_post >= 0.35, "first 300 frames: sign %.2f, lamp post %.2f", f_sign, f_post);
    sp_probe_dir_free(&d);
}

static void test_vtest(void)
{
    CHECK(SANITIZED ? run("import", VTEST, "-o", path_in("vtest.spcap"), "-q", "--max-frames", "300", NULL) == 0
                    : run("import", VTEST, "-o", path_in("vtest.spcap"), "-q", NULL) == 0);
    /* sanitizer builds run 5-10 times slower: the first 300 frames show the post and the sign too */
    int rc = run("probe", path_in("vtest.spcap"), "-o", path_in("vp"), "--holdout-half", NULL);
    CHECK(rc == 0);
    sp_probe_dir d;
    if (sp_probe_dir_load(path_in("vp"), &d)) {
        CHECK(!"probe directory");
        return;
    }
    static const region lawn = { "lawn", 50, 300, 420, 560 }, road = { "road", 550, 700, 250, 330 };
    double f_post, z_post, f_sign, z_sign, f_lawn, z_lawn, f_road, z_road;
    region_stats(&d, &vt_post, &f_post, &z_post);
    region_stats(&d, &vt_sign, &f_sign, &z_sign);
    region_stats(&d, &lawn, &f_lawn, &z_lawn);
    region_stats(&d, &road, &f_road, &z_road);
    printf("vtest: occluding %.2f of the lamp post (median z %.0f), %.2f of the sign (median z %.0f), "
           "%.3f of the lawn, %.3f of the open road\n", f_post, z_post, f_sign, z_sign, f_lawn, f_road);
    CHECK_MSG(f_post >= 0.35 && z_post >= 260 && z_post < 400, "lamp post %.2f, z %.0f", f_post, z_post);
    CHECK_MSG(f_sign >= 0.6 && z_sign >= 250, "sign %.2f, z %.0f", f_sign, z_sign);
    /* one object, one depth (occluders.c): 109 rows apart before the map was settled as objects */
    CHECK_MSG(fabs(z_post - z_sign) <= 10, "the lamp post at row %.0f, its sign at %.0f", z_post, z_sign);
    CHECK_MSG(f_lawn <= 0.02 && f_road <= 0.01, "lawn %.3f road %.3f", f_lawn, f_road); /* issue 17: 1% */
    CHECK_MSG(!d.shadow.present, "overcast video, yet: %s", d.shadow.note);
    CHECK(d.plane.status == SP_PROBE_PLANE_OK);
    if (!SANITIZED) {
        printf("vtest: scale model fitted on the first half, median relative height error on the second %.4f "
               "(%u observations)\n", d.plane.holdout_error_rel, d.plane.holdout_n);
        CHECK(d.plane.holdout_n > 100 && d.plane.holdout_error_rel < 0.15);
    }
    sp_probe_dir_free(&d);
    if (!SANITIZED)
        test_vtest_start();
}

/* One object of objects.csv. */
typedef struct seen_object {
    long frame;
    char cls[8];
    int x0, y0, x1, y1;
} seen_object;

static double box_iou(const int a[4], const int b[4])
{
    double ix = fmax(0, fmin(a[2], b[2]) - fmax(a[0], b[0]) + 1), iy = fmax(0, fmin(a[3], b[3]) - fmax(a[1], b[1]) + 1);
    double u = (double)(a[2] - a[0] + 1) * (a[3] - a[1] + 1) + (double)(b[2] - b[0] + 1) * (b[3] - b[1] + 1) - ix * iy;
    return ix * iy / u;
}

/*
 * Scores objects.csv against the truth's car views: of the views inside the image in probed frames that an
 * object matches (IoU at least 0.5), how many were called car and how many person; and how many objects
 * were called car where no car was (IoU under 0.1 with every view of the frame).
 */
static void score_cars(const char *truth, const char *objects, size_t *matched, size_t *cars, size_t *people,
                       size_t *phantom)
{
    size_t len = 0, n = 0, cap = 0;
    char *csv = slurp(path_in(objects), &len), *save = NULL;
    seen_object *o = NULL;
    for (char *line = csv ? strtok_r(csv, "\n", &save) : NULL; line; line = strtok_r(NULL, "\n", &save)) {
        seen_object s;
        if (sscanf(line, "%ld,%*[^,],%7[^,],%d,%d,%d,%d", &s.frame, s.cls, &s.x0, &s.y0, &s.x1, &s.y1) != 6)
            continue; /* the header */
        if (n == cap && !(o = realloc(o, (cap = cap ? 2 * cap : 1024) * sizeof(*o))))
            break;
        o[n++] = s;
    }
    sp_json *t = read_json(truth);
    const sp_json *views = sp_json_get(t, "car_views");
    CHECK(csv && o && views && views->count > 20);
    *matched = *cars = *people = *phantom = 0;
    for (size_t v = 0; views && o && v < views->count; v++) {
        double f[7];
        if (sp_json_numbers(sp_json_at(views, v), f, 7) != 7 || f[6] != 0)
            continue; /* cut by the border */
        const int box[4] = { (int)f[2], (int)f[3], (int)f[4], (int)f[5] };
        double best = 0;
        const seen_object *b = NULL;
        for (size_t k = 0; k < n; k++) {
            const int ob[4] = { o[k].x0, o[k].y0, o[k].x1, o[k].y1 };
            if (o[k].frame == (long)f[0] && box_iou(ob, box) > best)
                best = box_iou(ob, box), b = &o[k];
        }
        if (best < 0.5)
            continue; /* merged with a walker, split by a pole, or in the plate's warm-up */
        (*matched)++;
        *cars += !strcmp(b->cls, "car"), *people += !strcmp(b->cls, "person");
    }
    for (size_t k = 0; views && o && k < n; k++) {
        if (strcmp(o[k].cls, "car"))
            continue;
        const int ob[4] = { o[k].x0, o[k].y0, o[k].x1, o[k].y1 };
        int near = 0;
        for (size_t v = 0; v < views->count && !near; v++) {
            double f[7];
            if (sp_json_numbers(sp_json_at(views, v), f, 7) == 7 && (long)f[0] == o[k].frame) {
                const int box[4] = { (int)f[2], (int)f[3], (int)f[4], (int)f[5] };
                near = box_iou(ob, box) >= 0.1;
            }
        }
        *phantom += !near;
    }
    sp_json_free(t);
    free(o);
    free(csv);
}

/*
 * Cars driving past behind the walkers (synth street --cars): called car, never person, with the walkers'
 * occlusion map as good as without them; a street of cars alone gives the scale from them (a car taken as
 * 1.5 m against a person's 1.7 m; the synthetic cars are 1.4-1.55 m).
 * Seeds 1-5 with six cars: 46/46, 52/53, 43/43, 27/31, 36/36 matched views called car (PROBE.md); the street of
 * cars alone (seed 4) 94/98. Held to the 95% on seed 2 and to 90% on the cars alone.
 */
static void test_cars(void)
{
    CHECK(run("synth", "street", "-o", path_in("cs.spcap"), "--seed", "2", "--cars", "6", NULL) == 0);
    CHECK(run("probe", path_in("cs.spcap"), "-o", path_in("csp"), "-q", "--objects", NULL) == 0);
    size_t matched, cars, people, phantom;
    score_cars("cs.truth.json", "csp/objects.csv", &matched, &cars, &people, &phantom);
    printf("cars: %zu of %zu matched car views called car, %zu person; %zu cars where none was\n", cars, matched,
           people, phantom);
    CHECK_MSG(matched >= 30 && cars >= 0.95 * (double)matched, "%zu of %zu called car", cars, matched);
    CHECK(people == 0 && phantom == 0);
    sp_probe_dir d;
    int ret = sp_probe_dir_load(path_in("csp"), &d);
    CHECK_MSG(ret == 0, "loading the probe directory: %s", sp_strerror(ret));
    if (!ret) {
        check_occlusion(&d, "cs");
        sp_probe_dir_free(&d);
    }
    CHECK(run("synth", "street", "-o", path_in("co.spcap"), "--seed", "4", "--cars", "8", "--figures", "0", NULL) == 0);
    CHECK(run("probe", path_in("co.spcap"), "-o", path_in("cop"), "-q", "--objects", NULL) == 0);
    score_cars("co.truth.json", "cop/objects.csv", &matched, &cars, &people, &phantom);
    printf("cars alone: %zu of %zu matched car views called car, %zu person; %zu cars where none was\n", cars, matched,
           people, phantom);
    CHECK_MSG(matched >= 60 && cars >= 0.9 * (double)matched, "%zu of %zu called car", cars, matched);
    CHECK(people == 0 && phantom == 0);
    ret = sp_probe_dir_load(path_in("cop"), &d);
    CHECK_MSG(ret == 0, "loading the probe directory: %s", sp_strerror(ret));
    if (ret)
        return;
    CHECK_MSG(d.plane.status == SP_PROBE_PLANE_OK && strstr(d.plane.note, "car"), "%s", d.plane.note);
    check_plane_and_shadow_in(&d, "co.truth.json", -1);
    sp_probe_dir_free(&d);
}

/*
 * Indoors (synth street --indoor: a hall, a counter, a cabinet and a chair's back as the occluders, lamps): the
 * map and the plane where a counter hides legs and a cabinet whole bodies, and a plate without the people who
 * stop. Seeds 1-5 recall 0.617, 0.889, 0.591, 0.570, 0.358 (session 30; PROBE.md). Seed 2 is held to 0.85 and
 * seed 1, whose cabinet is learned only from walkers who pass wholly behind it (0.276 without that rule), to
 * 0.55: guards, not the 0.9.
 */
static void test_indoor(void)
{
    static const struct {
        const char *seed, *name;
        double min_recall;
    } halls[] = { { "2", "in", 0.85 }, { "1", "in1", 0.55 } };
    for (size_t i = 0; i < sizeof(halls) / sizeof(halls[0]); i++) {
        char cap[32], dir[32];
        snprintf(cap, sizeof(cap), "%s.spcap", halls[i].name);
        snprintf(dir, sizeof(dir), "%sp", halls[i].name);
        CHECK(run("synth", "street", "-o", path_in(cap), "--indoor", "--seed", halls[i].seed, NULL) == 0);
        CHECK(run("probe", path_in(cap), "-o", path_in(dir), "-q", NULL) == 0);
        sp_probe_dir d;
        int ret = sp_probe_dir_load(path_in(dir), &d);
        CHECK_MSG(ret == 0, "loading the probe directory of hall seed %s: %s", halls[i].seed, sp_strerror(ret));
        if (!ret) {
            char truth[32];
            snprintf(truth, sizeof(truth), "%s.truth.json", halls[i].name);
            check_occlusion_min(&d, halls[i].name, halls[i].min_recall);
            check_plane_and_shadow_in(&d, truth, 0);
            sp_probe_dir_free(&d);
        }
    }
    CHECK(run("synth", "street", "-o", path_in("il.spcap"), "--indoor", "--seed", "5", "--linger", "30", NULL) == 0);
    CHECK(run("probe", path_in("il.spcap"), "-o", path_in("ilp"), "-q", NULL) == 0);
    double dp = png_diff("ilp/clean_plate.png", "il.background.png");
    printf("hall, people stopping for up to 30 s: clean plate differs from the empty hall by %.3f levels\n", dp);
    CHECK_MSG(dp >= 0 && dp < 0.5, "clean plate off by %.3f levels", dp); /* 0.169 measured (40.5 dB) */
}

static void cleanup(void)
{
    char cmd[600];
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", tmp);
    if (system(cmd) != 0)
        fprintf(stderr, "could not remove %s\n", tmp);
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: test_probe SUNPROBE sunny|seeds|linger|noise|overcast|cars|indoor|bad|vtest\n");
        return 99;
    }
    sunprobe = argv[1];
    if (!strcmp(argv[2], "vtest"))
        vtest_or_skip(); /* before the temporary directory exists */
    snprintf(tmp, sizeof(tmp), "%s/sp-probe-XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    if (!mkdtemp(tmp))
        return 99;
    if (!strcmp(argv[2], "sunny"))
        test_sunny();
    else if (!strcmp(argv[2], "seeds"))
        test_seeds();
    else if (!strcmp(argv[2], "linger"))
        test_linger();
    else if (!strcmp(argv[2], "noise"))
        test_noise();
    else if (!strcmp(argv[2], "overcast"))
        test_overcast();
    else if (!strcmp(argv[2], "cars"))
        test_cars();
    else if (!strcmp(argv[2], "indoor"))
        test_indoor();
    else if (!strcmp(argv[2], "bad"))
        test_bad();
    else if (!strcmp(argv[2], "vtest"))
        test_vtest();
    cleanup();
    return check_exit();
}
