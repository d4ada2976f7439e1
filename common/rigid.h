/* SPDX-License-Identifier: MIT */
/* Rigid transforms x' = R x + t (R row-major) for the tools that place cameras and faces. Internal. */
#ifndef SUNPROBE_COMMON_RIGID_H
#define SUNPROBE_COMMON_RIGID_H

#include "common/private_api.h"

typedef struct sp_rigid {
    double R[9];
    double t[3];
} sp_rigid;

/* a after b: x -> a(b(x)). */
SP_PRIVATE sp_rigid sp_rigid_mul(const sp_rigid *a, const sp_rigid *b);
SP_PRIVATE sp_rigid sp_rigid_inv(const sp_rigid *a);
/* C = A B (3x3, row-major; C may not alias A or B). */
SP_PRIVATE void sp_mat3_mul(const double A[9], const double B[9], double C[9]);
/* y = R x (the rotation only). */
SP_PRIVATE void sp_mat3_apply(const double R[9], const double x[3], double y[3]);

#endif
