/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe texture EXEMPLAR.png -o OUT.png --size WxH`: a texture of any size
 * like the exemplar (pipeline/texture/TEXTURE.md), written row by row as the
 * tiles finish, so memory does not grow with the size. The file is made under
 * "OUT.partial" and renamed when complete; on any failure (a full disk: exit 3)
 * the partial file is removed and whatever was at OUT stays.
 */
#include <errno.h>
#include <getopt.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cmd.h"
#include "common/file_util.h"
#include "export/oiio_shim.h"
#include "export/png.h"
#include "export/png_read.h"
#include "sp_config.h"
#include "sunprobe/sp_texture.h"

typedef struct texture_args {
    const char *in, *out;
    uint32_t width, height;
    sp_texture_settings s;
    int quiet, force, sized;
    int tiled;          /* OUT is .tif/.tiff/.exr: a tiled image through OpenImageIO */
} texture_args;

static void usage(FILE *out)
{
    fprintf(out,
            "usage: sunprobe texture EXEMPLAR.png -o OUT.png|.tif|.exr --size WxH [options]\n\n"
            "Synthesises a texture of any size that looks like the exemplar: multi-scale patch\n"
            "optimisation over random crops, each pixel the mean of the patch votes covering it, the\n"
            "finest level laid again in image-quilting blocks whose cuts are then optimised; made\n"
            "in tiles and written as they finish; memory does not grow with the size (the finished\n"
            "rows wait in a scratch file in $TMPDIR, else /tmp).\n"
            "The same seed gives the same image whatever the thread count.\n\n"
            "options:\n"
            "  -o, --output FILE     the texture: .png (row by row), or .tif / .exr (tiled, 8-bit / float;\n"
            "                        needs -Dopenimageio); made under a .partial name, renamed when complete\n"
            "      --size WxH        its size in pixels, each side %d..%u\n"
            "      --seed N          random seed (default 1)\n"
            "      --patch P         patch side, 4..32 (default 8)\n"
            "      --tile T          tile side, 8 patches..4096 (default 256)\n"
            "      --tileable        the result wraps left-right and top-bottom (sides >= 16 patches)\n"
            "      --iterations N    passes per pyramid level, 1..16 (default 3)\n"
            "      --reuse R         penalty on reusing one exemplar region, 0..10 (default 0.5)\n"
            "      --threads N       worker threads (default: every CPU; the result does not change)\n"
            "  -f, --force           replace an existing OUT\n"
            "  -q, --quiet           no summary\n",
            4, SP_TEXTURE_MAX_SIDE);
}

enum { OPT_SIZE = 256, OPT_SEED, OPT_PATCH, OPT_TILE, OPT_TILEABLE, OPT_ITER, OPT_REUSE, OPT_THREADS };

static int parse_option(int c, texture_args *a)
{
    uint64_t u;
    int w, h;
    switch (c) {
    case OPT_SIZE: /* 0 and sides over the limit are explained by check_sizes */
        if (sp_opt_size_in("texture", "size", optarg, 0, INT_MAX, &w, &h))
            return SP_EXIT_USAGE;
        a->width = (uint32_t)w, a->height = (uint32_t)h, a->sized = 1;
        return 0;
    case OPT_SEED:
        if (sp_opt_u64("texture", "seed", optarg, 0, UINT64_MAX, &u))
            return SP_EXIT_USAGE;
        a->s.seed = u;
        return 0;
    case OPT_PATCH: return sp_opt_int("texture", "patch", optarg, 4, 32, &a->s.patch) ? SP_EXIT_USAGE : 0;
    case OPT_TILE: return sp_opt_int("texture", "tile", optarg, 32, 4096, &a->s.tile) ? SP_EXIT_USAGE : 0;
    case OPT_TILEABLE: a->s.tileable = 1; return 0;
    case OPT_ITER: return sp_opt_int("texture", "iterations", optarg, 1, 16, &a->s.iterations) ? SP_EXIT_USAGE : 0;
    case OPT_REUSE: return sp_opt_double("texture", "reuse", optarg, 0, 10, &a->s.reuse) ? SP_EXIT_USAGE : 0;
    case OPT_THREADS: return sp_opt_int("texture", "threads", optarg, 1, 256, &a->s.threads) ? SP_EXIT_USAGE : 0;
    case 'o': a->out = optarg; return 0;
    case 'f': a->force = 1; return 0;
    case 'q': a->quiet = 1; return 0;
    case 'h': usage(stdout); return -1;
    default: usage(stderr); return SP_EXIT_USAGE;
    }
}

/* The sizes the options allow together, each refusal naming the option. */
static int check_sizes(const texture_args *a)
{
    uint32_t P = (uint32_t)a->s.patch, lo = a->s.tileable ? 16 * P : P;
    if (!a->width || !a->height) {
        fprintf(stderr, "sunprobe texture: --size %ux%u: a side of 0\n", a->width, a->height);
        return SP_EXIT_USAGE;
    }
    if (a->width > SP_TEXTURE_MAX_SIDE || a->height > SP_TEXTURE_MAX_SIDE) {
        fprintf(stderr, "sunprobe texture: --size %ux%u: over the limit of %u pixels a side\n", a->width,
                a->height, SP_TEXTURE_MAX_SIDE);
        return SP_EXIT_USAGE;
    }
    if (a->width < lo || a->height < lo) {
        fprintf(stderr, "sunprobe texture: --size %ux%u: each side must be at least %u (%s)\n", a->width,
                a->height, lo, a->s.tileable ? "16 patches for --tileable" : "the patch");
        return SP_EXIT_USAGE;
    }
    if (a->s.tile < 8 * a->s.patch) {
        fprintf(stderr, "sunprobe texture: --tile %d: at least 8 patches (%d) for --patch %d\n", a->s.tile,
                8 * a->s.patch, a->s.patch);
        return SP_EXIT_USAGE;
    }
    return 0;
}

static int parse_args(int argc, char **argv, texture_args *a)
{
    static const struct option opts[] = {
        { "output", required_argument, NULL, 'o' },        { "size", required_argument, NULL, OPT_SIZE },
        { "seed", required_argument, NULL, OPT_SEED },     { "patch", required_argument, NULL, OPT_PATCH },
        { "tile", required_argument, NULL, OPT_TILE },     { "tileable", no_argument, NULL, OPT_TILEABLE },
        { "iterations", required_argument, NULL, OPT_ITER }, { "reuse", required_argument, NULL, OPT_REUSE },
        { "threads", required_argument, NULL, OPT_THREADS }, { "force", no_argument, NULL, 'f' },
        { "quiet", no_argument, NULL, 'q' },               { "help", no_argument, NULL, 'h' },
        { 0 },
    };
    optind = 0;
    int c, code;
    while ((c = getopt_long(argc, argv, "o:fqh", opts, NULL)) != -1)
        if ((code = parse_option(c, a)))
            return code;
    if (optind != argc - 1 || !a->out || !a->sized) {
        if (optind == argc - 1 && a->out)
            fprintf(stderr, "sunprobe texture: --size WxH is required\n");
        else
            usage(stderr);
        return SP_EXIT_USAGE;
    }
    a->in = argv[optind];
    const char *dot = strrchr(a->out, '.');
    a->tiled = dot && (!strcmp(dot, ".tif") || !strcmp(dot, ".tiff") || !strcmp(dot, ".exr"));
    if (!dot || (strcmp(dot, ".png") && !a->tiled)) {
        fprintf(stderr, "sunprobe texture: -o %s: the output must be a .png, .tif, .tiff or .exr file\n", a->out);
        return SP_EXIT_USAGE;
    }
    if (a->tiled && !HAVE_OPENIMAGEIO) {
        fprintf(stderr, "sunprobe texture: -o %s: tiled TIFF and EXR need OpenImageIO; build with "
                        "-Dopenimageio=enabled, or write a .png\n", a->out);
        return SP_EXIT_DISABLED;
    }
    return check_sizes(a);
}

/* The exemplar as float RGB in [0, 1] (alpha is ignored): a PNG, or what OpenImageIO reads. */
static int load_exemplar(const texture_args *a, float **rgb, uint32_t *w, uint32_t *h)
{
    uint8_t *rgba = NULL;
    int ret = sp_png_read_rgba(a->in, &rgba, w, h);
#if HAVE_OPENIMAGEIO
    if (ret == SP_EFORMAT) { /* not a PNG: TIFF, EXR, JPEG... */
        if ((ret = sp_image_read_rgb(a->in, rgb, w, h)))
            return sp_cmd_fail("texture", ret, a->in);
        if (*w >= (uint32_t)a->s.patch && *h >= (uint32_t)a->s.patch)
            return 0;
        free(*rgb);
        fprintf(stderr, "sunprobe texture: %s: %ux%u is smaller than the %dx%d patch\n", a->in, *w, *h, a->s.patch,
                a->s.patch);
        return SP_EXIT_BAD_INPUT;
    }
#endif
    if (ret)
        return sp_cmd_fail("texture", ret, a->in);
    if (*w < (uint32_t)a->s.patch || *h < (uint32_t)a->s.patch) {
        fprintf(stderr, "sunprobe texture: %s: %ux%u is smaller than the %dx%d patch\n", a->in, *w, *h, a->s.patch,
                a->s.patch);
        free(rgba);
        return SP_EXIT_BAD_INPUT;
    }
    size_t n = (size_t)*w * *h;
    *rgb = malloc(n * 3 * sizeof(float));
    for (size_t i = 0; *rgb && i < n; i++)
        for (int c = 0; c < 3; c++)
            (*rgb)[3 * i + c] = (float)rgba[4 * i + c] / 255.0f;
    free(rgba);
    return *rgb ? 0 : sp_cmd_fail("texture", -ENOMEM, "the exemplar");
}

typedef struct png_sink {
    sp_png_stream *png;
    uint8_t *row;
    uint32_t width;
    sp_tiled_image *tiled;
} png_sink;

static int write_band(void *ctx, uint32_t y0, uint32_t n, const float *rgb)
{
    (void)y0;
    png_sink *k = ctx;
    if (sp_cmd_stop_signal)
        return -EINTR;
#if HAVE_OPENIMAGEIO
    if (k->tiled)
        return sp_tiled_rows(k->tiled, n, rgb);
#endif
    for (uint32_t y = 0; y < n; y++) {
        const float *r = rgb + (size_t)y * k->width * 3;
        for (size_t i = 0; i < (size_t)k->width * 3; i++) {
            float v = r[i] * 255.0f + 0.5f;
            k->row[i] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
        }
        int ret = sp_png_stream_rows(k->png, k->row, 1, k->width * 3);
        if (ret)
            return ret;
    }
    return 0;
}

#if HAVE_OPENIMAGEIO
/* Synthesises into a tiled image at path (tiles of the synthesis' size when a multiple of 16, else 64). */
static int synthesize_tiled(const texture_args *a, const char *path, const float *ex, uint32_t ew, uint32_t eh)
{
    png_sink k = { 0 };
    uint32_t tile = a->s.tile % 16 ? 64 : (uint32_t)a->s.tile;
    int ret = sp_tiled_open(&k.tiled, path, a->width, a->height, tile);
    if (!ret)
        ret = sp_texture_synthesize(ex, ew, eh, a->width, a->height, &a->s, write_band, &k);
    int fin = sp_tiled_close(&k.tiled);
    return ret ? ret : fin;
}
#endif

/* Synthesises into the open file f; 0 or an error (the caller removes the file). */
static int synthesize_to(const texture_args *a, FILE *f, const float *ex, uint32_t ew, uint32_t eh)
{
    png_sink k = { NULL, malloc((size_t)a->width * 3), a->width };
    int ret = k.row ? sp_png_stream_open(&k.png, f, a->width, a->height, 3) : -ENOMEM;
    if (!ret)
        ret = sp_texture_synthesize(ex, ew, eh, a->width, a->height, &a->s, write_band, &k);
    int fin = sp_png_stream_finish(&k.png);
    free(k.row);
    return ret ? ret : fin;
}

/* "OUT.tif.partial" becomes "OUT.tif.partial.tif". */
static int keep_extension(sp_partial *pf, const char *out)
{
    const char *dot = strrchr(out, '.');
    size_t n = strlen(pf->path), e = strlen(dot);
    char *p = realloc(pf->path, n + e + 1);
    if (!p)
        return -ENOMEM;
    memcpy(p + n, dot, e + 1);
    pf->path = p;
    return 0;
}

static int run(const texture_args *a, const float *ex, uint32_t ew, uint32_t eh)
{
    int code = sp_cmd_refuse_existing("texture", a->out, a->force);
    if (code)
        return code;
    sp_partial pf;
    int ret = sp_partial_file_open(&pf, a->out);
    if (ret)
        return sp_cmd_fail("texture", ret, a->out);
    if (a->tiled) /* OpenImageIO picks the format by the extension: the partial name keeps it */
        ret = keep_extension(&pf, a->out);
    FILE *f = ret ? NULL : fopen(pf.path, "wb");
    if (!f) {
        ret = ret ? ret : -errno;
        sp_partial_forget(&pf);
        return sp_cmd_fail("texture", ret, a->out);
    }
#if HAVE_OPENIMAGEIO
    ret = a->tiled ? synthesize_tiled(a, pf.path, ex, ew, eh) : synthesize_to(a, f, ex, ew, eh);
#else
    ret = synthesize_to(a, f, ex, ew, eh);
#endif
    if (!ret && (fflush(f) || fsync(fileno(f))))
        ret = sp_write_error();
    if (fclose(f) && !ret)
        ret = sp_write_error();
    if (!ret && sp_cmd_stop_signal) /* a signal after the last band: the old OUT stays */
        ret = -EINTR;
    if (!ret)
        ret = sp_partial_file_commit(&pf, SP_PARTIAL_REPLACE);
    if (ret) {
        sp_partial_file_abort(&pf);
        return sp_cmd_failf("texture", ret, "%s: writing the texture", a->out);
    }
    return SP_EXIT_OK;
}

int sp_cmd_texture(int argc, char **argv)
{
    texture_args a = { 0 };
    sp_texture_default_settings(&a.s);
    int code = parse_args(argc, argv, &a);
    if (code)
        return code < 0 ? SP_EXIT_OK : code;
    float *ex = NULL;
    uint32_t ew, eh;
    if ((code = load_exemplar(&a, &ex, &ew, &eh)))
        return code;
    sp_cmd_signals saved;
    sp_cmd_catch_signals(&saved);
    code = run(&a, ex, ew, eh);
    sp_cmd_restore_signals(&saved);
    free(ex);
    if (!code && !a.quiet)
        printf("%s: %ux%u texture from %s (%ux%u), seed %llu, patch %d, tile %d%s\n", a.out, a.width, a.height,
               a.in, ew, eh, (unsigned long long)a.s.seed, a.s.patch, a.s.tile, a.s.tileable ? ", tileable" : "");
    return code;
}
