/* SPDX-License-Identifier: MIT */
#include "common/rigid.h"

sp_rigid sp_rigid_mul(const sp_rigid *a, const sp_rigid *b)
{
    sp_rigid r;
    sp_mat3_mul(a->R, b->R, r.R);
    sp_mat3_apply(a->R, b->t, r.t);
    for (int i = 0; i < 3; i++)
        r.t[i] += a->t[i];
    return r;
}

sp_rigid sp_rigid_inv(const sp_rigid *a)
{
    sp_rigid r;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            r.R[i * 3 + j] = a->R[j * 3 + i];
    for (int i = 0; i < 3; i++)
        r.t[i] = -(r.R[i * 3] * a->t[0] + r.R[i * 3 + 1] * a->t[1] + r.R[i * 3 + 2] * a->t[2]);
    return r;
}

void sp_mat3_mul(const double A[9], const double B[9], double C[9])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            C[i * 3 + j] = A[i * 3] * B[j] + A[i * 3 + 1] * B[3 + j] + A[i * 3 + 2] * B[6 + j];
}

void sp_mat3_apply(const double R[9], const double x[3], double y[3])
{
    for (int i = 0; i < 3; i++)
        y[i] = R[i * 3] * x[0] + R[i * 3 + 1] * x[1] + R[i * 3 + 2] * x[2];
}
