/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe retexture PROBE_DIR --texture TEX.png -o OUT.png`: the probed
 * scene's clean plate with its ground replaced by a texture laid on the ground
 * plane in perspective, multiplied by the plate's own shading so shadows stay
 * (pipeline/probe/RETEXTURE.md). Refused inputs leave no output.
 */
#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd.h"
#include "common/file_util.h"
#include "export/png.h"
#include "export/png_read.h"
#include "export/probe_dir.h"
#include "pipeline/probe/retexture.h"

typedef struct retexture_args {
    const char *dir, *texture, *mask, *out;
    sp_retexture_settings s;
    int force, quiet;
} retexture_args;

static void usage(FILE *out)
{
    fprintf(out, "usage: sunprobe retexture PROBE_DIR --texture TEX.png -o OUT.png [options]\n\n"
                 "Replaces the ground of a probed scene's clean plate with a texture laid on the ground plane\n"
                 "in perspective (its size on screen from the probe's plane model: it shrinks with distance),\n"
                 "multiplied by the plate's own shading (its low-passed colour over the lit ground's), so the\n"
                 "shadows stay. The texture repeats: make it with `sunprobe texture --tileable`.\n\n"
                 "options:\n"
                 "      --texture PNG     the new ground texture (required)\n"
                 "  -o, --output PNG      the result (made under a .partial name, renamed when complete)\n"
                 "      --metres M        the texture's width on the ground, 0.01..1000 (default 1)\n"
                 "      --focal PX        focal length in pixels (default: the image width, ~53 deg across)\n"
                 "      --shading-m M     the shading's low-pass radius on the ground, 0..10 m (default 0.15)\n"
                 "      --mask PNG        replace only where this image (the plate's size) is not black;\n"
                 "                        default: below the horizon where nobody was ever seen hidden\n"
                 "  -f, --force           replace an existing OUT\n"
                 "  -q, --quiet           no summary\n");
}

enum { OPT_TEXTURE = 256, OPT_METRES, OPT_FOCAL, OPT_SHADING, OPT_MASK };

static int parse_option(int c, retexture_args *a)
{
    switch (c) {
    case OPT_TEXTURE: a->texture = optarg; return 0;
    case OPT_MASK: a->mask = optarg; return 0;
    case OPT_METRES: return sp_opt_double("retexture", "metres", optarg, 0.01, 1000, &a->s.metres) ? SP_EXIT_USAGE : 0;
    case OPT_FOCAL: return sp_opt_double("retexture", "focal", optarg, 1, 1e6, &a->s.focal_px) ? SP_EXIT_USAGE : 0;
    case OPT_SHADING:
        return sp_opt_double("retexture", "shading-m", optarg, 0, 10, &a->s.shading_m) ? SP_EXIT_USAGE : 0;
    case 'o': a->out = optarg; return 0;
    case 'f': a->force = 1; return 0;
    case 'q': a->quiet = 1; return 0;
    case 'h': usage(stdout); return -1;
    default: usage(stderr); return SP_EXIT_USAGE;
    }
}

static int parse_args(int argc, char **argv, retexture_args *a)
{
    static const struct option opts[] = {
        { "texture", required_argument, NULL, OPT_TEXTURE }, { "metres", required_argument, NULL, OPT_METRES },
        { "focal", required_argument, NULL, OPT_FOCAL },     { "shading-m", required_argument, NULL, OPT_SHADING },
        { "mask", required_argument, NULL, OPT_MASK },       { "output", required_argument, NULL, 'o' },
        { "force", no_argument, NULL, 'f' },                 { "quiet", no_argument, NULL, 'q' },
        { "help", no_argument, NULL, 'h' },                  { 0 },
    };
    optind = 0;
    int c, code;
    while ((c = getopt_long(argc, argv, "o:fqh", opts, NULL)) != -1)
        if ((code = parse_option(c, a)))
            return code;
    if (optind != argc - 1 || !a->out || !a->texture) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    a->dir = argv[optind];
    return 0;
}

/* A PNG as float RGB in [0, 1]. */
static int load_texture(const char *path, float **rgb, uint32_t *w, uint32_t *h)
{
    uint8_t *rgba = NULL;
    int ret = sp_png_read_rgba(path, &rgba, w, h);
    if (ret)
        return ret;
    size_t n = (size_t)*w * *h;
    *rgb = malloc(sizeof(float) * 3 * (n ? n : 1));
    for (size_t i = 0; *rgb && i < n; i++)
        for (int c = 0; c < 3; c++)
            (*rgb)[3 * i + c] = (float)rgba[4 * i + c] / 255.0f;
    free(rgba);
    return *rgb ? 0 : -ENOMEM;
}

/* The region to replace: the mask's non-black pixels below the horizon, or the default ground. */
static int region_for(const retexture_args *a, const sp_probe_dir *d, uint8_t *region)
{
    int ret = sp_retexture_ground(&d->plane, a->mask ? NULL : d->occlusion, d->width, d->height, region);
    if (ret == SP_ENODATA && d->plane.status != SP_PROBE_PLANE_OK) {
        fprintf(stderr, "sunprobe retexture: %s/probe.json: no full ground plane (%s)\n", a->dir, d->plane.note);
        return SP_EXIT_BAD_INPUT;
    }
    if (ret && ret != SP_ENODATA)
        return sp_cmd_fail("retexture", ret, a->dir);
    if (!a->mask)
        return ret ? (fprintf(stderr, "sunprobe retexture: %s: no ground below the horizon\n", a->dir), SP_EXIT_BAD_INPUT) : 0;
    uint8_t *rgba = NULL;
    uint32_t w, h;
    if ((ret = sp_png_read_rgba(a->mask, &rgba, &w, &h)))
        return sp_cmd_fail("retexture", ret, a->mask);
    if (w != d->width || h != d->height) {
        fprintf(stderr, "sunprobe retexture: --mask %s: %ux%u, the probe's plate is %ux%u\n", a->mask, w, h,
                d->width, d->height);
        free(rgba);
        return SP_EXIT_BAD_INPUT;
    }
    for (size_t i = 0; i < (size_t)w * h; i++)
        region[i] &= rgba[4 * i] || rgba[4 * i + 1] || rgba[4 * i + 2];
    free(rgba);
    return 0;
}

static int write_out(const retexture_args *a, const uint8_t *rgb, uint32_t w, uint32_t h)
{
    int code = sp_cmd_refuse_existing("retexture", a->out, a->force);
    if (code)
        return code;
    sp_partial pf;
    int ret = sp_partial_file_open(&pf, a->out);
    if (!ret && (ret = sp_png_write(pf.path, rgb, w, h, w * 3, 3)) == 0)
        ret = sp_cmd_stop_signal ? -ECANCELED : sp_partial_file_commit(&pf, SP_PARTIAL_REPLACE);
    if (ret) {
        sp_partial_file_abort(&pf);
        return sp_cmd_fail("retexture", ret, a->out);
    }
    return SP_EXIT_OK;
}

static int run(const retexture_args *a, const sp_probe_dir *d, const float *tex, uint32_t tw, uint32_t th)
{
    size_t n = (size_t)d->width * d->height;
    uint8_t *region = malloc(n), *out = malloc(n * 3);
    int code = region && out ? region_for(a, d, region) : sp_cmd_fail("retexture", -ENOMEM, "the image");
    sp_retexture_report rep;
    int ret = code ? 0 : sp_retexture(d->clean_plate, d->width, d->height, &d->plane, region, tex, tw, th, &a->s, out, &rep);
    if (!code && ret == SP_ENODATA) {
        fprintf(stderr, "sunprobe retexture: %s: no ground pixel to replace (--mask %s)\n", a->dir,
                a->mask ? a->mask : "not given");
        code = SP_EXIT_BAD_INPUT;
    } else if (!code && ret)
        code = sp_cmd_fail("retexture", ret, "retexturing");
    if (!code)
        code = write_out(a, out, d->width, d->height);
    if (!code && !a->quiet)
        printf("%s: %llu ground pixels retextured; the texture is %.0f px/m near, %.1f px/m far; lit ground "
               "(linear) %.3f %.3f %.3f\n", a->out, (unsigned long long)rep.pixels, rep.near_px_per_m,
               rep.far_px_per_m, rep.lit[0], rep.lit[1], rep.lit[2]);
    free(region), free(out);
    return code;
}

int sp_cmd_retexture(int argc, char **argv)
{
    retexture_args a = { 0 };
    sp_retexture_default_settings(&a.s);
    int code = parse_args(argc, argv, &a);
    if (code)
        return code < 0 ? SP_EXIT_OK : code;
    sp_cmd_signals sig; /* a stop signal is acted on before OUT is committed; once it is, the run ends with 0 */
    sp_cmd_catch_signals(&sig);
    sp_probe_dir d;
    int ret = sp_probe_dir_load(a.dir, &d);
    if (ret) {
        sp_cmd_restore_signals(&sig);
        return sp_cmd_fail("retexture", ret, a.dir);
    }
    float *tex = NULL;
    uint32_t tw = 0, th = 0;
    if ((ret = load_texture(a.texture, &tex, &tw, &th)))
        code = sp_cmd_fail("retexture", ret, a.texture);
    else
        code = run(&a, &d, tex, tw, th);
    free(tex);
    sp_probe_dir_free(&d);
    sp_cmd_restore_signals(&sig);
    return code;
}
