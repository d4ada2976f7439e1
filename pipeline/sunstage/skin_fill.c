/* SPDX-License-Identifier: MIT */
/*
 * The face's unseen skin. Push-pull (albedo.c) gives every texel no keyframe
 * saw a smooth colour from the observed ones; here each skin cluster's unseen
 * texels then get skin synthesised (pipeline/texture/, hole filling) from the
 * observed plain skin (is_plain_skin), the cluster's own when it is plain and
 * seen, the observed texels held fixed so the synthesis continues them across
 * the boundary. The synthesised texture keeps its detail but takes its low
 * frequencies from push-pull, so the colour runs on from the boundary instead
 * of jumping to the cluster's mean. Texels filled
 * so are marked SS_TEXEL_SYNTHESISED in `observed`.
 */
#include "pipeline/sunstage/sunstage_internal.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "sunprobe/sp_common.h"
#include "sunprobe/sp_texture.h"

#define MOD "sunstage"
#define SKIN_PATCH 4     /* texels: the map has 128 rows by default, skin detail is a few texels across */
#define LOWPASS_RADIUS 4 /* box radius (texels) separating the texture's detail from its colour */

/* Cluster of texel (x, y) of a w x h map (nearest sample of a cw x ch cluster map). */
static int texel_cluster(const uint8_t *map, int cw, int ch, int x, int y, int w, int h)
{
    if (!map || cw < 1 || ch < 1)
        return SP_FACE_CLUSTER_NONE;
    size_t cx = (size_t)(((double)x + 0.5) * cw / w), cy = (size_t)(((double)y + 0.5) * ch / h);
    return map[cy * (size_t)cw + cx];
}

static int is_skin(int c)
{
    return c != SP_FACE_CLUSTER_NONE && c != SP_FACE_CLUSTER_LEFT_EYE && c != SP_FACE_CLUSTER_RIGHT_EYE;
}

/*
 * Skin without a feature drawn on it: the forehead holds the brows, the lips cluster the vermilion and the
 * nose the nostrils (pipeline/face/face_regions.c), and none of those is texture to repeat over a scalp,
 * a neck or even the same cluster's unseen part (the hairline, the corners of the mouth).
 */
static int is_plain_skin(int c)
{
    return is_skin(c) && c != SP_FACE_CLUSTER_FOREHEAD && c != SP_FACE_CLUSTER_LIPS && c != SP_FACE_CLUSTER_NOSE;
}

/* Box mean of radius r over the texels where mask is set (in place of out), RGB. */
static void masked_box(const float *in, const uint8_t *mask, int w, int h, int r, float *out)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double s[3] = { 0, 0, 0 }, n = 0;
            for (int dy = -r; dy <= r; dy++)
                for (int dx = -r; dx <= r; dx++) {
                    int u = x + dx, v = y + dy;
                    if (u < 0 || v < 0 || u >= w || v >= h || !mask[(size_t)v * w + u])
                        continue;
                    for (int c = 0; c < 3; c++)
                        s[c] += (double)in[3 * ((size_t)v * w + u) + c];
                    n += 1;
                }
            for (int c = 0; c < 3; c++)
                out[3 * ((size_t)y * w + x) + c] = n > 0 ? (float)(s[c] / n) : in[3 * ((size_t)y * w + x) + c];
        }
}

/* The synthesised texels' detail (texture minus its local mean) on push-pull's colour. */
static int keep_detail(float *albedo, const float *smooth, const uint8_t *filled, int w, int h)
{
    size_t n = (size_t)w * h;
    float *lo = malloc(sizeof(float) * 3 * n), *lo_pp = malloc(sizeof(float) * 3 * n);
    if (!lo || !lo_pp) {
        free(lo), free(lo_pp);
        return -ENOMEM;
    }
    masked_box(albedo, filled, w, h, LOWPASS_RADIUS, lo);
    masked_box(smooth, filled, w, h, LOWPASS_RADIUS, lo_pp);
    for (size_t i = 0; i < n; i++)
        for (int c = 0; filled[i] && c < 3; c++) {
            float v = albedo[3 * i + c] - lo[3 * i + c] + lo_pp[3 * i + c];
            albedo[3 * i + c] = v < 0 ? 0 : v;
        }
    free(lo), free(lo_pp);
    return 0;
}

/* Fills one cluster's unseen texels (fill) from source; SP_ENODATA when no whole patch is observed. */
static int fill_cluster(float *albedo, int w, int h, const uint8_t *fill, const uint8_t *source, int threads)
{
    sp_texture_settings s;
    sp_texture_default_settings(&s);
    s.patch = SKIN_PATCH;
    s.threads = threads;
    return sp_texture_fill(albedo, (uint32_t)w, (uint32_t)h, fill, source, &s);
}

int ss_albedo_complete(sp_sunstage *ss)
{
    const sp_face_model *m = ss->model;
    int ret = ss_albedo_fill_unobserved(ss->fit.albedo, ss->fit.tw, ss->fit.th, ss->fit.observed);
    return ret ? ret : ss_skin_synthesise(ss->fit.albedo, ss->fit.tw, ss->fit.th, ss->fit.observed, m->cluster_map,
                                          (int)m->cluster_width, (int)m->cluster_height, ss->set.threads);
}

static int cmp_float(const void *a, const void *b)
{
    float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

/*
 * The observed skin with each texel replaced by the median of its observed 3 x 3 neighbours, per
 * channel: single-texel outliers of the fit (a glint, a shadow edge baked in) are not skin texture and
 * would be copied over the whole unseen area.
 */
static void median_observed(const float *in, const uint8_t *observed, int w, int h, float *out)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            for (int c = 0; c < 3; c++) {
                float v[9];
                int k = 0;
                for (int dy = -1; dy <= 1; dy++)
                    for (int dx = -1; dx <= 1; dx++) {
                        int u = x + dx, t = y + dy;
                        if (u >= 0 && t >= 0 && u < w && t < h && observed[(size_t)t * w + u] == 1)
                            v[k++] = in[3 * ((size_t)t * w + u) + c];
                    }
                qsort(v, (size_t)k, sizeof(float), cmp_float);
                out[3 * i + c] = observed[i] == 1 && k ? v[k / 2] : in[3 * i + c];
            }
        }
}

/*
 * rim[i]: for an observed texel, 1..RIM when it lies that many steps from an unseen skin texel (those are
 * seen at grazing angles: the least trustworthy, and where the seam would be), else 0.
 */
static void mark_rim(const uint8_t *observed, const uint8_t *region, int w, int h, int rim_w, uint8_t *rim)
{
    size_t n = (size_t)w * h;
    for (size_t i = 0; i < n; i++)
        rim[i] = observed[i] == 0 && is_skin(region[i]) ? 255 : 0;
    for (int d = 1; d <= rim_w; d++)
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                size_t i = (size_t)y * w + x;
                if (rim[i] || observed[i] != 1)
                    continue;
                int near = (x > 0 && rim[i - 1] && rim[i - 1] != d) || (x + 1 < w && rim[i + 1] && rim[i + 1] != d) ||
                           (y > 0 && rim[i - w] && rim[i - w] != d) || (y + 1 < h && rim[i + w] && rim[i + w] != d);
                if (near)
                    rim[i] = (uint8_t)d;
            }
    for (size_t i = 0; i < n; i++)
        rim[i] = rim[i] == 255 ? 0 : rim[i];
}

/* Which observed texels a cluster's fill copies, most specific first; the last is any observed skin. */
enum source_kind { SOURCE_OWN, SOURCE_PLAIN, SOURCE_ANY, SOURCE_KINDS };

static int source_texel(enum source_kind kind, int r, int texel_region)
{
    return kind == SOURCE_OWN  ? texel_region == r && is_plain_skin(r)
        : kind == SOURCE_PLAIN ? is_plain_skin(texel_region)
                               : is_skin(texel_region);
}

/* One cluster: its unseen texels and its rim, from the first source with a whole observed patch. */
static int fill_region(float *albedo, int w, int h, const uint8_t *observed, const uint8_t *region, const uint8_t *rim,
                       int r, uint8_t *fill, uint8_t *src, int threads)
{
    size_t n = (size_t)w * h, k = 0;
    for (size_t i = 0; i < n; i++) {
        fill[i] = region[i] == r && (observed[i] == 0 || rim[i]);
        k += region[i] == r && observed[i] == 0;
    }
    if (!k) { /* nothing of this cluster unseen: its rim (beside another cluster's unseen texels) stays as seen */
        memset(fill, 0, n);
        return 0;
    }
    int ret = SP_ENODATA;
    for (int kind = 0; ret == SP_ENODATA && kind < SOURCE_KINDS; kind++) {
        size_t m = 0;
        for (size_t i = 0; i < n; i++)
            m += src[i] = observed[i] == 1 && !rim[i] && source_texel((enum source_kind)kind, r, region[i]);
        if (m)
            ret = fill_cluster(albedo, w, h, fill, src, threads);
    }
    if (ret == SP_ENODATA) /* no observed skin patch at all: push-pull stays */
        memset(fill, 0, n);
    return ret == SP_ENODATA ? 0 : ret;
}

int ss_skin_synthesise(float *albedo, int w, int h, uint8_t *observed, const uint8_t *clusters, int cw, int ch,
                       int threads)
{
    int ret = 0, rim_w = h / 24 > 2 ? h / 24 : 2; /* about a texel in 50 of the map's height, at least 2 */
    size_t n = (size_t)w * h, total = 0;
    uint8_t *region = malloc(n), *fill = malloc(n), *src = malloc(n), *done = calloc(n, 1), *rim = malloc(n);
    float *smooth = malloc(sizeof(float) * 3 * n), *work = malloc(sizeof(float) * 3 * n);
    if (!region || !fill || !src || !done || !smooth || !rim || !work) {
        ret = -ENOMEM;
        goto out;
    }
    memcpy(smooth, albedo, sizeof(float) * 3 * n);
    median_observed(smooth, observed, w, h, work);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            region[(size_t)y * w + x] = (uint8_t)texel_cluster(clusters, cw, ch, x, y, w, h);
    mark_rim(observed, region, w, h, rim_w, rim);
    for (int r = 0; !ret && r < SP_RENDER_CLUSTERS; r++) {
        if (is_skin(r))
            ret = fill_region(work, w, h, observed, region, rim, r, fill, src, threads);
        for (size_t i = 0; !ret && i < n; i++)
            done[i] |= fill[i] && is_skin(r);
    }
    if (!ret)
        ret = keep_detail(work, smooth, done, w, h);
    for (size_t i = 0; !ret && i < n; i++) {
        if (done[i])
            memcpy(albedo + 3 * i, work + 3 * i, 3 * sizeof(float));
        if (done[i] && rim[i]) /* the rim: from the observed texel inside to the synthesised one at the edge */
            for (int c = 0; c < 3; c++) {
                float a = (float)rim[i] / (float)(rim_w + 1);
                albedo[3 * i + c] = a * smooth[3 * i + c] + (1 - a) * albedo[3 * i + c];
            }
        else if (done[i])
            observed[i] = SS_TEXEL_SYNTHESISED, total++;
    }
    if (!ret)
        sp_log(SP_LOG_INFO, MOD, "albedo: %zu unseen skin texels synthesised from the observed skin, blended over %d "
               "texels of its rim", total, rim_w);
out:
    free(region), free(fill), free(src), free(done), free(smooth), free(rim), free(work);
    return ret;
}
