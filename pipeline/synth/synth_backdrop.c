/* SPDX-License-Identifier: MIT */
/*
 * The city backdrop (`--backdrop city`): what a world direction shows of a procedural street panorama at
 * infinity. Camera-orientation tracking from video alone (rotation-only tracking of background features)
 * needs test captures whose background has corners all round and lies far away compared with the arm's
 * motion; the sky map has neither. So the panorama is a pure function of the direction and the seed: three
 * rings of buildings (near, middle, far; random widths, heights, colours, setbacks, window grids, hazier
 * with distance) from below the horizon up to 10-30 deg, the sky above them and a paved ground below whose
 * tiles and value noise fade out where the pixel footprint would alias them. It returns reflectance-like
 * factors; synth.c shades them with the sky (the head's lighting stays the sky's environment map).
 */
#include "pipeline/synth/synth_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

#define DEG (M_PI / 180.0)
#define CITY_LAYERS 3
#define CITY_MAX 256         /* buildings per ring: 360 deg over the narrowest width (1.5 deg) is 240 */
#define FOOT_EL (-3.0 * DEG) /* buildings stand on the ground at this elevation: the street's far kerb */
#define GROUND_H 1.6         /* eye height over the ground plane, metres: scales the paving */

typedef struct city_building {
    double width;            /* azimuth span (rad); it starts at the ring's az0[i] */
    double top;              /* elevation of the roof line (rad); < FOOT_EL: a gap in the ring */
    double up0, up1, up_top; /* a narrower upper block (tower, setback) over [up0, up1] of the width */
    double col, row;         /* window pitch (rad) */
    double win_w, win_h;     /* window size as fractions of the pitch */
    double cornice;          /* height of a dark band under the roof line (rad), 0: none */
    double wall[3], glass[3];
    double lit; /* fraction of windows with the light on */
    uint32_t id;
} city_building;

typedef struct city_ring {
    int n;
    double offset; /* azimuth of the first building's left edge */
    double az0[CITY_MAX];
    city_building b[CITY_MAX];
} city_ring;

struct synth_city {
    city_ring ring[CITY_LAYERS];
    uint64_t seed;
};

/* Per ring, near to far: widths, roof heights, window pitch (deg), chance of a gap, haze. */
static const struct ring_shape {
    double w_lo, w_hi, top_lo, top_hi, pitch_lo, pitch_hi, gap, haze;
} shapes[CITY_LAYERS] = {
    { 3.0, 12.0, 10.0, 30.0, 1.6, 3.0, 0.18, 0.0 },
    { 2.0, 7.0, 6.0, 18.0, 1.1, 1.8, 0.10, 0.3 },
    { 1.5, 5.0, 2.5, 10.0, 0.9, 1.3, 0.0, 0.55 },
};

/* Street colours, linear reflectance: brick, sandstone, concrete, render, dark cladding, ochre, blue, ... */
static const double palette[][3] = {
    { 0.30, 0.13, 0.08 }, { 0.50, 0.42, 0.30 }, { 0.38, 0.37, 0.35 }, { 0.65, 0.63, 0.58 }, { 0.10, 0.11, 0.13 },
    { 0.55, 0.38, 0.16 }, { 0.35, 0.42, 0.50 }, { 0.16, 0.09, 0.07 }, { 0.30, 0.34, 0.30 }, { 0.58, 0.52, 0.48 },
};
#define N_PALETTE ((int)(sizeof(palette) / sizeof(palette[0])))

static double lerp(double a, double b, double t)
{
    return a + (b - a) * t;
}

static void draw_building(synth_rng *r, const struct ring_shape *sh, uint32_t id, city_building *b)
{
    b->id = id;
    b->width = lerp(sh->w_lo, sh->w_hi, synth_rng_uniform(r)) * DEG;
    double u = synth_rng_uniform(r);
    b->top = lerp(sh->top_lo, sh->top_hi, u * u) * DEG; /* more low buildings than towers */
    if (synth_rng_uniform(r) < sh->gap)
        b->top = -M_PI;
    b->up0 = b->up1 = 0.0;
    b->up_top = b->top;
    if (synth_rng_uniform(r) < 0.35) {
        double a = synth_rng_uniform(r), c = synth_rng_uniform(r);
        b->up0 = (0.1 + 0.3 * fmin(a, c)) * b->width;
        b->up1 = (0.6 + 0.3 * fmax(a, c)) * b->width;
        b->up_top = b->top * (1.1 + 0.4 * synth_rng_uniform(r));
    }
    b->col = lerp(sh->pitch_lo, sh->pitch_hi, synth_rng_uniform(r)) * DEG;
    b->row = lerp(sh->pitch_lo, sh->pitch_hi, synth_rng_uniform(r)) * DEG * 1.15;
    b->win_w = lerp(0.35, 0.75, synth_rng_uniform(r));
    if (synth_rng_uniform(r) < 0.15)
        b->win_w = 0.95; /* ribbon windows */
    b->win_h = lerp(0.4, 0.65, synth_rng_uniform(r));
    b->cornice = synth_rng_uniform(r) < 0.4 ? lerp(0.2, 0.5, synth_rng_uniform(r)) * b->row : 0.0;
    int p = (int)(synth_rng_uniform(r) * N_PALETTE);
    double k = lerp(0.75, 1.2, synth_rng_uniform(r));
    for (int c = 0; c < 3; c++)
        b->wall[c] = fmin(palette[p < N_PALETTE ? p : N_PALETTE - 1][c] * k, 0.9);
    int dark = b->wall[0] + b->wall[1] + b->wall[2] < 0.45; /* dark cladding: the glass is the bright part */
    double gk = dark ? lerp(0.25, 0.4, synth_rng_uniform(r)) : lerp(0.05, 0.1, synth_rng_uniform(r));
    b->glass[0] = gk;
    b->glass[1] = gk * 1.1;
    b->glass[2] = gk * 1.3;
    b->lit = 0.15 * synth_rng_uniform(r);
}

int synth_city_build(uint64_t seed, synth_city **out)
{
    synth_city *c = calloc(1, sizeof(*c));
    if (!c)
        return -ENOMEM;
    c->seed = seed;
    for (int l = 0; l < CITY_LAYERS; l++) {
        city_ring *ring = &c->ring[l];
        synth_rng r;
        synth_rng_init(&r, seed, SYNTH_STREAM_BACKDROP, (uint64_t)l);
        ring->offset = 2.0 * M_PI * synth_rng_uniform(&r);
        double sum = 0.0;
        while (ring->n < CITY_MAX && sum < 2.0 * M_PI - 0.5 * shapes[l].w_lo * DEG) {
            city_building *b = &ring->b[ring->n];
            draw_building(&r, &shapes[l], (uint32_t)(l * CITY_MAX + ring->n), b);
            ring->az0[ring->n++] = sum;
            sum += b->width;
        }
        double k = 2.0 * M_PI / sum; /* close the ring exactly */
        for (int i = 0; i < ring->n; i++) {
            ring->az0[i] *= k;
            ring->b[i].width *= k;
            ring->b[i].up0 *= k;
            ring->b[i].up1 *= k;
        }
    }
    *out = c;
    return 0;
}

void synth_city_free(synth_city **c)
{
    if (c) {
        free(*c);
        *c = NULL;
    }
}

/* The building of a ring at azimuth az (rad, any range); *a = azimuth from its left edge. */
static const city_building *ring_at(const city_ring *ring, double az, double *a)
{
    double x = fmod(az - ring->offset, 2.0 * M_PI);
    x += x < 0 ? 2.0 * M_PI : 0.0;
    int lo = 0, hi = ring->n - 1;
    while (lo < hi) { /* last az0 <= x */
        int mid = (lo + hi + 1) / 2;
        if (ring->az0[mid] <= x)
            lo = mid;
        else
            hi = mid - 1;
    }
    *a = x - ring->az0[lo];
    return &ring->b[lo];
}

/* The facade's reflectance at (a, el) inside building b (which covers that point). */
static void facade(const synth_city *c, const city_building *b, double a, double el, double rgb[3])
{
    double roof = a >= b->up0 && a < b->up1 ? b->up_top : b->top;
    double first = FOOT_EL + 1.3 * b->row; /* shop fronts below the first window row */
    const double *col = b->wall;
    double k = 1.0, win[3];
    if (el > roof - b->cornice) {
        k = 0.45;
    } else if (el < first) {
        k = el < FOOT_EL + 0.9 * b->row ? 0.55 : 1.0; /* shade of awnings, then a lintel */
    } else if (el < roof - 0.6 * b->row) {
        int ncol = (int)floor(b->width / b->col - 0.5);
        double x = (a - 0.5 * (b->width - ncol * b->col)) / b->col, y = (el - first) / b->row;
        double ix = floor(x), iy = floor(y), fx = x - ix, fy = y - iy;
        if (ix >= 0 && ix < ncol && fabs(fx - 0.5) < 0.5 * b->win_w && fabs(fy - 0.5) < 0.5 * b->win_h) {
            double h = synth_hash3((int64_t)b->id, (int64_t)ix, (int64_t)iy, c->seed);
            if (h < b->lit) {
                win[0] = 0.85, win[1] = 0.7, win[2] = 0.45;
            } else {
                double v = 0.6 + 0.8 * h; /* curtains, reflections */
                for (int i = 0; i < 3; i++)
                    win[i] = b->glass[i] * v;
            }
            col = win;
        }
    }
    for (int i = 0; i < 3; i++)
        rgb[i] = k * col[i];
}

/* Smooth value noise on the unit lattice, in [0, 1]. */
static double vnoise2(double x, double y, uint64_t seed)
{
    double ix = floor(x), iy = floor(y), fx = x - ix, fy = y - iy;
    fx = fx * fx * (3.0 - 2.0 * fx);
    fy = fy * fy * (3.0 - 2.0 * fy);
    int64_t i = (int64_t)ix, j = (int64_t)iy;
    double a = synth_hash3(i, j, 0, seed), b = synth_hash3(i + 1, j, 0, seed);
    double e = synth_hash3(i, j + 1, 0, seed), f = synth_hash3(i + 1, j + 1, 0, seed);
    return lerp(lerp(a, b, fx), lerp(e, f, fx), fy);
}

/* Weight of a detail `size` metres across seen at `foot` metres per pixel: 1 from 5 pixels up, 0 under 2. */
static double detail(double size, double foot)
{
    double r = foot / size;
    return r <= 0.2 ? 1.0 : r >= 0.5 ? 0.0 : (0.5 - r) / 0.3;
}

/* The paved ground: tiles with grout, worn patches; mean reflectance about 0.2. */
static void ground(const synth_city *c, const double d[3], double px_rad, double rgb[3])
{
    double s = -d[2], t = GROUND_H / s;
    double x = d[0] * t, y = d[1] * t, foot = px_rad * GROUND_H / (s * s);
    double v = 1.0;
    v += 0.5 * detail(6.0, foot) * (vnoise2(x / 6.0, y / 6.0, c->seed + 11) - 0.5);
    v += 0.4 * detail(1.5, foot) * (vnoise2(x / 1.5, y / 1.5, c->seed + 12) - 0.5);
    v += 0.2 * detail(0.25, foot) * (vnoise2(x / 0.25, y / 0.25, c->seed + 13) - 0.5);
    double wt = detail(0.6, foot); /* 0.6 m slabs, each a little different, 4 cm grout */
    if (wt > 0) {
        double u = x / 0.6, w = y / 0.6, iu = floor(u), iw = floor(w);
        double tile = 0.7 + 0.6 * synth_hash3((int64_t)iu, (int64_t)iw, 1, c->seed);
        int grout = u - iu < 0.067 || w - iw < 0.067;
        double mean = 0.933 * 0.933 * 1.0 + (1.0 - 0.933 * 0.933) * 0.45; /* what the fade leaves */
        v *= lerp(mean, grout ? 0.45 : tile, wt);
    }
    static const double stone[3] = { 0.21, 0.2, 0.19 };
    for (int i = 0; i < 3; i++)
        rgb[i] = stone[i] * v;
}

enum synth_city_part synth_city_look(const synth_city *c, const double d[3], double px_rad, double rgb[3], double *haze)
{
    double el = asin(fmin(fmax(d[2], -1.0), 1.0));
    *haze = 0.0;
    if (el < FOOT_EL) {
        ground(c, d, px_rad, rgb);
        double a = -el / DEG; /* the far ground fades into the haze at the buildings' feet */
        *haze = a < 8.0 ? 0.35 * (8.0 - a) / 5.0 : 0.0;
        return SYNTH_CITY_GROUND;
    }
    double az = atan2(d[1], d[0]);
    for (int l = 0; l < CITY_LAYERS; l++) {
        double a;
        const city_building *b = ring_at(&c->ring[l], az, &a);
        double roof = a >= b->up0 && a < b->up1 ? b->up_top : b->top;
        if (el <= roof) {
            facade(c, b, a, el, rgb);
            *haze = shapes[l].haze;
            return SYNTH_CITY_FACADE;
        }
    }
    rgb[0] = rgb[1] = rgb[2] = 1.0;
    return SYNTH_CITY_SKY;
}
