/* SPDX-License-Identifier: MIT */
/*
 * Mesh geometry for the renderer: per-vertex displacement along the coarse
 * normal, area-weighted vertex normals of the displaced mesh, camera-space
 * positions, and the adjoint of all of it back to world positions and
 * displacement texels. Buffers are sized by capacity and reused every frame.
 */
#ifndef SUNPROBE_RENDER_GEOMETRY_H
#define SUNPROBE_RENDER_GEOMETRY_H

#include <stdint.h>

#include "sunprobe/sp_mesh.h"
#include "sunprobe/sp_render.h"

typedef struct render_geom {
    uint32_t cap_v, cap_t;
    int32_t *copy_head;   /* per vertex: first distinct UV copy (index into copy_*), -1 none */
    int32_t *copy_next;   /* per corner slot: next copy of the same vertex */
    uint32_t *copy_uv;    /* per corner slot: the UV index of this copy */
    uint32_t *copy_count; /* per vertex: number of distinct UV copies */
    double *p0;  /* 3 per vertex: input positions */
    double *h;   /* displacement per vertex, metres */
    double *m0, *n0; /* coarse normal sums (sum of face cross products) and unit normals */
    double *pd;  /* displaced positions */
    double *md, *nd; /* displaced normal sums and unit normals */
    float *ndf;      /* nd rounded to float (the fit_float gather's per-vertex input; same values it converted per sample) */
    double *xc;  /* displaced positions in camera space */
    double *tri_k; /* 9 per triangle: camera-space B x C, C x A, A x B of drawn triangles (raster.h) */
    double *xs;    /* 2 per vertex: the rasteriser's scratch (sample-grid projections) */
    double *col_dx; /* 1 per sample column and row: the rasteriser's scratch (ray x and y) */
    int cap_cols;
    double *im0, *imd; /* 1 / |m0|, 1 / |md| per vertex (0 where the sum is tiny): the backward needs no sqrt */
    /*
     * Copy of the last mesh's positions and indices: when a frame's are equal
     * (fitting usually moves only the displacement, camera and lighting), the
     * UV-copy lists, p0, m0, n0 and im0 are kept instead of rebuilt.
     */
    float *key_pos;
    uint32_t *key_tv, *key_tuv;
    uint32_t key_nv, key_nt, key_nuv;
    int key_valid;
    /* adjoint accumulators, same layout */
    double *g_pd, *g_nd, *g_xc, *g_n0, *g_h;
    double *g_m; /* scratch: adjoint of a normal sum */
} render_geom;

/* Grows the buffers to hold the mesh; 0 or -ENOMEM (buffers then freed, capacity 0). */
int geom_reserve(render_geom *g, uint32_t n_vertices, uint32_t n_triangles);
/* Grows col_dx to n doubles (sample columns + rows); 0 or -ENOMEM. geom_reserve may free it: call after. */
int geom_reserve_raster(render_geom *g, int n);
void geom_free(render_geom *g);

/* Displacement (disp->data may be NULL), normals, then camera space with R, t. */
void geom_forward(render_geom *g, const sp_mesh *mesh, const sp_render_texture *disp, const double R[9],
                  const double t[3]);
/*
 * 1 when the mesh's vertex, triangle and UV counts, positions and index arrays
 * equal the copy kept by the last geom_forward (the mesh's arrays must be
 * readable: non-NULL where their count is nonzero).
 */
int geom_mesh_unchanged(const render_geom *g, const sp_mesh *mesh);
/* geom_forward with geom_mesh_unchanged(g, mesh) already known (same: its result for this mesh, now). */
void geom_forward_known(render_geom *g, const sp_mesh *mesh, int same, const sp_render_texture *disp,
                        const double R[9], const double t[3]);

/*
 * Adjoint: from g_pd and g_nd (displaced positions and unit normals, filled
 * by the shading adjoint) adds dL/d(world positions) to g_positions (3 per
 * vertex, may be NULL) and dL/d(texels) to g_disp (may be NULL).
 */
void geom_backward(render_geom *g, const sp_mesh *mesh, const sp_render_texture *disp, double *g_positions,
                   double *g_disp);

#endif
