/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe cutouts CAPTURE --probe PROBE_DIR -o DIR`: the people of a static
 * capture as cut-outs for `sunprobe repopulate`: every Nth frame segmented
 * against the probe's clean plate (depopulate's segmentation), person-shaped
 * objects kept, each written as an RGBA PNG (alpha: the object's mask, its
 * shadow left out) with a sidecar of its size, foot and the scene's light
 * (the sun from the probe's shadow model, the plate's lit ground). The
 * directory appears whole or not at all (pipeline/probe/REPOPULATE.md).
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "capture_open.h"
#include "cmd.h"
#include "common/file_util.h"
#include "common/json.h"
#include "common/pixconv.h"
#include "depop_job.h"
#include "export/png.h"
#include "pipeline/probe/repopulate.h"

#define CMD "cutouts"
#define MAX_PER_FRAME 64

typedef struct cut_args {
    const char *capture, *probe, *out;
    unsigned every, max, min_height;
    sp_depop_camera cam;
    int have_cam, force, quiet;
} cut_args;

typedef struct cut_run {
    const cut_args *a;
    sp_probe_dir pd;
    sp_repop_light light;
    const char *dir; /* the partial directory */
    uint8_t *rgb, *mask, *crop;
    uint64_t frames;
    unsigned written, segmented;
} cut_run;

static void usage(FILE *out)
{
    fprintf(out, "usage: sunprobe cutouts CAPTURE --probe PROBE_DIR -o DIR [options]\n\n"
                 "Writes the people of a static capture as cut-outs for `sunprobe repopulate`: every Nth frame is\n"
                 "segmented against the probe's clean plate; each person-shaped object becomes an RGBA PNG (alpha:\n"
                 "its mask, its shadow left out) with a sidecar JSON (height, foot point, the sun from the probe's\n"
                 "shadow model or overcast, the lit ground's colour).\n\n"
                 "options:\n"
                 "      --probe DIR       `sunprobe probe` of this capture (required)\n"
                 "      --every N         segment every Nth frame (default 10)\n"
                 "      --max N           at most N cut-outs (default 50)\n"
                 "      --min-height PX   smallest person kept (default 24)\n"
                 "      --camera F,CX,CY,PITCH  for the sun's angles (default: 60 deg wide, centred, 15 deg down)\n"
                 "  -o, --output DIR      the collection to create (written as DIR.partial.PID, then renamed)\n"
                 "  -f, --force           replace DIR if it exists\n"
                 "  -q, --quiet           no summary\n");
}

enum { OPT_PROBE = 256, OPT_EVERY, OPT_MAX, OPT_MIN_HEIGHT, OPT_CAMERA };

static int parse_option(int c, cut_args *a)
{
    int n;
    switch (c) {
    case OPT_PROBE: a->probe = optarg; return 0;
    case OPT_EVERY:
        return sp_opt_int(CMD, "--every", optarg, 1, 1 << 20, &n) ? SP_EXIT_USAGE : (a->every = (unsigned)n, 0);
    case OPT_MAX: return sp_opt_int(CMD, "--max", optarg, 1, 100000, &n) ? SP_EXIT_USAGE : (a->max = (unsigned)n, 0);
    case OPT_MIN_HEIGHT:
        return sp_opt_int(CMD, "--min-height", optarg, 4, 100000, &n) ? SP_EXIT_USAGE
                                                                        : (a->min_height = (unsigned)n, 0);
    case OPT_CAMERA:
        a->have_cam = 1;
        return depop_camera_option(CMD, optarg, &a->cam);
    case 'o': a->out = optarg; return 0;
    case 'f': a->force = 1; return 0;
    case 'q': a->quiet = 1; return 0;
    case 'h': usage(stdout); return -1;
    default: usage(stderr); return SP_EXIT_USAGE;
    }
}

static int parse_args(int argc, char **argv, cut_args *a)
{
    static const struct option opts[] = {
        { "probe", required_argument, NULL, OPT_PROBE },   { "every", required_argument, NULL, OPT_EVERY },
        { "max", required_argument, NULL, OPT_MAX },       { "min-height", required_argument, NULL, OPT_MIN_HEIGHT },
        { "camera", required_argument, NULL, OPT_CAMERA }, { "output", required_argument, NULL, 'o' },
        { "force", no_argument, NULL, 'f' },               { "quiet", no_argument, NULL, 'q' },
        { "help", no_argument, NULL, 'h' },                { 0 },
    };
    optind = 0;
    int c, code;
    while ((c = getopt_long(argc, argv, "o:fqh", opts, NULL)) != -1)
        if ((code = parse_option(c, a)))
            return code;
    if (optind != argc - 1 || !a->out || !a->probe) {
        if (optind == argc - 1 && a->out && !a->probe)
            fprintf(stderr, "sunprobe " CMD ": --probe PROBE_DIR is required (run `sunprobe probe %s -o DIR` first)\n",
                    argv[optind]);
        else
            usage(stderr);
        return SP_EXIT_USAGE;
    }
    a->capture = argv[optind];
    return 0;
}

/* Person-shaped: tall and narrow, off the border, and (where the plane answers) about a person's height. */
static int person_like(const cut_run *r, const sp_depop_object *o)
{
    if (o->y1 - o->y0 + 1 < (int)r->a->min_height || !depop_person_shaped(o) || o->x0 <= 0 || o->y0 <= 0 ||
        o->x1 >= (int)r->pd.width - 1 || o->y1 >= (int)r->pd.height - 1)
        return 0;
    double ph = sp_probe_plane_height(&r->pd.plane, 0.5 * (o->x0 + o->x1), o->y1);
    return !isfinite(ph) || fabs(o->y1 - o->y0 + 1 - ph) <= 0.25 * ph;
}

/* The object's box with one pixel around it as RGBA, alpha 255 on its own pixels (mask 1), 0 elsewhere. */
static int write_cutout(cut_run *r, const sp_depop_object *o, uint64_t frame, unsigned k)
{
    int W = (int)r->pd.width, H = (int)r->pd.height;
    int x0 = o->x0 - 1, y0 = o->y0 - 1, w = o->x1 - o->x0 + 3, h = o->y1 - o->y0 + 3;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int X = x0 + x, Y = y0 + y, in = X >= 0 && Y >= 0 && X < W && Y < H;
            size_t i = in ? (size_t)Y * W + X : 0;
            uint8_t *d = r->crop + 4 * ((size_t)y * w + x);
            int on = in && r->mask[i] == 1 && X >= o->x0 && X <= o->x1 && Y >= o->y0 && Y <= o->y1;
            memcpy(d, in ? r->rgb + 3 * i : (const uint8_t[3]){ 0, 0, 0 }, 3);
            d[3] = on ? 255 : 0;
        }
    sp_cutout_meta m = { .height_px = o->y1 - o->y0 + 1, .foot_x = 0.5 * (w - 1), .foot_y = h - 2, .light = r->light };
    snprintf(m.image, sizeof(m.image), "person_%06llu_%02u.png", (unsigned long long)frame, k);
    char *png = sp_path_join_alloc(r->dir, m.image), src[128], side[sizeof(m.image)];
    int ret = png ? sp_png_write(png, r->crop, (uint32_t)w, (uint32_t)h, (uint32_t)w * 4, 4) : -ENOMEM;
    snprintf(src, sizeof(src), "frame %llu, box %d,%d,%d,%d", (unsigned long long)frame, o->x0, o->y0,
             o->x1 - o->x0 + 1, o->y1 - o->y0 + 1);
    snprintf(side, sizeof(side), "person_%06llu_%02u.json", (unsigned long long)frame, k);
    char *json = sp_path_join_alloc(r->dir, side);
    sp_strbuf b = { 0 };
    sp_cutout_meta_json(&m, src, &b);
    if (!ret)
        ret = b.failed || !json ? -ENOMEM : sp_write_whole_file_atomic(json, b.data, b.len);
    sp_strbuf_free(&b);
    free(png), free(json);
    r->written += !ret;
    return ret;
}

static int frame_cutouts(cut_run *r, const sp_chunk *ch)
{
    sp_frame_chunk fc;
    int ret = sp_chunk_parse_frame(ch, &fc);
    if (ret || fc.stream_id != 0 || r->frames++ % r->a->every)
        return ret;
    if (fc.width != r->pd.width || fc.height != r->pd.height) {
        fprintf(stderr, "sunprobe " CMD ": %s is %ux%u, the probe %s %ux%u\n", r->a->capture, fc.width, fc.height,
                r->a->probe, r->pd.width, r->pd.height);
        return SP_EFORMAT;
    }
    sp_pixconv_src src = { fc.format, fc.width, fc.height, fc.stride, fc.data, fc.data_size };
    size_t np = (size_t)fc.width * fc.height, n = 0, kept = 0;
    sp_depop_object obj[MAX_PER_FRAME];
    if ((ret = sp_pixconv_to_rgb24(&src, r->rgb, np * 3, fc.width * 3)))
        return ret;
    memset(r->mask, 0, np);
    ret = sp_depop_from_plate(r->rgb, r->pd.clean_plate, fc.width, fc.height, &r->pd.plane, NULL, 0, obj,
                              MAX_PER_FRAME, &n, &kept, r->mask);
    r->segmented++;
    for (size_t i = 0; !ret && i < n && i < MAX_PER_FRAME && r->written < r->a->max; i++)
        if (person_like(r, &obj[i]))
            ret = write_cutout(r, &obj[i], r->frames - 1, (unsigned)i);
    return ret;
}

static int run(cut_run *r, sp_capture_reader *cr)
{
    sp_chunk ch;
    int ret;
    while (r->written < r->a->max && (ret = sp_capture_reader_next(cr, &ch)) == 0) {
        if (ch.type == SP_CHUNK_FRAME && (ret = frame_cutouts(r, &ch)))
            return ret == SP_EFORMAT ? SP_EXIT_BAD_INPUT
                                     : sp_cmd_fail(CMD, ret, sp_err_is_write(ret) ? r->a->out : r->a->capture);
        if (sp_cmd_stop_signal)
            return sp_cmd_stopped_code(SP_EXIT_OK);
    }
    if (r->written < r->a->max && ret != SP_EOS)
        return sp_tool_capture_error(CMD, r->a->capture, ret, ch.offset);
    if (!r->written) {
        fprintf(stderr, "sunprobe " CMD ": no person-shaped object in the %u frames segmented of %s; nothing written\n",
                r->segmented, r->a->capture);
        return SP_EXIT_BAD_INPUT;
    }
    return 0;
}

static void scene_light(cut_run *r)
{
    sp_depop_camera cam = r->a->have_cam ? r->a->cam : depop_assumed_camera(r->pd.width, r->pd.height);
    sp_depop_sun e = { 0 };
    sp_repop_sun_from_model(&r->pd.shadow, &r->pd.plane, r->pd.width, r->pd.height, &cam, &e);
    r->light.sky = e.found ? SP_REPOP_SUNNY : SP_REPOP_OVERCAST;
    r->light.sun_az_deg = e.azimuth_deg, r->light.sun_el_deg = e.elevation_deg;
    if (sp_repop_ground_light(r->pd.clean_plate, r->pd.width, r->pd.height, NULL, r->light.ground_rgb))
        memset(r->light.ground_rgb, 0, sizeof(r->light.ground_rgb));
}

static int cutouts(const cut_args *a)
{
    cut_run r = { .a = a };
    sp_capture_reader *cr = NULL;
    sp_partial pd = { 0 };
    sp_cmd_signals sig;
    int caught = 0;
    int ret = sp_probe_dir_load(a->probe, &r.pd), code = ret ? sp_cmd_fail(CMD, ret, a->probe) : 0;
    if (!code)
        code = sp_tool_open_capture(CMD, a->capture, 0, &cr);
    size_t np = code ? 0 : (size_t)r.pd.width * r.pd.height;
    if (!code) {
        r.rgb = malloc(np * 3), r.mask = malloc(np), r.crop = malloc((np + 4 * (r.pd.width + r.pd.height + 4)) * 4);
        if (!r.rgb || !r.mask || !r.crop)
            code = sp_cmd_fail(CMD, -ENOMEM, "frame buffers");
    }
    if (!code) { /* held from before the partial dir exists through the commit: a signal removes it */
        sp_cmd_catch_signals(&sig);
        caught = 1;
    }
    if (!code && (ret = sp_partial_dir_open(&pd, a->out)))
        code = sp_cmd_fail(CMD, ret, a->out);
    if (!code) {
        r.dir = pd.path;
        scene_light(&r);
        code = run(&r, cr);
    }
    if (!code && sp_cmd_stop_signal)
        code = sp_cmd_fail(CMD, -ECANCELED, a->out);
    if (!code && (ret = sp_partial_dir_commit(&pd, a->force ? SP_PARTIAL_REPLACE : 0)))
        code = ret == -EEXIST ? (fprintf(stderr, "sunprobe " CMD ": %s exists (use --force to replace it)\n", a->out),
                                 sp_exit_for_error(ret))
                              : sp_cmd_fail(CMD, ret, a->out);
    if (code)
        sp_partial_dir_abort(&pd);
    else if (!a->quiet)
        printf("%s: %u cut-out(s) from %u frames segmented; light %s\n", a->out, r.written, r.segmented,
               r.light.sky == SP_REPOP_SUNNY ? "sunny (the probe's shadow model)" : "overcast (no shadow model)");
    if (caught) /* after the commit: a late signal no longer matters */
        sp_cmd_restore_signals(&sig);
    sp_capture_reader_close(&cr);
    if (r.pd.clean_plate)
        sp_probe_dir_free(&r.pd);
    free(r.rgb), free(r.mask), free(r.crop);
    return code;
}

int sp_cmd_cutouts(int argc, char **argv)
{
    cut_args a = { .every = 10, .max = 50, .min_height = 24 };
    int code = parse_args(argc, argv, &a);
    if (code)
        return code < 0 ? SP_EXIT_OK : code;
    return cutouts(&a);
}
