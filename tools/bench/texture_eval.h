/* SPDX-License-Identifier: MIT */
/*
 * Procedural exemplars and the quality measures of bench_texture (also used by
 * the texture tests): coherence, verbatim repetition, tile-border seams and
 * colour / autocorrelation statistics. Images are float RGB in [0, 1].
 */
#ifndef SUNPROBE_TOOLS_BENCH_TEXTURE_EVAL_H
#define SUNPROBE_TOOLS_BENCH_TEXTURE_EVAL_H

#include <stdint.h>

typedef struct tev_image {
    float *px; /* w x h x 3, owned */
    int w, h;
} tev_image;

enum tev_kind { TEV_BRICKS, TEV_BLOBS, TEV_STONES, TEV_KINDS };

/* A procedural exemplar: near-regular bricks, stochastic coloured blobs, or irregular stones. 0 or -ENOMEM. */
int tev_procedural(tev_image *out, enum tev_kind kind, int w, int h, uint64_t seed);
const char *tev_kind_name(enum tev_kind kind);
void tev_free(tev_image *im);

/*
 * Mean over output patches (p x p, one at a fixed random place in each step x
 * step cell) of the distance to
 * their nearest exemplar patch (exhaustive search on the exemplar at stride 1),
 * divided by the same for the exemplar's own patches excluding matches that
 * overlap them (leave-one-out). ~1: as coherent as the exemplar with itself.
 */
double tev_coherence(const tev_image *out, const tev_image *ex, int p, int step);

/*
 * The largest 4-connected region of output pixels that equal the exemplar
 * pixel at one fixed offset (exactly, to 1/255), as a share of the exemplar's
 * area. Pixels are matched to the offset of their exact-match patch (3x3).
 */
double tev_repetition(const tev_image *out, const tev_image *ex);

/*
 * Mean squared difference between adjacent pixels across the lines x = k * tile
 * and y = k * tile, divided by the same across the lines 2, 4, .. 32 pixels
 * away (even shifts, so a texture with a 2-pixel period compares like with
 * like). 1: no seam.
 */
double tev_seam_ratio(const tev_image *out, int tile);
/*
 * The same ratio across the lines first, first + period, ...: a control, what the ratio is on lines that are no
 * tile border. On a structured texture a mortar line or a joint lying on the measured line by chance moves a
 * single image's ratio well past 1 either way; a seam is measurable only when the borders' ratio exceeds a
 * control's, taken on lines like them in all but the border, more often than chance over many outputs.
 */
double tev_seam_ratio_at(const tev_image *out, int first, int period); /* 1 for first or period <= 0 */

/* L1 distance of the normalised 8x8x8 colour histograms (0..2). */
double tev_histogram_distance(const tev_image *a, const tev_image *b);
/* RMS difference of the normalised luminance autocorrelation over shifts up to r pixels. */
double tev_autocorr_distance(const tev_image *a, const tev_image *b, int r);

#endif
