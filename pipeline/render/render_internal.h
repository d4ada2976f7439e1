/* SPDX-License-Identifier: MIT */
/* The renderer object shared by the forward (renderer.c) and adjoint (adjoint.c) passes. */
#ifndef SUNPROBE_RENDER_INTERNAL_H
#define SUNPROBE_RENDER_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "pipeline/render/envlight.h"
#include "pipeline/render/geometry.h"
#include "pipeline/render/raster.h"
#include "pipeline/render/shading.h"
#include "pipeline/render/shadow.h"
#include "sunprobe/sp_render.h"

struct sp_renderer {
    sp_renderer_settings set;
    int sw, sh;            /* sample grid */
    size_t npix, nsamp;
    /* per pixel */
    float *image, *radiance, *diffuse, *specular, *ambient, *fill, *visibility, *normal, *albedo, *coverage;
    float *out_diffuse, *out_specular, *out_ambient, *out_fill, *out_visibility, *out_normal, *out_albedo;
                           /* the above, or NULL where settings.skip_outputs (or the fused path) skips them */
    double *radiance64, *image64; /* double twins: the adjoint's reference, float outputs are their rounding */
    /* per sample */
    int32_t *tri_id, *shadow_texel;
    sun_cache *sun_cache;  /* forward sun terms the adjoint reuses */
    shade_rec *recs;       /* SIMD_BATCH (>= S * S): one pixel's (fit_float: one batch's) records, fused path */
    struct simd_batch *batches; /* fit_float: one batch of samples in float SoA (shade_simd.h) */
    const struct simd_kernels *simd; /* fit_float: the kernel set for this CPU (simd_kernels.h) */
    int *row_first;        /* fit_float: SIMD_BATCH + 1 offsets of each batch pixel's first record */
    float *bary, *depth;
    render_geom geo;
    shadow_map sm;
    double *env_basis;     /* ENV_TEXELS * ENV_SH_N */
    raster_camera cam;
    /* state of the last sp_render, for the adjoint */
    shade_ctx ctx;
    const sp_mesh *last_mesh;
    uint32_t last_nv, last_nt;
    int have_render;
    int backward_ok;       /* 0 after a render with forward-only features */
};

/*
 * The last render's display image in double (3 per pixel): what the adjoint
 * differentiates exactly; the float output is its rounding. For tests.
 */
const double *render_image_f64(const sp_renderer *r);

/*
 * Forward steps shared by sp_render and the fused path (renderer.c):
 * validation, capacity, geometry, frame constants and the camera raster.
 * need_backward: refuse (SP_EUNSUPPORTED) scenes without gradients first.
 * want_bary: 0 leaves r->bary as it was (fit_float does not read it).
 */
int render_begin(sp_renderer *r, const sp_render_scene *sc, int need_backward, int want_bary, int *n_sun);
/* Records the frame for a following sp_render_backward. */
void render_end(sp_renderer *r, const sp_render_scene *sc, int n_sun);
const shadow_map *render_prepare_shadow(sp_renderer *r, const sp_render_scene *sc, const double l[3], int force);
void render_fill_outputs(const sp_renderer *r, sp_render_outputs *out);

/* The adjoint pass (adjoint.c); arguments already validated. */
int render_backward_pass(sp_renderer *r, const sp_render_scene *sc, const float *dL, sp_render_grads *gr);

/* Pieces of the adjoint pass the fused path (fused.c) shares. */
typedef struct shade_acc shade_acc;
/* Clears the per-vertex accumulators; sets up ctx (a copy of the frame's) and acc for gr. */
void render_backward_begin(sp_renderer *r, const sp_render_scene *sc, sp_render_grads *gr, shade_ctx *ctx,
                           shade_acc *acc);
/*
 * dL/d(per-sample linear radiance) of pixel i from dL/d(its 3 display values);
 * adds to *g_exposure. 0 when the pixel has no gradient.
 */
int render_pixel_adjoint(const sp_renderer *r, const sp_render_scene *sc, const float dl[3], size_t i,
                         double gc[3], double *g_exposure);
/* Camera, geometry, environment and scalar chains after all samples. */
void render_backward_finish(sp_renderer *r, const sp_render_scene *sc, const shade_ctx *ctx, const shade_acc *acc,
                            double g_exposure, sp_render_grads *gr);

#endif
