/* SPDX-License-Identifier: MIT */
/* The stage registry (a static table) and the driver loop every command streams through. */
#include "stage.h"

#include <errno.h>
#include <string.h>

#include "common/clock.h"
#include "common/progress.h"
#include "stages/stages.h"

static const sp_stage_ops *const registry[] = {
    &sp_stage_null, &sp_stage_stats, &sp_stage_orientation, &sp_stage_landmarks, &sp_stage_video_orientation, NULL,
};

const sp_stage_ops *const *sp_stage_registry(void)
{
    return registry;
}

const sp_stage_ops *sp_stage_find(const char *name)
{
    for (size_t i = 0; name && registry[i]; i++)
        if (strcmp(registry[i]->name, name) == 0)
            return registry[i];
    return NULL;
}

int sp_stage_open(sp_stage *st, const sp_stage_ops *ops, const void *settings)
{
    if (!st || !ops || !ops->open || !ops->push || !ops->close)
        return -EINVAL;
    st->ops = NULL;
    st->ctx = NULL;
    int ret = ops->open(&st->ctx, settings);
    if (!ret)
        st->ops = ops;
    return ret;
}

void sp_stage_close(sp_stage *st)
{
    if (!st || !st->ops)
        return;
    st->ops->close(st->ctx);
    st->ops = NULL;
    st->ctx = NULL;
}

void sp_run_default_settings(sp_run_settings *s)
{
    memset(s, 0, sizeof(*s));
    sp_replay_default_settings(&s->replay);
    sp_tagger_default_settings(&s->tagger);
    s->finish = 1;
    s->summary = stdout;
    s->progress = -1;
    s->progress_label = "frames";
}

/* The loop: one event from the source, one push into the stage, until the end. */
static int loop(sp_source *src, const sp_stage *stage, const sp_run_settings *s, sp_run_stats *st)
{
    sp_progress bar;
    sp_progress_start(&bar, s->progress_label, s->progress_total, s->progress);
    sp_event ev;
    int ret = 0;
    while (!(s->stop && *s->stop) && (!s->max_frames || st->frames < s->max_frames)) {
        if ((ret = sp_source_next(src, &ev))) {
            if (ret != SP_EOS)
                st->failed_in = SP_RUN_FAILED_SOURCE;
            break;
        }
        st->events++;
        if (ev.type == SP_EVENT_META && ev.meta)
            st->meta = *ev.meta;
        ret = stage->ops->push(stage->ctx, &ev);
        int frame = ev.type == SP_EVENT_FRAME;
        sp_event_release(&ev);
        if (ret) {
            st->failed_in = SP_RUN_FAILED_STAGE;
            break;
        }
        if (frame)
            sp_progress_update(&bar, ++st->frames, NULL);
    }
    sp_progress_finish(&bar);
    if (s->stop && *s->stop) {
        st->stopped = 1;
        return 0;
    }
    return st->failed_in ? ret : 0;
}

int sp_stage_run(const char *path, const sp_stage *stage, const sp_run_settings *s, sp_run_stats *out)
{
    sp_run_stats local;
    sp_run_stats *st = out ? out : &local;
    memset(st, 0, sizeof(*st));
    sp_capture_meta_init(&st->meta);
    if (!path || !stage || !stage->ops || !s)
        return -EINVAL;
    sp_replay_settings rs = s->replay;
    if (stage->ops->wants_tags)
        rs.pool_frames += s->tagger.max_waiting; /* the frames the tagger holds come from this pool */
    sp_source *replay = NULL, *tagger = NULL;
    int ret = sp_replay_open(&replay, path, &rs);
    if (!ret && stage->ops->wants_tags)
        ret = sp_tagger_open(&tagger, replay, &s->tagger);
    if (ret) {
        st->failed_in = SP_RUN_FAILED_OPEN;
        goto done;
    }
    int64_t t0 = sp_clock_monotonic_ns();
    ret = loop(tagger ? tagger : replay, stage, s, st);
    st->seconds = (double)(sp_clock_monotonic_ns() - t0) * 1e-9;
    if (!ret && !st->stopped && s->finish && stage->ops->finish && (ret = stage->ops->finish(stage->ctx, s->summary ? s->summary : stdout)))
        st->failed_in = SP_RUN_FAILED_FINISH;
done:
    if (tagger)
        st->tagged = sp_tagger_get_stats(tagger, &st->tagger) == 0;
    if (replay)
        sp_replay_get_stats(replay, &st->replay);
    sp_source_close(&tagger);
    sp_source_close(&replay);
    return ret;
}
