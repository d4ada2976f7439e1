/* SPDX-License-Identifier: MIT */
/*
 * Fuzz harness for the PNG reader (export/png_read.c): any input decodes to width x height RGBA
 * (both sides 1..16384, every byte readable) or fails with one of the documented codes; what
 * decodes, encoded again by the project's writer, decodes to the same pixels. libFuzzer with
 * -DSP_LIBFUZZER, else a main that replays the corpus (tests/fuzz/corpus/png).
 */
#include <errno.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "export/png.h"
#include "export/png_read.h"
#include "sunprobe/sp_common.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static int documented(int rc)
{
    return rc == SP_EFORMAT || rc == SP_ECORRUPT || rc == SP_ETRUNCATED || rc == SP_EUNSUPPORTED || rc == -E2BIG ||
           rc == SP_EDISABLED || rc == -ENOMEM;
}

static void round_trip(const uint8_t *rgba, uint32_t w, uint32_t h)
{
    uint8_t *png = NULL, *back = NULL;
    size_t n = 0;
    uint32_t w2, h2;
    if ((size_t)w * h > (1u << 16) || sp_png_encode(rgba, w, h, w * 4, 4, &png, &n))
        return; /* large images: the decode above is the test */
    if (sp_png_decode_rgba(png, n, &back, &w2, &h2) || w2 != w || h2 != h || memcmp(back, rgba, (size_t)w * h * 4))
        abort();
    free(png);
    free(back);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    uint8_t *rgba = NULL;
    uint32_t w = 0, h = 0;
    int rc = sp_png_decode_rgba(data, size, &rgba, &w, &h);
    if (rc && !documented(rc))
        abort();
    if (!rc) {
        if (w < 1 || h < 1 || w > 16384 || h > 16384)
            abort();
        volatile uint8_t sum = 0;
        for (size_t i = 0; i < (size_t)w * h * 4; i++)
            sum ^= rgba[i]; /* every byte is there (ASan) */
        (void)sum;
        round_trip(rgba, w, h);
    }
    free(rgba);
    (void)sp_png_has_alpha(data, size);
    return 0;
}

#include "replay_main.h"
