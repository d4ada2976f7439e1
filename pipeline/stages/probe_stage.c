/* SPDX-License-Identifier: MIT */
/* "probe": People as Scene Probes as a stage: frames of stream 0 into sp_probe, finish fits its models. */
#include "stages.h"

#include <errno.h>
#include <stdlib.h>

typedef struct probe_stage {
    sp_probe_stage_settings set;
    sp_probe *probe;
    uint64_t index;
} probe_stage;

static void probe_close(void *ctx)
{
    probe_stage *s = ctx;
    if (!s)
        return;
    sp_probe_close(&s->probe);
    free(s);
}

static int probe_open(void **ctx, const void *settings)
{
    const sp_probe_stage_settings *set = settings;
    if (!set)
        return -EINVAL;
    probe_stage *s = calloc(1, sizeof(*s));
    if (!s)
        return -ENOMEM;
    s->set = *set;
    int ret = sp_probe_open(&s->probe, set->width, set->height, &set->probe);
    if (ret) {
        probe_close(s);
        return ret;
    }
    *ctx = s;
    return 0;
}

static int probe_push(void *ctx, const sp_event *ev)
{
    probe_stage *s = ctx;
    if (ev->type != SP_EVENT_FRAME || !ev->frame || ev->frame->stream_id != 0)
        return 0;
    int ret = sp_probe_push_frame(s->probe, ev->frame);
    if (!ret && s->set.on_frame)
        ret = s->set.on_frame(s->set.user, s->probe, ev->frame, s->index);
    s->index++;
    return ret;
}

static int probe_finish(void *ctx, FILE *summary)
{
    (void)summary; /* `sunprobe probe` prints the outcome from the probe's getters */
    probe_stage *s = ctx;
    return sp_probe_finish(s->probe);
}

const sp_stage_ops sp_stage_probe = {
    .name = "probe",
    .description = "People as Scene Probes: clean plate, occlusion, lighting, scale and shadow models",
    .open = probe_open,
    .push = probe_push,
    .finish = probe_finish,
    .close = probe_close,
};

sp_probe *sp_probe_stage_probe(const sp_stage *st)
{
    return st && st->ops == &sp_stage_probe && st->ctx ? ((probe_stage *)st->ctx)->probe : NULL;
}
