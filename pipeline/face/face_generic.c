/* SPDX-License-Identifier: MIT */
/*
 * The built-in generic head: a star-shaped surface around the head centre
 * (ellipsoid skull smoothly joined to a neck cylinder) with the face carved by
 * Gaussian bumps (brow, eye sockets, nose, cheekbones, lips, chin, jaw). The
 * grid is denser at the face; UVs are the grid parameters, a cylindrical
 * projection with its seam at the back of the head. Identity and expression
 * modes are smooth displacement fields; landmarks are the vertices nearest to
 * procedurally placed points. Coarser than ICT, but needs no data.
 */
#include "sunprobe/sp_face_model.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "face_internal.h"

#define NS 80          /* vertices around */
#define NR 64          /* rings below the crown pole */
#define PHI_END 2.86   /* polar angle of the neck's bottom ring (radians) */
#define KAPPA_U 0.5    /* face-ward crowding of columns */
#define KAPPA_W 0.6    /* face-ward crowding of rings */
#define N_ID 6
#define N_EXP 3

static const double PI = 3.14159265358979323846;

static double gauss2(double x, double y, double cx, double cy, double sx, double sy)
{
    double a = (x - cx) / sx, b = (y - cy) / sy;
    return exp(-0.5 * (a * a + b * b));
}

static double smoothstep(double e0, double e1, double x)
{
    double t = (x - e0) / (e1 - e0);
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return t * t * (3 - 2 * t);
}

/* Smooth maximum: never below max(a, b), k-wide blend. */
static double smax(double a, double b, double k)
{
    return fmax(a, b) + k * log1p(exp(-fabs(a - b) / k));
}

static double radius_ellipsoid(const double d[3])
{
    double x = d[0] / 0.075, y = d[1] / 0.115, z = d[2] / 0.095;
    return 1.0 / sqrt(x * x + y * y + z * z);
}

/* Distance along d to a vertical elliptic neck cylinder between y = -0.26 and y = 0.03. */
static double radius_neck(const double d[3])
{
    const double rx = 0.055, rz = 0.06, zc = -0.015, y_bot = -0.26, y_top = 0.03;
    double A = (d[0] / rx) * (d[0] / rx) + (d[2] / rz) * (d[2] / rz);
    double B = -2.0 * d[2] * zc / (rz * rz), C = (zc / rz) * (zc / rz) - 1.0;
    double r = A > 1e-12 ? (-B + sqrt(B * B - 4 * A * C)) / (2 * A) : 1e9;
    if (d[1] < -1e-12)
        r = fmin(r, y_bot / d[1]);
    else if (d[1] > 1e-12)
        r = fmin(r, y_top / d[1]);
    return r;
}

static double nose_offset(double x, double y)
{
    double s = y >= -0.028 ? fmin(1.0, fmax(0.0, (0.032 - y) / 0.06)) : exp(-0.5 * ((y + 0.028) / 0.007) * ((y + 0.028) / 0.007));
    double sx = 0.007 + 0.008 * s;
    return 0.026 * s * exp(-0.5 * (x / sx) * (x / sx)) + 0.008 * (gauss2(x, y, -0.016, -0.029, 0.007, 0.007) +
                                                                gauss2(x, y, 0.016, -0.029, 0.007, 0.007));
}

/* Radial face relief at frontal coordinates (x, y) of the base surface, nose excluded. */
static double relief(double x, double y)
{
    double r = 0.006 * gauss2(x, y, 0, 0.03, 0.045, 0.01);
    for (int side = -1; side <= 1; side += 2) {
        r -= 0.012 * gauss2(x, y, side * 0.032, 0.002, 0.014, 0.010);  /* eye socket */
        r += 0.006 * gauss2(x, y, side * 0.032, 0.0, 0.008, 0.006);    /* eyeball */
        r += 0.006 * gauss2(x, y, side * 0.045, -0.015, 0.018, 0.015); /* cheekbone */
    }
    r += 0.008 * gauss2(x, y, 0, -0.063, 0.022, 0.006);   /* upper lip */
    r += 0.007 * gauss2(x, y, 0, -0.075, 0.020, 0.006);   /* lower lip */
    r -= 0.004 * gauss2(x, y, 0, -0.069, 0.024, 0.002);   /* mouth line */
    r += 0.008 * gauss2(x, y, 0, -0.100, 0.018, 0.012);   /* chin */
    r += 0.030 * gauss2(x, y, 0, -0.082, 0.050, 0.035);   /* jaw mass */
    return r;
}

/* Per-vertex quantities the modes are built from. */
typedef struct gen_vertex {
    double d[3];    /* radial direction */
    double p[3];    /* final position */
    double fx, fy;  /* frontal coordinates of the base surface */
    double front;   /* 0..1 weight of the face relief */
    double nose;    /* radial nose offset applied */
} gen_vertex;

static void direction(double u, double w, double d[3])
{
    double theta = PI * u - KAPPA_U * sin(PI * u); /* u in [-1, 1): theta 0 = front */
    double wc = 0.62 - 0.5;
    double phi = PHI_END * (w + KAPPA_W / (2 * PI) * (sin(2 * PI * (w - wc)) + sin(2 * PI * wc)));
    d[0] = sin(phi) * sin(theta);
    d[1] = cos(phi);
    d[2] = sin(phi) * cos(theta);
}

static void make_vertex(double u, double w, gen_vertex *v)
{
    direction(u, w, v->d);
    double r0 = smax(radius_ellipsoid(v->d), radius_neck(v->d), 0.01);
    v->fx = r0 * v->d[0];
    v->fy = r0 * v->d[1];
    v->front = smoothstep(0.2, 0.5, v->d[2]);
    v->nose = v->front * nose_offset(v->fx, v->fy);
    double r = r0 + v->front * relief(v->fx, v->fy) + v->nose;
    for (int c = 0; c < 3; c++)
        v->p[c] = r * v->d[c];
}

static double grid_u(int j) { return -1.0 + 2.0 * j / NS; }

static void build_mesh(sp_face_model *m, gen_vertex *gv)
{
    sp_mesh *mesh = &m->mesh;
    make_vertex(0, 0, &gv[0]); /* crown pole */
    for (int r = 1; r <= NR; r++)
        for (int j = 0; j < NS; j++)
            make_vertex(grid_u(j), (double)r / NR, &gv[1 + (r - 1) * NS + j]);
    for (uint32_t i = 0; i < mesh->n_vertices; i++)
        for (int c = 0; c < 3; c++)
            mesh->positions[i * 3 + c] = (float)gv[i].p[c];
    /* UVs: NS pole copies, then NS + 1 per ring (the seam column is duplicated) */
    for (int j = 0; j < NS; j++) {
        mesh->uvs[j * 2] = (float)((j + 0.5) / NS);
        mesh->uvs[j * 2 + 1] = 1.0f;
    }
    for (int r = 1; r <= NR; r++)
        for (int j = 0; j <= NS; j++) {
            size_t k = (size_t)NS + (size_t)(r - 1) * (NS + 1) + (size_t)j;
            mesh->uvs[k * 2] = (float)((double)j / NS);
            mesh->uvs[k * 2 + 1] = (float)(1.0 - (double)r / NR);
        }
}

static void put_tri(sp_mesh *mesh, uint32_t *t, const uint32_t v[3], const uint32_t uv[3])
{
    for (int k = 0; k < 3; k++) {
        mesh->tri_vertices[*t * 3 + k] = v[k];
        mesh->tri_uvs[*t * 3 + k] = uv[k];
    }
    (*t)++;
}

static void build_triangles(sp_mesh *mesh)
{
    uint32_t t = 0;
#define VID(r, j) ((uint32_t)(1 + ((r) - 1) * NS + ((j) % NS)))
#define UVID(r, j) ((uint32_t)(NS + ((r) - 1) * (NS + 1) + (j)))
    for (int j = 0; j < NS; j++) {
        uint32_t v[3] = { 0, VID(1, j), VID(1, j + 1) }, uv[3] = { (uint32_t)j, UVID(1, j), UVID(1, j + 1) };
        put_tri(mesh, &t, v, uv);
    }
    for (int r = 1; r < NR; r++)
        for (int j = 0; j < NS; j++) {
            uint32_t a = VID(r, j), b = VID(r, j + 1), c = VID(r + 1, j), d = VID(r + 1, j + 1);
            uint32_t ua = UVID(r, j), ub = UVID(r, j + 1), uc = UVID(r + 1, j), ud = UVID(r + 1, j + 1);
            put_tri(mesh, &t, (uint32_t[3]){ a, c, d }, (uint32_t[3]){ ua, uc, ud });
            put_tri(mesh, &t, (uint32_t[3]){ a, d, b }, (uint32_t[3]){ ua, ud, ub });
        }
#undef VID
#undef UVID
}

/* ---- landmarks ---- */

/* Landmark positions in the frontal coordinates of the base surface, where the relief is defined. */
static void landmark_targets(double x[68], double y[68])
{
    for (int k = 0; k <= 16; k++) { /* jaw: subject's right ear level, round the chin, to the left */
        double a = PI * k / 16.0;
        x[k] = -0.068 * cos(a);
        y[k] = 0.0 - 0.105 * pow(sin(a), 0.8);
    }
    for (int i = 0; i < 5; i++) { /* brows: right outer->inner, left inner->outer */
        x[17 + i] = -0.055 + 0.0105 * i;
        y[17 + i] = 0.020 + 0.008 * sin(PI * (i + 1) / 6.0);
        x[26 - i] = -x[17 + i];
        y[26 - i] = y[17 + i];
    }
    static const double bridge_y[4] = { 0.012, -0.002, -0.015, -0.028 };
    static const double nostril[5][2] = { { -0.016, -0.033 }, { -0.008, -0.036 }, { 0, -0.038 },
                                          { 0.008, -0.036 }, { 0.016, -0.033 } };
    for (int i = 0; i < 4; i++) {
        x[27 + i] = 0;
        y[27 + i] = bridge_y[i];
    }
    for (int i = 0; i < 5; i++) {
        x[31 + i] = nostril[i][0];
        y[31 + i] = nostril[i][1];
    }
    static const double eye[6][2] = { { -0.046, 0.002 }, { -0.037, 0.006 }, { -0.027, 0.006 },
                                      { -0.018, 0.002 }, { -0.027, -0.002 }, { -0.037, -0.002 } };
    static const int mirror[6] = { 3, 2, 1, 0, 5, 4 }; /* left eye starts at its inner corner */
    for (int i = 0; i < 6; i++) {
        x[36 + i] = eye[i][0];
        y[36 + i] = eye[i][1];
        x[42 + i] = -eye[mirror[i]][0];
        y[42 + i] = eye[mirror[i]][1];
    }
    static const double lips[20][2] = {
        { -0.025, -0.069 }, { -0.016, -0.064 }, { -0.006, -0.061 }, { 0, -0.062 }, { 0.006, -0.061 },
        { 0.016, -0.064 },  { 0.025, -0.069 },  { 0.016, -0.075 },  { 0.008, -0.078 }, { 0, -0.079 },
        { -0.008, -0.078 }, { -0.016, -0.075 }, { -0.021, -0.069 }, { -0.008, -0.067 }, { 0, -0.067 },
        { 0.008, -0.067 },  { 0.021, -0.069 },  { 0.008, -0.071 },  { 0, -0.071 },  { -0.008, -0.071 },
    };
    for (int i = 0; i < 20; i++) {
        x[48 + i] = lips[i][0];
        y[48 + i] = lips[i][1];
    }
}

/* Nearest front-facing vertex in frontal base coordinates, never one already taken. */
static int pick_landmarks(sp_face_model *m, const gen_vertex *gv)
{
    double tx[68], ty[68];
    landmark_targets(tx, ty);
    for (int j = 0; j < SP_FACE_N_LANDMARKS; j++) {
        double best = INFINITY;
        for (uint32_t i = 0; i < m->mesh.n_vertices; i++) {
            int taken = 0;
            for (int k = 0; k < j && !taken; k++)
                taken = m->landmarks[k] == i;
            double dx = gv[i].fx - tx[j], dy = gv[i].fy - ty[j], e = dx * dx + dy * dy;
            if (gv[i].d[2] > 0.1 && !taken && e < best) {
                best = e;
                m->landmarks[j] = i;
            }
        }
        if (isinf(best))
            return SP_ECORRUPT;
    }
    return 0;
}

/* ---- modes (one-sigma identity displacements, unit-strength expressions) ---- */

static void identity_field(int k, const gen_vertex *v, double o[3])
{
    const double *p = v->p;
    double low = smoothstep(-0.02, -0.08, p[1]) * smoothstep(0.0, 0.04, p[2]);
    o[0] = o[1] = o[2] = 0;
    switch (k) {
    case 0: o[0] = 0.05 * p[0]; break;                                        /* width */
    case 1: o[1] = 0.05 * p[1]; break;                                        /* height */
    case 2: o[2] = 0.05 * p[2] * smoothstep(-0.02, 0.03, p[2]); break;        /* face depth */
    case 3: for (int c = 0; c < 3; c++) o[c] = 0.35 * v->nose * v->d[c]; break; /* nose size */
    case 4: o[0] = 0.08 * p[0] * low; break;                                  /* jaw width */
    default: o[1] = -0.008 * v->front * gauss2(v->fx, v->fy, 0, -0.095, 0.05, 0.03); break; /* chin length */
    }
}

static void expression_field(int k, const gen_vertex *v, double o[3])
{
    const double *p = v->p;
    o[0] = o[1] = o[2] = 0;
    if (k == 0) { /* jawOpen: 0.25 rad about the x axis through the jaw hinge, below the mouth line */
        double w = smoothstep(-0.060, -0.070, v->fy) * (1.0 - smoothstep(-0.11, -0.15, p[1])) *
                   smoothstep(-0.03, 0.02, p[2]) * (1.0 - smoothstep(0.06, 0.08, fabs(p[0])));
        double yr = p[1] + 0.01, zr = p[2] + 0.01;
        o[1] = -0.25 * zr * w;
        o[2] = 0.25 * yr * w;
    } else if (k == 1) { /* smile: mouth corners up and out, cheeks up */
        for (int side = -1; side <= 1; side += 2) {
            double g = v->front * gauss2(v->fx, v->fy, side * 0.025, -0.065, 0.012, 0.012);
            double c = v->front * gauss2(v->fx, v->fy, side * 0.035, -0.035, 0.015, 0.015);
            o[0] += 0.004 * side * g;
            o[1] += 0.005 * g + 0.003 * c;
            o[2] += -0.002 * g + 0.002 * c;
        }
    } else { /* browRaise */
        o[1] = 0.006 * v->front * gauss2(v->fx, v->fy, 0, 0.025, 0.05, 0.012);
    }
}

static void build_modes(sp_face_model *m, const gen_vertex *gv)
{
    size_t n = m->mesh.n_vertices;
    for (int k = 0; k < N_ID; k++)
        for (size_t i = 0; i < n; i++) {
            double o[3];
            identity_field(k, &gv[i], o);
            for (int c = 0; c < 3; c++)
                m->id_basis[((size_t)k * n + i) * 3 + c] = (float)o[c];
        }
    for (int k = 0; k < N_EXP; k++)
        for (size_t i = 0; i < n; i++) {
            double o[3];
            expression_field(k, &gv[i], o);
            for (int c = 0; c < 3; c++)
                m->exp_basis[((size_t)k * n + i) * 3 + c] = (float)o[c];
        }
    face_set_exp_name(m, 0, "jawOpen");
    face_set_exp_name(m, 1, "mouthSmile");
    face_set_exp_name(m, 2, "browRaise");
}

int sp_face_model_generic(sp_face_model *model)
{
    if (!model)
        return -EINVAL;
    uint32_t nv = 1 + NR * NS, nuv = NS + NR * (NS + 1), nt = NS + (NR - 1) * NS * 2;
    int err = sp_face_model_alloc(model, nv, nuv, nt, N_ID, N_EXP, 256, 256);
    if (err)
        return err;
    gen_vertex *gv = calloc(nv, sizeof(*gv));
    if (!gv) {
        sp_face_model_free(model);
        return -ENOMEM;
    }
    build_mesh(model, gv);
    build_triangles(&model->mesh);
    err = pick_landmarks(model, gv);
    build_modes(model, gv);
    free(gv);
    snprintf(model->source, sizeof(model->source), "generic-head v1");
    if (!err)
        err = face_regions_compute(model);
    if (!err)
        err = sp_face_model_validate(model);
    if (err)
        sp_face_model_free(model);
    return err;
}
