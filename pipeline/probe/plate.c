/* SPDX-License-Identifier: MIT */
/*
 * The clean plate: a per-channel temporal median of the last k sampled frames.
 * Frames are sampled every window/k seconds into a ring (bounded: k images);
 * each new sample recomputes the median with a sorting network (Batcher's
 * odd-even merge sort, pruned to the comparators that feed the median wire)
 * run on blocks of bytes, which compilers turn into SIMD min/max.
 */
#include "probe_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define BLOCK 128 /* bytes per network pass: wires * BLOCK stay in L1 */

/* All comparators of Batcher's odd-even merge sort on n (a power of two) wires. */
static unsigned batcher_pairs(unsigned n, uint8_t pairs[][2], unsigned max)
{
    unsigned count = 0;
    for (unsigned p = 1; p < n; p <<= 1)
        for (unsigned k = p; k >= 1; k >>= 1)
            for (unsigned j = k % p; j + k < n; j += 2 * k)
                for (unsigned i = 0; i < k && i + j + k < n; i++)
                    if ((i + j) / (2 * p) == (i + j + k) / (2 * p) && count < max) {
                        pairs[count][0] = (uint8_t)(i + j);
                        pairs[count][1] = (uint8_t)(i + j + k);
                        count++;
                    }
    return count;
}

/* Keeps only the comparators the output wire depends on (walking backwards). */
static unsigned prune_pairs(uint8_t pairs[][2], unsigned count, unsigned out_wire)
{
    uint8_t needed[PROBE_MAX_WIRES] = { 0 };
    uint8_t keep[PROBE_MAX_PAIRS] = { 0 };
    needed[out_wire] = 1;
    for (unsigned c = count; c-- > 0;) {
        if (needed[pairs[c][0]] || needed[pairs[c][1]]) {
            keep[c] = 1;
            needed[pairs[c][0]] = needed[pairs[c][1]] = 1;
        }
    }
    unsigned n = 0;
    for (unsigned c = 0; c < count; c++)
        if (keep[c]) {
            pairs[n][0] = pairs[c][0];
            pairs[n][1] = pairs[c][1];
            n++;
        }
    return n;
}

typedef struct network {
    unsigned n_wires, out_wire, n_pairs;
    uint8_t pairs[PROBE_MAX_PAIRS][2];
} network;

/*
 * k inputs on the top wires, the rest held at 0 so they sort first: the
 * median of the k real values is then sorted wire (n - k) + k / 2.
 */
static void network_build(network *nw, unsigned k)
{
    unsigned n = 1;
    while (n < k)
        n <<= 1;
    nw->n_wires = n;
    nw->out_wire = (n - k) + k / 2;
    unsigned count = batcher_pairs(n, nw->pairs, PROBE_MAX_PAIRS);
    nw->n_pairs = prune_pairs(nw->pairs, count, nw->out_wire);
}

static inline void compare_exchange(uint8_t *restrict a, uint8_t *restrict b)
{
    for (unsigned i = 0; i < BLOCK; i++) {
        uint8_t x = a[i], y = b[i];
        a[i] = x < y ? x : y;
        b[i] = x < y ? y : x;
    }
}

/* Median of wires 0..k-1 over n bytes; wires k.. are the zero padding. */
static inline __attribute__((always_inline)) void network_body(const network *nw, const uint8_t *const *in,
                                                                 unsigned k, size_t n, uint8_t *out)
{
    uint8_t w[PROBE_MAX_WIRES][BLOCK];
    memset(w, 0, sizeof(w));
    for (size_t off = 0; off < n; off += BLOCK) {
        size_t len = n - off < BLOCK ? n - off : BLOCK;
        for (unsigned j = 0; j < k; j++)
            memcpy(w[j], in[j] + off, len);
        /* the pads must read 0 again: the last pass may have swapped values into them */
        for (unsigned j = k; j < nw->n_wires; j++)
            memset(w[j], 0, BLOCK);
        for (unsigned c = 0; c < nw->n_pairs; c++)
            compare_exchange(w[nw->pairs[c][0]], w[nw->pairs[c][1]]);
        memcpy(out + off, w[nw->out_wire], len);
    }
}

static void network_run_base(const network *nw, const uint8_t *const *in, unsigned k, size_t n, uint8_t *out)
{
    network_body(nw, in, k, n, out);
}

#if defined(__x86_64__) && defined(__GNUC__)
/* The same, compiled for AVX2: 32 bytes per min/max instead of SSE2's 16 (the median is a fifth of a
 * probe's time); picked at run time, as crc32c.c picks its instructions, so the binary stays baseline. */
__attribute__((target("avx2"))) static void network_run_avx2(const network *nw, const uint8_t *const *in,
                                                              unsigned k, size_t n, uint8_t *out)
{
    network_body(nw, in, k, n, out);
}
#endif

static void network_run(const network *nw, const uint8_t *const *in, unsigned k, size_t n, uint8_t *out)
{
#if defined(__x86_64__) && defined(__GNUC__)
    if (__builtin_cpu_supports("avx2")) {
        network_run_avx2(nw, in, k, n, out);
        return;
    }
#endif
    network_run_base(nw, in, k, n, out);
}

int probe_median_bytes(const uint8_t *const *in, unsigned k, size_t n, uint8_t *out)
{
    if (!in || !out || k < 1 || k > PROBE_MAX_WIRES)
        return -EINVAL;
    network nw;
    network_build(&nw, k);
    network_run(&nw, in, k, n, out);
    return 0;
}

int plate_open(probe_plate *pl, uint32_t width, uint32_t height, unsigned k, int64_t window_ns, int64_t settle_ns)
{
    memset(pl, 0, sizeof(*pl));
    if (k < 3 || k > PROBE_MAX_WIRES || window_ns <= 0 || settle_ns < 0)
        return -EINVAL;
    pl->width = width;
    pl->height = height;
    pl->bytes = (size_t)width * height * 3;
    pl->k = k;
    pl->interval_ns = window_ns / k;
    pl->next_sample_ns = INT64_MIN;
    pl->ring = malloc(pl->bytes * k);
    pl->median = calloc(1, pl->bytes);
    pl->held = calloc((size_t)width * height, sizeof(uint16_t));
    double settle = (double)settle_ns / (double)pl->interval_ns;
    pl->settle_samples = settle < 65535 ? (unsigned)ceil(settle) : 65535;
    if (!pl->ring || !pl->median || !pl->held) {
        plate_close(pl);
        return -ENOMEM;
    }
    network nw;
    network_build(&nw, k);
    pl->n_wires = nw.n_wires;
    pl->out_wire = nw.out_wire;
    pl->n_pairs = nw.n_pairs;
    memcpy(pl->pairs, nw.pairs, sizeof(nw.pairs));
    return 0;
}

void plate_close(probe_plate *pl)
{
    free(pl->ring);
    free(pl->median);
    free(pl->held);
    pl->ring = pl->median = NULL;
    pl->held = NULL;
}

/*
 * The new sample: the frame, except where an object that walked in stands (hold): there the slot
 * keeps the sample it held, taken a window earlier, for up to settle_samples samples in a row, so the
 * median there is over older views of the background. A person who stops for a while does not become
 * background; a car that parks for good does after the settling time.
 */
static void take_sample(probe_plate *pl, uint8_t *slot, const uint8_t *rgb, const plate_hold *hold)
{
    if (!hold || !plate_ready(pl)) {
        memcpy(slot, rgb, pl->bytes);
        if (pl->held)
            memset(pl->held, 0, (size_t)pl->width * pl->height * sizeof(uint16_t));
        return;
    }
    for (uint32_t y = 0; y < pl->height; y++) {
        const uint8_t *cells = hold->cells + (size_t)(y / hold->block) * hold->gw;
        for (uint32_t x = 0; x < pl->width; x++) {
            size_t i = (size_t)y * pl->width + x;
            int keep = cells[x / hold->block] && pl->held[i] < pl->settle_samples;
            if (cells[x / hold->block])
                pl->held[i] = (uint16_t)(pl->held[i] < UINT16_MAX ? pl->held[i] + 1 : UINT16_MAX);
            else
                pl->held[i] = 0;
            if (!keep) /* kept: the slot holds the sample taken a window ago, a view of the background */
                memcpy(slot + 3 * i, rgb + 3 * i, 3);
        }
    }
}

int plate_offer(probe_plate *pl, const uint8_t *rgb, int64_t t_ns, const plate_hold *hold)
{
    if (pl->next_sample_ns != INT64_MIN && t_ns < pl->next_sample_ns)
        return 0;
    /* schedule from the due time, not the frame time, so jitter does not stretch the window */
    int64_t next = pl->next_sample_ns, step = pl->interval_ns; /* step >= 0 (plate_open) */
    /* t_ns >= next here, so t_ns - next overflows only when next < 0: then it is certainly late */
    int from_frame = next == INT64_MIN || (next < 0 && t_ns > INT64_MAX + next) || t_ns - next > step;
    int64_t base = from_frame ? t_ns : next;
    if (base > INT64_MAX - step)
        return -ERANGE; /* timestamps at the end of the clock's range */
    int64_t due = base + step;
    take_sample(pl, pl->ring + (size_t)pl->next * pl->bytes, rgb, hold);
    pl->next = (pl->next + 1) % pl->k;
    if (pl->filled < pl->k)
        pl->filled++;
    pl->next_sample_ns = due;
    if (!plate_ready(pl))
        return 0;
    const uint8_t *in[PROBE_MAX_WIRES];
    for (unsigned j = 0; j < pl->k; j++)
        in[j] = pl->ring + (size_t)j * pl->bytes;
    network nw = { .n_wires = pl->n_wires, .out_wire = pl->out_wire, .n_pairs = pl->n_pairs };
    memcpy(nw.pairs, pl->pairs, sizeof(nw.pairs));
    network_run(&nw, in, pl->k, pl->bytes, pl->median);
    pl->updates++;
    return 1;
}
