/* SPDX-License-Identifier: MIT */
/* "fit": the SunStage front end as a stage; the context is the sp_sunstage itself. */
#include "stages.h"

#include <errno.h>

static int fit_open(void **ctx, const void *settings)
{
    const sp_fit_stage_settings *s = settings;
    if (!s)
        return -EINVAL;
    return sp_sunstage_open((sp_sunstage **)ctx, &s->fit, s->model);
}

static int fit_push(void *ctx, const sp_event *ev)
{
    return sp_sunstage_push(ctx, ev);
}

static int fit_finish(void *ctx, FILE *summary)
{
    (void)summary; /* the fit itself reports (sp_sunstage_fit) */
    return sp_sunstage_end_stream(ctx);
}

static void fit_close(void *ctx)
{
    sp_sunstage *ss = ctx;
    sp_sunstage_close(&ss);
}

const sp_stage_ops sp_stage_fit = {
    .name = "fit",
    .description = "SunStage front end: quality checks, landmarks and the yaw-binned keyframe reservoir",
    .wants_tags = 1,
    .open = fit_open,
    .push = fit_push,
    .finish = fit_finish,
    .close = fit_close,
};
