/* SPDX-License-Identifier: MIT */
/*
 * Model evaluation v = s R(r) (mean + B_id a + B_exp e) + t, its adjoint for a
 * renderer's per-vertex gradients, and landmark projection with its Jacobian.
 * Everything is accumulated in double; the bases stay float in memory.
 */
#include "sunprobe/sp_face_model.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "face_internal.h"

/* ---- rotations ---- */

static void skew(const double v[3], double K[9])
{
    K[0] = 0;     K[1] = -v[2]; K[2] = v[1];
    K[3] = v[2];  K[4] = 0;     K[5] = -v[0];
    K[6] = -v[1]; K[7] = v[0];  K[8] = 0;
}

static void mat3_mul(const double A[9], const double B[9], double C[9])
{
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            C[i * 3 + j] = A[i * 3] * B[j] + A[i * 3 + 1] * B[3 + j] + A[i * 3 + 2] * B[6 + j];
}

/* R = I + A K + B K^2 with A = sin t / t, B = (1 - cos t) / t^2, and A'/t, B'/t for the derivatives. */
typedef struct rot_coefs {
    double theta, A, B, dA, dB;
} rot_coefs;

static rot_coefs rot_coefficients(const double r[3])
{
    rot_coefs c;
    double t = hypot(hypot(r[0], r[1]), r[2]);
    double t2 = t * t;
    c.theta = t;
    c.A = t > 0 ? sin(t) / t : 1.0;
    double h = t > 0 ? sin(0.5 * t) / t : 0.5; /* 1 - cos t = 2 sin^2(t/2): no cancellation */
    c.B = 2.0 * h * h;
    if (t < 1e-2) { /* the closed forms below cancel badly near zero: series to t^4 */
        c.dA = -1.0 / 3.0 + t2 / 30.0 - t2 * t2 / 840.0;
        c.dB = -1.0 / 12.0 + t2 / 180.0 - t2 * t2 / 6720.0;
    } else {
        c.dA = (t * cos(t) - sin(t)) / (t2 * t);
        c.dB = (t * sin(t) - 2.0 * (1.0 - cos(t))) / (t2 * t2);
    }
    return c;
}

void face_rotvec_to_matrix(const double r[3], double R[9])
{
    rot_coefs c = rot_coefficients(r);
    double K[9], K2[9];
    skew(r, K);
    mat3_mul(K, K, K2);
    for (int i = 0; i < 9; i++)
        R[i] = (i % 4 == 0 ? 1.0 : 0.0) + c.A * K[i] + c.B * K2[i];
}

void face_rotvec_derivatives(const double r[3], double dR[3][9])
{
    rot_coefs c = rot_coefficients(r);
    double K[9], K2[9];
    skew(r, K);
    mat3_mul(K, K, K2);
    for (int k = 0; k < 3; k++) {
        double e[3] = { 0, 0, 0 }, Ek[9], EK[9], KE[9];
        e[k] = 1.0;
        skew(e, Ek);
        mat3_mul(Ek, K, EK);
        mat3_mul(K, Ek, KE);
        for (int i = 0; i < 9; i++)
            dR[k][i] = c.A * Ek[i] + c.B * (EK[i] + KE[i]) + c.dA * r[k] * K[i] + c.dB * r[k] * K2[i];
    }
}

/* ---- evaluation ---- */

static int finite_in_limit(double x)
{
    return isfinite(x) && fabs(x) <= SP_FACE_PARAM_LIMIT;
}

static int check_params(const sp_face_model *m, const sp_face_params *p)
{
    if (!m || !p || !m->mesh.positions || (m->n_id && !m->id_basis) || (m->n_exp && !m->exp_basis))
        return -EINVAL;
    for (int i = 0; i < 3; i++)
        if (!finite_in_limit(p->rotvec[i]) || !finite_in_limit(p->t[i]))
            return -EINVAL;
    if (!finite_in_limit(p->s))
        return -EINVAL;
    for (uint32_t k = 0; p->id && k < m->n_id; k++)
        if (!finite_in_limit(p->id[k]))
            return -EINVAL;
    for (uint32_t k = 0; p->exp && k < m->n_exp; k++)
        if (!finite_in_limit(p->exp[k]))
            return -EINVAL;
    return 0;
}

/* q = mean + B_id a + B_exp e at vertex i, in the model frame. */
static void shape_vertex(const sp_face_model *m, const sp_face_params *p, uint32_t i, double q[3])
{
    size_t n3 = (size_t)m->mesh.n_vertices * 3, o = (size_t)i * 3;
    for (int c = 0; c < 3; c++)
        q[c] = (double)m->mesh.positions[o + c];
    for (uint32_t k = 0; p->id && k < m->n_id; k++) {
        const float *b = m->id_basis + k * n3 + o;
        for (int c = 0; c < 3; c++)
            q[c] += p->id[k] * (double)b[c];
    }
    for (uint32_t k = 0; p->exp && k < m->n_exp; k++) {
        const float *b = m->exp_basis + k * n3 + o;
        for (int c = 0; c < 3; c++)
            q[c] += p->exp[k] * (double)b[c];
    }
}

static void transform(const double R[9], const sp_face_params *p, const double q[3], double v[3])
{
    for (int r = 0; r < 3; r++)
        v[r] = p->s * (R[r * 3] * q[0] + R[r * 3 + 1] * q[1] + R[r * 3 + 2] * q[2]) + p->t[r];
}

void sp_face_params_init(sp_face_params *params)
{
    if (!params)
        return;
    memset(params, 0, sizeof(*params));
    params->s = 1.0;
}

int sp_face_model_eval(const sp_face_model *model, const sp_face_params *params, double *out)
{
    int err = check_params(model, params);
    if (err || !out)
        return err ? err : -EINVAL;
    double R[9];
    face_rotvec_to_matrix(params->rotvec, R);
    for (uint32_t i = 0; i < model->mesh.n_vertices; i++) {
        double q[3];
        shape_vertex(model, params, i, q);
        transform(R, params, q, out + (size_t)i * 3);
    }
    return 0;
}

int sp_face_model_eval_float(const sp_face_model *model, const sp_face_params *params, float *out)
{
    int err = check_params(model, params);
    if (err || !out)
        return err ? err : -EINVAL;
    double R[9];
    face_rotvec_to_matrix(params->rotvec, R);
    for (uint32_t i = 0; i < model->mesh.n_vertices; i++) {
        double q[3], v[3];
        shape_vertex(model, params, i, q);
        transform(R, params, q, v);
        for (int c = 0; c < 3; c++)
            out[(size_t)i * 3 + c] = (float)v[c];
    }
    return 0;
}

/* ---- adjoint ---- */

static void clear_grad(const sp_face_model *m, sp_face_grad *g)
{
    if (g->id)
        memset(g->id, 0, sizeof(double) * m->n_id);
    if (g->exp)
        memset(g->exp, 0, sizeof(double) * m->n_exp);
    memset(g->rotvec, 0, sizeof(g->rotvec));
    memset(g->t, 0, sizeof(g->t));
    g->s = 0.0;
}

/* grad[k] += B_k(i) . h for every mode of one basis. */
static void accumulate_modes(const float *basis, uint32_t n_modes, uint32_t n_vertices, uint32_t i,
                             const double h[3], double *grad)
{
    size_t n3 = (size_t)n_vertices * 3, o = (size_t)i * 3;
    for (uint32_t k = 0; grad && k < n_modes; k++) {
        const float *b = basis + k * n3 + o;
        grad[k] += (double)b[0] * h[0] + (double)b[1] * h[1] + (double)b[2] * h[2];
    }
}

int sp_face_model_eval_adjoint(const sp_face_model *model, const sp_face_params *params,
                               const double *dl_dv, sp_face_grad *grad)
{
    int err = check_params(model, params);
    if (err || !dl_dv || !grad)
        return err ? err : -EINVAL;
    clear_grad(model, grad);
    double R[9], M[9] = { 0 };
    face_rotvec_to_matrix(params->rotvec, R);
    for (uint32_t i = 0; i < model->mesh.n_vertices; i++) {
        double g[3], q[3], h[3];
        for (int c = 0; c < 3; c++)
            g[c] = dl_dv[(size_t)i * 3 + c];
        shape_vertex(model, params, i, q);
        for (int a = 0; a < 3; a++) {
            grad->t[a] += g[a];
            for (int b = 0; b < 3; b++)
                M[a * 3 + b] += g[a] * q[b];
            /* h = s R^T g: the gradient with respect to the model-frame shape */
            h[a] = params->s * (R[a] * g[0] + R[3 + a] * g[1] + R[6 + a] * g[2]);
        }
        accumulate_modes(model->id_basis, model->n_id, model->mesh.n_vertices, i, h, grad->id);
        accumulate_modes(model->exp_basis, model->n_exp, model->mesh.n_vertices, i, h, grad->exp);
    }
    double dR[3][9];
    face_rotvec_derivatives(params->rotvec, dR);
    for (int j = 0; j < 9; j++) {
        grad->s += R[j] * M[j];
        for (int k = 0; k < 3; k++)
            grad->rotvec[k] += params->s * dR[k][j] * M[j];
    }
    return 0;
}

/* ---- landmarks ---- */

uint32_t sp_face_model_n_params(const sp_face_model *model)
{
    return model ? model->n_id + model->n_exp + 7 : 0;
}

static void mat3_vec(const double A[9], const double x[3], double y[3])
{
    for (int r = 0; r < 3; r++)
        y[r] = A[r * 3] * x[0] + A[r * 3 + 1] * x[1] + A[r * 3 + 2] * x[2];
}

/* Fills one parameter column: d(u,v)/dθ = J_proj * dp/dθ. */
static void put_column(double *row_u, double *row_v, uint32_t col, const double ju[3], const double jv[3],
                       const double dp[3])
{
    row_u[col] = ju[0] * dp[0] + ju[1] * dp[1] + ju[2] * dp[2];
    row_v[col] = jv[0] * dp[0] + jv[1] * dp[1] + jv[2] * dp[2];
}

static void basis_columns(const float *basis, uint32_t n_modes, uint32_t n_vertices, uint32_t vi, double s,
                          const double R[9], uint32_t col0, double *row_u, double *row_v, const double ju[3],
                          const double jv[3])
{
    for (uint32_t k = 0; k < n_modes; k++) {
        const float *b = basis + ((size_t)k * n_vertices + vi) * 3;
        double bk[3] = { (double)b[0], (double)b[1], (double)b[2] }, dp[3];
        mat3_vec(R, bk, dp);
        for (int c = 0; c < 3; c++)
            dp[c] *= s;
        put_column(row_u, row_v, col0 + k, ju, jv, dp);
    }
}

static void landmark_jacobian(const sp_face_model *m, const sp_face_params *p, const double R[9],
                              const double dR[3][9], uint32_t vi, const double q[3], const double ju[3],
                              const double jv[3], double *row_u, double *row_v)
{
    uint32_t n_id = m->n_id, n_exp = m->n_exp, col = n_id + n_exp;
    basis_columns(m->id_basis, n_id, m->mesh.n_vertices, vi, p->s, R, 0, row_u, row_v, ju, jv);
    basis_columns(m->exp_basis, n_exp, m->mesh.n_vertices, vi, p->s, R, n_id, row_u, row_v, ju, jv);
    for (int k = 0; k < 3; k++) {
        double dp[3];
        mat3_vec(dR[k], q, dp);
        for (int c = 0; c < 3; c++)
            dp[c] *= p->s;
        put_column(row_u, row_v, col + (uint32_t)k, ju, jv, dp);
    }
    for (int k = 0; k < 3; k++) {
        double dp[3] = { 0, 0, 0 };
        dp[k] = 1.0;
        put_column(row_u, row_v, col + 3 + (uint32_t)k, ju, jv, dp);
    }
    double rq[3];
    mat3_vec(R, q, rq);
    put_column(row_u, row_v, col + 6, ju, jv, rq);
}

void sp_face_camera_init(sp_face_camera *camera, double fx, double fy, double cx, double cy)
{
    if (!camera)
        return;
    memset(camera, 0, sizeof(*camera));
    camera->fx = fx;
    camera->fy = fy;
    camera->cx = cx;
    camera->cy = cy;
    camera->R[0] = camera->R[4] = camera->R[8] = 1.0;
}

static int camera_ok(const sp_face_camera *c)
{
    if (!c || !isfinite(c->fx) || !isfinite(c->fy) || !isfinite(c->cx) || !isfinite(c->cy))
        return 0;
    for (int i = 0; i < 9; i++)
        if (!isfinite(c->R[i]))
            return 0;
    return isfinite(c->t[0]) && isfinite(c->t[1]) && isfinite(c->t[2]);
}

/* Projects one world point; fills the projection's gradient rows in world coordinates. */
static int project_point(const sp_face_camera *c, const double w[3], double uv[2], double ju[3], double jv[3])
{
    double p[3];
    mat3_vec(c->R, w, p);
    for (int k = 0; k < 3; k++)
        p[k] += c->t[k];
    if (!(p[2] >= 1e-6)) {
        uv[0] = c->cx;
        uv[1] = c->cy;
        return 0;
    }
    double iz = 1.0 / p[2];
    uv[0] = c->fx * p[0] * iz + c->cx;
    uv[1] = c->fy * p[1] * iz + c->cy;
    double gu[3] = { c->fx * iz, 0, -c->fx * p[0] * iz * iz };
    double gv[3] = { 0, c->fy * iz, -c->fy * p[1] * iz * iz };
    for (int k = 0; k < 3; k++) { /* chain through x_cam = R x_world + t */
        ju[k] = gu[0] * c->R[k] + gu[1] * c->R[3 + k] + gu[2] * c->R[6 + k];
        jv[k] = gv[0] * c->R[k] + gv[1] * c->R[3 + k] + gv[2] * c->R[6 + k];
    }
    return 1;
}

int sp_face_model_project_landmarks(const sp_face_model *model, const sp_face_params *params,
                                    const sp_face_camera *camera, double *uv, uint8_t *valid, double *jac)
{
    int err = check_params(model, params);
    if (err)
        return err;
    if (!camera_ok(camera) || !uv)
        return -EINVAL;
    for (int j = 0; j < SP_FACE_N_LANDMARKS; j++)
        if (model->landmarks[j] >= model->mesh.n_vertices)
            return SP_ECORRUPT;
    uint32_t np = sp_face_model_n_params(model);
    double R[9], dR[3][9];
    face_rotvec_to_matrix(params->rotvec, R);
    face_rotvec_derivatives(params->rotvec, dR);
    if (jac)
        memset(jac, 0, sizeof(double) * np * 2 * SP_FACE_N_LANDMARKS);
    int n_valid = 0;
    for (int j = 0; j < SP_FACE_N_LANDMARKS; j++) {
        double q[3], v[3], ju[3], jv[3];
        shape_vertex(model, params, model->landmarks[j], q);
        transform(R, params, q, v);
        int ok = project_point(camera, v, uv + 2 * j, ju, jv);
        if (valid)
            valid[j] = (uint8_t)ok;
        n_valid += ok;
        if (ok && jac)
            landmark_jacobian(model, params, R, dR, model->landmarks[j], q, ju, jv, jac + (size_t)(2 * j) * np,
                              jac + (size_t)(2 * j + 1) * np);
    }
    return n_valid;
}
