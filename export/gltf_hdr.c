/* SPDX-License-Identifier: MIT */
/* Radiance RGBE (.hdr) writer for the environment map: flat (not run-length encoded) scanlines. */
#include "export/gltf_internal.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>

#include "common/atomic_file.h"

/* Shared-exponent encoding of one linear RGB texel; negative and non-finite values become 0. */
static void rgbe(const float *rgb, unsigned char out[4])
{
    double c[3], m = 0.0;
    for (int k = 0; k < 3; k++) {
        c[k] = isfinite(rgb[k]) && rgb[k] > 0.0f ? (double)rgb[k] : 0.0;
        m = c[k] > m ? c[k] : m;
    }
    if (m < 1e-32) {
        out[0] = out[1] = out[2] = out[3] = 0;
        return;
    }
    if (m > 1e38)
        m = 1e38;
    int e;
    double scale = frexp(m, &e) * 256.0 / m; /* m = f * 2^e, f in [0.5, 1) */
    for (int k = 0; k < 3; k++) {
        double v = (c[k] > m ? m : c[k]) * scale;
        out[k] = (unsigned char)(v >= 255.0 ? 255.0 : v);
    }
    out[3] = (unsigned char)(e + 128);
}

int sp_hdr_write(const char *path, const float *rgb, int width, int height)
{
    if (!path || !rgb || width < 1 || height < 1)
        return -EINVAL;
    sp_atomic_file af;
    int ret = sp_atomic_file_open(&af, path);
    if (ret)
        return ret;
    if (fprintf(af.file, "#?RADIANCE\n# sunprobe environment map, equirectangular\nFORMAT=32-bit_rle_rgbe\n\n"
                         "-Y %d +X %d\n", height, width) < 0)
        ret = -EIO;
    for (size_t i = 0; !ret && i < (size_t)width * (size_t)height; i++) {
        unsigned char px[4];
        rgbe(rgb + i * 3, px);
        if (fwrite(px, 1, 4, af.file) != 4)
            ret = -EIO;
    }
    return sp_atomic_file_finish(&af, ret);
}
