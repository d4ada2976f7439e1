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

typedef int (*tiled_open_fn)(sp_tiled_image **, const char *, uint32_t, uint32_t, uint32_t);
typedef int (*tiled_rows_fn)(sp_tiled_image *, uint32_t, const float *);
typedef int (*tiled_close_fn)(sp_tiled_image **);

static sp_module_slot sp_tiled_open_slot, sp_tiled_rows_slot, sp_tiled_close_slot;
int sp_tiled_open(sp_tiled_image **out, const char *path, uint32_t width, uint32_t height, uint32_t tile)
{
    tiled_open_fn fn = (tiled_open_fn)sp_module_symbol_cached(&sp_module_oiio, "sp_tiled_open", &sp_tiled_open_slot);
    return fn ? fn(out, path, width, height, tile) : SP_EMODULE;
}

int sp_tiled_rows(sp_tiled_image *t, uint32_t n, const float *rgb)
{
    tiled_rows_fn fn = (tiled_rows_fn)sp_module_symbol_cached(&sp_module_oiio, "sp_tiled_rows", &sp_tiled_rows_slot);
    return fn ? fn(t, n, rgb) : SP_EMODULE;
}

int sp_tiled_close(sp_tiled_image **t)
{
    tiled_close_fn fn = (tiled_close_fn)sp_module_symbol_cached(&sp_module_oiio, "sp_tiled_close", &sp_tiled_close_slot);
    return fn ? fn(t) : SP_EMODULE;
}
