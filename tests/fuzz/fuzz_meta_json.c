/* SPDX-License-Identifier: MIT */
/*
 * Fuzz harness for the metadata JSON: import --meta (sp_import_meta_load, then the META it builds)
 * and the capture reader's META merge. What import accepts must build a META that parses again and
 * that the reader merges; a refusal names its cause. libFuzzer with -DSP_LIBFUZZER, else a main that
 * replays the corpus (tests/fuzz/corpus/meta_json).
 */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "capture/import_internal.h"
#include "common/json.h"
#include "fuzz_util.h"
#include "sunprobe/sp_meta.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check_built(const sp_json *root)
{
    static const double to_camera[4] = { 1, 0, 0, 0 };
    /* a sensor log's time and place too: root's own keys win, the rest is added */
    const sp_import_meta_extra extra = { "2024-06-21T12:00:00.000Z", 1, { 48.85, 2.35, NAN } };
    sp_strbuf b = { 0 };
    if (sp_import_meta_build(root, NULL, "in.mp4", 64, 48, 30.0, to_camera, &extra, &b) == 0 && !b.failed) {
        sp_json *again = NULL;
        char err[160];
        if (sp_json_parse(b.data, b.len, &again, err, sizeof(err)))
            FUZZ_FAIL("import would write a META no reader parses");
        sp_json_free(again);
        sp_capture_meta m;
        sp_capture_meta_init(&m);
        if (sp_capture_meta_merge(&m, b.data, b.len))
            FUZZ_FAIL("nor one the capture reader merges");
    }
    sp_strbuf_free(&b);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char p[400], msg[512] = "";
    fuzz_put("m.json", data, size);
    sp_json *root = NULL;
    sp_capture_meta meta;
    sp_capture_meta_init(&meta);
    int rc = sp_import_meta_load(fuzz_path(p, sizeof(p), "m.json"), &root, &meta, msg, sizeof(msg));
    if (rc && !msg[0])
        FUZZ_FAIL("a refusal without a message");
    if (!rc)
        check_built(root);
    sp_json_free(root);
    sp_capture_meta_init(&meta);
    (void)sp_capture_meta_merge(&meta, (const char *)data, size); /* any outcome, no crash */
    return 0;
}

#include "replay_main.h"
