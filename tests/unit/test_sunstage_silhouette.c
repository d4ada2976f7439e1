/* SPDX-License-Identifier: MIT */
/*
 * SunStage silhouette loss: the signed distance to a skin-mask boundary (a
 * skin-coloured disk on a sky-blue background, on a grey ground as a
 * path-traced capture's horizon has it, and joined by a thin band to a
 * skin-coloured wall), the choice of outline vertices on the
 * generic head (face, and face with the scalp), the one-sided residuals,
 * residuals against the face model's own evaluation, and the analytic Jacobian
 * against central finite differences for every face parameter (identity,
 * expression, rotation, translation, scale), on both sides of the edge.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "pipeline/sunstage/sunstage_internal.h"
#include "sunprobe/sp_face_model.h"

#define W 96
#define H 80
#define FX 110.0

/*
 * Landmarks on a skin disk of radius rad at (cx, cy): jaw (0..16) along the lower half of a smaller circle, brows
 * (17..26) along its upper half, the rest (nose tip 30 included) at the centre; with eyes, the outer eye corners
 * (36, 45) 0.7 radii apart.
 */
static void disk_landmarks(double cx, double cy, double rad, int eyes, double lm[136])
{
    for (int k = 0; k < 68; k++) {
        double a = k <= 16 ? M_PI + M_PI * k / 16.0 : M_PI - M_PI * (k - 17) / 9.0;
        int on = k <= 26, corner = eyes && (k == 36 || k == 45);
        lm[2 * k] = on ? cx + 0.7 * rad * cos(a) : corner ? cx + (k == 36 ? -0.35 : 0.35) * rad : cx;
        lm[2 * k + 1] = on ? cy - 0.7 * rad * sin(a) : corner ? cy - 0.2 * rad : cy;
    }
}

/*
 * A skin-coloured block at the image's left edge (a sunlit wall), joined to the face by a band four pixels
 * high (a warm horizon): the mask leaks, and the outline is kept without what only the band joins.
 */
static void check_thin_join(float *rgb, float *dist, double cx, double cy, double rad)
{
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int skin = hypot(x - cx, y - cy) <= rad || x < 12 || (y >= 38 && y < 42);
            float *p = rgb + ((size_t)y * W + (size_t)x) * 3;
            p[0] = skin ? 0.62f : 0.35f;
            p[1] = skin ? 0.43f : 0.55f;
            p[2] = skin ? 0.35f : 0.85f;
        }
    double lm[136];
    disk_landmarks(cx, cy, rad, 1, lm); /* the cut's radius is in eye widths */
    int nb = ss_silhouette_target(rgb, W, H, lm, dist);
    CHECK_MSG(nb > 100, "boundary pixels with a band to a skin-coloured wall %d", nb);
    if (nb > 0) {
        CHECK_NEAR(dist[40 * W + 48], -(rad - 0.5), 1.5); /* the disk as without the wall */
        CHECK_NEAR(dist[20 * W + 48], -5.5, 1.5);
        CHECK_MSG(dist[60 * W + 5] > 20.0f, "the wall: %g", (double)dist[60 * W + 5]);
        CHECK_MSG(dist[39 * W + 14] > 5.0f, "the band: %g", (double)dist[39 * W + 14]);
        CHECK(dist[39 * W + 30] < 0.0f); /* inside the disk on the band's rows */
    }
    /* a band 12 px high, over twice what the cut opens (2 x 0.15 eye widths = 5.25 px here), stays joined */
    for (int y = 34; y < 46; y++)
        for (int x = 0; x < W; x++) {
            float *p = rgb + ((size_t)y * W + (size_t)x) * 3;
            p[0] = 0.62f, p[1] = 0.43f, p[2] = 0.35f;
        }
    CHECK(ss_silhouette_target(rgb, W, H, lm, dist) == SP_ENODATA);
}

static void test_distance_map(void)
{
    float *rgb = malloc(sizeof(float) * W * H * 3), *dist = malloc(sizeof(float) * W * H);
    CHECK(rgb && dist);
    if (!rgb || !dist)
        return;
    const double cx = 48.0, cy = 40.0, rad = 25.0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            int in = hypot(x - cx, y - cy) <= rad;
            float *p = rgb + ((size_t)y * W + (size_t)x) * 3;
            double shade = 0.6 + 0.3 * (double)x / W; /* shading varies, chroma does not */
            p[0] = in ? (float)(0.8 * shade) : 0.35f;
            p[1] = in ? (float)(0.55 * shade) : 0.55f;
            p[2] = in ? (float)(0.45 * shade) : 0.85f;
        }
    double lm[136];
    disk_landmarks(cx, cy, rad, 0, lm);
    int nb = ss_silhouette_target(rgb, W, H, lm, dist);
    CHECK_MSG(nb > 100, "boundary pixels %d", nb);
    int finite = 1;
    for (int i = 0; i < W * H; i++)
        finite &= isfinite(dist[i]);
    CHECK(finite);
    /* signed, zero half a pixel beyond the outermost skin pixel: negative inside, positive outside */
    CHECK_NEAR(dist[40 * W + 48], -(rad - 0.5), 1.5); /* centre */
    CHECK_NEAR(dist[40 * W + 23], 0.0, 1.01);         /* on the rim */
    CHECK_NEAR(dist[40 * W + 5], 17.5, 1.5);          /* outside, left */
    /* the lower half of the background a grey ground (neutral chroma, as bright as the skin): the
       disk's rim there is still the outline, the ground is not skin */
    for (int y = (int)cy; y < H; y++)
        for (int x = 0; x < W; x++)
            if (hypot(x - cx, y - cy) > rad) {
                float *p = rgb + ((size_t)y * W + (size_t)x) * 3;
                p[0] = p[1] = p[2] = 0.6f;
            }
    nb = ss_silhouette_target(rgb, W, H, lm, dist);
    CHECK_MSG(nb > 100, "boundary pixels on grey ground %d", nb);
    if (nb > 0) {
        CHECK_NEAR(dist[70 * W + 48], 4.5, 1.5);  /* below the disk, on the ground */
        CHECK_NEAR(dist[60 * W + 10], hypot(38.0, 20.0) - rad - 0.5, 1.5);
        CHECK(dist[50 * W + 48] < 0.0f);          /* inside, lower half */
    }
    check_thin_join(rgb, dist, cx, cy, rad);
    /* a skin-coloured background: the mask leaks far beyond the face, so no outline is trusted */
    for (int i = 0; i < W * H; i++) {
        rgb[i * 3] = 0.6f;
        rgb[i * 3 + 1] = 0.42f;
        rgb[i * 3 + 2] = 0.33f;
    }
    CHECK(ss_silhouette_target(rgb, W, H, lm, dist) == SP_ENODATA);
    /* degenerate input: no skin inside the outline (all black) gives no data, never NaN */
    memset(rgb, 0, sizeof(float) * W * H * 3);
    CHECK(ss_silhouette_target(rgb, W, H, lm, dist) == SP_ENODATA);
    CHECK(ss_silhouette_target(NULL, W, H, lm, dist) < 0);
    free(rgb);
    free(dist);
}

static void frontal_params(sp_face_params *p, const double *id, const double *exp)
{
    sp_face_params_init(p);
    p->id = id;
    p->exp = exp;
    p->rotvec[0] = M_PI - 0.2; /* turned to the camera, a bit tilted and turned */
    p->rotvec[1] = 0.35;
    p->rotvec[2] = 0.1;
    p->t[0] = 0.01;
    p->t[1] = -0.02;
    p->t[2] = 0.55;
    p->s = 1.05;
}

/* sum of squared residuals: the scalar whose gradient J^T r is checked */
static double half_ss(const sp_face_model *m, const sp_face_params *p, const sp_face_camera *cam, const uint32_t *idx,
                      int n, const float *dist, double *r)
{
    ss_silhouette_residuals(m, p, cam, idx, n, dist, W, H, r, NULL);
    double e = 0.0;
    for (int j = 0; j < n; j++)
        e += 0.5 * r[j] * r[j];
    return e;
}

static double *param_slot(sp_face_params *p, double *id, double *exp, const sp_face_model *m, uint32_t c)
{
    if (c < m->n_id)
        return &id[c];
    c -= m->n_id;
    if (c < m->n_exp)
        return &exp[c];
    c -= m->n_exp;
    return c < 3 ? &p->rotvec[c] : (c < 6 ? &p->t[c - 3] : &p->s);
}

/* Analytic J^T r against central differences of 0.5 |r|^2 for every parameter; the worst relative error. */
static double grad_check(const sp_face_model *m, sp_face_params *p, double *id, double *exp, const sp_face_camera *cam,
                         const uint32_t *idx, int n, const float *dist, double *jac)
{
    uint32_t nc = sp_face_model_n_params(m);
    double r[2 * H], r2[2 * H], worst = 0.0;
    CHECK(ss_silhouette_residuals(m, p, cam, idx, n, dist, W, H, r, jac) == 0);
    for (uint32_t c = 0; c < nc; c++) {
        double g = 0.0;
        for (int j = 0; j < n; j++)
            g += r[j] * jac[(size_t)j * nc + c];
        double *v = param_slot(p, id, exp, m, c), v0 = *v, hstep = 1e-7;
        *v = v0 + hstep;
        double ep = half_ss(m, p, cam, idx, n, dist, r2);
        *v = v0 - hstep;
        double em = half_ss(m, p, cam, idx, n, dist, r2);
        *v = v0;
        double fd = (ep - em) / (2.0 * hstep);
        double rel = fabs(fd - g) / fmax(1.0, fabs(fd));
        worst = fmax(worst, rel);
        CHECK_MSG(rel < 2e-3, "param %u: analytic %.6g, finite difference %.6g", c, g, fd);
    }
    return worst;
}

static void test_outline_and_gradient(void)
{
    sp_face_model m;
    if (sp_face_model_generic(&m)) {
        CHECK_MSG(0, "generic face model");
        return;
    }
    uint32_t nc = sp_face_model_n_params(&m), nv = m.mesh.n_vertices;
    double *id = calloc(m.n_id + 1, sizeof(double)), *exp = calloc(m.n_exp + 1, sizeof(double));
    double *work = malloc(sizeof(double) * 6 * nv), *pos = malloc(sizeof(double) * 3 * nv);
    uint32_t idx[2 * H];
    double r[2 * H];
    double *jac = malloc(sizeof(double) * 2 * H * nc);
    float *dist = malloc(sizeof(float) * W * H);
    CHECK(id && exp && work && pos && jac && dist);
    if (!id || !exp || !work || !pos || !jac || !dist)
        goto out;
    for (uint32_t k = 0; k < m.n_id; k++)
        id[k] = 0.3 * sin(1.0 + k);
    for (uint32_t k = 0; k < m.n_exp; k++)
        exp[k] = 0.2 + 0.1 * cos(2.0 * k);
    sp_face_params p;
    frontal_params(&p, id, exp);
    sp_face_camera cam;
    sp_face_camera_init(&cam, FX, FX, 0.5 * (W - 1), 0.5 * (H - 1));
    int n = ss_silhouette_vertices(&m, NULL, &p, &cam, W, H, idx, 2 * H, work);
    CHECK_MSG(n >= 10, "outline vertices %d", n);
    for (int j = 0; j < n; j++)
        CHECK(idx[j] < nv && m.face_mask[idx[j]]);
    /* with the scalp: the crown's outline joins (tagged), and only scalp vertices are tagged */
    {
        uint8_t *scalp = malloc(nv);
        uint32_t *all = malloc(sizeof(uint32_t) * SS_SIL_CAP(W, H));
        CHECK(scalp && all && sp_face_model_scalp(&m, scalp) == 0);
        if (scalp && all) {
            int n_scalp = 0, n_overlap = 0;
            for (uint32_t i = 0; i < nv; i++) {
                n_scalp += scalp[i];
                n_overlap += scalp[i] && m.face_mask[i];
            }
            CHECK_MSG(n_scalp > 20 && n_overlap == 0, "scalp vertices %d, %d of them in the face mask", n_scalp,
                      n_overlap);
            /* the head's sides (the ears) below the brows are in it, the neck below the chin is not */
            const float *P = m.mesh.positions;
            double brow_y = P[m.landmarks[19] * 3 + 1], chin_y = P[m.landmarks[8] * 3 + 1];
            int n_sides = 0, n_neck = 0;
            for (uint32_t i = 0; i < nv; i++) {
                n_sides += scalp[i] && (double)P[i * 3 + 1] < brow_y;
                n_neck += scalp[i] && (double)P[i * 3 + 1] < chin_y;
            }
            CHECK_MSG(n_sides > 0 && n_neck == 0, "scalp: %d vertices below the brows, %d below the chin", n_sides,
                      n_neck);
            int na = ss_silhouette_vertices(&m, scalp, &p, &cam, W, H, all, SS_SIL_CAP(W, H), work), tagged = 0;
            for (int j = 0; j < na; j++) {
                uint32_t v = all[j] & ~SS_SIL_SCALP;
                int is_scalp = (all[j] & SS_SIL_SCALP) != 0;
                tagged += is_scalp;
                CHECK(v < nv && (is_scalp ? scalp[v] : m.face_mask[v]));
            }
            CHECK_MSG(tagged >= 5 && na > n, "outline with the scalp: %d vertices, %d of them scalp", na, tagged);
            /* each vertex is one residual, however many of its row's and column's extremes it is */
            int doubled = 0;
            for (int j = 0; j < na; j++)
                for (int k = j + 1; k < na; k++)
                    doubled += (all[j] & ~SS_SIL_SCALP) == (all[k] & ~SS_SIL_SCALP);
            CHECK_MSG(doubled == 0, "%d outline vertices are listed twice", doubled);
        }
        free(scalp);
        free(all);
    }
    /* residual against the model's own evaluation: with dist = u, r is the projected u */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            dist[y * W + x] = (float)x;
    CHECK(sp_face_model_eval(&m, &p, pos) == 0);
    CHECK(ss_silhouette_residuals(&m, &p, &cam, idx, n, dist, W, H, r, NULL) == 0);
    for (int j = 0; j < n; j++) {
        const double *X = pos + (size_t)idx[j] * 3;
        CHECK_NEAR(r[j], FX * X[0] / X[2] + cam.cx, 1e-3);
    }
    /* a smooth, non-linear distance-like field for the gradient check */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            dist[y * W + x] = (float)(fabs(hypot(x - 40.0, y - 45.0) - 22.0) + 0.02 * x * (double)y / W);
    double worst = grad_check(&m, &p, id, exp, &cam, idx, n, dist, jac);
    printf("silhouette: %d outline vertices, worst gradient mismatch %.2g (relative)\n", n, worst);
    /* one-sided: a face vertex pulls only from outside the skin, a scalp vertex only from inside */
    {
        uint32_t two[2] = { idx[0], idx[0] | SS_SIL_SCALP };
        double rr[2];
        for (int i = 0; i < W * H; i++)
            dist[i] = -3.0f;
        CHECK(ss_silhouette_residuals(&m, &p, &cam, two, 2, dist, W, H, rr, NULL) == 0);
        CHECK_NEAR(rr[0], 0.0, 1e-12);
        CHECK_NEAR(rr[1], 3.0, 1e-6);
        for (int i = 0; i < W * H; i++)
            dist[i] = 3.0f;
        CHECK(ss_silhouette_residuals(&m, &p, &cam, two, 2, dist, W, H, rr, NULL) == 0);
        CHECK_NEAR(rr[0], 3.0, 1e-6);
        CHECK_NEAR(rr[1], 0.0, 1e-12);
    }
    /* the scalp's side: every vertex tagged, the field negated (inside the skin), the same gradient */
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            dist[y * W + x] = -(float)(fabs(hypot(x - 40.0, y - 45.0) - 22.0) + 0.02 * x * (double)y / W + 0.1);
    for (int j = 0; j < n; j++)
        idx[j] |= SS_SIL_SCALP;
    worst = grad_check(&m, &p, id, exp, &cam, idx, n, dist, jac);
    printf("silhouette, scalp side: worst gradient mismatch %.2g\n", worst);
    for (int j = 0; j < n; j++)
        idx[j] &= ~SS_SIL_SCALP;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++)
            dist[y * W + x] = (float)(fabs(hypot(x - 40.0, y - 45.0) - 22.0) + 0.02 * x * (double)y / W);
    /* at the identity rotation (the closed form's special case) the gradient still matches */
    p.rotvec[0] = p.rotvec[1] = p.rotvec[2] = 0.0;
    worst = grad_check(&m, &p, id, exp, &cam, idx, n, dist, jac);
    printf("silhouette at the identity rotation: worst gradient mismatch %.2g\n", worst);
out:
    free(id);
    free(exp);
    free(work);
    free(pos);
    free(jac);
    free(dist);
    sp_face_model_free(&m);
}

int main(void)
{
    test_distance_map();
    test_outline_and_gradient();
    return check_exit();
}
