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

#ifdef __cplusplus
extern "C" {
#endif

/*
 * Writes width x height float pixels of 1..4 channels (row-major, top row
 * first, borrowed) as a 32-bit float OpenEXR file, atomically (a temporary
 * beside `path`, then rename). Returns 0, -EINVAL, or -EIO with the reason logged.
 */
int sp_exr_write(const char *path, const float *pixels, uint32_t width, uint32_t height, int channels);

/*
 * Reads the first subimage of `path` as RGB floats (*rgb malloc'd, width x height x 3, top row first;
 * one channel is replicated, a fourth dropped), linear as the file stores it. Returns 0, -ENOENT,
 * SP_EFORMAT (no reader for it, or not an image: the reason logged), -ENOMEM or -EIO.
 */
int sp_image_read_rgb(const char *path, float **rgb, uint32_t *width, uint32_t *height);

#ifdef __cplusplus
}
#endif
#endif
