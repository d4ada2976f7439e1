/* SPDX-License-Identifier: MIT */
/*
 * The street generator (sp_synth_street_write, `sunprobe synth street`): a
 * static camera watching a street with ground truth for the scene probe. A pinhole camera above a ground plane; static occluders
 * at known depths (a lamp pole with a sign board, a second pole); an unseen wall to
 * the left whose shadow is "pre-existing shadow"; walking figures of known
 * height (billboards with a head, torso and swinging legs); cars driving past
 * on the road behind them (side-view billboards: body, cabin, windows, wheels,
 * and the shade under them); a sun casting
 * shadows of everything onto the ground, or an overcast sky with none but the
 * soft darkening at each figure's feet.
 * Indoors (`--indoor`): a hall instead, a back wall where the sky was, a
 * wooden floor, a counter, a cabinet and a chair's back as the occluders, and
 * no sun. Optional camera pan (a moving camera) and no figures at all, for the
 * bad-input tests.
 *
 * Beside OUT (PREFIX = OUT without ".spcap"): PREFIX.truth.json (camera, sun,
 * figures, occluders, and sample ground points with the true person height and
 * shadow direction), PREFIX.background.png (the empty street), and 16-bit PGMs
 * PREFIX.hidden-far.pgm / PREFIX.hidden-near.pgm (per pixel, 1 + the farthest /
 * nearest foot row of the figures a static occluder hid there, 0 none) and
 * PREFIX.seen-far.pgm (1 + the farthest foot row of the figures seen there) and
 * PREFIX.hidden-count.pgm (figure-frames a static occluder hid there). The
 * truth's "car_views" lists every frame's view of every car (its box, whether
 * the image border cuts it), for scoring object classes; cars are not figures
 * in the occlusion truth.
 * Coordinates follow the probe: pixel centres at integers.
 */
#include "sunprobe/sp_synth.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/atomic_file.h"
#include "common/file_set.h"
#include "common/jpeg.h"
#include "common/json.h"
#include "common/progress.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_math.h"

#define MAX_FIGURES SP_SYNTH_STREET_MAX_FIGURES
#define MAX_CARS SP_SYNTH_STREET_MAX_CARS
#define N_STATIC 3
#define N_TRUTH 6 /* ground-truth files beside the capture */

typedef sp_synth_street_settings street_args;

typedef struct camera {
    uint32_t w, h;
    double f, cx, cy;
    sp_vec3 pos, fwd, right, down;
} camera;

/* A vertical board: drawn facing the camera at depth y, shadows cast as if facing the sun. */
typedef struct board {
    double x, y, half_w, z0, z1;
    uint8_t rgb[3];
} board;

typedef struct figure {
    double height, x0, y0, x1, y1, speed, t0;
    double stop_m, stop_s; /* stands still for stop_s seconds after walking stop_m metres */
    uint8_t shirt[3], pants[3];
} figure;

/* A car: a side-view billboard at depth y, driving along x from x0 to x1. */
typedef struct car {
    double length, height, y, x0, x1, speed, t0;
    uint8_t body[3];
} car;

typedef struct scene {
    street_args a;
    const char *out;      /* the capture's path; the truth files are named after it */
    camera cam;
    sp_vec3 sun;          /* unit vector towards the sun */
    double ambient, sun_ground, sun_figure;
    board occ[N_STATIC];
    double wall_x, wall_y0, wall_y1, wall_h; /* shadow-only wall (off to the left) */
    double back_y;                           /* indoors: the hall's back wall, facing the camera */
    figure fig[MAX_FIGURES];
    unsigned n_fig;
    car cars[MAX_CARS];
    unsigned n_car;
    sp_strbuf car_views; /* truth: "[frame,car,x0,y0,x1,y1,cut]" per car and frame it is in view */
    /* the static image */
    uint8_t *bg, *ground_dark, *kind, *static_shadow;
    float *depth, *gx, *gy;
    /* truth accumulators */
    uint16_t *hidden_far, *hidden_near, *seen_far, *hidden_count;
    uint8_t *frame;
    uint8_t *car_px; /* this frame: pixels a car was drawn on (the shadows and shades on the ground skip them) */
} scene;

enum { KIND_SKY = 0, KIND_GROUND = 1, KIND_OCCLUDER = 2 };
enum { PART_NONE = 0, PART_PANTS = 1, PART_SHIRT = 2, PART_SKIN = 3, PART_BODY = 4, PART_GLASS = 5, PART_WHEEL = 6 };

/* ---- camera ---- */

static void camera_setup(camera *c, const street_args *a, double yaw_deg)
{
    double th = a->pitch_deg * M_PI / 180.0, ps = yaw_deg * M_PI / 180.0;
    c->w = a->width, c->h = a->height;
    c->f = 0.5 * a->width / tan(0.5 * a->hfov_deg * M_PI / 180.0);
    c->cx = 0.5 * a->width, c->cy = 0.5 * a->height;
    c->pos = (sp_vec3){ 0, 0, a->camera_height_m };
    c->fwd = (sp_vec3){ sin(ps) * cos(th), cos(ps) * cos(th), -sin(th) };
    c->right = (sp_vec3){ cos(ps), -sin(ps), 0 };
    c->down = (sp_vec3){ -sin(ps) * sin(th), -cos(ps) * sin(th), -cos(th) };
}

/* Continuous image coordinates (pixel i spans [i, i+1)); 0 when behind the camera. */
static int project(const camera *c, sp_vec3 p, double *u, double *v)
{
    sp_vec3 r = sp_vec3_sub(p, c->pos);
    double zc = sp_vec3_dot(r, c->fwd);
    if (zc < 1e-6)
        return 0;
    *u = c->cx + c->f * sp_vec3_dot(r, c->right) / zc;
    *v = c->cy + c->f * sp_vec3_dot(r, c->down) / zc;
    return 1;
}

static sp_vec3 ray_dir(const camera *c, double u, double v)
{
    sp_vec3 d = sp_vec3_add(c->fwd, sp_vec3_scale(c->right, (u - c->cx) / c->f));
    return sp_vec3_add(d, sp_vec3_scale(c->down, (v - c->cy) / c->f));
}

/* ---- deterministic noise ---- */

static uint32_t hash32(uint32_t a, uint32_t b, uint32_t c)
{
    uint32_t h = a * 0x9E3779B1u ^ (b + 0x7F4A7C15u) * 0x85EBCA77u ^ (c + 0x165667B1u) * 0xC2B2AE3Du;
    h ^= h >> 15;
    h *= 0x2C1B3C6Du;
    h ^= h >> 12;
    h *= 0x297A2D39u;
    return h ^ (h >> 15);
}

static double unit_hash(uint32_t a, uint32_t b, uint32_t c)
{
    return (hash32(a, b, c) >> 8) * (1.0 / 16777216.0);
}

/* Smooth value noise on the ground plane, 0..1. */
static double value_noise(double x, double y, uint32_t seed)
{
    double fx = floor(x), fy = floor(y), ax = x - fx, ay = y - fy;
    uint32_t ix = (uint32_t)(int32_t)fx, iy = (uint32_t)(int32_t)fy;
    double v00 = unit_hash(ix, iy, seed), v10 = unit_hash(ix + 1, iy, seed);
    double v01 = unit_hash(ix, iy + 1, seed), v11 = unit_hash(ix + 1, iy + 1, seed);
    ax = ax * ax * (3 - 2 * ax), ay = ay * ay * (3 - 2 * ay);
    return (v00 * (1 - ax) + v10 * ax) * (1 - ay) + (v01 * (1 - ax) + v11 * ax) * ay;
}

static void ground_albedo(const scene *s, double x, double y, double out[3])
{
    if (s->a.indoor) { /* oak boards 0.15 m wide running away from the camera, each its own shade */
        double plank = floor(x / 0.15),
               g = 0.8 + 0.12 * unit_hash((uint32_t)(int32_t)plank, 7, (uint32_t)s->a.seed) +
            0.08 * value_noise(x * 9, y * 0.8, (uint32_t)s->a.seed + 5);
        out[0] = 150 * g, out[1] = 112 * g, out[2] = 76 * g;
        return;
    }
    double n = 0.7 * value_noise(x * 0.7, y * 0.7, (uint32_t)s->a.seed) + 0.3 * value_noise(x * 3, y * 3, 99);
    double g = 0.78 + 0.22 * n;
    out[0] = 112 * g, out[1] = 110 * g, out[2] = 104 * g;
}

/* ---- shadows ---- */

/* Does the ray from p towards the sun cross the board standing at (x, y) turned to face the sun? */
static int board_blocks(const scene *s, const board *b, sp_vec3 p)
{
    double nx = s->sun.x, ny = s->sun.y, len = hypot(nx, ny);
    if (!(len > 1e-9))
        return 0;
    nx /= len, ny /= len;
    double denom = s->sun.x * nx + s->sun.y * ny;
    double t = ((b->x - p.x) * nx + (b->y - p.y) * ny) / denom;
    if (t <= 1e-6)
        return 0;
    double qx = p.x + t * s->sun.x, qy = p.y + t * s->sun.y, qz = p.z + t * s->sun.z;
    double lateral = (qx - b->x) * -ny + (qy - b->y) * nx;
    return fabs(lateral) <= b->half_w && qz >= b->z0 && qz <= b->z1;
}

static int wall_blocks(const scene *s, sp_vec3 p)
{
    if (s->sun.x >= -1e-9 || p.x <= s->wall_x)
        return 0;
    double t = (s->wall_x - p.x) / s->sun.x, qy = p.y + t * s->sun.y, qz = p.z + t * s->sun.z;
    return qy >= s->wall_y0 && qy <= s->wall_y1 && qz >= 0 && qz <= s->wall_h;
}

static int static_shadow_at(const scene *s, sp_vec3 p)
{
    if (s->a.overcast)
        return 0;
    if (wall_blocks(s, p))
        return 1;
    for (int i = 0; i < N_STATIC; i++)
        if (board_blocks(s, &s->occ[i], p))
            return 1;
    return 0;
}

/* ---- figures ---- */

/* Position at time t; 0 when the figure is not in the scene. */
static int figure_at(const figure *f, double t, double *x, double *y, double *phase)
{
    double len = hypot(f->x1 - f->x0, f->y1 - f->y0), d = (t - f->t0) * f->speed;
    int standing = f->stop_s > 0 && d > f->stop_m && d <= f->stop_m + f->stop_s * f->speed;
    if (f->stop_s > 0 && d > f->stop_m) /* the time spent standing is not walked */
        d = standing ? f->stop_m : d - f->stop_s * f->speed;
    if (d < 0 || d > len || !(len > 0))
        return 0;
    *x = f->x0 + (f->x1 - f->x0) * d / len;
    *y = f->y0 + (f->y1 - f->y0) * d / len;
    *phase = standing ? 0.0 : d / (0.7 * f->height) * M_PI; /* a stride of about 0.7 h; feet together standing */
    return 1;
}

static int silhouette(double h, double s, double z, double phase)
{
    if (z < 0 || z > h)
        return PART_NONE;
    double hc = h - 0.065 * h, r = 0.065 * h;
    if (s * s + (z - hc) * (z - hc) <= r * r)
        return PART_SKIN;
    if (z >= 0.83 * h && z < hc && fabs(s) <= 0.035 * h)
        return PART_SKIN;
    if (z >= 0.47 * h && z < 0.83 * h && fabs(s) <= 0.125 * h)
        return PART_SHIRT;
    if (z < 0.47 * h) {
        double spread = 0.04 * h + 0.14 * h * fabs(sin(phase)) * (1.0 - z / (0.47 * h));
        if (fabs(s - spread) <= 0.045 * h || fabs(s + spread) <= 0.045 * h)
            return PART_PANTS;
    }
    return PART_NONE;
}

static void make_figures(scene *s)
{
    static const uint8_t shirts[][3] = { { 200, 40, 40 },  { 40, 160, 60 },  { 220, 190, 30 }, { 140, 50, 170 },
                                         { 230, 120, 30 }, { 30, 150, 200 }, { 240, 240, 235 }, { 180, 30, 110 } };
    static const uint8_t pants[][3] = { { 40, 50, 120 }, { 90, 60, 40 }, { 20, 20, 25 }, { 150, 140, 120 } };
    uint32_t seed = (uint32_t)s->a.seed;
    s->n_fig = s->a.figures;
    for (unsigned i = 0; i < s->n_fig; i++) {
        figure *f = &s->fig[i];
        double r[6];
        for (int k = 0; k < 6; k++)
            r[k] = unit_hash(seed, i, (uint32_t)k + 11);
        f->height = 1.6 + 0.3 * r[0];
        /* depths straddle the occluders: some walk behind the pole and the pillar, some in front */
        double depth = 6.5 + 9.0 * ((i * 0.618034 + r[1] * 0.3) - floor(i * 0.618034 + r[1] * 0.3));
        int left_to_right = r[2] < 0.5;
        f->x0 = left_to_right ? -9 : 9, f->x1 = -f->x0;
        f->y0 = depth + 2.0 * (r[3] - 0.5), f->y1 = depth - 2.0 * (r[3] - 0.5);
        f->speed = 1.1 + 0.5 * r[4];
        double span = s->a.seconds - 8.0 > 1.0 ? s->a.seconds - 8.0 : 1.0;
        f->t0 = -3.0 + span * ((double)i + r[5] * 0.8) / (s->n_fig ? s->n_fig : 1);
        f->stop_m = f->stop_s = 0;
        if (s->a.linger_s > 0 && i % 2) { /* stops where the camera sees it, x within +-5 m */
            double len = hypot(f->x1 - f->x0, f->y1 - f->y0);
            f->stop_m = len * (0.25 + 0.5 * unit_hash(seed, i, 17));
            double lo = s->a.linger_s < 5 ? s->a.linger_s : 5;
            f->stop_s = lo + (s->a.linger_s - lo) * unit_hash(seed, i, 18);
        }
        memcpy(f->shirt, shirts[(i + (unsigned)(r[5] * 3)) % 8], 3);
        memcpy(f->pants, pants[i % 4], 3);
    }
}

/*
 * A car's side profile, s along it from its centre, z up from the ground: a body from the sills to the
 * waist, a cabin narrowing to the roof with windows in it, wheels under the sills (the ground shows
 * between them). Proportions of a hatchback or saloon.
 */
static int car_part(const car *c, double s, double z)
{
    double L = c->length, H = c->height, half = 0.5 * L, wheel_r = 0.16 * H + 0.1;
    for (int k = -1; k <= 1; k += 2) {
        double ds = s - k * 0.31 * L, dz = z - wheel_r;
        if (ds * ds + dz * dz <= wheel_r * wheel_r)
            return PART_WHEEL;
    }
    double waist = 0.58 * H;
    if (z >= 0.22 * H && z < waist && fabs(s) <= half)
        return PART_BODY;
    if (z >= waist && z <= H) { /* the cabin: 0.62 L at the waist, 0.4 L at the roof, set back a little */
        double u = (z - waist) / (H - waist), cs = s + 0.04 * L, hw = L * (0.31 - 0.11 * u);
        if (fabs(cs) > hw)
            return PART_NONE;
        return u > 0.12 && u < 0.88 && fabs(cs) < hw - 0.08 && fabs(cs - 0.02 * L) > 0.04 ? PART_GLASS : PART_BODY;
    }
    return PART_NONE;
}

static int car_at(const car *c, double t, double *x)
{
    double d = (t - c->t0) * c->speed, len = fabs(c->x1 - c->x0);
    if (d < 0 || d > len)
        return 0;
    *x = c->x0 + (c->x1 > c->x0 ? d : -d);
    return 1;
}

/*
 * Cars on two lanes 18.5 and 21 m out (behind every walker: they never hide one), in turn in each
 * direction, entering and leaving the view; 7-11 m/s, 3.9-4.6 m long, 1.4-1.55 m tall.
 */
static const double car_lanes[2] = { 21.0, 18.5 }; /* far, near: drawn in this order */

static void make_cars(scene *s)
{
    static const uint8_t paint[][3] = { { 180, 30, 35 }, { 35, 60, 140 },   { 215, 215, 210 },
                                        { 40, 40, 45 },  { 120, 125, 130 }, { 200, 160, 40 } };
    uint32_t seed = (uint32_t)s->a.seed;
    s->n_car = s->a.cars;
    for (unsigned i = 0; i < s->n_car; i++) {
        car *c = &s->cars[i];
        double r[5];
        for (int k = 0; k < 5; k++)
            r[k] = unit_hash(seed, i, (uint32_t)k + 41);
        c->length = 3.9 + 0.7 * r[0];
        c->height = 1.4 + 0.15 * r[1];
        c->y = car_lanes[i % 2 ? 0 : 1];
        double reach = c->y * tan(0.5 * s->a.hfov_deg * M_PI / 180.0) + c->length + 1.0;
        c->x0 = i % 2 ? reach : -reach, c->x1 = -c->x0;
        c->speed = 7.0 + 4.0 * r[2];
        c->t0 = s->a.seconds * ((double)i + 0.2 + 0.6 * r[3]) / s->n_car - 2.0;
        memcpy(c->body, paint[(i + (unsigned)(r[4] * 6)) % 6], 3);
    }
}

/* ---- the static image ---- */

static void setup_scene(scene *s)
{
    double az = s->a.sun_azimuth_deg * M_PI / 180.0, el = s->a.sun_elevation_deg * M_PI / 180.0;
    s->sun = (sp_vec3){ sin(az) * cos(el), cos(az) * cos(el), sin(el) };
    s->ambient = s->a.overcast ? 1.15 : 0.55;
    s->sun_ground = s->a.overcast ? 0 : 1.25 * s->sun.z;
    s->sun_figure = s->a.overcast ? 0 : 0.6;
    if (s->a.indoor) {
        s->occ[0] = (board){ -1.6, 10.0, 0.9, 0.0, 0.95, { 70, 90, 120 } };  /* a counter, hiding legs */
        s->occ[1] = (board){ 2.3, 12.5, 0.45, 0.0, 1.9, { 225, 225, 215 } }; /* a tall white cabinet */
        s->occ[2] = (board){ 0.4, 8.2, 0.22, 0.45, 0.95, { 60, 45, 35 } };   /* a chair's back, its legs unseen */
        s->back_y = 19.0;
    } else {
        s->occ[0] = (board){ 1.0, 11.0, 0.06, 0.0, 3.8, { 95, 105, 100 } };    /* lamp pole */
        s->occ[1] = (board){ 1.0, 10.97, 0.45, 1.05, 1.45, { 30, 125, 140 } }; /* sign on the pole */
        s->occ[2] = (board){ -2.0, 9.0, 0.07, 0.0, 3.4, { 160, 125, 100 } };   /* a second, brown pole */
    }
    s->wall_x = -7.0, s->wall_y0 = 0.0, s->wall_y1 = 40.0, s->wall_h = 3.0;
    make_figures(s);
    make_cars(s);
}

/* Nearest static board hit along a camera ray: distance t, or INFINITY. */
static double board_hit(const scene *s, sp_vec3 d, int *which)
{
    double best = (double)INFINITY;
    for (int i = 0; i < N_STATIC; i++) {
        const board *b = &s->occ[i];
        if (d.y <= 1e-9)
            continue;
        double t = (b->y - s->cam.pos.y) / d.y;
        sp_vec3 q = sp_vec3_add(s->cam.pos, sp_vec3_scale(d, t));
        if (t > 0 && t < best && fabs(q.x - b->x) <= b->half_w && q.z >= b->z0 && q.z <= b->z1) {
            best = t;
            *which = i;
        }
    }
    return best;
}

static void put_rgb(uint8_t *p, const double c[3])
{
    for (int k = 0; k < 3; k++)
        p[k] = (uint8_t)(c[k] < 0 ? 0 : c[k] > 255 ? 255 : lrint(c[k]));
}

static void render_static_pixel(scene *s, uint32_t x, uint32_t y)
{
    size_t i = (size_t)y * s->cam.w + x;
    sp_vec3 d = ray_dir(&s->cam, x + 0.5, y + 0.5);
    int which = -1;
    double tb = board_hit(s, d, &which), tg = d.z < -1e-9 ? -s->cam.pos.z / d.z : (double)INFINITY;
    double tw = s->a.indoor && d.y > 1e-9 ? (s->back_y - s->cam.pos.y) / d.y : (double)INFINITY;
    if (tw < tg) /* the back wall stands on the floor: beyond it the floor is not seen */
        tg = (double)INFINITY;
    double c[3];
    s->depth[i] = (float)fmin(tb, tg);
    if (isfinite(tb) && tb < tg) {
        const board *b = &s->occ[which];
        double lit = s->ambient + (s->a.overcast ? 0 : 0.35);
        for (int k = 0; k < 3; k++)
            c[k] = b->rgb[k] * lit;
        s->kind[i] = KIND_OCCLUDER;
    } else if (isfinite(tg) && tg < 400) {
        sp_vec3 g = sp_vec3_add(s->cam.pos, sp_vec3_scale(d, tg));
        double alb[3], dark[3];
        ground_albedo(s, g.x, g.y, alb);
        int shadowed = static_shadow_at(s, g);
        for (int k = 0; k < 3; k++) {
            dark[k] = alb[k] * s->ambient;
            c[k] = shadowed ? dark[k] : alb[k] * (s->ambient + s->sun_ground);
        }
        put_rgb(s->ground_dark + 3 * i, dark);
        s->kind[i] = KIND_GROUND;
        s->static_shadow[i] = (uint8_t)shadowed;
        s->gx[i] = (float)g.x, s->gy[i] = (float)g.y;
    } else if (isfinite(tw)) { /* plaster, a skirting board at its foot */
        sp_vec3 q = sp_vec3_add(s->cam.pos, sp_vec3_scale(d, tw));
        double g = q.z < 0.12 ? 0.45 : 0.92 + 0.05 * value_noise(q.x * 2, q.z * 2, 3);
        c[0] = 205 * g * s->ambient, c[1] = 196 * g * s->ambient, c[2] = 178 * g * s->ambient;
        s->depth[i] = (float)tw;
        s->kind[i] = KIND_SKY; /* background nobody walks on or behind */
    } else {
        c[0] = 185, c[1] = 205, c[2] = 230;
        s->kind[i] = KIND_SKY;
    }
    put_rgb(s->bg + 3 * i, c);
}

static void render_static(scene *s)
{
    for (uint32_t y = 0; y < s->cam.h; y++)
        for (uint32_t x = 0; x < s->cam.w; x++)
            render_static_pixel(s, x, y);
}

/* ---- one frame ---- */

typedef struct box {
    int x0, y0, x1, y1;
} box;

static box box_of(const scene *s, const sp_vec3 *pts, int n)
{
    box b = { INT32_MAX, INT32_MAX, -1, -1 };
    for (int i = 0; i < n; i++) {
        double u, v;
        if (!project(&s->cam, pts[i], &u, &v))
            continue;
        b.x0 = (int)fmin(b.x0, floor(u) - 2), b.x1 = (int)fmax(b.x1, ceil(u) + 2);
        b.y0 = (int)fmin(b.y0, floor(v) - 2), b.y1 = (int)fmax(b.y1, ceil(v) + 2);
    }
    b.x0 = b.x0 < 0 ? 0 : b.x0, b.y0 = b.y0 < 0 ? 0 : b.y0;
    b.x1 = b.x1 >= (int)s->cam.w ? (int)s->cam.w - 1 : b.x1;
    b.y1 = b.y1 >= (int)s->cam.h ? (int)s->cam.h - 1 : b.y1;
    return b;
}

/* A billboard's side profile: its part at lateral offset `lateral` and height z (PART_NONE: not there). */
typedef int (*profile_fn)(const void *obj, double lateral, double z, double phase);

static int figure_profile(const void *obj, double lateral, double z, double phase)
{
    return silhouette(((const figure *)obj)->height, lateral, z, phase);
}

static int car_profile(const void *obj, double lateral, double z, double phase)
{
    (void)phase;
    return car_part(obj, lateral, z);
}

/*
 * The sun's shadow of a billboard standing at (fx, fy), `height` tall and reaching `w` to either side: each
 * ground pixel is traced towards the sun to the billboard turned to face it.
 */
static void draw_shadow(scene *s, profile_fn profile, const void *obj, double height, double w, double fx, double fy,
                        double phase)
{
    if (s->a.overcast || !(s->sun.z > 0.05))
        return;
    double k = height / s->sun.z, tx = fx - k * s->sun.x, ty = fy - k * s->sun.y;
    sp_vec3 pts[4] = { { fx - w, fy - w, 0 }, { fx + w, fy + w, 0 }, { tx - w, ty - w, 0 }, { tx + w, ty + w, 0 } };
    box b = box_of(s, pts, 4);
    double nx = s->sun.x, ny = s->sun.y, len = hypot(nx, ny);
    if (!(len > 1e-9))
        return;
    nx /= len, ny /= len;
    for (int y = b.y0; y <= b.y1; y++)
        for (int x = b.x0; x <= b.x1; x++) {
            size_t i = (size_t)y * s->cam.w + (size_t)x;
            if (s->kind[i] != KIND_GROUND || s->static_shadow[i] || s->car_px[i])
                continue;
            sp_vec3 g = { s->gx[i], s->gy[i], 0 };
            double t = ((fx - g.x) * nx + (fy - g.y) * ny) / (s->sun.x * nx + s->sun.y * ny);
            if (t <= 0)
                continue;
            double qx = g.x + t * s->sun.x, qy = g.y + t * s->sun.y, qz = t * s->sun.z;
            double lateral = (qx - fx) * -ny + (qy - fy) * nx;
            if (profile(obj, lateral, qz, phase))
                memcpy(s->frame + 3 * i, s->ground_dark + 3 * i, 3);
        }
}

/*
 * Under an overcast sky a person still darkens the ground at their feet: their body hides part of the sky
 * from it (ambient occlusion). A soft disc, CONTACT_DEPTH darker at the feet and fading quadratically to
 * nothing at CONTACT_REACH of the height, about what a 1.7 m person does to the sky's light on paving.
 */
#define CONTACT_DEPTH 0.35
#define CONTACT_REACH 0.35
static void draw_figure_contact(scene *s, const figure *f, double fx, double fy)
{
    if (!s->a.overcast)
        return;
    double R = CONTACT_REACH * f->height;
    sp_vec3 pts[4] = { { fx - R, fy - R, 0 }, { fx + R, fy - R, 0 }, { fx - R, fy + R, 0 }, { fx + R, fy + R, 0 } };
    box b = box_of(s, pts, 4);
    for (int y = b.y0; y <= b.y1; y++)
        for (int x = b.x0; x <= b.x1; x++) {
            size_t i = (size_t)y * s->cam.w + (size_t)x;
            double r = hypot((double)s->gx[i] - fx, (double)s->gy[i] - fy);
            if (s->kind[i] != KIND_GROUND || s->car_px[i] || !(r < R))
                continue;
            double k = 1 - CONTACT_DEPTH * (1 - r / R) * (1 - r / R);
            for (int c = 0; c < 3; c++)
                s->frame[3 * i + c] = (uint8_t)lrint(s->frame[3 * i + c] * k);
        }
}

static void truth_min(uint16_t *m, size_t i, uint16_t v)
{
    if (!m[i] || v < m[i])
        m[i] = v;
}

/* Where pixel (x, y)'s ray meets a billboard standing at depth `board_y`: distance t and point q; 0: it does not. */
static int billboard_point(const scene *s, int x, int y, double board_y, double *t, sp_vec3 *q)
{
    sp_vec3 d = ray_dir(&s->cam, x + 0.5, y + 0.5);
    if (d.y <= 1e-9)
        return 0;
    *t = (board_y - s->cam.pos.y) / d.y;
    *q = sp_vec3_add(s->cam.pos, sp_vec3_scale(d, *t));
    return 1;
}

static void draw_figure(scene *s, const figure *f, double fx, double fy, double phase)
{
    double w = 0.3 * f->height;
    sp_vec3 pts[4] = { { fx - w, fy, 0 }, { fx + w, fy, 0 }, { fx - w, fy, f->height }, { fx + w, fy, f->height } };
    box b = box_of(s, pts, 4);
    double uf, vf;
    if (!project(&s->cam, (sp_vec3){ fx, fy, 0 }, &uf, &vf))
        return;
    uint16_t foot = (uint16_t)(vf - 1.0 < 0 ? 1 : lrint(vf - 1.0) + 1); /* 1 + the probe's foot row */
    for (int y = b.y0; y <= b.y1; y++)
        for (int x = b.x0; x <= b.x1; x++) {
            double t;
            sp_vec3 q;
            if (!billboard_point(s, x, y, fy, &t, &q))
                continue;
            int part = silhouette(f->height, q.x - fx, q.z, phase);
            size_t i = (size_t)y * s->cam.w + (size_t)x;
            if (!part)
                continue;
            if (t > (double)s->depth[i]) { /* behind a static occluder or beyond the ground: hidden */
                if (s->kind[i] == KIND_OCCLUDER) {
                    s->hidden_count[i] += s->hidden_count[i] < UINT16_MAX;
                    truth_min(s->hidden_far, i, foot);
                    s->hidden_near[i] = foot > s->hidden_near[i] ? foot : s->hidden_near[i];
                }
                continue;
            }
            truth_min(s->seen_far, i, foot);
            static const uint8_t skin[3] = { 225, 180, 150 };
            const uint8_t *base = part == PART_SKIN ? skin : part == PART_SHIRT ? f->shirt : f->pants;
            double lit = s->ambient + (static_shadow_at(s, q) ? 0 : s->sun_figure), c[3];
            for (int k = 0; k < 3; k++)
                c[k] = base[k] * lit * 0.8;
            put_rgb(s->frame + 3 * i, c);
        }
}

/* The ground under a car, shaded by it from the sun and most of the sky. */
static void draw_car_shade(scene *s, const car *c, double cx)
{
    double hl = 0.5 * c->length, hw = 0.9;
    sp_vec3 pts[4] = {
        { cx - hl, c->y - hw, 0 }, { cx + hl, c->y - hw, 0 }, { cx - hl, c->y + hw, 0 }, { cx + hl, c->y + hw, 0 }
    };
    box b = box_of(s, pts, 4);
    for (int y = b.y0; y <= b.y1; y++)
        for (int x = b.x0; x <= b.x1; x++) {
            size_t i = (size_t)y * s->cam.w + (size_t)x;
            if (s->kind[i] == KIND_GROUND && !s->car_px[i] && fabs((double)s->gx[i] - cx) <= hl &&
                fabs((double)s->gy[i] - c->y) <= hw)
                for (int k = 0; k < 3; k++)
                    s->frame[3 * i + k] = (uint8_t)lrint(s->ground_dark[3 * i + k] * 0.6);
        }
}

/* A car at (cx, c->y); its view goes to the truth's car_views (the box of its outline, cut by the border or not). */
static void draw_car(scene *s, const car *c, unsigned id, double cx, uint64_t frame)
{
    double hl = 0.5 * c->length;
    sp_vec3 pts[4] = {
        { cx - hl, c->y, 0 }, { cx + hl, c->y, 0 }, { cx - hl, c->y, c->height }, { cx + hl, c->y, c->height }
    };
    double u0 = (double)INFINITY, u1 = -(double)INFINITY, v0 = (double)INFINITY, v1 = -(double)INFINITY;
    for (int k = 0; k < 4; k++) {
        double u, v;
        if (!project(&s->cam, pts[k], &u, &v))
            return;
        u0 = fmin(u0, u), u1 = fmax(u1, u), v0 = fmin(v0, v), v1 = fmax(v1, v);
    }
    if (u1 < 0 || v1 < 0 || u0 > s->cam.w || v0 > s->cam.h)
        return;
    int cut = u0 < 0 || v0 < 0 || u1 > s->cam.w || v1 > s->cam.h;
    sp_strbuf_printf(&s->car_views, "%s[%llu,%u,%d,%d,%d,%d,%d]", s->car_views.len ? "," : "",
                     (unsigned long long)frame, id, (int)fmax(floor(u0), 0), (int)fmax(floor(v0), 0),
                     (int)fmin(ceil(u1), s->cam.w - 1), (int)fmin(ceil(v1), s->cam.h - 1), cut);
    draw_car_shade(s, c, cx);
    draw_shadow(s, car_profile, c, c->height, hl + 0.3, cx, c->y, 0);
    box b = box_of(s, pts, 4);
    for (int y = b.y0; y <= b.y1; y++)
        for (int x = b.x0; x <= b.x1; x++) {
            double t;
            sp_vec3 q;
            if (!billboard_point(s, x, y, c->y, &t, &q))
                continue;
            int part = car_part(c, q.x - cx, q.z);
            size_t i = (size_t)y * s->cam.w + (size_t)x;
            if (!part || t > (double)s->depth[i])
                continue;
            s->car_px[i] = 1;
            static const uint8_t glass[3] = { 45, 55, 65 }, tyre[3] = { 25, 25, 28 };
            const uint8_t *base = part == PART_GLASS ? glass : part == PART_WHEEL ? tyre : c->body;
            double lit = s->ambient + (static_shadow_at(s, q) ? 0 : s->sun_figure), col[3];
            for (int k = 0; k < 3; k++)
                col[k] = base[k] * lit * 0.8;
            put_rgb(s->frame + 3 * i, col);
        }
}

static void render_frame(scene *s, uint64_t index, double t)
{
    if (s->a.pan_deg_s != 0) {
        camera_setup(&s->cam, &s->a, s->a.pan_deg_s * t);
        render_static(s);
    }
    memcpy(s->frame, s->bg, (size_t)s->cam.w * s->cam.h * 3);
    memset(s->car_px, 0, (size_t)s->cam.w * s->cam.h);
    for (int lane = 0; lane < 2; lane++) /* behind every walker; the far lane first */
        for (unsigned i = 0; i < s->n_car; i++) {
            double cx;
            if (s->cars[i].y == car_lanes[lane] && car_at(&s->cars[i], t, &cx))
                draw_car(s, &s->cars[i], i, cx, index);
        }
    double fx[MAX_FIGURES], fy[MAX_FIGURES], ph[MAX_FIGURES];
    int on[MAX_FIGURES], order[MAX_FIGURES], n = 0;
    for (unsigned i = 0; i < s->n_fig; i++) {
        on[i] = figure_at(&s->fig[i], t, &fx[i], &fy[i], &ph[i]);
        if (on[i]) {
            draw_shadow(s, figure_profile, &s->fig[i], s->fig[i].height, 0.4 * s->fig[i].height, fx[i], fy[i], ph[i]);
            draw_figure_contact(s, &s->fig[i], fx[i], fy[i]);
            order[n++] = (int)i;
        }
    }
    for (int i = 1; i < n; i++) /* far to near */
        for (int j = i; j > 0 && fy[order[j - 1]] < fy[order[j]]; j--) {
            int tmp = order[j];
            order[j] = order[j - 1];
            order[j - 1] = tmp;
        }
    for (int i = 0; i < n; i++)
        draw_figure(s, &s->fig[order[i]], fx[order[i]], fy[order[i]], ph[order[i]]);
    size_t bytes = (size_t)s->cam.w * s->cam.h * 3;
    for (size_t i = 0; i < bytes; i++) { /* sensor noise, +-2 levels */
        int v = s->frame[i] + (int)(hash32((uint32_t)i, (uint32_t)index, (uint32_t)s->a.seed) % 5) - 2;
        s->frame[i] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
    }
}

/* ---- ground truth files ---- */

static char *path_with(const char *out, const char *suffix)
{
    size_t n = strlen(out), e = strlen(".spcap");
    size_t stem = n > e && !strcmp(out + n - e, ".spcap") ? n - e : n;
    char *p = malloc(stem + strlen(suffix) + 1);
    if (p) {
        memcpy(p, out, stem);
        strcpy(p + stem, suffix);
    }
    return p;
}

static int write_pgm16(const char *path, const uint16_t *v, uint32_t w, uint32_t h)
{
    sp_atomic_file af;
    int ret = sp_atomic_file_open(&af, path);
    if (ret)
        return ret;
    fprintf(af.file, "P5\n%u %u\n65535\n", w, h);
    for (size_t i = 0; i < (size_t)w * h && !ret; i++) {
        uint8_t be[2] = { (uint8_t)(v[i] >> 8), (uint8_t)v[i] };
        if (fwrite(be, 1, 2, af.file) != 2)
            ret = -EIO;
    }
    return sp_atomic_file_finish(&af, ret);
}

/* A person of the mean height at ground point (gx, gy): foot, pixel height and shadow direction. */
static int truth_sample(const scene *s, double gx, double gy, double mean_h, sp_strbuf *b, int first)
{
    double uf, vf, ut, vt, us, vs;
    if (!project(&s->cam, (sp_vec3){ gx, gy, 0 }, &uf, &vf) || !project(&s->cam, (sp_vec3){ gx, gy, mean_h }, &ut, &vt))
        return 0;
    if (uf < 2 || vf < 2 || uf > s->cam.w - 2 || vf > s->cam.h - 2 || vt < 2)
        return 0;
    double sdx = 0, sdy = 0, h = vf - vt;
    if (!s->a.overcast && s->sun.z > 0.05) {
        double k = mean_h / s->sun.z;
        if (project(&s->cam, (sp_vec3){ gx - k * s->sun.x, gy - k * s->sun.y, 0 }, &us, &vs))
            sdx = (us - uf) / h, sdy = (vs - vf) / h;
    }
    sp_strbuf_printf(b, "%s\n    {\"x\":%.4f,\"y\":%.4f,\"height\":%.4f,\"shadow_dx\":%.5f,\"shadow_dy\":%.5f}",
                     first ? "" : ",", uf - 0.5, vf - 1.0, h, sdx, sdy);
    return 1;
}

static void truth_json(const scene *s, sp_strbuf *b)
{
    const camera *c = &s->cam;
    sp_strbuf_printf(
        b,
        "{\"format\":\"sunprobe-street-truth\",\"version\":1,\"width\":%u,\"height\":%u,"
        "\"fps\":%.17g,\"frames\":%.0f,\n\"camera\":{\"height_m\":%.17g,\"pitch_deg\":%.17g,"
        "\"hfov_deg\":%.17g,\"fx\":%.17g,\"cx\":%.17g,\"cy\":%.17g,\"pan_deg_s\":%.17g},\n"
        "\"indoor\":%s,\"sun\":{\"overcast\":%s,\"azimuth_deg\":%.17g,\"elevation_deg\":%.17g,"
        "\"direction\":[%.17g,%.17g,%.17g]},\n\"contact\":{\"model\":\"ground x (1 - depth (1 - r / (reach h))^2) "
        "within reach h of a figure's foot, h its height; overcast only\",\"depth\":%.17g,"
        "\"reach\":%.17g},\n\"occluders\":[",
        c->w, c->h, s->a.fps, floor(s->a.seconds * s->a.fps + 1e-9), s->a.camera_height_m, s->a.pitch_deg,
        s->a.hfov_deg, c->f, c->cx, c->cy, s->a.pan_deg_s, s->a.indoor ? "true" : "false",
        s->a.overcast ? "true" : "false", s->a.sun_azimuth_deg, s->a.sun_elevation_deg, s->sun.x, s->sun.y, s->sun.z,
        s->a.overcast ? CONTACT_DEPTH : 0.0, CONTACT_REACH);
    for (int i = 0; i < N_STATIC; i++)
        sp_strbuf_printf(b, "%s{\"x\":%.3f,\"y\":%.3f,\"half_width\":%.3f,\"z0\":%.3f,\"z1\":%.3f}", i ? "," : "",
                         s->occ[i].x, s->occ[i].y, s->occ[i].half_w, s->occ[i].z0, s->occ[i].z1);
    sp_strbuf_printf(b, "],\n\"figures\":[");
    double mean_h = 0;
    for (unsigned i = 0; i < s->n_fig; i++) {
        const figure *f = &s->fig[i];
        mean_h += f->height / s->n_fig;
        sp_strbuf_printf(b, "%s\n    {\"height_m\":%.4f,\"from\":[%.3f,%.3f],\"to\":[%.3f,%.3f],\"speed\":%.3f,"
                            "\"t0\":%.3f,\"stop_after_m\":%.3f,\"stop_s\":%.3f}", i ? "," : "", f->height, f->x0,
                         f->y0, f->x1, f->y1, f->speed, f->t0, f->stop_m, f->stop_s);
    }
    sp_strbuf_printf(b, "],\n\"cars\":[");
    for (unsigned i = 0; i < s->n_car; i++) {
        const car *v = &s->cars[i];
        sp_strbuf_printf(b,
                         "%s\n    {\"length_m\":%.3f,\"height_m\":%.3f,\"y\":%.3f,\"from_x\":%.3f,\"to_x\":%.3f,"
                         "\"speed\":%.3f,\"t0\":%.3f}",
                         i ? "," : "", v->length, v->height, v->y, v->x0, v->x1, v->speed, v->t0);
    }
    sp_strbuf_printf(b,
                     "],\n\"car_views_fields\":[\"frame\",\"car\",\"x0\",\"y0\",\"x1\",\"y1\",\"cut_by_border\"],"
                     "\n\"car_views\":[%s],",
                     s->car_views.len ? s->car_views.data : "");
    sp_strbuf_printf(b, "\n\"mean_height_m\":%.6f,\n\"samples\":[", s->n_fig ? mean_h : 1.75);
    int first = 1;
    for (double gy = 6.5; gy <= 16.01; gy += 1.0)
        for (double gx = -7; gx <= 7.01; gx += 1.0)
            if (truth_sample(s, gx, gy, s->n_fig ? mean_h : 1.75, b, first))
                first = 0;
    sp_strbuf_printf(b, "]}\n");
}

static int write_file(const char *path, const void *data, size_t len)
{
    sp_atomic_file af;
    int ret = sp_atomic_file_open(&af, path);
    if (ret)
        return ret;
    if (fwrite(data, 1, len, af.file) != len)
        ret = -EIO;
    return sp_atomic_file_finish(&af, ret);
}

/* Binary PPM: the background when no image writer is given. */
static int write_ppm(const char *path, const uint8_t *rgb, uint32_t w, uint32_t h)
{
    char head[48];
    size_t hn = (size_t)snprintf(head, sizeof(head), "P6\n%u %u\n255\n", w, h), n = (size_t)w * h * 3;
    uint8_t *buf = malloc(hn + n);
    if (!buf)
        return -ENOMEM;
    memcpy(buf, head, hn);
    memcpy(buf + hn, rgb, n);
    int ret = write_file(path, buf, hn + n);
    free(buf);
    return ret;
}

/* The ground truth beside OUT, each file under its name in the set (p: the temporary names). */
static int write_truth(const scene *s, const char *const p[N_TRUTH])
{
    int ret = 0;
    sp_strbuf b = { 0 };
    if (!ret) {
        truth_json(s, &b);
        ret = b.failed || s->car_views.failed ? -ENOMEM : write_file(p[0], b.data, b.len);
    }
    if (!ret)
        ret = s->a.write_image ? s->a.write_image(p[1], s->bg, s->cam.w, s->cam.h, s->cam.w * 3, 3)
                               : write_ppm(p[1], s->bg, s->cam.w, s->cam.h);
    if (!ret)
        ret = write_pgm16(p[2], s->hidden_far, s->cam.w, s->cam.h);
    if (!ret)
        ret = write_pgm16(p[3], s->hidden_near, s->cam.w, s->cam.h);
    if (!ret)
        ret = write_pgm16(p[4], s->seen_far, s->cam.w, s->cam.h);
    if (!ret)
        ret = write_pgm16(p[5], s->hidden_count, s->cam.w, s->cam.h);
    sp_strbuf_free(&b);
    return ret;
}

/* ---- the capture ---- */

static int scene_alloc(scene *s)
{
    size_t n = (size_t)s->a.width * s->a.height;
    s->bg = malloc(n * 3), s->ground_dark = calloc(n * 3, 1), s->kind = calloc(n, 1);
    s->static_shadow = calloc(n, 1), s->depth = malloc(n * sizeof(float));
    s->gx = calloc(n, sizeof(float)), s->gy = calloc(n, sizeof(float));
    s->hidden_far = calloc(n, 2), s->hidden_near = calloc(n, 2), s->seen_far = calloc(n, 2);
    s->hidden_count = calloc(n, 2);
    s->frame = malloc(n * 3);
    s->car_px = calloc(n, 1);
    return s->bg && s->ground_dark && s->kind && s->static_shadow && s->depth && s->gx && s->gy && s->hidden_far &&
            s->hidden_near && s->seen_far && s->hidden_count && s->frame && s->car_px
        ? 0
        : -ENOMEM;
}

static void scene_free(scene *s)
{
    free(s->bg), free(s->ground_dark), free(s->kind), free(s->static_shadow), free(s->depth);
    free(s->gx), free(s->gy), free(s->hidden_far), free(s->hidden_near), free(s->seen_far), free(s->frame);
    free(s->hidden_count), free(s->car_px);
    sp_strbuf_free(&s->car_views);
}

/* Gaussian sensor noise (Box-Muller on the pixel's hashes), independent per frame, pixel and channel. */
static void add_noise(scene *s, uint64_t index)
{
    size_t n = (size_t)s->cam.w * s->cam.h * 3;
    uint32_t key = (uint32_t)s->a.seed * 0x9E3779B1u ^ (uint32_t)index;
    for (size_t i = 0; i < n; i++) {
        double u1 = (hash32(key, (uint32_t)i, 91) + 1.0) * (1.0 / 4294967297.0);
        double u2 = hash32(key, (uint32_t)i, 92) * (1.0 / 4294967296.0);
        double v = s->frame[i] + s->a.noise * sqrt(-2.0 * log(u1)) * cos(2.0 * M_PI * u2);
        s->frame[i] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : lrint(v));
    }
}

static int write_meta(sp_capture_writer *w, const scene *s)
{
    char *truth = path_with(s->out, ".truth.json");
    if (!truth)
        return -ENOMEM;
    const char *base = strrchr(truth, '/') ? strrchr(truth, '/') + 1 : truth;
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"kind\":\"static\",\"source\":\"sunprobe synth street\",\"camera\":{\"name\":\"synthetic "
                         "street camera\",\"driver\":\"synth\",\"width\":%u,\"height\":%u,\"fps\":%.17g,\"fx\":%.17g,"
                         "\"fy\":%.17g,\"cx\":%.17g,\"cy\":%.17g},\"ground_truth\":",
                     s->cam.w, s->cam.h, s->a.fps, s->cam.f, s->cam.f, s->cam.cx - 0.5, s->cam.cy - 0.5);
    sp_strbuf_json_string(&b, base);
    sp_strbuf_printf(&b, "}");
    int ret = b.failed ? -ENOMEM : sp_capture_write_meta(w, 0, b.data, b.len);
    sp_strbuf_free(&b);
    free(truth);
    return ret;
}

static int write_capture(scene *s, const char *partial)
{
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    ws.sync = SP_SYNC_NONE;
    ws.overwrite = 1;
    sp_capture_writer *w = NULL;
    int ret = sp_capture_writer_open(&w, partial, &ws);
    if (!ret)
        ret = write_meta(w, s);
    uint64_t n = (uint64_t)floor(s->a.seconds * s->a.fps + 1e-9);
    sp_jpeg_buffer jpg = { 0 };
    sp_progress bar;
    sp_progress_start(&bar, "synth street", n, s->a.progress);
    for (uint64_t i = 0; !ret && i < n; i++) {
        if (s->a.cancel && *s->a.cancel) {
            ret = -ECANCELED;
            break;
        }
        double t = (double)i / s->a.fps;
        render_frame(s, i, t);
        if (s->a.noise > 0)
            add_noise(s, i);
        sp_frame f = { .format = SP_PIXFMT_RGB24, .width = s->cam.w, .height = s->cam.h, .stride = s->cam.w * 3,
                       .data = s->frame, .capacity = (size_t)s->cam.w * s->cam.h * 3,
                       .bytes_used = (size_t)s->cam.w * s->cam.h * 3, .timestamp_ns = (int64_t)llround(t * 1e9),
                       .sequence = i, .exposure_us = NAN, .gain = NAN };
        if (s->a.jpeg_quality > 0) { /* a camera's compression, after its noise */
            ret = sp_jpeg_encode_rgb24(s->frame, s->cam.w, s->cam.h, s->cam.w * 3, s->a.jpeg_quality, &jpg);
            f.format = SP_PIXFMT_MJPEG, f.stride = 0, f.data = jpg.data, f.capacity = jpg.cap, f.bytes_used = jpg.size;
        }
        if (!ret)
            ret = sp_capture_write_frame(w, &f);
        sp_progress_update(&bar, i + 1, NULL);
    }
    sp_progress_finish(&bar);
    sp_jpeg_buffer_free(&jpg);
    int close_ret = sp_capture_writer_close(&w);
    return ret ? ret : close_ret;
}

/* The capture and its truth files, one set: all of them replace the previous ones, or none does. */
static int run(scene *s)
{
    static const char *const sfx[N_TRUTH] = { ".truth.json", ".background.png", ".hidden-far.pgm",
                                              ".hidden-near.pgm", ".seen-far.pgm", ".hidden-count.pgm" };
    sp_file_set fs = { 0 };
    const char *cap = NULL, *truth[N_TRUTH];
    int ret = sp_file_set_add(&fs, s->out, &cap);
    for (int i = 0; !ret && i < N_TRUTH; i++) {
        char *p = path_with(s->out, i == 1 && !s->a.write_image ? ".background.ppm" : sfx[i]);
        ret = p ? sp_file_set_add(&fs, p, &truth[i]) : -ENOMEM;
        free(p);
    }
    setup_scene(s);
    camera_setup(&s->cam, &s->a, 0);
    if (!ret)
        ret = scene_alloc(s);
    if (!ret) {
        render_static(s);
        ret = write_capture(s, cap);
    }
    if (!ret) {
        if (s->a.pan_deg_s != 0) { /* the truth describes the first view */
            camera_setup(&s->cam, &s->a, 0);
            render_static(s);
        }
        ret = write_truth(s, truth);
    }
    if (!ret)
        return sp_file_set_commit(&fs);
    sp_file_set_abort(&fs);
    return ret;
}

/* ---- public API ---- */

void sp_synth_street_default_settings(sp_synth_street_settings *s)
{
    *s = (sp_synth_street_settings){ .width = 320, .height = 240, .fps = 10, .seconds = 40, .figures = 10,
                                     .seed = 1, .sun_azimuth_deg = -30, .sun_elevation_deg = 40,
                                     .camera_height_m = 4.0, .pitch_deg = 15, .hfov_deg = 45 };
}

static int within(double v, double lo, double hi)
{
    return v >= lo && v <= hi; /* false for NaN */
}

static const char *street_bad_field(const sp_synth_street_settings *s)
{
    if (s->width < 32 || s->width > 4096 || s->height < 32 || s->height > 4096)
        return "width/height (32..4096)";
    if (!within(s->fps, 1, 240) || !within(s->seconds, 0.01, 36000))
        return "fps (1..240) / seconds (0.01..36000)";
    if (s->figures > MAX_FIGURES)
        return "figures (0..64)";
    if (s->cars > MAX_CARS || (s->cars && s->indoor))
        return "cars (0..16; none indoors)";
    if (!within(s->sun_azimuth_deg, -360, 360) || !within(s->sun_elevation_deg, 5, 85))
        return "sun_azimuth_deg (-360..360) / sun_elevation_deg (5..85)";
    if (!within(s->pan_deg_s, -90, 90) || !within(s->linger_s, 0, 3600) || !within(s->noise, 0, 64))
        return "pan_deg_s (-90..90) / linger_s (0..3600) / noise (0..64)";
    if (s->jpeg_quality < 0 || s->jpeg_quality > 100)
        return "jpeg_quality (0: RGB24, 1..100)";
    if (!within(s->camera_height_m, 0.5, 50) || !within(s->pitch_deg, 0, 60) || !within(s->hfov_deg, 10, 120))
        return "camera_height_m (0.5..50) / pitch_deg (0..60) / hfov_deg (10..120)";
    return NULL;
}

int sp_synth_street_write(const sp_synth_street_settings *settings, const char *capture_path,
                          sp_synth_street_report *report)
{
    if (!settings || !capture_path || !capture_path[0])
        return -EINVAL;
    const char *bad = street_bad_field(settings);
    if (bad) {
        sp_log(SP_LOG_ERROR, "synth street", "bad setting: %s", bad);
        return -EINVAL;
    }
    if (settings->jpeg_quality > 0 && !sp_jpeg_available()) {
        sp_log(SP_LOG_ERROR, "synth street", "MJPEG frames (jpeg_quality) need libjpeg: rebuild with -Djpeg=enabled");
        return SP_EDISABLED;
    }
    scene *s = calloc(1, sizeof(*s));
    if (!s)
        return -ENOMEM;
    s->a = *settings;
    s->a.overcast |= s->a.indoor; /* lamps all round: no cast shadows, the darkening at the feet */
    s->out = capture_path;
    int ret = run(s);
    if (!ret && report)
        *report = (sp_synth_street_report){ .frames = (uint64_t)floor(s->a.seconds * s->a.fps + 1e-9),
                                            .figures = s->n_fig,
                                            .cars = s->n_car };
    scene_free(s);
    free(s);
    return ret;
}
