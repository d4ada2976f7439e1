/* SPDX-License-Identifier: MIT */
/* The dlib shim in a build without dlib: every call says the feature was left out. */
#include "pipeline/sunstage/dlib_shim.h"

#include "sunprobe/sp_common.h"

int sp_dlib_open(void **ctx, const char *path)
{
    (void)path;
    if (ctx)
        *ctx = 0;
    return SP_EDISABLED;
}

void sp_dlib_close(void *ctx)
{
    (void)ctx;
}

int sp_dlib_detect(void *ctx, const uint8_t *gray, int w, int h, double adjust, sp_dlib_face *faces, int max)
{
    (void)ctx, (void)gray, (void)w, (void)h, (void)adjust, (void)faces, (void)max;
    return SP_EDISABLED;
}

int sp_dlib_shape(void *ctx, const uint8_t *gray, int w, int h, const double box[4], float lm[136])
{
    (void)ctx, (void)gray, (void)w, (void)h, (void)box, (void)lm;
    return SP_EDISABLED;
}
