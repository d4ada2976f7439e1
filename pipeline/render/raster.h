/* SPDX-License-Identifier: MIT */
/*
 * Camera rasteriser. Homogeneous (2D-homogeneous / ray-triangle) edge
 * functions: for a sample ray d and a camera-space triangle (A, B, C),
 * w = (d.(B x C), d.(C x A), d.(A x B)) are affine in the pixel position, the
 * perspective-correct barycentrics are w / sum(w) and the depth is
 * [A B C] / sum(w). Near/far handling needs no geometric clipping: a sample
 * is kept only when its hit depth lies in [near, far]; clipping is used only to
 * bound the screen rectangle of triangles that cross the near plane.
 */
#ifndef SUNPROBE_RENDER_RASTER_H
#define SUNPROBE_RENDER_RASTER_H

#include <stdint.h>

#include "sunprobe/sp_mesh.h"

typedef struct raster_camera {
    double fx, fy, cx, cy;
    double near_plane, far_plane;
    int supersample;          /* S */
    int sample_width, sample_height;
    int cull_backfaces;
} raster_camera;

/* Camera-space ray direction (z = 1) through the centre of sample (sx, sy). */
static inline void raster_sample_ray(const raster_camera *c, int sx, int sy, double d[3])
{
    double s = (double)c->supersample;
    d[0] = (((double)sx + 0.5) / s - 0.5 - c->cx) / c->fx;
    d[1] = (((double)sy + 0.5) / s - 0.5 - c->cy) / c->fy;
    d[2] = 1.0;
}

/*
 * Unnormalised barycentric weights w and their sum for ray d through the
 * triangle (a, b, c); lambda = w / sum. Identical arithmetic to the rasteriser.
 */
void raster_tri_weights(const double a[3], const double b[3], const double c[3], const double d[3],
                        double w[3], double *sum);

/*
 * Rasterises mesh triangles whose camera-space vertices are xc (3 per vertex)
 * into per-sample triangle ids (-1 empty), depths (zbuf, FLT_MAX empty) and
 * barycentrics (3 per sample). Depth test keeps the nearest hit.
 */
void raster_camera_draw(const raster_camera *c, const double *xc, const sp_mesh *mesh, int32_t *tri_id,
                        float *zbuf, float *bary);

#endif
