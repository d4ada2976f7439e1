/* SPDX-License-Identifier: MIT */
/* A one-line progress bar on a terminal (stderr); silent when stderr is not a TTY. */
#ifndef SUNPROBE_COMMON_PROGRESS_H
#define SUNPROBE_COMMON_PROGRESS_H

#include <stdint.h>
#include "common/private_api.h"

typedef struct sp_progress {
    const char *label;
    uint64_t total;      /* 0 when unknown: shows a count instead of a bar */
    int enabled;
    int64_t start_ns, last_draw_ns;
} sp_progress;

/* enabled: 1 force, 0 off, -1 auto (on when stderr is a terminal). */
SP_PRIVATE void sp_progress_start(sp_progress *p, const char *label, uint64_t total, int enabled);
/* Redraws at most ten times a second; `detail` (may be NULL) is shown after the bar. */
SP_PRIVATE void sp_progress_update(sp_progress *p, uint64_t done, const char *detail);
SP_PRIVATE void sp_progress_finish(sp_progress *p);

#endif
