/* SPDX-License-Identifier: MIT */
/*
 * Ground retexturing (pipeline/probe/retexture.c) on a made-up scene: a grey
 * plate with a shadow, a plane with its horizon at row 100, vertical stripes
 * as the texture. Checked: nothing above the horizon or outside the region
 * changes, the shadow's ratio stays, the stripes shrink on screen as the
 * plane's person height does, the rows at the horizon are the texture's mean
 * (no aliasing), and bad arguments are refused.
 */
#include "pipeline/probe/retexture.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "sunprobe/sp_math.h"

enum { W = 200, H = 240, TW = 64 };

static double lum(const uint8_t *p)
{
    return 0.2126 * sp_srgb_decode(p[0] / 255.0) + 0.7152 * sp_srgb_decode(p[1] / 255.0) +
           0.0722 * sp_srgb_decode(p[2] / 255.0);
}

/* Light/dark changes along row y between columns 20 and 180. */
static int transitions(const uint8_t *img, int y, double mid)
{
    int n = 0;
    for (int x = 21; x < 180; x++)
        n += (lum(img + 3 * (y * W + x)) > mid) != (lum(img + 3 * (y * W + x - 1)) > mid);
    return n;
}

static double row_sd(const uint8_t *img, int y)
{
    double s = 0, q = 0;
    for (int x = 20; x < 180; x++) {
        double v = lum(img + 3 * (y * W + x));
        s += v, q += v * v;
    }
    s /= 160, q /= 160;
    return sqrt(fmax(q - s * s, 0));
}

static int in_shadow(int x, int y)
{
    return x >= 120 && x < 170 && y >= 200 && y < 230;
}

int main(void)
{
    uint8_t *plate = malloc(3 * W * H), *out = malloc(3 * W * H), *region = malloc(W * H);
    float *tex = malloc(sizeof(float) * 3 * TW * TW);
    for (int i = 0; i < W * H; i++) {
        int x = i % W, y = i / W;
        uint8_t v = (uint8_t)lrint(255 * sp_srgb_encode(in_shadow(x, y) ? 0.15 : 0.5));
        plate[3 * i] = plate[3 * i + 1] = plate[3 * i + 2] = v;
    }
    for (int i = 0; i < TW * TW; i++) /* stripes 8 texels wide */
        tex[3 * i] = tex[3 * i + 1] = tex[3 * i + 2] = (i % TW) / 8 % 2 ? 0.9f : 0.2f;
    sp_probe_plane pl = { .status = SP_PROBE_PLANE_OK, .a = 0, .b = 0.5, .c = -50 }; /* h = 0.5 y - 50 */
    sp_retexture_settings s;
    sp_retexture_default_settings(&s);
    s.metres = 2, s.shading_m = 0.05;
    CHECK_EQ_INT(sp_retexture_ground(&pl, NULL, W, H, region), 0);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            region[y * W + x] &= x >= 10; /* a column the caller keeps */
    sp_retexture_report rep;
    CHECK_EQ_INT(sp_retexture(plate, W, H, &pl, region, tex, TW, TW, &s, out, &rep), 0);
    int kept = 1;
    for (int i = 0; i < W * H; i++)
        if (i / W < 104 || i % W < 10)
            kept &= !memcmp(out + 3 * i, plate + 3 * i, 3);
    CHECK_MSG(kept, "pixels above the horizon or outside the region changed");
    printf("%llu pixels, %.1f px/m near, %.2f px/m far\n", (unsigned long long)rep.pixels, rep.near_px_per_m,
           rep.far_px_per_m);

    /* the shadow: against the same scene without it, pixel for pixel, the plate's ratio 0.3 */
    uint8_t *lit_plate = malloc(3 * W * H), *lit_out = malloc(3 * W * H);
    memset(lit_plate, plate[0], 3 * W * H);
    sp_retexture_report rep2;
    CHECK_EQ_INT(sp_retexture(lit_plate, W, H, &pl, region, tex, TW, TW, &s, lit_out, &rep2), 0);
    double sh = 0, lit = 0;
    for (int y = 204; y < 226; y++)
        for (int x = 124; x < 166; x++)
            sh += lum(out + 3 * (y * W + x)), lit += lum(lit_out + 3 * (y * W + x));
    printf("shadow / lit %.3f (plate 0.300)\n", sh / lit);
    CHECK_NEAR(sh / lit, 0.3, 0.3 * 0.03);
    free(lit_plate), free(lit_out);

    /* perspective: a row's stripe count goes as 1 / (person height there) */
    double mid = 0.5 * (sp_srgb_decode(0.9) + sp_srgb_decode(0.2));
    int near = transitions(out, 230, mid), far = transitions(out, 150, mid);
    double want = (0.5 * 230 - 50) / (0.5 * 150 - 50);
    printf("stripe changes near %d, far %d: ratio %.2f (plane %.2f)\n", near, far, (double)far / near, want);
    CHECK_MSG(near > 10 && fabs((double)far / near - want) < 0.1 * want, "far/near %d/%d, want %.2f", far, near, want);
    /* at the horizon a pixel covers many stripes: the mip level gives their mean, not aliasing */
    double sd_h = row_sd(out, 104), sd_n = row_sd(out, 230);
    printf("row sd at the horizon %.4f, near %.4f\n", sd_h, sd_n);
    CHECK_MSG(sd_h < 0.1 * sd_n, "aliasing at the horizon: sd %.4f vs %.4f near", sd_h, sd_n);

    /* the extreme scale: 100 texture widths a metre, every pixel covers many stripes: their mean, flat */
    s.metres = 0.01;
    CHECK_EQ_INT(sp_retexture(plate, W, H, &pl, region, tex, TW, TW, &s, out, &rep), 0);
    double mean = 0, want_mean = 0.5 * (sp_srgb_decode(0.9) + sp_srgb_decode(0.2));
    for (int x = 20; x < 100; x++)
        mean += lum(out + 3 * (236 * W + x)) / 80; /* a row clear of the shadow's low-pass */
    printf("at 0.01 m: row mean %.4f (the stripes' %.4f), sd %.4f\n", mean, want_mean, row_sd(out, 236));
    CHECK_NEAR(mean, want_mean, 0.03 * want_mean);
    CHECK_MSG(row_sd(out, 236) < 0.01, "aliasing at 0.01 m: sd %.4f", row_sd(out, 236));
    s.metres = 2;

    /* refusals */
    sp_probe_plane line = pl;
    line.status = SP_PROBE_PLANE_LINE;
    CHECK_EQ_INT(sp_retexture(plate, W, H, &line, region, tex, TW, TW, &s, out, &rep), SP_ENODATA);
    CHECK_EQ_INT(sp_retexture_ground(&line, NULL, W, H, region), SP_ENODATA);
    sp_probe_plane sky = { .status = SP_PROBE_PLANE_OK, .a = 0, .b = 0.5, .c = -500 }; /* horizon below the image */
    CHECK_EQ_INT(sp_retexture_ground(&sky, NULL, W, H, region), SP_ENODATA);
    memset(region, 0, W * H);
    CHECK_EQ_INT(sp_retexture(plate, W, H, &pl, region, tex, TW, TW, &s, out, &rep), SP_ENODATA);
    s.metres = 0;
    CHECK_EQ_INT(sp_retexture(plate, W, H, &pl, region, tex, TW, TW, &s, out, &rep), -EINVAL);
    free(plate), free(out), free(region), free(tex);
    return check_exit();
}
