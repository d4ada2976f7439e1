/* SPDX-License-Identifier: MIT */
/*
 * Preview legends (export/legend.h): the map is kept, the strip is added below it, the bar's ends have the
 * colours of its end values, labels draw ink inside the strip only, text is clipped at the image's edges,
 * and bad arguments are refused. Then a probe directory's previews carry their legends.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "export/legend.h"

static void ramp(double v, uint8_t rgb[3], const void *ctx)
{
    (void)ctx;
    int l = (int)(v * 100.0 + 0.5);
    rgb[0] = (uint8_t)(l < 0 ? 0 : l > 255 ? 255 : l), rgb[1] = 7, rgb[2] = 200;
}

static int count_ink(const uint8_t *img, uint32_t w, uint32_t y0, uint32_t y1)
{
    int n = 0;
    for (size_t i = (size_t)y0 * w; i < (size_t)y1 * w; i++)
        n += img[3 * i] == 16 && img[3 * i + 1] == 16 && img[3 * i + 2] == 16;
    return n;
}

static void test_strip(uint32_t w, uint32_t h, int room)
{
    uint8_t *map = malloc((size_t)w * h * 3), *out = NULL;
    for (size_t i = 0; i < (size_t)w * h * 3; i++)
        map[i] = (uint8_t)(i * 31 % 251);
    sp_legend lg = { .title = "VALUE (UNIT)", .v0 = 0.5, .v1 = 2.5, .ticks = 5, .decimals = 1, .colour = ramp,
                     .none_label = "NO VALUE", .none_rgb = { 1, 2, 3 } };
    uint32_t oh = 0;
    CHECK(sp_legend_image(map, w, h, &lg, &out, &oh) == 0);
    CHECK_EQ_INT(oh, h + sp_legend_height(w));
    CHECK(out && !memcmp(out, map, (size_t)w * h * 3));
    /* the strip holds text, the bar's two end colours and the swatch's colour */
    int ink = out ? count_ink(out, w, h, oh) : 0;
    CHECK_MSG(!room || ink > 200, "%d ink pixels in the strip", ink);
    int lo = 0, hi = 0, none = 0;
    for (size_t i = (size_t)w * h; out && i < (size_t)w * oh; i++) {
        const uint8_t *p = out + 3 * i;
        lo += p[0] == 50 && p[1] == 7 && p[2] == 200;
        hi += p[0] == 250 && p[1] == 7 && p[2] == 200;
        none += p[0] == 1 && p[1] == 2 && p[2] == 3;
    }
    CHECK_MSG(lo > 0 && hi > 0 && (!room || none > 0), "bar ends %d %d, swatch %d", lo, hi, none);
    free(out);
    free(map);
}

static void test_text_and_args(void)
{
    enum { W = 40, H = 10 };
    uint8_t img[W * H * 3] = { 0 };
    static const uint8_t ink[3] = { 16, 16, 16 };
    /* "1" is 6 px wide per character at scale 1; clipped text draws nothing outside */
    CHECK_EQ_INT(sp_legend_text(img, W, H, 0, 0, 1, "1", ink), 6);
    int n = count_ink(img, W, 0, H);
    CHECK_EQ_INT(n, 1 + 2 + 1 + 1 + 1 + 1 + 3); /* the glyph's set bits, row by row */
    CHECK_EQ_INT(sp_legend_text(img, W, H, -100, 20, 2, "CLIPPED", ink), 6 * 2 * 7);
    CHECK_EQ_INT(count_ink(img, W, 0, H), n);
    /* lower case draws as upper case; unknown characters are blanks */
    uint8_t a[W * H * 3] = { 0 }, b[W * H * 3] = { 0 };
    sp_legend_text(a, W, H, 1, 1, 1, "ab~", ink);
    sp_legend_text(b, W, H, 1, 1, 1, "AB ", ink);
    CHECK(!memcmp(a, b, sizeof(a)));
    uint8_t *out = NULL;
    uint32_t oh = 0;
    sp_legend lg = { .title = "T", .v0 = 0, .v1 = 1, .ticks = 2, .decimals = 0, .colour = ramp };
    CHECK(sp_legend_image(img, W, H, &lg, &out, &oh) == 0);
    free(out);
    lg.ticks = 1;
    CHECK(sp_legend_image(img, W, H, &lg, &out, &oh) == -EINVAL);
    lg.ticks = 2, lg.v1 = 0;
    CHECK(sp_legend_image(img, W, H, &lg, &out, &oh) == -EINVAL);
    lg.v1 = 1, lg.colour = NULL;
    CHECK(sp_legend_image(img, W, H, &lg, &out, &oh) == -EINVAL);
    lg.colour = ramp;
    CHECK(sp_legend_image(img, 0, H, &lg, &out, &oh) == -EINVAL);
}

int main(void)
{
    test_strip(320, 240, 1);
    test_strip(2000, 100, 1); /* scaled font: four font pixels per glyph pixel */
    test_strip(8, 8, 0);      /* narrower than the labels: clipped, not refused */
    test_text_and_args();
    return check_exit();
}
