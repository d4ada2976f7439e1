/* SPDX-License-Identifier: MIT */
/* The stage registry: a static table, one entry per built-in stage. */
#include "stage.h"

#include <string.h>

#include "stages/stages.h"

static const sp_stage_ops *const registry[] = {
    &sp_stage_null,
    &sp_stage_stats,
    &sp_stage_orientation,
    NULL,
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
