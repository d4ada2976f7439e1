/* SPDX-License-Identifier: MIT */
/* Small vector and quaternion types used across the public API (double precision). */
#ifndef SUNPROBE_SP_MATH_H
#define SUNPROBE_SP_MATH_H

#include "sp_common.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sp_vec3 {
    double x, y, z;
} sp_vec3;

/* Unit quaternion w + xi + yj + zk rotating vectors from a body frame into the world frame. */
typedef struct sp_quat {
    double w, x, y, z;
} sp_quat;

SP_API sp_quat sp_quat_identity(void);
SP_API sp_quat sp_quat_mul(sp_quat a, sp_quat b);
SP_API sp_quat sp_quat_conj(sp_quat q);
/* Normalised copy; the identity for a zero or non-finite input. */
SP_API sp_quat sp_quat_normalize(sp_quat q);
/* Rotation by |v| radians about v; exact and finite for tiny and zero v. */
SP_API sp_quat sp_quat_from_rotvec(sp_vec3 v);
SP_API sp_vec3 sp_quat_to_rotvec(sp_quat q);
SP_API sp_quat sp_quat_from_axis_angle(sp_vec3 axis, double angle);
SP_API sp_vec3 sp_quat_rotate(sp_quat q, sp_vec3 v);
/* Shortest-path spherical interpolation, t in [0,1]; stable for nearly equal inputs. */
SP_API sp_quat sp_quat_slerp(sp_quat a, sp_quat b, double t);
/* Angle in radians of the rotation taking a to b, in [0, pi]. */
SP_API double sp_quat_angle_between(sp_quat a, sp_quat b);
/* Row-major 3x3 rotation matrix from a unit quaternion, and back. */
SP_API void sp_quat_to_matrix(sp_quat q, double m[9]);
/* The sRGB curve: linear light in [0, 1] to its encoded value, and back (NaN and negatives give 0). */
SP_API double sp_srgb_encode(double linear);
SP_API double sp_srgb_decode(double encoded);
/* Mean rotation of a set of quaternions: each is sign-flipped to the first one's hemisphere (q and -q are one
   rotation), summed, normalised. Good for rotations within a few tens of degrees of each other. */
typedef struct sp_quat_mean {
    sp_quat sum, first;
    int n;
} sp_quat_mean;
SP_API void sp_quat_mean_init(sp_quat_mean *m);
SP_API void sp_quat_mean_add(sp_quat_mean *m, sp_quat q);
/* The mean so far; the identity when nothing was added. */
SP_API sp_quat sp_quat_mean_get(const sp_quat_mean *m);
SP_API sp_quat sp_quat_from_matrix(const double m[9]);

SP_API sp_vec3 sp_vec3_add(sp_vec3 a, sp_vec3 b);
SP_API sp_vec3 sp_vec3_sub(sp_vec3 a, sp_vec3 b);
SP_API sp_vec3 sp_vec3_scale(sp_vec3 a, double s);
SP_API double sp_vec3_dot(sp_vec3 a, sp_vec3 b);
SP_API sp_vec3 sp_vec3_cross(sp_vec3 a, sp_vec3 b);
SP_API double sp_vec3_norm(sp_vec3 a);
/* Unit vector along a; the zero vector for a zero or non-finite input. */
SP_API sp_vec3 sp_vec3_normalize(sp_vec3 a);

#ifdef __cplusplus
}
#endif
#endif
