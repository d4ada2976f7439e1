/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe relight --panel`: one labelled figure of what a relightable face allows, in the style of the
 * SunStage thesis' Fig. 4.2: the input frame, the reconstruction, and the same view edited one way per
 * tile (soft sun, fill light, new light, novel views, focal lengths, shinier skin), a caption under each.
 */
#include "relight.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd.h"
#include "export/legend.h"
#include "export/png.h"

#define COLS 5
#define TILES 10

static const uint8_t panel_grey[3] = { 40, 40, 40 }, caption_white[3] = { 235, 235, 235 };

/* Tile k's arguments: base edited one way; its caption into cap. 0 for the input frame (no render). */
static int tile_args(const relight_ctx *c, const relight_args *base, int k, relight_args *t, char *cap, size_t n)
{
    *t = *base;
    double az = base->az, el = base->el; /* the light the edits start from */
    if (!base->have_sun) {
        const double *s = c->fa.sun_dir;
        az = atan2(s[1], s[0]) * 180.0 / M_PI;
        el = asin(fmax(-1.0, fmin(1.0, s[2] / fmax(1e-12, sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]))))) * 180.0 / M_PI;
    }
    double I = base->intensity > 0.0 ? base->intensity : (c->fa.sun_intensity > 0.0 ? c->fa.sun_intensity : 3.0);
    switch (k) {
    case 0: snprintf(cap, n, "input frame %d", base->keyframe); return 0;
    case 1: snprintf(cap, n, "reconstruction"); break;
    case 2: snprintf(cap, n, "soft sun, 10 deg"); t->sun_size = 10.0; break;
    case 3:
        snprintf(cap, n, "fill light opposite");
        if (t->n_fill < MAX_FILLS)
            t->fill[t->n_fill++] = (fill_light){ az + 180.0, 10.0, 0.5 * I, { 1.0, 1.0, 1.0 }, 0 };
        break;
    case 4:
        snprintf(cap, n, "sky and sun turned 180 deg");
        t->have_sun = 1, t->az = az + 180.0, t->el = el, t->sky_turn = 180.0;
        break;
    case 5: snprintf(cap, n, "novel view -40 deg"); t->have_orbit = 1, t->orbit_az = -40.0, t->orbit_el = 0.0; break;
    case 6: snprintf(cap, n, "novel view 40 deg, up 15"); t->have_orbit = 1, t->orbit_az = 40.0, t->orbit_el = 15.0; break;
    case 7: snprintf(cap, n, "24 mm"); t->fov_deg = 2.0 * atan(18.0 / 24.0) * 180.0 / M_PI; break;
    case 8: snprintf(cap, n, "135 mm"); t->fov_deg = 2.0 * atan(18.0 / 135.0) * 180.0 / M_PI; break;
    default:
        snprintf(cap, n, "shinier skin, x4");
        for (int i = 0; i < SP_RENDER_CLUSTERS; i++)
            t->spec_scale[i] *= 4.0;
    }
    return 1;
}

/* Keyframe N's frame at W x H (nearest pixel), or NULL (no --capture, or it cannot be read). */
static uint8_t *input_frame(relight_ctx *c, relight_args *t, int W, int H)
{
    if (!t->capture)
        return NULL;
    t->background_keyframe = t->keyframe;
    uint8_t *px = relight_read_background(c) == 0 && c->bg_raw ? malloc((size_t)W * (size_t)H * 4) : NULL;
    for (int y = 0; px && y < H; y++)
        for (int x = 0; x < W; x++) {
            size_t sx = (size_t)x * c->bg_w / (size_t)W, sy = (size_t)y * c->bg_h / (size_t)H;
            uint8_t *d = px + ((size_t)y * (size_t)W + (size_t)x) * 4;
            memcpy(d, c->bg_raw + (sy * c->bg_w + sx) * 3, 3);
            d[3] = 255;
        }
    free(c->bg);
    free(c->bg_raw);
    c->bg = NULL;
    c->bg_raw = NULL;
    c->bg_is_capture = 0;
    return px;
}

/* Tile k (RGBA, alpha over the panel's grey; NULL: left grey) and its caption into the RGB panel. */
static void place(uint8_t *panel, int PW, const uint8_t *rgba, int k, int W, int H, int cap_h, const char *cap)
{
    int x0 = (k % COLS) * W, y0 = (k / COLS) * (H + cap_h);
    for (int y = 0; rgba && y < H; y++)
        for (int x = 0; x < W; x++) {
            const uint8_t *s = rgba + ((size_t)y * (size_t)W + (size_t)x) * 4;
            uint8_t *d = panel + ((size_t)(y0 + y) * (size_t)PW + (size_t)(x0 + x)) * 3;
            for (int ch = 0; ch < 3; ch++)
                d[ch] = (uint8_t)((s[ch] * s[3] + panel_grey[ch] * (255 - s[3]) + 127) / 255);
        }
    int scale = W >= 240 ? 2 : 1;
    sp_legend_text(panel, (uint32_t)PW, (uint32_t)((TILES / COLS) * (H + cap_h)), x0 + 4 * scale, y0 + H + 3 * scale,
                   scale, cap, caption_white);
}

int relight_panel(relight_ctx *c)
{
    relight_args base = *c->a, t;
    uint8_t *tile[TILES] = { 0 };
    char caps[TILES][48];
    int W = 0, H = 0, ret = 0;
    for (int k = 1; k < TILES && !ret; k++) {
        int w = 0, h = 0;
        tile_args(c, &base, k, &t, caps[k], sizeof(caps[k]));
        c->a = &t;
        ret = relight_tile(c, &tile[k], &w, &h);
        if (!ret && k > 1 && (w != W || h != H)) {
            fprintf(stderr, "sunprobe relight: --panel: tile %d is %dx%d, the others %dx%d\n", k, w, h, W, H);
            ret = SP_EXIT_INTERNAL;
        }
        W = w, H = h;
    }
    tile_args(c, &base, 0, &t, caps[0], sizeof(caps[0]));
    c->a = &t;
    tile[0] = ret ? NULL : input_frame(c, &t, W, H);
    if (!ret && !tile[0])
        snprintf(caps[0], sizeof(caps[0]), "no input frame: --capture");
    c->a = &base;
    int scale = W >= 240 ? 2 : 1, cap_h = 13 * scale, PW = COLS * W, PH = (TILES / COLS) * (H + cap_h);
    uint8_t *panel = ret ? NULL : malloc((size_t)PW * (size_t)PH * 3);
    for (size_t i = 0; panel && i < (size_t)PW * (size_t)PH; i++)
        memcpy(panel + i * 3, panel_grey, 3);
    for (int k = 0; panel && k < TILES; k++)
        place(panel, PW, tile[k], k, W, H, cap_h, caps[k]);
    if (!ret)
        ret = panel ? sp_png_write(base.out, panel, (uint32_t)PW, (uint32_t)PH, (uint32_t)PW * 3, 3) : -ENOMEM;
    if (ret < 0)
        ret = sp_cmd_fail("relight", ret, base.out);
    else if (!ret)
        printf("relight: wrote %s (%dx%d, %d tiles of %dx%d)\n", base.out, PW, PH, TILES, W, H);
    for (int k = 0; k < TILES; k++)
        free(tile[k]);
    free(panel);
    return ret;
}
