/* SPDX-License-Identifier: MIT */
/* C interface to dlib's HOG face detector and 68-point shape predictor (dlib_shim.cpp, built with HAVE_DLIB). */
#ifndef SUNPROBE_SUNSTAGE_DLIB_SHIM_H
#define SUNPROBE_SUNSTAGE_DLIB_SHIM_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Loads the predictor at path (borrowed); *ctx owned by the caller. 0, -ENOENT or SP_ECORRUPT. */
int sp_dlib_open(void **ctx, const char *path);
void sp_dlib_close(void *ctx);
/* Largest face in a w x h grey image (borrowed): 68 (x, y) pixel pairs into lm. 0, or SP_ENODATA without a face. */
int sp_dlib_landmarks(void *ctx, const uint8_t *gray, int w, int h, float lm[136]);

#ifdef __cplusplus
}
#endif
#endif
