/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe relight` as a photographer or VFX artist uses it, on a small fitted synthetic selfie:
 * linear output (.pfm, .exr) and the passes directory, finiteness at the extremes (sun at and below
 * the horizon, intensities of 1e5, focal lengths of 1 and 10,000 mm), a background picture, paint over
 * the albedo, and the round trip: each training keyframe rendered with the fitted light and camera
 * reproduces its own frame inside the face mask at least as well as the fit's training PSNR.
 * Usage: test_relight SUNPROBE
 */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "check.h"
#include "common/file_util.h"
#include "common/json.h"
#include "export/png.h"
#include "export/png_read.h"
#include "export/probe_dir.h"
#include "sp_config.h"
#include "sunprobe/sp_sunstage.h"

static char dir[256], face[300];
static const char *sunprobe;

/* Runs sunprobe with the printf-formatted arguments; its exit code, output in dir/out.txt. */
static int run(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static int run(const char *fmt, ...)
{
    char args[4096], cmd[8192];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(args, sizeof(args), fmt, ap);
    va_end(ap);
    snprintf(cmd, sizeof(cmd), "%s %s > %s/out.txt 2>&1", sunprobe, args, dir);
    int st = system(cmd);
    return st == -1 ? -1 : WEXITSTATUS(st);
}

static int said(const char *needle)
{
    char path[512];
    void *buf = NULL;
    size_t n = 0;
    snprintf(path, sizeof(path), "%s/out.txt", dir);
    if (sp_read_whole_file(path, 1 << 20, &buf, &n))
        return 0;
    char *s = realloc(buf, n + 1);
    if (!s) {
        free(buf);
        return 0;
    }
    s[n] = 0;
    int found = strstr(s, needle) != NULL;
    free(s);
    return found;
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

static char *in_dir(const char *name)
{
    static char paths[8][600];
    static int next;
    char *p = paths[next++ % 8];
    snprintf(p, sizeof(paths[0]), "%s/%s", dir, name);
    return p;
}

/* A PFM of the run's directory: values (caller frees) or NULL. */
static float *pfm(const char *path, uint32_t *w, uint32_t *h, int *ch)
{
    float *v = NULL;
    return sp_pfm_read(path, &v, w, h, ch) == 0 ? v : NULL;
}

static int all_finite_nonneg(const float *v, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (!isfinite(v[i]) || v[i] < 0.0f)
            return 0;
    return 1;
}

/* -o .pfm is the beauty pass; beauty = diffuse + specular + ambient; alpha, visibility and normals in range. */
static void check_passes(void)
{
    char *passes = in_dir("passes"), *out = in_dir("lin.pfm");
    CHECK_MSG(run("relight %s -o %s --sun 60,30 --passes %s", face, out, passes) == 0, "relight --passes");
    char p[800];
    static const char *const names[] = { "beauty", "diffuse", "specular", "ambient", "visibility", "normal",
                                         "albedo", "alpha" };
    float *v[8] = { 0 };
    uint32_t w = 0, h = 0, w1, h1;
    int ch;
    for (int k = 0; k < 8; k++) {
        snprintf(p, sizeof(p), "%s/%s.pfm", passes, names[k]);
        v[k] = pfm(p, &w1, &h1, &ch);
        CHECK_MSG(v[k] && (k ? w1 == w && h1 == h : 1) && ch == (k == 4 || k == 7 ? 1 : 3), "pass %s", names[k]);
        w = k ? w : w1, h = k ? h : h1;
    }
    float *o = pfm(out, &w1, &h1, &ch);
    size_t n = (size_t)w * h;
    CHECK_MSG(o && v[0] && w1 == w && h1 == h && ch == 3 && !memcmp(o, v[0], n * 3 * sizeof(float)),
              "-o .pfm is not the beauty pass");
    int ok = o != NULL;
    for (int k = 0; k < 8; k++)
        ok &= v[k] != NULL;
    if (ok) {
        double worst = 0.0, lit = 0.0, cover = 0.0;
        int bad = 0;
        for (size_t i = 0; i < n; i++) {
            double a = v[7][i], nl = 0.0;
            for (int c = 0; c < 3; c++) {
                size_t j = i * 3 + (size_t)c;
                double sum = (double)v[1][j] + (double)v[2][j] + (double)v[3][j];
                worst = fmax(worst, fabs(sum - (double)v[0][j]) / (1e-6 + fabs((double)v[0][j])));
                nl += (double)v[5][j] * (double)v[5][j];
            }
            bad += !(a >= 0.0 && a <= 1.0) || !(v[4][i] >= 0.0f && (double)v[4][i] <= a + 1e-5) || !(sqrt(nl) <= a + 1e-3);
            lit += (double)v[4][i];
            cover += a;
        }
        CHECK_MSG(worst < 1e-4, "beauty - (diffuse + specular + ambient): %g relative", worst);
        CHECK_MSG(bad == 0, "%d pixels with alpha, visibility or normals out of range", bad);
        CHECK_MSG(cover > 100.0 && lit > 0.05 * cover && lit < cover, "visibility %g of coverage %g", lit, cover);
    }
    for (int k = 0; k < 8; k++)
        free(v[k]);
    free(o);
    /* a directory that is not a passes directory is never replaced */
    char *other = in_dir("other"), *keep = in_dir("other/keep.txt"), *none = in_dir("none.png");
    mkdir(other, 0755);
    FILE *f = fopen(keep, "w");
    if (f)
        fclose(f);
    CHECK(run("relight %s -o %s --passes %s", face, none, other) == 1 && exists(keep) && !exists(none) &&
          said("not replaced"));
    CHECK_MSG(run("relight %s -o %s --passes %s", face, none, passes) == 0, "a passes directory is replaced");
}

/* Linear output stays finite and non-negative at the extremes of light and lens. */
static void check_extremes(void)
{
    static const char *const opts[] = {
        "--sun 40,0 --intensity 1e5",          "--sun 40,-90 --intensity 1e5",
        "--sun 40,20 --sun-size 90 --intensity 1e5", "--sun 40,0 --fill dir,200,0,1e5,1,1,1",
        "--focal 1 --sun 40,10",               "--focal 10000 --sun 40,10",
        "--sun 40,20 --intensity 1e5 --exposure 1e5",
        "--sun 40,10 --fill point,200,0,1e5,1,1,1", "--sun 40,10 --fill point,0,-90,1e5",
    };
    char *out = in_dir("extreme.pfm");
    for (size_t k = 0; k < sizeof(opts) / sizeof(opts[0]); k++) {
        remove(out);
        int rc = run("relight %s -o %s %s", face, out, opts[k]);
        uint32_t w = 0, h = 0;
        int ch = 0;
        float *v = rc == 0 ? pfm(out, &w, &h, &ch) : NULL;
        CHECK_MSG(v && all_finite_nonneg(v, (size_t)w * h * 3), "%s: exit %d, not finite or negative", opts[k], rc);
        free(v);
    }
}

/* -o .exr: a 32-bit OpenEXR where OpenImageIO is built, else exit 4 with nothing written. */
static void check_exr(void)
{
    char *out = in_dir("lin.exr");
    int rc = run("relight %s -o %s", face, out);
    if (!HAVE_OPENIMAGEIO) {
        CHECK_MSG(rc == 4 && !exists(out) && said("OpenImageIO"), "-o .exr without OpenImageIO: exit %d", rc);
        return;
    }
    unsigned char magic[4] = { 0 };
    FILE *f = fopen(out, "rb");
    size_t got = f ? fread(magic, 1, 4, f) : 0;
    if (f)
        fclose(f);
    CHECK_MSG(rc == 0 && got == 4 && magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01,
              "-o .exr: exit %d, no OpenEXR", rc);
}

static int write_png_fill(const char *path, int w, int h, int ch, const uint8_t *px4)
{
    uint8_t *px = malloc((size_t)w * h * (size_t)ch);
    for (int i = 0; px && i < w * h; i++)
        memcpy(px + (size_t)i * (size_t)ch, px4, (size_t)ch);
    int ret = px ? sp_png_write(path, px, (uint32_t)w, (uint32_t)h, (uint32_t)(w * ch), ch) : -1;
    free(px);
    return ret;
}

static uint8_t *relight_png(const char *opts, const char *name, uint32_t *w, uint32_t *h)
{
    char *out = in_dir(name);
    uint8_t *px = NULL;
    remove(out);
    if (run("relight %s -o %s %s", face, out, opts) != 0 || sp_png_read_rgba(out, &px, w, h) != 0)
        return NULL;
    return px;
}

/* A sky the same at every azimuth (rows of one colour each), turned by 180 deg, lights the face the same. */
static void check_symmetric_sky(void)
{
    char *env = in_dir("sym.f32"), opts[800];
    float v[16 * 32 * 3];
    for (int i = 0; i < 16 * 32; i++)
        for (int c = 0; c < 3; c++)
            v[i * 3 + c] = (float)(0.2 + 0.05 * (i / 32) + 0.1 * c);
    FILE *f = fopen(env, "wb");
    CHECK(f && fwrite(v, sizeof(v), 1, f) == 1);
    if (f)
        fclose(f);
    uint32_t w0 = 0, h0 = 0, w1 = 0, h1 = 0;
    snprintf(opts, sizeof(opts), "--sun 60,30 --env %s", env);
    uint8_t *a = relight_png(opts, "sym-0.png", &w0, &h0);
    snprintf(opts, sizeof(opts), "--sun 60,30 --env %s --env-rotate 180", env);
    uint8_t *b = relight_png(opts, "sym-180.png", &w1, &h1);
    int worst = a && b && w0 == w1 && h0 == h1 ? 0 : 999;
    for (size_t i = 0; worst < 999 && i < (size_t)w0 * h0 * 4; i++)
        worst = abs(a[i] - b[i]) > worst ? abs(a[i] - b[i]) : worst;
    CHECK_MSG(worst <= 1, "a symmetric sky turned by 180 deg changed the render by %d levels", worst);
    free(a);
    free(b);
}

/* --background FILE: the picture's size, opaque, the picture where the head is not, the head over it. */
static void check_background_file(void)
{
    static const uint8_t orange[4] = { 200, 100, 50, 255 };
    char *bg = in_dir("bg.png"), opts[800];
    CHECK(write_png_fill(bg, 64, 48, 3, orange) == 0);
    for (int big = 0; big < 2; big++) {
        snprintf(opts, sizeof(opts), "--background %s%s", bg, big ? " --size 128x96" : "");
        uint32_t w = 0, h = 0, W = big ? 128 : 64, H = big ? 96 : 48;
        uint8_t *px = relight_png(opts, "bg-out.png", &w, &h);
        CHECK_MSG(px && w == W && h == H, "%s: %ux%u", opts, w, h);
        if (!px || w != W || h != H) {
            free(px);
            continue;
        }
        int worst = 0, opaque = 1, head = 0;
        for (size_t i = 0; i < (size_t)w * h; i++) {
            int d = 0;
            for (int c = 0; c < 3; c++)
                d = abs((int)px[i * 4 + (size_t)c] - orange[c]) > d ? abs((int)px[i * 4 + (size_t)c] - orange[c]) : d;
            opaque &= px[i * 4 + 3] == 255;
            head += d > 8;
            if (i < w) /* the top row: sky, far from the head */
                worst = d > worst ? d : worst;
        }
        CHECK_MSG(worst <= 1 && opaque && head > (int)(w * h / 50), "%s: top row off by %d, opaque %d, head %d px",
                  opts, worst, opaque, head);
        free(px);
    }
}

/* --albedo-paint: transparent paint changes nothing, opaque red paint reddens the head, RGB is refused. */
static void check_paint(void)
{
    static const uint8_t clear[4] = { 0, 255, 0, 0 }, red[4] = { 255, 0, 0, 255 };
    char *p0 = in_dir("paint-clear.png"), *p1 = in_dir("paint-red.png"), *p2 = in_dir("paint-rgb.png");
    CHECK(write_png_fill(p0, 32, 16, 4, clear) == 0 && write_png_fill(p1, 32, 16, 4, red) == 0 &&
          write_png_fill(p2, 32, 16, 3, red) == 0);
    uint32_t w0 = 0, h0 = 0, w1 = 0, h1 = 0, w2 = 0, h2 = 0;
    char opts[800];
    uint8_t *def = relight_png("--sun 60,30", "paint-def.png", &w0, &h0);
    snprintf(opts, sizeof(opts), "--sun 60,30 --albedo-paint %s", p0);
    uint8_t *c = relight_png(opts, "paint-0.png", &w1, &h1);
    snprintf(opts, sizeof(opts), "--sun 60,30 --albedo-paint %s", p1);
    uint8_t *r = relight_png(opts, "paint-1.png", &w2, &h2);
    size_t n = (size_t)w0 * h0;
    CHECK_MSG(def && c && w1 == w0 && h1 == h0 && !memcmp(def, c, n * 4), "transparent paint changed the render");
    if (def && r && w2 == w0 && h2 == h0) {
        double dg = 0.0, on = 0.0;
        int brighter = 0;
        for (size_t i = 0; i < n; i++)
            if (def[i * 4 + 3] == 255) {
                brighter += r[i * 4 + 1] > def[i * 4 + 1] || r[i * 4 + 2] > def[i * 4 + 2];
                dg += (double)def[i * 4 + 1] - r[i * 4 + 1];
                on++;
            }
        CHECK_MSG(on > 100 && brighter == 0 && dg / on > 10.0, "red paint: %d brighter, green down %g levels", brighter,
                  on > 0 ? dg / on : 0.0);
    } else {
        CHECK_MSG(0, "red paint did not render");
    }
    char *out = in_dir("paint-bad.png");
    CHECK_MSG(run("relight %s -o %s --albedo-paint %s", face, out, p2) == 2 && !exists(out) && said("no alpha"), "a paint PNG without alpha");
    free(def);
    free(c);
    free(r);
}

/*
 * --albedo-paint-image: transparent paint over keyframe 0's frame changes nothing; a blue stripe down the
 * middle of the frame turns the face blue there in the same view and nowhere in the left quarter; a picture
 * of another size is refused naming it, with no file.
 */
static void check_paint_image(void)
{
    uint32_t w = 0, h = 0, w1 = 0, h1 = 0, w2 = 0, h2 = 0;
    uint8_t *def = relight_png("", "pi-def.png", &w, &h);
    if (!def) {
        CHECK_MSG(0, "default render");
        return;
    }
    static const uint8_t clear[4] = { 0, 0, 255, 0 }, red[4] = { 255, 0, 0, 255 };
    char *p0 = in_dir("pi-clear.png"), *p1 = in_dir("pi-stripe.png"), *p2 = in_dir("pi-small.png"), opts[800];
    uint8_t *stripe = malloc((size_t)w * h * 4);
    for (size_t i = 0; stripe && i < (size_t)w * h; i++) {
        uint32_t x = (uint32_t)(i % w);
        uint8_t px[4] = { 0, 0, 255, (uint8_t)(x >= w / 2 - w / 16 && x < w / 2 + w / 16 ? 255 : 0) };
        memcpy(stripe + i * 4, px, 4);
    }
    CHECK(stripe && write_png_fill(p0, (int)w, (int)h, 4, clear) == 0 &&
          sp_png_write(p1, stripe, w, h, w * 4, 4) == 0 && write_png_fill(p2, 16, 16, 4, red) == 0);
    snprintf(opts, sizeof(opts), "--albedo-paint-image %s,0", p0);
    uint8_t *c = relight_png(opts, "pi-0.png", &w1, &h1);
    CHECK_MSG(c && w1 == w && h1 == h && !memcmp(c, def, (size_t)w * h * 4), "transparent image paint changed the render");
    snprintf(opts, sizeof(opts), "--albedo-paint-image %s,0", p1);
    uint8_t *b = relight_png(opts, "pi-1.png", &w2, &h2);
    int bluer = 0, left = 0;
    for (size_t i = 0; b && w2 == w && h2 == h && i < (size_t)w * h; i++) {
        uint32_t x = (uint32_t)(i % w);
        if (def[i * 4 + 3] == 255 && x >= w / 2 - w / 32 && x < w / 2 + w / 32)
            bluer += b[i * 4 + 2] > def[i * 4 + 2] + 8 && b[i * 4] < def[i * 4];
        if (x < w / 4)
            left += memcmp(b + i * 4, def + i * 4, 4) != 0;
    }
    CHECK_MSG(b && bluer > 50 && left == 0, "a blue stripe: %d face pixels bluer, %d changed in the left quarter",
              bluer, left);
    char *out = in_dir("pi-bad.png");
    CHECK(run("relight %s -o %s --albedo-paint-image %s,0", face, out, p2) == 2 && !exists(out) && said("16x16"));
    free(def);
    free(stripe);
    free(c);
    free(b);
}

/* A point fill of intensity 0 changes nothing; a white one only brightens, and brightens the head. */
static void check_point_fill(void)
{
    uint32_t w0 = 0, h0 = 0, w1 = 0, h1 = 0, w2 = 0, h2 = 0;
    uint8_t *def = relight_png("--sun 60,30", "pf-def.png", &w0, &h0);
    uint8_t *f0 = relight_png("--sun 60,30 --fill point,240,10,0", "pf-0.png", &w1, &h1);
    uint8_t *f1 = relight_png("--sun 60,30 --fill point,240,10,2", "pf-1.png", &w2, &h2);
    size_t n = (size_t)w0 * h0 * 4;
    CHECK_MSG(def && f0 && w1 == w0 && h1 == h0 && !memcmp(def, f0, n), "a point fill of 0 changed the render");
    int darker = 0, brighter = 0;
    for (size_t i = 0; def && f1 && w2 == w0 && h2 == h0 && i < n; i++) {
        darker += i % 4 != 3 && f1[i] < def[i];
        brighter += i % 4 != 3 && f1[i] > def[i];
    }
    CHECK_MSG(f1 && darker == 0 && brighter > 300, "a point fill darkened %d channels, brightened %d", darker, brighter);
    free(def);
    free(f0);
    free(f1);
}

/* cameras.json and manifest.json of the fit (caller frees), or NULL. */
static sp_json *face_json(const char *name)
{
    char path[800], err[160];
    void *buf = NULL;
    size_t n = 0;
    sp_json *root = NULL;
    snprintf(path, sizeof(path), "%s/%s", face, name);
    if (sp_read_whole_file(path, 64u << 20, &buf, &n) || sp_json_parse(buf, n, &root, err, sizeof(err)))
        root = NULL;
    free(buf);
    return root;
}

/*
 * v (W x H x ch, capture pixels) box-filtered to w x h as the fit's front end filters a frame: fit pixel
 * (X, Y) averages the capture pixels [X W / w, (X + 1) W / w) x [Y H / h, (Y + 1) H / h) (no crop here).
 */
static void to_fit(const double *v, int W, int H, int ch, int w, int h, double *out)
{
    for (int Y = 0; Y < h; Y++)
        for (int X = 0; X < w; X++) {
            int x0 = X * W / w, x1 = (X + 1) * W / w, y0 = Y * H / h, y1 = (Y + 1) * H / h;
            x1 = x1 > x0 ? x1 : x0 + 1;
            y1 = y1 > y0 ? y1 : y0 + 1;
            double acc[8] = { 0 }; /* ch <= 8 */
            for (int y = y0; y < y1; y++)
                for (int x = x0; x < x1; x++)
                    for (int c = 0; c < ch; c++)
                        acc[c] += v[((size_t)y * (size_t)W + (size_t)x) * (size_t)ch + (size_t)c];
            for (int c = 0; c < ch; c++)
                out[((size_t)Y * (size_t)w + (size_t)X) * (size_t)ch + (size_t)c] = acc[c] / ((x1 - x0) * (y1 - y0));
        }
}

/*
 * Squared error and count of keyframe k rendered as the fit sees it (its camera at the fit's size, one sample
 * a pixel) against its frame box-filtered as the fit's front end does, inside the face (rim out, as the fit
 * has it), unsaturated.
 */
static int round_trip_frame(const sp_json *kf, int k, double *se, double *cnt)
{
    char *passes = in_dir("rt-passes"), *out = in_dir("rt.pfm"), path[900];
    if (run("relight %s -o %s --view keyframe:%d --scale 1 --supersample 1 --passes %s", face, out, k, passes))
        return -1;
    uint32_t w = 0, h = 0, wa, ha, wf, hf;
    int ch, cha;
    snprintf(path, sizeof(path), "%s/beauty.pfm", passes);
    float *b = pfm(path, &w, &h, &ch);
    snprintf(path, sizeof(path), "%s/face.pfm", passes);
    float *a = pfm(path, &wa, &ha, &cha);
    uint8_t *fr = NULL;
    snprintf(path, sizeof(path), "%s/frames/frame_%06.0f.png", dir, sp_json_number(sp_json_get(kf, "sequence"), -1));
    int ret = b && a && wa == w && ha == h && sp_png_read_rgba(path, &fr, &wf, &hf) == 0 ? 0 : -1;
    double *frame = ret ? NULL : malloc(sizeof(double) * 3 * wf * hf), *target = malloc(sizeof(double) * 3 * w * h);
    for (size_t i = 0; frame && i < (size_t)wf * hf * 3; i++)
        frame[i] = fr[i / 3 * 4 + i % 3] / 255.0;
    if (frame && target) {
        to_fit(frame, (int)wf, (int)hf, 3, (int)w, (int)h, target);
        for (size_t i = 0; i < (size_t)w * h; i++) {
            const double *g = target + i * 3;
            size_t x = i % w, y = i / w; /* the fit's mask: face with its four neighbours (not the rim), unsaturated */
            int inside = x > 0 && y > 0 && x + 1 < w && y + 1 < h && a[i] >= 0.999f && a[i - 1] >= 0.999f &&
                         a[i + 1] >= 0.999f && a[i - w] >= 0.999f && a[i + w] >= 0.999f;
            if (!inside || fmax(g[0], fmax(g[1], g[2])) > 0.98)
                continue;
            for (int c = 0; c < 3; c++) {
                double d = sp_sunstage_linear_to_display(fmax(0.0, (double)b[i * 3 + (size_t)c])) - g[c];
                *se += d * d;
                *cnt += 1.0;
            }
        }
    } else {
        ret = -1;
    }
    free(frame);
    free(target);
    free(b);
    free(a);
    free(fr);
    return ret;
}

/*
 * The round trip: every training keyframe rendered with the fitted camera, pose, light and that frame's
 * exposure matches its frame inside the face mask, pooled over the keyframes, at least as well as the fit's
 * own training PSNR.
 */
static void check_round_trip(void)
{
    sp_json *cams = face_json("cameras.json"), *man = face_json("manifest.json");
    double train = sp_json_number(sp_json_get(sp_json_get(man, "fit"), "train_psnr"), NAN);
    double se = 0.0, cnt = 0.0;
    int frames = 0, failed = 0;
    const sp_json *kf;
    for (size_t k = 0; (kf = sp_json_at(sp_json_get(cams, "frames"), k)); k++) {
        const sp_json *held = sp_json_get(kf, "heldout");
        if (held && held->type == SP_JSON_BOOL && held->number != 0.0)
            continue;
        double se0 = se, cnt0 = cnt;
        failed += round_trip_frame(kf, (int)k, &se, &cnt) != 0;
        printf("keyframe %zu: %.2f dB over %.0f values\n", k, -10.0 * log10((se - se0) / fmax(1.0, cnt - cnt0)), cnt - cnt0);
        frames++;
    }
    double psnr = cnt > 0.0 && se > 0.0 ? -10.0 * log10(se / cnt) : (double)NAN;
    printf("round trip: %d training keyframes, %.4f dB inside the face mask; the fit's training PSNR %.4f dB\n", frames,
           psnr, train);
    CHECK_MSG(cams && man && frames > 0 && !failed, "%d of %d keyframes did not render", failed, frames);
    /* the same sums in another order: equal to rounding, so 0.01 dB of slack */
    CHECK_MSG(isfinite(train) && psnr >= train - 0.01, "round trip %.4f dB, training %.4f dB", psnr, train);
    sp_json_free(cams);
    sp_json_free(man);
}

/* The largest difference of tile k (W x H at column k % 5, row k / 5, rows cap apart) from rgb (RGBA, over grey 40). */
static int tile_diff(const uint8_t *panel, uint32_t pw, int k, uint32_t W, uint32_t H, uint32_t cap, const uint8_t *rgba,
                     int *n_off)
{
    int worst = 0;
    *n_off = 0;
    for (uint32_t y = 0; y < H; y++)
        for (uint32_t x = 0; x < W; x++) {
            const uint8_t *p = panel + ((size_t)((uint32_t)(k / 5) * (H + cap) + y) * pw + (uint32_t)(k % 5) * W + x) * 4;
            const uint8_t *q = rgba + ((size_t)y * W + x) * 4;
            int d = 0;
            for (int c = 0; c < 3; c++) {
                int want = (q[c] * q[3] + 40 * (255 - q[3]) + 127) / 255;
                d = abs(p[c] - want) > d ? abs(p[c] - want) : d;
            }
            worst = d > worst ? d : worst;
            *n_off += d > 2;
        }
    return worst;
}

/*
 * --panel: ten tiles of the default view's size with captions; the input frame is the keyframe's frame, the
 * reconstruction the default render, every other tile differs from it; --panel with --passes is refused.
 */
static void check_panel(void)
{
    uint32_t w = 0, h = 0, pw = 0, ph = 0, fw = 0, fh = 0;
    uint8_t *def = relight_png("", "panel-def.png", &w, &h), *panel = NULL, *frame = NULL;
    char *out = in_dir("panel.png"), path[800];
    int rc = run("relight %s -o %s --panel --capture %s/s.spcap", face, out, dir);
    CHECK_MSG(rc == 0 && sp_png_read_rgba(out, &panel, &pw, &ph) == 0, "--panel: exit %d", rc);
    sp_json *cams = face_json("cameras.json");
    snprintf(path, sizeof(path), "%s/frames/frame_%06.0f.png", dir,
             sp_json_number(sp_json_get(sp_json_at(sp_json_get(cams, "frames"), 0), "sequence"), -1));
    sp_json_free(cams);
    uint32_t cap = (ph - 2 * h) / 2;
    int ok = def && panel && pw == 5 * w && ph > 2 * h && cap >= 8 && cap <= 40 && sp_png_read_rgba(path, &frame, &fw, &fh) == 0;
    CHECK_MSG(ok, "panel %ux%u for tiles of %ux%u", pw, ph, w, h);
    if (ok) {
        int n_off, worst = tile_diff(panel, pw, 1, w, h, cap, def, &n_off);
        CHECK_MSG(worst <= 1, "the reconstruction tile differs from the default render by %d", worst);
        worst = fw == w && fh == h ? tile_diff(panel, pw, 0, w, h, cap, frame, &n_off) : 999;
        CHECK_MSG(worst <= 1, "the input tile differs from keyframe 0's frame by %d", worst);
        for (int k = 2; k < 10; k++) {
            tile_diff(panel, pw, k, w, h, cap, def, &n_off);
            CHECK_MSG(n_off > 50, "tile %d differs from the reconstruction in only %d pixels", k, n_off);
        }
        int text = 0;
        for (uint32_t y = h; y < h + cap; y++)
            for (uint32_t x = w; x < 2 * w; x++)
                text += panel[((size_t)y * pw + x) * 4] != 40;
        CHECK_MSG(text > 20, "no caption under the reconstruction (%d pixels)", text);
    }
    free(def);
    free(panel);
    free(frame);
    char *bad = in_dir("panel-bad.png");
    CHECK(run("relight %s -o %s --panel --passes %s", face, bad, in_dir("panel-passes")) == 1 && !exists(bad));
}

int main(int argc, char **argv)
{
    if (argc < 2)
        SKIP("usage: test_relight SUNPROBE");
    sunprobe = argv[1];
    snprintf(dir, sizeof(dir), "%s/sp-relight.XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    if (!mkdtemp(dir))
        SKIP("cannot create a temporary directory");
    snprintf(face, sizeof(face), "%s/s.face", dir);
    char cap[600];
    snprintf(cap, sizeof(cap), "%s/s.spcap", dir);
    int rc = run("synth selfie -o %s --face generic --width 160 --height 160 --turn-seconds 4 --still 1 "
                 "--supersample 1 --shadow-size 512 --relit 0 --novel 0 --fps 20", cap);
    if (rc == 0) /* the frames as a user sees them, for the round trip */
        rc = run("export-video %s -o %s", cap, in_dir("frames"));
    CHECK_MSG(rc == 0, "synth selfie: exit %d", rc);
    if (rc == 0)
        rc = run("fit %s -o %s --face generic --keyframes 8 --heldout 2 --no-progress", cap, face);
    CHECK_MSG(rc == 0, "fit: exit %d", rc);
    if (rc == 0) {
        check_passes();
        check_extremes();
        check_exr();
        check_symmetric_sky();
        check_background_file();
        check_paint();
        check_point_fill();
        check_paint_image();
        check_panel();
        check_round_trip();
    }
    char cmd[300];
    snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
    if (system(cmd) == -1)
        fprintf(stderr, "cannot remove %s\n", dir);
    return check_exit();
}
