/* SPDX-License-Identifier: MIT */
#define _POSIX_C_SOURCE 200809L
#include "progress.h"

#include <stdio.h>
#include <unistd.h>

#include "clock.h"

void sp_progress_start(sp_progress *p, const char *label, uint64_t total, int enabled)
{
    p->label = label;
    p->total = total;
    p->enabled = enabled < 0 ? isatty(STDERR_FILENO) : enabled;
    p->start_ns = sp_clock_monotonic_ns();
    p->last_draw_ns = 0;
}

void sp_progress_update(sp_progress *p, uint64_t done, const char *detail)
{
    if (!p->enabled)
        return;
    int64_t now = sp_clock_monotonic_ns();
    if (now - p->last_draw_ns < 100000000 && !(p->total && done >= p->total))
        return;
    p->last_draw_ns = now;
    double secs = (double)(now - p->start_ns) * 1e-9;
    char bar[31];
    if (p->total) {
        double frac = done >= p->total ? 1.0 : (double)done / (double)p->total;
        int fill = (int)(frac * 30.0);
        for (int i = 0; i < 30; i++)
            bar[i] = i < fill ? '#' : '.';
        bar[30] = 0;
        fprintf(stderr, "\r%s [%s] %3.0f%% %6.1fs %s\033[K", p->label, bar, frac * 100.0, secs,
                detail ? detail : "");
    } else {
        fprintf(stderr, "\r%s %llu %6.1fs %s\033[K", p->label, (unsigned long long)done, secs,
                detail ? detail : "");
    }
    fflush(stderr);
}

void sp_progress_finish(sp_progress *p)
{
    if (p->enabled) {
        fputc('\n', stderr);
        fflush(stderr);
    }
}
