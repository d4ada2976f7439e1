/* SPDX-License-Identifier: MIT */
/* oiio_shim.h's function forwarded to the sunprobe-oiio module, loaded on first use (common/module.h). */
#include "oiio_shim.h"

#include <errno.h>

#include "common/module.h"

typedef int (*exr_write_fn)(const char *, const float *, uint32_t, uint32_t, int);

typedef int (*image_read_fn)(const char *, float **, uint32_t *, uint32_t *);

static sp_module_slot sp_image_read_slot;
int sp_image_read_rgb(const char *path, float **rgb, uint32_t *width, uint32_t *height)
{
    image_read_fn fn = (image_read_fn)sp_module_symbol_cached(&sp_module_oiio, "sp_image_read_rgb", &sp_image_read_slot);
    return fn ? fn(path, rgb, width, height) : SP_EMODULE;
}

static sp_module_slot sp_exr_write_slot;
int sp_exr_write(const char *path, const float *pixels, uint32_t width, uint32_t height, int channels)
{
    exr_write_fn fn = (exr_write_fn)sp_module_symbol_cached(&sp_module_oiio, "sp_exr_write", &sp_exr_write_slot);
    return fn ? fn(path, pixels, width, height, channels) : SP_EMODULE;
}
