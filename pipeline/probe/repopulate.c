/* SPDX-License-Identifier: MIT */
/*
 * Lighting descriptors and matching for repopulating a street from one image,
 * and the camera-plane geometry that scales inserted people and casts their
 * shadows (REPOPULATE.md). The geometry is depop_sun.c's camera, one camera
 * height above the ground, so no metric scale is needed.
 */
#include "repopulate.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/stats.h"

#define DEG (M_PI / 180.0)

static const char *const sky_names[] = { "unknown", "sunny", "overcast" };

void sp_cutout_meta_json(const sp_cutout_meta *m, const char *source, sp_strbuf *b)
{
    sp_strbuf_printf(b, "{\"format\":\"sunprobe-cutout\",\"version\":1,\"image\":");
    sp_strbuf_json_string(b, m->image);
    sp_strbuf_printf(b, ",\"height_px\":");
    sp_strbuf_json_number(b, m->height_px);
    if (m->height_m > 0)
        sp_strbuf_printf(b, ",\"height_m\":%.3f", m->height_m);
    double foot[2] = { m->foot_x, m->foot_y };
    sp_strbuf_printf(b, ",\"foot\":");
    sp_strbuf_json_numbers(b, foot, 2);
    sp_strbuf_printf(b, ",\"sky\":\"%s\"", sky_names[m->light.sky]);
    if (m->light.sky == SP_REPOP_SUNNY)
        sp_strbuf_printf(b, ",\"sun_azimuth_deg\":%.3f,\"sun_elevation_deg\":%.3f", m->light.sun_az_deg,
                         m->light.sun_el_deg);
    sp_strbuf_printf(b, ",\"ground_rgb\":");
    sp_strbuf_json_numbers(b, m->light.ground_rgb, 3);
    if (source) {
        sp_strbuf_printf(b, ",\"source\":");
        sp_strbuf_json_string(b, source);
    }
    sp_strbuf_printf(b, "}\n");
}

/* A number field that must be finite and within lo..hi; writes why into err otherwise. */
static int field(const sp_json *root, const char *key, size_t i, double lo, double hi, double *out, char *err,
                 size_t n)
{
    const sp_json *v = sp_json_get(root, key);
    if (v && v->type == SP_JSON_ARRAY)
        v = sp_json_at(v, i);
    if (!v || v->type != SP_JSON_NUMBER) {
        snprintf(err, n, "field \"%s\" is missing or not a number", key);
        return SP_ECORRUPT;
    }
    if (!isfinite(v->number) || v->number < lo || v->number > hi) {
        snprintf(err, n, "field \"%s\" is %g, expected %g..%g", key, v->number, lo, hi);
        return SP_ECORRUPT;
    }
    *out = v->number;
    return 0;
}

static int parse_light(const sp_json *root, sp_repop_light *l, char *err, size_t n)
{
    const char *sky = sp_json_string(sp_json_get(root, "sky"), NULL);
    int k = -1;
    for (int i = 0; sky && i < 3; i++)
        k = strcmp(sky, sky_names[i]) ? k : i;
    if (k < 0) {
        snprintf(err, n, "field \"sky\" must be \"sunny\", \"overcast\" or \"unknown\"");
        return SP_ECORRUPT;
    }
    l->sky = (sp_repop_sky)k;
    int ret = 0;
    if (l->sky == SP_REPOP_SUNNY)
        ret = field(root, "sun_azimuth_deg", 0, -360, 360, &l->sun_az_deg, err, n) ||
              field(root, "sun_elevation_deg", 0, 0, 90, &l->sun_el_deg, err, n);
    for (size_t c = 0; c < 3 && !ret && sp_json_get(root, "ground_rgb"); c++)
        ret = field(root, "ground_rgb", c, 0, 255, &l->ground_rgb[c], err, n);
    return ret ? SP_ECORRUPT : 0;
}

int sp_cutout_meta_parse(const char *json, size_t len, sp_cutout_meta *out, char *err, size_t n)
{
    sp_json *root = NULL;
    memset(out, 0, sizeof(*out));
    int ret = sp_json_parse(json, len, &root, err, n);
    if (ret)
        return SP_ECORRUPT;
    const char *img = sp_json_string(sp_json_get(root, "image"), NULL);
    if (root->type != SP_JSON_OBJECT || !img || !*img || strlen(img) >= sizeof(out->image) || strchr(img, '/')) {
        snprintf(err, n, "field \"image\" must name a PNG file beside the sidecar");
        ret = SP_ECORRUPT;
    } else {
        strcpy(out->image, img);
    }
    if (!ret &&
        (field(root, "height_px", 0, 1, 1e5, &out->height_px, err, n) ||
         field(root, "foot", 0, -1e5, 1e5, &out->foot_x, err, n) ||
         field(root, "foot", 1, -1e5, 1e5, &out->foot_y, err, n) || parse_light(root, &out->light, err, n) ||
         (sp_json_get(root, "height_m") && field(root, "height_m", 0, 0.2, 10, &out->height_m, err, n))))
        ret = SP_ECORRUPT;
    sp_json_free(root);
    return ret;
}

static void sun_vector(double az, double el, double v[3])
{
    v[0] = sin(az * DEG) * cos(el * DEG), v[1] = cos(az * DEG) * cos(el * DEG), v[2] = sin(el * DEG);
}

double sp_repop_match(const sp_repop_light *scene, const sp_repop_light *cut, double gain[3])
{
    if (gain) {
        int known = scene->ground_rgb[0] + scene->ground_rgb[1] + scene->ground_rgb[2] > 0 &&
                    cut->ground_rgb[0] > 0 && cut->ground_rgb[1] > 0 && cut->ground_rgb[2] > 0;
        for (int c = 0; c < 3; c++) {
            double g = known ? scene->ground_rgb[c] / cut->ground_rgb[c] : 1.0;
            gain[c] = g < 0.25 ? 0.25 : g > 4 ? 4 : g;
        }
    }
    if (scene->sky == SP_REPOP_UNKNOWN || cut->sky == SP_REPOP_UNKNOWN)
        return 0;
    if (scene->sky != cut->sky)
        return -1;
    if (scene->sky == SP_REPOP_OVERCAST)
        return 1;
    double a[3], b[3];
    sun_vector(scene->sun_az_deg, scene->sun_el_deg, a);
    sun_vector(cut->sun_az_deg, cut->sun_el_deg, b);
    double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    return d > 1 ? 1 : d < -1 ? -1 : d;
}

static int luma(const uint8_t *p) { return (299 * p[0] + 587 * p[1] + 114 * p[2]) / 1000; }

int sp_repop_ground_light(const uint8_t *rgb, uint32_t width, uint32_t height, const uint8_t *mask, double out[3])
{
    uint32_t hist[256] = { 0 }, n = 0;
    size_t first = (size_t)(height / 2) * width, np = (size_t)width * height;
    for (size_t i = first; i < np; i++)
        if (!mask || !mask[i])
            hist[luma(rgb + 3 * i)]++, n++;
    if (n < 64)
        return -1;
    int lo, hi;
    sp_depop_lit_band(hist, n, &lo, &hi);
    double sum[3] = { 0, 0, 0 }, k = 0;
    for (size_t i = first; i < np; i++) {
        int l = luma(rgb + 3 * i);
        if ((!mask || !mask[i]) && l >= lo && l <= hi)
            sum[0] += rgb[3 * i], sum[1] += rgb[3 * i + 1], sum[2] += rgb[3 * i + 2], k++;
    }
    for (int c = 0; c < 3; c++)
        out[c] = sum[c] / k; /* k >= 1: the percentile band holds at least one pixel */
    return 0;
}

double sp_repop_height_px(const sp_depop_camera *cam, double H, double x, double y)
{
    double g[2], u, v;
    if (!(H > 0) || sp_depop_ground_point(cam, x + 0.5, y + 0.5, g))
        return NAN;
    double head[3] = { g[0], g[1], H };
    if (H >= 1.0 || sp_depop_project(cam, head, &u, &v))
        return NAN; /* a head at or above the camera never projects to a finite height below the horizon */
    return y + 0.5 - v;
}

double sp_repop_people_height(const sp_depop_object *objs, size_t n, const sp_depop_camera *cam)
{
    double *H = malloc((n ? n : 1) * sizeof(double));
    size_t m = 0;
    for (size_t i = 0; H && i < n; i++) {
        double g[2];
        if (sp_depop_ground_point(cam, 0.5 * (objs[i].x0 + objs[i].x1), objs[i].y1 + 0.5, g))
            continue;
        double h = sp_depop_height_at(cam, g, objs[i].y0 - 0.5);
        if (h > 0 && h < 1)
            H[m++] = h;
    }
    double r = H ? sp_median_inplace(H, m) : (double)NAN;
    free(H);
    return r;
}

int sp_repop_shadow_offset(const sp_depop_camera *cam, double az_deg, double el_deg, double x, double y, double h_px,
                           double *dx, double *dy)
{
    double g[2], fu = x + 0.5, fv = y + 0.5;
    if (!(el_deg >= 2 && el_deg <= 90) || !(h_px > 0) || sp_depop_ground_point(cam, fu, fv, g))
        return -1;
    double H = sp_depop_height_at(cam, g, fv - h_px), L = H / tan(el_deg * DEG);
    if (!(H > 0 && H < 1))
        return -1;
    /* the shadow points away from the sun along the ground */
    double tip[3] = { g[0] - L * sin(az_deg * DEG), g[1] - L * cos(az_deg * DEG), 0 }, u, v;
    if (sp_depop_project(cam, tip, &u, &v))
        return -1;
    *dx = (u - fu) / h_px, *dy = (v - fv) / h_px;
    return isfinite(*dx) && isfinite(*dy) ? 0 : -1;
}

int sp_repop_sun_from_model(const sp_probe_shadow *sh, const sp_probe_plane *plane, uint32_t width, uint32_t height,
                            const sp_depop_camera *cam, sp_depop_sun *out)
{
    *out = (sp_depop_sun){ 0 };
    if (!sh->present)
        return 0;
    /* synthetic people on a grid of the lower half, each with its modelled shadow, through the image estimate */
    sp_depop_object o[25];
    size_t n = 0;
    for (int j = 0; j < 5; j++)
        for (int i = 0; i < 5; i++) {
            double x = (i + 0.5) * width / 5.0, y = height * (0.55 + 0.09 * j);
            double h = sp_probe_plane_height(plane, x, y), u = x / width, v = y / height;
            if (!(h >= 4 && h < y))
                continue;
            double dx = sh->ox[0] + sh->ox[1] * u + sh->ox[2] * v, dy = sh->oy[0] + sh->oy[1] * u + sh->oy[2] * v;
            int w = (int)(0.3 * h) + 1;
            o[n] = (sp_depop_object){ .x0 = (int)x - w / 2, .x1 = (int)x - w / 2 + w - 1, .y0 = (int)(y - h + 1),
                                      .y1 = (int)y, .shadow_px = (uint32_t)(w * h) };
            o[n].tip_x = 0.5 * (o[n].x0 + o[n].x1) - 0.5 + dx * h, o[n].tip_y = y + dy * h;
            n++;
        }
    return sp_depop_sun_estimate(o, n, cam, out);
}
