/* SPDX-License-Identifier: MIT */
/*
 * Camera rasteriser. Homogeneous (ray-triangle) edge functions: for a sample
 * ray d and a camera-space triangle (A, B, C), w = (d.(B x C), d.(C x A),
 * d.(A x B)) are affine in the pixel position, the perspective-correct
 * barycentrics are w / sum(w) and the depth is [A B C] / sum(w). Near/far
 * handling needs no geometric clipping: a sample is kept only when its hit
 * depth lies in [near, far]; clipping only bounds the screen rectangle of
 * triangles that cross the near plane.
 */
#ifndef SUNPROBE_RENDER_RASTER_H
#define SUNPROBE_RENDER_RASTER_H

#include <stdint.h>

#include "sunprobe/sp_mesh.h"

typedef struct raster_camera {
    double fx, fy, cx, cy;
    double inv_fx, inv_fy, inv_s; /* 1 / fx, 1 / fy, 1 / supersample */
    double near_plane, far_plane;
    int supersample;              /* S */
    int sample_width, sample_height;
    int cull_backfaces;
} raster_camera;

/* Camera-space ray direction (z = 1) through the centre of sample (sx, sy). */
static inline void raster_sample_ray(const raster_camera *c, int sx, int sy, double d[3])
{
    d[0] = (((double)sx + 0.5) * c->inv_s - 0.5 - c->cx) * c->inv_fx;
    d[1] = (((double)sy + 0.5) * c->inv_s - 0.5 - c->cy) * c->inv_fy;
    d[2] = 1.0;
}

/*
 * Unnormalised barycentric weights of ray d for a triangle whose edge vectors
 * k = (B x C, C x A, A x B) were cached by the rasteriser: w_i = d.k_i.
 */
static inline double raster_weights(const double k[9], const double d[3], double w[3])
{
    w[0] = k[0] * d[0] + k[1] * d[1] + k[2];
    w[1] = k[3] * d[0] + k[4] * d[1] + k[5];
    w[2] = k[6] * d[0] + k[7] * d[1] + k[8];
    return w[0] + w[1] + w[2];
}

/*
 * Rasterises mesh triangles whose camera-space vertices are xc (3 per vertex)
 * into per-sample triangle ids (-1 empty), depths (zbuf, FLT_MAX empty) and
 * barycentrics (3 per sample; bary NULL: not computed); the nearest hit wins. tri_k (9 doubles per
 * triangle) receives B x C, C x A, A x B of every triangle that may own a
 * sample (entries of the others are left as they were). Scratch: xs, 2
 * doubles per vertex (the vertices' sample-grid projections), col_dx, one
 * per sample column and one per sample row (the rays' x and y).
 */
void raster_camera_draw(const raster_camera *c, const double *xc, const sp_mesh *mesh, int32_t *tri_id,
                        float *zbuf, float *bary, double *tri_k, double *xs, double *col_dx);

#endif
