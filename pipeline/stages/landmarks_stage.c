/* SPDX-License-Identifier: MIT */
/*
 * "landmarks": the SunStage front end's landmark tracker (sunstage/landmarks.h)
 * on every frame, as a CSV with -o: how each frame's points were found
 * (tracked, detected near the last face, searched in the whole frame, none),
 * their self-consistency drift and the 68 points in capture pixels.
 */
#include "stages.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>

#include "common/atomic_file.h"
#include "common/pixconv.h"
#include "pipeline/sunstage/landmarks.h"

typedef struct landmarks_stage {
    FILE *csv;          /* = out.file while the CSV is written, else NULL */
    sp_atomic_file out; /* the CSV under a temporary name until finish succeeds */
    ss_lm_tracker *tracker;
    uint8_t *rgb;
    size_t rgb_size;
    uint64_t frames, by_source[4];
    double drift_sum;
} landmarks_stage;

static const char *const source_names[] = { "none", "tracked", "detected", "searched" };

static void lm_close(void *ctx)
{
    landmarks_stage *s = ctx;
    if (s->csv) /* not finished, or finish failed: the previous CSV (if any) stays */
        sp_atomic_file_finish(&s->out, -ECANCELED);
    ss_lm_tracker_close(&s->tracker);
    free(s->rgb);
    free(s);
}

static int lm_open(void **ctx, const void *settings)
{
    const sp_stage_options *options = settings;
    landmarks_stage *s = calloc(1, sizeof(*s));
    if (!s)
        return -ENOMEM;
    ss_lm_settings ls;
    ss_lm_default_settings(&ls);
    int ret = ss_lm_tracker_open(&s->tracker, &ls);
    if (!ret && options && options->output_path && !(ret = sp_atomic_file_open(&s->out, options->output_path)))
        s->csv = s->out.file;
    if (ret) {
        lm_close(s);
        return ret;
    }
    if (s->csv) {
        fprintf(s->csv, "sequence,timestamp_ns,source,drift,score");
        for (int k = 0; k < 68; k++)
            fprintf(s->csv, ",x%d,y%d", k, k);
        fputc('\n', s->csv);
    }
    *ctx = s;
    return 0;
}

int sp_stage_frame_landmarks(ss_lm_tracker *t, const sp_frame *f, uint8_t **rgb, size_t *rgb_size, ss_lm_result *r)
{
    size_t need = (size_t)f->width * f->height * 3;
    if (need > *rgb_size) {
        uint8_t *b = realloc(*rgb, need);
        if (!b)
            return -ENOMEM;
        *rgb = b, *rgb_size = need;
    }
    int ret = sp_pixconv_frame_to_rgb24(f, *rgb, need, f->width * 3);
    return ret ? ret : ss_lm_tracker_frame(t, *rgb, (int)f->width, (int)f->height, r);
}

static int lm_push(void *ctx, const sp_event *ev)
{
    landmarks_stage *s = ctx;
    if (ev->type != SP_EVENT_FRAME)
        return 0;
    const sp_frame *f = ev->frame;
    ss_lm_result r;
    int ret = sp_stage_frame_landmarks(s->tracker, f, &s->rgb, &s->rgb_size, &r);
    if (ret)
        return ret;
    s->frames++;
    s->by_source[r.source]++;
    if (r.source != SS_LM_NONE)
        s->drift_sum += r.drift;
    if (!s->csv)
        return 0;
    fprintf(s->csv, "%" PRIu64 ",%" PRId64 ",%s,", f->sequence, ev->timestamp_ns, source_names[r.source]);
    if (r.source != SS_LM_NONE)
        fprintf(s->csv, "%.5f", r.drift);
    fputc(',', s->csv);
    if (isfinite(r.score))
        fprintf(s->csv, "%.4f", r.score);
    for (int k = 0; k < 136; k++)
        if (r.source != SS_LM_NONE)
            fprintf(s->csv, ",%.3f", r.lm[k]);
        else
            fputc(',', s->csv);
    fputc('\n', s->csv);
    return 0;
}

static int lm_finish(void *ctx, FILE *summary)
{
    landmarks_stage *s = ctx;
    uint64_t found = s->frames - s->by_source[SS_LM_NONE];
    fprintf(summary,
            "landmarks: %" PRIu64 " of %" PRIu64 " frames (%" PRIu64 " tracked, %" PRIu64 " detected near the last "
            "face, %" PRIu64 " searched); mean drift %.4f of the inter-ocular distance\n",
            found, s->frames, s->by_source[SS_LM_TRACKED], s->by_source[SS_LM_DETECTED], s->by_source[SS_LM_SEARCHED],
            found ? s->drift_sum / (double)found : (double)NAN);
    int status = found ? 0 : SP_ENODATA;
    if (!s->csv)
        return status;
    s->csv = NULL; /* committed (status 0) or removed */
    return sp_atomic_file_finish(&s->out, status);
}

const sp_stage_ops sp_stage_landmarks = {
    .name = "landmarks",
    .writes_output = 1,
    .description = "68 face landmarks per frame, tracked, with their confidence (CSV with -o)",
    .wants_tags = 0,
    .open = lm_open,
    .push = lm_push,
    .finish = lm_finish,
    .close = lm_close,
};
