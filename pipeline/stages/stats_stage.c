/* SPDX-License-Identifier: MIT */
/*
 * "stats": per-frame exposure statistics — mean luma, black and saturated pixel
 * fractions, and sharpness (variance of a 4-neighbour Laplacian) — the checks a
 * fitter uses to skip black, saturated or blurred frames. Optional CSV per frame.
 */
#include "stages.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>

#include "common/atomic_file.h"
#include "common/pixconv.h"

#define BLACK_LEVEL 16
#define SATURATED_LEVEL 250
#define BAD_FRACTION 0.9   /* a frame this black or saturated is unusable */

typedef struct stats_stage {
    FILE *csv;                 /* = out.file while the CSV is written, else NULL */
    sp_atomic_file out;        /* the CSV under a temporary name until finish succeeds */
    uint8_t *gray;
    size_t gray_size;
    uint64_t frames, black_frames, saturated_frames, undecodable;
    double luma_min, luma_max, sharp_min, sharp_max;
} stats_stage;

typedef struct frame_stats {
    double mean, black, saturated, sharpness;
} frame_stats;

static int stats_open(void **ctx, const void *settings)
{
    const sp_stage_options *options = settings;
    stats_stage *s = calloc(1, sizeof(*s));
    if (!s)
        return -ENOMEM;
    s->luma_min = s->sharp_min = INFINITY;
    s->luma_max = s->sharp_max = -INFINITY;
    if (options && options->output_path) {
        int err = sp_atomic_file_open(&s->out, options->output_path);
        if (err) {
            free(s);
            return err;
        }
        s->csv = s->out.file;
        fprintf(s->csv, "sequence,timestamp_s,mean_luma,black_fraction,saturated_fraction,sharpness,exposure_us\n");
    }
    *ctx = s;
    return 0;
}

static void measure(const uint8_t *g, uint32_t w, uint32_t h, frame_stats *out)
{
    uint64_t sum = 0, black = 0, sat = 0;
    double lap_sum = 0, lap_sq = 0;
    for (uint32_t y = 0; y < h; y++) {
        const uint8_t *row = g + (size_t)y * w;
        for (uint32_t x = 0; x < w; x++) {
            sum += row[x];
            black += row[x] < BLACK_LEVEL;
            sat += row[x] > SATURATED_LEVEL;
        }
        if (y == 0 || y + 1 >= h)
            continue;
        const uint8_t *up = row - w, *down = row + w;
        for (uint32_t x = 1; x + 1 < w; x++) {
            double lap = 4.0 * row[x] - row[x - 1] - row[x + 1] - up[x] - down[x];
            lap_sum += lap;
            lap_sq += lap * lap;
        }
    }
    double n = (double)w * h, n_lap = (double)(w > 2 ? w - 2 : 0) * (h > 2 ? h - 2 : 0);
    out->mean = (double)sum / n;
    out->black = (double)black / n;
    out->saturated = (double)sat / n;
    out->sharpness = n_lap > 0 ? fmax(lap_sq / n_lap - (lap_sum / n_lap) * (lap_sum / n_lap), 0.0) : 0.0;
}

static int stats_process(void *ctx, const sp_event *ev)
{
    stats_stage *s = ctx;
    if (ev->type != SP_EVENT_FRAME)
        return 0;
    const sp_frame *f = ev->frame;
    size_t need = (size_t)f->width * f->height;
    if (need > s->gray_size) { /* only when the frame size grows */
        uint8_t *g = realloc(s->gray, need);
        if (!g)
            return -ENOMEM;
        s->gray = g;
        s->gray_size = need;
    }
    if (sp_pixconv_frame_to_gray8(f, s->gray, s->gray_size, f->width)) {
        s->undecodable++;
        return 0;
    }
    frame_stats st;
    measure(s->gray, f->width, f->height, &st);
    s->frames++;
    s->black_frames += st.black > BAD_FRACTION;
    s->saturated_frames += st.saturated > BAD_FRACTION;
    s->luma_min = fmin(s->luma_min, st.mean);
    s->luma_max = fmax(s->luma_max, st.mean);
    s->sharp_min = fmin(s->sharp_min, st.sharpness);
    s->sharp_max = fmax(s->sharp_max, st.sharpness);
    if (s->csv)
        fprintf(s->csv, "%" PRIu64 ",%.6f,%.3f,%.5f,%.5f,%.2f,%.1f\n", f->sequence, (double)f->timestamp_ns * 1e-9,
                st.mean, st.black, st.saturated, st.sharpness, (double)f->exposure_us);
    return 0;
}

/* Puts the CSV in place only after a complete run (status 0); else removes it. Returns status or the error. */
static int commit_csv(stats_stage *s, int status)
{
    if (!s->csv)
        return status;
    s->csv = NULL;
    return sp_atomic_file_finish(&s->out, status);
}

static int stats_finish(void *ctx, FILE *summary)
{
    stats_stage *s = ctx;
    if (!s->frames) {
        fprintf(summary, "stats: no decodable frames (%" PRIu64 " undecodable)\n", s->undecodable);
        return commit_csv(s, 0);
    }
    fprintf(summary, "stats: %" PRIu64 " frames, mean luma %.1f..%.1f, sharpness %.1f..%.1f, %" PRIu64
                     " black, %" PRIu64 " saturated, %" PRIu64 " undecodable\n", s->frames, s->luma_min,
            s->luma_max, s->sharp_min, s->sharp_max, s->black_frames, s->saturated_frames, s->undecodable);
    return commit_csv(s, 0);
}

static void stats_close(void *ctx)
{
    stats_stage *s = ctx;
    if (s->csv) /* not finished, or finish failed: the previous CSV (if any) stays */
        sp_atomic_file_finish(&s->out, -ECANCELED);
    free(s->gray);
    free(s);
}

const sp_stage_ops sp_stage_stats = {
    .name = "stats",
    .writes_output = 1,
    .description = "per-frame luma, black/saturated fractions and sharpness (CSV with -o)",
    .open = stats_open,
    .push = stats_process,
    .finish = stats_finish,
    .close = stats_close,
};
