/* SPDX-License-Identifier: MIT */
/*
 * Deterministic randomness (splitmix64 streams, Gaussian by Box-Muller, a
 * lattice hash and value noise for texture fields), the drawn appearance
 * (skin tone, hair, iris, freckles) and the per-cluster specular material.
 */
#include "pipeline/synth/synth_internal.h"

#include <errno.h>
#include <math.h>
#include <string.h>

static uint64_t mix64(uint64_t z)
{
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

void synth_rng_init(synth_rng *r, uint64_t seed, uint64_t stream, uint64_t index)
{
    r->state = mix64(seed + 0x9E3779B97F4A7C15ull * (stream + 1)) ^ mix64(index * 0xD6E8FEB86659FD93ull + stream);
    r->have_spare = 0;
    r->spare = 0.0;
}

uint64_t synth_rng_u64(synth_rng *r) { return mix64(r->state += 0x9E3779B97F4A7C15ull); }

double synth_rng_uniform(synth_rng *r) { return ((double)(synth_rng_u64(r) >> 11) + 0.5) / 9007199254740992.0; }

double synth_rng_gauss(synth_rng *r)
{
    if (r->have_spare) {
        r->have_spare = 0;
        return r->spare;
    }
    double rad = sqrt(-2.0 * log(synth_rng_uniform(r))); /* uniform is never 0 */
    double a = 2.0 * M_PI * synth_rng_uniform(r);
    r->spare = rad * sin(a);
    r->have_spare = 1;
    return rad * cos(a);
}

double synth_hash3(int64_t x, int64_t y, int64_t z, uint64_t seed)
{
    uint64_t h = mix64(seed ^ mix64((uint64_t)x * 0x8CB92BA72F3D8DD7ull) ^
                       mix64((uint64_t)y * 0xABC98388FB8FAC03ull + 1) ^ mix64((uint64_t)z * 0xD1342543DE82EF95ull + 2));
    return (double)(h >> 11) / 9007199254740992.0;
}

/* ---- appearance ---- */

static void lerp_log(const double a[3], const double b[3], double t, double out[3])
{
    for (int i = 0; i < 3; i++)
        out[i] = exp((1.0 - t) * log(a[i]) + t * log(b[i]));
}

void synth_draw_look(sp_synth_selfie *g)
{
    /* linear albedos: light and dark skin ends, hair and iris palettes */
    static const double light[3] = { 0.62, 0.43, 0.34 }, dark[3] = { 0.16, 0.085, 0.06 };
    static const double hairs[4][3] = {
        { 0.045, 0.03, 0.02 }, { 0.02, 0.017, 0.015 }, { 0.32, 0.22, 0.11 }, { 0.26, 0.09, 0.04 } };
    static const double irises[4][3] = {
        { 0.12, 0.06, 0.03 }, { 0.05, 0.025, 0.012 }, { 0.10, 0.16, 0.24 }, { 0.10, 0.14, 0.07 } };
    synth_rng r;
    synth_rng_init(&r, g->s.seed, SYNTH_STREAM_LOOK, 0);
    synth_look *lk = &g->look;
    lk->tone = synth_rng_uniform(&r);
    lerp_log(light, dark, lk->tone, lk->skin);
    int h = (int)(synth_rng_uniform(&r) * 4) & 3;
    if (lk->tone > 0.5) /* darker skin: dark hair and irises */
        h &= 1;
    memcpy(lk->hair, hairs[h], sizeof(lk->hair));
    int e = (int)(synth_rng_uniform(&r) * 4) & 3;
    if (lk->tone > 0.5)
        e &= 1;
    memcpy(lk->iris, irises[e], sizeof(lk->iris));
    lk->freckles = synth_rng_uniform(&r) * (1.0 - lk->tone);
    lk->redness = 0.3 + 0.5 * synth_rng_uniform(&r);
    lk->noise_seed = synth_rng_u64(&r);
}

void synth_draw_materials(sp_synth_selfie *g)
{
    /* per cluster (sp_face_cluster order): skin is shiniest on the forehead and nose (oil), lips are moist */
    static const double ks[SP_RENDER_CLUSTERS] = { 0.07, 0.08, 0.05, 0.05, 0.055, 0.06, 0.045, 0.045, 0.04, 0.035 };
    static const double sh[SP_RENDER_CLUSTERS] = { 35, 40, 22, 22, 25, 30, 25, 25, 18, 15 };
    synth_rng r;
    synth_rng_init(&r, g->s.seed, SYNTH_STREAM_LOOK, 1);
    for (int c = 0; c < SP_RENDER_CLUSTERS; c++) {
        g->ks[c] = ks[c] * (1.0 + 0.3 * (synth_rng_uniform(&r) - 0.5));
        g->shininess[c] = sh[c] * (1.0 + 0.3 * (synth_rng_uniform(&r) - 0.5));
    }
}

/* ---- face frame ---- */

static void lm_pos(const sp_face_model *m, int l, double p[3])
{
    const float *v = m->mesh.positions + (size_t)m->landmarks[l] * 3;
    p[0] = v[0];
    p[1] = v[1];
    p[2] = v[2];
}

static double norm3(const double v[3]) { return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

int synth_face_frame_init(const sp_face_model *m, synth_face_frame *ff)
{
    double a[3], b[3], brow[3] = { 0 }, chin[3], p[3];
    memset(ff, 0, sizeof(*ff));
    for (int l = 36; l < 48; l++) {
        lm_pos(m, l, p);
        for (int k = 0; k < 3; k++)
            ff->o[k] += p[k] / 12.0;
    }
    for (int l = 17; l < 27; l++) {
        lm_pos(m, l, p);
        for (int k = 0; k < 3; k++)
            brow[k] += p[k] / 10.0;
    }
    lm_pos(m, 36, a);
    lm_pos(m, 45, b);
    lm_pos(m, 8, chin);
    double up[3];
    for (int k = 0; k < 3; k++) {
        ff->x[k] = b[k] - a[k];
        up[k] = brow[k] - chin[k];
    }
    ff->unit = norm3(ff->x);
    double un = norm3(up);
    if (!(ff->unit > 1e-6) || !(un > 1e-6))
        return -EINVAL;
    for (int k = 0; k < 3; k++)
        ff->x[k] /= ff->unit;
    double d = up[0] * ff->x[0] + up[1] * ff->x[1] + up[2] * ff->x[2];
    for (int k = 0; k < 3; k++)
        ff->y[k] = up[k] - d * ff->x[k];
    double yn = norm3(ff->y);
    if (!(yn > 1e-6))
        return -EINVAL;
    for (int k = 0; k < 3; k++)
        ff->y[k] /= yn;
    ff->z[0] = ff->x[1] * ff->y[2] - ff->x[2] * ff->y[1];
    ff->z[1] = ff->x[2] * ff->y[0] - ff->x[0] * ff->y[2];
    ff->z[2] = ff->x[0] * ff->y[1] - ff->x[1] * ff->y[0];
    return 0;
}
