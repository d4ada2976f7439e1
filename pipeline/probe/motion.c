/* SPDX-License-Identifier: MIT */
/*
 * Camera motion check: every MOTION_GAP frames a 4x4-block gray thumbnail is
 * compared with the previous one over shifts of up to MOTION_RANGE cells. A
 * static camera is best matched unshifted (people moving through are a small
 * part of the picture); a panning or shaking one by a shift that explains most
 * of the difference. Cheap enough to run alongside probing, and it does not
 * need contrast everywhere, only some texture that moves.
 */
#include "probe_internal.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#define MOTION_GAP 3
#define MOTION_RANGE 5

int motion_open(probe_motion *mo, uint32_t width, uint32_t height)
{
    memset(mo, 0, sizeof(*mo));
    mo->tw = width / 4, mo->th = height / 4;
    mo->cur = malloc((size_t)mo->tw * mo->th);
    mo->prev = malloc((size_t)mo->tw * mo->th);
    if (!mo->cur || !mo->prev) {
        motion_close(mo);
        return -ENOMEM;
    }
    return 0;
}

void motion_close(probe_motion *mo)
{
    free(mo->cur);
    free(mo->prev);
    mo->cur = mo->prev = NULL;
}

static void thumbnail(probe_motion *mo, const uint8_t *rgb, uint32_t width)
{
    for (uint32_t ty = 0; ty < mo->th; ty++)
        for (uint32_t tx = 0; tx < mo->tw; tx++) {
            unsigned sum = 0;
            for (uint32_t y = 4 * ty; y < 4 * ty + 4; y++) {
                const uint8_t *p = rgb + ((size_t)y * width + 4 * tx) * 3;
                for (int k = 0; k < 12; k++)
                    sum += p[k];
            }
            mo->cur[(size_t)ty * mo->tw + tx] = (uint8_t)(sum / 48);
        }
}

/* Mean absolute difference between cur and prev shifted by (dx, dy), over the overlap. */
static double sad(const probe_motion *mo, int dx, int dy)
{
    uint64_t s = 0, n = 0;
    for (int y = MOTION_RANGE; y < (int)mo->th - MOTION_RANGE; y++) {
        const uint8_t *c = mo->cur + (size_t)y * mo->tw, *p = mo->prev + (size_t)(y + dy) * mo->tw + dx;
        for (int x = MOTION_RANGE; x < (int)mo->tw - MOTION_RANGE; x++, n++)
            s += (uint64_t)abs(c[x] - p[x]);
    }
    return n ? (double)s / (double)n : 0.0;
}

void motion_frame(probe_motion *mo, const uint8_t *rgb, uint32_t width)
{
    if (mo->tw <= 2 * MOTION_RANGE + 2 || mo->th <= 2 * MOTION_RANGE + 2 || mo->frames++ % MOTION_GAP)
        return;
    thumbnail(mo, rgb, width);
    if (mo->have_prev) {
        double still = sad(mo, 0, 0), best = still;
        for (int dy = -MOTION_RANGE; dy <= MOTION_RANGE; dy++)
            for (int dx = -MOTION_RANGE; dx <= MOTION_RANGE; dx++) {
                double v = dx || dy ? sad(mo, dx, dy) : still;
                best = v < best ? v : best;
            }
        mo->checks++;
        /* moved: a shift explains a good part of a difference clearly above sensor noise */
        mo->moved += still > 1.5 && best < 0.75 * still;
    }
    uint8_t *t = mo->prev;
    mo->prev = mo->cur, mo->cur = t;
    mo->have_prev = 1;
}
