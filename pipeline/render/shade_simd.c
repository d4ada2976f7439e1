/* SPDX-License-Identifier: MIT */
#include "pipeline/render/shade_simd.h"

#include <stdint.h>
#include <string.h>

#include "pipeline/render/vec_simd.h"

#define SK0 0.28209479f
#define SK1 0.48860251f
#define SK2 1.09254843f
#define SK3 0.31539157f
#define SK4 0.54627422f
#define INV_PI 0.31830989f
#define INV_2PI 0.15915494f

float simd_exp2f(float x)
{
    float out[LANES];
    st(out, v_exp2(splat(x)));
    return out[0];
}

float simd_log2f(float x)
{
    float out[LANES];
    st(out, v_log2(splat(x)));
    return out[0];
}

void simd_frame_init(simd_frame *f, const double l[3], double I, const env_sh *sh)
{
    for (int i = 0; i < 3; i++)
        f->l[i] = (float)l[i];
    f->I = (float)I;
    for (int c = 0; c < 3; c++)
        for (int j = 0; j < ENV_SH_N; j++)
            f->C[c][j] = (float)sh->C[c][j];
}

void simd_batch_pad(simd_batch *b)
{
    int end = (b->n + LANES - 1) / LANES * LANES;
    for (int i = b->n; i < end; i++) {
        b->nx[i] = b->ny[i] = b->vx[i] = b->vy[i] = 0.0f;
        b->nz[i] = b->vz[i] = 1.0f;
        b->a[0][i] = b->a[1][i] = b->a[2][i] = 0.0f;
        b->ks[i] = 0.0f;
        b->s[i] = 1.0f;
        b->z[i] = -1e30f;
        b->gc[0][i] = b->gc[1][i] = b->gc[2][i] = 0.0f;
    }
}

/* SH basis at n (env_sh_eval in float). */
static inline void sh_basis(vf x, vf y, vf z, vf Y[ENV_SH_N])
{
    Y[0] = splat(SK0);
    Y[1] = SK1 * y;
    Y[2] = SK1 * z;
    Y[3] = SK1 * x;
    Y[4] = SK2 * x * y;
    Y[5] = SK2 * y * z;
    Y[6] = SK3 * (3.0f * z * z - 1.0f);
    Y[7] = SK2 * x * z;
    Y[8] = SK4 * (x * x - y * y);
}

/* Soft shadow: V = 1 / (1 + e^z) with |z| clamped to 80 (V saturates long before float overflows). */
static inline vf sigmoid_v(vf z, vf *dVdz)
{
    vf zc = vmin(vmax(z, splat(-80.0f)), splat(80.0f));
    vf ez = v_exp2(zc * LOG2E);
    vf V = 1.0f / (1.0f + ez);
    *dVdz = -(V * (1.0f - V)); /* -sigmoid'(z) */
    return V;
}

/* Half vector, clamped n.h and (n.h)^s for lanes [i, i + LANES); returns P. */
static inline vf lobe_v(const simd_frame *f, simd_batch *b, int i, vf nx, vf ny, vf nz, vf s)
{
    vf hx = f->l[0] + ld(b->vx + i), hy = f->l[1] + ld(b->vy + i), hz = f->l[2] + ld(b->vz + i);
    vf hl2 = hx * hx + hy * hy + hz * hz;
    vi hok = MASK(hl2 > splat(1e-24f));
    vf inv = v_rsqrt(vmax(hl2, splat(1e-24f))), hlen = hl2 * inv;
    hx *= inv, hy *= inv, hz *= inv;
    vf nh = nx * hx + ny * hy + nz * hz;
    vi ok = hok & MASK(nh >= splat(1e-12f)) & MASK(nh <= splat(1.0f));
    vf nhc = vmin(vmax(nh, splat(1e-12f)), splat(1.0f));
    vf lg2 = v_log2(nhc);
    vf e2 = s * lg2;
    /* lobe tail below 2^-100 (~1e-30) flushed to 0, as the double path; clamp keeps exp2 finite */
    vf P = sel(hok & MASK(e2 > splat(-100.0f)), v_exp2(e2), splat(0.0f));
    st(b->hx + i, hx), st(b->hy + i, hy), st(b->hz + i, hz), st(b->hlen + i, hlen);
    st(b->nh + i, nhc), st(b->lnh + i, lg2 * LN2), st(b->nhok + i, sel(ok, splat(1.0f), splat(0.0f)));
    return P;
}

void simd_shade_forward(const simd_frame *f, simd_batch *b)
{
    for (int i = 0; i < b->n; i += LANES) {
        vf nx = ld(b->nx + i), ny = ld(b->ny + i), nz = ld(b->nz + i), Y[ENV_SH_N];
        vf nl = nx * f->l[0] + ny * f->l[1] + nz * f->l[2];
        vi lit_on = MASK(nl > splat(0.0f));
        vf dVdz, V = sigmoid_v(ld(b->z + i), &dVdz);
        vf lit = sel(lit_on, f->I * nl * V, splat(0.0f));
        vf ks = ld(b->ks + i), s = ld(b->s + i);
        vf P = lobe_v(f, b, i, nx, ny, nz, s);
        vi spec_on = lit_on & MASK(ks != splat(0.0f));
        vf spec = sel(spec_on, ks * (s + 2.0f) * INV_2PI * P * lit, splat(0.0f));
        sh_basis(nx, ny, nz, Y);
        for (int c = 0; c < 3; c++) {
            const float *C = f->C[c];
            vf e = C[0] * Y[0] + C[1] * Y[1] + C[2] * Y[2] + C[3] * Y[3] + C[4] * Y[4] + C[5] * Y[5] + C[6] * Y[6] +
                   C[7] * Y[7] + C[8] * Y[8];
            vf E = vmax(e, splat(0.0f));
            vf a = ld(b->a[c] + i) * INV_PI;
            st(b->e[c] + i, e);
            st(b->rad[c] + i, a * E + a * lit + spec);
        }
        st(b->V + i, V), st(b->dVdz + i, dVdz), st(b->nl + i, sel(lit_on, nl, splat(0.0f)));
        st(b->P + i, sel(spec_on, P, splat(0.0f)));
    }
}

/* dE/dn of one channel (0 where clamped) times gE, added to gn. */
static inline void sh_grad_n(const float *C, vf x, vf y, vf z, vf gE, vf gn[3])
{
    gn[0] += gE * (SK1 * C[3] + SK2 * (C[4] * y + C[7] * z) + 2.0f * SK4 * C[8] * x);
    gn[1] += gE * (SK1 * C[1] + SK2 * (C[4] * x + C[5] * z) - 2.0f * SK4 * C[8] * y);
    gn[2] += gE * (SK1 * C[2] + SK2 * (C[5] * y + C[7] * x) + 6.0f * SK3 * C[6] * z);
}

/* Specular adjoint for lanes [i, i + LANES): adds to g_nl, g_I, g_V, gn, gv and the sun-direction sums gl. */
static inline void spec_backward_v(const simd_frame *f, simd_batch *b, int i, vf gsum, vf n[3], vf *g_nl, vf *g_I,
                                   vf *g_V, vf gn[3], vf gv[3], vf gl[3])
{
    vf ks = ld(b->ks + i), s = ld(b->s + i), P = ld(b->P + i), nl = ld(b->nl + i), V = ld(b->V + i);
    vf fac = (s + 2.0f) * INV_2PI, I = splat(f->I);
    st(b->gks + i, gsum * fac * P * nl * I * V);
    st(b->gs + i, gsum * ks * P * nl * I * V * (INV_2PI + fac * ld(b->lnh + i)));
    vf k = gsum * ks * fac;
    *g_nl += k * P * I * V;
    *g_I += k * P * nl * V;
    *g_V += k * P * nl * I;
    /* s P / nh = s nh^(s-1) <= s: finite; 0 where the clamp was active */
    vf g_nh = ld(b->nhok + i) * k * nl * I * V * s * P / ld(b->nh + i);
    vf h[3] = {ld(b->hx + i), ld(b->hy + i), ld(b->hz + i)};
    vf gh[3], hg = splat(0.0f);
    for (int d = 0; d < 3; d++) {
        gn[d] += g_nh * h[d];
        gh[d] = n[d] * g_nh;
        hg += h[d] * gh[d];
    }
    vf inv = 1.0f / vmax(ld(b->hlen + i), splat(1e-12f));
    for (int d = 0; d < 3; d++) {
        vf ghs = (gh[d] - h[d] * hg) * inv;
        gl[d] += ghs;
        gv[d] += ghs;
    }
}

void simd_shade_backward(const simd_frame *f, simd_batch *b, simd_acc *acc)
{
    vf gY[3][ENV_SH_N], gl[3], gI = splat(0.0f);
    memset(gY, 0, sizeof(gY));
    memset(gl, 0, sizeof(gl));
    for (int i = 0; i < b->n; i += LANES) {
        vf n[3] = {ld(b->nx + i), ld(b->ny + i), ld(b->nz + i)}, Y[ENV_SH_N];
        vf gn[3] = {splat(0.0f), splat(0.0f), splat(0.0f)}, gv[3] = {gn[0], gn[0], gn[0]};
        vf nl = ld(b->nl + i), V = ld(b->V + i), I = splat(f->I), sd = splat(0.0f), gsum = splat(0.0f);
        sh_basis(n[0], n[1], n[2], Y);
        for (int c = 0; c < 3; c++) {
            vf gc = ld(b->gc[c] + i), e = ld(b->e[c] + i), a = ld(b->a[c] + i) * INV_PI;
            vf gE = sel(MASK(e > splat(0.0f)), gc * a, splat(0.0f));
            st(b->ga[c] + i, gc * (vmax(e, splat(0.0f)) + I * nl * V) * INV_PI);
            sh_grad_n(f->C[c], n[0], n[1], n[2], gE, gn);
            for (int j = 0; j < ENV_SH_N; j++)
                gY[c][j] += gE * Y[j];
            sd += gc * a;
            gsum += gc;
        }
        /* nl is 0 on unlit lanes: every sun term below vanishes there */
        vi lit_on = MASK(nl > splat(0.0f));
        vf g_nl = sel(lit_on, sd * I * V, splat(0.0f)), g_V = sd * I * nl, g_I = sd * nl * V;
        spec_backward_v(f, b, i, sel(lit_on, gsum, splat(0.0f)), n, &g_nl, &g_I, &g_V, gn, gv, gl);
        for (int d = 0; d < 3; d++) {
            gn[d] += g_nl * f->l[d];
            gl[d] += g_nl * n[d];
            st(b->gn[d] + i, gn[d]);
            st(b->gv[d] + i, gv[d]);
        }
        gI += g_I;
        st(b->gV + i, g_V);
    }
    for (int d = 0; d < 3; d++)
        acc->gl[d] += lane_sum(gl[d]);
    acc->gI += lane_sum(gI);
    for (int c = 0; c < 3; c++)
        for (int j = 0; j < ENV_SH_N; j++)
            acc->gY[c][j] += lane_sum(gY[c][j]);
}
