/* SPDX-License-Identifier: MIT */
/*
 * The probe's C face of OpenCV (opencv_probe_shim.cpp, compiled only under
 * HAVE_OPENCV): the HOG people detector that can confirm person-shaped objects,
 * GrabCut for an object's silhouette in its box, and the MOG2 background
 * subtractor and Telea inpainting the benchmarks compare against. Pixels
 * cross as packed RGB24; no C++ exception escapes. Internal, not installed.
 */
#ifndef SUNPROBE_PIPELINE_PROBE_OPENCV_PROBE_SHIM_H
#define SUNPROBE_PIPELINE_PROBE_OPENCV_PROBE_SHIM_H

#include <stddef.h>
#include <stdint.h>
#include "common/private_api.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sp_cv_hog sp_cv_hog;

/* OpenCV's default 64x128 people detector (Dalal-Triggs HOG + linear SVM). */
SP_PRIVATE int sp_cv_hog_open(sp_cv_hog **out);
/*
 * SVM margin of one detection window fitted around the box x0..x1, y0..y1
 * (inclusive pixels) of an RGB24 image (borrowed): the box is padded by an
 * eighth of its height, as in the training windows, and resampled to 64x128.
 * Positive means "person".
 */
int sp_cv_hog_score(sp_cv_hog *hog, const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, int x0,
                    int y0, int x1, int y1, double *score);
SP_PRIVATE void sp_cv_hog_close(sp_cv_hog **hog);
/*
 * Whole-image detection with the same detector (detectMultiScale, grouped): up to `cap` boxes as
 * x0, y0, x1, y1 (inclusive pixels) into boxes (4 ints each); *n is how many were found. The image is
 * upscaled by `upscale` (1..4) first, so people shorter than the 128-px window are found.
 */
SP_PRIVATE int sp_cv_hog_detect(sp_cv_hog *hog, const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride,
                     double upscale, int *boxes, unsigned cap, unsigned *n);

/* OpenCV's Telea inpainting (photo module) of the pixels where mask != 0, in place: a baseline. */
int sp_cv_inpaint_telea(uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, const uint8_t *mask,
                        double radius);

/*
 * OpenCV's GrabCut of the object in the box x0..x1, y0..y1 (inclusive pixels) of an RGB24 image: the colour
 * models are learnt on a crop around the box (half its width and a quarter of its height each side, at
 * least 8 px), the box's outside as background. A box shorter than min_height is cut on the crop enlarged
 * (bicubic) until it is that tall or the crop is a megapixel, the answer read back at the image's pixels.
 * Sets mask (image-sized, width bytes a row) to 1 where the box's pixels come out (probably) foreground,
 * leaves the rest. Deterministic.
 * SP_ENODATA for a box under 3 px or without background around it, -EINVAL, -EIO.
 */
int sp_cv_grabcut_box(const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, int x0, int y0, int x1,
                      int y1, int iterations, int min_height, uint8_t *mask);

typedef struct sp_cv_mog2 sp_cv_mog2;

/* OpenCV's MOG2 background subtractor with its usual parameters. */
int sp_cv_mog2_open(sp_cv_mog2 **out, int history, double var_threshold, int detect_shadows);
/* Updates the model with one RGB24 frame and writes the foreground mask (0, 127 shadow, 255). */
int sp_cv_mog2_apply(sp_cv_mog2 *m, const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride,
                     uint8_t *mask, uint32_t mask_stride);
void sp_cv_mog2_close(sp_cv_mog2 **m);

/* OpenCV's own worker threads (benchmarks compare single-threaded). */
void sp_cv_set_threads(int n);

#ifdef __cplusplus
}
#endif
#endif
