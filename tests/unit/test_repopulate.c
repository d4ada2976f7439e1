/* SPDX-License-Identifier: MIT */
/*
 * Repopulating from one image (pipeline/probe/repopulate.c): the lighting
 * match at its extremes, the cut-out sidecar (good, NaN, infinite, missing,
 * out of range), and the camera geometry against a pinhole written here
 * independently: a person's pixel height and the head's shadow tip under
 * suns all round, high and grazing, and the sun recovered from a shadow model.
 */
#include "pipeline/probe/repopulate.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "../common/check.h"

#define R (M_PI / 180)

/* World (x right, y ahead, z up; camera at height 1) to pixel, for a camera pitched down by p degrees. */
static void pinhole(const sp_depop_camera *c, double x, double y, double z, double *u, double *v)
{
    double p = c->pitch_deg * R, dz = z - 1;
    double depth = y * cos(p) - dz * sin(p), down = -(y * sin(p) + dz * cos(p));
    *u = c->cx + c->f * x / depth, *v = c->cy + c->f * down / depth;
}

static void test_match(void)
{
    sp_repop_light sun = { SP_REPOP_SUNNY, -30, 40, { 120, 110, 100 } }, cut = sun, over = { SP_REPOP_OVERCAST };
    double g[3];
    CHECK_NEAR(sp_repop_match(&sun, &cut, g), 1.0, 1e-12);
    CHECK(g[0] == 1 && g[1] == 1 && g[2] == 1);
    cut.sun_az_deg = 150, cut.sun_el_deg = 0; /* opposite horizontal direction, low: cos = -cos(40) */
    CHECK_NEAR(sp_repop_match(&sun, &cut, NULL), -cos(40 * R), 1e-9);
    cut.sun_az_deg = -30, cut.sun_el_deg = 90; /* straight overhead: cos(50) */
    CHECK_NEAR(sp_repop_match(&sun, &cut, NULL), cos(50 * R), 1e-9);
    CHECK_NEAR(sp_repop_match(&sun, &over, NULL), -1.0, 0);
    CHECK_NEAR(sp_repop_match(&over, &over, NULL), 1.0, 0);
    sp_repop_light unknown = { SP_REPOP_UNKNOWN };
    CHECK_NEAR(sp_repop_match(&unknown, &sun, g), 0.0, 0);
    CHECK(g[0] == 1 && g[2] == 1); /* no ground colour known on one side: no gain */
    /* gains: the ratio of the grounds, held within 0.25..4 */
    cut = sun, cut.ground_rgb[0] = 60, cut.ground_rgb[1] = 1, cut.ground_rgb[2] = 255;
    sun.ground_rgb[2] = 30;
    sp_repop_match(&sun, &cut, g);
    CHECK_NEAR(g[0], 2.0, 1e-12);
    CHECK_NEAR(g[1], 4.0, 0);
    CHECK_NEAR(g[2], 0.25, 0);
}

static int parse(const char *json, sp_cutout_meta *m, char *err)
{
    return sp_cutout_meta_parse(json, strlen(json), m, err, 200);
}

static void test_sidecar(void)
{
    sp_cutout_meta m = { .height_px = 70,
                         .height_m = 0.85,
                         .foot_x = 12.5,
                         .foot_y = 70,
                         .light = { SP_REPOP_SUNNY, -30.5, 41, { 139, 136.5, 129 } } },
                   back;
    strcpy(m.image, "p.png");
    sp_strbuf b = { 0 };
    sp_cutout_meta_json(&m, "frame 3", &b);
    char err[200] = "";
    CHECK_EQ_INT(sp_cutout_meta_parse(b.data, b.len, &back, err, sizeof(err)), 0);
    CHECK(!strcmp(back.image, "p.png") && back.height_px == 70 && back.foot_x == 12.5 && back.foot_y == 70);
    CHECK(back.height_m == 0.85);
    CHECK(back.light.sky == SP_REPOP_SUNNY && back.light.sun_az_deg == -30.5 && back.light.ground_rgb[1] == 136.5);
    sp_strbuf_free(&b);
    static const struct {
        const char *json, *why;
    } bad[] = {
        { "{\"image\":\"p.png\",\"height_px\":NaN,\"foot\":[1,2],\"sky\":\"overcast\"}", "byte" },
        { "{\"image\":\"p.png\",\"height_px\":1e999,\"foot\":[1,2],\"sky\":\"overcast\"}", "height_px" },
        { "{\"image\":\"p.png\",\"height_px\":0,\"foot\":[1,2],\"sky\":\"overcast\"}", "height_px" },
        { "{\"image\":\"p.png\",\"height_px\":50,\"foot\":[1],\"sky\":\"overcast\"}", "foot" },
        { "{\"image\":\"p.png\",\"height_px\":50,\"foot\":[1,2],\"sky\":\"cloudy\"}", "sky" },
        { "{\"image\":\"p.png\",\"height_px\":50,\"foot\":[1,2],\"sky\":\"sunny\"}", "sun_azimuth_deg" },
        { "{\"image\":\"p.png\",\"height_px\":50,\"foot\":[1,2],\"sky\":\"sunny\",\"sun_azimuth_deg\":0,"
          "\"sun_elevation_deg\":91}",
          "sun_elevation_deg" },
        { "{\"image\":\"p.png\",\"height_px\":50,\"foot\":[1,2],\"sky\":\"overcast\",\"ground_rgb\":[1,2,-3]}",
          "ground_rgb" },
        { "{\"image\":\"../p.png\",\"height_px\":50,\"foot\":[1,2],\"sky\":\"overcast\"}", "image" },
        { "[1,2]", "image" },
        { "{\"image\":\"p.png\",\"height_px\":50,\"foot\":[1,2],\"sky\":\"overcast\",\"height_m\":0.1}", "height_m" },
        { "{\"image\":\"p.png\",\"height_px\":50,\"foot\":[1,2],\"sky\":\"overcast\",\"height_m\":12}", "height_m" },
        { "{\"image\":\"p.png\",\"height_px\":50,\"foot\":[1,2],\"sky\":\"overcast\",\"height_m\":\"tall\"}",
          "height_m" },
    };
    for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
        err[0] = 0;
        CHECK_EQ_INT(parse(bad[i].json, &back, err), SP_ECORRUPT);
        CHECK_MSG(strstr(err, bad[i].why) != NULL, "case %zu: '%s' does not name %s", i, err, bad[i].why);
    }
    CHECK_EQ_INT(parse("{\"image\":\"p.png\",\"height_px\":5,\"foot\":[1,2],\"sky\":\"unknown\"}", &back, err), 0);
    CHECK(back.height_m == 0); /* not given: a person of the scene's height */
}

static void test_geometry(void)
{
    sp_depop_camera cam = { 800, 640, 360, 20 };
    static const double suns[][2] = { { -30, 40 }, { 60, 25 }, { -132.5, 33 }, { 170, 60 }, { 95, 2.5 }, { 10, 89.9 } };
    static const double spots[][2] = { { -1.0, 5 }, { 1.5, 8 }, { 0.3, 3.5 } };
    int checked = 0;
    for (size_t s = 0; s < 3; s++) {
        double gx = spots[s][0], gy = spots[s][1], H = 0.4, fu, fv, hu, hv;
        pinhole(&cam, gx, gy, 0, &fu, &fv);
        pinhole(&cam, gx, gy, H, &hu, &hv);
        double x = fu - 0.5, y = fv - 0.5; /* the foot pixel whose bottom edge is the ground point */
        CHECK_NEAR(sp_repop_height_px(&cam, H, x, y), fv - hv, 1e-6);
        for (size_t k = 0; k < sizeof(suns) / sizeof(suns[0]); k++) {
            double L = H / tan(suns[k][1] * R), tu, tv, dx, dy;
            pinhole(&cam, gx - sin(suns[k][0] * R) * L, gy - cos(suns[k][0] * R) * L, 0, &tu, &tv);
            int ok = !sp_repop_shadow_offset(&cam, suns[k][0], suns[k][1], x, y, fv - hv, &dx, &dy);
            if (tv > cam.cy - cam.f * tan(cam.pitch_deg * R) + 1 && ++checked) /* the tip is on the ground */
                CHECK_MSG(ok && fabs(fu + dx * (fv - hv) - tu) < 1e-3 && fabs(fv + dy * (fv - hv) - tv) < 1e-3,
                          "spot %zu sun %zu: %d (%.3f %.3f) vs (%.3f %.3f)", s, k, ok, fu + dx * (fv - hv),
                          fv + dy * (fv - hv), tu, tv);
        }
    }
    CHECK_MSG(checked >= 15, "only %d of 18 shadow tips on the ground", checked);
    double dx, dy;
    CHECK(sp_repop_shadow_offset(&cam, 0, 1.9, 640, 500, 80, &dx, &dy) == -1); /* the sun too low */
    CHECK(sp_repop_shadow_offset(&cam, 0, 40, 640, 0, 80, &dx, &dy) == -1);    /* above the horizon */
    CHECK(sp_repop_shadow_offset(&cam, 0, 40, 640, 500, 0, &dx, &dy) == -1);   /* no height */
    CHECK(isnan(sp_repop_height_px(&cam, 0.4, 640, -100)));
    CHECK(isnan(sp_repop_height_px(&cam, 1.0, 640, 500))); /* as tall as the camera: the head never comes down */
    CHECK(isnan(sp_repop_height_px(&cam, -0.1, 640, 500)));
}

/* People of one height on the ground: their median height back; the sun back from a shadow model. */
static void test_people_and_model(void)
{
    sp_depop_camera cam = { 386.27, 160, 120, 15 };
    sp_depop_object o[3];
    static const double foot[3][2] = { { 60, 200 }, { 150, 150 }, { 250, 230 } };
    for (int i = 0; i < 3; i++) {
        double h = sp_repop_height_px(&cam, 0.43, foot[i][0], foot[i][1]);
        o[i] = (sp_depop_object){ .x0 = (int)foot[i][0] - 5, .x1 = (int)foot[i][0] + 5,
                                  .y0 = (int)lround(foot[i][1] + 1 - h), .y1 = (int)foot[i][1] };
    }
    CHECK_NEAR(sp_repop_people_height(o, 3, &cam), 0.43, 0.01);
    CHECK(isnan(sp_repop_people_height(o, 0, &cam)));
    /* a shadow model made from the sun (-30, 40), the plane from the camera: the sun back within 2 degrees */
    double dx0, dy0, dx1, dy1, dx2, dy2;
    CHECK(!sp_repop_shadow_offset(&cam, -30, 40, 160, 180, sp_repop_height_px(&cam, 0.43, 160, 180), &dx0, &dy0));
    CHECK(!sp_repop_shadow_offset(&cam, -30, 40, 320, 180, sp_repop_height_px(&cam, 0.43, 320, 180), &dx1, &dy1));
    CHECK(!sp_repop_shadow_offset(&cam, -30, 40, 160, 240, sp_repop_height_px(&cam, 0.43, 160, 240), &dx2, &dy2));
    /* the linear model through the three points (u, v) = (0.5, 0.75), (1, 0.75), (0.5, 1) */
    sp_probe_shadow sh = { .present = 1 };
    sh.ox[1] = 2 * (dx1 - dx0), sh.ox[2] = 4 * (dx2 - dx0), sh.ox[0] = dx0 - 0.5 * sh.ox[1] - 0.75 * sh.ox[2];
    sh.oy[1] = 2 * (dy1 - dy0), sh.oy[2] = 4 * (dy2 - dy0), sh.oy[0] = dy0 - 0.5 * sh.oy[1] - 0.75 * sh.oy[2];
    double hA = sp_repop_height_px(&cam, 0.43, 160, 180), hB = sp_repop_height_px(&cam, 0.43, 160, 239);
    sp_probe_plane plane = { .status = SP_PROBE_PLANE_OK, .b = (hB - hA) / 59, .c = hA - (hB - hA) / 59 * 180 };
    sp_depop_sun e;
    CHECK_EQ_INT(sp_repop_sun_from_model(&sh, &plane, 320, 240, &cam, &e), 0);
    CHECK_MSG(e.found && fabs(e.azimuth_deg + 30) < 2 && fabs(e.elevation_deg - 40) < 2, "model sun %d %.2f/%.2f",
              e.found, e.azimuth_deg, e.elevation_deg);
    sh.present = 0;
    CHECK_EQ_INT(sp_repop_sun_from_model(&sh, &plane, 320, 240, &cam, &e), 0);
    CHECK(!e.found);
}

static void test_ground_light(void)
{
    enum { W = 40, H = 40 };
    static uint8_t rgb[W * H * 3], mask[W * H];
    memset(rgb, 200, sizeof(rgb)); /* sky */
    for (int i = W * H / 2; i < W * H; i++) /* ground: 80 % lit (150, 140, 130), 20 % shadow */
        memcpy(rgb + 3 * i, i % 5 ? (const uint8_t[3]){ 150, 140, 130 } : (const uint8_t[3]){ 60, 56, 52 }, 3);
    double g[3];
    CHECK_EQ_INT(sp_repop_ground_light(rgb, W, H, NULL, g), 0);
    CHECK(g[0] == 150 && g[1] == 140 && g[2] == 130);
    memset(mask, 1, sizeof(mask));
    CHECK_EQ_INT(sp_repop_ground_light(rgb, W, H, mask, g), -1);
}

int main(void)
{
    test_match();
    test_sidecar();
    test_geometry();
    test_people_and_model();
    test_ground_light();
    return check_exit();
}
