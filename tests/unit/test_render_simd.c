/* SPDX-License-Identifier: MIT */
/*
 * The float SoA shading kernels (shade_simd.c) against the double shading
 * code (shading.c, envlight.c, shadow_sigmoid): forward radiance within
 * 2e-6 + 1e-7 s relative (float n.h raised to the power s), every adjoint group (albedo, normal, view, shadow argument, ks,
 * shininess, sun direction and irradiance, SH coefficients) against central
 * differences of the double forward within 1e-3 relative, the exp2 / log2
 * approximations, and extremes (s = 1e4, |z| = 1e6, n.l = 0, black and
 * 1e3 albedo, 1e5 sun and sky) without NaN or Inf.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "pipeline/render/shade_simd.h"
#include "pipeline/render/shading.h"
#include "pipeline/render/shadow.h"

typedef struct sample {
    double n[3], v[3], a[3], ks, s, z;
} sample;

typedef struct frame {
    double l[3], I, C[3][ENV_SH_N];
} frame;

static double urand(double lo, double hi)
{
    return lo + (hi - lo) * (double)rand() / (double)RAND_MAX;
}

static void unit_rand(double o[3])
{
    double len;
    do {
        for (int i = 0; i < 3; i++)
            o[i] = urand(-1.0, 1.0);
        len = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
    } while (len < 0.2 || len > 1.0);
    for (int i = 0; i < 3; i++)
        o[i] /= len;
}

/* The double path's radiance of one sample (ambient + V * sun, the renderer's formulas). */
static void ref_rad(const frame *f, const sample *x, double rad[3])
{
    shade_ctx ctx;
    shade_rec rec;
    memset(&ctx, 0, sizeof(ctx));
    memset(&rec, 0, sizeof(rec));
    memcpy(ctx.sh.C, f->C, sizeof(f->C));
    ctx.ks[0] = x->ks;
    ctx.s[0] = x->s;
    memcpy(rec.n, x->n, sizeof(rec.n));
    memcpy(rec.v, x->v, sizeof(rec.v));
    memcpy(rec.a, x->a, sizeof(rec.a));
    rec.cluster = 0;
    shade_ambient(&ctx, &rec);
    shade_sun(&ctx, &rec, f->l, f->I, NULL, NULL);
    double V = shadow_sigmoid(-x->z, NULL);
    for (int c = 0; c < 3; c++)
        rad[c] = rec.amb[c] + V * (rec.diff[c] + rec.spec);
}

static void load(simd_frame *sf, simd_batch *b, const frame *f, const sample *xs, int n)
{
    env_sh sh;
    memset(&sh, 0, sizeof(sh));
    memcpy(sh.C, f->C, sizeof(f->C));
    simd_frame_init(sf, f->l, f->I, &sh);
    b->n = n;
    for (int i = 0; i < n; i++) {
        const sample *x = xs + i;
        b->nx[i] = (float)x->n[0], b->ny[i] = (float)x->n[1], b->nz[i] = (float)x->n[2];
        b->vx[i] = (float)x->v[0], b->vy[i] = (float)x->v[1], b->vz[i] = (float)x->v[2];
        for (int c = 0; c < 3; c++)
            b->a[c][i] = (float)x->a[c];
        b->ks[i] = (float)x->ks, b->s[i] = (float)x->s, b->z[i] = (float)x->z;
    }
    simd_batch_pad(b);
}

static const double W[3] = {0.7, -0.4, 1.1}; /* L = sum_c W[c] rad[c] */

static double loss_of(const frame *f, const sample *x)
{
    double r[3];
    ref_rad(f, x, r);
    return W[0] * r[0] + W[1] * r[1] + W[2] * r[2];
}

/* Central difference of loss_of w.r.t. *p (a field of f or x), step relative to |*p|. */
static double fd(const frame *f, const sample *x, double *p)
{
    double h = 1e-6 * (fabs(*p) > 1.0 ? fabs(*p) : 1.0), keep = *p;
    *p = keep + h;
    double lp = loss_of(f, x);
    *p = keep - h;
    double lm = loss_of(f, x);
    *p = keep;
    return (lp - lm) / (2.0 * h);
}

typedef struct group_err {
    double diff, scale;
} group_err;

static void group_add(group_err *g, double got, double want)
{
    double d = fabs(got - want), s = fabs(want);
    g->diff = d > g->diff ? d : g->diff;
    g->scale = s > g->scale ? s : g->scale;
}

static double group_rel(const group_err *g)
{
    return g->diff / (g->scale > 1e-9 ? g->scale : 1e-9);
}

static void random_frame(frame *f)
{
    unit_rand(f->l);
    f->I = 3.0;
    for (int c = 0; c < 3; c++)
        for (int j = 0; j < ENV_SH_N; j++)
            f->C[c][j] = j == 0 ? urand(1.0, 3.0) : urand(-1.2, 1.2);
}

static void random_sample(const frame *f, sample *x, int i)
{
    unit_rand(x->n);
    unit_rand(x->v);
    for (int c = 0; c < 3; c++)
        x->a[c] = urand(0.05, 1.0);
    x->ks = i % 5 == 0 ? 0.0 : urand(0.05, 1.0);
    x->s = i % 7 == 0 ? urand(1.0, 3.0) : urand(5.0, 300.0);
    x->z = urand(-6.0, 6.0);
    if (i % 3 == 0) /* bias towards lit, near-specular samples so the lobe is exercised */
        for (int k = 0; k < 3; k++)
            x->v[k] = 2.0 * (x->n[0] * f->l[0] + x->n[1] * f->l[1] + x->n[2] * f->l[2]) * x->n[k] - f->l[k] +
                      urand(-0.05, 0.05);
}

static void test_math(void)
{
    double worst_e = 0.0, worst_l = 0.0;
    for (double x = -120.0; x <= 120.0; x += 0.0137) {
        double r = (double)simd_exp2f((float)x) / exp2((double)(float)x) - 1.0;
        worst_e = fabs(r) > worst_e ? fabs(r) : worst_e;
    }
    for (double x = 1e-30; x < 1.0; x *= 1.0137) {
        double want = log2((double)(float)x), got = (double)simd_log2f((float)x);
        double r = fabs(got - want) / (fabs(want) > 1e-3 ? fabs(want) : 1e-3);
        worst_l = r > worst_l ? r : worst_l;
    }
    printf("exp2 worst relative error %.2e, log2 %.2e\n", worst_e, worst_l);
    CHECK(worst_e < 5e-7);
    CHECK(worst_l < 5e-6);
    CHECK(simd_log2f(1.0f) == 0.0f);
    CHECK(isfinite(simd_exp2f(1e30f)) && simd_exp2f(-1e30f) >= 0.0f && simd_exp2f(-1e30f) < 1e-37f);
}

static void test_against_double(void)
{
    static simd_batch b;
    simd_frame sf;
    frame f;
    sample xs[SIMD_BATCH - 3]; /* not a multiple of 4: the padded lanes must not leak */
    int n = SIMD_BATCH - 3;
    srand(7);
    random_frame(&f);
    for (int i = 0; i < n; i++)
        random_sample(&f, xs + i, i);
    load(&sf, &b, &f, xs, n);
    simd_shade_forward(&sf, &b);
    double worst = 0.0;
    for (int i = 0; i < n; i++) {
        double r[3];
        ref_rad(&f, xs + i, r);
        for (int c = 0; c < 3; c++) {
            /* float n.h carries ~6e-8 relative error, which (n.h)^s multiplies by s */
            double tol = 2e-6 + 1e-7 * xs[i].s;
            double e = fabs((double)b.rad[c][i] - r[c]) / (fabs(r[c]) + 1e-6) / tol;
            worst = e > worst ? e : worst;
            b.gc[c][i] = (float)W[c];
        }
    }
    printf("forward worst relative error / (2e-6 + 1e-7 s) = %.2f\n", worst);
    CHECK(worst < 1.0);
    simd_acc acc;
    memset(&acc, 0, sizeof(acc));
    simd_shade_backward(&sf, &b, &acc);
    group_err ga = {0, 0}, gn = {0, 0}, gv = {0, 0}, gz = {0, 0}, gks = {0, 0}, gs = {0, 0}, gl = {0, 0}, gI = {0, 0},
              gY = {0, 0};
    double sum_l[3] = {0, 0, 0}, sum_I = 0.0, sum_C[3][ENV_SH_N];
    memset(sum_C, 0, sizeof(sum_C));
    for (int i = 0; i < n; i++) {
        sample *x = xs + i;
        for (int k = 0; k < 3; k++) {
            group_add(&ga, (double)b.ga[k][i], fd(&f, x, &x->a[k]));
            group_add(&gn, (double)b.gn[k][i], fd(&f, x, &x->n[k]));
            group_add(&gv, (double)b.gv[k][i], fd(&f, x, &x->v[k]));
            sum_l[k] += fd(&f, x, &f.l[k]);
        }
        group_add(&gz, (double)b.gV[i] * (double)b.dVdz[i], fd(&f, x, &x->z));
        if (x->ks != 0.0) /* the double path has no ks gradient at ks = 0 either */
            group_add(&gks, (double)b.gks[i], fd(&f, x, &x->ks));
        group_add(&gs, (double)b.gs[i], fd(&f, x, &x->s));
        sum_I += fd(&f, x, &f.I);
        for (int c = 0; c < 3; c++)
            for (int j = 0; j < ENV_SH_N; j++)
                sum_C[c][j] += fd(&f, x, &f.C[c][j]);
    }
    for (int k = 0; k < 3; k++)
        group_add(&gl, acc.gl[k], sum_l[k]);
    group_add(&gI, acc.gI, sum_I);
    for (int c = 0; c < 3; c++)
        for (int j = 0; j < ENV_SH_N; j++)
            group_add(&gY, acc.gY[c][j], sum_C[c][j]);
    const group_err *all[] = {&ga, &gn, &gv, &gz, &gks, &gs, &gl, &gI, &gY};
    const char *names[] = {"albedo", "normal", "view", "shadow z", "ks", "shininess", "sun dir", "sun I", "SH"};
    for (int k = 0; k < 9; k++) {
        printf("%-10s relative error %.2e (scale %.2e)\n", names[k], group_rel(all[k]), all[k]->scale);
        CHECK_MSG(group_rel(all[k]) < 1e-3, "group %s", names[k]);
        CHECK(all[k]->scale > 0.0); /* every group was exercised */
    }
}

static int batch_finite(const simd_batch *b, const simd_acc *acc)
{
    int bad = 0;
    for (int i = 0; i < b->n; i++) {
        const float *v[] = {&b->rad[0][i], &b->rad[1][i], &b->rad[2][i], &b->ga[0][i], &b->ga[1][i], &b->ga[2][i],
                            &b->gn[0][i], &b->gn[1][i], &b->gn[2][i], &b->gv[0][i], &b->gv[1][i], &b->gv[2][i],
                            &b->gV[i], &b->dVdz[i], &b->gks[i], &b->gs[i]};
        for (size_t k = 0; k < sizeof(v) / sizeof(v[0]); k++)
            bad += !isfinite(*v[k]);
    }
    for (int k = 0; k < 3; k++)
        bad += !isfinite(acc->gl[k]);
    bad += !isfinite(acc->gI);
    for (int c = 0; c < 3; c++)
        for (int j = 0; j < ENV_SH_N; j++)
            bad += !isfinite(acc->gY[c][j]);
    return bad;
}

static void test_extremes(void)
{
    static simd_batch b;
    simd_frame sf;
    frame f;
    sample xs[SIMD_BATCH];
    srand(11);
    random_frame(&f);
    f.I = 1e5;
    for (int c = 0; c < 3; c++)
        f.C[c][0] = 1e5;
    const double s_vals[] = {1.0, 1e4, 1e4, 2.0};
    const double z_vals[] = {1e6, -1e6, 0.0, 80.5};
    const double a_vals[] = {0.0, 1.0, 1e3, 0.5};
    for (int i = 0; i < SIMD_BATCH; i++) {
        random_sample(&f, xs + i, i);
        xs[i].s = s_vals[i % 4];
        xs[i].z = z_vals[(i / 4) % 4];
        xs[i].ks = i % 2 ? 1.0 : 0.0;
        for (int c = 0; c < 3; c++)
            xs[i].a[c] = a_vals[(i / 16) % 4];
        if (i % 8 == 1) { /* n.l exactly 0, and v = -l (no half vector) */
            xs[i].n[0] = f.l[1], xs[i].n[1] = -f.l[0], xs[i].n[2] = 0.0;
            for (int k = 0; k < 3; k++)
                xs[i].v[k] = -f.l[k];
        }
        if (i % 8 == 3) /* the mirror direction: n.h = 1, P = 1 at s = 1e4 */
            for (int k = 0; k < 3; k++)
                xs[i].v[k] = f.l[k];
    }
    for (int i = 0; i < SIMD_BATCH; i += 8) {
        for (int k = 0; k < 3; k++)
            xs[i + 3].n[k] = f.l[k];
    }
    load(&sf, &b, &f, xs, SIMD_BATCH);
    simd_shade_forward(&sf, &b);
    for (int i = 0; i < SIMD_BATCH; i++)
        for (int c = 0; c < 3; c++)
            b.gc[c][i] = 1e3f;
    simd_acc acc;
    memset(&acc, 0, sizeof(acc));
    simd_shade_backward(&sf, &b, &acc);
    int bad = batch_finite(&b, &acc);
    printf("extremes: %d non-finite values\n", bad);
    CHECK(bad == 0);
    for (int i = 0; i < SIMD_BATCH; i++) {
        CHECK(b.V[i] >= 0.0f && b.V[i] <= 1.0f);
        CHECK(b.P[i] >= 0.0f && b.P[i] <= 1.0f);
    }
    CHECK(b.V[0] < 1e-30f && b.V[4] == 1.0f); /* z = 1e6 fully shadowed, -1e6 fully lit */
}

int main(void)
{
    test_math();
    test_against_double();
    test_extremes();
    return check_exit();
}
