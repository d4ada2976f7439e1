/* SPDX-License-Identifier: MIT */
#include "legend.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* 5x7 glyphs, one byte per row, bit 4 the leftmost column; drawn for this project. */
typedef struct glyph {
    char c;
    uint8_t rows[7];
} glyph;

static const glyph FONT[] = {
    { '0', { 0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E } }, { '1', { 0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E } },
    { '2', { 0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F } }, { '3', { 0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E } },
    { '4', { 0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02 } }, { '5', { 0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E } },
    { '6', { 0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E } }, { '7', { 0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08 } },
    { '8', { 0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E } }, { '9', { 0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C } },
    { 'A', { 0x0E, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11 } }, { 'B', { 0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E } },
    { 'C', { 0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E } }, { 'D', { 0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C } },
    { 'E', { 0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F } }, { 'F', { 0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10 } },
    { 'G', { 0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F } }, { 'H', { 0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11 } },
    { 'I', { 0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E } }, { 'J', { 0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C } },
    { 'K', { 0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11 } }, { 'L', { 0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F } },
    { 'M', { 0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11 } }, { 'N', { 0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11 } },
    { 'O', { 0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E } }, { 'P', { 0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10 } },
    { 'Q', { 0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D } }, { 'R', { 0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11 } },
    { 'S', { 0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E } }, { 'T', { 0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04 } },
    { 'U', { 0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E } }, { 'V', { 0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04 } },
    { 'W', { 0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A } }, { 'X', { 0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11 } },
    { 'Y', { 0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04 } }, { 'Z', { 0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F } },
    { '.', { 0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C } }, { '-', { 0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00 } },
    { ':', { 0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00 } }, { '(', { 0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02 } },
    { ')', { 0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08 } }, { '=', { 0x00, 0x00, 0x1F, 0x00, 0x1F, 0x00, 0x00 } },
    { '/', { 0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00 } }, { ',', { 0x00, 0x00, 0x00, 0x00, 0x0C, 0x04, 0x08 } },
    { '%', { 0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03 } }, { '<', { 0x02, 0x04, 0x08, 0x10, 0x08, 0x04, 0x02 } },
    { '>', { 0x08, 0x04, 0x02, 0x01, 0x02, 0x04, 0x08 } },
};

static const uint8_t *glyph_rows(char c)
{
    if (c >= 'a' && c <= 'z')
        c = (char)(c - 'a' + 'A');
    for (size_t i = 0; i < sizeof(FONT) / sizeof(FONT[0]); i++)
        if (FONT[i].c == c)
            return FONT[i].rows;
    return NULL; /* a blank */
}

static void put(uint8_t *rgb, uint32_t w, uint32_t h, long x, long y, const uint8_t c[3])
{
    if (x < 0 || y < 0 || x >= (long)w || y >= (long)h)
        return;
    memcpy(rgb + 3 * ((size_t)y * w + (size_t)x), c, 3);
}

static void fill(uint8_t *rgb, uint32_t w, uint32_t h, long x0, long y0, long x1, long y1, const uint8_t c[3])
{
    for (long y = y0; y < y1; y++)
        for (long x = x0; x < x1; x++)
            put(rgb, w, h, x, y, c);
}

int sp_legend_text(uint8_t *rgb, uint32_t width, uint32_t height, int x, int y, int scale, const char *text,
                   const uint8_t colour[3])
{
    int s = scale > 0 ? scale : 1, pen = x;
    for (const char *t = text; t && *t; t++, pen += 6 * s) {
        const uint8_t *g = glyph_rows(*t);
        for (int r = 0; g && r < 7; r++)
            for (int b = 0; b < 5; b++)
                if (g[r] & (0x10 >> b))
                    fill(rgb, width, height, pen + b * s, y + r * s, pen + (b + 1) * s, y + (r + 1) * s, colour);
    }
    return pen - x;
}

/* Font pixels per image pixel: legible at 1 on small images, larger on large ones. */
static int legend_scale(uint32_t width)
{
    int s = (int)(width / 480);
    return s < 1 ? 1 : s > 8 ? 8 : s;
}

/* rows, in font pixels: margin 4, title 8, gap 3, bar 10, tick 2, labels 8, gap 3, swatch line 8, margin 4 */
uint32_t sp_legend_height(uint32_t width)
{
    return 50u * (uint32_t)legend_scale(width);
}

int sp_legend_image(const uint8_t *map, uint32_t width, uint32_t height, const sp_legend *lg, uint8_t **out,
                    uint32_t *out_height)
{
    if (!map || !width || !height || !lg || !lg->colour || !out || !out_height || lg->ticks < 2 || lg->ticks > 11 ||
        lg->decimals < 0 || lg->decimals > 3 || !(lg->v1 != lg->v0))
        return -EINVAL;
    int s = legend_scale(width);
    uint32_t strip = sp_legend_height(width), h = height + strip;
    uint8_t *img = malloc((size_t)width * h * 3);
    if (!img)
        return -ENOMEM;
    memcpy(img, map, (size_t)width * height * 3);
    static const uint8_t bg[3] = { 240, 240, 240 }, ink[3] = { 16, 16, 16 };
    fill(img, width, h, 0, height, width, h, bg);
    long y = (long)height + 4 * s, margin = 8 * s;
    sp_legend_text(img, width, h, (int)margin, (int)y, s, lg->title, ink);
    y += 11 * s;
    /* the bar spans the width less the margins and room for the end labels to be centred on its ends */
    long x0 = margin + 12 * s, x1 = (long)width - margin - 12 * s;
    if (x1 <= x0 + 1)
        x0 = 0, x1 = width;
    for (long x = x0; x < x1; x++) {
        uint8_t c[3];
        lg->colour(lg->v0 + (lg->v1 - lg->v0) * (double)(x - x0) / (double)(x1 - 1 - x0), c, lg->ctx);
        fill(img, width, h, x, y, x + 1, y + 10 * s, c);
    }
    y += 10 * s;
    for (int k = 0; k < lg->ticks; k++) {
        long tx = x0 + (long)((double)(x1 - 1 - x0) * k / (lg->ticks - 1) + 0.5);
        fill(img, width, h, tx, y, tx + s, y + 2 * s, ink);
        char label[32];
        snprintf(label, sizeof(label), "%.*f", lg->decimals, lg->v0 + (lg->v1 - lg->v0) * k / (lg->ticks - 1));
        long lw = 6 * s * (long)strlen(label) - s;
        sp_legend_text(img, width, h, (int)(tx - lw / 2), (int)(y + 2 * s), s, label, ink);
    }
    y += 13 * s;
    if (lg->none_label) {
        fill(img, width, h, margin, y, margin + 8 * s, y + 7 * s, ink);
        fill(img, width, h, margin + s, y + s, margin + 7 * s, y + 6 * s, lg->none_rgb);
        sp_legend_text(img, width, h, (int)(margin + 11 * s), (int)y, s, lg->none_label, ink);
    }
    *out = img, *out_height = h;
    return 0;
}
