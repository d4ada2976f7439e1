/* SPDX-License-Identifier: MIT */
#include "pipeline/render/surf_simd.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#include "pipeline/render/adjoint.h"
#include "pipeline/render/shade_simd.h"
#include "pipeline/render/surf_gather.h"
#include "pipeline/render/texture.h"
#include "pipeline/render/vec3.h"
#include "pipeline/render/vec_simd.h"

/* Per-lane integer select and minimum. */
static inline vi seli(vi m, vi a, vi b)
{
    return (a & m) | (b & ~m);
}

static inline vi mini(vi a, vi b)
{
    return seli(MASK(a < b), a, b);
}

void surf_batch_pad(surf_batch *s, int n)
{
    int end = (n + LANES - 1) / LANES * LANES;
    for (int i = n; i < end; i++) {
        s->d0[i] = s->d1[i] = s->iw[i] = s->u[i] = s->v[i] = s->msk[i] = 0.0f;
        s->tgt[0][i] = s->tgt[1][i] = s->tgt[2][i] = 0.0f;
        for (int a = 0; a < 3; a++) {
            s->lam[a][i] = s->ev[a][i] = s->dz[a][i] = 0.0f;
            for (int d = 0; d < 3; d++)
                s->dp[a][d][i] = s->nd[a][d][i] = 0.0f;
            s->uvv[a][0][i] = s->uvv[a][1][i] = 0.0f;
        }
        for (int k = 0; k < 4; k++)
            s->tex[k][0][i] = s->tex[k][1][i] = s->tex[k][2][i] = 0.0f;
    }
}

/* 1 / |x| for the squared length l2, 0 where the length is below 1e-15 or not finite (v3_normalize's zero vector). */
static inline vf inv_len(vf l2)
{
    vi ok = MASK(l2 > splat(1e-30f)) & MASK(l2 < splat(1e30f));
    return sel(ok, v_rsqrt(vmin(vmax(l2, splat(1e-30f)), splat(1e30f))), splat(0.0f));
}

/*
 * One texture axis as tex_axis: coordinate x (texel centres at integers) clamped to [0, n - 1] (NaN -> 0), lower
 * texel i0, upper i1, fraction f and scale dfd (0 where clamped).
 */
static inline void axis_v(vf x, int n, float scale, vi *i0, vi *i1, vf *f, vf *dfd)
{
    vf top = splat((float)(n - 1));
    vi lo = MASK(x > splat(0.0f)), hi = MASK(x >= top);
    x = sel(lo, x, splat(0.0f));
    x = sel(hi, top, x);
    *dfd = sel(lo & ~hi, splat(scale), splat(0.0f));
    vi i = mini(CVT_I(x), (vi){0} + (n - 1)); /* x >= 0: truncation is the floor */
    *i0 = i;
    *i1 = mini(i + 1, (vi){0} + (n - 1));
    *f = x - CVT_F(i);
}

void surf_forward_a(const surf_frame *f, simd_batch *b)
{
    surf_batch *s = &b->surf;
    int W = f->tex_w, H = f->tex_h;
    for (int i = 0; i < b->n; i += LANES) {
        vf l0 = ld(s->lam[0] + i), l1 = ld(s->lam[1] + i), l2 = ld(s->lam[2] + i), m[3];
        for (int d = 0; d < 3; d++)
            m[d] = l0 * ld(s->nd[0][d] + i) + l1 * ld(s->nd[1][d] + i) + l2 * ld(s->nd[2][d] + i);
        vf im = inv_len(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
        st(b->nx + i, m[0] * im), st(b->ny + i, m[1] * im), st(b->nz + i, m[2] * im), st(s->imlen + i, im);
        vf ex = ld(s->ev[0] + i), ey = ld(s->ev[1] + i), ez = ld(s->ev[2] + i);
        vf ie = inv_len(ex * ex + ey * ey + ez * ez);
        st(b->vx + i, ex * ie), st(b->vy + i, ey * ie), st(b->vz + i, ez * ie), st(s->ievlen + i, ie);
        vi x0, x1, y0, y1;
        vf fx, fy, dfx, dfy;
        axis_v(ld(s->u + i) * (float)W - 0.5f, W, (float)W, &x0, &x1, &fx, &dfx);
        axis_v((1.0f - ld(s->v + i)) * (float)H - 0.5f, H, -(float)H, &y0, &y1, &fy, &dfy);
        vi r0 = y0 * W, r1 = y1 * W;
        sti(s->tidx[0] + i, r0 + x0), sti(s->tidx[1] + i, r0 + x1);
        sti(s->tidx[2] + i, r1 + x0), sti(s->tidx[3] + i, r1 + x1);
        st(s->fx + i, fx), st(s->fy + i, fy), st(s->dfx + i, dfx), st(s->dfy + i, dfy);
    }
}

void surf_forward_b(simd_batch *b)
{
    surf_batch *s = &b->surf;
    for (int i = 0; i < b->n; i += LANES) {
        vf fx = ld(s->fx + i), fy = ld(s->fy + i), gx = 1.0f - fx, gy = 1.0f - fy;
        vf w0 = gx * gy, w1 = fx * gy, w2 = gx * fy, w3 = fx * fy;
        for (int c = 0; c < 3; c++)
            st(b->a[c] + i, w0 * ld(s->tex[0][c] + i) + w1 * ld(s->tex[1][c] + i) + w2 * ld(s->tex[2][c] + i) +
                                w3 * ld(s->tex[3][c] + i));
    }
}

/* (I - x x^T) g * inv: the adjoint of x = y / |y| with inv = 1 / |y|. */
static inline void unit_back(const vf x[3], const vf g[3], vf inv, vf out[3])
{
    vf dot = x[0] * g[0] + x[1] * g[1] + x[2] * g[2];
    for (int d = 0; d < 3; d++)
        out[d] = (g[d] - x[d] * dot) * inv;
}

/* dL/du and dL/dv of the bilinear albedo lookup at lanes [i, i + LANES), given dL/da. */
static inline void uv_back(const surf_batch *s, const simd_batch *b, int i, vf *gu, vf *gv)
{
    vf fx = ld(s->fx + i), fy = ld(s->fy + i), gx = 1.0f - fx, gy = 1.0f - fy;
    vf su = splat(0.0f), sv = splat(0.0f);
    for (int c = 0; c < 3; c++) {
        vf t0 = ld(s->tex[0][c] + i), t1 = ld(s->tex[1][c] + i), t2 = ld(s->tex[2][c] + i),
           t3 = ld(s->tex[3][c] + i), ga = ld(b->ga[c] + i);
        su += ga * (gy * (t1 - t0) + fy * (t3 - t2));
        sv += ga * (gx * (t2 - t0) + fx * (t3 - t1));
    }
    *gu = su * ld(s->dfx + i);
    *gv = sv * ld(s->dfy + i);
}

/* d x q for d = (d0, d1, 1) */
static inline void cross_d(vf d0, vf d1, const vf q[3], vf out[3])
{
    out[0] = d1 * q[2] - q[1];
    out[1] = q[0] - d0 * q[2];
    out[2] = d0 * q[1] - d1 * q[0];
}

/*
 * Camera-space vertices of lanes [i, i + LANES): x_v = R pd_v + t = R (pd_v - eye) = R (dp_v - ev), since
 * eye = -R^T t (no gather; as accurate as rounding x_v itself, dp and ev being small or exact to ~1e-7).
 */
static inline void camera_vertices(const surf_frame *f, const surf_batch *s, int i, vf X[3][3])
{
    vf ev[3] = {ld(s->ev[0] + i), ld(s->ev[1] + i), ld(s->ev[2] + i)};
    for (int v = 0; v < 3; v++) {
        vf r[3];
        for (int d = 0; d < 3; d++)
            r[d] = ld(s->dp[v][d] + i) - ev[d];
        for (int d = 0; d < 3; d++)
            X[v][d] = f->R[d * 3] * r[0] + f->R[d * 3 + 1] * r[1] + f->R[d * 3 + 2] * r[2];
    }
}

/*
 * Barycentric adjoint of lanes [i, i + LANES) from dL/d(lam_v) to the camera-space vertices (gx), and
 * gd = sum_v gw_v k_v (x and y; k = B x C, C x A, A x B) for the ray's intrinsics.
 */
static inline void bary_back(const surf_frame *f, const surf_batch *s, int i, const vf glam[3], vf gx[3][3],
                             vf gd[2])
{
    vf lam[3] = {ld(s->lam[0] + i), ld(s->lam[1] + i), ld(s->lam[2] + i)}, gw[3];
    vf dot = lam[0] * glam[0] + lam[1] * glam[1] + lam[2] * glam[2], iw = ld(s->iw + i);
    for (int j = 0; j < 3; j++)
        gw[j] = (glam[j] - dot) * iw;
    vf X[3][3], q[3], d0 = ld(s->d0 + i), d1 = ld(s->d1 + i);
    camera_vertices(f, s, i, X);
    gd[0] = gd[1] = splat(0.0f);
    for (int v = 0; v < 3; v++) {
        const vf *B = X[(v + 1) % 3], *C = X[(v + 2) % 3];
        gd[0] += gw[v] * (B[1] * C[2] - B[2] * C[1]);
        gd[1] += gw[v] * (B[2] * C[0] - B[0] * C[2]);
    }
    /* w0 = [d, B, C], w1 = [d, C, A], w2 = [d, A, B]: vertex v gets d x (gw_{v+1} X_{v+2} - gw_{v+2} X_{v+1}) */
    for (int v = 0; v < 3; v++) {
        int a = (v + 1) % 3, c = (v + 2) % 3;
        for (int d = 0; d < 3; d++)
            q[d] = gw[a] * X[c][d] - gw[c] * X[a][d];
        cross_d(d0, d1, q, gx[v]);
    }
}

/* Pose sums of surf_backward, per lane. */
typedef struct pose_sums {
    vf R[9], t[3];
} pose_sums;

/*
 * Per-vertex outputs of lanes [i, i + LANES): gpv = lam_v gp + R^T gx_v, gmv = lam_v gm; dL/dR and dL/dt of
 * x_v = R pd_v + t with pd_v = p + dp_v and p = eye - ev.
 */
static inline void vertex_out(const surf_frame *f, surf_batch *s, int i, const vf gp[3], const vf gm[3],
                              vf gx[3][3], pose_sums *ps)
{
    vf sx[3] = {splat(0.0f), splat(0.0f), splat(0.0f)};
    for (int v = 0; v < 3; v++) {
        vf lam = ld(s->lam[v] + i);
        for (int a = 0; a < 3; a++) {
            st(s->gpv[v][a] + i, lam * gp[a] + f->R[a] * gx[v][0] + f->R[3 + a] * gx[v][1] + f->R[6 + a] * gx[v][2]);
            st(s->gmv[v][a] + i, lam * gm[a]);
            sx[a] += gx[v][a];
        }
        for (int r = 0; r < 3; r++)
            for (int k = 0; k < 3; k++)
                ps->R[r * 3 + k] += gx[v][r] * ld(s->dp[v][k] + i);
    }
    for (int k = 0; k < 3; k++) {
        vf p = f->eye[k] - ld(s->ev[k] + i);
        for (int r = 0; r < 3; r++)
            ps->R[r * 3 + k] += sx[r] * p;
    }
    for (int r = 0; r < 3; r++)
        ps->t[r] += sx[r];
}

/* dL/d(albedo texel k) = wt_k dL/da of lanes [i, i + LANES). */
static inline void texel_out(surf_batch *s, const simd_batch *b, int i)
{
    vf fx = ld(s->fx + i), fy = ld(s->fy + i), gx = 1.0f - fx, gy = 1.0f - fy;
    vf wt[4] = {gx * gy, fx * gy, gx * fy, fx * fy};
    for (int c = 0; c < 3; c++) {
        vf ga = ld(b->ga[c] + i);
        for (int k = 0; k < 4; k++)
            st(s->gal[k][c] + i, wt[k] * ga);
    }
}

void surf_backward(const surf_frame *f, simd_batch *b, surf_acc *acc)
{
    surf_batch *s = &b->surf;
    vf eye[3] = {splat(0.0f), splat(0.0f), splat(0.0f)}, sfx = eye[0], scx = eye[0], sfy = eye[0], scy = eye[0];
    pose_sums ps;
    for (int k = 0; k < 9; k++)
        ps.R[k] = splat(0.0f);
    ps.t[0] = ps.t[1] = ps.t[2] = splat(0.0f);
    for (int i = 0; i < b->n; i += LANES) {
        vf vv[3] = {ld(b->vx + i), ld(b->vy + i), ld(b->vz + i)}, gv[3], gev[3], gp[3], gm[3];
        vf nn[3] = {ld(b->nx + i), ld(b->ny + i), ld(b->nz + i)}, gn[3];
        vf gz = ld(b->gV + i) * ld(b->dVdz + i);
        for (int d = 0; d < 3; d++)
            gv[d] = ld(b->gv[d] + i), gn[d] = ld(b->gn[d] + i);
        unit_back(vv, gv, ld(s->ievlen + i), gev);
        unit_back(nn, gn, ld(s->imlen + i), gm);
        for (int d = 0; d < 3; d++) {
            gp[d] = gz * ld(s->dz[d] + i) - gev[d]; /* ev = eye - p */
            eye[d] += gev[d];
        }
        vf gu, gvv, glam[3], gd[2], gx[3][3];
        uv_back(s, b, i, &gu, &gvv);
        for (int v = 0; v < 3; v++) {
            vf g = gu * ld(s->uvv[v][0] + i) + gvv * ld(s->uvv[v][1] + i);
            for (int d = 0; d < 3; d++)
                g += gp[d] * ld(s->dp[v][d] + i) + gm[d] * ld(s->nd[v][d] + i);
            glam[v] = g;
        }
        bary_back(f, s, i, glam, gx, gd);
        vertex_out(f, s, i, gp, gm, gx, &ps);
        texel_out(s, b, i);
        sfx += gd[0] * ld(s->d0 + i), scx += gd[0];
        sfy += gd[1] * ld(s->d1 + i), scy += gd[1];
    }
    for (int d = 0; d < 3; d++) {
        acc->g_eye[d] += lane_sum(eye[d]);
        acc->g_t[d] += lane_sum(ps.t[d]);
    }
    for (int k = 0; k < 9; k++)
        acc->g_R[k] += lane_sum(ps.R[k]);
    /* d = ((u - cx) / fx, (v - cy) / fy, 1) */
    acc->g_fx -= lane_sum(sfx) * f->inv_fx;
    acc->g_cx -= lane_sum(scx) * f->inv_fx;
    acc->g_fy -= lane_sum(sfy) * f->inv_fy;
    acc->g_cy -= lane_sum(scy) * f->inv_fy;
}

/* tonemap_eval in float: Reinhard then y^(1/2.2) (linear below the toe); returns the value, *slope d/dx. */
static inline vf tonemap_v(const surf_frame *f, vf x, vf *slope)
{
    vi pos = MASK(x > splat(0.0f)); /* also false for NaN: black, flat */
    x = vmin(sel(pos, x, splat(0.0f)), splat(1e30f));
    vf inv = 1.0f / (1.0f + x), y = x * inv;
    vi toe = MASK(y < splat(1e-6f));
    vf yc = vmax(y, splat(1e-6f));
    vf g = v_exp2(v_log2(vmin(yc, splat(1.0f))) * (float)(1.0 / 2.2));
    vf dg = g / (2.2f * yc);
    g = sel(toe, y * f->toe_slope, g);
    dg = sel(toe, splat(f->toe_slope), dg);
    *slope = sel(pos, dg * inv * inv, splat(0.0f));
    return sel(pos, g, splat(0.0f));
}

void surf_resolve_l2(const surf_frame *f, simd_batch *b, resolve_acc *acc)
{
    surf_batch *s = &b->surf;
    vf loss = splat(0.0f), gexp = splat(0.0f), e = splat(f->exposure);
    for (int i = 0; i < b->n; i += LANES) {
        vf m = ld(s->msk + i); /* 0 in the padding lanes (surf_batch_pad): no loss, no gradient */
        for (int c = 0; c < 3; c++) {
            vf rad = ld(b->rad[c] + i), slope, img = tonemap_v(f, e * rad, &slope);
            vf d = img - ld(s->tgt[c] + i), md = m * d;
            loss += md * d;
            vf gx = md * f->two_over_norm * slope;
            gexp += gx * rad;
            st(s->img[c] + i, img);
            st(b->gc[c] + i, gx * e);
        }
    }
    acc->loss += lane_sum(loss);
    acc->g_exposure += lane_sum(gexp);
}

int surf_gather(const shade_ctx *ctx, int sx, int sy, int32_t tri, simd_batch *b, int i)
{
    return surf_gather_at(ctx, sx, sy, tri, b, i);
}

#ifdef DLANES
/* shadow.c's tap: a texel of the map, or empty outside it. */
static inline double map_tap(const shadow_map *m, int x, int y, double empty)
{
    if (x < 0 || y < 0 || x >= m->n || y >= m->n)
        return empty;
    return (double)m->depth[(size_t)y * (size_t)m->n + (size_t)x];
}

/*
 * Lanes [i, i + DLANES) of shadow_eval_z_lanes, DLANES at a time in double:
 * the same operations in the same order (no contraction), so the same z, dz
 * and texel bit for bit; only the four depth taps are loaded per lane.
 */
static void shadow_z_group(const shadow_map *m, double k, double bias, const double *const p[3], const float *lit,
                           int i, float *z, float *const dz[3], int32_t *texel)
{
    const shadow_frame *f = &m->f;
    int n = m->n;
    double h = 0.5 * (double)f->n - 0.5, empty = f->offset + SHADOW_EMPTY_DEPTH;
    vd q0 = ldd(p[0] + i) - f->c[0], q1 = ldd(p[1] + i) - f->c[1], q2 = ldd(p[2] + i) - f->c[2];
    vd mx = (q0 * f->e1[0] + q1 * f->e1[1] + q2 * f->e1[2]) * f->scale + h;
    vd my = (q0 * f->e2[0] + q1 * f->e2[1] + q2 * f->e2[2]) * f->scale + h;
    vd mz = f->offset - (q0 * f->l[0] + q1 * f->l[1] + q2 * f->l[2]) / f->r;
    vd lt;
    for (int j = 0; j < DLANES; j++)
        lt[j] = (double)lit[i + j];
    vdm in = (lt > 0.0) & (mx > -1.0) & (mx < (double)n) & (my > -1.0) & (my < (double)n);
    vd zero = {0.0};
    mx = seld(in, mx, zero), my = seld(in, my, zero); /* in range before the conversion */
    vdi tx = __builtin_convertvector(mx, vdi), ty = __builtin_convertvector(my, vdi); /* ifloor */
    vdi ix = tx + __builtin_convertvector(mx < __builtin_convertvector(tx, vd), vdi);
    vdi iy = ty + __builtin_convertvector(my < __builtin_convertvector(ty, vd), vdi);
    vd fx = mx - __builtin_convertvector(ix, vd), fy = my - __builtin_convertvector(iy, vd);
    vd d00, d10, d01, d11;
    for (int j = 0; j < DLANES; j++) {
        int x = ix[j], y = iy[j];
        texel[i + j] = in[j] ? (y + 1) * (n + 1) + (x + 1) : -1;
        if (!in[j]) {
            d00[j] = d10[j] = d01[j] = d11[j] = 0.0;
        } else if (x >= 0 && y >= 0 && x + 1 < n && y + 1 < n) {
            const float *row = m->depth + (size_t)y * (size_t)n + (size_t)x;
            d00[j] = (double)row[0], d10[j] = (double)row[1];
            d01[j] = (double)row[n], d11[j] = (double)row[n + 1];
        } else {
            d00[j] = map_tap(m, x, y, empty), d10[j] = map_tap(m, x + 1, y, empty);
            d01[j] = map_tap(m, x, y + 1, empty), d11[j] = map_tap(m, x + 1, y + 1, empty);
        }
    }
    vd gx = 1.0 - fx, gy = 1.0 - fy;
    vd ds = gy * (gx * d00 + fx * d10) + fy * (gx * d01 + fx * d11);
    vd dsdx = gy * (d10 - d00) + fy * (d11 - d01);
    vd dsdy = gx * (d01 - d00) + fx * (d11 - d10);
    vd zz = seld(in, k * (mz - bias * ds), zero - 1e30);
    zz = seld(zz < -1e30, zero - 1e30, seld(zz > 1e30, zero + 1e30, zz)); /* NaN stays NaN */
    double gzr = -k / f->r, gs = -k * bias * f->scale;
    for (int a = 0; a < 3; a++) {
        vd g = seld(in, gzr * f->l[a] + gs * (dsdx * f->e1[a] + dsdy * f->e2[a]), zero);
        for (int j = 0; j < DLANES; j++)
            dz[a][i + j] = (float)g[j];
    }
    for (int j = 0; j < DLANES; j++)
        z[i + j] = (float)zz[j];
}
#endif

/* shadow_eval_z_lanes, DLANES lanes at a time where the vector types exist. */
static void shadow_z_lanes(const shadow_map *m, double k, double bias, int n, const double *const p[3],
                           const float *lit, float *z, float *const dz[3], int32_t *texel)
{
    int i = 0;
#ifdef DLANES
    for (; i + DLANES <= n; i += DLANES)
        shadow_z_group(m, k, bias, p, lit, i, z, dz, texel);
#endif
    if (i < n) {
        const double *const pt[3] = {p[0] + i, p[1] + i, p[2] + i};
        float *const dzt[3] = {dz[0] + i, dz[1] + i, dz[2] + i};
        shadow_eval_z_lanes(m, k, bias, n - i, pt, lit + i, z + i, dzt, texel + i);
    }
}

void surf_shadow(const shade_ctx *ctx, const float l[3], simd_batch *b, int32_t *texels)
{
    surf_batch *s = &b->surf;
    float lit[SIMD_BATCH];
    int32_t tx[SIMD_BATCH];
    for (int i = 0; i < b->n; i += LANES) /* simd_shade_forward's n.l, the same expression */
        st(lit + i, ld(b->nx + i) * l[0] + ld(b->ny + i) * l[1] + ld(b->nz + i) * l[2]);
    if (ctx->sm) {
        const double *const pw[3] = {s->pw[0], s->pw[1], s->pw[2]};
        float *const dz[3] = {s->dz[0], s->dz[1], s->dz[2]};
        shadow_z_lanes(ctx->sm, ctx->shadow_k, ctx->shadow_b, b->n, pw, lit, b->z, dz, tx);
    } else {
        for (int i = 0; i < b->n; i++) {
            b->z[i] = (float)-1e30; /* as shadow_eval_z_lanes' clamp */
            s->dz[0][i] = s->dz[1][i] = s->dz[2][i] = 0.0f;
            tx[i] = -1;
        }
    }
    if (texels)
        for (int i = 0; i < b->n; i++)
            texels[s->samp[i]] = tx[i];
}

void surf_gather_texels(simd_batch *b, const float *albedo)
{
    surf_batch *s = &b->surf;
    for (int i = 0; i < b->n; i++)
        for (int k = 0; k < 4; k++) {
            const float *t = albedo + (size_t)s->tidx[k][i] * 3;
            s->tex[k][0][i] = t[0], s->tex[k][1][i] = t[1], s->tex[k][2][i] = t[2];
        }
}

void surf_scatter(const shade_ctx *ctx, const simd_batch *b, shade_acc *acc)
{
    const surf_batch *s = &b->surf;
    for (int i = 0; i < b->n; i++) {
        if (b->gc[0][i] == 0.0f && b->gc[1][i] == 0.0f && b->gc[2][i] == 0.0f)
            continue;
        int cl = s->cluster[i];
        if (cl >= 0) {
            acc->g_ks[cl] += (double)b->gks[i];
            if (!ctx->s_clamped[cl])
                acc->g_s[cl] += (double)b->gs[i];
        }
        for (int v = 0; v < 3; v++) {
            double *gp = acc->g_pd + (size_t)s->vtx[v][i] * 3, *gn = acc->g_nd + (size_t)s->vtx[v][i] * 3;
            gp[0] += (double)s->gpv[v][0][i], gp[1] += (double)s->gpv[v][1][i], gp[2] += (double)s->gpv[v][2][i];
            gn[0] += (double)s->gmv[v][0][i], gn[1] += (double)s->gmv[v][1][i], gn[2] += (double)s->gmv[v][2][i];
        }
        if (!acc->g_albedo)
            continue;
        for (int k = 0; k < 4; k++) {
            double *dst = acc->g_albedo + (size_t)s->tidx[k][i] * 3;
            dst[0] += (double)s->gal[k][0][i], dst[1] += (double)s->gal[k][1][i], dst[2] += (double)s->gal[k][2][i];
        }
    }
}
