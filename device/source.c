/* SPDX-License-Identifier: MIT */
/* The generic stream source every device, replay and generator is driven through. */
#include "sunprobe/sp_source.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>


int sp_source_create(sp_source **out, const sp_source_ops *ops, void *ctx)
{
    if (!out || !ops || !ops->next || !ops->close)
        return -EINVAL;
    sp_source *s = calloc(1, sizeof(*s));
    if (!s)
        return -ENOMEM;
    s->ops = ops;
    s->ctx = ctx;
    *out = s;
    return 0;
}

int sp_source_next(sp_source *src, sp_event *ev)
{
    if (!src || !ev)
        return -EINVAL;
    memset(ev, 0, sizeof(*ev));
    return src->ops->next(src->ctx, ev);
}

const char *sp_source_name(const sp_source *src)
{
    return src && src->ops->name ? src->ops->name : "?";
}

void sp_source_close(sp_source **src)
{
    if (!src || !*src)
        return;
    (*src)->ops->close((*src)->ctx);
    free(*src);
    *src = NULL;
}

void sp_event_release(sp_event *ev)
{
    if (ev)
        sp_frame_unref(&ev->frame);
}
