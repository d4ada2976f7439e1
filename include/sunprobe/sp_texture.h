/* SPDX-License-Identifier: MIT */
/*
 * Example-based texture synthesis in bounded memory (pipeline/texture/TEXTURE.md):
 * a multi-scale patch optimisation in which each iteration cuts the output into
 * crops at a random offset, matches every crop's patches to the exemplar
 * (PatchMatch with a penalty on reusing one exemplar region) and sets each pixel
 * to the mean of the votes covering it; the finest level is then laid again in
 * image-quilting-style blocks joined along minimum-error cuts, and the band
 * about the cuts optimised towards exemplar patches. Large outputs are made tile by tile,
 * each tile constrained by the finished pixels around it, and handed out in
 * bands of rows as they finish. The result depends on the seed only, never on
 * the thread count.
 *
 * Images are float RGB in [0, 1] (any encoding: the synthesis compares values), interleaved, rows top first.
 */
#ifndef SUNPROBE_SP_TEXTURE_H
#define SUNPROBE_SP_TEXTURE_H

#include <stddef.h>
#include <stdint.h>

#include "sp_common.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SP_TEXTURE_MAX_SIDE 1000000u /* the longest output side accepted */

typedef struct sp_texture_settings {
    int patch;          /* patch side in pixels, 4..32, default 8 */
    int tile;           /* tile core side in pixels, >= 4 * patch (at least 64), default 256 */
    int levels;         /* pyramid levels, 0 (default): as many as the exemplar allows, at most 4 */
    int iterations;     /* optimisation passes at the finest level (doubled per coarser one), 1..16, default 3 */
    int threads;        /* 0 (default): every online CPU */
    double reuse;       /* penalty on reusing an exemplar region, 0..10, default 0.5 (the blocks: of those
                           within a factor 1 + 0.25 x reuse of the best fit, the least used region and
                           colours are laid) */
    uint64_t seed;      /* default 1 */
    int tileable;       /* 1: the output wraps left-right and top-bottom (default 0) */
} sp_texture_settings;

/* Fills s with the defaults above. */
SP_API void sp_texture_default_settings(sp_texture_settings *s);

/*
 * Receives rows [y0, y0 + n_rows) of the output, each width * 3 floats (borrowed
 * for the call), top to bottom, every row exactly once. A non-zero return stops
 * the synthesis, which then returns that value.
 */
typedef int (*sp_texture_sink)(void *ctx, uint32_t y0, uint32_t n_rows, const float *rgb);

/*
 * Synthesises a width x height texture like the exemplar (ew x eh pixels,
 * borrowed) and hands it to sink row by row. Memory: one tile window, the
 * pyramids and one row, whatever the size; the finished rows wait in an unlinked
 * scratch file in $TMPDIR (else /tmp) of at most width x (tile + 8 patch) x 12 bytes. Returns 0, -EINVAL for bad settings or sizes (an exemplar side below
 * the patch; an output side of 0, below the patch or above SP_TEXTURE_MAX_SIDE;
 * a tileable side below 16 patches; a tile below 8 patches or above 4096),
 * -ENOMEM, -errno when the scratch file cannot be made or written, or the sink's value.
 */
SP_API int sp_texture_synthesize(const float *exemplar, uint32_t ew, uint32_t eh, uint32_t width, uint32_t height,
                                 const sp_texture_settings *s, sp_texture_sink sink, void *ctx);

/*
 * Hole filling in place: the pixels of rgb (w x h) where fill[i] is non-zero are
 * replaced by texture synthesised from the patches lying wholly where source[i]
 * is non-zero, the other pixels held fixed so the fill continues them. Uses
 * patch, levels, iterations, threads, reuse and seed from s. Returns 0, -EINVAL,
 * -ENOMEM, or SP_ENODATA when no whole patch fits in the source.
 */
SP_API int sp_texture_fill(float *rgb, uint32_t w, uint32_t h, const uint8_t *fill, const uint8_t *source,
                           const sp_texture_settings *s);

#ifdef __cplusplus
}
#endif
#endif
