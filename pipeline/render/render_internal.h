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
    double *radiance64, *image64; /* double twins: the adjoint's reference, float outputs are their rounding */
    /* per sample */
    int32_t *tri_id, *shadow_texel;
    sun_cache *sun_cache;  /* forward sun terms the adjoint reuses */
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

/* The adjoint pass (adjoint.c); arguments already validated. */
int render_backward_pass(sp_renderer *r, const sp_render_scene *sc, const float *dL, sp_render_grads *gr);

#endif
