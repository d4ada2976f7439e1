/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe composite PROBE_DIR --object CUT.png --at X,Y -o OUT.png`: inserts
 * cut-outs into the clean plate (or a given background) with the size, occlusion,
 * brightness and shadow the probe learned. Several --object/--at pairs are drawn
 * back to front.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd.h"
#include "export/png.h"
#include "export/png_read.h"
#include "export/probe_dir.h"
#include "sunprobe/sp_probe.h"

#define MAX_OBJECTS 32

typedef struct cut {
    const char *path;
    double x, y, height_px, scale;
    int placed;
    uint8_t *rgba;
    uint32_t w, h;
} cut;

typedef struct composite_args {
    const char *dir, *out, *background;
    sp_composite_settings s;
    cut obj[MAX_OBJECTS];
    unsigned n;
    int quiet;
} composite_args;

static void usage(FILE *out)
{
    fprintf(out,
            "usage: sunprobe composite PROBE_DIR --object CUT.png --at X,Y [--object ... --at ...] -o OUT.png\n\n"
            "Inserts cut-outs (PNG with alpha) at ground points of the probed scene: the height comes from\n"
            "the ground plane, hidden pixels from the occlusion map, the brightness from the lighting map,\n"
            "and a shadow from the shadow model when one was learned (else the contact shadow people were seen\n"
            "to make at their feet, when learned). Objects are drawn back to front.\n\n"
            "options:\n"
            "      --object PNG      a cut-out; the next --at/--height-px/--scale apply to it\n"
            "      --at X,Y          where its bottom middle stands (pixels of the background)\n"
            "      --height-px H     its height on screen instead of the plane's\n"
            "      --scale S         its height relative to a person's (default 1)\n"
            "      --background PNG  draw into this image (default: the clean plate)\n"
            "      --no-occlusion --no-lighting --no-shadow   leave one effect out\n"
            "  -o, --output PNG      the result\n"
            "  -q, --quiet           no summary\n");
}

static int bad(const char *what, const char *v)
{
    fprintf(stderr, "sunprobe composite: bad %s: '%s'\n", what, v);
    return SP_EXIT_USAGE;
}

enum { OPT_OBJECT = 256, OPT_AT, OPT_HEIGHT, OPT_SCALE, OPT_BACKGROUND, OPT_NO_OCC, OPT_NO_LIGHT, OPT_NO_SHADOW };

/* --at, --height-px and --scale belong to the --object before them */
static int object_value(int c, cut *o)
{
    static const double lo[2] = { -1e6, -1e6 }, hi[2] = { 1e6, 1e6 };
    double v[2];
    const char *name = c == OPT_AT ? "at" : c == OPT_HEIGHT ? "height-px" : "scale";
    if (!o) {
        fprintf(stderr, "sunprobe composite: --%s '%s': give it after the --object it places\n", name, optarg);
        return SP_EXIT_USAGE;
    }
    if (c == OPT_AT) {
        if (sp_opt_list("composite", "at", optarg, 2, lo, hi, v, "X,Y in pixels of the background, |X|,|Y| <= 1e6"))
            return SP_EXIT_USAGE;
        o->x = v[0], o->y = v[1], o->placed = 1;
        return 0;
    }
    if (c == OPT_HEIGHT)
        return sp_opt_double("composite", name, optarg, 0.01, 1e5, &o->height_px) ? SP_EXIT_USAGE : 0;
    return sp_opt_double("composite", name, optarg, 0.001, 100.0, &o->scale) ? SP_EXIT_USAGE : 0;
}

static int parse_option(int c, composite_args *a)
{
    switch (c) {
    case OPT_OBJECT:
        if (a->n == MAX_OBJECTS)
            return bad("--object (at most 32)", optarg);
        a->obj[a->n++] = (cut){ .path = optarg, .scale = 1.0 };
        return 0;
    case OPT_AT:
    case OPT_HEIGHT:
    case OPT_SCALE: return object_value(c, a->n ? &a->obj[a->n - 1] : NULL);
    case OPT_BACKGROUND: a->background = optarg; return 0;
    case OPT_NO_OCC: a->s.occlusion = 0; return 0;
    case OPT_NO_LIGHT: a->s.lighting = 0; return 0;
    case OPT_NO_SHADOW: a->s.shadow = 0; return 0;
    case 'o': a->out = optarg; return 0;
    case 'q': a->quiet = 1; return 0;
    case 'h': usage(stdout); return -1;
    default: usage(stderr); return SP_EXIT_USAGE;
    }
}

static int parse_args(int argc, char **argv, composite_args *a)
{
    static const struct option opts[] = {
        { "object", required_argument, NULL, OPT_OBJECT },   { "at", required_argument, NULL, OPT_AT },
        { "height-px", required_argument, NULL, OPT_HEIGHT }, { "scale", required_argument, NULL, OPT_SCALE },
        { "background", required_argument, NULL, OPT_BACKGROUND }, { "no-occlusion", no_argument, NULL, OPT_NO_OCC },
        { "no-lighting", no_argument, NULL, OPT_NO_LIGHT },  { "no-shadow", no_argument, NULL, OPT_NO_SHADOW },
        { "output", required_argument, NULL, 'o' },          { "quiet", no_argument, NULL, 'q' },
        { "help", no_argument, NULL, 'h' },                  { 0 },
    };
    optind = 0;
    int c, code;
    while ((c = getopt_long(argc, argv, "o:qh", opts, NULL)) != -1)
        if ((code = parse_option(c, a)))
            return code;
    if (optind != argc - 1 || !a->out || !a->n) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    for (unsigned i = 0; i < a->n; i++)
        if (!a->obj[i].placed)
            return bad("--object without --at", a->obj[i].path);
    a->dir = argv[optind];
    return 0;
}

static int load_background(const composite_args *a, const sp_probe_dir *d, uint8_t **rgb)
{
    size_t n = (size_t)d->width * d->height;
    *rgb = malloc(n * 3);
    if (!*rgb)
        return -ENOMEM;
    if (!a->background) {
        memcpy(*rgb, d->clean_plate, n * 3);
        return 0;
    }
    uint8_t *rgba = NULL;
    uint32_t w, h;
    int ret = sp_png_read_rgba(a->background, &rgba, &w, &h);
    if (!ret && (w != d->width || h != d->height)) {
        fprintf(stderr, "sunprobe composite: %s is %ux%u, the probe %ux%u\n", a->background, w, h, d->width,
                d->height);
        ret = -EINVAL;
    }
    for (size_t i = 0; !ret && i < n; i++)
        memcpy(*rgb + 3 * i, rgba + 4 * i, 3);
    free(rgba);
    return ret;
}

static int composite(composite_args *a, const sp_probe_dir *d, uint8_t *rgb)
{
    sp_composite_object objs[MAX_OBJECTS];
    for (unsigned i = 0; i < a->n; i++) {
        cut *c = &a->obj[i];
        int ret = sp_png_read_rgba(c->path, &c->rgba, &c->w, &c->h);
        if (ret)
            return sp_cmd_fail("composite", ret, c->path);
        objs[i] = (sp_composite_object){ c->rgba, c->w, c->h, c->w * 4, c->x, c->y, c->height_px, c->scale };
    }
    sp_probe_maps maps = sp_probe_dir_maps(d);
    sp_composite_report rep;
    int ret = sp_composite(&maps, &d->plane, &d->shadow, &a->s, objs, a->n, rgb, d->width * 3, &rep);
    if (ret == SP_ENODATA) {
        fprintf(stderr, "sunprobe composite: the ground plane does not give a height there (%s); "
                        "use --height-px\n", d->plane.note);
        return SP_EXIT_BAD_INPUT;
    }
    if (ret == -EINVAL) {
        fprintf(stderr, "sunprobe composite: an object is outside the %ux%u image or has no visible pixels\n",
                d->width, d->height);
        return SP_EXIT_USAGE;
    }
    if (ret)
        return sp_cmd_fail("composite", ret, "compositing");
    if (sp_cmd_stop_signal) /* Ctrl-C while compositing: OUT as it was */
        return sp_cmd_fail("composite", -ECANCELED, a->out);
    if ((ret = sp_png_write(a->out, rgb, d->width, d->height, d->width * 3, 3)))
        return sp_cmd_fail("composite", ret, a->out);
    if (!a->quiet)
        printf("%s: %u object(s); last: %.1f px tall, lighting gain %.2f %.2f %.2f; %llu pixels drawn, %llu hidden, "
               "%llu shadow pixels, %llu contact shadow pixels%s\n",
               a->out, a->n, rep.height_px, rep.gain[0], rep.gain[1], rep.gain[2], (unsigned long long)rep.pixels_drawn,
               (unsigned long long)rep.pixels_hidden, (unsigned long long)rep.shadow_pixels,
               (unsigned long long)rep.contact_pixels,
               d->shadow.present || d->shadow.contact_present ? "" : " (no shadow model)");
    return SP_EXIT_OK;
}

int sp_cmd_composite(int argc, char **argv)
{
    composite_args a = { 0 };
    sp_composite_default_settings(&a.s);
    int code = parse_args(argc, argv, &a);
    if (code)
        return code < 0 ? SP_EXIT_OK : code;
    sp_cmd_signals sig; /* a stop signal is acted on before OUT is written; once it is, the run ends with 0 */
    sp_cmd_catch_signals(&sig);
    sp_probe_dir d;
    int ret = sp_probe_dir_load(a.dir, &d);
    if (ret) {
        sp_cmd_restore_signals(&sig);
        return sp_cmd_fail("composite", ret, a.dir);
    }
    uint8_t *rgb = NULL;
    ret = load_background(&a, &d, &rgb);
    code = ret ? sp_cmd_fail("composite", ret, a.background ? a.background : a.dir) : composite(&a, &d, rgb);
    for (unsigned i = 0; i < a.n; i++)
        free(a.obj[i].rgba);
    free(rgb);
    sp_probe_dir_free(&d);
    sp_cmd_restore_signals(&sig);
    return code;
}
