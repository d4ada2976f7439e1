/* SPDX-License-Identifier: MIT */
/*
 * The landmark tracker (pipeline/sunstage/landmarks.h) at its extremes, on
 * synthetic selfie frames (sp_synth, frame 0, noise-free) against the
 * synthesiser's true landmarks: a 40 px face, a 230 px face, a frame wider
 * than the search's working size, a face exposed
 * seven times too dark, a face lit from the side; a frame without a face finds
 * nothing; the model offsets turn with the face. Prints the mean error over the
 * inter-ocular distance per case. Skips (77, with the reason) without dlib in
 * the build or without libdlib-data's shape_predictor_68_face_landmarks.dat.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "check.h"
#include "pipeline/sunstage/landmarks.h"
#include "sp_config.h"
#include "sunprobe/sp_render.h"
#include "sunprobe/sp_synth.h"

#define MODEL "/usr/share/dlib/shape_predictor_68_face_landmarks.dat"

#if HAVE_DLIB
typedef struct face_case {
    const char *name;
    int size;          /* square frame side */
    double gain;       /* display values scaled by this */
    double sun_az_deg; /* NAN: the synthesiser's default */
} face_case;

/* Renders frame 0 of a seed-1 selfie into rgb (size x size RGB24); its true landmarks into lm. */
static int render_face(const face_case *c, uint8_t *rgb, double lm[136])
{
    sp_synth_selfie_settings s;
    sp_synth_selfie_default_settings(&s);
    s.width = s.height = (uint32_t)c->size;
    s.noise = 0.0;
    s.n_relit = s.n_novel = 0;
    if (isfinite(c->sun_az_deg))
        s.sun_azimuth_deg = c->sun_az_deg, s.sun_elevation_deg = 10.0;
    sp_synth_selfie *g = NULL;
    int ret = sp_synth_selfie_open(&g, &s);
    sp_render_outputs o;
    sp_synth_frame_truth t;
    if (!ret)
        ret = sp_synth_selfie_render_frame(g, 0, 0.0, &o);
    if (!ret)
        ret = sp_synth_selfie_frame_truth(g, 0, &t);
    for (int i = 0; !ret && i < 3 * c->size * c->size; i++) {
        double v = c->gain * (double)o.image[i];
        rgb[i] = (uint8_t)lround(255.0 * (v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v)));
    }
    for (int k = 0; !ret && k < 136; k++)
        lm[k] = (double)t.landmarks[k];
    sp_synth_selfie_close(&g);
    return ret;
}

static void check_case(const face_case *c)
{
    uint8_t *rgb = malloc((size_t)c->size * (size_t)c->size * 3);
    double truth[136];
    CHECK(rgb != NULL);
    int ret = rgb ? render_face(c, rgb, truth) : -1;
    CHECK_MSG(ret == 0, "%s: synthetic frame: %d", c->name, ret);
    ss_lm_tracker *t = NULL;
    if (!ret)
        CHECK_MSG((ret = ss_lm_tracker_open(&t, NULL)) == 0, "%s: opening the tracker: %d", c->name, ret);
    ss_lm_result r;
    if (!ret)
        CHECK_MSG((ret = ss_lm_tracker_frame(t, rgb, c->size, c->size, &r)) == 0, "%s: %d", c->name, ret);
    if (!ret) {
        CHECK_MSG(r.source == SS_LM_SEARCHED, "%s: no landmarks (source %d)", c->name, (int)r.source);
        double iod = ss_lm_interocular(truth), err = 0.0;
        for (int k = 0; k < 68; k++)
            err += hypot(r.lm[2 * k] - truth[2 * k], r.lm[2 * k + 1] - truth[2 * k + 1]) / 68.0;
        printf("%-22s %4d px frame, inter-ocular %5.1f px: mean error %.2f%% of it, drift %.2f%%\n", c->name, c->size,
               iod, 100.0 * err / iod, 100.0 * r.drift);
        if (r.source != SS_LM_NONE) {
            /* dlib against the model's vertices is ~4% (tools/bench/landmark_offsets); twice that is a failure */
            CHECK_MSG(err < 0.08 * iod, "%s: mean landmark error %.2f px (inter-ocular %.1f px)", c->name, err, iod);
            CHECK_MSG(r.drift >= 0.0 && r.drift <= 0.06, "%s: drift %g", c->name, r.drift);
        }
        /* the next frame is the same: it is tracked, and lands where the first did */
        ss_lm_result again;
        CHECK(ss_lm_tracker_frame(t, rgb, c->size, c->size, &again) == 0);
        CHECK_MSG(again.source == SS_LM_TRACKED, "%s: second frame source %d", c->name, (int)again.source);
        double moved = 0.0;
        for (int k = 0; again.source != SS_LM_NONE && k < 68; k++)
            moved += hypot(again.lm[2 * k] - r.lm[2 * k], again.lm[2 * k + 1] - r.lm[2 * k + 1]) / 68.0;
        CHECK_MSG(moved < 0.03 * iod, "%s: the tracked frame moved %.2f px", c->name, moved);
    }
    ss_lm_tracker_close(&t);
    free(rgb);
}

/* A flat grey frame with a gradient: nothing is found, and nothing is made up. */
static void check_no_face(void)
{
    enum { W = 320, H = 240 };
    uint8_t *rgb = malloc(W * H * 3);
    CHECK(rgb != NULL);
    if (!rgb)
        return;
    for (int i = 0; i < W * H * 3; i++)
        rgb[i] = (uint8_t)(60 + (i / 3) % W / 4);
    ss_lm_tracker *t = NULL;
    ss_lm_result r;
    CHECK(ss_lm_tracker_open(&t, NULL) == 0);
    CHECK(t && ss_lm_tracker_frame(t, rgb, W, H, &r) == 0 && r.source == SS_LM_NONE);
    ss_lm_tracker_close(&t);
    CHECK(t == NULL);
    free(rgb);
}

/* The model offsets are in the face's frame: rotating and scaling the points rotates and scales the result. */
static void check_offsets_turn_with_the_face(void)
{
    double a[136], b[136];
    for (int k = 0; k < 68; k++) /* any points with distinct eye corners */
        a[2 * k] = 100.0 + 40.0 * cos(0.3 * k), a[2 * k + 1] = 80.0 + 30.0 * sin(0.7 * k);
    const double c = cos(0.9), s = sin(0.9), z = 2.5;
    for (int k = 0; k < 68; k++)
        b[2 * k] = z * (c * a[2 * k] - s * a[2 * k + 1]), b[2 * k + 1] = z * (s * a[2 * k] + c * a[2 * k + 1]);
    ss_lm_apply_offsets(a);
    ss_lm_apply_offsets(b);
    double worst = 0.0, moved = 0.0;
    for (int k = 0; k < 68; k++) {
        double x = z * (c * a[2 * k] - s * a[2 * k + 1]), y = z * (s * a[2 * k] + c * a[2 * k + 1]);
        worst = fmax(worst, hypot(x - b[2 * k], y - b[2 * k + 1]));
    }
    for (int k = 0; k < 68; k++)
        moved += fabs(a[2 * k] - (100.0 + 40.0 * cos(0.3 * k)));
    CHECK_MSG(worst < 1e-9, "offsets differ by %g px after a rotation", worst);
    CHECK_MSG(moved > 1e-3, "the offsets moved nothing");
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
    check_offsets_turn_with_the_face();
    static const face_case cases[] = {
        { "40 px face", 160, 1.0, NAN },
        { "medium face", 320, 1.0, NAN },
        { "230 px face", 960, 1.0, NAN },
        { "1280 px frame", 1280, 1.0, NAN }, /* searched reduced to 960 px first */
        { "underexposed 7x", 320, 1.0 / 7.0, NAN },
        { "sun from the side", 320, 1.0, 240.0 },
    };
    for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++)
        check_case(&cases[i]);
    check_no_face();
    return check_exit();
#endif
}
