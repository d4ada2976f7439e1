/* SPDX-License-Identifier: MIT */
/*
 * Per-sample shading: rebuilds the surface point from the triangle id and the
 * sample ray (so forward and adjoint share one set of formulas), then
 * evaluates environment diffuse (SH irradiance), the sun's Lambert and
 * normalised Blinn-Phong terms with soft shadow-map visibility, and fill lights.
 * A shade_rec keeps every intermediate the adjoint needs; the costly part of
 * the sun term (shadow lookup, lobe power) is also kept per sample in a
 * sun_cache so the adjoint does not redo it.
 */
#ifndef SUNPROBE_RENDER_SHADING_H
#define SUNPROBE_RENDER_SHADING_H

#include <stdint.h>

#include "pipeline/render/envlight.h"
#include "pipeline/render/geometry.h"
#include "pipeline/render/raster.h"
#include "pipeline/render/shadow.h"
#include "pipeline/render/texture.h"
#include "sunprobe/sp_render.h"

#define SHADE_NH_MIN 1e-12 /* n.h is clamped to [SHADE_NH_MIN, 1] before log */
#define SHADE_PI 3.14159265358979323846

/* Per-frame constants. */
typedef struct shade_ctx {
    const sp_render_scene *sc;
    const render_geom *geo;
    const raster_camera *cam;
    double eye[3];          /* camera centre, world */
    double sun_l[3];        /* unit sun direction used for shading */
    double sun_len;         /* |scene.sun_dir| */
    double sun_I;           /* irradiance of this sun direction (I / samples) */
    env_sh sh;
    const shadow_map *sm;   /* NULL: no shadows */
    double shadow_k, shadow_b;
    double soft_tan, soft_sin; /* a soft sun's tan and sin of its angular radius; 0: a point sun */
    double ks[SP_RENDER_CLUSTERS], s[SP_RENDER_CLUSTERS];
    int s_clamped[SP_RENDER_CLUSTERS];
} shade_ctx;

/* Normalised Blinn-Phong lobe state for one light direction. */
typedef struct blinn_state {
    double hs[3], hlen, h[3]; /* l + v, its length, the half vector */
    double nh;                /* n.h clamped to [SHADE_NH_MIN, 1] */
    double log_nh;            /* log(nh) */
    double P;                 /* nh^s */
    int nh_clamped;           /* the clamp was active: no gradient through nh */
} blinn_state;

/* What the adjoint reuses from the forward sun term of one sample (its costly parts). */
typedef struct sun_cache {
    float V, dVdp[3]; /* shadow lookup */
    float P, log_nh;  /* Blinn-Phong lobe */
} sun_cache;

typedef struct shade_rec {
    int32_t tri;
    uint32_t vi[3], ui[3];
    int sx, sy;
    double d[3], w[3], wsum, lam[3];
    double p[3], m[3], mlen, n[3], uv[2];
    double ev[3], evlen, v[3];     /* eye - p and its direction */
    tex_lookup alb;
    double a[3];
    int cluster;                   /* -1: no specular */
    double E[3];                   /* SH irradiance */
    int have_dE;                   /* dEdn and y hold E's derivative and basis (shade_ambient_full) */
    double dEdn[3][3], y[ENV_SH_N];
    /* sun */
    double nl, V;
    shadow_sample shadow;
    blinn_state bl;
    int spec_on;
    /* results (linear radiance) */
    double diff[3], spec, amb[3], fill[3];
} shade_rec;

/* Fills the geometry part of rec; 0 if the sample cannot be shaded (degenerate hit). */
int shade_geometry(const shade_ctx *ctx, int sx, int sy, int32_t tri, shade_rec *rec);
/* Ambient (environment) term into rec->amb. */
void shade_ambient(const shade_ctx *ctx, shade_rec *rec);
/* The same, also keeping dE/dn and the SH basis for shade_backward (the fused path). */
void shade_ambient_full(const shade_ctx *ctx, shade_rec *rec);
/* Fill lights into rec->fill (unshadowed). */
void shade_fill(const shade_ctx *ctx, shade_rec *rec);
/*
 * Sun term for unit direction l with irradiance I and shadow map sm (NULL =
 * unshadowed); fills *store (if non-NULL) for shade_sun_replay.
 */
void shade_sun(const shade_ctx *ctx, shade_rec *rec, const double l[3], double I, const shadow_map *sm,
               sun_cache *store);
/* The same for ctx's sun, taking the shadow lookup and lobe power from the forward pass's cache. */
void shade_sun_replay(const shade_ctx *ctx, shade_rec *rec, const sun_cache *c);

#endif
