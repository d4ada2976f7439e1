/* SPDX-License-Identifier: MIT */
/*
 * The C face of OpenImageIO (oiio_shim.cpp, compiled only under
 * HAVE_OPENIMAGEIO): float images to OpenEXR, and any image OpenImageIO
 * reads (OpenEXR, Radiance HDR, PFM, TIFF, PNG...) as floats. No C++ exception escapes.
 * Internal, not installed.
 */
#ifndef SUNPROBE_EXPORT_OIIO_SHIM_H
#define SUNPROBE_EXPORT_OIIO_SHIM_H

#include <stdint.h>
#include "common/private_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/*
 * Writes width x height float pixels of 1..4 channels (row-major, top row
 * first, borrowed) as a 32-bit float OpenEXR file, atomically (a temporary
 * beside `path`, then rename). Returns 0, -EINVAL, or -EIO with the reason logged.
 */
SP_PRIVATE int sp_exr_write(const char *path, const float *pixels, uint32_t width, uint32_t height, int channels);

/*
 * Reads the first subimage of `path` as RGB floats (*rgb malloc'd, width x height x 3, top row first;
 * one channel is replicated, a fourth dropped), linear as the file stores it. Returns 0, -ENOENT,
 * SP_EFORMAT (no reader for it, or not an image: the reason logged), -ENOMEM or -EIO.
 */
SP_PRIVATE int sp_image_read_rgb(const char *path, float **rgb, uint32_t *width, uint32_t *height);

/*
 * A tiled image (TIFF or OpenEXR, by the extension of `path`) written a row of
 * tiles at a time, so it never has to be whole in memory: rows arrive in order
 * (any count per call) and each complete row of tiles goes to the file. 8-bit for
 * TIFF, 32-bit float for EXR; `path` is written in place (the caller names a
 * temporary and renames it). Errors: -EINVAL, -ENOMEM, -EIO (the reason logged).
 */
typedef struct sp_tiled_image sp_tiled_image;
SP_PRIVATE int sp_tiled_open(sp_tiled_image **out, const char *path, uint32_t width, uint32_t height, uint32_t tile);
/* n RGB float rows (width x 3 each, borrowed) continuing the image. */
SP_PRIVATE int sp_tiled_rows(sp_tiled_image *t, uint32_t n, const float *rgb);
/* Writes what is left, closes and frees *t (accepts NULL); 0 only when every row came and the file closed well. */
SP_PRIVATE int sp_tiled_close(sp_tiled_image **t);

#ifdef __cplusplus
}
#endif
#endif
