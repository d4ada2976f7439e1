/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe fit` and `sunprobe relight` end to end. Bad input (no IMU, one
 * frame, all-black frames, frames without a face) must end with exit code 2
 * and a message, and leave neither FACE_DIR nor FACE_DIR.partial.<pid> behind.
 * With "synth" as second argument, a small synthetic selfie is fitted and the
 * sun direction must come out within a few degrees of the truth; with "clock", the same for a capture
 * that carries its time and place (the sun from the clock).
 * Usage: test_fit SUNPROBE [synth|clock]
 */
#include <errno.h>
#include <math.h>
#include <glob.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "check.h"
#include "common/file_util.h"
#include "common/json.h"
#include "export/png_read.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_frame.h"
#include "sunprobe/sp_sunstage.h"

#define FW 64
#define FH 48

static char dir[256];
static const char *sunprobe;

typedef enum { CONTENT_BLACK, CONTENT_NOISE } content;

/* Still IMU at 200 Hz from start_ns to end_ns. */
static int write_still_imu(sp_capture_writer *w, int64_t start_ns, int64_t end_ns)
{
    int ret = 0;
    for (int64_t t = start_ns; !ret && t < end_ns; t += 5000000) {
        sp_imu_sample s[2] = { { t, SP_IMU_GYRO, { 0, 0, 0 } }, { t, SP_IMU_ACCEL, { 0, -9.81f, 0 } } };
        ret = sp_capture_write_imu(w, s, 2);
    }
    return ret;
}

/*
 * Writes a capture: n RGB24 frames at 15 fps (black or noise), with_imu 1: still IMU over them at
 * 200 Hz; 2: the same IMU 1000 s later (a clock that never meets the frames', as a recorder could write);
 * 3: as 1 with every frame at the first frame's time (a writer that stamped them all at once).
 */
static int write_capture(const char *path, int n, content what, int with_imu)
{
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    ws.sync = SP_SYNC_NONE;
    ws.overwrite = 1;
    sp_capture_writer *w = NULL;
    int ret = sp_capture_writer_open(&w, path, &ws);
    if (ret)
        return ret;
    const char *meta = "{\"kind\":\"selfie\",\"camera\":{\"width\":64,\"height\":48,\"fps\":15,\"fx\":60,\"fy\":60,"
                       "\"cx\":31.5,\"cy\":23.5}}";
    ret = sp_capture_write_meta(w, 0, meta, strlen(meta));
    sp_frame_pool *pool = NULL;
    if (!ret)
        ret = sp_frame_pool_open(&pool, 1, FW * FH * 3);
    int64_t end_ns = (int64_t)n * 66666667 + 500000000;
    if (!ret && (with_imu == 1 || with_imu == 3))
        ret = write_still_imu(w, 0, end_ns);
    unsigned seed = 7;
    for (int i = 0; !ret && i < n; i++) {
        sp_frame *f = NULL;
        if ((ret = sp_frame_pool_get(pool, &f)))
            break;
        f->format = SP_PIXFMT_RGB24;
        f->width = FW;
        f->height = FH;
        f->stride = FW * 3;
        f->bytes_used = FW * FH * 3;
        f->timestamp_ns = 300000000 + (with_imu == 3 ? 0 : (int64_t)i * 66666667);
        f->sequence = (uint64_t)i;
        for (size_t k = 0; k < f->bytes_used; k++)
            f->data[k] = what == CONTENT_BLACK ? 0 : (uint8_t)(64 + (rand_r(&seed) % 128));
        ret = sp_capture_write_frame(w, f);
        sp_frame_unref(&f);
    }
    if (!ret && with_imu == 2)
        ret = write_still_imu(w, 1000000000000LL, 1000000000000LL + end_ns);
    sp_frame_pool_close(&pool);
    int cret = sp_capture_writer_close(&w);
    return ret ? ret : cret;
}

/* 1 when some path matches the glob pattern. */
static int matches(const char *pattern)
{
    glob_t g;
    int found = glob(pattern, 0, NULL, &g) == 0 && g.gl_pathc > 0;
    globfree(&g);
    return found;
}

static int exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* Runs a command line; returns its exit code, output in dir/out.txt. */
static int run(const char *args)
{
    char cmd[4096];
    snprintf(cmd, sizeof(cmd), "%s %s > %s/out.txt 2>&1", sunprobe, args, dir);
    int st = system(cmd);
    return st == -1 ? -1 : WEXITSTATUS(st);
}

static int output_contains(const char *needle)
{
    char path[512], buf[8192];
    snprintf(path, sizeof(path), "%s/out.txt", dir);
    FILE *f = fopen(path, "r");
    if (!f)
        return 0;
    size_t n = fread(buf, 1, sizeof(buf) - 1, f);
    fclose(f);
    buf[n] = 0;
    return strstr(buf, needle) != NULL;
}

static void show_output(void)
{
    char cmd[512];
    snprintf(cmd, sizeof(cmd), "sed 's/^/  | /' %s/out.txt >&2", dir);
    if (system(cmd) == -1)
        fprintf(stderr, "(cannot show output)\n");
}

static void bad_input(const char *name, int n, content what, int with_imu, const char *message)
{
    char cap[512], face[512], partial[600], args[2048];
    snprintf(cap, sizeof(cap), "%s/%s.spcap", dir, name);
    snprintf(face, sizeof(face), "%s/%s.face", dir, name);
    snprintf(partial, sizeof(partial), "%s.partial*", face); /* FACE_DIR.partial.<pid of the fit> */
    CHECK(write_capture(cap, n, what, with_imu) == 0);
    snprintf(args, sizeof(args), "fit %s -o %s --face generic --no-progress", cap, face);
    int code = run(args);
    CHECK_MSG(code == 2, "%s: exit %d, expected 2", name, code);
    CHECK_MSG(output_contains(message), "%s: no '%s' in the output", name, message);
    CHECK(!exists(face));
    CHECK_MSG(!matches(partial), "%s left behind", partial);
    if (code != 2 || !output_contains(message))
        show_output();
}

/* 1 when FACE/displacement.f32 is all zero, 0 when not, -1 when unreadable. */
static int displacement_flat(const char *face)
{
    char path[700];
    snprintf(path, sizeof(path), "%s/displacement.f32", face);
    FILE *f = fopen(path, "rb");
    if (!f)
        return -1;
    float v;
    int flat = 1;
    size_t n = 0;
    while (fread(&v, sizeof(v), 1, f) == 1) {
        n++;
        if (v != 0.0f)
            flat = 0;
    }
    fclose(f);
    return n ? flat : -1;
}

/* sp_face_dir_read: left_out from the manifest, and inferred for a manifest without it (older writers). */
static void check_left_out_reader(const char *face, const char *manifest, int flat)
{
    sp_face_asset a;
    CHECK(sp_face_dir_read(&a, face) == 0);
    CHECK(!a.left_out_inferred);
    CHECK(!!(a.left_out & SP_FACE_LEFT_OUT_DISPLACEMENT) == (flat == 1));
    unsigned written = a.left_out;
    sp_face_asset_free(&a);
    /* the same directory as an old writer left it: drop the "left_out" line */
    char path[700];
    snprintf(path, sizeof(path), "%s/manifest.json", face);
    const char *l = strstr(manifest, "\"left_out\":[");
    const char *e = l ? strchr(l, '\n') : NULL;
    FILE *f = e ? fopen(path, "w") : NULL;
    CHECK(f != NULL);
    if (!f)
        return;
    fwrite(manifest, 1, (size_t)(l - manifest), f);
    fputs(e + 1, f);
    fclose(f);
    CHECK(sp_face_dir_read(&a, face) == 0);
    CHECK(a.left_out_inferred);
    /* inference sees the zeros the list named: displacement, and sun/specular when they are zero */
    CHECK(!!(a.left_out & SP_FACE_LEFT_OUT_DISPLACEMENT) == !!(written & SP_FACE_LEFT_OUT_DISPLACEMENT));
    CHECK(!!(a.left_out & SP_FACE_LEFT_OUT_SUN) == !!(written & SP_FACE_LEFT_OUT_SUN));
    sp_face_asset_free(&a);
}

/* The report has a row per solver phase; the sun error converges to the final one. */
static void check_report(double final_err)
{
    char path[512], line[512];
    snprintf(path, sizeof(path), "%s/rep.csv", dir);
    FILE *f = fopen(path, "r");
    CHECK(f != NULL);
    if (!f)
        return;
    int rows = 0;
    double first = NAN, last = NAN;
    while (fgets(line, sizeof(line), f)) {
        double t, loss, ho, sun;
        if (sscanf(line, "%lf,%lf,%lf,%lf", &t, &loss, &ho, &sun) != 4)
            continue;
        if (!rows++)
            first = sun;
        last = sun;
    }
    fclose(f);
    CHECK_MSG(rows >= 5, "report rows %d", rows);
    CHECK_MSG(last <= first + 0.5, "sun error went from %.2f to %.2f deg", first, last);
    CHECK_NEAR(last, final_err, 0.01);
}

/* 1 when both files exist and hold the same bytes. */
static int same_bytes(const char *a, const char *b)
{
    FILE *fa = fopen(a, "rb"), *fb = fopen(b, "rb");
    int same = fa && fb;
    while (same) {
        int ca = fgetc(fa), cb = fgetc(fb);
        same = ca == cb;
        if (ca == EOF || cb == EOF)
            break;
    }
    if (fa)
        fclose(fa);
    if (fb)
        fclose(fb);
    return same;
}

/* One relight into dir/NAME.png; its RGBA (caller frees) or NULL when it failed. */
static uint8_t *relight_rgba(const char *face, const char *name, const char *opts, uint32_t *w, uint32_t *h)
{
    char args[2048], path[1024];
    snprintf(path, sizeof(path), "%s/%s.png", dir, name);
    snprintf(args, sizeof(args), "relight %s -o %s %s", face, path, opts);
    uint8_t *px = NULL;
    *w = *h = 0;
    if (run(args) != 0 || sp_png_read_rgba(path, &px, w, h) != 0)
        return NULL;
    return px;
}

static double coverage(const uint8_t *px, uint32_t w, uint32_t h)
{
    double s = 0;
    for (size_t i = 0; i < (size_t)w * h; i++)
        s += px[i * 4 + 3] / 255.0;
    return s;
}

/* Sum of absolute differences between horizontal neighbours on the head (alpha 255): edges, shadows' too. */
static double edge_energy(const uint8_t *px, uint32_t w, uint32_t h)
{
    double e = 0;
    for (size_t y = 0; y < h; y++)
        for (size_t x = 0; x + 1 < w; x++) {
            const uint8_t *a = px + (y * w + x) * 4, *b = a + 4;
            if (a[3] == 255 && b[3] == 255)
                for (int k = 0; k < 3; k++)
                    e += abs((int)a[k] - (int)b[k]);
        }
    return e;
}

/*
 * Lights add: a fill of intensity 0 changes nothing; an area sun of 0.001 deg is the point sun (to a
 * level); a 90 deg sun has softer shadows (less edge energy) than the point sun; a coloured fill adds.
 */
static void check_relight_lights(const char *face, uint32_t w0, uint32_t h0)
{
    uint32_t w, h;
    uint8_t *pt = relight_rgba(face, "rl-point", "--sun 60,20", &w, &h);
    uint8_t *f0 = relight_rgba(face, "rl-fill0", "--sun 60,20 --fill dir,240,10,0", &w, &h);
    uint8_t *tiny = relight_rgba(face, "rl-tiny", "--sun 60,20 --sun-size 0.001", &w, &h);
    uint8_t *wide = relight_rgba(face, "rl-area90", "--sun 60,20 --sun-size 90", &w, &h);
    uint8_t *fill = relight_rgba(face, "rl-fill", "--sun 60,20 --fill dir,240,10,2,0.2,0.4,1", &w, &h);
    CHECK(pt && f0 && tiny && wide && fill && w == w0 && h == h0);
    if (pt && f0 && tiny && wide && fill && w == w0 && h == h0) {
        size_t n = (size_t)w * h * 4;
        CHECK_MSG(!memcmp(pt, f0, n), "a fill of intensity 0 changed the image");
        int off = 0, darker = 0, bluer = 0;
        for (size_t i = 0; i < n; i++) {
            off += abs((int)pt[i] - (int)tiny[i]) > 2; /* a shadow-map texel may flip on a shadow's very edge */
            darker += i % 4 != 3 && fill[i] < pt[i];
            bluer += i % 4 == 2 && fill[i] > pt[i];
        }
        CHECK_MSG(off <= (int)(n / 2000), "a 0.001 deg sun differs from the point sun by > 2 levels in %d of %zu",
                  off, n);
        CHECK_MSG(darker == 0 && bluer > 100, "a fill darkened %d channels, brightened %d blue ones", darker, bluer);
        double ep = edge_energy(pt, w, h), ea = edge_energy(wide, w, h);
        CHECK_MSG(ea < ep, "a 90 deg sun: edge energy %g, the point sun's %g", ea, ep);
    }
    free(pt);
    free(f0);
    free(tiny);
    free(wide);
    free(fill);
}

/* The face's env.f32 as a PFM twice its size (each texel 2 x 2 pixels), or w x h of white for a bad aspect. */
static int write_env_pfm(const char *face, const char *path, int bad_aspect)
{
    char src[1024];
    snprintf(src, sizeof(src), "%s/env.f32", face);
    float env[32 * 16 * 3];
    FILE *f = fopen(src, "rb");
    size_t n = f ? fread(env, sizeof(float), 32 * 16 * 3, f) : 0;
    if (f)
        fclose(f);
    FILE *o = n == 32 * 16 * 3 ? fopen(path, "wb") : NULL;
    if (!o)
        return -1;
    int w = bad_aspect ? 48 : 64, h = 32;
    fprintf(o, "PF\n%d %d\n-1.0\n", w, h);
    for (int y = h - 1; y >= 0; y--) /* PFM: the bottom row first */
        for (int x = 0; x < w; x++)
            for (int k = 0; k < 3; k++) {
                float v = bad_aspect ? 1.0f : env[((y / 2) * 32 + x / 2) * 3 + k];
                fwrite(&v, sizeof(v), 1, o);
            }
    return fclose(o) == 0 ? 0 : -1;
}

/*
 * --env: the fitted sky written as a PFM at twice its resolution reads back (through OpenImageIO) to
 * the same image as the fitted sky; a turn by 360 deg changes nothing; a map that is not 2:1 is
 * refused naming its size, with no file. Skipped where the build has no OpenImageIO (exit 4).
 */
static void check_relight_env(const char *face, const uint8_t *def, uint32_t w0, uint32_t h0)
{
    char pfm[1024], bad[1024], opts[2200], args[4096], out[1024];
    snprintf(pfm, sizeof(pfm), "%s/env64.pfm", dir);
    snprintf(bad, sizeof(bad), "%s/env48.pfm", dir);
    CHECK(write_env_pfm(face, pfm, 0) == 0 && write_env_pfm(face, bad, 1) == 0);
    snprintf(out, sizeof(out), "%s/rl-envbad.png", dir);
    snprintf(args, sizeof(args), "relight %s -o %s --env %s", face, out, bad);
    int rc = run(args);
    if (rc == 4) {
        printf("SKIP (--env images): this build has no OpenImageIO\n");
        return;
    }
    CHECK_MSG(rc == 2 && !exists(out) && output_contains("48x32"), "a 48x32 map: exit %d", rc);
    uint32_t w, h;
    snprintf(opts, sizeof(opts), "--env %s", pfm);
    uint8_t *px = relight_rgba(face, "rl-env", opts, &w, &h);
    CHECK_MSG(px && w == w0 && h == h0 && !memcmp(px, def, (size_t)w * h * 4), "the fitted sky through a PFM differs");
    free(px);
    snprintf(opts, sizeof(opts), "--env %s --env-rotate 360", pfm);
    px = relight_rgba(face, "rl-env360", opts, &w, &h);
    int worst = 0;
    for (size_t i = 0; px && w == w0 && h == h0 && i < (size_t)w * h * 4; i++)
        worst = abs((int)px[i] - (int)def[i]) > worst ? abs((int)px[i] - (int)def[i]) : worst;
    CHECK_MSG(px && worst <= 1, "the sky turned by 360 deg differs by %d levels", worst);
    free(px);
}

/*
 * --background capture:1: keyframe 1 composited into its own frame of the fitted capture; away from
 * the head the output is that frame (as export-video decodes it) to a level; a missing --capture and a
 * keyframe out of range are refused with no file.
 */
static void check_relight_background(const char *face)
{
    char path[2048], args[4096], frames[1024];
    snprintf(path, sizeof(path), "%s/cameras.json", face);
    size_t n = 0;
    char *cams = NULL;
    FILE *f = fopen(path, "rb");
    if (f) {
        cams = malloc(1 << 20);
        n = cams ? fread(cams, 1, (1 << 20) - 1, f) : 0;
        fclose(f);
    }
    if (!cams) {
        CHECK_MSG(0, "cameras.json");
        return;
    }
    cams[n] = 0;
    const char *k = strstr(cams, "\"sequence\":");
    k = k ? strstr(k + 1, "\"sequence\":") : NULL; /* keyframe 1's */
    long seq = k ? strtol(k + 11, NULL, 10) : -1;
    free(cams);
    CHECK(seq >= 0);
    snprintf(frames, sizeof(frames), "%s/frames", dir);
    snprintf(args, sizeof(args), "export-video %s/s.spcap -o %s", dir, frames);
    CHECK(run(args) == 0);
    snprintf(args, sizeof(args), "--background capture:1 --capture %s/s.spcap", dir);
    uint32_t w, h, fw = 0, fh = 0;
    uint8_t *out = relight_rgba(face, "rl-bg", args, &w, &h), *frame = NULL;
    snprintf(path, sizeof(path), "%s/frame_%06ld.png", frames, seq);
    CHECK(sp_png_read_rgba(path, &frame, &fw, &fh) == 0);
    if (out && frame && w == fw && h == fh) {
        int worst = 0, opaque = 1;
        for (uint32_t y = 0; y < h / 8; y++) /* the top corners: sky, far from the head */
            for (uint32_t x = 0; x < w; x += (x == w / 8 ? w - w / 4 : 1)) {
                const uint8_t *a = out + ((size_t)y * w + x) * 4, *b = frame + ((size_t)y * w + x) * 4;
                for (int c = 0; c < 3; c++)
                    worst = abs((int)a[c] - (int)b[c]) > worst ? abs((int)a[c] - (int)b[c]) : worst;
                opaque &= a[3] == 255;
            }
        CHECK_MSG(worst <= 1 && opaque, "away from the head the composite differs from the frame by %d", worst);
    } else {
        CHECK_MSG(0, "composite %ux%u, frame %ux%u", w, h, fw, fh);
    }
    free(out);
    free(frame);
    snprintf(path, sizeof(path), "%s/rl-bg-bad.png", dir);
    snprintf(args, sizeof(args), "relight %s -o %s --background capture:1", face, path);
    CHECK(run(args) == 1 && !exists(path) && output_contains("--capture"));
    snprintf(args, sizeof(args), "relight %s -o %s --background capture:999 --capture %s/s.spcap", face, path, dir);
    CHECK(run(args) != 0 && !exists(path));
}

/*
 * `relight` views and materials: keyframe 0 and a zero orbit are the default view exactly; the size
 * option is honoured; specular only adds light (scale 0 never brighter than 1); a dolly zoom keeps
 * the head's size; extreme focal lengths still render; a keyframe out of range is refused, no file.
 */
static void check_relight_views(const char *face)
{
    uint32_t w0, h0, w, h;
    uint8_t *def = relight_rgba(face, "rl-default", "", &w0, &h0);
    CHECK_MSG(def != NULL, "relight with defaults");
    if (!def)
        return;
    CHECK(w0 > 0 && h0 > 0 && coverage(def, w0, h0) > 100.0);
    const char *same[] = { "--view keyframe:0", "--orbit 0,0" };
    for (int i = 0; i < 2; i++) {
        uint8_t *px = relight_rgba(face, "rl-same", same[i], &w, &h);
        CHECK_MSG(px && w == w0 && h == h0 && !memcmp(px, def, (size_t)w * h * 4), "relight %s differs", same[i]);
        free(px);
    }
    uint8_t *px = relight_rgba(face, "rl-size", "--size 64x48", &w, &h);
    CHECK_MSG(px && w == 64 && h == 48, "--size 64x48 gave %ux%u", w, h);
    free(px);
    uint8_t *s0 = relight_rgba(face, "rl-spec0", "--specular-scale 0", &w, &h), *s2 = NULL;
    if (s0 && w == w0 && h == h0) {
        int brighter = 0;
        for (size_t i = 0; i < (size_t)w * h * 4; i++)
            brighter += i % 4 != 3 && s0[i] > def[i];
        CHECK_MSG(brighter == 0, "%d channels brighter without specular", brighter);
    } else {
        CHECK_MSG(0, "--specular-scale 0");
    }
    s2 = relight_rgba(face, "rl-spec-nose", "--specular-scale nose=2 --specular-scale 0.5", &w, &h);
    CHECK(s2 != NULL);
    free(s0);
    free(s2);
    double c0 = coverage(def, w0, h0);
    uint8_t *tele = relight_rgba(face, "rl-tele", "--focal 10000", &w, &h);
    CHECK_MSG(tele && coverage(tele, w, h) > 0.6 * c0 && coverage(tele, w, h) < 1.6 * c0,
              "dolly zoom to 10000 mm: coverage %g against %g", tele ? coverage(tele, w, h) : -1.0, c0);
    free(tele);
    uint8_t *wide = relight_rgba(face, "rl-wide", "--focal 1", &w, &h);
    CHECK_MSG(wide != NULL, "--focal 1 renders");
    free(wide);
    uint8_t *orbit = relight_rgba(face, "rl-orbit", "--orbit 180,30 --sun 0,90", &w, &h);
    CHECK_MSG(orbit && coverage(orbit, w, h) > 0.3 * c0, "the back of the head from above");
    /* --save-camera then --camera: the same camera, the same image, bit for bit */
    {
        char cam[1024], opts[1200];
        snprintf(cam, sizeof(cam), "%s/rl-orbit-camera.json", dir);
        snprintf(opts, sizeof(opts), "--orbit 180,30 --sun 0,90 --save-camera %s", cam);
        uint32_t w1, h1, w2, h2;
        uint8_t *saved = relight_rgba(face, "rl-orbit-saved", opts, &w1, &h1);
        snprintf(opts, sizeof(opts), "--camera %s --sun 0,90", cam);
        uint8_t *again = relight_rgba(face, "rl-orbit-again", opts, &w2, &h2);
        CHECK_MSG(orbit && saved && again && w1 == w && h1 == h && w2 == w && h2 == h &&
                      !memcmp(saved, orbit, (size_t)w * h * 4) && !memcmp(again, orbit, (size_t)w * h * 4),
                  "--camera of a --save-camera file renders another image");
        free(saved);
        free(again);
        /* a camera whose rotation is not one is refused with the field named */
        FILE *f = fopen(cam, "w");
        if (f) {
            fputs("{\"width\": 64, \"height\": 48, \"fx\": 60, \"fy\": 60, \"cx\": 32, \"cy\": 24, \"camera_to_world\": "
                  "[[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}\n", f);
            fclose(f);
        }
        char args2[4096], bad[1024];
        snprintf(bad, sizeof(bad), "%s/rl-badcam.png", dir);
        snprintf(args2, sizeof(args2), "relight %s -o %s --camera %s", face, bad, cam);
        CHECK(run(args2) == 2 && !exists(bad) && output_contains("must be a rotation"));
    }
    free(orbit);
    check_relight_lights(face, w0, h0);
    check_relight_env(face, def, w0, h0);
    check_relight_background(face);
    char args[2048], path[1024];
    snprintf(path, sizeof(path), "%s/rl-bad.png", dir);
    snprintf(args, sizeof(args), "relight %s -o %s --view keyframe:999", face, path);
    CHECK(run(args) == 1 && !exists(path) && output_contains("keyframe:999"));
    snprintf(args, sizeof(args), "relight %s -o %s --specular-scale teeth=2", face, path);
    CHECK(run(args) == 1 && !exists(path) && output_contains("teeth"));
    free(def);
}

/* The same fit on one solver thread: bit-identical maps and lighting (the solvers' sums are cut by the data). */
static void check_thread_independence(const char *face)
{
    char args[2048], one[600];
    snprintf(one, sizeof(one), "%s.1", face);
    snprintf(args, sizeof(args), "fit %s/s.spcap -o %s --face generic --keyframes 8 --heldout 2 --no-progress "
                                 "--threads 1", dir, one);
    CHECK_MSG(run(args) == 0, "fit --threads 1 failed");
    static const char *const files[] = { "albedo.f32", "displacement.f32", "env.f32", "cameras.json" };
    for (size_t i = 0; i < sizeof(files) / sizeof(files[0]); i++) {
        char a[700], b[700];
        snprintf(a, sizeof(a), "%s/%s", face, files[i]);
        snprintf(b, sizeof(b), "%s/%s", one, files[i]);
        CHECK_MSG(same_bytes(a, b), "%s differs between 1 solver thread and the default", files[i]);
    }
}

/*
 * The default map size is chosen on the held-out frames (texture_size 0): the manifest says which rows won
 * and by how much, and keeping the default rows leaves the fit exactly as a fit asked for them.
 */
static void check_texture_choice(const char *face, const char *manifest)
{
    const char *note = strstr(manifest, "\"rows_chosen\":\"");
    CHECK_MSG(note != NULL, "the manifest does not say how the texture rows were chosen");
    int rows = 0, other = 0;
    double won = NAN, lost = NAN;
    if (!note || sscanf(note, "\"rows_chosen\":\"%d texture rows: held-out PSNR %lf dB against %lf dB with %d rows",
                        &rows, &won, &lost, &other) != 4)
        return;
    CHECK_MSG(won >= lost, "%d rows were kept with %.2f dB against %.2f dB", rows, won, lost);
    CHECK_MSG((strstr(manifest, "\"part\":\"texture detail\"") != NULL) == (rows < other),
              "left_out must list the texture detail exactly when the coarser map won");
    if (rows < other)
        return; /* a fresh fit at the coarse rows is not the chosen map (it starts from the finer one) */
    char args[2048], fixed[600], a[700], b[700];
    snprintf(fixed, sizeof(fixed), "%s.fixed", face);
    snprintf(args, sizeof(args), "fit %s/s.spcap -o %s --face generic --keyframes 8 --heldout 2 --no-progress "
                                 "--texture %d", dir, fixed, rows);
    CHECK_MSG(run(args) == 0, "fit --texture %d failed", rows);
    snprintf(a, sizeof(a), "%s/albedo.f32", face);
    snprintf(b, sizeof(b), "%s/albedo.f32", fixed);
    CHECK_MSG(same_bytes(a, b), "the chosen %d-row map differs from a fit asked for %d rows", rows, rows);
}

static void synth_fit(void)
{
    char args[2048], face[512];
    snprintf(args, sizeof(args),
             "synth selfie -o %s/s.spcap --face generic --width 160 --height 160 --turn-seconds 4 --still 1 "
             "--supersample 1 --shadow-size 512 --relit 0 --novel 0 --fps 20",
             dir);
    int code = run(args);
    CHECK_MSG(code == 0, "synth selfie: exit %d", code);
    if (code) {
        show_output();
        return;
    }
    snprintf(face, sizeof(face), "%s/s.face", dir);
    snprintf(args, sizeof(args), "fit %s/s.spcap -o %s --face generic --keyframes 8 --heldout 2 --no-progress "
                                 "--report %s/rep", dir, face, dir);
    code = run(args);
    CHECK_MSG(code == 0, "fit: exit %d", code);
    show_output();
    char path[700];
    snprintf(path, sizeof(path), "%s/manifest.json", face);
    CHECK(exists(path));
    snprintf(path, sizeof(path), "%s/rep.svg", dir);
    CHECK(exists(path));
    char buf[8192] = "";
    snprintf(path, sizeof(path), "%s/out.txt", dir);
    FILE *f = fopen(path, "r");
    size_t n = f ? fread(buf, 1, sizeof(buf) - 1, f) : 0;
    if (f)
        fclose(f);
    buf[n] = 0;
    const char *p = strstr(buf, "sun direction error ");
    double err = p ? strtod(p + strlen("sun direction error "), NULL) : (double)NAN;
    /*
     * This capture is deliberately small (8 keyframes of 160 px over a 4 s turn), so its error
     * is a few degrees and moves with unrelated changes to the renderer and synthesiser
     * (measured 3.1 to 5.4 deg); the 3 deg target is checked by bench_fit on full captures.
     * 8 deg still fails for a broken search or world alignment (a guess is tens of degrees off).
     */
    CHECK_MSG(err < 8.0, "sun direction error %.2f deg", err);
    p = strstr(buf, "train PSNR ");
    double train = p ? strtod(p + strlen("train PSNR "), NULL) : (double)NAN;
    CHECK_MSG(train > 25.0, "training PSNR %.2f dB", train);
    check_report(err);
    snprintf(path, sizeof(path), "%s/manifest.json", face);
    f = fopen(path, "r");
    n = f ? fread(buf, 1, sizeof(buf) - 1, f) : 0;
    if (f)
        fclose(f);
    buf[n] = 0;
    /* left_out lists the displacement map exactly when it stayed zero (refinement reverted or off) */
    CHECK_MSG(strstr(buf, "\"left_out\":[") != NULL, "manifest without left_out");
    CHECK_MSG(strstr(buf, "\"sun_from_clock\":{\"unavailable\":\"the capture carries no utc_start") != NULL,
              "manifest does not say why there is no sun from the clock");
    int listed = strstr(buf, "\"part\":\"displacement\"") != NULL;
    int flat = displacement_flat(face);
    CHECK_MSG(flat >= 0 && listed == flat, "displacement listed %d, all zero %d", listed, flat);
    check_left_out_reader(face, buf, flat);
    check_texture_choice(face, buf);
    check_thread_independence(face);
    snprintf(args, sizeof(args), "relight %s --sun 30,40 -o %s/relit.png", face, dir);
    CHECK(run(args) == 0);
    snprintf(path, sizeof(path), "%s/relit.png", dir);
    CHECK(exists(path));
    snprintf(args, sizeof(args), "relight %s/nothing --sun 30,40 -o %s/x.png", dir, dir);
    CHECK(run(args) == 2);
    check_relight_views(face);
    snprintf(args, sizeof(args), "fit %s/s.spcap -o %s --face generic", dir, face); /* exists: refuse */
    CHECK(run(args) == 1);
}

/* A JSON file, parsed; NULL (with a failed check) when unreadable. */
static sp_json *read_json(const char *path)
{
    void *buf = NULL;
    size_t n = 0;
    sp_json *root = NULL;
    char err[160];
    CHECK_MSG(sp_read_whole_file(path, 64u << 20, &buf, &n) == 0 && sp_json_parse(buf, n, &root, err, sizeof(err)) == 0,
              "%s unreadable", path);
    free(buf);
    return root;
}

/*
 * The sun from the clock: a synthetic capture placed in Paris at 10:00 UTC on 21 June (sun from the
 * ephemeris, magnetometer on) must give the fit the truth's sun as its clock sun, and the photometric sun
 * must agree with it; options that cannot work are refused.
 */
static void clock_fit(void)
{
    char args[2048], path[700];
    const char *synth = "synth selfie --face generic --width 160 --height 160 --turn-seconds 4 --still 1 "
                        "--supersample 1 --relit 0 --novel 0 --fps 20";
    snprintf(args, sizeof(args), "%s -o %s/bad.spcap --utc 2024-06-21T10:00:00Z", synth, dir); /* no place */
    CHECK(run(args) == 1 && output_contains("--location"));
    snprintf(args, sizeof(args), "%s -o %s/bad.spcap --utc 2024-06-21T10:00:00 --location 48.85,2.35", synth, dir);
    CHECK(run(args) == 1 && output_contains("--utc"));
    snprintf(args, sizeof(args), "%s -o %s/bad.spcap --utc 2024-06-21T23:00:00Z --location 48.85,2.35", synth, dir);
    CHECK(run(args) == 2 && output_contains("below the horizon")); /* night in Paris */
    snprintf(path, sizeof(path), "%s/bad.spcap", dir);
    CHECK(!exists(path));
    snprintf(args, sizeof(args), "%s -o %s/c.spcap --utc 2024-06-21T10:00:00Z --location 48.85,2.35", synth, dir);
    int code = run(args);
    CHECK_MSG(code == 0, "synth selfie: exit %d", code);
    if (code) {
        show_output();
        return;
    }
    snprintf(args, sizeof(args), "fit %s/c.spcap -o %s/c.face --face generic --keyframes 8 --heldout 2 --no-progress",
             dir, dir);
    code = run(args);
    CHECK_MSG(code == 0, "fit: exit %d", code);
    if (code) {
        show_output();
        return;
    }
    snprintf(path, sizeof(path), "%s/c.truth/truth.json", dir);
    sp_json *truth = read_json(path);
    snprintf(path, sizeof(path), "%s/c.face/manifest.json", dir);
    sp_json *man = read_json(path);
    const sp_json *clock = sp_json_get(sp_json_get(man, "lighting"), "sun_from_clock");
    double want[3], got[3] = { NAN, NAN, NAN }, angle = NAN;
    int ok = sp_json_numbers(sp_json_get(sp_json_get(sp_json_get(truth, "lighting"), "sun"), "direction_world"),
                             want, 3) == 3;
    ok = ok && sp_json_numbers(sp_json_get(clock, "direction_world"), got, 3) == 3;
    angle = sp_json_number(sp_json_get(clock, "angle_to_fitted_deg"), NAN);
    CHECK_MSG(ok, "truth sun or manifest lighting.sun_from_clock missing");
    double dot = want[0] * got[0] + want[1] * got[1] + want[2] * got[2];
    /* the synthesiser takes the sun at the middle of its IMU span, the fit at the middle of its frames: 0.01 deg */
    CHECK_MSG(dot > cos(0.05 * M_PI / 180.0), "clock sun (%g %g %g) against the truth (%g %g %g)", got[0], got[1],
              got[2], want[0], want[1], want[2]);
    CHECK_MSG(angle < 8.0, "photometric sun %.2f deg from the clock's", angle); /* same bound as synth_fit's */
    sp_json_free(truth);
    sp_json_free(man);
}

int main(int argc, char **argv)
{
    if (argc < 2)
        SKIP("usage: test_fit SUNPROBE [synth]");
    sunprobe = argv[1];
    snprintf(dir, sizeof(dir), "%s/sp-fit.XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    if (!mkdtemp(dir))
        SKIP("cannot create a temporary directory");
    if (argc > 2 && !strcmp(argv[2], "synth")) {
        synth_fit();
    } else if (argc > 2 && !strcmp(argv[2], "clock")) {
        clock_fit();
    } else {
        bad_input("noimu", 12, CONTENT_NOISE, 0, "no IMU");
        bad_input("lateimu", 12, CONTENT_NOISE, 2, "never overlap in time");
        bad_input("oneframe", 1, CONTENT_NOISE, 1, "no camera orientation");
        bad_input("sametime", 12, CONTENT_NOISE, 3, "carry the same timestamp"); /* it said ENOSPC once */
        bad_input("black", 12, CONTENT_BLACK, 1, "12 of 12 frames are too dark");
        bad_input("noface", 12, CONTENT_NOISE, 1, "no face");
    }
    char cmd[300];
    snprintf(cmd, sizeof(cmd), "rm -rf %s", dir);
    if (system(cmd) == -1)
        fprintf(stderr, "cannot remove %s\n", dir);
    return check_exit();
}
