/* SPDX-License-Identifier: MIT */
/*
 * The dlib front end on a face: a synthetic selfie frame (sp_synth, its first
 * frame, noise-free) through dlib's HOG detector and 68-point shape predictor,
 * compared with the synthesiser's true landmarks. Prints the mean and largest
 * pixel error. Skips (77, with the reason) without dlib in the build, without
 * libdlib-data's shape_predictor_68_face_landmarks.dat, or when the HOG
 * detector does not find the rendered face.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/stat.h>

#include "check.h"
#include "sp_config.h"
#include "sunprobe/sp_render.h"
#include "sunprobe/sp_synth.h"
#if HAVE_DLIB
#include "pipeline/sunstage/dlib_shim.h"
#endif

#define MODEL "/usr/share/dlib/shape_predictor_68_face_landmarks.dat"
#define SIZE 320

#if HAVE_DLIB
/* Renders frame 0 into grey bytes; its true landmarks into lm. */
static int render_face(uint8_t *gray, float lm[136])
{
    sp_synth_selfie_settings s;
    sp_synth_selfie_default_settings(&s);
    s.width = s.height = SIZE;
    s.noise = 0.0;
    s.n_relit = s.n_novel = 0;
    sp_synth_selfie *g = NULL;
    int ret = sp_synth_selfie_open(&g, &s);
    sp_render_outputs o;
    sp_synth_frame_truth t;
    if (!ret)
        ret = sp_synth_selfie_render_frame(g, 0, 0.0, &o);
    if (!ret)
        ret = sp_synth_selfie_frame_truth(g, 0, &t);
    if (!ret) {
        for (int i = 0; i < SIZE * SIZE; i++) {
            const float *p = o.image + (size_t)i * 3;
            double y = 0.299 * (double)p[0] + 0.587 * (double)p[1] + 0.114 * (double)p[2];
            gray[i] = (uint8_t)lround(255.0 * (y < 0.0 ? 0.0 : (y > 1.0 ? 1.0 : y)));
        }
        for (int k = 0; k < 136; k++)
            lm[k] = t.landmarks[k];
    }
    sp_synth_selfie_close(&g);
    return ret;
}
#endif

int main(void)
{
#if !HAVE_DLIB
    SKIP("this build has no dlib (meson option -Ddlib=enabled)");
#else
    struct stat st;
    if (stat(MODEL, &st) != 0)
        SKIP("no " MODEL " (Debian package libdlib-data)");
    uint8_t *gray = malloc(SIZE * SIZE);
    float truth[136], found[136];
    CHECK(gray != NULL);
    if (!gray)
        return check_exit();
    int ret = render_face(gray, truth);
    CHECK_MSG(ret == 0, "synthetic frame: %d", ret);
    void *ctx = NULL;
    if (!ret) {
        ret = sp_dlib_open(&ctx, MODEL);
        CHECK_MSG(ret == 0, "loading %s: %d", MODEL, ret);
    }
    if (!ret && sp_dlib_landmarks(ctx, gray, SIZE, SIZE, found) != 0) {
        sp_dlib_close(ctx);
        free(gray);
        SKIP("dlib's HOG detector found no face in the synthetic frame");
    }
    if (!ret) {
        double sum = 0.0, worst = 0.0;
        for (int k = 0; k < 68; k++) {
            double e = hypot((double)(found[2 * k] - truth[2 * k]), (double)(found[2 * k + 1] - truth[2 * k + 1]));
            CHECK(isfinite(e));
            sum += e / 68.0;
            worst = fmax(worst, e);
        }
        /* inter-ocular distance (outer eye corners 36 and 45) sets the scale of the tolerance */
        double iod = hypot((double)(truth[90] - truth[72]), (double)(truth[91] - truth[73]));
        printf("dlib on a synthetic %dx%d face: mean landmark error %.2f px, largest %.2f px, inter-ocular %.1f px\n",
               SIZE, SIZE, sum, worst, iod);
        CHECK_MSG(iod > 10.0, "inter-ocular distance %.1f px", iod);
        CHECK_MSG(sum < 0.15 * iod, "mean landmark error %.2f px (inter-ocular %.1f px)", sum, iod);
    }
    sp_dlib_close(ctx);
    free(gray);
    return check_exit();
#endif
}
