/* SPDX-License-Identifier: MIT */
/* The face directory with its albedo preview (face_dir.h). */
#include "face_dir.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "common/file_util.h"
#include "export/png.h"

/* Albedo preview: gamma-encoded 8-bit PNG beside the float map. */
static int write_albedo_png(const sp_sunstage *ss, const char *dir)
{
    sp_sunstage_result r;
    int ret = sp_sunstage_get_result(ss, &r);
    if (ret)
        return ret;
    size_t n = (size_t)r.tex_width * (size_t)r.tex_height * 3;
    uint8_t *px = malloc(n);
    char *path = sp_path_join_alloc(dir, "albedo.png");
    if (!px || !path) {
        free(px);
        free(path);
        return -ENOMEM;
    }
    for (size_t i = 0; i < n; i++) {
        double v = (double)r.albedo[i];
        v = v > 0.0 ? pow(v > 1.0 ? 1.0 : v, 1.0 / 2.2) : 0.0;
        px[i] = (uint8_t)lround(255.0 * v);
    }
    ret = sp_png_write(path, px, (uint32_t)r.tex_width, (uint32_t)r.tex_height, (uint32_t)r.tex_width * 3, 3);
    free(px);
    free(path);
    return ret;
}

int sp_face_dir_write_all(const sp_sunstage *ss, const char *dir)
{
    int ret = sp_face_dir_write(ss, dir);
    return ret ? ret : write_albedo_png(ss, dir);
}
