/* SPDX-License-Identifier: MIT */
/* The exemplar's pyramid and, per level, the patch positions a synthesis may copy from. */
#include "texture_internal.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

int tex_window_levels(int w, int h, int patch, int max_levels)
{
    int l = 1;
    while (l < max_levels && l < TEX_MAX_LEVELS && (w >> l) >= 2 * patch && (h >> l) >= 2 * patch)
        l++;
    return l;
}

void tex_reduce(const float *in, const uint8_t *min, int w, int h, float *out, uint8_t *mout, int cw, int ch)
{
    for (int y = 0; y < ch; y++)
        for (int x = 0; x < cw; x++) {
            float s[3] = { 0, 0, 0 };
            int n = 0, ok = 255;
            for (int dy = 0; dy < 2; dy++)
                for (int dx = 0; dx < 2; dx++) {
                    int sx = 2 * x + dx, sy = 2 * y + dy;
                    if (sx >= w || sy >= h)
                        continue;
                    const float *p = in + 3 * ((size_t)sy * w + sx);
                    s[0] += p[0], s[1] += p[1], s[2] += p[2];
                    n++;
                    int m = min ? min[(size_t)sy * w + sx] : 0;
                    ok = m < ok ? m : ok;
                }
            float *o = out + 3 * ((size_t)y * cw + x);
            for (int c = 0; c < 3; c++)
                o[c] = s[c] / (float)n;
            if (mout)
                mout[(size_t)y * cw + x] = (uint8_t)ok;
        }
}

/* valid[i]: the patch starting at i lies wholly in usable pixels (a summed-area table of the mask). */
static int mark_valid(tex_level *l, const uint8_t *mask, int patch)
{
    size_t n = (size_t)l->w * l->h;
    l->list = malloc(sizeof(int32_t) * (n ? n : 1));
    if (!l->list)
        return -ENOMEM;
    int32_t *sat = NULL;
    if (mask) {
        l->valid = calloc(n, 1);
        sat = calloc((size_t)(l->w + 1) * (l->h + 1), sizeof(int32_t));
        if (!l->valid || !sat) {
            free(sat);
            return -ENOMEM;
        }
        for (int y = 0; y < l->h; y++)
            for (int x = 0; x < l->w; x++)
                sat[(size_t)(y + 1) * (l->w + 1) + x + 1] = (mask[(size_t)y * l->w + x] != 0) +
                    sat[(size_t)y * (l->w + 1) + x + 1] + sat[(size_t)(y + 1) * (l->w + 1) + x] -
                    sat[(size_t)y * (l->w + 1) + x];
    }
    int P = patch, W1 = l->w + 1;
    l->n_list = 0;
    for (int y = 0; y + P <= l->h; y++)
        for (int x = 0; x + P <= l->w; x++) {
            if (sat && sat[(size_t)(y + P) * W1 + x + P] - sat[(size_t)y * W1 + x + P] -
                               sat[(size_t)(y + P) * W1 + x] + sat[(size_t)y * W1 + x] != P * P)
                continue;
            if (l->valid)
                l->valid[(size_t)y * l->w + x] = 1;
            l->list[l->n_list++] = y * l->w + x;
        }
    free(sat);
    return 0;
}

/* A typical distance between two unrelated patches: P^2 times twice the summed channel variance (over usable pixels). */
static double patch_scale(const tex_level *l, const uint8_t *mask, int patch)
{
    double s[3] = { 0, 0, 0 }, q[3] = { 0, 0, 0 };
    size_t n = 0;
    for (size_t i = 0; i < (size_t)l->w * l->h; i++) {
        if (mask && !mask[i])
            continue;
        for (int c = 0; c < 3; c++) {
            s[c] += (double)l->px[3 * i + c];
            q[c] += (double)l->px[3 * i + c] * (double)l->px[3 * i + c];
        }
        n++;
    }
    double var = 0;
    for (int c = 0; c < 3 && n; c++)
        var += q[c] / (double)n - (s[c] / (double)n) * (s[c] / (double)n);
    /* a flat exemplar still needs a positive scale for the penalty to act */
    return (double)patch * patch * 2.0 * (var > 1e-6 ? var : 1e-6);
}

static int colour_bin(const float *c)
{
    int k = 0;
    for (int i = 0; i < 3; i++) {
        float v = c[i] * TEX_COLOUR_LEVELS; /* clamped before the cast: HDR or NaN input stays in range */
        k = k * TEX_COLOUR_LEVELS + (v >= 1 ? (v < TEX_COLOUR_LEVELS - 1 ? (int)v : TEX_COLOUR_LEVELS - 1) : 0);
    }
    return k;
}

/* The finest level's colour bins and their counts (the exemplar does not change between windows). */
static int colour_bins(tex_level *L)
{
    size_t n = (size_t)L->w * L->h;
    L->colour = malloc(sizeof(uint16_t) * n);
    L->colour_count = calloc(TEX_COLOUR_BINS, sizeof(uint32_t));
    if (!L->colour || !L->colour_count)
        return -ENOMEM;
    for (size_t k = 0; k < n; k++)
        L->colour_count[L->colour[k] = (uint16_t)colour_bin(L->px + 3 * k)] += 1;
    return 0;
}

int tex_exemplar_build(tex_exemplar *ex, const float *rgb, int ew, int eh, const uint8_t *source, int patch,
                       int levels)
{
    memset(ex, 0, sizeof(*ex));
    ex->patch = patch;
    uint8_t *mask[TEX_MAX_LEVELS] = { 0 };
    int ret = -ENOMEM;
    for (int l = 0; l < levels && l < TEX_MAX_LEVELS; l++) {
        tex_level *L = &ex->lv[l];
        L->w = l ? (ex->lv[l - 1].w + 1) / 2 : ew;
        L->h = l ? (ex->lv[l - 1].h + 1) / 2 : eh;
        if (L->w < patch || L->h < patch)
            break;
        size_t n = (size_t)L->w * L->h;
        L->px = malloc(n * 3 * sizeof(float));
        if (!L->px || (source && !(mask[l] = malloc(n))))
            goto out;
        if (!l) {
            memcpy(L->px, rgb, n * 3 * sizeof(float));
            if (source)
                memcpy(mask[0], source, n);
        } else {
            const tex_level *F = &ex->lv[l - 1];
            tex_reduce(F->px, mask[l - 1], F->w, F->h, L->px, mask[l], L->w, L->h);
        }
        if ((ret = mark_valid(L, mask[l], patch)) || (!l && (ret = colour_bins(L))))
            goto out;
        if (!L->n_list) {
            if (!l) {
                ret = SP_ENODATA;
                goto out;
            }
            free(L->px), free(L->valid), free(L->list), free(L->colour), free(L->colour_count);
            memset(L, 0, sizeof(*L));
            break;
        }
        L->scale = patch_scale(L, mask[l], patch);
        ex->levels = l + 1;
    }
    ret = 0;
out:
    for (int l = 0; l < TEX_MAX_LEVELS; l++)
        free(mask[l]);
    if (ret)
        tex_exemplar_free(ex);
    return ret;
}

void tex_exemplar_free(tex_exemplar *ex)
{
    for (int l = 0; l < TEX_MAX_LEVELS; l++) {
        free(ex->lv[l].px);
        free(ex->lv[l].valid);
        free(ex->lv[l].list);
        free(ex->lv[l].colour);
        free(ex->lv[l].colour_count);
    }
    memset(ex, 0, sizeof(*ex));
}
