/* SPDX-License-Identifier: MIT */
/* `sunprobe relight FACE_DIR --sun AZ,EL [--env FILE] -o out.png`: renders a fitted face under new light. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd.h"
#include "export/png.h"
#include "sunprobe/sp_render.h"
#include "sunprobe/sp_sunstage.h"

typedef struct relight_args {
    const char *dir, *out, *env;
    double az, el, intensity, exposure;
    int have_sun, scale;
} relight_args;

static void relight_usage(FILE *out)
{
    fprintf(out, "usage: sunprobe relight FACE_DIR --sun AZ,EL [--env FILE] -o OUT.png\n\n"
                 "Renders the fitted face (keyframe 0's view) under a new sun and sky.\n"
                 "  --sun AZ,EL        sun azimuth (from world +x towards +y) and elevation, degrees\n"
                 "  --intensity I      sun irradiance (default: the fitted one, 3 if the fit had no sun)\n"
                 "  --env FILE         16x32 RGB float32 environment map (raw, as env.f32); default: fitted\n"
                 "  --exposure E       exposure (default 1)\n"
                 "  --scale N          output size as a multiple of the fit resolution (default 2)\n");
}

static int parse_relight(int argc, char **argv, relight_args *a)
{
    static const struct option opts[] = {
        { "help", no_argument, NULL, 'h' }, { "output", required_argument, NULL, 'o' },
        { "sun", required_argument, NULL, 's' }, { "env", required_argument, NULL, 'e' },
        { "intensity", required_argument, NULL, 'i' }, { "exposure", required_argument, NULL, 'x' },
        { "scale", required_argument, NULL, 'S' }, { 0 },
    };
    int c, bad = 0;
    char *end;
    while (!bad && (c = getopt_long(argc, argv, "ho:", opts, NULL)) != -1) {
        switch (c) {
        case 'h': relight_usage(stdout); return 1;
        case 'o': a->out = optarg; break;
        case 's':
            bad = sscanf(optarg, "%lf,%lf", &a->az, &a->el) != 2 || !(fabs(a->az) <= 720.0) ||
                  !(a->el >= -90.0 && a->el <= 90.0);
            a->have_sun = 1;
            break;
        case 'e': a->env = optarg; break;
        case 'i': a->intensity = strtod(optarg, &end); bad = *end || !(a->intensity >= 0.0 && a->intensity < 1e6); break;
        case 'x': a->exposure = strtod(optarg, &end); bad = *end || !(a->exposure >= 0.0 && a->exposure < 1e6); break;
        case 'S': a->scale = (int)strtol(optarg, &end, 10); bad = *end || a->scale < 1 || a->scale > 8; break;
        default: bad = 1;
        }
    }
    if (bad || optind != argc - 1 || !a->out || !a->have_sun) {
        fprintf(stderr, "sunprobe relight: expected FACE_DIR, --sun AZ,EL and -o OUT.png (see --help)\n");
        return -1;
    }
    a->dir = argv[optind];
    return 0;
}

static int read_env(const char *path, float *env)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return -errno;
    size_t n = fread(env, sizeof(float), SP_RENDER_ENV_FLOATS, f);
    int extra = fgetc(f) != EOF;
    fclose(f);
    if (n != SP_RENDER_ENV_FLOATS || extra)
        return SP_EFORMAT;
    for (int i = 0; i < SP_RENDER_ENV_FLOATS; i++)
        if (!isfinite(env[i]) || env[i] < 0.0f)
            return SP_ECORRUPT;
    return 0;
}

static int render_to_png(const relight_args *a, const sp_face_asset *fa)
{
    sp_renderer_settings rs;
    sp_renderer_default_settings(&rs);
    rs.width = fa->width * a->scale;
    rs.height = fa->height * a->scale;
    rs.supersample = 2;
    sp_renderer *r = NULL;
    int ret = sp_renderer_open(&r, &rs);
    if (ret)
        return ret;
    sp_render_scene sc;
    sp_render_scene_defaults(&sc);
    sc.camera = fa->camera;
    sc.camera.fx *= a->scale;
    sc.camera.fy *= a->scale;
    sc.camera.cx = (fa->camera.cx + 0.5) * a->scale - 0.5;
    sc.camera.cy = (fa->camera.cy + 0.5) * a->scale - 0.5;
    sc.mesh = &fa->mesh;
    sc.albedo = (sp_render_texture){ fa->tex_width, fa->tex_height, fa->albedo };
    sc.displacement = (sp_render_texture){ fa->tex_width, fa->tex_height, fa->displacement };
    sc.clusters = (sp_render_cluster_map){ fa->cluster_width, fa->cluster_height, fa->clusters };
    memcpy(sc.ks, fa->ks, sizeof(sc.ks));
    memcpy(sc.shininess, fa->shininess, sizeof(sc.shininess));
    sc.env = fa->env;
    double az = a->az * M_PI / 180.0, el = a->el * M_PI / 180.0;
    sc.sun_dir[0] = cos(el) * cos(az);
    sc.sun_dir[1] = cos(el) * sin(az);
    sc.sun_dir[2] = sin(el);
    sc.sun_intensity = a->intensity > 0.0 ? a->intensity : (fa->sun_intensity > 0.0 ? fa->sun_intensity : 3.0);
    sc.exposure = a->exposure > 0.0 ? a->exposure : 1.0;
    sp_render_outputs o;
    if (!(ret = sp_render(r, &sc, &o))) {
        size_t n = (size_t)o.width * (size_t)o.height * 3;
        uint8_t *px = malloc(n);
        if (!px)
            ret = -ENOMEM;
        for (size_t i = 0; px && i < n; i++)
            px[i] = (uint8_t)lround(255.0 * fmin(1.0, fmax(0.0, (double)o.image[i])));
        if (px)
            ret = sp_png_write(a->out, px, (uint32_t)o.width, (uint32_t)o.height, (uint32_t)o.width * 3, 3);
        free(px);
    }
    sp_renderer_close(&r);
    return ret;
}

int sp_cmd_relight(int argc, char **argv)
{
    relight_args a = { .scale = 2 };
    int p = parse_relight(argc, argv, &a);
    if (p)
        return p > 0 ? SP_EXIT_OK : SP_EXIT_USAGE;
    sp_face_asset fa;
    int ret = sp_face_dir_read(&fa, a.dir);
    if (ret) {
        fprintf(stderr, "sunprobe relight: %s is not a readable face directory: %s\n", a.dir, sp_strerror(ret));
        return sp_exit_for_error(ret == -ENOENT ? SP_EFORMAT : ret);
    }
    if (a.env && (ret = read_env(a.env, fa.env))) {
        sp_face_asset_free(&fa);
        return sp_cmd_fail("relight", ret, "reading --env (16x32x3 float32, non-negative)");
    }
    ret = render_to_png(&a, &fa);
    sp_face_asset_free(&fa);
    if (ret)
        return sp_cmd_fail("relight", ret, "rendering");
    printf("relight: wrote %s\n", a.out);
    return SP_EXIT_OK;
}
