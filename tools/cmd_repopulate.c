/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe repopulate INPUT --collection DIR -o OUT.png`: inserts people from
 * a collection of cut-outs whose lighting matches the scene's, scaled from the
 * ground plane, with a shadow along the sun, occluded by a probe's map when
 * given; with --private the people found are removed first and each replaced
 * at their foot point (pipeline/probe/REPOPULATE.md). Drawing is
 * sp_composite's, the object finding and filling depopulate's.
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
#include "cutout_collection.h"
#include "depop_job.h"
#include "export/png.h"

#define MAX_AT 64
#define MAX_UPSCALE 2.0 /* a cut-out is not drawn more than twice its own height: it would blur */

typedef struct repop_args {
    depop_input in;
    const char *out, *report, *collection;
    unsigned count;
    uint64_t seed;
    int private_mode, have_cam, quiet;
    double at[2 * MAX_AT];
    unsigned n_at;
    sp_depop_camera cam;
    sp_repop_light sky; /* --sun / --overcast; UNKNOWN: from the image */
    double min_match;
} repop_args;

/* One person to insert. */
typedef struct target {
    double x, y, h;         /* foot pixel, height on screen */
    int ci;                 /* the chosen cut-out, -1 none */
    double shadow_dx, shadow_dy;
    int has_shadow;
} target;

typedef struct scene {
    sp_repop_light light;
    const char *sun_from;
    double shadow_ratio[3];
    double person_h; /* camera heights; NaN with a probe */
    sp_depop_camera cam;
} scene;

static void usage(FILE *out)
{
    fprintf(out,
            "usage: sunprobe repopulate INPUT.png|.jpg --collection DIR -o OUT.png [options]\n\n"
            "Inserts people from a collection of cut-outs (RGBA PNG + sidecar JSON each, as `sunprobe cutouts`\n"
            "writes) whose lighting matches the scene's: the sun from the shadows of the people in the image\n"
            "(or a probe's shadow model, or --sun), the ground's brightness. Heights come from the ground plane\n"
            "(the people found and the camera, or the probe's plane), shadows are cast along the sun.\n\n"
            "options:\n"
            "      --collection DIR  the cut-outs\n"
            "      --count N         people to insert at random ground points (default 3)\n"
            "      --at X,Y          insert one at this foot point instead (repeatable)\n"
            "      --private         remove the people found first and put a different one at each foot point\n"
            "      --seed S          the random choices (default 1)\n"
            "      --probe DIR       a probe directory of the scene: objects, plane, shadow model, occlusion\n"
            "      --box X,Y,W,H     a person in the image (repeatable); --keep X,Y, --detector hog|none,\n"
            "                        --whole-boxes as in depopulate\n"
            "      --camera F,CX,CY,PITCH  as in depopulate (default: 60 deg wide, centred, 15 deg down)\n"
            "      --sun AZ,EL       the sun relative to the camera instead of from the shadows\n"
            "      --overcast        no sun\n"
            "      --min-match M     lowest lighting match (-1..1) a cut-out may have (default 0)\n"
            "      --report FILE     the JSON report (default OUT without .png + .json)\n"
            "  -o, --output PNG      the result\n"
            "  -q, --quiet           no summary\n");
}

static int bad(const char *opt, const char *v)
{
    fprintf(stderr, "sunprobe repopulate: bad %s: '%s'\n", opt, v);
    return SP_EXIT_USAGE;
}

enum {
    OPT_PROBE = 256,
    OPT_BOX,
    OPT_KEEP,
    OPT_DETECTOR,
    OPT_WHOLE_BOXES,
    OPT_COLLECTION,
    OPT_COUNT,
    OPT_AT,
    OPT_PRIVATE,
    OPT_SEED,
    OPT_CAMERA,
    OPT_SUN,
    OPT_OVERCAST,
    OPT_MIN_MATCH,
    OPT_REPORT
};

static int parse_option(int c, const char *name, repop_args *a)
{
    double v[4];
    int n;
    if (c >= OPT_PROBE && c <= OPT_WHOLE_BOXES)
        return depop_input_option("repopulate", name, optarg, &a->in);
    switch (c) {
    case OPT_COLLECTION: a->collection = optarg; return 0;
    case OPT_COUNT:
        if (sp_opt_int("repopulate", "--count", optarg, 1, 256, &n))
            return SP_EXIT_USAGE;
        a->count = (unsigned)n;
        return 0;
    case OPT_AT:
        if (a->n_at == MAX_AT || sp_opt_numbers(optarg, a->at + 2 * a->n_at, 2))
            return bad("--at (X,Y, at most 64)", optarg);
        a->n_at++;
        return 0;
    case OPT_PRIVATE: a->private_mode = 1; return 0;
    case OPT_SEED: return sp_opt_u64("repopulate", "--seed", optarg, 0, UINT64_MAX, &a->seed) ? SP_EXIT_USAGE : 0;
    case OPT_CAMERA:
        a->have_cam = 1, a->in.ds.camera = &a->cam; /* the masks search the one sun through it too */
        return depop_camera_option("repopulate", optarg, &a->cam);
    case OPT_SUN:
        if (sp_opt_numbers(optarg, v, 2) || fabs(v[0]) > 360 || !(v[1] > 0 && v[1] <= 90))
            return bad("--sun (AZ,EL in degrees, elevation 0..90)", optarg);
        a->sky = (sp_repop_light){ SP_REPOP_SUNNY, v[0], v[1], { 0, 0, 0 } };
        return 0;
    case OPT_OVERCAST: a->sky.sky = SP_REPOP_OVERCAST; return 0;
    case OPT_MIN_MATCH:
        return sp_opt_double("repopulate", "--min-match", optarg, -1, 1, &a->min_match) ? SP_EXIT_USAGE : 0;
    case OPT_REPORT: a->report = optarg; return 0;
    case 'o': a->out = optarg; return 0;
    case 'q': a->quiet = 1; return 0;
    case 'h': usage(stdout); return -1;
    default: usage(stderr); return SP_EXIT_USAGE;
    }
}

static int parse_args(int argc, char **argv, repop_args *a)
{
    static const struct option opts[] = {
        { "probe", required_argument, NULL, OPT_PROBE },
        { "box", required_argument, NULL, OPT_BOX },
        { "keep", required_argument, NULL, OPT_KEEP },
        { "detector", required_argument, NULL, OPT_DETECTOR },
        { "whole-boxes", no_argument, NULL, OPT_WHOLE_BOXES },
        { "collection", required_argument, NULL, OPT_COLLECTION },
        { "count", required_argument, NULL, OPT_COUNT },
        { "at", required_argument, NULL, OPT_AT },
        { "private", no_argument, NULL, OPT_PRIVATE },
        { "seed", required_argument, NULL, OPT_SEED },
        { "camera", required_argument, NULL, OPT_CAMERA },
        { "sun", required_argument, NULL, OPT_SUN },
        { "overcast", no_argument, NULL, OPT_OVERCAST },
        { "min-match", required_argument, NULL, OPT_MIN_MATCH },
        { "report", required_argument, NULL, OPT_REPORT },
        { "output", required_argument, NULL, 'o' },
        { "quiet", no_argument, NULL, 'q' },
        { "help", no_argument, NULL, 'h' },
        { 0 },
    };
    optind = 0;
    int c, code, li;
    while ((li = -1, c = getopt_long(argc, argv, "o:qh", opts, &li)) != -1)
        if ((code = parse_option(c, li >= 0 ? opts[li].name : "", a)))
            return code;
    if (optind != argc - 1 || !a->out || !a->collection) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    if (a->private_mode && a->n_at) {
        fprintf(stderr, "sunprobe repopulate: --private puts people where the removed ones stood; leave out --at\n");
        return SP_EXIT_USAGE;
    }
    a->in.in = argv[optind];
    return 0;
}

static uint64_t next_random(uint64_t *s)
{
    *s ^= *s << 13, *s ^= *s >> 7, *s ^= *s << 17; /* xorshift64 */
    return *s;
}

static double uniform(uint64_t *s) { return (double)(next_random(s) >> 11) / 9007199254740992.0; }

/*
 * The shadows the masks found over the lit ground: the scene's shadow ratio, 0.5 when fewer than 20
 * pixels are darker than 0.85 of the ground (contact masks on lit ground are no shadow).
 */
static void shadow_ratio(const depop_job *j, const double ground[3], double out[3])
{
    double sum[3] = { 0, 0, 0 }, n = 0, gl = 0.299 * ground[0] + 0.587 * ground[1] + 0.114 * ground[2];
    for (size_t i = 0; i < (size_t)j->w * j->h; i++) {
        const uint8_t *p = j->rgb + 3 * i;
        if (j->mask[i] == 2 && 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2] < 0.85 * gl)
            for (int c = 0; c < 3; c++)
                sum[c] += p[c], n += c == 0;
    }
    for (int c = 0; c < 3; c++) {
        double r = n >= 20 && ground[c] > 1 ? sum[c] / n / ground[c] : 0.5;
        out[c] = r < 0.15 ? 0.15 : r > 0.9 ? 0.9 : r;
    }
}

/*
 * The person in object i's box: HOG's boxes are its 64x128 training window, the person about 96 pixels
 * tall in it with an eighth above and below (Dalal and Triggs), so they lose those eighths.
 */
static sp_depop_object person_box(const depop_job *j, size_t i)
{
    sp_depop_object o = j->obj[i];
    if (!strcmp(j->origin[i], "hog")) {
        int pad = (o.y1 - o.y0 + 1) / 8;
        o.y0 += pad, o.y1 -= pad;
    }
    return o;
}

static double people_height(const depop_job *j, const sp_depop_camera *cam)
{
    sp_depop_object o[DEPOP_MAX_OBJECTS];
    for (size_t i = 0; i < j->n; i++)
        o[i] = person_box(j, i);
    return sp_repop_people_height(o, j->n, cam);
}

static void scene_light(const repop_args *a, const depop_job *j, scene *sc)
{
    sc->cam = j->cam;
    if (sp_repop_ground_light(j->rgb, j->w, j->h, j->mask, sc->light.ground_rgb))
        memset(sc->light.ground_rgb, 0, sizeof(sc->light.ground_rgb));
    sp_depop_sun e = { 0 };
    if (a->sky.sky != SP_REPOP_UNKNOWN) {
        sc->light.sky = a->sky.sky, sc->light.sun_az_deg = a->sky.sun_az_deg, sc->light.sun_el_deg = a->sky.sun_el_deg;
        sc->sun_from = a->sky.sky == SP_REPOP_SUNNY ? "--sun" : "--overcast";
    } else if (j->have_probe) {
        sp_repop_sun_from_model(&j->pd.shadow, &j->pd.plane, j->w, j->h, &sc->cam, &e);
        sc->sun_from = "the probe's shadow model";
        sc->light.sky = e.found ? SP_REPOP_SUNNY : SP_REPOP_OVERCAST;
    } else if (j->n) {
        sp_depop_sun_estimate(j->obj, j->n, &sc->cam, &e);
        sc->sun_from = e.found ? "the people's shadows" : "no sun shadows under the people found";
        sc->light.sky = e.found ? SP_REPOP_SUNNY : SP_REPOP_OVERCAST;
    } else {
        sc->sun_from = "nothing: no people found and no --sun";
    }
    if (e.found)
        sc->light.sun_az_deg = e.azimuth_deg, sc->light.sun_el_deg = e.elevation_deg;
    if (j->have_probe && j->pd.shadow.present)
        memcpy(sc->shadow_ratio, j->pd.shadow.ratio, sizeof(sc->shadow_ratio));
    else
        shadow_ratio(j, sc->light.ground_rgb, sc->shadow_ratio);
    sc->person_h = j->have_probe ? (double)NAN : people_height(j, &sc->cam);
}

static double height_at(const depop_job *j, const scene *sc, double x, double y)
{
    double h = j->have_probe ? sp_probe_plane_height(&j->pd.plane, x, y)
                             : sp_repop_height_px(&sc->cam, sc->person_h, x, y);
    return h >= 4 && h <= y + 1 ? h : (double)NAN;
}

/* Whether a person h tall at (x, y) overlaps a found object or an earlier target. */
static int crowded(const depop_job *j, const target *t, size_t n, double x, double y, double h)
{
    double w = 0.35 * h;
    for (size_t i = 0; i < j->n; i++)
        if (x + w / 2 > j->obj[i].x0 && x - w / 2 < j->obj[i].x1 && y > j->obj[i].y0 && y - h < j->obj[i].y1)
            return 1;
    for (size_t i = 0; i < n; i++)
        if (fabs(x - t[i].x) < 0.35 * (h + t[i].h) / 2 && y > t[i].y - t[i].h && y - h < t[i].y)
            return 1;
    return 0;
}

/* Random foot points on the ground rows (those of the people found, else the lower half). */
static size_t random_targets(const repop_args *a, const depop_job *j, const scene *sc, target *t)
{
    double lo = 0.5 * j->h;
    for (size_t i = 0; i < j->n; i++)
        lo = fmin(lo, j->obj[i].y1 - 0.1 * (j->obj[i].y1 - j->obj[i].y0));
    uint64_t s = a->seed * 0x9E3779B97F4A7C15ull + 1;
    size_t n = 0;
    for (unsigned tries = 0; n < a->count && tries < 400 * a->count; tries++) {
        double y = floor(lo + uniform(&s) * (j->h - 1 - lo)), x = floor(uniform(&s) * j->w);
        double h = height_at(j, sc, x, y);
        if (!isfinite(h) || x < 0.2 * h || x > j->w - 1 - 0.2 * h || crowded(j, t, n, x, y, h))
            continue;
        t[n++] = (target){ x, y, h, -1, 0, 0, 0 };
    }
    return n;
}

static int place_targets(const repop_args *a, const depop_job *j, const scene *sc, target *t, size_t *n)
{
    *n = 0;
    if (a->private_mode) {
        /* a probe's objects may be cars or groups: those not shaped like a person are removed, not replaced,
           and so is anyone the plane gives no height */
        for (size_t i = 0; i < j->n; i++) {
            sp_depop_object o = person_box(j, i);
            double x = floor(0.5 * (o.x0 + o.x1)), y = o.y1, h = height_at(j, sc, x, y);
            if (isfinite(h) && (strcmp(j->origin[i], "probe") || depop_person_shaped(&o)))
                t[(*n)++] = (target){ x, y, h, -1, 0, 0, 0 };
        }
    } else if (a->n_at) {
        for (unsigned i = 0; i < a->n_at; i++)
            t[(*n)++] = (target){ a->at[2 * i], a->at[2 * i + 1], height_at(j, sc, a->at[2 * i], a->at[2 * i + 1]),
                                  -1, 0, 0, 0 };
    } else {
        *n = random_targets(a, j, sc, t);
    }
    for (size_t i = 0; i < *n; i++)
        if (!isfinite(t[i].h) || t[i].x < 0 || t[i].x >= j->w || t[i].y < 0 || t[i].y >= j->h) {
            fprintf(stderr, "sunprobe repopulate: no person height at %.0f,%.0f in %s (outside the image, above the "
                            "horizon, or under 4 pixels)\n", t[i].x, t[i].y, a->in.in);
            return SP_EXIT_BAD_INPUT;
        }
    if (!*n && a->private_mode) {
        fprintf(stderr, "sunprobe repopulate: --private: none of the %zu objects found in %s is shaped like a person "
                        "with a height from the plane\n", j->n, a->in.in);
        return SP_EXIT_BAD_INPUT;
    }
    if (!*n) {
        fprintf(stderr, "sunprobe repopulate: no free ground point in %s for a person of a usable size\n", a->in.in);
        return SP_EXIT_BAD_INPUT;
    }
    return 0;
}

/* Scores the collection against the scene; how many match it well enough. */
static size_t score_cutouts(const repop_args *a, const scene *sc, cutout *c, size_t n, double *best)
{
    size_t usable = 0;
    *best = -2;
    for (size_t i = 0; i < n; i++) {
        c[i].match = sp_repop_match(&sc->light, &c[i].m.light, c[i].gain);
        double g = (c[i].gain[0] + c[i].gain[1] + c[i].gain[2]) / 3;
        c[i].score = c[i].match - 0.25 * fabs(log2(g));
        usable += c[i].match >= a->min_match;
        *best = fmax(*best, c[i].match);
    }
    return usable;
}

/* A cut-out's height over a person's of the scene (its real height over the scale model's person; 1 unknown). */
static double real_scale(const cutout *c)
{
    return c->m.height_m > 0 ? c->m.height_m / SP_REPOP_PERSON_HEIGHT_M : 1.0;
}

/* For each target the best-scoring usable cut-out big enough for it, fewer repeats first, ties by the seed. */
static size_t choose(const repop_args *a, cutout *c, size_t n, target *t, size_t nt)
{
    uint64_t s = a->seed * 0xD1B54A32D192ED03ull + 7;
    size_t placed = 0;
    for (size_t k = 0; k < nt; k++) {
        double best = -1e9;
        for (size_t i = 0; i < n; i++) {
            if (c[i].match < a->min_match || t[k].h * real_scale(&c[i]) > MAX_UPSCALE * c[i].m.height_px)
                continue;
            double v = c[i].score - 0.5 * c[i].used + 0.02 * uniform(&s);
            if (v > best)
                best = v, t[k].ci = (int)i;
        }
        if (t[k].ci >= 0) /* the target's height was a person's of the scene's height: now the cut-out's own */
            c[t[k].ci].used++, placed++, t[k].h *= real_scale(&c[t[k].ci]);
    }
    return placed;
}

/* The cut-out with the scene's brightness: its colour times the gain (straight alpha kept). */
static uint8_t *adjusted(const cutout *c)
{
    size_t np = (size_t)c->w * c->h;
    uint8_t *p = malloc(np * 4);
    for (size_t i = 0; p && i < np; i++) {
        for (int k = 0; k < 3; k++) {
            double v = c->rgba[4 * i + k] * c->gain[k];
            p[4 * i + k] = (uint8_t)(v > 255 ? 255 : lrint(v));
        }
        p[4 * i + 3] = c->rgba[4 * i + 3];
    }
    return p;
}

static int by_row(const void *a, const void *b)
{
    const target *x = a, *y = b;
    return (x->y > y->y) - (x->y < y->y);
}

/* Draws the chosen cut-outs back to front into bg through sp_composite, each with its own shadow. */
static int draw(const depop_job *j, const scene *sc, const cutout *c, target *t, size_t nt, uint8_t *bg,
                sp_composite_report *total)
{
    qsort(t, nt, sizeof(*t), by_row);
    sp_probe_maps maps = j->have_probe ? sp_probe_dir_maps(&j->pd) : (sp_probe_maps){ j->w, j->h, NULL, NULL, NULL };
    sp_composite_settings s;
    sp_composite_default_settings(&s);
    *total = (sp_composite_report){ 0 };
    for (size_t k = 0; k < nt; k++) {
        if (t[k].ci < 0)
            continue;
        sp_probe_shadow sh = { 0 };
        if (j->have_probe) {
            sh = j->pd.shadow;
            double u = t[k].x / j->w, v = t[k].y / j->h; /* the model's offset here, for the report */
            t[k].shadow_dx = sh.ox[0] + sh.ox[1] * u + sh.ox[2] * v;
            t[k].shadow_dy = sh.oy[0] + sh.oy[1] * u + sh.oy[2] * v;
        }
        else if (sc->light.sky == SP_REPOP_SUNNY &&
                 !sp_repop_shadow_offset(&sc->cam, sc->light.sun_az_deg, sc->light.sun_el_deg, t[k].x, t[k].y, t[k].h,
                                         &t[k].shadow_dx, &t[k].shadow_dy)) {
            sh = (sp_probe_shadow){ .present = 1, .ox = { t[k].shadow_dx }, .oy = { t[k].shadow_dy } };
            memcpy(sh.ratio, sc->shadow_ratio, sizeof(sh.ratio));
        }
        t[k].has_shadow = sh.present;
        const cutout *cu = &c[t[k].ci];
        uint8_t *px = adjusted(cu);
        if (!px)
            return -ENOMEM;
        sp_composite_object o = { px, cu->w, cu->h, cu->w * 4, t[k].x, t[k].y, t[k].h, 1.0 };
        sp_composite_report r;
        int ret = sp_composite(&maps, j->have_probe ? &j->pd.plane : NULL, &sh, &s, &o, 1, bg, j->w * 3, &r);
        free(px);
        if (ret)
            return ret;
        total->pixels_drawn += r.pixels_drawn, total->pixels_hidden += r.pixels_hidden;
        total->shadow_pixels += r.shadow_pixels;
    }
    return 0;
}

static const char *sky_name(sp_repop_sky s)
{
    return s == SP_REPOP_SUNNY ? "sunny" : s == SP_REPOP_OVERCAST ? "overcast" : "unknown";
}

static void scene_json(const scene *sc, sp_strbuf *b)
{
    sp_strbuf_printf(b, "\"scene\":{\"sky\":\"%s\",\"sun_from\":", sky_name(sc->light.sky));
    sp_strbuf_json_string(b, sc->sun_from);
    if (sc->light.sky == SP_REPOP_SUNNY)
        sp_strbuf_printf(b, ",\"sun_azimuth_deg\":%.2f,\"sun_elevation_deg\":%.2f", sc->light.sun_az_deg,
                         sc->light.sun_el_deg);
    sp_strbuf_printf(b, ",\"ground_rgb\":");
    sp_strbuf_json_numbers(b, sc->light.ground_rgb, 3);
    sp_strbuf_printf(b, ",\"shadow_ratio\":");
    sp_strbuf_json_numbers(b, sc->shadow_ratio, 3);
    sp_strbuf_printf(b, ",\"person_height_camera_heights\":");
    sp_strbuf_json_number(b, sc->person_h);
    sp_strbuf_printf(b, "}");
}

static void placed_json(const scene *sc, const cutout *c, const target *t, size_t nt, sp_strbuf *b)
{
    sp_strbuf_printf(b, ",\"placed\":[");
    for (size_t k = 0, first = 1; k < nt; k++) {
        sp_strbuf_printf(b, "%s{\"at\":[%.1f,%.1f],\"height_px\":%.2f,\"cutout\":", first ? "" : ",", t[k].x, t[k].y,
                         t[k].h);
        first = 0;
        if (t[k].ci < 0) {
            sp_strbuf_printf(b, "null,\"why\":\"no usable cut-out is at least half this tall\"}");
            continue;
        }
        const cutout *cu = &c[t[k].ci];
        sp_strbuf_json_string(b, cu->name);
        sp_strbuf_printf(b, ",\"image\":");
        sp_strbuf_json_string(b, cu->m.image);
        sp_strbuf_printf(b, ",\"cutout_sky\":\"%s\",\"match\":%.4f,\"sun_angle_deg\":", sky_name(cu->m.light.sky),
                         cu->match);
        int both = sc->light.sky == SP_REPOP_SUNNY && cu->m.light.sky == SP_REPOP_SUNNY;
        sp_strbuf_json_number(b, both ? acos(cu->match) * 180 / M_PI : (double)NAN);
        sp_strbuf_printf(b, ",\"gain\":");
        sp_strbuf_json_numbers(b, cu->gain, 3);
        double off[2] = { t[k].shadow_dx, t[k].shadow_dy };
        sp_strbuf_printf(b, ",\"shadow\":%s,\"shadow_offset_per_height\":", t[k].has_shadow ? "true" : "false");
        if (t[k].has_shadow && (off[0] != 0 || off[1] != 0))
            sp_strbuf_json_numbers(b, off, 2);
        else
            sp_strbuf_printf(b, "null");
        sp_strbuf_printf(b, ",\"why\":\"best lighting match (sky, sun direction, ground brightness) of the cut-outs "
                            "big enough, fewest repeats\"}");
    }
    sp_strbuf_printf(b, "]");
}

static int write_report(const repop_args *a, const depop_job *j, const scene *sc, const cutout *c, size_t nc,
                        size_t usable, const target *t, size_t nt, const sp_composite_report *r, const char *path)
{
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"format\":\"sunprobe-repopulate\",\"version\":1,\"input\":");
    sp_strbuf_json_string(&b, a->in.in);
    sp_strbuf_printf(&b, ",\"collection\":");
    sp_strbuf_json_string(&b, a->collection);
    sp_strbuf_printf(&b,
                     ",\"width\":%u,\"height\":%u,\"private\":%s,\"people_found\":%zu,\"silhouettes\":%zu,"
                     "\"objects_from\":",
                     j->w, j->h, a->private_mode ? "true" : "false", j->n, j->segmented);
    sp_strbuf_json_string(&b, j->source);
    sp_strbuf_printf(&b, ",\"found\":[");
    for (size_t i = 0; i < j->n; i++)
        sp_strbuf_printf(&b, "%s[%d,%d,%d,%d]", i ? "," : "", j->obj[i].x0, j->obj[i].y0,
                         j->obj[i].x1 - j->obj[i].x0 + 1, j->obj[i].y1 - j->obj[i].y0 + 1);
    sp_strbuf_printf(&b, "],\"filled_from\":");
    if (j->fill)
        sp_strbuf_json_string(&b, j->fill);
    else
        sp_strbuf_printf(&b, "null");
    sp_strbuf_printf(&b, ",\"camera\":\"%s\",", a->have_cam ? "given" : "assumed");
    scene_json(sc, &b);
    sp_strbuf_printf(&b, ",\"cutouts\":%zu,\"usable\":%zu,\"min_match\":%.3f,\"pixels_drawn\":%llu,"
                         "\"pixels_hidden\":%llu,\"shadow_pixels\":%llu", nc, usable, a->min_match,
                     (unsigned long long)r->pixels_drawn, (unsigned long long)r->pixels_hidden,
                     (unsigned long long)r->shadow_pixels);
    placed_json(sc, c, t, nt, &b);
    sp_strbuf_printf(&b, "}\n");
    int ret = b.failed ? -ENOMEM : sp_write_whole_file_atomic(path, b.data, b.len);
    sp_strbuf_free(&b);
    return ret;
}

static int write_outputs(const repop_args *a, const depop_job *j, const scene *sc, const cutout *c, size_t nc,
                         size_t usable, const target *t, size_t nt, const sp_composite_report *r, const uint8_t *img)
{
    char *rep = a->report ? NULL : depop_derived_name(a->out, ".json");
    const char *rp = a->report ? a->report : rep, *tr, *to, *what = "output names";
    /* the image and its report as one file set: both or, on a failure or a stop signal, the old ones as they were */
    sp_file_set fs = { 0 };
    int ret = rp ? sp_file_set_add(&fs, rp, &tr) : -ENOMEM;
    if (!ret)
        ret = sp_file_set_add(&fs, a->out, &to);
    if (!ret && (what = rp))
        ret = write_report(a, j, sc, c, nc, usable, t, nt, r, tr);
    if (!ret && (what = a->out))
        ret = sp_png_write(to, img, j->w, j->h, j->w * 3, 3);
    if (!ret && sp_cmd_stop_signal)
        ret = -ECANCELED;
    if (!ret)
        ret = sp_file_set_commit(&fs);
    sp_file_set_abort(&fs);
    int code = ret ? sp_cmd_fail("repopulate", ret, what) : 0;
    if (!code && !a->quiet)
        printf("%s: %llu pixels of people drawn (%llu hidden), %llu shadow pixels; scene %s (%s); report %s\n", a->out,
               (unsigned long long)r->pixels_drawn, (unsigned long long)r->pixels_hidden,
               (unsigned long long)r->shadow_pixels, sky_name(sc->light.sky), sc->sun_from, rp);
    free(rep);
    return code;
}

/* Everything that can refuse the input, before any drawing: 0 or the exit code. */
static int prepare(const repop_args *a, depop_job *j, scene *sc, cutout *c, size_t nc, size_t *usable)
{
    if (a->private_mode && j->n == 0) {
        fprintf(stderr, "sunprobe repopulate: --private: nothing to remove in %s (objects from %s; %zu kept)\n",
                a->in.in, j->source, j->kept);
        return SP_EXIT_BAD_INPUT;
    }
    scene_light(a, j, sc);
    if (!j->have_probe && !isfinite(sc->person_h)) {
        fprintf(stderr, "sunprobe repopulate: no scale for %s: no person found standing on the ground (give --box "
                        "around one, or --probe)\n", a->in.in);
        return SP_EXIT_BAD_INPUT;
    }
    double best;
    *usable = score_cutouts(a, sc, c, nc, &best);
    if (!*usable) {
        fprintf(stderr, "sunprobe repopulate: no usable cut-out in %s: none of its %zu matches the scene's light "
                        "(%s; best match %.2f, --min-match %.2f)\n", a->collection, nc,
                sky_name(sc->light.sky), best, a->min_match);
        return SP_EXIT_BAD_INPUT;
    }
    return 0;
}

static int repopulate(const repop_args *a)
{
    cutout *c = NULL;
    size_t nc = 0, usable = 0, nt = 0;
    depop_job j = { 0 };
    scene sc = { 0 };
    target t[DEPOP_MAX_OBJECTS > MAX_AT ? DEPOP_MAX_OBJECTS : MAX_AT + 256];
    sp_composite_report r = { 0 };
    int code = cutouts_load("repopulate", a->collection, &c, &nc);
    if (!code)
        code = depop_job_run("repopulate", &a->in, &j);
    if (!code)
        code = prepare(a, &j, &sc, c, nc, &usable);
    if (!code)
        code = place_targets(a, &j, &sc, t, &nt);
    if (!code && !choose(a, c, nc, t, nt)) {
        fprintf(stderr, "sunprobe repopulate: no usable cut-out in %s: the %zu that match the light are all under "
                        "half the height they would be drawn at\n", a->collection, usable);
        code = SP_EXIT_BAD_INPUT;
    }
    if (!code && a->private_mode)
        code = depop_job_fill(&j);
    else if (!code)
        memcpy(j.result, j.rgb, (size_t)j.w * j.h * 3);
    int ret = code ? 0 : draw(&j, &sc, c, t, nt, j.result, &r);
    if (ret)
        code = sp_cmd_fail("repopulate", ret, "compositing");
    if (!code)
        code = write_outputs(a, &j, &sc, c, nc, usable, t, nt, &r, j.result);
    cutouts_free(c, nc);
    depop_job_free(&j);
    return code;
}

int sp_cmd_repopulate(int argc, char **argv)
{
    repop_args a = { .count = 3, .seed = 1 };
    depop_input_default(&a.in);
    int code = parse_args(argc, argv, &a);
    if (code)
        return code < 0 ? SP_EXIT_OK : code;
    sp_cmd_signals sig; /* a stop signal is acted on before the outputs are committed; once they are, exit 0 */
    sp_cmd_catch_signals(&sig);
    code = repopulate(&a);
    sp_cmd_restore_signals(&sig);
    return code;
}
