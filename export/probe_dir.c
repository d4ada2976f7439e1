/* SPDX-License-Identifier: MIT */
#include "probe_dir.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/atomic_file.h"
#include "common/file_util.h"
#include "export/legend.h"
#include "export/png.h"
#include "export/png_read.h"
#include "sp_config.h"
#if HAVE_OPENIMAGEIO
#include "export/oiio_shim.h"
#endif

/* ---- PFM ---- */

int sp_pfm_write(const char *path, const float *v, uint32_t width, uint32_t height, int channels)
{
    if (!path || !v || !width || !height || (channels != 1 && channels != 3))
        return -EINVAL;
    sp_atomic_file af;
    int ret = sp_atomic_file_open(&af, path);
    if (ret)
        return ret;
    fprintf(af.file, "%s\n%u %u\n-1.0\n", channels == 3 ? "PF" : "Pf", width, height);
    size_t row = (size_t)width * (size_t)channels;
    uint8_t *buf = malloc(row * 4);
    if (!buf)
        ret = -ENOMEM;
    for (uint32_t y = height; !ret && y-- > 0;) { /* PFM stores the bottom row first */
        for (size_t i = 0; i < row; i++) {
            uint32_t bits;
            memcpy(&bits, &v[(size_t)y * row + i], 4);
            for (int b = 0; b < 4; b++)
                buf[4 * i + (size_t)b] = (uint8_t)(bits >> (8 * b));
        }
        if (fwrite(buf, 4, row, af.file) != row)
            ret = sp_write_error();
    }
    free(buf);
    return sp_atomic_file_finish(&af, ret);
}

static int pfm_header(FILE *f, uint32_t *w, uint32_t *h, int *channels, int *little)
{
    char magic[3] = { 0 };
    double scale;
    unsigned long ww, hh;
    if (fread(magic, 1, 2, f) != 2 || magic[0] != 'P' || (magic[1] != 'F' && magic[1] != 'f'))
        return SP_EFORMAT;
    if (fscanf(f, "%lu %lu %lf", &ww, &hh, &scale) != 3 || fgetc(f) == EOF)
        return SP_ECORRUPT;
    if (ww == 0 || hh == 0 || ww > 16384 || hh > 16384 || !isfinite(scale) || scale == 0)
        return SP_ECORRUPT;
    *w = (uint32_t)ww, *h = (uint32_t)hh;
    *channels = magic[1] == 'F' ? 3 : 1;
    *little = scale < 0;
    return 0;
}

int sp_pfm_read(const char *path, float **v, uint32_t *width, uint32_t *height, int *channels)
{
    if (!path || !v || !width || !height || !channels)
        return -EINVAL;
    FILE *f = fopen(path, "rb");
    if (!f)
        return -errno;
    uint32_t w = 0, h = 0;
    int ch = 0, little = 1, ret = pfm_header(f, &w, &h, &ch, &little);
    size_t row = (size_t)w * (size_t)ch;
    float *out = ret ? NULL : malloc(row * h * sizeof(float));
    uint8_t *buf = ret ? NULL : malloc(row * 4);
    if (!ret && (!out || !buf))
        ret = -ENOMEM;
    for (uint32_t y = h; !ret && y-- > 0;) {
        if (fread(buf, 4, row, f) != row) {
            ret = SP_ETRUNCATED;
            break;
        }
        for (size_t i = 0; i < row; i++) {
            uint32_t bits = 0;
            for (int b = 0; b < 4; b++)
                bits |= (uint32_t)buf[4 * i + (size_t)(little ? b : 3 - b)] << (8 * b);
            memcpy(&out[(size_t)y * row + i], &bits, 4);
            if (!isfinite(out[(size_t)y * row + i]))
                ret = SP_ECORRUPT;
        }
    }
    fclose(f);
    free(buf);
    if (ret) {
        free(out);
        return ret;
    }
    *v = out, *width = w, *height = h, *channels = ch;
    return 0;
}

/* ---- writing a probe directory ---- */

/* Occluding pixels coloured by the row their bottom is at (far, high in the image: blue; near: red). */
static void occlusion_colour(double z, uint8_t rgb[3], const void *ctx)
{
    const sp_probe_maps *m = ctx;
    double t = z / (m->height > 1 ? m->height - 1 : 1);
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    rgb[0] = (uint8_t)lrint(255 * t), rgb[1] = 96, rgb[2] = (uint8_t)lrint(255 * (1 - t));
}

static void occlusion_preview(const sp_probe_maps *m, uint8_t *rgb)
{
    for (size_t i = 0; i < (size_t)m->width * m->height; i++) {
        if (m->occlusion[i] < 0)
            rgb[3 * i] = rgb[3 * i + 1] = rgb[3 * i + 2] = 24;
        else
            occlusion_colour(m->occlusion[i], rgb + 3 * i, m);
    }
}

/* Confidence from 0 black (nothing seen there) to 1 white. */
static void confidence_colour(double c, uint8_t rgb[3], const void *ctx)
{
    (void)ctx;
    c = c < 0 ? 0 : c > 1 ? 1 : c;
    rgb[0] = rgb[1] = rgb[2] = (uint8_t)lrint(255 * c);
}

static void confidence_preview(const sp_probe_maps *m, uint8_t *rgb)
{
    for (size_t i = 0; i < (size_t)m->width * m->height; i++)
        confidence_colour((double)m->occlusion_confidence[i], rgb + 3 * i, NULL);
}

/* Relative lighting 1.0 at 128 gray. */
static uint8_t lighting_level(double v)
{
    v *= 128.0;
    return (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : lrint(v));
}

static void lighting_colour(double v, uint8_t rgb[3], const void *ctx)
{
    (void)ctx;
    rgb[0] = rgb[1] = rgb[2] = lighting_level(v);
}

static void lighting_preview(const sp_probe_maps *m, uint8_t *rgb)
{
    for (size_t i = 0; i < (size_t)m->width * m->height * 3; i++)
        rgb[i] = lighting_level((double)m->lighting[i]);
}

/* A preview with its legend (export/legend.h) under it, written as PNG. */
static int write_preview(const char *path, const uint8_t *rgb, const sp_probe_maps *m, const sp_legend *lg)
{
    uint8_t *img = NULL;
    uint32_t h = 0;
    int ret = sp_legend_image(rgb, m->width, m->height, lg, &img, &h);
    if (!ret)
        ret = sp_png_write(path, img, m->width, h, m->width * 3, 3);
    free(img);
    return ret;
}

static int write_params(const char *dir, const sp_probe *p, const sp_probe_maps *m)
{
    sp_probe_plane plane;
    sp_probe_shadow shadow;
    sp_probe_stats stats;
    char *json = NULL, *path = sp_path_join_alloc(dir, "probe.json");
    int ret = path ? 0 : -ENOMEM;
    if (!ret)
        ret = sp_probe_get_plane(p, &plane);
    if (!ret)
        ret = sp_probe_get_shadow(p, &shadow);
    if (!ret)
        ret = sp_probe_get_stats(p, &stats);
    if (!ret)
        ret = sp_probe_params_to_json(&plane, &shadow, &stats, m->width, m->height, &json);
    if (!ret)
        ret = sp_write_whole_file_atomic(path, json, strlen(json));
    free(json);
    free(path);
    return ret;
}

/* The float maps as OpenEXR too, where OpenImageIO is built (-Dopenimageio). */
static int write_exr_maps(const char *dir, const sp_probe_maps *m)
{
#if HAVE_OPENIMAGEIO
    char *occ = sp_path_join_alloc(dir, "occlusion.exr"), *light = sp_path_join_alloc(dir, "lighting.exr");
    int ret = occ && light ? sp_exr_write(occ, m->occlusion, m->width, m->height, 1) : -ENOMEM;
    if (!ret)
        ret = sp_exr_write(light, m->lighting, m->width, m->height, 3);
    free(occ);
    free(light);
    return ret;
#else
    (void)dir, (void)m;
    return 0;
#endif
}

int sp_probe_dir_write(const char *dir, const sp_probe *p)
{
    if (!dir || !p)
        return -EINVAL;
    sp_probe_maps m;
    int ret = sp_probe_get_maps(p, &m);
    if (ret)
        return ret;
    static const char *const names[7] = {
        "clean_plate.png",          "occlusion.pfm",           "occlusion.png", "lighting.pfm", "lighting.png",
        "occlusion_confidence.pfm", "occlusion_confidence.png"
    };
    char *path[7] = { 0 };
    uint8_t *rgb = malloc((size_t)m.width * m.height * 3);
    for (int i = 0; i < 7; i++)
        if (!(path[i] = sp_path_join_alloc(dir, names[i])))
            ret = -ENOMEM;
    if (!rgb)
        ret = -ENOMEM;
    if (!ret)
        ret = sp_png_write(path[0], m.clean_plate, m.width, m.height, m.width * 3, 3);
    if (!ret)
        ret = sp_pfm_write(path[1], m.occlusion, m.width, m.height, 1);
    if (!ret) {
        occlusion_preview(&m, rgb);
        sp_legend lg = { .title = "OCCLUDER: HIDES PEOPLE WITH FEET ABOVE ROW (PX)", .v0 = 0, .v1 = m.height - 1,
                         .ticks = 5, .decimals = 0, .colour = occlusion_colour, .ctx = &m,
                         .none_label = "NEVER OCCLUDES", .none_rgb = { 24, 24, 24 } };
        ret = write_preview(path[2], rgb, &m, &lg);
    }
    if (!ret)
        ret = sp_pfm_write(path[3], m.lighting, m.width, m.height, 3);
    if (!ret) {
        lighting_preview(&m, rgb);
        sp_legend lg = { .title = "LIGHTING RELATIVE TO THE MEAN OBJECT, PER CHANNEL", .v0 = 0, .v1 = 2, .ticks = 5,
                         .decimals = 1, .colour = lighting_colour, .none_label = "BLACK: NOBODY PASSED" };
        ret = write_preview(path[4], rgb, &m, &lg);
    }
    if (!ret)
        ret = sp_pfm_write(path[5], m.occlusion_confidence, m.width, m.height, 1);
    if (!ret) {
        confidence_preview(&m, rgb);
        sp_legend lg = { .title = "EVIDENCE FOR THE OCCLUSION VALUE: SHARE OF EVENTS THAT AGREE",
                         .v0 = 0,
                         .v1 = 1,
                         .ticks = 5,
                         .decimals = 2,
                         .colour = confidence_colour };
        ret = write_preview(path[6], rgb, &m, &lg);
    }
    if (!ret)
        ret = write_exr_maps(dir, &m);
    if (!ret) /* last: a directory with probe.json is complete */
        ret = write_params(dir, p, &m);
    for (int i = 0; i < 7; i++)
        free(path[i]);
    free(rgb);
    return ret;
}

/* ---- loading ---- */

/* A params file is small: anything over 16 MiB is not one. */
static int read_text(const char *path, char **out, size_t *len)
{
    void *buf = NULL;
    int ret = sp_read_whole_file(path, (size_t)1 << 24, &buf, len);
    if (ret)
        return ret == -EFBIG ? SP_ECORRUPT : ret;
    *out = buf;
    return 0;
}

static int load_map(const char *dir, const char *name, int want_ch, const sp_probe_dir *d, float **out)
{
    char *path = sp_path_join_alloc(dir, name);
    if (!path)
        return -ENOMEM;
    uint32_t w, h;
    int ch, ret = sp_pfm_read(path, out, &w, &h, &ch);
    free(path);
    if (!ret && (w != d->width || h != d->height || ch != want_ch)) {
        free(*out);
        *out = NULL;
        ret = SP_ECORRUPT;
    }
    return ret;
}

/* A map older directories lack: absent leaves *out NULL; present, it must be whole. */
static int load_optional_map(const char *dir, const char *name, const sp_probe_dir *d, float **out)
{
    int ret = load_map(dir, name, 1, d, out);
    return ret == -ENOENT ? 0 : ret;
}

static int load_plate(const char *dir, sp_probe_dir *d)
{
    char *path = sp_path_join_alloc(dir, "clean_plate.png");
    uint8_t *rgba = NULL;
    uint32_t w, h;
    int ret = path ? sp_png_read_rgba(path, &rgba, &w, &h) : -ENOMEM;
    free(path);
    if (!ret && (w != d->width || h != d->height))
        ret = SP_ECORRUPT;
    if (!ret && !(d->clean_plate = malloc((size_t)w * h * 3)))
        ret = -ENOMEM;
    for (size_t i = 0; !ret && i < (size_t)w * h; i++)
        memcpy(d->clean_plate + 3 * i, rgba + 4 * i, 3);
    free(rgba);
    return ret;
}

int sp_probe_dir_load(const char *dir, sp_probe_dir *d)
{
    if (!dir || !d)
        return -EINVAL;
    memset(d, 0, sizeof(*d));
    char *path = sp_path_join_alloc(dir, "probe.json"), *json = NULL;
    size_t len = 0;
    int ret = path ? read_text(path, &json, &len) : -ENOMEM;
    free(path);
    if (!ret)
        ret = sp_probe_params_from_json(json, len, &d->plane, &d->shadow, &d->width, &d->height);
    free(json);
    if (!ret)
        ret = load_map(dir, "occlusion.pfm", 1, d, &d->occlusion);
    if (!ret)
        ret = load_map(dir, "lighting.pfm", 3, d, &d->lighting);
    if (!ret)
        ret = load_optional_map(dir, "occlusion_confidence.pfm", d, &d->occlusion_confidence);
    if (!ret)
        ret = load_plate(dir, d);
    if (ret)
        sp_probe_dir_free(d);
    return ret;
}

void sp_probe_dir_free(sp_probe_dir *d)
{
    if (!d)
        return;
    free(d->clean_plate);
    free(d->occlusion);
    free(d->lighting);
    free(d->occlusion_confidence);
    memset(d, 0, sizeof(*d));
}

sp_probe_maps sp_probe_dir_maps(const sp_probe_dir *d)
{
    return (sp_probe_maps){ d->width, d->height, d->clean_plate, d->occlusion, d->lighting, d->occlusion_confidence };
}
