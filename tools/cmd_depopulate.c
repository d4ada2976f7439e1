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
#include "depop_job.h"
#include "sunprobe/sp_solar.h"

typedef struct depop_args {
    depop_input in;
    const char *out, *report, *debug;
    sp_depop_camera cam;
    int have_cam;
    const char *utc;
    double lat, lon, heading;
    int have_location, have_heading;
    sp_depop_sun clock; /* the sun from the clock relative to the camera, for the masks (in.ds.clock_sun) */
    int quiet;
} depop_args;

static void usage(FILE *out)
{
    fprintf(out,
            "usage: sunprobe depopulate INPUT.png|.jpg -o OUT.png [options]\n\n"
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
            "      --whole-boxes     remove each box whole (default: its object's silhouette, found by\n"
            "                        OpenCV's GrabCut, and the box's lowest fifth)\n"
            "      --no-shadows      remove the objects only, not their shadows\n"
            "      --camera F,CX,CY,PITCH  focal length and principal point (pixels) and the downward pitch\n"
            "                        (degrees) for the sun from the shadows (default: assumed, 60 deg wide,\n"
            "                        centred, 15 deg down)\n"
            "      --utc ISO --location LAT,LON --heading DEG  the sun from the clock as well (heading: the\n"
            "                        view's compass bearing), and how far the two disagree; the masks\n"
            "                        use it where no closed shadow tells the sun\n"
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

enum {
    OPT_PROBE = 256,
    OPT_BOX,
    OPT_KEEP,
    OPT_DETECTOR,
    OPT_WHOLE_BOXES,
    OPT_SUN,
    OPT_NO_SHADOWS,
    OPT_REPORT,
    OPT_DEBUG,
    OPT_CAMERA,
    OPT_UTC,
    OPT_LOCATION,
    OPT_HEADING
};

static int parse_option(int c, const char *name, depop_args *a)
{
    static const double location_lo[2] = { -90, -360 }, location_hi[2] = { 90, 360 };
    double v[4];
    if (c >= OPT_PROBE && c <= OPT_NO_SHADOWS)
        return depop_input_option("depopulate", name, optarg, &a->in);
    switch (c) {
    case OPT_CAMERA:
        a->have_cam = 1, a->in.ds.camera = &a->cam; /* the masks search the one sun through it too */
        return depop_camera_option("depopulate", optarg, &a->cam);
    case OPT_UTC: {
        double t;
        if (sp_utc_parse(optarg, &t))
            return bad("--utc (ISO 8601 with a zone, e.g. 2026-06-21T12:00:00Z)", optarg);
        a->utc = optarg;
        return 0;
    }
    case OPT_LOCATION:
        if (sp_opt_list("depopulate", name, optarg, 2, location_lo, location_hi, v,
                        "LAT,LON in degrees, latitude -90..90, longitude -360..360"))
            return SP_EXIT_USAGE;
        a->lat = v[0], a->lon = v[1], a->have_location = 1;
        return 0;
    case OPT_HEADING: /* degrees clockwise from true north */
        if (sp_opt_double("depopulate", name, optarg, -360, 360, &a->heading))
            return SP_EXIT_USAGE;
        a->have_heading = 1;
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
        { "probe", required_argument, NULL, OPT_PROBE },
        { "box", required_argument, NULL, OPT_BOX },
        { "keep", required_argument, NULL, OPT_KEEP },
        { "detector", required_argument, NULL, OPT_DETECTOR },
        { "sun-dir", required_argument, NULL, OPT_SUN },
        { "no-shadows", no_argument, NULL, OPT_NO_SHADOWS },
        { "whole-boxes", no_argument, NULL, OPT_WHOLE_BOXES },
        { "report", required_argument, NULL, OPT_REPORT },
        { "debug", required_argument, NULL, OPT_DEBUG },
        { "camera", required_argument, NULL, OPT_CAMERA },
        { "utc", required_argument, NULL, OPT_UTC },
        { "location", required_argument, NULL, OPT_LOCATION },
        { "heading", required_argument, NULL, OPT_HEADING },
        { "output", required_argument, NULL, 'o' },
        { "quiet", no_argument, NULL, 'q' },
        { "help", no_argument, NULL, 'h' },
        { 0 },
    };
    optind = 0;
    int c, code, li = -1;
    while ((li = -1, c = getopt_long(argc, argv, "o:qh", opts, &li)) != -1)
        if ((code = parse_option(c, li >= 0 ? opts[li].name : "", a)))
            return code;
    if (optind != argc - 1 || !a->out) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    a->in.in = argv[optind];
    if ((a->utc || a->have_location || a->have_heading) && !(a->utc && a->have_location && a->have_heading)) {
        fprintf(stderr, "sunprobe depopulate: the sun from the clock needs --utc, --location and --heading together\n");
        return SP_EXIT_USAGE;
    }
    double t;
    sp_sun_position p;
    if (a->utc && !sp_utc_parse(a->utc, &t) && !sp_sun_position_at(t, a->lat, a->lon, &p)) {
        a->clock = (sp_depop_sun){ .found = 1,
                                   .closed = 1,
                                   .azimuth_deg = fmod(p.azimuth_deg - a->heading + 540.0, 360.0) - 180.0,
                                   .elevation_deg = p.elevation_deg };
        a->in.ds.clock_sun = &a->clock; /* the masks use it where no closed shadow tells the sun */
    }
    return 0;
}

/* The input with object pixels tinted red, shadow pixels blue, and every box outlined in yellow. */
static void draw_debug(const depop_job *j, uint8_t *debug)
{
    size_t np = (size_t)j->w * j->h;
    static const uint8_t tint[3][3] = { { 0, 0, 0 }, { 255, 0, 0 }, { 0, 80, 255 } };
    for (size_t i = 0; i < np; i++)
        for (int c = 0; c < 3; c++)
            debug[3 * i + c] = j->mask[i] ? (uint8_t)((j->rgb[3 * i + c] + tint[j->mask[i] > 1][c]) / 2)
                                             : j->rgb[3 * i + c];
    for (size_t k = 0; k < j->n; k++) {
        const sp_depop_object *o = &j->obj[k];
        for (int y = o->y0; y <= o->y1; y++)
            for (int x = o->x0; x <= o->x1; x++)
                if (y == o->y0 || y == o->y1 || x == o->x0 || x == o->x1)
                    memcpy(debug + 3 * ((size_t)y * j->w + x), (const uint8_t[3]){ 255, 230, 0 }, 3);
    }
}

/* The sun from the shadows (with the given or the assumed camera) and from the clock, as "sun": {...}. */
static void sun_json(const depop_args *a, const depop_job *j, sp_strbuf *b)
{
    sp_depop_sun e = { 0 };
    int shadows = !j->have_probe && !sp_depop_sun_estimate(j->obj, j->n, &j->cam, &e) && e.found;
    sp_strbuf_printf(b, "\"sun\":{\"camera\":\"%s\",\"from_shadows\":", a->have_cam ? "given" : "assumed");
    if (shadows)
        sp_strbuf_printf(b,
                         "{\"azimuth_deg\":%.2f,\"elevation_deg\":%.2f,\"shadows\":%u,\"azimuth_spread_deg\":%.2f,"
                         "\"elevation_spread_deg\":%.2f,\"closed\":%s}",
                         e.azimuth_deg, e.elevation_deg, e.used, e.azimuth_spread_deg, e.elevation_spread_deg,
                         e.closed ? "true" : "false");
    else
        sp_strbuf_printf(b, "\"%s\"", j->have_probe ? "not estimated with --probe" : "no sun shadows");
    sp_strbuf_printf(b, ",\"from_clock\":");
    if (a->in.ds.clock_sun) {
        double az = a->clock.azimuth_deg, el = a->clock.elevation_deg;
        sp_strbuf_printf(b, "{\"azimuth_deg\":%.2f,\"elevation_deg\":%.2f}", az, el);
        if (shadows) { /* the angle between the two directions */
            double r = M_PI / 180,
                   c = sin(e.elevation_deg * r) * sin(el * r) +
                cos(e.elevation_deg * r) * cos(el * r) * cos((az - e.azimuth_deg) * r);
            sp_strbuf_printf(b, ",\"disagreement_deg\":%.2f", acos(c > 1 ? 1 : c < -1 ? -1 : c) / r);
        }
    } else {
        sp_strbuf_printf(b, "null");
    }
    sp_strbuf_printf(b, "}");
}

static int write_report(const depop_args *a, const depop_job *j, const char *path)
{
    size_t np = (size_t)j->w * j->h, nobj = 0, nsh = 0;
    for (size_t i = 0; i < np; i++)
        nobj += j->mask[i] == 1, nsh += j->mask[i] == 2;
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"format\":\"sunprobe-depopulate\",\"version\":1,\"input\":");
    sp_strbuf_json_string(&b, a->in.in);
    sp_strbuf_printf(&b, ",\"width\":%u,\"height\":%u,\"objects_from\":", j->w, j->h);
    sp_strbuf_json_string(&b, j->source);
    sp_strbuf_printf(&b, ",\"filled_from\":");
    sp_strbuf_json_string(&b, j->fill);
    sp_strbuf_printf(&b,
                     ",\"kept\":%zu,\"hog_detections\":%zu,\"silhouettes\":%zu,\"object_pixels\":%zu,"
                     "\"shadow_pixels\":%zu,\"sun_dir_given\":",
                     j->kept, j->hog_found, j->segmented, nobj, nsh);
    double sd[2] = { a->in.ds.sun_dx, a->in.ds.sun_dy };
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
        sp_strbuf_printf(&b, ",\"shadow_closed\":%s,\"shadow_strip_px\":%u,\"shadow_thin\":%s}",
                         sp_depop_closed_shadow(o) ? "true" : "false", o->strip_px, o->shadow_thin ? "true" : "false");
    }
    sp_strbuf_printf(&b, "]}\n");
    int ret = b.failed ? -ENOMEM : sp_write_whole_file_atomic(path, b.data, b.len);
    sp_strbuf_free(&b);
    return ret;
}

/* The image, its masks and its report as one file set: all three or, on any failure, the old ones as they were */
static int write_outputs(const depop_args *a, depop_job *j)
{
    char *rep = a->report ? NULL : depop_derived_name(a->out, ".json"), *dbg = a->debug ? NULL : depop_derived_name(a->out, ".debug.png");
    const char *rp = a->report ? a->report : rep, *dp = a->debug ? a->debug : dbg, *tr, *td, *to;
    sp_file_set fs = { 0 };
    const char *what = "output names";
    int ret = rp && dp ? 0 : -ENOMEM;
    uint8_t *debug = malloc((size_t)j->w * j->h * 3);
    ret = ret ? ret : debug ? 0 : -ENOMEM;
    if (!ret)
        draw_debug(j, debug);
    if (!ret && !(ret = sp_file_set_add(&fs, dp, &td)) && !(ret = sp_file_set_add(&fs, rp, &tr)))
        ret = sp_file_set_add(&fs, a->out, &to);
    if (!ret && (what = dp))
        ret = sp_png_write(td, debug, j->w, j->h, j->w * 3, 3);
    if (!ret && (what = rp))
        ret = write_report(a, j, tr);
    if (!ret && (what = a->out))
        ret = sp_png_write(to, j->result, j->w, j->h, j->w * 3, 3);
    if (!ret && sp_cmd_stop_signal) /* Ctrl-C: the old set stays */
        ret = -ECANCELED;
    if (!ret && (what = a->out))
        ret = sp_file_set_commit(&fs);
    sp_file_set_abort(&fs);
    int code = ret ? sp_cmd_fail("depopulate", ret, what) : 0;
    if (!ret && !a->quiet)
        printf("%s: %zu object(s) removed (from %s), %zu kept; filled from %s; report %s, masks %s\n", a->out, j->n,
               j->source, j->kept, j->fill, rp, dp);
    free(rep), free(dbg), free(debug);
    return code;
}

static int depopulate(const depop_args *a)
{
    depop_job j;
    int code = depop_job_run("depopulate", &a->in, &j);
    if (!code && j.n == 0) {
        fprintf(stderr, "sunprobe depopulate: nothing to remove in %s (objects from %s; %zu kept)\n", a->in.in,
                j.source, j.kept);
        code = SP_EXIT_BAD_INPUT;
    }
    if (!code)
        code = depop_job_fill(&j);
    if (!code)
        code = write_outputs(a, &j);
    depop_job_free(&j);
    return code;
}

int sp_cmd_depopulate(int argc, char **argv)
{
    depop_args a = { 0 };
    depop_input_default(&a.in);
    int code = parse_args(argc, argv, &a);
    if (code)
        return code < 0 ? SP_EXIT_OK : code;
    sp_cmd_signals sig; /* Ctrl-C: the outputs are not put in place, 128+N */
    sp_cmd_catch_signals(&sig);
    code = depopulate(&a);
    sp_cmd_restore_signals(&sig);
    return code;
}
