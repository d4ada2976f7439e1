/* SPDX-License-Identifier: MIT */
/* make_exemplar KIND W H OUT.png: one of bench_texture's procedural exemplars as an 8-bit PNG, for CLI tests. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "export/png.h"
#include "tools/bench/texture_eval.h"

int main(int argc, char **argv)
{
    if (argc != 5)
        return fprintf(stderr, "usage: make_exemplar bricks|blobs|stones W H OUT.png\n"), 1;
    int kind = 0, w = atoi(argv[2]), h = atoi(argv[3]);
    while (kind < TEV_KINDS && strcmp(argv[1], tev_kind_name((enum tev_kind)kind)))
        kind++;
    tev_image im;
    if (kind == TEV_KINDS || w < 1 || h < 1 || tev_procedural(&im, (enum tev_kind)kind, w, h, 1))
        return fprintf(stderr, "make_exemplar: bad arguments\n"), 1;
    uint8_t *px = malloc((size_t)w * h * 3);
    for (size_t i = 0; px && i < (size_t)w * h * 3; i++)
        px[i] = (uint8_t)(im.px[i] * 255.0f + 0.5f);
    int ret = px ? sp_png_write(argv[4], px, (uint32_t)w, (uint32_t)h, (uint32_t)w * 3, 3) : -1;
    free(px);
    tev_free(&im);
    return ret ? 1 : 0;
}
