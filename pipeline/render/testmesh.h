/* SPDX-License-Identifier: MIT */
/*
 * Procedural scenes for the renderer's tests and benchmark (internal): a
 * UV-sphere "head" (ellipsoid with a nose bump, a UV seam and pole fans) and
 * tessellated quads, all counter-clockwise seen from outside, in metres; and a
 * look-at camera pose.
 */
#ifndef SUNPROBE_RENDER_TESTMESH_H
#define SUNPROBE_RENDER_TESTMESH_H

#include "sunprobe/sp_mesh.h"
#include "sunprobe/sp_render.h"

/*
 * Head centred at c with semi-axes ax (x), ay (y), az (z, up); the nose bump
 * points along -y with relative height `nose` (0 = plain ellipsoid).
 * Triangles: 2 * n_lon * (n_lat - 1). UV: u = azimuth / 2 pi, v = 1 - polar / pi.
 */
int testmesh_head(sp_mesh *m, int n_lat, int n_lon, const double c[3], double ax, double ay, double az,
                  double nose);
/*
 * Quad p0 + s e_u + t e_v for s, t in [0, 1], split into nu x nv cells of
 * two triangles; UV (s, t). The front side is e_u x e_v.
 */
int testmesh_grid(sp_mesh *m, const double p0[3], const double e_u[3], const double e_v[3], int nu, int nv);
/* Appends b to a (a grows; b unchanged). */
int testmesh_append(sp_mesh *a, const sp_mesh *b);
/* Pose of a camera at eye looking at target with world `up` (OpenCV axes); intrinsics untouched. */
void testmesh_look_at(sp_render_camera *cam, const double eye[3], const double target[3], const double up[3]);

#endif
