/* SPDX-License-Identifier: MIT */
/*
 * Face mask and specular clusters, defined relative to the 68 landmarks so the
 * same rules serve the ICT model and the generic head. Vertices are expressed
 * in a face frame (origin between the eyes, x to the subject's left, y up,
 * z forward, unit = outer eye-corner distance) and labelled by simple regions;
 * the labels are then rasterised into the UV cluster map.
 */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "face_internal.h"
#include "sunprobe/sp_math.h"

#define SCALP_ABOVE_BROWS 0.25 /* outer eye-corner distances */
#define SCALP_BELOW_NOSE 0.1   /* the ears' lobes reach about this far below the nose's base */

typedef struct face_frame {
    sp_vec3 origin, ex, ey, ez;
    double unit;
    double lx[SP_FACE_N_LANDMARKS], ly[SP_FACE_N_LANDMARKS], lz[SP_FACE_N_LANDMARKS];
} face_frame;

static sp_vec3 vertex_at(const sp_mesh *mesh, uint32_t i)
{
    const float *p = mesh->positions + (size_t)i * 3;
    return (sp_vec3){ (double)p[0], (double)p[1], (double)p[2] };
}

static sp_vec3 landmark_mean(const sp_face_model *m, int first, int last)
{
    sp_vec3 s = { 0, 0, 0 };
    for (int j = first; j <= last; j++)
        s = sp_vec3_add(s, vertex_at(&m->mesh, m->landmarks[j]));
    return sp_vec3_scale(s, 1.0 / (double)(last - first + 1));
}

static void to_frame(const face_frame *f, sp_vec3 p, double *x, double *y, double *z)
{
    sp_vec3 d = sp_vec3_scale(sp_vec3_sub(p, f->origin), 1.0 / f->unit);
    *x = sp_vec3_dot(d, f->ex);
    *y = sp_vec3_dot(d, f->ey);
    *z = sp_vec3_dot(d, f->ez);
}

static int build_frame(const sp_face_model *m, face_frame *f)
{
    sp_vec3 right_outer = vertex_at(&m->mesh, m->landmarks[36]);
    sp_vec3 left_outer = vertex_at(&m->mesh, m->landmarks[45]);
    sp_vec3 across = sp_vec3_sub(left_outer, right_outer);
    f->unit = sp_vec3_norm(across);
    f->origin = landmark_mean(m, 36, 47);
    f->ex = sp_vec3_normalize(across);
    sp_vec3 up = sp_vec3_sub(landmark_mean(m, 17, 26), vertex_at(&m->mesh, m->landmarks[8]));
    up = sp_vec3_sub(up, sp_vec3_scale(f->ex, sp_vec3_dot(up, f->ex)));
    f->ey = sp_vec3_normalize(up);
    f->ez = sp_vec3_cross(f->ex, f->ey);
    if (!(f->unit > 1e-9) || sp_vec3_norm(f->ey) < 0.5)
        return SP_ECORRUPT; /* landmarks collapsed onto a point or a line */
    for (int j = 0; j < SP_FACE_N_LANDMARKS; j++)
        to_frame(f, vertex_at(&m->mesh, m->landmarks[j]), &f->lx[j], &f->ly[j], &f->lz[j]);
    return 0;
}

/* Even-odd point-in-polygon test in the frame's (x, y). */
static int inside_polygon(const double *px, const double *py, int n, double x, double y)
{
    int in = 0;
    for (int i = 0, j = n - 1; i < n; j = i++) {
        if ((py[i] > y) != (py[j] > y)) {
            double xc = px[j] + (px[i] - px[j]) * (y - py[j]) / (py[i] - py[j]);
            if (x < xc)
                in = !in;
        }
    }
    return in;
}

static double segment_distance(double ax, double ay, double bx, double by, double x, double y)
{
    double dx = bx - ax, dy = by - ay, len2 = dx * dx + dy * dy;
    double t = len2 > 0 ? ((x - ax) * dx + (y - ay) * dy) / len2 : 0.0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return hypot(x - ax - t * dx, y - ay - t * dy);
}

/*
 * Inside test with a margin: > 0 grows the polygon by that distance, < 0 shrinks it, so
 * vertices on the landmark polygon itself (the landmarks) fall on a definite side.
 */
static int inside_margin(const double *px, const double *py, int n, double x, double y, double margin)
{
    double d = INFINITY;
    for (int i = 0, j = n - 1; i < n; j = i++)
        d = fmin(d, segment_distance(px[j], py[j], px[i], py[i], x, y));
    int in = inside_polygon(px, py, n, x, y);
    return margin >= 0 ? in || d < margin : in && d > -margin;
}

static int inside_landmarks(const face_frame *f, int first, int last, double x, double y)
{
    double px[20], py[20];
    int n = last - first + 1;
    for (int k = 0; k < n; k++) {
        px[k] = f->lx[first + k];
        py[k] = f->ly[first + k];
    }
    return inside_margin(px, py, n, x, y, -0.02); /* lid and lip landmarks stay skin */
}

static double mean_y(const face_frame *f, int first, int last)
{
    double s = 0;
    for (int j = first; j <= last; j++)
        s += f->ly[j];
    return s / (double)(last - first + 1);
}

static double mean_x(const face_frame *f, int first, int last)
{
    double s = 0;
    for (int j = first; j <= last; j++)
        s += f->lx[j];
    return s / (double)(last - first + 1);
}

/* Jawline 0..16 closed over the forehead, 0.6 units above the brows. */
static int inside_face_outline(const face_frame *f, double x, double y)
{
    double px[21], py[21], top = mean_y(f, 17, 26) + 0.6;
    for (int j = 0; j <= 16; j++) {
        px[j] = f->lx[j];
        py[j] = f->ly[j];
    }
    px[17] = f->lx[16];        py[17] = top - 0.15;
    px[18] = 0.5 * f->lx[16];  py[18] = top;
    px[19] = 0.5 * f->lx[0];   py[19] = top;
    px[20] = f->lx[0];         py[20] = top - 0.15;
    return inside_margin(px, py, 21, x, y, 0.02); /* the jaw landmarks are on the face */
}

static int in_front(const face_frame *f, double z)
{
    return z > (f->lz[0] < f->lz[16] ? f->lz[0] : f->lz[16]) - 0.1;
}

static int in_eye_region(const face_frame *f, int first, double x, double y)
{
    double cx = mean_x(f, first, first + 5), cy = mean_y(f, first, first + 5);
    double half = 0.5 * fabs(f->lx[first + 3] - f->lx[first]);
    double rx = 1.3 * half + 0.05, ry = 0.9 * half + 0.05;
    double dx = (x - cx) / rx, dy = (y - cy) / ry;
    return dx * dx + dy * dy < 1.0;
}

static int in_nose(const face_frame *f, double x, double y)
{
    double top = f->ly[27], bottom = f->ly[33] - 0.04;
    if (y > top || y < bottom || !(top > bottom))
        return 0;
    double t = (top - y) / (top - bottom);
    double half = 0.09 + t * (0.5 * fabs(f->lx[35] - f->lx[31]) + 0.04 - 0.09);
    return fabs(x - f->lx[30]) < half;
}

static int in_mouth(const face_frame *f, double x, double y)
{
    double top = f->ly[33] - 0.04, bottom = f->ly[57] - 0.06;
    double cx = 0.5 * (f->lx[48] + f->lx[54]), cy = 0.5 * (top + bottom);
    double rx = 0.5 * fabs(f->lx[54] - f->lx[48]) + 0.08, ry = 0.5 * (top - bottom);
    if (!(ry > 0))
        return 0;
    double dx = (x - cx) / rx, dy = (y - cy) / ry;
    return dx * dx + dy * dy < 1.0;
}

static uint8_t face_cluster(const face_frame *f, double x, double y)
{
    if (in_eye_region(f, 36, x, y))
        return SP_FACE_CLUSTER_RIGHT_EYE;
    if (in_eye_region(f, 42, x, y))
        return SP_FACE_CLUSTER_LEFT_EYE;
    if (in_nose(f, x, y))
        return SP_FACE_CLUSTER_NOSE;
    if (in_mouth(f, x, y))
        return SP_FACE_CLUSTER_LIPS;
    if (y < f->ly[57] - 0.06)
        return fabs(x) < 0.5 * fabs(f->lx[54] - f->lx[48]) + 0.12 ? SP_FACE_CLUSTER_CHIN : SP_FACE_CLUSTER_JAW_NECK;
    if (y > 0.5 * (mean_y(f, 17, 26) + mean_y(f, 36, 47))) /* brows belong to the forehead */
        return SP_FACE_CLUSTER_FOREHEAD;
    return x > 0 ? SP_FACE_CLUSTER_LEFT_CHEEK : SP_FACE_CLUSTER_RIGHT_CHEEK;
}

static void label_vertex(const face_frame *f, sp_vec3 p, uint8_t part, uint8_t *mask, uint8_t *cluster)
{
    double x, y, z;
    to_frame(f, p, &x, &y, &z);
    if (part == SP_FACE_PART_EYE) { /* not skin; its specular is the eye region's */
        *mask = 0;
        *cluster = x > 0 ? SP_FACE_CLUSTER_LEFT_EYE : SP_FACE_CLUSTER_RIGHT_EYE;
        return;
    }
    if (!in_front(f, z) || !inside_face_outline(f, x, y)) {
        *mask = 0;
        *cluster = y < mean_y(f, 48, 59) ? SP_FACE_CLUSTER_JAW_NECK : SP_FACE_CLUSTER_OTHER;
        return;
    }
    /* eyeballs and the mouth opening are not skin */
    *mask = !inside_landmarks(f, 36, 41, x, y) && !inside_landmarks(f, 42, 47, x, y) &&
            !inside_landmarks(f, 60, 67, x, y);
    *cluster = face_cluster(f, x, y);
}

/* ---- rasterisation into UV space ---- */

static void raster_triangle(sp_face_model *m, const double px[3], const double py[3], const uint8_t lab[3])
{
    int W = (int)m->cluster_width, H = (int)m->cluster_height;
    double area = (px[1] - px[0]) * (py[2] - py[0]) - (px[2] - px[0]) * (py[1] - py[0]);
    if (!(fabs(area) > 1e-12))
        return;
    double x0 = fmin(px[0], fmin(px[1], px[2])), x1 = fmax(px[0], fmax(px[1], px[2]));
    double y0 = fmin(py[0], fmin(py[1], py[2])), y1 = fmax(py[0], fmax(py[1], py[2]));
    int ix0 = (int)fmax(0.0, ceil(x0 - 0.5)), ix1 = (int)fmin((double)W - 1, floor(x1 - 0.5));
    int iy0 = (int)fmax(0.0, ceil(y0 - 0.5)), iy1 = (int)fmin((double)H - 1, floor(y1 - 0.5));
    for (int iy = iy0; iy <= iy1; iy++) {
        for (int ix = ix0; ix <= ix1; ix++) {
            double x = ix + 0.5, y = iy + 0.5, w[3];
            for (int k = 0; k < 3; k++) {
                int a = (k + 1) % 3, b = (k + 2) % 3;
                w[k] = ((px[b] - px[a]) * (y - py[a]) - (x - px[a]) * (py[b] - py[a])) / area;
            }
            if (w[0] < -1e-9 || w[1] < -1e-9 || w[2] < -1e-9)
                continue;
            int best = w[1] > w[0] ? (w[2] > w[1] ? 2 : 1) : (w[2] > w[0] ? 2 : 0);
            m->cluster_map[(size_t)iy * (size_t)W + (size_t)ix] = lab[best];
        }
    }
}

/* Grows labels into empty texels so bilinear lookups near chart edges find a cluster. */
static int dilate(sp_face_model *m, int passes)
{
    size_t W = m->cluster_width, H = m->cluster_height;
    uint8_t *tmp = malloc(W * H);
    if (!tmp)
        return -ENOMEM;
    static const int d[4][2] = { { 1, 0 }, { -1, 0 }, { 0, 1 }, { 0, -1 } };
    for (int p = 0; p < passes; p++) {
        memcpy(tmp, m->cluster_map, W * H);
        for (size_t y = 0; y < H; y++)
            for (size_t x = 0; x < W; x++) {
                if (tmp[y * W + x] != SP_FACE_CLUSTER_NONE)
                    continue;
                for (int k = 0; k < 4; k++) {
                    long nx = (long)x + d[k][0], ny = (long)y + d[k][1];
                    if (nx < 0 || ny < 0 || nx >= (long)W || ny >= (long)H)
                        continue;
                    uint8_t c = tmp[(size_t)ny * W + (size_t)nx];
                    if (c != SP_FACE_CLUSTER_NONE) {
                        m->cluster_map[y * W + x] = c;
                        break;
                    }
                }
            }
    }
    free(tmp);
    return 0;
}

static void rasterise(sp_face_model *m, const uint8_t *labels)
{
    const sp_mesh *mesh = &m->mesh;
    memset(m->cluster_map, SP_FACE_CLUSTER_NONE, (size_t)m->cluster_width * m->cluster_height);
    for (uint32_t t = 0; t < mesh->n_triangles; t++) {
        double px[3], py[3];
        uint8_t lab[3];
        for (int k = 0; k < 3; k++) {
            const float *uv = mesh->uvs + (size_t)mesh->tri_uvs[t * 3 + k] * 2;
            px[k] = (double)uv[0] * m->cluster_width;
            py[k] = (1.0 - (double)uv[1]) * m->cluster_height;
            lab[k] = labels[mesh->tri_vertices[t * 3 + k]];
        }
        raster_triangle(m, px, py, lab);
    }
}

int face_regions_compute(sp_face_model *model)
{
    int err = sp_mesh_validate(&model->mesh);
    if (err)
        return err;
    for (int j = 0; j < SP_FACE_N_LANDMARKS; j++)
        if (model->landmarks[j] >= model->mesh.n_vertices)
            return SP_ECORRUPT;
    face_frame f;
    err = build_frame(model, &f);
    if (err)
        return err;
    uint8_t *labels = malloc((size_t)model->mesh.n_vertices + 1);
    if (!labels)
        return -ENOMEM;
    for (uint32_t i = 0; i < model->mesh.n_vertices; i++)
        label_vertex(&f, vertex_at(&model->mesh, i), model->part[i], &model->face_mask[i], &labels[i]);
    rasterise(model, labels);
    free(labels);
    return dilate(model, 2);
}

int sp_face_model_scalp(const sp_face_model *model, uint8_t *scalp)
{
    if (!model || !scalp || !model->face_mask)
        return -EINVAL;
    face_frame f;
    int err = build_frame(model, &f);
    if (err)
        return err;
    /* the cranium a little above the brows, and its sides with the ears beyond the jaw's ends down to the
       nose's base (the ears' lobes); the neck below stays out */
    double above = mean_y(&f, 17, 26) + SCALP_ABOVE_BROWS, lobes = f.ly[33] - SCALP_BELOW_NOSE;
    double side = fmax(fabs(f.lx[0]), fabs(f.lx[16]));
    for (uint32_t i = 0; i < model->mesh.n_vertices; i++) {
        double x, y, z;
        to_frame(&f, vertex_at(&model->mesh, i), &x, &y, &z);
        scalp[i] = !model->face_mask[i] && model->part[i] == SP_FACE_PART_SKIN &&
                   (y > above || (fabs(x) > side && y > lobes));
    }
    return 0;
}
