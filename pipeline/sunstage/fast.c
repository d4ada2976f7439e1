/* SPDX-License-Identifier: MIT */
/*
 * Fast photometric solver. With the stage-1 geometry fixed, every masked pixel
 * of every keyframe becomes one linear-radiance observation (the display
 * transform is inverted; weights = its slope squared, so the cost matches the
 * display-space L2). The image model is
 *     L = a(uv) * (I D(n, sun) V + sum_k c_k E_k(n)) + I ks_cluster P_s
 * which is linear in the albedo given the lighting (closed form per texel) and
 * linear in (I, c, I ks) given the albedo (non-negative least squares). The
 * sun direction is the only nonlinear unknown: a sphere search on unshadowed
 * shading, then a shrinking pattern search with shadows from re-rendering.
 */
#include "pipeline/sunstage/sunstage_internal.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/clock.h"
#include "common/parallel.h"
#include "pipeline/render/texture.h"

#define MOD "sunstage"
#define NK SS_ENV_BASIS
#define NL (1 + 3 * NK + SP_RENDER_CLUSTERS) /* I, env per channel, I ks per cluster */
#define N_SHIN 7
#define CHUNKS 64
#define PART (NL * NL + NL)
#define LANES 4 /* at most this many albedo lanes: a board's cores, at 6 doubles per texel each */
static const double shin_grid[N_SHIN] = { 4, 8, 16, 32, 64, 128, 256 };

typedef struct obs {
    double L[3], w;
    double n[3];
    double V, D, P;    /* visibility, shadowed sun diffuse / pi, specular basis for the chosen shininess */
    double A[NK];      /* ambient of env lobe k / pi */
    int32_t tex[4];
    double tw[4];
    int32_t px;        /* its pixel in the frame: the later per-frame renders (shadows, highlights) look it up */
    double u, v;       /* its texture coordinates: the taps again for another map size */
    int8_t cluster;
    uint8_t eye;       /* on an eyeball: its albedo is fitted, but it says nothing about the light (a wet cornea) */
    uint8_t clip;      /* bit ch: L[ch] is a lower bound (the camera clipped it), a cost only while the model is below */
} obs;

/* A clipped channel that the model already reaches costs nothing (a one-sided, censored observation). */
static inline int bound_met(const obs *o, int ch, double model)
{
    return (o->clip >> ch & 1) && model >= o->L[ch];
}

typedef struct fast_ctx {
    sp_sunstage *ss;
    ss_scene sc;
    obs *o;
    size_t n, cap;
    int idx[64], nf;
    size_t *frame_start;
    float *envb;      /* NK env maps */
    double *num, *den; /* per texel * 3 */
    float *prev;       /* per texel * 3: the albedo before a Jacobi step */
    uint8_t *seen;     /* per texel: 1 when the training pixels' taps cover it (geometry, not photometric weight) */
    /* parallel loops (common/parallel.h): observations and texels in fixed ranges (their number set by the data
       alone), each writing its own partial, summed in range order: the result does not depend on the threads */
    sp_pool *pool;
    int obs_chunks, tex_chunks;
    double *part;      /* CHUNKS x PART: per-chunk partial sums */
    int lanes;         /* albedo sums: observation ranges scattered into their own per-texel arrays */
    double *lane;      /* lanes x texels x 6 (numerator, denominator per channel); zero between steps */
    size_t nt;         /* texels */
    double prior[5];   /* albedo step priors: the seen texels' mean per channel, the mean pull, the neighbour pull */
    double x[NL];     /* lighting unknowns */
    int use_sun, use_spec;
    int decide_only; /* stop after the sun search and the overcast decision */
    size_t stride; /* observation subsampling while searching (1 = all) */
    double sun[3];
} fast_ctx;

/* Non-negative broad lobes over the sky: constant, up, down and six horizon directions. */
static void make_env_basis(float *envb)
{
    for (int k = 0; k < NK; k++)
        for (int i = 0; i < SP_RENDER_ENV_H; i++)
            for (int j = 0; j < SP_RENDER_ENV_W; j++) {
                double th = (i + 0.5) * M_PI / SP_RENDER_ENV_H, ph = (j + 0.5) * 2.0 * M_PI / SP_RENDER_ENV_W;
                double d[3] = { sin(th) * cos(ph), sin(th) * sin(ph), cos(th) };
                double c[3] = { 0, 0, 0 }, v = 1.0;
                if (k == 1 || k == 2)
                    c[2] = k == 1 ? 1.0 : -1.0;
                else if (k >= 3) {
                    double a = (k - 3) * M_PI / 3.0;
                    c[0] = cos(a);
                    c[1] = sin(a);
                }
                if (k > 0) {
                    double dot = d[0] * c[0] + d[1] * c[1] + d[2] * c[2];
                    v = dot > 0.0 ? dot * dot : 0.0;
                }
                for (int ch = 0; ch < 3; ch++)
                    envb[((size_t)k * SP_RENDER_ENV_H * SP_RENDER_ENV_W + (size_t)(i * SP_RENDER_ENV_W + j)) * 3 + (size_t)ch] = (float)v;
            }
}

static void texel_taps(const sp_sunstage *ss, double u, double v, obs *ob)
{
    double x = u * ss->fit.tw - 0.5, y = (1.0 - v) * ss->fit.th - 0.5;
    int x0 = (int)floor(x), y0 = (int)floor(y);
    double fx = x - x0, fy = y - y0;
    for (int k = 0; k < 4; k++) {
        int xi = x0 + (k & 1), yi = y0 + (k >> 1);
        xi = xi < 0 ? 0 : (xi >= ss->fit.tw ? ss->fit.tw - 1 : xi);
        yi = yi < 0 ? 0 : (yi >= ss->fit.th ? ss->fit.th - 1 : yi);
        ob->tex[k] = yi * ss->fit.tw + xi;
        ob->tw[k] = (((k & 1) ? fx : 1.0 - fx) * ((k >> 1) ? fy : 1.0 - fy));
    }
}

static int grow(fast_ctx *c, size_t need)
{
    if (need <= c->cap)
        return 0;
    size_t cap = c->cap ? c->cap * 2 : 16384;
    while (cap < need)
        cap *= 2;
    obs *o = realloc(c->o, cap * sizeof(obs));
    if (!o)
        return -ENOMEM;
    c->o = o;
    c->cap = cap;
    return 0;
}

/* Renders frame f with a white 1x1 albedo, sun/env/ks as given. */
static int render_white(fast_ctx *c, const ss_frame *f, const double sun[3], double I, const float *env, double ks,
                        double shin, sp_render_outputs *out)
{
    sp_render_scene scene;
    int ret = ss_scene_setup(&c->sc, c->ss, f, &scene);
    if (ret)
        return ret;
    scene.albedo = (sp_render_texture){ 1, 1, c->sc.white };
    scene.displacement.data = NULL;
    scene.env = env;
    memcpy(scene.sun_dir, sun, sizeof(scene.sun_dir));
    scene.sun_intensity = I;
    scene.shadow_mode = I > 0.0 ? SP_RENDER_SHADOW_RENDER : SP_RENDER_SHADOW_OFF;
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++) {
        scene.ks[k] = ks;
        scene.shininess[k] = shin;
    }
    return sp_render(c->sc.r, &scene, out);
}

#define TEXEL_SEEN 0.25 /* summed tap weight that makes a texel observed: a quarter of one pixel's footprint */

/*
 * Which texels the data reaches, decided by the taps alone: the photometric
 * weights span decades (the display transform is steep in the shadows), so a
 * threshold on them would call most of a sunlit face unobserved. Then how the
 * sums over observations and texels are cut into ranges.
 */
static int plan_sums(fast_ctx *c)
{
    size_t nt = (size_t)c->ss->fit.tw * (size_t)c->ss->fit.th;
    double *cover = calloc(nt, sizeof(double));
    if (!cover)
        return -ENOMEM;
    for (size_t i = 0; i < c->n; i++)
        for (int k = 0; k < 4; k++)
            cover[c->o[i].tex[k]] += c->o[i].tw[k];
    for (size_t t = 0; t < nt; t++)
        c->seen[t] = cover[t] >= TEXEL_SEEN;
    free(cover);
    /* chunk counts: set by the data alone, large enough that the partial sums cost little beside the work */
    c->obs_chunks = (int)(c->n / 4096 < 1 ? 1 : (c->n / 4096 > CHUNKS ? CHUNKS : c->n / 4096));
    c->tex_chunks = (int)(nt / 4096 < 1 ? 1 : (nt / 4096 > CHUNKS ? CHUNKS : nt / 4096));
    c->lanes = (int)(c->n / 16384 < 1 ? 1 : (c->n / 16384 > LANES ? LANES : c->n / 16384));
    free(c->lane);
    c->lane = calloc((size_t)c->lanes * nt * 6, sizeof(double));
    return c->lane ? 0 : -ENOMEM;
}

/* Collects the masked pixels of every training frame with their geometry and env-lobe shading. */
static int gather(fast_ctx *c)
{
    sp_sunstage *ss = c->ss;
    const sp_face_model *m = ss->model;
    int npx = ss->W * ss->H;
    float *mask = malloc(sizeof(float) * (size_t)npx);
    if (!mask)
        return -ENOMEM;
    int ret = 0;
    for (int fi = 0; fi < c->nf && !ret; fi++) {
        const ss_frame *f = &ss->res.slots[c->idx[fi]];
        sp_render_outputs o;
        c->frame_start[fi] = c->n;
        if ((ret = render_white(c, f, c->sun, 0.0, NULL, 0.0, 16.0, &o)))
            break;
        ss_scene_mask(&c->sc, &o, f->rgb, mask);
        size_t first = c->n;
        for (int p = 0; p < npx; p++) {
            const float *bound = f->clip + (size_t)p * SS_CLIP_FLOATS;
            /* a clipped rim pixel stays a lower bound: blended with darker surroundings and still clipped,
               the skin there is brighter still */
            int clipped = !(mask[p] > 0.0f) && bound[3] > 0.0f && ss_scene_covers(&c->sc, &o, p);
            if (!(mask[p] > 0.0f) && !clipped)
                continue;
            if (clipped && m->part[m->mesh.tri_vertices[(size_t)o.tri_id[p] * 3]] == SP_FACE_PART_EYE)
                continue; /* a clipped eye is a cornea's glint: no bound on the eye's albedo */
            if ((ret = grow(c, c->n + 1)))
                break;
            obs *ob = &c->o[c->n++];
            memset(ob, 0, sizeof(*ob));
            ob->px = p;
            ob->clip = clipped ? (uint8_t)bound[3] : 0;
            const float *val = clipped ? bound : f->rgb + (size_t)p * 3;
            double slope = 0.0;
            for (int ch = 0; ch < 3; ch++) {
                double s;
                /* display = tonemap(exposure * L): divide the exposure out, scale the slope by it */
                ob->L[ch] = ss_tonemap_inverse((double)val[ch], &s) / f->expo;
                slope += (s * f->expo) * (s * f->expo) / 3.0;
            }
            ob->w = slope;
            for (int k = 0; k < 3; k++)
                ob->n[k] = o.normal[(size_t)p * 3 + (size_t)k];
            ob->V = 1.0;
            const float *b = o.bary + (size_t)p * 3;
            const uint32_t *tu = m->mesh.tri_uvs + (size_t)o.tri_id[p] * 3;
            double u = 0.0, v = 0.0;
            for (int k = 0; k < 3; k++) {
                u += (double)b[k] * (double)m->mesh.uvs[tu[k] * 2];
                v += (double)b[k] * (double)m->mesh.uvs[tu[k] * 2 + 1];
            }
            ob->u = u;
            ob->v = v;
            texel_taps(ss, u, v, ob);
            int cx = (int)(u * m->cluster_width), cy = (int)((1.0 - v) * m->cluster_height);
            cx = cx < 0 ? 0 : (cx >= (int)m->cluster_width ? (int)m->cluster_width - 1 : cx);
            cy = cy < 0 ? 0 : (cy >= (int)m->cluster_height ? (int)m->cluster_height - 1 : cy);
            uint8_t cl = m->cluster_map[(size_t)cy * m->cluster_width + (size_t)cx];
            ob->cluster = (int8_t)(cl < SP_RENDER_CLUSTERS ? cl : -1);
            ob->eye = m->part[m->mesh.tri_vertices[(size_t)o.tri_id[p] * 3]] == SP_FACE_PART_EYE;
        }
        for (int k = 0; k < NK && !ret; k++) {
            const float *env = c->envb + (size_t)k * SP_RENDER_ENV_FLOATS;
            if ((ret = render_white(c, f, c->sun, 0.0, env, 0.0, 16.0, &o)))
                break;
            for (size_t i = first; i < c->n; i++)
                c->o[i].A[k] = (double)o.ambient[(size_t)c->o[i].px * 3];
        }
    }
    c->frame_start[c->nf] = c->n;
    free(mask);
    if (!ret)
        ret = plan_sums(c);
    return ret;
}

static void set_sun_diffuse(fast_ctx *c, const double d[3])
{
    for (size_t i = 0; i < c->n; i++) {
        obs *o = &c->o[i];
        double nl = o->n[0] * d[0] + o->n[1] * d[1] + o->n[2] * d[2];
        o->D = nl > 0.0 ? nl * o->V / M_PI : 0.0;
    }
}

static double albedo_at(const sp_sunstage *ss, const obs *o, int ch)
{
    double a = 0.0;
    for (int k = 0; k < 4; k++)
        a += (double)o->tw[k] * (double)ss->fit.albedo[(size_t)o->tex[k] * 3 + (size_t)ch];
    return a;
}

static double shading(const fast_ctx *c, const obs *o, int ch)
{
    double s = c->use_sun ? c->x[0] * o->D : 0.0;
    for (int k = 0; k < NK; k++)
        s += c->x[1 + ch * NK + k] * o->A[k];
    return s;
}

static double spec_of(const fast_ctx *c, const obs *o)
{
    return c->use_spec && o->cluster >= 0 ? c->x[1 + 3 * NK + o->cluster] * o->P : 0.0;
}

/* The observations of chunk k (a fixed range), stepping by the stride from a multiple of it. */
static void chunk_range(const fast_ctx *c, int k, size_t *lo, size_t *hi)
{
    size_t a = c->n * (size_t)k / (size_t)c->obs_chunks, b = c->n * (size_t)(k + 1) / (size_t)c->obs_chunks;
    *lo = (a + c->stride - 1) / c->stride * c->stride;
    *hi = b;
}

static void cost_task(void *ctx, int k)
{
    fast_ctx *c = ctx;
    size_t lo, hi;
    chunk_range(c, k, &lo, &hi);
    double e = 0.0;
    for (size_t i = lo; i < hi; i += c->stride) {
        const obs *o = &c->o[i];
        if (o->eye)
            continue;
        double sp = spec_of(c, o);
        for (int ch = 0; ch < 3; ch++) {
            double model = albedo_at(c->ss, o, ch) * shading(c, o, ch) + sp, r = model - o->L[ch];
            e += bound_met(o, ch, model) ? 0.0 : o->w * r * r;
        }
    }
    c->part[(size_t)k * PART] = e;
}

/* Weighted squared residual of the current model. */
static double cost(fast_ctx *c)
{
    sp_pool_for(c->pool, c->obs_chunks, cost_task, c);
    double e = 0.0;
    for (int k = 0; k < c->obs_chunks; k++)
        e += c->part[(size_t)k * PART];
    return e;
}

/* Albedo pass 1, per lane: scatters its observations' data terms into the lane's texel sums. */
static void lane_task(void *ctx, int j)
{
    fast_ctx *c = ctx;
    double *restrict sum = c->lane + (size_t)j * c->nt * 6;
    size_t a = c->n * (size_t)j / (size_t)c->lanes, b = c->n * (size_t)(j + 1) / (size_t)c->lanes;
    for (size_t i = (a + c->stride - 1) / c->stride * c->stride; i < b; i += c->stride) {
        const obs *restrict o = &c->o[i];
        double sp = spec_of(c, o);
        for (int ch = 0; ch < 3; ch++) {
            double S = shading(c, o, ch);
            double model = sp + albedo_at(c->ss, o, ch) * S, r = bound_met(o, ch, model) ? 0.0 : o->L[ch] - model;
            for (int k = 0; k < 4; k++) {
                double *t = sum + (size_t)o->tex[k] * 6 + (size_t)ch * 2;
                double ws = o->w * o->tw[k] * S;
                t[0] += ws * r; /* a met bound adds no pull but keeps its curvature: still a majoriser */
                t[1] += ws * S; /* sum of taps is 1: a majoriser, so the Jacobi step never overshoots */
            }
        }
    }
}

/* Albedo pass 2, per texel chunk: the lanes summed in order (and zeroed), and the albedo's sum over seen texels. */
static void texel_sums_task(void *ctx, int k)
{
    fast_ctx *c = ctx;
    size_t t0 = c->nt * (size_t)k / (size_t)c->tex_chunks, t1 = c->nt * (size_t)(k + 1) / (size_t)c->tex_chunks;
    double *acc = c->part + (size_t)k * PART; /* seen-texel albedo sum per channel, and their count */
    acc[0] = acc[1] = acc[2] = acc[3] = 0.0;
    for (size_t t = t0; t < t1; t++) {
        for (int ch = 0; ch < 3; ch++) {
            double num = 0.0, den = 0.0;
            for (int j = 0; j < c->lanes; j++) {
                double *l = c->lane + ((size_t)j * c->nt + t) * 6 + (size_t)ch * 2;
                num += l[0], den += l[1];
                l[0] = l[1] = 0.0;
            }
            c->num[t * 3 + (size_t)ch] = num;
            c->den[t * 3 + (size_t)ch] = den;
        }
        if (c->seen[t]) {
            for (int ch = 0; ch < 3; ch++)
                acc[ch] += (double)c->ss->fit.albedo[t * 3 + (size_t)ch];
            acc[3] += 1.0;
        }
    }
}

/* Albedo pass 3, per texel chunk: the Jacobi update with the priors. */
static void texel_update_task(void *ctx, int k)
{
    fast_ctx *c = ctx;
    sp_sunstage *ss = c->ss;
    const double *pri = c->prior;
    size_t t0 = c->nt * (size_t)k / (size_t)c->tex_chunks, t1 = c->nt * (size_t)(k + 1) / (size_t)c->tex_chunks;
    for (size_t t = t0 * 3; t < t1 * 3; t += 3) {
        double nb[3];
        ss_albedo_neighbours(c->prev, ss->fit.tw, ss->fit.th, t, nb);
        for (int ch = 0; ch < 3; ch++) {
            size_t q = t + (size_t)ch;
            double a = (double)c->prev[q];
            /* the neighbour pull goes half way: a texel the data do not reach would otherwise take its
               neighbours' mean each step, and the alternating (checkerboard) mode never decays (the dot grid) */
            double toward = 0.5 * (nb[ch] - a);
            a += (c->num[q] + pri[3] * (pri[ch] - a) + pri[4] * toward) / (c->den[q] + pri[3] + pri[4]);
            ss->fit.albedo[q] = (float)(a < 0.0 ? 0.0 : (a > 4.0 ? 4.0 : a));
        }
    }
}

/* Jacobi steps of the per-texel closed form a = sum w S (L - spec) / sum w S^2, with a weak pull to the mean. */
static void solve_albedo(fast_ctx *c, int steps)
{
    sp_sunstage *ss = c->ss;
    size_t nt = c->nt * 3;
    for (int it = 0; it < steps; it++) {
        sp_pool_for(c->pool, c->lanes, lane_task, c);
        sp_pool_for(c->pool, c->tex_chunks, texel_sums_task, c);
        double mean[4] = { 0, 0, 0, 0 };
        for (int k = 0; k < c->tex_chunks; k++)
            for (int j = 0; j < 4; j++)
                mean[j] += c->part[(size_t)k * PART + (size_t)j];
        /* priors: a faint pull to the map's mean (unseen texels stay sane), and one to the texel's neighbours
           scaled to a typical observed texel's data weight, so texels between pixel samples interpolate */
        double typical = ss_albedo_typical_weight(c->den, c->seen, c->nt);
        double *pri = c->prior;
        for (int ch = 0; ch < 3; ch++)
            pri[ch] = mean[3] > 0.0 ? mean[ch] / mean[3] : 0.5;
        pri[3] = 1e-3 * typical + 1e-30;
        pri[4] = SS_ALBEDO_SMOOTH * typical;
        memcpy(c->prev, ss->fit.albedo, nt * sizeof(float));
        sp_pool_for(c->pool, c->tex_chunks, texel_update_task, c);
    }
}

/* After the last albedo solve: texels no observation reached are filled from the observed ones (albedo.c). */
static int fill_unseen(fast_ctx *c)
{
    sp_sunstage *ss = c->ss;
    size_t n = (size_t)ss->fit.tw * (size_t)ss->fit.th;
    size_t seen = 0;
    for (size_t t = 0; t < n; t++)
        seen += ss->fit.observed[t] = c->seen[t];
    if (!seen)
        return 0; /* nothing observed: the map stays at its prior */
    ss->fit.have_observed = 1;
    sp_log(SP_LOG_INFO, MOD, "albedo: %zu of %zu texels observed, the rest filled from them", seen, n);
    return ss_albedo_complete(ss);
}

#define NH (1 + NK)              /* one channel's albedo-scaled shading terms: sun diffuse, then the env lobes */
#define NTRI (NH * (NH + 1) / 2) /* their outer product's upper triangle */

/* Unknown of shading term p in channel ch (x: I, env per channel, I ks per cluster). */
static int term_unknown(int p, int ch)
{
    return p == 0 ? 0 : 1 + ch * NK + (p - 1);
}

/*
 * The normal equations' share of one observation chunk. The rows of an
 * observation are a * (D, A_0..A_8) for its channel and P for its cluster, so
 * the sums are kept as dense per-channel blocks and per-cluster cross terms
 * (no scattered updates into the full matrix), then laid out once per chunk.
 */
static void lighting_task(void *ctx, int k)
{
    fast_ctx *c = ctx;
    double blk[3][NTRI], bh[3][NH], cross[SP_RENDER_CLUSTERS][3][NH], pp[SP_RENDER_CLUSTERS], pl[SP_RENDER_CLUSTERS];
    memset(blk, 0, sizeof(blk));
    memset(bh, 0, sizeof(bh));
    memset(cross, 0, sizeof(cross));
    memset(pp, 0, sizeof(pp));
    memset(pl, 0, sizeof(pl));
    size_t lo, hi;
    chunk_range(c, k, &lo, &hi);
    for (size_t i = lo; i < hi; i += c->stride) {
        const obs *o = &c->o[i];
        if (o->eye)
            continue;
        double h[NH];
        h[0] = c->use_sun ? o->D : 0.0;
        for (int j = 0; j < NK; j++)
            h[1 + j] = o->A[j];
        int cl = c->use_spec ? o->cluster : -1;
        double sp = o->clip ? spec_of(c, o) : 0.0;
        for (int ch = 0; ch < 3; ch++) {
            double a = albedo_at(c->ss, o, ch);
            if (o->clip && bound_met(o, ch, a * shading(c, o, ch) + sp))
                continue; /* the current lighting already reaches the bound: not an active row */
            double u = o->w * a * a, wl = o->w * a * o->L[ch];
            double *t = blk[ch];
            for (int p = 0; p < NH; p++) {
                double up = u * h[p];
                for (int q = p; q < NH; q++)
                    *t++ += up * h[q];
                bh[ch][p] += wl * h[p];
            }
            if (cl >= 0) {
                double wp = o->w * a * o->P;
                for (int p = 0; p < NH; p++)
                    cross[cl][ch][p] += wp * h[p];
                pp[cl] += o->w * o->P * o->P;
                pl[cl] += o->w * o->P * o->L[ch];
            }
        }
    }
    double *A = c->part + (size_t)k * PART, *b = A + NL * NL;
    memset(A, 0, sizeof(double) * PART);
    for (int ch = 0; ch < 3; ch++) {
        const double *t = blk[ch];
        for (int p = 0; p < NH; p++) {
            int ip = term_unknown(p, ch);
            b[ip] += bh[ch][p];
            for (int q = p; q < NH; q++, t++) {
                int iq = term_unknown(q, ch);
                A[ip * NL + iq] += *t;
                if (iq != ip)
                    A[iq * NL + ip] += *t;
            }
        }
        for (int cl = 0; cl < SP_RENDER_CLUSTERS; cl++) {
            int is = 1 + 3 * NK + cl;
            for (int p = 0; p < NH; p++) {
                int ip = term_unknown(p, ch);
                A[is * NL + ip] += cross[cl][ch][p];
                A[ip * NL + is] += cross[cl][ch][p];
            }
        }
    }
    for (int cl = 0; cl < SP_RENDER_CLUSTERS; cl++) {
        int is = 1 + 3 * NK + cl;
        A[is * NL + is] += pp[cl];
        b[is] += pl[cl];
    }
}

/* Lighting unknowns by NNLS given the albedo, each cluster's ks at most SS_KS_MAX; terms switched off stay 0. */
static int solve_lighting(fast_ctx *c)
{
    double A[PART], x[NL];
    sp_pool_for(c->pool, c->obs_chunks, lighting_task, c);
    memset(A, 0, sizeof(A));
    for (int k = 0; k < c->obs_chunks; k++)
        for (int j = 0; j < PART; j++)
            A[j] += c->part[(size_t)k * PART + (size_t)j];
    double *b = A + NL * NL;
    double tr = 0.0;
    for (int i = 0; i < NL; i++)
        tr += A[i * NL + i];
    for (int i = 0; i < NL; i++) /* environment L2 (and a floor for unused unknowns) */
        A[i * NL + i] += 1e-6 * tr / NL + 1e-12;
    int ret = ss_nnls_capped(A, b, NL, 1 + 3 * NK, c->use_spec ? SP_RENDER_CLUSTERS : 0, SS_KS_MAX, x);
    if (ret)
        return ret;
    if (!c->use_sun)
        x[0] = 0.0;
    for (int i = 0; i < NL; i++)
        c->x[i] = x[i];
    return 0;
}

static double alternate(fast_ctx *c, int rounds, int albedo_steps)
{
    for (int r = 0; r < rounds; r++) {
        solve_albedo(c, albedo_steps);
        if (solve_lighting(c))
            return INFINITY;
    }
    return cost(c);
}

static void reset_state(fast_ctx *c)
{
    sp_sunstage *ss = c->ss;
    size_t nt = (size_t)ss->fit.tw * (size_t)ss->fit.th * 3;
    for (size_t t = 0; t < nt; t++)
        ss->fit.albedo[t] = 0.5f;
    memset(c->x, 0, sizeof(c->x));
    c->x[0] = c->use_sun ? 1.0 : 0.0;
    for (int ch = 0; ch < 3; ch++)
        c->x[1 + ch * NK] = 0.5;
}

/* Cost of a sun direction: alternations from a neutral start. */
static double try_sun(fast_ctx *c, const double d[3], int rounds)
{
    set_sun_diffuse(c, d);
    reset_state(c);
    return alternate(c, rounds, 2);
}

static void fib_dir(int i, int n, double d[3])
{
    double z = 1.0 - (2.0 * i + 1.0) / n;
    double r = sqrt(fmax(0.0, 1.0 - z * z));
    double ph = i * M_PI * (3.0 - sqrt(5.0));
    d[0] = r * cos(ph);
    d[1] = r * sin(ph);
    d[2] = z;
}

static void perturb(const double d[3], double step, int k, double out[3])
{
    /* tangent basis of d, then move by step along one of 8 directions */
    double a[3] = { fabs(d[0]) < 0.9 ? 1.0 : 0.0, fabs(d[0]) < 0.9 ? 0.0 : 1.0, 0.0 };
    double u[3] = { d[1] * a[2] - d[2] * a[1], d[2] * a[0] - d[0] * a[2], d[0] * a[1] - d[1] * a[0] };
    double nu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int i = 0; i < 3; i++)
        u[i] /= nu;
    double v[3] = { d[1] * u[2] - d[2] * u[1], d[2] * u[0] - d[0] * u[2], d[0] * u[1] - d[1] * u[0] };
    double ang = k * M_PI / 4.0;
    double len = 0.0;
    for (int i = 0; i < 3; i++) {
        out[i] = d[i] + step * (cos(ang) * u[i] + sin(ang) * v[i]);
        len += out[i] * out[i];
    }
    len = sqrt(len);
    for (int i = 0; i < 3; i++)
        out[i] /= len;
}

/* Shrinking pattern search around c->sun with the current visibility. */
static double pattern_search(fast_ctx *c, double step, double min_step, int rounds)
{
    double best = try_sun(c, c->sun, rounds);
    int turn = 0;
    while (step >= min_step) {
        int improved = 0;
        for (int k = turn & 1; k < 8; k += 2) { /* four directions, the diagonal set every other pass */
            double d[3];
            perturb(c->sun, step, k, d);
            double e = try_sun(c, d, rounds);
            if (e < best) {
                best = e;
                memcpy(c->sun, d, sizeof(d));
                improved = 1;
            }
        }
        if (!improved)
            step *= 0.7071;
        turn++;
    }
    return best;
}

/* Visibility (soft shadow) of each observation for the current sun, from the renderer. */
static int update_visibility(fast_ctx *c)
{
    sp_sunstage *ss = c->ss;
    int ret = 0;
    for (int fi = 0; fi < c->nf && !ret; fi++) {
        const ss_frame *f = &ss->res.slots[c->idx[fi]];
        sp_render_outputs o;
        if ((ret = render_white(c, f, c->sun, 1.0, NULL, 0.0, 16.0, &o)))
            break;
        for (size_t i = c->frame_start[fi]; i < c->frame_start[fi + 1]; i++)
            c->o[i].V = (double)o.visibility[c->o[i].px];
    }
    return ret;
}

/* Specular basis per observation for one shininess (ks = 1 in every cluster, white sun of intensity 1). */
static int update_specular(fast_ctx *c, double shin, float *out)
{
    sp_sunstage *ss = c->ss;
    int ret = 0;
    for (int fi = 0; fi < c->nf && !ret; fi++) {
        const ss_frame *f = &ss->res.slots[c->idx[fi]];
        sp_render_outputs o;
        if ((ret = render_white(c, f, c->sun, 1.0, NULL, 1.0, shin, &o)))
            break;
        for (size_t i = c->frame_start[fi]; i < c->frame_start[fi + 1]; i++)
            out[i] = o.specular[(size_t)c->o[i].px * 3];
    }
    return ret;
}

/* Per-cluster weighted residual under the current model. */
static void cluster_costs(const fast_ctx *c, double *e)
{
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++)
        e[k] = 0.0;
    for (size_t i = 0; i < c->n; i++) {
        const obs *o = &c->o[i];
        if (o->cluster < 0 || o->eye)
            continue;
        double sp = spec_of(c, o);
        for (int ch = 0; ch < 3; ch++) {
            double model = albedo_at(c->ss, o, ch) * shading(c, o, ch) + sp, r = model - o->L[ch];
            e[o->cluster] += bound_met(o, ch, model) ? 0.0 : o->w * r * r;
        }
    }
}

/* Chooses the shininess per cluster on a grid, solving albedo and lighting for each. */
static int fit_specular(fast_ctx *c)
{
    float *P = malloc(sizeof(float) * c->n * N_SHIN);
    if (!P)
        return -ENOMEM;
    int ret = 0;
    double best[SP_RENDER_CLUSTERS];
    int pick[SP_RENDER_CLUSTERS];
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++) {
        best[k] = INFINITY;
        pick[k] = 2;
    }
    c->use_spec = 1;
    for (int s = 0; s < N_SHIN && !ret; s++) {
        if ((ret = update_specular(c, shin_grid[s], P + (size_t)s * c->n)))
            break;
        for (size_t i = 0; i < c->n; i++)
            c->o[i].P = (double)P[(size_t)s * c->n + i];
        alternate(c, 2, 2);
        double e[SP_RENDER_CLUSTERS];
        cluster_costs(c, e);
        for (int k = 0; k < SP_RENDER_CLUSTERS; k++)
            if (e[k] < best[k]) {
                best[k] = e[k];
                pick[k] = s;
            }
    }
    for (size_t i = 0; ret == 0 && i < c->n; i++) {
        int k = c->o[i].cluster;
        c->o[i].P = k >= 0 ? (double)P[(size_t)pick[k] * c->n + i] : 0.0;
    }
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++)
        c->ss->fit.shin[k] = shin_grid[pick[k]];
    free(P);
    return ret;
}

static void report(fast_ctx *c, sp_sunstage_callback cb, void *user, int it, int total)
{
    sp_sunstage *ss = c->ss;
    double tr = NAN, ho = NAN;
    ss_evaluate(ss, &c->sc, &tr, &ho);
    ss->fit.train_psnr = tr;
    ss->fit.heldout_psnr = ho;
    if (!cb)
        return;
    sp_sunstage_progress p = { "photometric", it, total, (double)(sp_clock_monotonic_ns() - ss->fit.t0) * 1e-9,
                               isfinite(tr) ? pow(10.0, -tr / 10.0) : (double)NAN, ho };
    cb(user, &p);
}

/* Writes the solver's unknowns into the fitter's lighting state. */
static void commit(fast_ctx *c)
{
    sp_sunstage *ss = c->ss;
    double I = c->use_sun ? c->x[0] : 0.0;
    ss->fit.sun_I = I;
    memcpy(ss->fit.sun_dir, c->sun, sizeof(c->sun));
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++)
        ss->fit.ks[k] = c->use_spec && I > 1e-9 ? c->x[1 + 3 * NK + k] / I : 0.0;
    for (int t = 0; t < SP_RENDER_ENV_H * SP_RENDER_ENV_W; t++)
        for (int ch = 0; ch < 3; ch++) {
            double v = 0.0;
            for (int k = 0; k < NK; k++)
                v += c->x[1 + ch * NK + k] * (double)c->envb[(size_t)k * SP_RENDER_ENV_FLOATS + (size_t)t * 3 + (size_t)ch];
            ss->fit.env[t * 3 + ch] = (float)v;
        }
}


/*
 * A report row at a phase boundary: the state at the current sun, committed;
 * the loss is the solver's own weighted cost per channel (about the display
 * MSE, no rendering), the held-out PSNR is rendered (held-out frames only).
 */
static void checkpoint(fast_ctx *c, sp_sunstage_callback cb, void *user, int phase)
{
    if (!cb)
        return;
    sp_sunstage *ss = c->ss;
    size_t stride = c->stride;
    try_sun(c, c->sun, 2);
    commit(c);
    c->stride = 1;
    double loss = c->n ? cost(c) / (3.0 * (double)c->n) : (double)NAN;
    c->stride = stride;
    double ho = NAN;
    ss_evaluate(ss, &c->sc, NULL, &ho);
    sp_sunstage_progress p = { "photometric", phase, SS_FAST_PHASES,
                               (double)(sp_clock_monotonic_ns() - ss->fit.t0) * 1e-9, loss, ho };
    cb(user, &p);
}

#define SUN_STARTS 4        /* local minima of the coarse scan refined with shadows, the best one kept */
#define SUN_START_SEP 0.9063 /* cos 25 deg: starts closer than this to a better one are the same minimum */

/* Resets every observation's sun visibility to 1 (the coarse scan's unshadowed shading). */
static void clear_visibility(fast_ctx *c)
{
    for (size_t i = 0; i < c->n; i++)
        c->o[i].V = 1.0;
}

/*
 * The sun: a scan of the upper hemisphere on unshadowed shading (a third of the pixels), then the
 * SUN_STARTS best mutually distinct directions each refined by pattern search with the renderer's
 * shadows; the lowest shadowed cost wins and is refined further. One start alone settled in a wrong
 * minimum (25-60 deg off) on frame-subsampled variants of the path-traced sunny selfie: without
 * shadows the cost cannot tell a sun from its mirror across the face. The sun from the clock, when the
 * capture gives it, is one more start (clock_sun.c).
 */
static int fit_sun(fast_ctx *c, sp_sunstage_callback cb, void *user)
{
    sp_sunstage *ss = c->ss;
    double e_nosun, best = INFINITY;
    c->use_sun = 1;
    c->stride = 3;
    double start[SUN_STARTS + 1][3], start_e[SUN_STARTS + 1]; /* + the sun from the clock */
    int n_start = 0;
    for (int i = 0; i < 160; i++) { /* the scan keeps the best few directions at least 25 deg apart */
        double d[3];
        fib_dir(i, 320, d);
        double e = try_sun(c, d, 2);
        int at = n_start; /* insertion point by cost */
        while (at > 0 && e < start_e[at - 1])
            at--;
        int dup = 0;
        for (int k = 0; k < at && !dup; k++)
            dup = d[0] * start[k][0] + d[1] * start[k][1] + d[2] * start[k][2] > SUN_START_SEP;
        if (dup || at >= SUN_STARTS)
            continue;
        for (int k = at; k < n_start; k++) /* starts near the new one and worse than it are its minimum */
            if (d[0] * start[k][0] + d[1] * start[k][1] + d[2] * start[k][2] > SUN_START_SEP) {
                memmove(start[k], start[k + 1], sizeof(start[0]) * (size_t)(n_start - k - 1));
                memmove(start_e + k, start_e + k + 1, sizeof(double) * (size_t)(n_start - k - 1));
                n_start--;
                k--;
            }
        if (n_start == SUN_STARTS)
            n_start--;
        memmove(start[at + 1], start[at], sizeof(start[0]) * (size_t)(n_start - at));
        memmove(start_e + at + 1, start_e + at, sizeof(double) * (size_t)(n_start - at));
        memcpy(start[at], d, sizeof(d));
        start_e[at] = e;
        n_start++;
    }
    if (ss->clock.have && ss->clock.dir[2] > 0.0) /* the ephemeris sun competes as one more start */
        memcpy(start[n_start++], ss->clock.dir, sizeof(start[0]));
    checkpoint(c, cb, user, 1);
    double best_sun[3] = { 0, 0, 1 };
    for (int k = 0; k < n_start; k++) {
        memcpy(c->sun, start[k], sizeof(c->sun));
        clear_visibility(c);
        c->stride = 3;
        pattern_search(c, 0.12, 0.02, 2);
        c->stride = 2;
        pattern_search(c, 0.02, 0.004, 2);
        int ret = update_visibility(c);
        if (ret)
            return ret;
        double e = pattern_search(c, 0.02, 0.004, 2);
        sp_log(SP_LOG_DEBUG, MOD, "sun start %d (%.3f %.3f %.3f): refined to (%.3f %.3f %.3f), shadowed cost %.6g", k,
               start[k][0], start[k][1], start[k][2], c->sun[0], c->sun[1], c->sun[2], e);
        if (e < best) {
            best = e;
            memcpy(best_sun, c->sun, sizeof(best_sun));
        }
    }
    memcpy(c->sun, best_sun, sizeof(c->sun));
    checkpoint(c, cb, user, 2);
    c->stride = 2;
    checkpoint(c, cb, user, 3);
    for (int round = 0; round < 2; round++) { /* shadows from the renderer, then search again */
        int ret = update_visibility(c);
        if (ret)
            return ret;
        best = pattern_search(c, 0.02, 0.002, 3);
        checkpoint(c, cb, user, 4 + round);
    }
    c->stride = 1;
    best = try_sun(c, c->sun, 3);
    c->use_sun = 0;
    e_nosun = try_sun(c, c->sun, 3); /* same pixels and rounds as best */
    c->use_sun = 1;
    try_sun(c, c->sun, 1);
    if (!(best < 0.8 * e_nosun) || !(c->x[0] > 0.0)) {
        snprintf(ss->fit.notes, sizeof(ss->fit.notes),
                 "overcast: a sun explains %.0f%% of the residual of a sky-only fit (need 20%%); sun, shadows and "
                 "specular dropped",
                 e_nosun > 0.0 ? 100.0 * (1.0 - best / e_nosun) : 0.0);
        sp_log(SP_LOG_INFO, MOD, "%s", ss->fit.notes);
        ss->fit.sun_dropped = 1;
        c->use_sun = 0;
        reset_state(c);
        alternate(c, 6, 3);
    }
    return 0;
}

/* src sampled at dst's texel centres, as the renderer samples a map (bilinear, clamped): the coarser map's start. */
static void resample_map(const float *src, int sw, int sh, float *dst, int dw, int dh)
{
    for (int y = 0; y < dh; y++)
        for (int x = 0; x < dw; x++) {
            tex_lookup t;
            double rgb[3];
            tex_lookup_init(&t, sw, sh, ((double)x + 0.5) / dw, 1.0 - ((double)y + 0.5) / dh);
            tex_sample(&t, src, 3, rgb);
            for (int ch = 0; ch < 3; ch++)
                dst[((size_t)y * (size_t)dw + (size_t)x) * 3 + (size_t)ch] = (float)rgb[ch];
        }
}

/* Moves the fit to a map of `rows`, starting from `from` (tw x th x 3 of the old size) resampled. */
static int remap(fast_ctx *c, int rows, const float *from, int fw, int fh)
{
    sp_sunstage *ss = c->ss;
    int ret = ss_fit_alloc_maps(ss, rows);
    if (ret)
        return ret;
    if (fw == ss->fit.tw && fh == ss->fit.th)
        memcpy(ss->fit.albedo, from, sizeof(float) * 3 * (size_t)fw * (size_t)fh);
    else
        resample_map(from, fw, fh, ss->fit.albedo, ss->fit.tw, ss->fit.th);
    c->nt = (size_t)ss->fit.tw * (size_t)ss->fit.th;
    for (size_t i = 0; i < c->n; i++)
        texel_taps(ss, c->o[i].u, c->o[i].v, &c->o[i]);
    return plan_sums(c);
}

/*
 * texture_size 0: the map's rows chosen on the held-out frames, between SS_TEXTURE_ROWS and the rows that
 * give one texel per face pixel. Where the keyframes agree to a fraction of a pixel (the synthetic
 * captures) the finer map resolves detail between pixels; where they do not (another renderer's head,
 * landmarks a few percent off), its texels between the pixel samples take up the disagreement, a dot grid
 * at full resolution, and the held-out frames say so.
 */
static int choose_texture(fast_ctx *c)
{
    sp_sunstage *ss = c->ss;
    int fine_w = ss->fit.tw, fine_h = ss->fit.th, coarse = ss->fit.matched_rows;
    if (ss->set.texture_size != 0 || coarse <= 0 || coarse >= fine_h)
        return 0;
    double h_fine = NAN, h_coarse = NAN, x_fine[NL];
    commit(c);
    ss_evaluate(ss, &c->sc, NULL, &h_fine);
    if (!isfinite(h_fine)) {
        sp_log(SP_LOG_INFO, MOD, "texture: %d rows (no held-out frames to compare %d rows with)", fine_h, coarse);
        return 0;
    }
    size_t n = (size_t)fine_w * (size_t)fine_h * 3;
    float *fine = malloc(sizeof(float) * n);
    if (!fine)
        return -ENOMEM;
    memcpy(fine, ss->fit.albedo, sizeof(float) * n);
    memcpy(x_fine, c->x, sizeof(x_fine));
    int ret = remap(c, coarse, fine, fine_w, fine_h);
    if (!ret) {
        alternate(c, 4, 3);
        commit(c);
        ss_evaluate(ss, &c->sc, NULL, &h_coarse);
    }
    int keep_coarse = !ret && h_coarse > h_fine;
    if (!ret) {
        int won = keep_coarse ? coarse : fine_h, lost = keep_coarse ? fine_h : coarse;
        double h_won = keep_coarse ? h_coarse : h_fine, h_lost = keep_coarse ? h_fine : h_coarse;
        snprintf(ss->fit.texture_note, sizeof(ss->fit.texture_note),
                 "%d texture rows: held-out PSNR %.2f dB against %.2f dB with %d rows", won, h_won, h_lost, lost);
        ss->fit.texture_coarse = keep_coarse;
        sp_log(SP_LOG_INFO, MOD, "texture: %s", ss->fit.texture_note);
    }
    if (!ret && !keep_coarse) { /* back to the finer map exactly as it was */
        memcpy(c->x, x_fine, sizeof(x_fine));
        ret = remap(c, fine_h, fine, fine_w, fine_h);
    }
    free(fine);
    return ret;
}

#define EXPOSURE_STEPS 6      /* exposure steps, each followed by albedo and lighting given them */
#define EXPOSURE_EXPLAINS 0.2 /* kept when they explain this share of a one-exposure fit's residual (the sun's rule) */
#define EXPOSURE_MAX 8.0      /* an estimated exposure stays within 3 stops of the keyframes' geometric mean */

static double clamp_gain(double g)
{
    return g > EXPOSURE_MAX ? EXPOSURE_MAX : (g < 1.0 / EXPOSURE_MAX ? 1.0 / EXPOSURE_MAX : g);
}

/* Training keyframe fi's exposure multiplied by k, its observations rescaled as gather() would have made them. */
static void scale_exposure(fast_ctx *c, int fi, double k)
{
    c->ss->res.slots[c->idx[fi]].expo *= k;
    for (size_t i = c->frame_start[fi]; i < c->frame_start[fi + 1]; i++) {
        for (int ch = 0; ch < 3; ch++)
            c->o[i].L[ch] /= k;
        c->o[i].w *= k * k;
    }
}

/*
 * One step of each training keyframe's exposure: times the gain that best fits the model to its observations
 * (weighted least squares in linear light, clipped channels and eyes left out), the gains' geometric mean
 * made 1 (the common scale is the albedo's and the light's).
 */
static void exposure_step(fast_ctx *c)
{
    sp_sunstage *ss = c->ss;
    double g[64], lsum = 0.0;
    for (int fi = 0; fi < c->nf; fi++) {
        double num = 0.0, den = 0.0;
        for (size_t i = c->frame_start[fi]; i < c->frame_start[fi + 1]; i++) {
            const obs *o = &c->o[i];
            double sp = spec_of(c, o);
            for (int ch = 0; !o->eye && ch < 3; ch++) {
                double m = albedo_at(ss, o, ch) * shading(c, o, ch) + sp;
                num += (o->clip >> ch & 1) ? 0.0 : o->w * o->L[ch] * m;
                den += (o->clip >> ch & 1) ? 0.0 : o->w * m * m;
            }
        }
        g[fi] = clamp_gain(den > 0.0 && num > 0.0 ? num / den : 1.0);
        lsum += log(g[fi]);
    }
    double norm = exp(lsum / (c->nf > 0 ? c->nf : 1));
    for (int fi = 0; fi < c->nf; fi++) {
        double e = ss->res.slots[c->idx[fi]].expo;
        scale_exposure(c, fi, clamp_gain(e * g[fi] / norm) / e);
    }
}

/* Each held-out frame's exposure times the gain that best fits its render, in linear light (display slope weights). */
static int heldout_exposures(fast_ctx *c)
{
    sp_sunstage *ss = c->ss;
    int idx[64], n = ss_list_frames(ss, 1, idx, 64), npx = ss->W * ss->H, ret = 0;
    float *mask = malloc(sizeof(float) * (size_t)npx);
    if (!mask)
        return -ENOMEM;
    for (int k = 0; k < n && !ret; k++) {
        ss_frame *f = &ss->res.slots[idx[k]];
        sp_render_scene scene;
        sp_render_outputs o;
        if ((ret = ss_scene_setup(&c->sc, ss, f, &scene)) || (ret = sp_render(c->sc.r, &scene, &o)))
            break;
        ss_scene_mask(&c->sc, &o, f->rgb, mask);
        double num = 0.0, den = 0.0;
        for (int p = 0; p < npx; p++)
            for (int ch = 0; mask[p] > 0.0f && ch < 3; ch++) {
                size_t q = (size_t)p * 3 + (size_t)ch;
                if (f->rgb[q] >= 0.99f) /* clipped: a lower bound, no measure of the gain */
                    continue;
                double sl, sm, seen = ss_tonemap_inverse((double)f->rgb[q], &sl);
                double model = ss_tonemap_inverse((double)o.image[q], &sm);
                num += sl * sl * seen * model;
                den += sl * sl * model * model;
            }
        f->expo = clamp_gain(f->expo * (den > 0.0 && num > 0.0 ? num / den : 1.0));
    }
    free(mask);
    return ret;
}

/*
 * When no frame gives its exposure: each keyframe's estimated (EXPOSURE_STEPS steps alternating with albedo
 * and lighting), kept only when that explains EXPOSURE_EXPLAINS of the residual of as many alternations at
 * one exposure; then the held-out frames'. Returns 1 when kept (the caller solves again), 0 when left out
 * (the solve's state as it was), or a negative error.
 */
static int estimate_exposures(fast_ctx *c)
{
    sp_sunstage *ss = c->ss;
    size_t na = (size_t)ss->fit.tw * (size_t)ss->fit.th * 3;
    float *albedo = malloc(sizeof(float) * na);
    double *lw = malloc(sizeof(double) * 4 * c->n), x[NL], expo[64], e_fixed, e_free, lo = INFINITY, hi = 0.0;
    if (!albedo || !lw) {
        free(albedo), free(lw);
        return -ENOMEM;
    }
    memcpy(albedo, ss->fit.albedo, sizeof(float) * na);
    memcpy(x, c->x, sizeof(x));
    for (size_t i = 0; i < c->n; i++) /* the observations at the exposures they were gathered with */
        memcpy(lw + 4 * i, c->o[i].L, sizeof(double) * 3), lw[4 * i + 3] = c->o[i].w;
    for (int fi = 0; fi < c->nf; fi++)
        expo[fi] = ss->res.slots[c->idx[fi]].expo;
    for (int k = 0; k < 2 * EXPOSURE_STEPS; k++) /* as many rounds as the estimate gets, and its start */
        alternate(c, 2, 2);
    e_fixed = cost(c);
    for (int k = 0; k < EXPOSURE_STEPS; k++) {
        exposure_step(c);
        alternate(c, 2, 2);
    }
    e_free = cost(c);
    for (int fi = 0; fi < c->nf; fi++) {
        lo = fmin(lo, ss->res.slots[c->idx[fi]].expo);
        hi = fmax(hi, ss->res.slots[c->idx[fi]].expo);
    }
    double explained = e_fixed > 0.0 ? 1.0 - e_free / e_fixed : 0.0;
    int keep = explained >= EXPOSURE_EXPLAINS;
    sp_log(SP_LOG_INFO, MOD,
           "exposure: none in the capture; estimated per keyframe, %.3f..%.3f of their geometric "
           "mean, they explain %.0f%% of the residual at one exposure (need %.0f%%): %s",
           lo, hi, 100.0 * explained, 100.0 * EXPOSURE_EXPLAINS, keep ? "kept" : "left out");
    int ret = 0;
    if (keep) {
        commit(c); /* the held-out frames are rendered with this light */
        ret = heldout_exposures(c);
    } else { /* back to one exposure and the solve's own state, exactly */
        for (int fi = 0; fi < c->nf; fi++)
            ss->res.slots[c->idx[fi]].expo = expo[fi];
        for (size_t i = 0; i < c->n; i++)
            memcpy(c->o[i].L, lw + 4 * i, sizeof(double) * 3), c->o[i].w = lw[4 * i + 3];
        memcpy(ss->fit.albedo, albedo, sizeof(float) * na);
        memcpy(c->x, x, sizeof(x));
    }
    free(albedo), free(lw);
    return ret ? ret : keep;
}

static int fast_run_once(fast_ctx *c, sp_sunstage_callback cb, void *user);

/* The solve; when the capture gives no frame's exposure (a phone's video) and estimating them pays, again with them. */
static int fast_run(fast_ctx *c, sp_sunstage_callback cb, void *user)
{
    sp_sunstage *ss = c->ss;
    int fine_rows = ss->fit.th, ret = fast_run_once(c, cb, user);
    if (ret || c->decide_only || ss->fe.expo_ref > 0.0 || ss->set.fixed_exposure)
        return ret;
    if ((ret = estimate_exposures(c)) <= 0)
        return ret;
    /* from the start again: the sun and its overcast decision, the specular, the map's rows */
    if (!ss->fit.unobservable) {
        ss->fit.sun_dropped = 0;
        ss->fit.notes[0] = '\0';
    }
    c->use_sun = c->use_spec = 0;
    ss->fit.texture_coarse = 0;
    ss->fit.texture_note[0] = '\0';
    if (ss->fit.th != fine_rows && (ret = ss_fit_alloc_maps(ss, fine_rows)))
        return ret;
    c->nt = (size_t)ss->fit.tw * (size_t)ss->fit.th;
    c->n = 0;
    return fast_run_once(c, cb, user);
}

static int fast_run_once(fast_ctx *c, sp_sunstage_callback cb, void *user)
{
    sp_sunstage *ss = c->ss;
    c->sun[0] = c->sun[1] = 0.0;
    c->sun[2] = 1.0;
    int ret = gather(c);
    if (ret)
        return ret;
    if (c->n < 50) {
        sp_log(SP_LOG_ERROR, MOD, "only %zu face pixels in the keyframes: the face is too small or misaligned", c->n);
        return SP_ENODATA;
    }
    if (ss->fit.unobservable) {
        c->use_sun = 0;
        reset_state(c);
        alternate(c, 6, 3);
    } else if ((ret = fit_sun(c, cb, user))) {
        return ret;
    }
    if (c->decide_only)
        return 0;
    if (c->use_sun) {
        try_sun(c, c->sun, 4);
        commit(c);
        report(c, cb, user, 6, SS_FAST_PHASES);
        if ((ret = fit_specular(c)))
            return ret;
        alternate(c, 4, 3);
    }
    if ((ret = choose_texture(c)))
        return ret;
    if ((ret = fill_unseen(c)))
        return ret;
    commit(c);
    report(c, cb, user, 7, SS_FAST_PHASES);
    size_t n_clip = 0;
    for (size_t i = 0; i < c->n; i++)
        n_clip += c->o[i].clip != 0;
    sp_log(SP_LOG_INFO, MOD, "fast solver: %zu observations (%zu clipped: lower bounds), sun (%.3f %.3f %.3f) I %.3f, "
           "train %.2f dB", c->n, n_clip, ss->fit.sun_dir[0], ss->fit.sun_dir[1], ss->fit.sun_dir[2], ss->fit.sun_I,
           ss->fit.train_psnr);
    return 0;
}

static int fast_main(sp_sunstage *ss, sp_sunstage_callback cb, void *user, int decide_only)
{
    fast_ctx c;
    memset(&c, 0, sizeof(c));
    c.ss = ss;
    c.stride = 1;
    c.decide_only = decide_only;
    c.nf = ss_list_frames(ss, 0, c.idx, 64);
    size_t nt = (size_t)ss->fit.tw * (size_t)ss->fit.th * 3;
    int ret = ss_scene_open(&c.sc, ss);
    if (ret)
        return ret;
    c.frame_start = calloc((size_t)c.nf + 1, sizeof(size_t));
    c.envb = malloc(sizeof(float) * SP_RENDER_ENV_FLOATS * NK);
    c.num = malloc(sizeof(double) * nt);
    c.den = malloc(sizeof(double) * nt);
    c.prev = malloc(sizeof(float) * nt);
    c.seen = malloc(nt / 3);
    c.nt = nt / 3;
    c.part = malloc(sizeof(double) * CHUNKS * PART);
    if (!ret)
        ret = sp_pool_open(&c.pool, ss->set.threads);
    if (!c.frame_start || !c.envb || !c.num || !c.den || !c.prev || !c.seen || !c.part)
        ret = -ENOMEM;
    if (!ret) {
        make_env_basis(c.envb);
        ret = fast_run(&c, cb, user);
    }
    ss_scene_close(&c.sc);
    free(c.o);
    free(c.frame_start);
    free(c.envb);
    free(c.num);
    free(c.den);
    free(c.prev);
    free(c.seen);
    free(c.part);
    free(c.lane);
    sp_pool_close(&c.pool);
    return ret;
}

int ss_fit_fast(sp_sunstage *ss, sp_sunstage_callback cb, void *user)
{
    return fast_main(ss, cb, user, 0);
}

int ss_fast_overcast_check(sp_sunstage *ss)
{
    size_t n = (size_t)ss->fit.tw * (size_t)ss->fit.th * 3;
    float *keep = malloc(sizeof(float) * n);
    if (!keep)
        return -ENOMEM;
    memcpy(keep, ss->fit.albedo, sizeof(float) * n);
    int ret = fast_main(ss, NULL, NULL, 1);
    memcpy(ss->fit.albedo, keep, sizeof(float) * n);
    free(keep);
    sp_log(SP_LOG_INFO, MOD, "overcast check (fast solver's sun search): %s",
           ss->fit.sun_dropped ? "overcast, sun dropped" : "a sun is needed");
    return ret;
}
