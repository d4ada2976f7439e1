/* SPDX-License-Identifier: MIT */
/*
 * Legends for preview images: a strip under the picture with a title, a colour bar with labelled
 * values and a swatch for pixels that hold no value, drawn with a built-in 5x7 pixel font (upper
 * case, digits and a few signs). A preview a person opens in an image viewer then says what its
 * colours mean without the documentation.
 */
#ifndef SUNPROBE_EXPORT_LEGEND_H
#define SUNPROBE_EXPORT_LEGEND_H

#include <stdint.h>
#include "common/private_api.h"

typedef struct sp_legend {
    const char *title;          /* one line: the quantity and its unit */
    double v0, v1;              /* the values at the bar's left and right ends */
    int ticks;                  /* labelled values, evenly spaced from v0 to v1, 2..11 */
    int decimals;               /* of the labels, 0..3 */
    void (*colour)(double v, uint8_t rgb[3], const void *ctx); /* the preview's colour of value v */
    const void *ctx;
    const char *none_label;     /* NULL: no swatch */
    uint8_t none_rgb[3];
} sp_legend;

/* Draws text (lower case is drawn upper case; unknown characters as blanks) with its top-left corner at
 * (x, y), each font pixel scale x scale, clipped to the image. Returns the width in pixels it took. */
SP_PRIVATE int sp_legend_text(uint8_t *rgb, uint32_t width, uint32_t height, int x, int y, int scale, const char *text,
                   const uint8_t colour[3]);
/* Height of the legend strip for an image this wide. */
uint32_t sp_legend_height(uint32_t width);
/* A new image: the width x height RGB map with the legend's strip below it (*out_height rows). 0, -EINVAL,
 * -ENOMEM. */
int sp_legend_image(const uint8_t *map, uint32_t width, uint32_t height, const sp_legend *lg, uint8_t **out,
                    uint32_t *out_height);

#endif
