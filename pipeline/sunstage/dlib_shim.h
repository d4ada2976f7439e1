/* SPDX-License-Identifier: MIT */
/* C interface to dlib's HOG face detector and 68-point shape predictor (dlib_shim.cpp, built with HAVE_DLIB). */
#ifndef SUNPROBE_SUNSTAGE_DLIB_SHIM_H
#define SUNPROBE_SUNSTAGE_DLIB_SHIM_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* A detection: the box in image pixels (left, top, right, bottom, inclusive as dlib has it) and the SVM score. */
typedef struct sp_dlib_face {
    double box[4];
    double score;
} sp_dlib_face;

/* Loads the predictor at path (borrowed); *ctx owned by the caller. 0, -ENOENT or SP_ECORRUPT. */
int sp_dlib_open(void **ctx, const char *path);
void sp_dlib_close(void *ctx);
/*
 * Faces in a w x h grey image (borrowed) with a score above adjust (dlib's threshold is 0; negative finds
 * more), best first, at most max into faces. Returns the number found or a negative error.
 */
int sp_dlib_detect(void *ctx, const uint8_t *gray, int w, int h, double adjust, sp_dlib_face *faces, int max);
/* The 68 landmarks (x, y pixel pairs into lm) the shape predictor places from box (as sp_dlib_face.box). */
int sp_dlib_shape(void *ctx, const uint8_t *gray, int w, int h, const double box[4], float lm[136]);

#ifdef __cplusplus
}
#endif
#endif
