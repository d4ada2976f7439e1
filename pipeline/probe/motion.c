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
#if defined(__SSE2__)
#include <emmintrin.h>
#elif defined(__aarch64__)
#include <arm_neon.h>
#endif

#define MOTION_GAP 3
#define MOTION_RANGE 5

int motion_open(probe_motion *mo, uint32_t width, uint32_t height)
{
    memset(mo, 0, sizeof(*mo));
    mo->tw = width / 4, mo->th = height / 4;
    mo->cur = malloc((size_t)mo->tw * mo->th);
    mo->prev = malloc((size_t)mo->tw * mo->th);
    mo->rowsum = malloc((size_t)mo->tw * 12 * sizeof(uint16_t) + 1); /* + 1: never malloc(0) */
    if (!mo->cur || !mo->prev || !mo->rowsum) {
        motion_close(mo);
        return -ENOMEM;
    }
    return 0;
}

void motion_close(probe_motion *mo)
{
    free(mo->cur);
    free(mo->prev);
    free(mo->rowsum);
    mo->cur = mo->prev = NULL;
    mo->rowsum = NULL;
}

static void thumbnail(probe_motion *mo, const uint8_t *rgb, uint32_t width)
{
    uint16_t *acc = mo->rowsum; /* 12 * tw: the four rows' bytes added, a loop that vectorises */
    size_t nb = (size_t)12 * mo->tw;
    for (uint32_t ty = 0; ty < mo->th; ty++) {
        const uint8_t *r = rgb + (size_t)4 * ty * width * 3;
        for (size_t i = 0; i < nb; i++)
            acc[i] = (uint16_t)(r[i] + r[i + 3 * (size_t)width] + r[i + 6 * (size_t)width] + r[i + 9 * (size_t)width]);
        for (uint32_t tx = 0; tx < mo->tw; tx++) {
            unsigned sum = 0;
            for (int k = 0; k < 12; k++)
                sum += acc[12 * tx + (unsigned)k];
            mo->cur[(size_t)ty * mo->tw + tx] = (uint8_t)(sum / 48);
        }
    }
}

/* Sum of |a - b| over n bytes: SSE2's psadbw / NEON's vabd take 16 at a time (baseline on x86-64 and
 * AArch64; a fifth of a probe's time went here, scalar). */
static uint32_t row_sad(const uint8_t *a, const uint8_t *b, int n)
{
    uint32_t s = 0;
    int x = 0;
#if defined(__SSE2__)
    __m128i acc = _mm_setzero_si128();
    for (; x + 16 <= n; x += 16)
        acc = _mm_add_epi64(acc, _mm_sad_epu8(_mm_loadu_si128((const __m128i *)(a + x)),
                                              _mm_loadu_si128((const __m128i *)(b + x))));
    s = (uint32_t)(_mm_cvtsi128_si32(acc) + _mm_cvtsi128_si32(_mm_unpackhi_epi64(acc, acc)));
#elif defined(__aarch64__)
    uint32x4_t acc = vdupq_n_u32(0);
    for (; x + 16 <= n; x += 16)
        acc = vpadalq_u16(acc, vpaddlq_u8(vabdq_u8(vld1q_u8(a + x), vld1q_u8(b + x))));
    s = vaddvq_u32(acc);
#endif
    for (; x < n; x++)
        s += (uint32_t)(a[x] > b[x] ? a[x] - b[x] : b[x] - a[x]);
    return s;
}

/* Mean absolute difference between cur and prev shifted by (dx, dy), over the overlap. */
static double sad(const probe_motion *mo, int dx, int dy)
{
    uint64_t s = 0, n = 0;
    int x0 = MOTION_RANGE, x1 = (int)mo->tw - MOTION_RANGE;
    for (int y = MOTION_RANGE; y < (int)mo->th - MOTION_RANGE; y++) {
        const uint8_t *c = mo->cur + (size_t)y * mo->tw, *p = mo->prev + (size_t)(y + dy) * mo->tw + dx;
        s += row_sad(c + x0, p + x0, x1 - x0);
        n += (uint64_t)(x1 - x0);
    }
    return n ? (double)s / (double)n : 0.0;
}

void motion_frame(probe_motion *mo, const uint8_t *rgb, uint32_t width)
{
    if (mo->tw <= 2 * MOTION_RANGE + 2 || mo->th <= 2 * MOTION_RANGE + 2 || mo->frames++ % MOTION_GAP)
        return;
    thumbnail(mo, rgb, width);
    if (mo->have_prev) {
        /* moved: a shift explains a good part of a difference clearly above sensor noise; the search
         * stops at the first such shift and is skipped under the noise (the verdict is the same) */
        double still = sad(mo, 0, 0);
        int moved = 0;
        for (int dy = -MOTION_RANGE; still > 1.5 && !moved && dy <= MOTION_RANGE; dy++)
            for (int dx = -MOTION_RANGE; !moved && dx <= MOTION_RANGE; dx++)
                moved = (dx || dy) && sad(mo, dx, dy) < 0.75 * still;
        mo->checks++;
        mo->moved += moved;
    }
    uint8_t *t = mo->prev;
    mo->prev = mo->cur, mo->cur = t;
    mo->have_prev = 1;
}
