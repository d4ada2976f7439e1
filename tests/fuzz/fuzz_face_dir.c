/* SPDX-License-Identifier: MIT */
/*
 * Fuzz harness for the face-directory reader (sp_face_dir_read) and, built with -DSP_FUZZ_GLTF, for
 * the glTF writer fed by it (sp_export_face, plain GLB). The input is a packed face directory
 * (face_pack.h). Whatever reads must give finite maps, a mesh whose
 * indices are in range and a GLB whose chunks and plain accessors are consistent; whatever fails,
 * fails with a code. `fuzz_face_dir --pack DIR OUT` packs an existing face directory (for seeds).
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "check.h"
#include "face_pack.h"
#include "fuzz_util.h"
#include "glb_read.h"
#include "sunprobe/sp_export.h"
#include "sunprobe/sp_sunstage.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static void check_asset(const sp_face_asset *a)
{
    const sp_mesh *m = &a->mesh;
    for (size_t i = 0; i < (size_t)a->tex_width * a->tex_height; i++)
        if (!isfinite(a->albedo[3 * i]) || !isfinite(a->displacement[i]))
            FUZZ_FAIL("a map value is NaN or Inf");
    for (size_t t = 0; t < 3 * (size_t)m->n_triangles; t++)
        if (m->tri_vertices[t] >= m->n_vertices || m->tri_uvs[t] >= m->n_uvs)
            FUZZ_FAIL("a triangle index is out of range");
    if (m->n_triangles == 0 || a->width < 1 || a->height < 1)
        FUZZ_FAIL("no triangles or no image size");
}

#ifdef SP_FUZZ_GLTF
static void check_export(const char *face)
{
    char out[400];
    snprintf(out, sizeof(out), "%s/face.glb", fuzz_dir());
    sp_export_settings s;
    sp_export_default_settings(&s);
    s.draco = 0;
    s.write_env = 0;
    s.texture_size = 16; /* the smallest: the default 512 px texture per input held the harness to ~2 runs/s */
    if (sp_export_face(face, out, &s, NULL))
        return;
    glb g;
    if (glb_read(&g, out) || check_failures)
        FUZZ_FAIL("the writer accepted the directory and wrote no valid GLB");
    uint32_t count = 0;
    const sp_json *acc = sp_json_get(g.json, "accessors");
    for (size_t k = 0; k < (acc ? acc->count : 0); k++) {
        const sp_json *a = sp_json_at(acc, k);
        if (sp_json_get(a, "sparse"))
            continue;
        static const char *const types[] = { "SCALAR", "VEC2", "VEC3", "VEC4" };
        size_t comps = 0, ct = (size_t)sp_json_number(sp_json_get(a, "componentType"), 0);
        for (size_t t = 0; t < 4; t++)
            if (!strcmp(sp_json_string(sp_json_get(a, "type"), ""), types[t]))
                comps = t + 1;
        size_t bytes = ct == 5120 || ct == 5121 ? 1 : ct == 5122 || ct == 5123 ? 2 : ct == 5125 || ct == 5126 ? 4 : 0;
        if (!comps || !bytes)
            FUZZ_FAIL("an accessor of no glTF type");
        if (!accessor_data(&g, (int)k, bytes * comps, &count))
            FUZZ_FAIL("a plain accessor does not fit the BIN chunk");
    }
    glb_free(&g);
    unlink(out);
}
#endif

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char face[400];
    fuzz_path(face, sizeof(face), "face");
    mkdir(face, 0755);
    face_unpack(data, size, face);
    sp_face_asset a;
    int rc = sp_face_dir_read(&a, face);
    if (rc > 0)
        FUZZ_FAIL("the reader returned a positive code");
    if (!rc)
        check_asset(&a);
    sp_face_asset_free(&a);
#ifdef SP_FUZZ_GLTF
    if (!rc)
        check_export(face);
#endif
    return 0;
}

#ifndef SP_LIBFUZZER
/* --pack DIR OUT: a face directory as one input */
static int pack(const char *dir, const char *out)
{
    FILE *o = fopen(out, "wb");
    for (size_t k = 0; o && k < FACE_FILES; k++) {
        char p[4096];
        snprintf(p, sizeof(p), "%s/%s", dir, face_files[k]);
        size_t n;
        uint8_t *d = slurp(p, &n), hdr[5] = { (uint8_t)k, (uint8_t)n, (uint8_t)(n >> 8), (uint8_t)(n >> 16),
                                                 (uint8_t)(n >> 24) };
        if (d && (fwrite(hdr, 1, 5, o) != 5 || fwrite(d, 1, n, o) != n))
            n = 0;
        free(d);
    }
    return o && fclose(o) == 0 ? 0 : 1;
}
#define main replay_main
int replay_main(int argc, char **argv);
#endif
#include "replay_main.h"
#ifndef SP_LIBFUZZER
#undef main
int main(int argc, char **argv)
{
    if (argc == 4 && !strcmp(argv[1], "--pack"))
        return pack(argv[2], argv[3]);
    return replay_main(argc, argv);
}
#endif
