/* SPDX-License-Identifier: MIT */
/* "null": counts events and bytes; measures how fast a source can deliver. */
#include "stages.h"

#include <errno.h>
#include <inttypes.h>
#include <stdlib.h>

typedef struct null_stage {
    uint64_t frames, imu, other, frame_bytes;
} null_stage;

static int null_open(void **ctx, const void *settings)
{
    (void)settings;
    *ctx = calloc(1, sizeof(null_stage));
    return *ctx ? 0 : -ENOMEM;
}

static int null_process(void *ctx, const sp_event *ev)
{
    null_stage *s = ctx;
    if (ev->type == SP_EVENT_FRAME) {
        s->frames++;
        s->frame_bytes += ev->frame->bytes_used;
    } else if (ev->type == SP_EVENT_IMU) {
        s->imu++;
    } else {
        s->other++;
    }
    return 0;
}

static int null_finish(void *ctx, FILE *summary)
{
    null_stage *s = ctx;
    fprintf(summary, "null: %" PRIu64 " frames (%" PRIu64 " bytes), %" PRIu64 " IMU samples, %" PRIu64
                     " other events\n", s->frames, s->frame_bytes, s->imu, s->other);
    return 0;
}

static void null_close(void *ctx)
{
    free(ctx);
}

const sp_stage_ops sp_stage_null = {
    .name = "null",
    .description = "count events (throughput measurement)",
    .open = null_open,
    .push = null_process,
    .finish = null_finish,
    .close = null_close,
};
