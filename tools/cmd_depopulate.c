/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe depopulate INPUT -o OUT.png`: removes people (and other objects)
 * with their cast and contact shadows from one street image. Objects come
 * from a probe directory's clean plate (the probe's segmentation; the plate
 * fills the holes) or, for a lone image, from user boxes and OpenCV's HOG
 * people detector; then the holes are filled by exemplar inpainting
 * (pipeline/probe/DEPOPULATE.md). Writes the image, a JSON report and a
 * debug image with the masks.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd.h"
#include "common/file_set.h"
#include "common/file_util.h"
#include "common/json.h"
#include "export/png.h"
#include "export/png_read.h"
#include "export/probe_dir.h"
#include "pipeline/probe/depopulate.h"
#include "pipeline/probe/opencv_probe_shim.h"
#include "sp_config.h"
#include "sunprobe/sp_solar.h"

#define MAX_BOXES 64
#define MAX_OBJECTS 128
#define MAX_KEEP 64

typedef struct depop_args {
    const char *in, *out, *probe, *report, *debug;
    int boxes[MAX_BOXES][4]; /* x0, y0, x1, y1 */
    unsigned n_boxes;
    double keep[2 * MAX_KEEP];
    unsigned n_keep;
    int detector; /* 0 none, 1 hog */
    sp_depop_camera cam;
    int have_cam;
    const char *utc;
    double lat, lon, heading;
    int have_location, have_heading;
    sp_depop_settings ds;
    int quiet;
} depop_args;

typedef struct image {
    uint8_t *rgb;
    uint32_t w, h;
} image;

static void usage(FILE *out)
{
    fprintf(out, "usage: sunprobe depopulate INPUT.png|.jpg -o OUT.png [options]\n\n"
                 "Removes people and other objects with their shadows from one street image and fills the holes.\n"
                 "With --probe, objects come from the probe's segmentation against its clean plate, which fills\n"
                 "them; otherwise from --box and OpenCV's HOG people detector, filled by exemplar inpainting.\n\n"
                 "options:\n"
                 "      --probe DIR       a probe directory of the same scene (sunprobe probe)\n"
                 "      --box X,Y,W,H     an object to remove (repeatable)\n"
                 "      --keep X,Y        keep the object whose box holds this point (repeatable)\n"
                 "      --detector hog|none  single-image people detector (default hog where OpenCV is built,\n"
                 "                        else none)\n"
                 "      --sun-dir DX,DY   image direction shadows fall in from the feet (default: found per object)\n"
                 "      --no-shadows      remove the objects only, not their shadows\n"
                 "      --camera F,CX,CY,PITCH  focal length and principal point (pixels) and the downward pitch\n"
                 "                        (degrees) for the sun from the shadows (default: assumed, 60 deg wide,\n"
                 "                        centred, 15 deg down)\n"
                 "      --utc ISO --location LAT,LON --heading DEG  the sun from the clock as well (heading: the\n"
                 "                        view's compass bearing), and how far the two disagree\n"
                 "      --report FILE     the JSON report (default OUT without .png + .json)\n"
                 "      --debug FILE      the input with the masks drawn (default OUT without .png + .debug.png)\n"
                 "  -o, --output PNG      the emptied image\n"
                 "  -q, --quiet           no summary\n");
}

static int bad(const char *opt, const char *v)
{
    fprintf(stderr, "sunprobe depopulate: bad %s: '%s'\n", opt, v);
    return SP_EXIT_USAGE;
}

enum { OPT_PROBE = 256, OPT_BOX, OPT_KEEP, OPT_DETECTOR, OPT_SUN, OPT_NO_SHADOWS, OPT_REPORT, OPT_DEBUG, OPT_CAMERA,
       OPT_UTC, OPT_LOCATION, OPT_HEADING };

static int parse_option(int c, depop_args *a)
{
    double v[4];
    switch (c) {
    case OPT_PROBE: a->probe = optarg; return 0;
    case OPT_BOX:
        if (a->n_boxes == MAX_BOXES || sp_opt_numbers(optarg, v, 4) || v[2] < 1 || v[3] < 1 || v[0] < 0 || v[1] < 0 ||
            v[0] + v[2] > 1e5 || v[1] + v[3] > 1e5)
            return bad("--box (X,Y,W,H, W and H at least 1, at most 64 boxes)", optarg);
        a->boxes[a->n_boxes][0] = (int)v[0], a->boxes[a->n_boxes][1] = (int)v[1];
        a->boxes[a->n_boxes][2] = (int)(v[0] + v[2]) - 1, a->boxes[a->n_boxes][3] = (int)(v[1] + v[3]) - 1;
        a->n_boxes++;
        return 0;
    case OPT_KEEP:
        if (a->n_keep == MAX_KEEP || sp_opt_numbers(optarg, a->keep + 2 * a->n_keep, 2))
            return bad("--keep (X,Y, at most 64)", optarg);
        a->n_keep++;
        return 0;
    case OPT_DETECTOR: {
        static const char *const names[] = { "none", "hog" };
        return sp_opt_choice("depopulate", "detector", optarg, names, 2, &a->detector) ? SP_EXIT_USAGE : 0;
    }
    case OPT_SUN:
        if (sp_opt_numbers(optarg, v, 2) || hypot(v[0], v[1]) < 1e-9)
            return bad("--sun-dir (DX,DY, not both 0)", optarg);
        a->ds.sun_dx = v[0], a->ds.sun_dy = v[1];
        return 0;
    case OPT_NO_SHADOWS: a->ds.shadows = 0; return 0;
    case OPT_CAMERA:
        if (sp_opt_numbers(optarg, v, 4) || !(v[0] > 0 && v[0] < 1e6) || !(v[3] >= 0 && v[3] < 89))
            return bad("--camera (F,CX,CY,PITCH: F > 0, pitch 0..89 degrees)", optarg);
        a->cam = (sp_depop_camera){ v[0], v[1], v[2], v[3] }, a->have_cam = 1;
        return 0;
    case OPT_UTC: {
        double t;
        if (sp_utc_parse(optarg, &t))
            return bad("--utc (ISO 8601 with a zone, e.g. 2026-06-21T12:00:00Z)", optarg);
        a->utc = optarg;
        return 0;
    }
    case OPT_LOCATION:
        if (sp_opt_numbers(optarg, v, 2) || fabs(v[0]) > 90 || fabs(v[1]) > 360)
            return bad("--location (LAT,LON in degrees)", optarg);
        a->lat = v[0], a->lon = v[1], a->have_location = 1;
        return 0;
    case OPT_HEADING:
        if (sp_opt_numbers(optarg, v, 1) || fabs(v[0]) > 360)
            return bad("--heading (degrees clockwise from true north)", optarg);
        a->heading = v[0], a->have_heading = 1;
        return 0;
    case OPT_REPORT: a->report = optarg; return 0;
    case OPT_DEBUG: a->debug = optarg; return 0;
    case 'o': a->out = optarg; return 0;
    case 'q': a->quiet = 1; return 0;
    case 'h': usage(stdout); return -1;
    default: usage(stderr); return SP_EXIT_USAGE;
    }
}

static int parse_args(int argc, char **argv, depop_args *a)
{
    static const struct option opts[] = {
        { "probe", required_argument, NULL, OPT_PROBE },       { "box", required_argument, NULL, OPT_BOX },
        { "keep", required_argument, NULL, OPT_KEEP },         { "detector", required_argument, NULL, OPT_DETECTOR },
        { "sun-dir", required_argument, NULL, OPT_SUN },       { "no-shadows", no_argument, NULL, OPT_NO_SHADOWS },
        { "report", required_argument, NULL, OPT_REPORT },     { "debug", required_argument, NULL, OPT_DEBUG },
        { "camera", required_argument, NULL, OPT_CAMERA },     { "utc", required_argument, NULL, OPT_UTC },
        { "location", required_argument, NULL, OPT_LOCATION }, { "heading", required_argument, NULL, OPT_HEADING },
        { "output", required_argument, NULL, 'o' },            { "quiet", no_argument, NULL, 'q' },
        { "help", no_argument, NULL, 'h' },                    { 0 },
    };
    optind = 0;
    int c, code;
    while ((c = getopt_long(argc, argv, "o:qh", opts, NULL)) != -1)
        if ((code = parse_option(c, a)))
            return code;
    if (optind != argc - 1 || !a->out) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    a->in = argv[optind];
    if ((a->utc || a->have_location || a->have_heading) && !(a->utc && a->have_location && a->have_heading)) {
        fprintf(stderr, "sunprobe depopulate: the sun from the clock needs --utc, --location and --heading together\n");
        return SP_EXIT_USAGE;
    }
    return 0;
}

/* The derived file names: OUT without ".png" + suffix. */
static char *derived(const char *out, const char *suffix)
{
    size_t n = strlen(out);
    if (n > 4 && !strcmp(out + n - 4, ".png"))
        n -= 4;
    char *p = malloc(n + strlen(suffix) + 1);
    if (p)
        memcpy(p, out, n), strcpy(p + n, suffix);
    return p;
}

typedef struct job {
    image im;
    sp_probe_dir pd;
    int have_probe;
    uint8_t *mask, *result, *debug;
    sp_depop_object obj[MAX_OBJECTS];
    const char *origin[MAX_OBJECTS]; /* "box", "hog", "probe" */
    size_t n, kept, hog_found;
    const char *source, *fill;
    sp_inpaint_report ir;
} job;

static int add_object(job *j, int x0, int y0, int x1, int y1, const char *origin)
{
    if (j->n == MAX_OBJECTS)
        return 0; /* the report says how many were found */
    j->obj[j->n] = (sp_depop_object){ .x0 = x0, .y0 = y0, .x1 = x1, .y1 = y1 };
    j->origin[j->n++] = origin;
    return 1;
}

/* Whether box b is mostly inside an object already listed (a HOG hit on a user's box). */
static int covered(const job *j, const int *b)
{
    for (size_t i = 0; i < j->n; i++) {
        const sp_depop_object *o = &j->obj[i];
        int w = (b[2] < o->x1 ? b[2] : o->x1) - (b[0] > o->x0 ? b[0] : o->x0) + 1;
        int h = (b[3] < o->y1 ? b[3] : o->y1) - (b[1] > o->y0 ? b[1] : o->y0) + 1;
        if (w > 0 && h > 0 && 2.0 * w * h > (double)(b[2] - b[0] + 1) * (b[3] - b[1] + 1))
            return 1;
    }
    return 0;
}

static int user_boxes(const depop_args *a, job *j)
{
    for (unsigned i = 0; i < a->n_boxes; i++) {
        const int *b = a->boxes[i];
        if (b[2] >= (int)j->im.w || b[3] >= (int)j->im.h) {
            fprintf(stderr, "sunprobe depopulate: --box %d,%d,%d,%d reaches outside the %ux%u image %s\n", b[0],
                    b[1], b[2] - b[0] + 1, b[3] - b[1] + 1, j->im.w, j->im.h, a->in);
            return SP_EXIT_USAGE;
        }
        if (sp_depop_keeps(a->keep, a->n_keep, b[0], b[1], b[2], b[3]))
            j->kept++;
        else
            add_object(j, b[0], b[1], b[2], b[3], "box");
    }
    return 0;
}

static int hog_people(const depop_args *a, job *j)
{
    int boxes[4 * MAX_OBJECTS];
    unsigned n = 0;
#if HAVE_OPENCV
    sp_cv_hog *hog = NULL;
    double up = j->im.h < 480 ? 2.0 : 1.0; /* people under the 128-px window */
    int ret = sp_cv_hog_open(&hog);
    if (!ret)
        ret = sp_cv_hog_detect(hog, j->im.rgb, j->im.w, j->im.h, j->im.w * 3, up, boxes, MAX_OBJECTS, &n);
    sp_cv_hog_close(&hog);
    if (ret)
        return sp_cmd_fail("depopulate", ret, "HOG people detector");
#else
    (void)boxes;
    fprintf(stderr, "sunprobe depopulate: --detector hog needs OpenCV (-Dopencv=enabled); give --box and "
                    "--detector none\n");
    return SP_EXIT_DISABLED;
#endif
    j->hog_found = n;
    for (unsigned i = 0; i < n && i < MAX_OBJECTS; i++) {
        const int *b = boxes + 4 * i;
        if (sp_depop_keeps(a->keep, a->n_keep, b[0], b[1], b[2], b[3]))
            j->kept++;
        else if (!covered(j, b))
            add_object(j, b[0], b[1], b[2], b[3], "hog");
    }
    return 0;
}

static int find_objects(const depop_args *a, job *j)
{
    size_t np = (size_t)j->im.w * j->im.h;
    int code = user_boxes(a, j);
    if (code)
        return code;
    if (j->have_probe) {
        size_t first = j->n, n = 0, kept = 0;
        int ret = sp_depop_from_plate(j->im.rgb, j->pd.clean_plate, j->im.w, j->im.h, &j->pd.plane, a->keep,
                                      a->n_keep, j->obj + first, MAX_OBJECTS - first, &n, &kept, j->mask);
        if (ret)
            return sp_cmd_fail("depopulate", ret, "segmenting against the clean plate");
        for (size_t i = first; i < first + n && i < MAX_OBJECTS; i++)
            j->origin[i] = "probe";
        j->n = first + n < MAX_OBJECTS ? first + n : MAX_OBJECTS;
        j->kept += kept;
        for (size_t i = 0; i < first; i++) /* user boxes: the whole box, its shadow is in the plate's segmentation */
            for (int y = j->obj[i].y0; y <= j->obj[i].y1; y++)
                memset(j->mask + (size_t)y * j->im.w + j->obj[i].x0, 1, (size_t)(j->obj[i].x1 - j->obj[i].x0 + 1));
        j->source = a->n_boxes ? "the probe's segmentation against its clean plate, and --box" :
                                 "the probe's segmentation against its clean plate";
        return 0;
    }
    if (a->detector == 1 && (code = hog_people(a, j)))
        return code;
    j->source = a->detector == 1 ? (a->n_boxes ? "--box and the HOG people detector" : "the HOG people detector")
                                 : "--box";
    (void)np;
    int ret = sp_depop_mask(j->im.rgb, j->im.w, j->im.h, j->im.w * 3, j->obj, j->n, &a->ds, j->mask);
    return ret ? sp_cmd_fail("depopulate", ret, "removal masks") : 0;
}

static int fill(job *j)
{
    size_t np = (size_t)j->im.w * j->im.h;
    memcpy(j->result, j->im.rgb, np * 3);
    if (j->have_probe) {
        for (size_t i = 0; i < np; i++)
            if (j->mask[i])
                memcpy(j->result + 3 * i, j->pd.clean_plate + 3 * i, 3);
        j->fill = "the probe's clean plate";
        return 0;
    }
    j->fill = "exemplar inpainting";
    int ret = sp_inpaint_exemplar(j->result, j->im.w, j->im.h, j->im.w * 3, j->mask, NULL, &j->ir);
    if (ret == SP_ENODATA)
        fprintf(stderr, "sunprobe depopulate: the objects cover the whole image: nothing is left to fill from\n");
    return ret ? sp_cmd_fail("depopulate", ret, "inpainting") : 0;
}

/* The input with object pixels tinted red, shadow pixels blue, and every box outlined in yellow. */
static void draw_debug(job *j)
{
    size_t np = (size_t)j->im.w * j->im.h;
    static const uint8_t tint[3][3] = { { 0, 0, 0 }, { 255, 0, 0 }, { 0, 80, 255 } };
    for (size_t i = 0; i < np; i++)
        for (int c = 0; c < 3; c++)
            j->debug[3 * i + c] = j->mask[i] ? (uint8_t)((j->im.rgb[3 * i + c] + tint[j->mask[i] > 1][c]) / 2)
                                             : j->im.rgb[3 * i + c];
    for (size_t k = 0; k < j->n; k++) {
        const sp_depop_object *o = &j->obj[k];
        for (int y = o->y0; y <= o->y1; y++)
            for (int x = o->x0; x <= o->x1; x++)
                if (y == o->y0 || y == o->y1 || x == o->x0 || x == o->x1)
                    memcpy(j->debug + 3 * ((size_t)y * j->im.w + x), (const uint8_t[3]){ 255, 230, 0 }, 3);
    }
}

/* The sun from the shadows (with the given or the assumed camera) and from the clock, as "sun": {...}. */
static void sun_json(const depop_args *a, const job *j, sp_strbuf *b)
{
    sp_depop_camera cam = a->cam;
    if (!a->have_cam) /* assumed: a 60-degree-wide view, centred, 15 degrees down */
        cam = (sp_depop_camera){ 0.5 * j->im.w / tan(30 * M_PI / 180), 0.5 * j->im.w, 0.5 * j->im.h, 15 };
    sp_depop_sun e = { 0 };
    int shadows = !j->have_probe && !sp_depop_sun_estimate(j->obj, j->n, &cam, &e) && e.found;
    sp_strbuf_printf(b, "\"sun\":{\"camera\":\"%s\",\"from_shadows\":", a->have_cam ? "given" : "assumed");
    if (shadows)
        sp_strbuf_printf(b, "{\"azimuth_deg\":%.2f,\"elevation_deg\":%.2f,\"shadows\":%u,\"azimuth_spread_deg\":%.2f,"
                            "\"elevation_spread_deg\":%.2f}", e.azimuth_deg, e.elevation_deg, e.used,
                         e.azimuth_spread_deg, e.elevation_spread_deg);
    else
        sp_strbuf_printf(b, "\"%s\"", j->have_probe ? "not estimated with --probe" : "no sun shadows");
    sp_strbuf_printf(b, ",\"from_clock\":");
    double t;
    sp_sun_position p;
    if (a->utc && !sp_utc_parse(a->utc, &t) && !sp_sun_position_at(t, a->lat, a->lon, &p)) {
        double az = fmod(p.azimuth_deg - a->heading + 540.0, 360.0) - 180.0;
        sp_strbuf_printf(b, "{\"azimuth_deg\":%.2f,\"elevation_deg\":%.2f}", az, p.elevation_deg);
        if (shadows) { /* the angle between the two directions */
            double r = M_PI / 180, c = sin(e.elevation_deg * r) * sin(p.elevation_deg * r) +
                                       cos(e.elevation_deg * r) * cos(p.elevation_deg * r) * cos((az - e.azimuth_deg) * r);
            sp_strbuf_printf(b, ",\"disagreement_deg\":%.2f", acos(c > 1 ? 1 : c < -1 ? -1 : c) / r);
        }
    } else {
        sp_strbuf_printf(b, "null");
    }
    sp_strbuf_printf(b, "}");
}

static int write_report(const depop_args *a, const job *j, const char *path)
{
    size_t np = (size_t)j->im.w * j->im.h, nobj = 0, nsh = 0;
    for (size_t i = 0; i < np; i++)
        nobj += j->mask[i] == 1, nsh += j->mask[i] == 2;
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"format\":\"sunprobe-depopulate\",\"version\":1,\"input\":");
    sp_strbuf_json_string(&b, a->in);
    sp_strbuf_printf(&b, ",\"width\":%u,\"height\":%u,\"objects_from\":", j->im.w, j->im.h);
    sp_strbuf_json_string(&b, j->source);
    sp_strbuf_printf(&b, ",\"filled_from\":");
    sp_strbuf_json_string(&b, j->fill);
    sp_strbuf_printf(&b, ",\"kept\":%zu,\"hog_detections\":%zu,\"object_pixels\":%zu,\"shadow_pixels\":%zu,"
                         "\"sun_dir_given\":", j->kept, j->hog_found, nobj, nsh);
    double sd[2] = { a->ds.sun_dx, a->ds.sun_dy };
    if (sd[0] != 0 || sd[1] != 0)
        sp_strbuf_json_numbers(&b, sd, 2);
    else
        sp_strbuf_printf(&b, "null");
    sp_strbuf_printf(&b, ",\"inpainted_patches\":%llu,", (unsigned long long)j->ir.patches);
    sun_json(a, j, &b);
    sp_strbuf_printf(&b, ",\"objects\":[");
    for (size_t k = 0; k < j->n; k++) {
        const sp_depop_object *o = &j->obj[k];
        double sh[3] = { o->shadow_dx, o->shadow_dy, o->shadow_len };
        sp_strbuf_printf(&b, "%s{\"from\":\"%s\",\"box\":[%d,%d,%d,%d],\"shadow_px\":%u,\"contact_px\":%u,"
                             "\"shadow_leak\":%s,\"shadow_offset_len\":", k ? "," : "", j->origin[k], o->x0, o->y0,
                         o->x1 - o->x0 + 1, o->y1 - o->y0 + 1, o->shadow_px, o->contact_px,
                         o->shadow_leak ? "true" : "false");
        sp_strbuf_json_numbers(&b, sh, 3);
        sp_strbuf_printf(&b, "}");
    }
    sp_strbuf_printf(&b, "]}\n");
    int ret = b.failed ? -ENOMEM : sp_write_whole_file_atomic(path, b.data, b.len);
    sp_strbuf_free(&b);
    return ret;
}

static int load_probe(const depop_args *a, job *j)
{
    int ret = sp_probe_dir_load(a->probe, &j->pd);
    if (ret)
        return sp_cmd_fail("depopulate", ret, a->probe);
    j->have_probe = 1;
    if (j->pd.width != j->im.w || j->pd.height != j->im.h) {
        fprintf(stderr, "sunprobe depopulate: %s is %ux%u, the probe %s %ux%u\n", a->in, j->im.w, j->im.h, a->probe,
                j->pd.width, j->pd.height);
        return SP_EXIT_BAD_INPUT;
    }
    return 0;
}

/* The image, its masks and its report as one file set: all three or, on any failure, the old ones as they were */
static int write_outputs(const depop_args *a, job *j)
{
    char *rep = a->report ? NULL : derived(a->out, ".json"), *dbg = a->debug ? NULL : derived(a->out, ".debug.png");
    const char *rp = a->report ? a->report : rep, *dp = a->debug ? a->debug : dbg, *tr, *td, *to;
    sp_file_set fs = { 0 };
    const char *what = "output names";
    int ret = rp && dp ? 0 : -ENOMEM;
    draw_debug(j);
    if (!ret && !(ret = sp_file_set_add(&fs, dp, &td)) && !(ret = sp_file_set_add(&fs, rp, &tr)))
        ret = sp_file_set_add(&fs, a->out, &to);
    if (!ret && (what = dp))
        ret = sp_png_write(td, j->debug, j->im.w, j->im.h, j->im.w * 3, 3);
    if (!ret && (what = rp))
        ret = write_report(a, j, tr);
    if (!ret && (what = a->out))
        ret = sp_png_write(to, j->result, j->im.w, j->im.h, j->im.w * 3, 3);
    if (!ret && sp_cmd_stop_signal) /* Ctrl-C: the old set stays */
        ret = -ECANCELED;
    if (!ret && (what = a->out))
        ret = sp_file_set_commit(&fs);
    sp_file_set_abort(&fs);
    int code = ret ? sp_cmd_fail("depopulate", ret, what) : 0;
    if (!ret && !a->quiet)
        printf("%s: %zu object(s) removed (from %s), %zu kept; filled from %s; report %s, masks %s\n", a->out, j->n,
               j->source, j->kept, j->fill, rp, dp);
    free(rep), free(dbg);
    return code;
}

static int depopulate(const depop_args *a)
{
    job j = { 0 };
    int code = 0, ret = sp_image_read_rgb8(a->in, &j.im.rgb, &j.im.w, &j.im.h);
    if (ret)
        return sp_cmd_fail("depopulate", ret, a->in);
    size_t np = (size_t)j.im.w * j.im.h;
    j.mask = calloc(np, 1), j.result = malloc(np * 3), j.debug = malloc(np * 3);
    if (!j.mask || !j.result || !j.debug)
        code = sp_cmd_fail("depopulate", -ENOMEM, "image buffers");
    if (!code && a->probe)
        code = load_probe(a, &j);
    if (!code)
        code = find_objects(a, &j);
    if (!code && j.n == 0) {
        fprintf(stderr, "sunprobe depopulate: nothing to remove in %s (objects from %s; %zu kept)\n", a->in,
                j.source, j.kept);
        code = SP_EXIT_BAD_INPUT;
    }
    if (!code)
        code = fill(&j);
    if (!code)
        code = write_outputs(a, &j);
    free(j.im.rgb), free(j.mask), free(j.result), free(j.debug);
    if (j.have_probe)
        sp_probe_dir_free(&j.pd);
    return code;
}

int sp_cmd_depopulate(int argc, char **argv)
{
    depop_args a = { .detector = HAVE_OPENCV ? 1 : 0 };
    sp_depop_default_settings(&a.ds);
    int code = parse_args(argc, argv, &a);
    if (code)
        return code < 0 ? SP_EXIT_OK : code;
    sp_cmd_signals sig; /* Ctrl-C: the outputs are not put in place, 128+N */
    sp_cmd_catch_signals(&sig);
    code = depopulate(&a);
    sp_cmd_restore_signals(&sig);
    return code;
}
