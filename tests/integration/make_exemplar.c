/* SPDX-License-Identifier: MIT */
/*
 * make_exemplar KIND W H OUT.png: one of bench_texture's procedural exemplars as an 8-bit PNG, for CLI tests.
 * make_exemplar same A.png B: 0 when B (any format OpenImageIO reads) has A's size and pixels to 1/255.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "export/oiio_shim.h"
#include "export/png.h"
#include "export/png_read.h"
#include "sp_config.h"
#include "tools/bench/texture_eval.h"

static int same(const char *a, const char *b)
{
#if HAVE_OPENIMAGEIO
    uint8_t *pa = NULL;
    float *pb = NULL;
    uint32_t wa, ha, wb, hb;
    if (sp_png_read_rgba(a, &pa, &wa, &ha) || sp_image_read_rgb(b, &pb, &wb, &hb))
        return fprintf(stderr, "make_exemplar: cannot read %s or %s\n", a, b), 1;
    int bad = wa != wb || ha != hb;
    for (size_t i = 0; !bad && i < (size_t)wa * ha; i++)
        for (int c = 0; c < 3; c++)
            bad |= abs((int)pa[4 * i + c] - (int)(pb[3 * i + c] * 255.0f + 0.5f)) > 1;
    free(pa), free(pb);
    if (bad)
        fprintf(stderr, "make_exemplar: %s and %s differ\n", a, b);
    return bad;
#else
    (void)a, (void)b;
    return 77;
#endif
}

int main(int argc, char **argv)
{
    if (argc == 4 && !strcmp(argv[1], "same"))
        return same(argv[2], argv[3]);
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
