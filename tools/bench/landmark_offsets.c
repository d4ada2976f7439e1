/* SPDX-License-Identifier: MIT */
/*
 * landmark_offsets: how far dlib's 68 points (the 300-W annotation) lie from
 * the face model's own landmark vertices (the points the fit aligns to), on
 * the project's synthetic selfies. Renders frames of several seeds (each a
 * different identity, expression, sun and turn), tracks them with the
 * front end's tracker and averages, per point, the offset from the tracked
 * point to the true one in the face's own frame (x along the eye line, y
 * perpendicular, in inter-ocular distances). Prints the table as C for
 * pipeline/sunstage/landmark_offsets.h and the error before and after
 * applying the built-in table (measure it on seeds it was not made from).
 *
 * usage: landmark_offsets [--seeds A-B] [--step N] [--size WxH]
 */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "pipeline/sunstage/landmarks.h"
#include "sunprobe/sp_synth.h"

typedef struct stats {
    double sum[136];
    double err_raw, err_corrected;
    long frames, missed;
} stats;

static void to_rgb24(const float *img, int n, uint8_t *rgb)
{
    for (int i = 0; i < 3 * n; i++) {
        double v = img[i] < 0.0f ? 0.0 : (img[i] > 1.0f ? 1.0 : (double)img[i]);
        rgb[i] = (uint8_t)lround(255.0 * v);
    }
}

static double mean_error(const double *lm, const float *truth)
{
    double iod = hypot((double)truth[90] - (double)truth[72], (double)truth[91] - (double)truth[73]), e = 0.0;
    for (int k = 0; k < 68; k++)
        e += hypot(lm[2 * k] - (double)truth[2 * k], lm[2 * k + 1] - (double)truth[2 * k + 1]) / 68.0;
    return e / iod;
}

static int run_seed(uint64_t seed, int w, int h, int step, stats *st)
{
    sp_synth_selfie_settings s;
    sp_synth_selfie_default_settings(&s);
    s.width = (uint32_t)w, s.height = (uint32_t)h, s.seed = seed;
    s.n_relit = s.n_novel = 0;
    sp_synth_selfie *g = NULL;
    ss_lm_tracker *t = NULL;
    uint8_t *rgb = malloc((size_t)w * (size_t)h * 3);
    int ret = rgb ? sp_synth_selfie_open(&g, &s) : -1;
    ss_lm_settings ls;
    ss_lm_default_settings(&ls);
    ls.model_offsets = 0; /* raw dlib points */
    if (!ret)
        ret = ss_lm_tracker_open(&t, &ls);
    uint64_t n = ret ? 0 : sp_synth_selfie_get_truth(g)->n_frames;
    for (uint64_t i = 0; !ret && i < n; i += (uint64_t)step) {
        sp_render_outputs o;
        sp_synth_frame_truth ft;
        if ((ret = sp_synth_selfie_render_frame(g, i, 0.0, &o)) || (ret = sp_synth_selfie_frame_truth(g, i, &ft)))
            break;
        to_rgb24(o.image, w * h, rgb);
        ss_lm_result r;
        if ((ret = ss_lm_tracker_frame(t, rgb, w, h, &r)))
            break;
        if (r.source == SS_LM_NONE) {
            st->missed++;
            continue;
        }
        const double *raw = r.lm;
        double corrected[136];
        memcpy(corrected, raw, sizeof(corrected));
        ss_lm_apply_offsets(corrected);
        double ex = raw[90] - raw[72], ey = raw[91] - raw[73], iod = hypot(ex, ey);
        ex /= iod, ey /= iod;
        for (int k = 0; k < 68; k++) {
            double dx = (double)ft.landmarks[2 * k] - raw[2 * k], dy = (double)ft.landmarks[2 * k + 1] - raw[2 * k + 1];
            st->sum[2 * k] += (dx * ex + dy * ey) / iod;
            st->sum[2 * k + 1] += (-dx * ey + dy * ex) / iod;
        }
        st->err_raw += mean_error(raw, ft.landmarks);
        st->err_corrected += mean_error(corrected, ft.landmarks);
        st->frames++;
    }
    if (t) {
        double k, ox, oy;
        int nb;
        ss_lm_tracker_box_relation(t, &k, &ox, &oy, &nb);
        fprintf(stderr, "seed %d: detector box over the points' box %.4f, centre offset %+.4f, %+.4f (%d detections)\n",
                (int)seed, k, ox, oy, nb);
    }
    ss_lm_tracker_close(&t);
    sp_synth_selfie_close(&g);
    free(rgb);
    return ret;
}

int main(int argc, char **argv)
{
    int seed0 = 1, seed1 = 6, step = 15, w = 480, h = 360;
    static const struct option opts[] = { { "seeds", required_argument, NULL, 's' },
                                          { "step", required_argument, NULL, 'n' },
                                          { "size", required_argument, NULL, 'z' },
                                          { NULL, 0, NULL, 0 } };
    for (int c; (c = getopt_long(argc, argv, "", opts, NULL)) != -1;) {
        if (c == 's' && sscanf(optarg, "%d-%d", &seed0, &seed1) == 2 && seed0 >= 0 && seed1 >= seed0)
            continue;
        if (c == 'n' && (step = atoi(optarg)) > 0)
            continue;
        if (c == 'z' && sscanf(optarg, "%dx%d", &w, &h) == 2 && w >= 64 && h >= 64 && w <= 4096 && h <= 4096)
            continue;
        fprintf(stderr, "usage: landmark_offsets [--seeds A-B] [--step N] [--size WxH]\n");
        return 1;
    }
    stats st = { 0 };
    for (int seed = seed0; seed <= seed1; seed++) {
        int ret = run_seed((uint64_t)seed, w, h, step, &st);
        if (ret) {
            fprintf(stderr, "landmark_offsets: seed %d: %s\n", seed, sp_strerror(ret));
            return 3;
        }
        fprintf(stderr, "seed %d: %ld frames so far, %ld without landmarks\n", seed, st.frames, st.missed);
    }
    if (!st.frames)
        return 2;
    printf("/* landmark_offsets --seeds %d-%d --step %d --size %dx%d: %ld frames */\n", seed0, seed1, step, w, h,
           st.frames);
    printf("static const float landmark_offsets[136] = {\n");
    for (int k = 0; k < 68; k++)
        printf("%s%+.4ff, %+.4ff,%s", k % 4 == 0 ? "    " : " ", st.sum[2 * k] / (double)st.frames,
               st.sum[2 * k + 1] / (double)st.frames, k % 4 == 3 ? "\n" : "");
    printf("};\n");
    fprintf(stderr, "mean error over the inter-ocular distance: raw %.2f%%, with the built-in table %.2f%% (%ld frames, "
                    "%ld without landmarks)\n",
            100.0 * st.err_raw / (double)st.frames, 100.0 * st.err_corrected / (double)st.frames, st.frames, st.missed);
    return 0;
}
