/* SPDX-License-Identifier: MIT */
/* The texture module's window synthesiser (synth.c), shared by the tiled driver and hole filling (texture.c). */
#ifndef SUNPROBE_PIPELINE_TEXTURE_INTERNAL_H
#define SUNPROBE_PIPELINE_TEXTURE_INTERNAL_H

#include <stdint.h>

#include "common/parallel.h"
#include "sunprobe/sp_texture.h"

#define TEX_MAX_LEVELS 4

/* One pyramid level of the exemplar and which patch positions may be copied from. */
typedef struct tex_level {
    float *px;          /* w x h x 3 */
    int w, h;
    uint8_t *valid;     /* per pixel: a patch may start here; NULL: every position with room for a patch */
    int32_t *list;      /* the valid positions (y * w + x) */
    int n_list;
    double scale;       /* a typical patch distance, so the reuse penalty is relative */
    uint16_t *colour;   /* finest level only (else NULL): each pixel's colour bin, TEX_COLOUR_LEVELS a channel */
    uint32_t *colour_count; /* and the pixels per bin: the exemplar's colours, for the blocks' share of them */
} tex_level;

#define TEX_COLOUR_LEVELS 16
#define TEX_COLOUR_BINS (TEX_COLOUR_LEVELS * TEX_COLOUR_LEVELS * TEX_COLOUR_LEVELS)

typedef struct tex_exemplar {
    tex_level lv[TEX_MAX_LEVELS];
    int levels, patch;
} tex_exemplar;

/* 2x box reduction of rgb (w x h) and of a mask (NULL: none): a coarse mask value is the least of its children's. */
void tex_reduce(const float *in, const uint8_t *min, int w, int h, float *out, uint8_t *mout, int cw, int ch);

/* Builds levels of the exemplar (ew x eh, borrowed); source: NULL or a mask of usable pixels. */
int tex_exemplar_build(tex_exemplar *ex, const float *rgb, int ew, int eh, const uint8_t *source, int patch,
                       int levels);
void tex_exemplar_free(tex_exemplar *ex);

/* Window pixel states, ordered so a coarse pixel takes the least of its children. */
enum { TEX_FREE = 0, TEX_SOFT = 1, TEX_FIXED = 2 };

/* What a window synthesis needs besides the pixels. */
typedef struct tex_job {
    const tex_exemplar *ex;
    const sp_texture_settings *s;
    sp_pool *pool;
    uint64_t key;       /* per window: mixed into every random draw */
    int blocks;         /* 1: the finest level is laid in whole blocks (synth.c), 0: left as voted */
    int seams;          /* 1: the band about the blocks' cuts is optimised after them (synth.c) */
} tex_job;

/*
 * Synthesises the w x h window img (x 3 floats) in place; TEX_FIXED pixels keep
 * their values and constrain the rest, TEX_SOFT ones start from their values. levels: pyramid levels used
 * (<= ex->levels; coarse windows must keep a patch). src (or NULL), per pixel: in, the finest-level exemplar
 * pixel (y * ew + x) a held pixel was laid from, -1 unknown; out, each pixel's, -1 where it is a blend (the
 * seams' band, the vote, a cross-fade). 0 or -ENOMEM.
 */
int tex_synth_window(const tex_job *job, float *img, const uint8_t *fixed, int32_t *src, int w, int h, int levels);

/* Whether a w x h window's finest level is laid in whole blocks (when the job asks): exemplar and window hold one. */
int tex_blocks_apply(const tex_exemplar *ex, int w, int h);
/* The blocks' step at this patch side: laid from each window's origin, a block cut ends every step apart. */
int tex_block_step(int patch);

/* Levels a w x h window can use: each level's window at least two patches a side. */
int tex_window_levels(int w, int h, int patch, int max_levels);

/* A 64-bit mix of a and b (splitmix64 finaliser), the root of every random draw. */
static inline uint64_t tex_hash(uint64_t a, uint64_t b)
{
    uint64_t z = a * 0x9E3779B97F4A7C15ull + b + 0x632BE59BD9B4E019ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

#endif
