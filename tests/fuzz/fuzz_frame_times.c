/* SPDX-License-Identifier: MIT */
/*
 * Fuzz harness for import's frame-times CSV (--frame-times: a t or t_ns column, exposure columns
 * beside it): it must fail with a message, or give at least one strictly increasing time and one
 * exposure row per time when it read exposure columns. libFuzzer with -DSP_LIBFUZZER, else a main
 * that replays the corpus (tests/fuzz/corpus/frame_times).
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "capture/import_ctx.h"
#include "fuzz_util.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char p[400];
    fuzz_put("t.csv", data, size);
    sp_import_settings s;
    sp_import_default_settings(&s);
    sp_import_report rep = { 0 };
    import_ctx c = { .s = &s, .rep = &rep };
    int rc = sp_import_load_frame_times(&c, fuzz_path(p, sizeof(p), "t.csv"));
    if (rc && !rep.message[0])
        FUZZ_FAIL("every failure names its cause");
    if (!rc && c.ntimes == 0)
        FUZZ_FAIL("read, yet no frame times");
    for (size_t i = 1; !rc && i < c.ntimes; i++)
        if (c.times[i] <= c.times[i - 1])
            FUZZ_FAIL("frame times not strictly increasing");
    if (!rc && c.expo.n && c.expo.n != c.ntimes)
        FUZZ_FAIL("not one exposure row per frame time");
    for (size_t i = 0; i < c.expo.n; i++)
        if (!(isnan(c.expo.v[i][0]) || c.expo.v[i][0] >= 0))
            FUZZ_FAIL("a negative exposure time");
    free(c.times);
    sp_import_exposure_free(&c.expo);
    return 0;
}

#include "replay_main.h"
