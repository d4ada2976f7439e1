/* SPDX-License-Identifier: MIT */
/*
 * Removal masks from one image: an object's box or mask, a pixel more for
 * its anti-aliased edge, the contact shadow at its foot and its cast shadow.
 * With no clean plate the lit ground near the foot is the reference: the
 * brighter half of a band around the foot, outside every object. The cast
 * shadow is the ground connected to the foot that is a shadow of that
 * reference (probe_shadow_of, the probe's own test), no farther than a few
 * object heights, within a cone around the sun's image direction (when not
 * given, the direction the dark ground near the foot leans to) and no wider
 * than the object across it. Where the sun is known (closed shadows, the
 * clock), the ground strip it casts from each foot instead; last, a thin
 * dark line from the foot where nothing else was found.
 */
#include "depopulate.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "probe_internal.h"

enum { M_NONE = 0, M_OBJECT = 1, M_SHADOW = 2 };
/* of the object's height: the longest run of foreign pixels (a pole, a marking) its cast shadow is followed across */
#define BRIDGE 0.25

void sp_depop_default_settings(sp_depop_settings *s)
{
    if (!s)
        return;
    *s = (sp_depop_settings){ .cone_deg = 30, .max_length = 3, .ratio_lo = 0.2, .ratio_hi = 0.85,
                              .chroma_tol = 0.05, .shadows = 1 };
}

typedef struct grow {
    const uint8_t *rgb;
    uint32_t stride;
    int w, h;
    uint8_t *mask;
    int32_t *queue;
    uint8_t *seen;
    const sp_depop_settings *s;
    int32_t lo, hi, tol; /* the shadow test's bounds from s, in 1/1024 */
    int32_t lit_top;     /* lit ground's upper ratio, 1 / hi, in 1/1024 (lit_at) */
} grow;

static int clampi(int v, int lo, int hi) { return v < lo ? lo : v > hi ? hi : v; }

/* Whether pixel (x, y) is a shadow of the lit reference colour (the probe's own test, probe_internal.h). */
static int shadow_at(const grow *g, int x, int y, const uint8_t ref[3])
{
    return probe_shadow_of(g->rgb + (size_t)y * g->stride + 3 * (size_t)x, ref, g->lo, g->hi, g->tol, 3);
}

/* Whether pixel (x, y) is lit ground: the reference's colour at about its brightness (ratio in [hi, 1 / hi]). */
static int lit_at(const grow *g, int x, int y, const uint8_t ref[3])
{
    return probe_shadow_of(g->rgb + (size_t)y * g->stride + 3 * (size_t)x, ref, g->hi, g->lit_top, g->tol, 3);
}

/* Where a flood of o starts: the object's lower quarter and its contact shadow, k pixels around (x0, y0, x1, y1). */
static void seed_box(const sp_depop_object *o, int box[4])
{
    int h = o->y1 - o->y0 + 1, k = (int)ceil(0.04 * h) + 3;
    box[0] = o->x0 - k, box[1] = o->y1 - h / 4, box[2] = o->x1 + k, box[3] = o->y1 + k;
}

int sp_depop_standing(const sp_depop_object *o)
{
    return !o->truncated && o->x1 - o->x0 <= o->y1 - o->y0;
}

void sp_depop_lit_band(const uint32_t hist[256], uint32_t n, int *lo, int *hi)
{
    uint64_t acc = 0;
    *lo = -1, *hi = 255;
    for (int v = 0; v < 256; v++) {
        acc += hist[v];
        if (*lo < 0 && acc * 10 >= (uint64_t)n * 7)
            *lo = v;
        if (acc * 20 >= (uint64_t)n * 19) {
            *hi = v;
            break;
        }
    }
}

/*
 * The lit ground near the foot: mean colour of the band's pixels between its 70th and 95th luma percentiles
 * (a shadow or a dark road may cover most of the band; a bright stray is rare).
 */
static int ground_reference(const grow *g, const sp_depop_object *o, uint8_t ref[3])
{
    int h = o->y1 - o->y0 + 1, w = o->x1 - o->x0 + 1;
    int ya = clampi(o->y1 - h / 8, 0, g->h - 1), yb = clampi(o->y1 + h / 2, 0, g->h - 1);
    int xa = clampi(o->x0 - w, 0, g->w - 1), xb = clampi(o->x1 + w, 0, g->w - 1);
    uint32_t hist[256] = { 0 }, n = 0;
    for (int y = ya; y <= yb; y++)
        for (int x = xa; x <= xb; x++) {
            const uint8_t *p = g->rgb + (size_t)y * g->stride + 3 * (size_t)x;
            if (g->mask[(size_t)y * g->w + x] == M_NONE)
                hist[(299 * p[0] + 587 * p[1] + 114 * p[2]) / 1000]++, n++;
        }
    if (n < 16)
        return -1;
    int lo, hi;
    sp_depop_lit_band(hist, n, &lo, &hi);
    double sum[3] = { 0, 0, 0 }, k = 0;
    for (int y = ya; y <= yb; y++)
        for (int x = xa; x <= xb; x++) {
            const uint8_t *p = g->rgb + (size_t)y * g->stride + 3 * (size_t)x;
            int l = (299 * p[0] + 587 * p[1] + 114 * p[2]) / 1000;
            if (g->mask[(size_t)y * g->w + x] == M_NONE && l >= lo && l <= hi)
                sum[0] += p[0], sum[1] += p[1], sum[2] += p[2], k++;
        }
    for (int c = 0; c < 3; c++)
        ref[c] = (uint8_t)lrint(sum[c] / k);
    return ref[0] + ref[1] + ref[2] > 12 ? 0 : -1; /* black ground: no shadow can be told */
}

typedef struct cone {
    double fx, fy;   /* the foot */
    double dx, dy;   /* unit direction; 0,0: any */
    double cos_max;  /* of the cone's half angle */
    double reach;    /* farthest distance from the foot */
    double half_w;   /* farthest distance across the direction */
    double free_r;   /* within this of the foot, any direction (the contact area) */
    int bridge;      /* with a direction: a run of foreign pixels up to this long is crossed along it (0: none) */
} cone;

static int in_cone(const cone *c, int x, int y)
{
    double ox = x - c->fx, oy = y - c->fy, d = hypot(ox, oy);
    if (d > c->reach)
        return 0;
    if (d <= c->free_r || (c->dx == 0 && c->dy == 0))
        return 1;
    double along = ox * c->dx + oy * c->dy, across = fabs(ox * c->dy - oy * c->dx);
    return along >= c->cos_max * d && across <= c->half_w;
}

/*
 * Ground connected to the object's lower quarter that passes the shadow test inside the cone, as
 * pixel indices in g->queue; returns how many. *spill (may be NULL): how many pixels next to them pass
 * the test outside the cone, plus how many found lie on the image's edge; *cut: whether the shadow goes on
 * past the search's reach or out of the image (one such pixel does: a thin shadow's spill is a pixel or
 * two). Nothing is marked: the caller decides.
 */
static size_t flood(grow *g, const sp_depop_object *o, const uint8_t ref[3], const cone *c, uint32_t *spill, int *cut)
{
    int sb[4];
    seed_box(o, sb);
    size_t n = 0, head = 0;
    /* seeds: the object's lower part and its contact shadow */
    for (int y = clampi(sb[1], 0, g->h - 1); y <= clampi(sb[3], 0, g->h - 1); y++)
        for (int x = clampi(sb[0], 0, g->w - 1); x <= clampi(sb[2], 0, g->w - 1); x++) {
            size_t i = (size_t)y * g->w + x;
            if (g->mask[i] != M_NONE && !g->seen[i])
                g->seen[i] = 1, g->queue[n++] = (int32_t)i;
        }
    size_t seeds = n;
    uint32_t out = 0;
    int past = 0;
    while (head < n) {
        int32_t i = g->queue[head++];
        int x = i % g->w, y = i / g->w;
        int edge = head > seeds && (x == 0 || y == 0 || x == g->w - 1 || y == g->h - 1);
        out += edge, past |= edge;
        for (int dy = -1; dy <= 1; dy++)
            for (int dx = -1; dx <= 1; dx++) {
                int u = x + dx, v = y + dy;
                if (u < 0 || v < 0 || u >= g->w || v >= g->h)
                    continue;
                size_t j = (size_t)v * g->w + u;
                if (g->seen[j] || g->mask[j] != M_NONE)
                    continue;
                g->seen[j] = 1; /* outside the cone too: within a pixel of its box, cleared with it */
                int dark = shadow_at(g, u, v, ref);
                if (dark && in_cone(c, u, v))
                    g->queue[n++] = (int32_t)j;
                else if (dark && head > seeds)
                    out++, past |= hypot(u - c->fx, v - c->fy) > c->reach;
            }
        /*
         * Across what is neither shadow nor lit ground: a pole or a road marking on a long shadow ends the flood
         * there, and the shadow, found short and closed, puts the sun too high. Along the search's direction,
         * inside its cone, a run of such pixels up to c->bridge long is crossed where shadow goes on past it;
         * lit ground or an object in the run ends it (a real end, or someone else's shadow beyond).
         */
        /* (from the shadow found, not from the object's seeds) */
        for (int k = 1; c->bridge > 0 && head > seeds && k <= c->bridge + 1; k++) {
            int u = (int)lrint(x + k * c->dx), v = (int)lrint(y + k * c->dy);
            if (u < 0 || v < 0 || u >= g->w || v >= g->h || !in_cone(c, u, v))
                break;
            size_t j = (size_t)v * g->w + u;
            if (g->mask[j] != M_NONE || lit_at(g, u, v, ref))
                break;
            if (shadow_at(g, u, v, ref)) {
                if (k > 1 && !g->seen[j])
                    g->seen[j] = 1, g->queue[n++] = (int32_t)j;
                break;
            }
        }
    }
    if (spill)
        *spill = out, *cut = past;
    for (size_t q = 0; q < n; q++)
        g->seen[g->queue[q]] = 0;
    /* the seen flags of rejected pixels are cleared by the caller (clear_seen) */
    memmove(g->queue, g->queue + seeds, (n - seeds) * sizeof(*g->queue));
    return n - seeds;
}

/*
 * Clears the seen flags a flood of o in c set: over the cone's box and the seeds' box (flood's), each a pixel
 * wider, since neighbours of both are marked whether or not they are in the cone (a wide object's seeds reach
 * farther sideways than a short cone).
 */
static void clear_seen(grow *g, const sp_depop_object *o, const cone *c)
{
    int sb[4];
    seed_box(o, sb);
    int x0 = (int)fmin(floor(c->fx - c->reach), sb[0]) - 1, x1 = (int)fmax(ceil(c->fx + c->reach), sb[2]) + 1;
    int y0 = (int)fmin(floor(c->fy - c->reach), sb[1]) - 1, y1 = (int)fmax(ceil(c->fy + c->reach), sb[3]) + 1;
    x0 = clampi(x0, 0, g->w - 1), x1 = clampi(x1, 0, g->w - 1), y0 = clampi(y0, 0, g->h - 1),
    y1 = clampi(y1, 0, g->h - 1);
    for (int y = y0; y <= y1; y++)
        memset(g->seen + (size_t)y * g->w + x0, 0, (size_t)(x1 - x0 + 1));
}

/* Mean offset of the found pixels from the foot. */
static void mean_offset(const grow *g, size_t n, double fx, double fy, double *mx, double *my)
{
    double sx = 0, sy = 0;
    for (size_t k = 0; k < n; k++)
        sx += g->queue[k] % g->w - fx, sy += g->queue[k] / g->w - fy;
    *mx = n ? sx / n : 0, *my = n ? sy / n : 0;
}

static cone object_cone(const grow *g, const sp_depop_object *o)
{
    int h = o->y1 - o->y0 + 1, w = o->x1 - o->x0 + 1;
    return (cone){ .fx = 0.5 * (o->x0 + o->x1), .fy = o->y1, .reach = g->s->max_length * h,
                   .cos_max = cos(g->s->cone_deg * M_PI / 180.0), .half_w = 0.75 * w + 2, .free_r = 0.15 * h };
}

/*
 * Where the dark ground within one height of the foot leans (a unit vector): 0 when it does, -1 when
 * there is too little of it, or so much (more than the box's area) that it is dark material, not a shadow.
 */
static int near_direction(grow *g, const sp_depop_object *o, const uint8_t ref[3], double *dx, double *dy)
{
    int h = o->y1 - o->y0 + 1, w = o->x1 - o->x0 + 1;
    cone near = object_cone(g, o);
    near.reach = h;
    size_t n = flood(g, o, ref, &near, NULL, NULL);
    clear_seen(g, o, &near);
    double mx, my;
    mean_offset(g, n, near.fx, near.fy, &mx, &my);
    double ml = hypot(mx, my);
    if (n < (size_t)(w > 4 ? w : 4) || n > (size_t)w * h || ml < 0.1 * h)
        return -1;
    *dx = mx / ml, *dy = my / ml;
    return 0;
}

/* The cast shadow along (dx, dy); refused as a leak into dark material when larger than 1.5 boxes. */
static void cast_along(grow *g, sp_depop_object *o, const uint8_t ref[3], double dx, double dy)
{
    o->shadow_px = 0, o->shadow_leak = 0, o->shadow_spill = 0, o->shadow_cut = 0; /* a second pass starts afresh */
    o->shadow_dx = o->shadow_dy = o->shadow_len = 0;
    cone c = object_cone(g, o);
    c.dx = dx, c.dy = dy, c.bridge = (int)ceil(BRIDGE * (o->y1 - o->y0 + 1)); /* the cast alone: not the search's */
    uint32_t spill;
    int cut;
    size_t n = flood(g, o, ref, &c, &spill, &cut);
    clear_seen(g, o, &c);
    if ((double)n > 1.5 * (o->x1 - o->x0 + 1) * (o->y1 - o->y0 + 1)) {
        o->shadow_leak = 1;
        return;
    }
    double mx, my, len = 0;
    mean_offset(g, n, c.fx, c.fy, &mx, &my);
    /* along the shadow's own axis (foot to its mean; the cone's direction is the search's, a few degrees off) */
    double ml = hypot(mx, my), ax = ml > 0 ? mx / ml : c.dx, ay = ml > 0 ? my / ml : c.dy;
    for (size_t k = 0; k < n; k++) {
        int32_t i = g->queue[k];
        len = fmax(len, (i % g->w - c.fx) * ax + (i / g->w - c.fy) * ay);
        g->mask[i] = M_SHADOW;
    }
    /* the tip: on that axis, as far as the shadow goes (not a corner of its end) */
    o->tip_x = c.fx + len * ax, o->tip_y = c.fy + len * ay;
    o->shadow_px = (uint32_t)n, o->shadow_dx = mx, o->shadow_dy = my, o->shadow_len = len, o->shadow_spill = spill;
    o->shadow_cut = cut;
}

/*
 * 1 when a found shadow of n pixels is closed: it does not go on past the search's reach (cut), and the
 * shadow-dark ground going on past its cone (spill, a count along the boundary) is a few stray pixels, under
 * a tenth of the shadow's side (sqrt(n)).
 */
static int closed(uint32_t spill, int cut, size_t n)
{
    return !cut && spill <= 2 + 0.1 * sqrt((double)n);
}

int sp_depop_closed_shadow(const sp_depop_object *o)
{
    /* a thin line's tip is where the line test stops, not the shadow's end */
    return o->shadow_px > 0 && !o->shadow_thin && closed(o->shadow_spill, o->shadow_cut, o->shadow_px);
}

/* The image direction at object o's foot of the ground direction psi (radians from the view direction to the right). */
static int ground_to_image(const sp_depop_camera *cam, const sp_depop_object *o, double psi, double d[2])
{
    double fx = 0.5 * (o->x0 + o->x1), fy = o->y1 + 0.5, g[2], u, v;
    if (sp_depop_ground_point(cam, fx, fy, g))
        return -1;
    double e = 0.05 * (1 + hypot(g[0], g[1])); /* a ground line is an image line: any step works */
    double p[3] = { g[0] + e * sin(psi), g[1] + e * cos(psi), 0 };
    if (sp_depop_project(cam, p, &u, &v))
        return -1;
    double l = hypot(u - fx, v - fy);
    if (!(l > 1e-9))
        return -1;
    d[0] = (u - fx) / l, d[1] = (v - fy) / l;
    return 0;
}

enum { N_PSI = 36 }; /* ground directions 10 degrees apart; the cone is 30 degrees either side */

/*
 * One sun: every cast shadow on the ground plane points one way. Each ground direction is scored by the
 * number of objects whose flood along its image direction is a closed shadow reaching past the contact area;
 * a wrong direction cuts a real shadow at the cone's side, which leaves it open, and one large dark patch
 * by one foot outvotes nothing. The best direction, refined between its neighbours, goes to dir[i] for every
 * object with have[i] == 0 (set to 3). Nothing when no direction scores or a second one, more than 60
 * degrees away, scores within 80% of the best (no shadows that tell, e.g. under an overcast sky).
 */
static void one_sun(grow *g, sp_depop_object *objs, size_t n, const uint8_t (*ref)[3], int *have, double (*dir)[2])
{
    const sp_depop_camera *cam = g->s->camera;
    double score[N_PSI] = { 0 };
    for (int k = 0; k < N_PSI; k++)
        for (size_t i = 0; i < n; i++) {
            double d[2];
            if (have[i] != 0 || ground_to_image(cam, &objs[i], 2 * M_PI * k / N_PSI, d))
                continue;
            const sp_depop_object *o = &objs[i];
            cone c = object_cone(g, o);
            c.dx = d[0], c.dy = d[1];
            uint32_t spill;
            int cut;
            size_t m = flood(g, o, ref[i], &c, &spill, &cut), far = 0;
            clear_seen(g, o, &c);
            for (size_t q = 0; q < m; q++)
                far += hypot(g->queue[q] % g->w - c.fx, g->queue[q] / g->w - c.fy) > c.free_r;
            double area = (double)(o->x1 - o->x0 + 1) * (o->y1 - o->y0 + 1);
            if (closed(spill, cut, m) && far >= 10 && far >= 0.05 * area && m <= 1.5 * area)
                score[k] +=
                    1 + 0.1 * (far < area ? far / area : 1); /* objects count, their shadows' size breaks ties */
        }
    /* a shadow fits the cone over a range of directions: the range's evidence (over +-20 degrees) decides,
       and the answer is the score-weighted mean direction over that range */
    double wide[N_PSI];
    int best = 0;
    for (int k = 0; k < N_PSI; k++) {
        wide[k] = 0;
        for (int j = -2; j <= 2; j++)
            wide[k] += score[(k + j + N_PSI) % N_PSI];
        best = wide[k] > wide[best] ? k : best;
    }
    if (!(wide[best] > 0))
        return;
    for (int k = 0; k < N_PSI; k++) {
        int apart = abs(k - best) < N_PSI - abs(k - best) ? abs(k - best) : N_PSI - abs(k - best);
        if (apart * 360 / N_PSI > 60 && wide[k] >= 0.8 * wide[best])
            return;
    }
    double sx = 0, sy = 0;
    for (int j = -2; j <= 2; j++) {
        double a = 2 * M_PI * (best + j) / N_PSI;
        sx += score[(best + j + N_PSI) % N_PSI] * sin(a), sy += score[(best + j + N_PSI) % N_PSI] * cos(a);
    }
    double psi = atan2(sx, sy);
    for (size_t i = 0; i < n; i++)
        if (have[i] == 0 && !ground_to_image(cam, &objs[i], psi, dir[i]))
            have[i] = 3;
}

/*
 * Where the sun is known from closed shadows, each standing object's cast shadow is where that sun puts it:
 * the ground strip from its foot, its height over tan(elevation) long (1.15 times, for the head's penumbra)
 * and as wide as its foot row on the ground, widened for the sun's error (1.2 times the width plus a tenth of
 * the distance along it, half a width longer); inside it, the pixels that pass the shadow test. This replaces
 * the search's flood: it takes a shadow cut from the foot (a walker in a building's shadow, a white road
 * marking across it) and leaves dark ground beside it (a shop window, the road) that the cone let in.
 * Returns 0, or -1 for an object it cannot place (the caller keeps the search's shadow then).
 */
static int sun_strip(grow *g, sp_depop_object *o, const uint8_t ref[3], const sp_depop_sun *sun)
{
    const sp_depop_camera *cam = g->s->camera;
    double psi = (sun->azimuth_deg + 180) * M_PI / 180, sdx = sin(psi), sdy = cos(psi);
    double foot[2], left[2], right[2];
    if (sp_depop_ground_point(cam, 0.5 * (o->x0 + o->x1), o->y1 + 0.5, foot) ||
        sp_depop_ground_point(cam, o->x0, o->y1 + 0.5, left) ||
        sp_depop_ground_point(cam, o->x1 + 1, o->y1 + 0.5, right))
        return -1;
    double H = sp_depop_height_at(cam, foot, o->y0 - 0.5), hw = 0.5 * hypot(right[0] - left[0], right[1] - left[1]);
    double L = 1.15 * H / tan(sun->elevation_deg * M_PI / 180) + hw, slack = 0.1;
    hw *= 1.2;
    if (!(H > 0) || !(L > 0) || !(L < 20 * H))
        return -1;
    /* the strip's image box from its corners (all in front of the camera, or it is not placed) */
    double u0 = g->w, v0 = g->h, u1 = -1, v1 = -1;
    for (int c = 0; c < 4; c++) {
        double t = c & 1 ? L : 0, a = (c & 2 ? 1 : -1) * (hw + slack * t), u, v;
        double p[3] = { foot[0] + t * sdx + a * sdy, foot[1] + t * sdy - a * sdx, 0 };
        if (sp_depop_project(cam, p, &u, &v))
            return -1;
        u0 = fmin(u0, u), u1 = fmax(u1, u), v0 = fmin(v0, v), v1 = fmax(v1, v);
    }
    /* a corner just in front of the camera projects far off: bound the box before it becomes an int */
    u0 = fmax(u0, -1), v0 = fmax(v0, -1), u1 = fmin(u1, g->w), v1 = fmin(v1, g->h);
    uint32_t took = 0;
    for (int y = clampi((int)floor(v0), 0, g->h - 1); y <= clampi((int)ceil(v1), 0, g->h - 1); y++)
        for (int x = clampi((int)floor(u0), 0, g->w - 1); x <= clampi((int)ceil(u1), 0, g->w - 1); x++) {
            size_t k = (size_t)y * g->w + x;
            double q[2];
            if (g->mask[k] != M_NONE || sp_depop_ground_point(cam, x + 0.5, y + 0.5, q))
                continue;
            double along = (q[0] - foot[0]) * sdx + (q[1] - foot[1]) * sdy;
            double across = fabs((q[0] - foot[0]) * sdy - (q[1] - foot[1]) * sdx);
            if (along >= 0 && along <= L && across <= hw + slack * along && shadow_at(g, x, y, ref))
                g->mask[k] = M_SHADOW, took++;
        }
    o->strip_px = took;
    return 0;
}

/* ---- thin cast shadows: dark lines leaving the foot ---- */

enum {
    THIN_ANGLES = 180,   /* image directions 2 degrees apart */
    THIN_MAX_HALF = 4,   /* half-widths 1..4 px: a far walker's line to a near child's */
    THIN_MISSES = 2,     /* a run goes on over this many failing samples (grain, a joint in the paving) */
    THIN_SPREAD = 3,     /* bins either side of a direction that count as it (+-6 degrees) */
    THIN_PSI_STEPS = 72, /* ground directions 5 degrees apart for the one-sun vote */
};
#define THIN_RATIO 0.75     /* the line is at most this bright against each side (the flood's: ratio_hi, 0.85) */
#define THIN_MARGIN 2.5     /* the sides are looked at this far beyond the line's edge, pixels */
#define THIN_START 2        /* a run starts within this many pixels of its origin */
#define THIN_MIN_SHARE 0.25 /* of the object's height: a shorter run is no shadow (nor one under THIN_MIN_PX) */
#define THIN_MIN_PX 6
#define THIN_THROUGH 0.5 /* of its length: a line going on this far past the object's other side passes under it */

/* Colour at image point (x, y), bilinear over pixel centres; -1 off the image or on the mask. */
static int colour_at(const grow *g, double x, double y, double rgb[3])
{
    int x0 = (int)floor(x - 0.5), y0 = (int)floor(y - 0.5);
    double fx = x - 0.5 - x0, fy = y - 0.5 - y0;
    if (x0 < 0 || y0 < 0 || x0 + 1 >= g->w || y0 + 1 >= g->h)
        return -1;
    rgb[0] = rgb[1] = rgb[2] = 0;
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            if (g->mask[(size_t)(y0 + j) * g->w + x0 + i] != M_NONE)
                return -1;
            const uint8_t *p = g->rgb + (size_t)(y0 + j) * g->stride + 3 * (size_t)(x0 + i);
            double wgt = (i ? fx : 1 - fx) * (j ? fy : 1 - fy);
            for (int c = 0; c < 3; c++)
                rgb[c] += wgt * p[c];
        }
    return 0;
}

static void to_u8(const double in[3], uint8_t out[3])
{
    for (int c = 0; c < 3; c++)
        out[c] = (uint8_t)clampi((int)lround(in[c]), 0, 255);
}

/*
 * Whether a line of half-width hw through (x, y) (unit normal nx, ny) is a shadow, by the probe's test, of
 * the ground on each of its sides. Its colour: the darkest tap across it when hw is 1 (a line 1-2 px wide
 * straddles pixels), else the mean of the inner taps. *off: a tap lies off the image or on the mask.
 */
static int thin_hit(const grow *g, double x, double y, double nx, double ny, int hw, int *off)
{
    double c[3] = { 0, 0, 0 }, v[3], dark = INFINITY, side = hw + THIN_MARGIN, a[3], b[3];
    int taps = 0;
    for (int k = -hw; k <= hw; k++) {
        if (colour_at(g, x + k * nx, y + k * ny, v))
            return *off = 1, 0;
        if (hw == 1 && v[0] + v[1] + v[2] < dark)
            dark = v[0] + v[1] + v[2], memcpy(c, v, sizeof(c));
        if (hw > 1 && abs(k) < hw)
            c[0] += v[0], c[1] += v[1], c[2] += v[2], taps++;
    }
    for (int i = 0; i < 3 && taps; i++)
        c[i] /= taps;
    *off = 0;
    if (colour_at(g, x + side * nx, y + side * ny, a) || colour_at(g, x - side * nx, y - side * ny, b))
        return 0;
    uint8_t pc[3], pa[3], pb[3];
    to_u8(c, pc), to_u8(a, pa), to_u8(b, pb);
    int32_t hi = (int32_t)lround(THIN_RATIO * 1024);
    return probe_shadow_of(pc, pa, g->lo, hi, g->tol, 3) && probe_shadow_of(pc, pb, g->lo, hi, g->tol, 3);
}

/* How far a dark line runs along (dx, dy) from (ox, oy), pixels; 0 when it does not start within 2 px. */
static double thin_run(const grow *g, double ox, double oy, double dx, double dy, int hw, double reach)
{
    int started = 0, miss = 0;
    double last = 0;
    for (double t = 0; t <= reach; t += 1) {
        int off, hit = thin_hit(g, ox + t * dx, oy + t * dy, -dy, dx, hw, &off);
        if (hit)
            started = 1, miss = 0, last = t;
        else if (!started && t >= THIN_START)
            return 0;
        else if (started && (off || ++miss > THIN_MISSES))
            break;
    }
    return started ? last : 0;
}

/* Bin a taken round the circle into 0..THIN_ANGLES-1. */
static int thin_wrap(int a)
{
    return (a % THIN_ANGLES + THIN_ANGLES) % THIN_ANGLES;
}

/* The bin nearest image direction (dx, dy). */
static int thin_bin(double dx, double dy)
{
    return thin_wrap((int)lround(atan2(dy, dx) * THIN_ANGLES / (2 * M_PI)));
}

/* Per image direction, the longest dark line leaving an object: its run (pixels), origin and half-width. */
typedef struct thin_rays {
    double run[THIN_ANGLES], ox[THIN_ANGLES], oy[THIN_ANGLES];
    int hw[THIN_ANGLES];
} thin_rays;

/*
 * Rays leave every unmasked pixel next to the object's lower part: a shadow need not pass the box's bottom
 * middle. Only the bins within THIN_SPREAD of bin a0 when it is not negative (the direction is known).
 */
static void thin_search(const grow *g, const sp_depop_object *o, int a0, thin_rays *r)
{
    int h = o->y1 - o->y0 + 1, sb[4];
    seed_box(o, sb);
    double reach = g->s->max_length * h;
    memset(r, 0, sizeof(*r));
    for (int y = clampi(sb[1], 1, g->h - 2); y <= clampi(sb[3], 1, g->h - 2); y++)
        for (int x = clampi(sb[0], 1, g->w - 2); x <= clampi(sb[2], 1, g->w - 2); x++) {
            size_t k = (size_t)y * g->w + x;
            if (g->mask[k] != M_NONE ||
                (g->mask[k - 1] == M_NONE && g->mask[k + 1] == M_NONE && g->mask[k - g->w] == M_NONE &&
                 g->mask[k + g->w] == M_NONE))
                continue;
            for (int hw = 1; hw <= THIN_MAX_HALF; hw++)
                for (int a = 0; a < THIN_ANGLES; a++) {
                    if (a0 >= 0 && abs(thin_wrap(a - a0 + THIN_ANGLES / 2) - THIN_ANGLES / 2) > THIN_SPREAD)
                        continue;
                    double th = a * 2 * M_PI / THIN_ANGLES;
                    double run = thin_run(g, x + 0.5, y + 0.5, cos(th), sin(th), hw, reach);
                    if (run > r->run[a])
                        r->run[a] = run, r->ox[a] = x + 0.5, r->oy[a] = y + 0.5, r->hw[a] = hw;
                }
        }
}

/* The bin within THIN_SPREAD of image direction (dx, dy) that holds the longest run. */
static int thin_best_near(const thin_rays *r, double dx, double dy)
{
    int a0 = thin_bin(dx, dy), best = -1;
    for (int k = -THIN_SPREAD; k <= THIN_SPREAD; k++) {
        int a = thin_wrap(a0 + k);
        if (best < 0 || r->run[a] > r->run[best])
            best = a;
    }
    return best;
}

/* Marks bin a's line as o's cast shadow (its pixels darker than the sides by the flood's bound), with its figures. */
static void thin_mark(grow *g, sp_depop_object *o, const thin_rays *r, int a)
{
    double th = a * 2 * M_PI / THIN_ANGLES, dx = cos(th), dy = sin(th), len = r->run[a];
    double ox0 = r->ox[a], oy0 = r->oy[a], hw = r->hw[a], side = hw + THIN_MARGIN;
    int x0 = clampi((int)floor(fmin(ox0, ox0 + len * dx) - side), 0, g->w - 1);
    int x1 = clampi((int)ceil(fmax(ox0, ox0 + len * dx) + side), 0, g->w - 1);
    int y0 = clampi((int)floor(fmin(oy0, oy0 + len * dy) - side), 0, g->h - 1);
    int y1 = clampi((int)ceil(fmax(oy0, oy0 + len * dy) + side), 0, g->h - 1);
    cone c = object_cone(g, o);
    double sx = 0, sy = 0;
    uint32_t took = 0;
    for (int y = y0; y <= y1; y++)
        for (int x = x0; x <= x1; x++) {
            double ox = x + 0.5 - ox0, oy = y + 0.5 - oy0, t = ox * dx + oy * dy, across = -ox * dy + oy * dx;
            size_t k = (size_t)y * g->w + x;
            if (t < -1 || t > len + 1 || fabs(across) > hw + 0.5 || g->mask[k] != M_NONE)
                continue;
            double cx = ox0 + t * dx, cy = oy0 + t * dy, left[3], right[3];
            const uint8_t *p = g->rgb + (size_t)y * g->stride + 3 * (size_t)x;
            if (!colour_at(g, cx - side * dy, cy + side * dx, left) &&
                !colour_at(g, cx + side * dy, cy - side * dx, right) &&
                p[0] + p[1] + p[2] <=
                    g->s->ratio_hi * fmin(left[0] + left[1] + left[2], right[0] + right[1] + right[2]))
                g->mask[k] = M_SHADOW, took++, sx += x - c.fx, sy += y - c.fy;
        }
    if (!took)
        return;
    double tx = ox0 + len * dx, ty = oy0 + len * dy;
    o->shadow_px = took, o->shadow_dx = sx / took, o->shadow_dy = sy / took, o->shadow_thin = 1;
    o->tip_x = tx, o->tip_y = ty, o->shadow_len = hypot(tx - c.fx, ty - c.fy), o->shadow_spill = 0;
    o->shadow_cut = tx < 2 || ty < 2 || tx > g->w - 3 || ty > g->h - 3 || len >= c.reach - 2;
}

/*
 * Whether bin a's line goes on past the object's other side: from the first unmasked pixel after the line,
 * followed back, leaves the box and its contact area, a dark line of the same width runs on for
 * THIN_THROUGH of the length (within a bin's angle and 2 px across of the way back: the origin and direction
 * are the search's grid). A road marking's gap, a kerb or a lamp post's shadow passes under the object; the
 * object's own shadow starts at it.
 */
static int thin_through(const grow *g, const sp_depop_object *o, const thin_rays *r, int a)
{
    int sb[4]; /* the box with its contact area, where the search's origins lie */
    seed_box(o, sb);
    for (int da = -1; da <= 1; da++)
        for (int across = -2; across <= 2; across++) {
            double th = (a + da) * 2 * M_PI / THIN_ANGLES, dx = -cos(th), dy = -sin(th), rgb[3];
            double x = r->ox[a] - across * dy, y = r->oy[a] + across * dx;
            int was_in = 0;
            for (int step = 0; step < g->w + g->h && x >= 0 && y >= 0 && x < g->w && y < g->h;
                 step++, x += dx, y += dy) {
                int in = x >= sb[0] && x <= sb[2] + 1 && y >= o->y0 && y <= sb[3] + 1;
                if (was_in && !in && !colour_at(g, x, y, rgb)) {
                    if (thin_run(g, x, y, dx, dy, r->hw[a], r->run[a]) >= THIN_THROUGH * r->run[a])
                        return 1;
                    break;
                }
                was_in |= in;
            }
        }
    return 0;
}

/* Bin a's run as a share of the object's height (at most 1) when it can be its shadow, else 0. */
static double thin_shadow_run(const grow *g, const sp_depop_object *o, const thin_rays *r, int a)
{
    int h = o->y1 - o->y0 + 1;
    if (r->run[a] < fmax(THIN_MIN_PX, THIN_MIN_SHARE * h) || thin_through(g, o, r, a))
        return 0;
    return fmin(1, r->run[a] / h);
}

/* Object o's shadow direction in the image, d: the given one, else ground direction psi's; -1 when unknown. */
static int thin_direction(const grow *g, const sp_depop_object *o, double psi, double d[2])
{
    double sl = hypot(g->s->sun_dx, g->s->sun_dy);
    if (sl > 0)
        return d[0] = g->s->sun_dx / sl, d[1] = g->s->sun_dy / sl, 0;
    return isfinite(psi) ? ground_to_image(g->s->camera, o, psi, d) : -1;
}

/*
 * Thin cast shadows the flood did not follow (a far walker's line under a low sun; DEPOPULATE.md, "Thin
 * shadows"), for the standing objects with a ground reference and no cast shadow yet. Along the given image
 * direction, the sun's ground direction psi_known, or else the ground direction whose image directions hold
 * the longest runs that can be shadows over the objects (a crossing's dark gaps run every way from one foot,
 * a shadow one way from every foot); refused, as one_sun's, when a second direction over 60 degrees away
 * scores 80% as much.
 */
static void thin_shadows(grow *g, sp_depop_object *objs, size_t n, const int *have, double psi_known)
{
    const sp_depop_camera *cam = g->s->camera;
    double sl = hypot(g->s->sun_dx, g->s->sun_dy), psi = psi_known, score[THIN_PSI_STEPS] = { 0 };
    if (!(sl > 0) && !cam)
        return;
    thin_rays *r = calloc(n + 1, sizeof(*r));
    int *use = calloc(n + 1, sizeof(int)), any = 0, best = -1;
    if (!r || !use) {
        free(r), free(use);
        return;
    }
    int voted = !(sl > 0) && !isfinite(psi_known); /* no direction yet: the objects' runs vote for one */
    for (size_t i = 0; i < n; i++) {
        double d[2];
        if (have[i] < 0 || !sp_depop_standing(&objs[i]) || objs[i].shadow_px || objs[i].strip_px)
            continue;
        int known = !thin_direction(g, &objs[i], psi_known, d);
        if (!known && !voted)
            continue;
        use[i] = 1, any = 1, thin_search(g, &objs[i], known ? thin_bin(d[0], d[1]) : -1, &r[i]);
    }
    for (int k = 0; any && voted && k < THIN_PSI_STEPS; k++) {
        double ps = k * 2 * M_PI / THIN_PSI_STEPS, d[2];
        for (size_t i = 0; i < n; i++)
            if (use[i] && !ground_to_image(cam, &objs[i], ps, d))
                score[k] += thin_shadow_run(g, &objs[i], &r[i], thin_best_near(&r[i], d[0], d[1]));
        if (score[k] > 0 && (best < 0 || score[k] > score[best]))
            best = k;
    }
    if (best >= 0) {
        psi = best * 2 * M_PI / THIN_PSI_STEPS;
        for (int k = 0; k < THIN_PSI_STEPS; k++) {
            int apart = abs(k - best) < THIN_PSI_STEPS / 2 ? abs(k - best) : THIN_PSI_STEPS - abs(k - best);
            if (apart * 360 > 60 * THIN_PSI_STEPS && score[k] >= 0.8 * score[best])
                psi = NAN; /* two ways, each as good: no sun tells itself here */
        }
    }
    for (size_t i = 0; i < n; i++) {
        double d[2];
        if (!use[i] || thin_direction(g, &objs[i], psi, d))
            continue;
        int a = thin_best_near(&r[i], d[0], d[1]);
        if (thin_shadow_run(g, &objs[i], &r[i], a) > 0)
            thin_mark(g, &objs[i], &r[i], a);
    }
    free(r), free(use);
}

/*
 * Every object's cast shadow. With the sun's image direction given, along it. With a camera, along the one
 * ground direction that closes the most shadows (one_sun); then, where those closed shadows tell the sun,
 * again from the mask before any cast shadow: each standing object's shadow in the sun's strip (sun_strip).
 * Without, each object's own lean where it agrees with the others' (within 40 degrees of their mean
 * direction), else the mean's: one sun casts every shadow, and a lone lean is more often dark ground than a
 * shadow. Last, a thin line for the standing objects still without one (thin_shadows).
 */
static void cast_shadows(grow *g, sp_depop_object *objs, size_t n)
{
    double sl = hypot(g->s->sun_dx, g->s->sun_dy), sx = 0, sy = 0;
    int with_camera = g->s->camera && !(sl > 0);
    uint8_t (*ref)[3] = malloc(n * 3 + 1);
    double (*dir)[2] = calloc(n + 1, sizeof(*dir));
    int *have = calloc(n + 1, sizeof(int)), agree = 0;
    uint8_t *before = with_camera ? malloc((size_t)g->w * g->h) : NULL; /* the mask before any cast shadow */
    if (!ref || !dir || !have) {
        free(ref), free(dir), free(have), free(before);
        return;
    }
    if (before)
        memcpy(before, g->mask, (size_t)g->w * g->h);
    for (size_t i = 0; i < n; i++)
        have[i] = ground_reference(g, &objs[i], ref[i]) ? -1 : sl > 0 ? 1 : 0;
    if (with_camera)
        one_sun(g, objs, n, (const uint8_t(*)[3])ref, have, dir);
    for (size_t i = 0; i < n; i++) {
        if (have[i] == 0 && !near_direction(g, &objs[i], ref[i], &dir[i][0], &dir[i][1]))
            have[i] = 2, sx += dir[i][0], sy += dir[i][1], agree++;
    }
    double ml = hypot(sx, sy);
    int consensus = agree >= 2 && ml > 0.5 * agree; /* several leans, and they roughly agree */
    double psi_known = NAN;                         /* the sun's ground direction, where the closed shadows told it */
    for (int pass = 0; pass < 2; pass++) {
        sp_depop_sun sun = { 0 };
        /* the second pass only where the first one's closed shadows tell the sun, or the clock does */
        if (pass == 1) {
            const sp_depop_sun *clock = g->s->clock_sun;
            int told = before && !sp_depop_sun_estimate(objs, n, g->s->camera, &sun) && sun.found && sun.closed &&
                sun.elevation_deg > 1;
            if (!told && before && clock && clock->elevation_deg > 1)
                sun = *clock, told = 1;
            if (!told)
                break;
            memcpy(g->mask, before, (size_t)g->w * g->h), psi_known = (sun.azimuth_deg + 180) * M_PI / 180;
        }
        for (size_t i = 0; i < n; i++) {
            sp_depop_object *o = &objs[i];
            if (pass == 1 && have[i] >= 0 && sp_depop_standing(o) && !sun_strip(g, o, ref[i], &sun))
                continue;
            if (have[i] == 1)
                cast_along(g, o, ref[i], g->s->sun_dx / sl, g->s->sun_dy / sl);
            else if (have[i] == 2 && consensus && dir[i][0] * sx / ml + dir[i][1] * sy / ml < cos(40 * M_PI / 180))
                cast_along(g, o, ref[i], sx / ml, sy / ml);
            else if (have[i] == 2 || have[i] == 3)
                cast_along(g, o, ref[i], dir[i][0], dir[i][1]);
        }
    }
    thin_shadows(g, objs, n, have, psi_known);
    free(ref), free(dir), free(have), free(before);
}

/* Marks the object (its mask or box) and a pixel around it. */
static void mark_object(grow *g, const sp_depop_object *o)
{
    for (int y = clampi(o->y0 - 1, 0, g->h - 1); y <= clampi(o->y1 + 1, 0, g->h - 1); y++)
        for (int x = clampi(o->x0 - 1, 0, g->w - 1); x <= clampi(o->x1 + 1, 0, g->w - 1); x++) {
            int hit = 0;
            for (int v = y - 1; v <= y + 1 && !hit; v++)
                for (int u = x - 1; u <= x + 1 && !hit; u++)
                    hit = u >= o->x0 && u <= o->x1 && v >= o->y0 && v <= o->y1 &&
                          (!o->mask || o->mask[(size_t)v * g->w + u]);
            if (hit)
                g->mask[(size_t)y * g->w + x] = M_OBJECT;
        }
}

/* The contact shadow: the ground within a few pixels of the object's lowest tenth. */
static void contact_shadow(grow *g, sp_depop_object *o)
{
    int h = o->y1 - o->y0 + 1, k = (int)lround(0.04 * h);
    k = k < 2 ? 2 : k;
    int ya = o->y1 - h / 10;
    uint32_t n = 0;
    for (int y = clampi(ya - k, 0, g->h - 1); y <= clampi(o->y1 + k, 0, g->h - 1); y++)
        for (int x = clampi(o->x0 - k, 0, g->w - 1); x <= clampi(o->x1 + k, 0, g->w - 1); x++) {
            size_t i = (size_t)y * g->w + x;
            if (g->mask[i] != M_NONE)
                continue;
            int near = 0;
            for (int v = y - k; v <= y + k && !near; v++)
                for (int u = x - k; u <= x + k && !near; u++)
                    near = v >= ya && v >= 0 && u >= 0 && u < g->w && v < g->h && v <= o->y1 &&
                           g->mask[(size_t)v * g->w + u] == M_OBJECT && u >= o->x0 - 1 && u <= o->x1 + 1;
            if (near)
                g->mask[i] = M_SHADOW, n++;
        }
    o->contact_px = n;
}

static int check(const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, const sp_depop_object *objs,
                 size_t n, const sp_depop_settings *s, const uint8_t *mask)
{
    if (!rgb || !mask || (!objs && n) || !s || width == 0 || height == 0 || width > 32768 || height > 32768 ||
        stride < 3 * width || !(s->ratio_lo > 0 && s->ratio_lo < s->ratio_hi && s->ratio_hi < 1) ||
        !(s->cone_deg > 0 && s->cone_deg <= 90) || !(s->max_length > 0 && s->max_length <= 20) ||
        !(s->chroma_tol >= 0 && s->chroma_tol < 1) || !isfinite(s->sun_dx) || !isfinite(s->sun_dy))
        return -EINVAL;
    if (s->camera &&
        (!(s->camera->f > 0 && s->camera->f < 1e6) || !isfinite(s->camera->cx) || !isfinite(s->camera->cy) ||
         !(s->camera->pitch_deg >= 0 && s->camera->pitch_deg < 89)))
        return -EINVAL;
    if (s->clock_sun && (!isfinite(s->clock_sun->azimuth_deg) || !(fabs(s->clock_sun->elevation_deg) <= 90)))
        return -EINVAL;
    for (size_t i = 0; i < n; i++)
        if (objs[i].x0 < 0 || objs[i].y0 < 0 || objs[i].x1 < objs[i].x0 || objs[i].y1 < objs[i].y0 ||
            objs[i].x1 >= (int)width || objs[i].y1 >= (int)height)
            return -EINVAL;
    return 0;
}

int sp_depop_mask(const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, sp_depop_object *objs,
                  size_t n, const sp_depop_settings *s, uint8_t *mask)
{
    sp_depop_settings def;
    sp_depop_default_settings(&def);
    s = s ? s : &def;
    int ret = check(rgb, width, height, stride, objs, n, s, mask);
    if (ret)
        return ret;
    size_t np = (size_t)width * height;
    grow g = { .rgb = rgb,
               .stride = stride,
               .w = (int)width,
               .h = (int)height,
               .mask = mask,
               .queue = malloc(np * sizeof(int32_t)),
               .seen = calloc(np, 1),
               .s = s,
               .lo = (int32_t)lround(s->ratio_lo * 1024),
               .hi = (int32_t)lround(s->ratio_hi * 1024),
               .tol = (int32_t)lround(s->chroma_tol * 1024) };
    if (!g.queue || !g.seen) {
        free(g.queue), free(g.seen);
        return -ENOMEM;
    }
    g.lit_top = g.hi >= 1 ? 1024 * 1024 / g.hi : 1024 * 1024; /* ratio_hi may round to 0 (the API allows it) */
    memset(mask, M_NONE, np);
    for (size_t i = 0; i < n; i++) {
        objs[i].shadow_px = objs[i].contact_px = 0, objs[i].shadow_leak = 0;
        objs[i].shadow_dx = objs[i].shadow_dy = objs[i].shadow_len = 0, objs[i].shadow_spill = 0;
        objs[i].shadow_cut = 0;
        objs[i].strip_px = 0, objs[i].shadow_thin = 0;
        objs[i].truncated =
            objs[i].x0 == 0 || objs[i].y0 == 0 || objs[i].x1 == (int)width - 1 || objs[i].y1 == (int)height - 1;
        mark_object(&g, &objs[i]);
    }
    for (size_t i = 0; i < n && s->shadows; i++)
        contact_shadow(&g, &objs[i]);
    if (s->shadows)
        cast_shadows(&g, objs, n);
    free(g.queue), free(g.seen);
    return 0;
}

/* One pixel of dilation keeps each class (object over shadow) so anti-aliased edges go too. */
static void dilate_classes(uint8_t *mask, uint8_t *tmp, int w, int h)
{
    memcpy(tmp, mask, (size_t)w * h);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            uint8_t best = tmp[(size_t)y * w + x];
            for (int v = y - 1; v <= y + 1; v++)
                for (int u = x - 1; u <= x + 1; u++)
                    if (u >= 0 && v >= 0 && u < w && v < h && tmp[(size_t)v * w + u] &&
                        (!best || tmp[(size_t)v * w + u] < best))
                        best = tmp[(size_t)v * w + u];
            mask[(size_t)y * w + x] = best;
        }
}

int sp_depop_keeps(const double *keep, size_t n_keep, int x0, int y0, int x1, int y1)
{
    for (size_t k = 0; k < n_keep; k++)
        if (keep[2 * k] >= x0 - 0.5 && keep[2 * k] <= x1 + 0.5 && keep[2 * k + 1] >= y0 - 0.5 &&
            keep[2 * k + 1] <= y1 + 0.5)
            return 1;
    return 0;
}

int sp_depop_from_plate(const uint8_t *rgb, const uint8_t *plate, uint32_t width, uint32_t height,
                        const sp_probe_plane *plane, const double *keep, size_t n_keep, sp_depop_object *objs,
                        size_t cap, size_t *n, size_t *kept, uint8_t *mask)
{
    if (!rgb || !plate || !mask || !n || !kept || (!objs && cap) || (!keep && n_keep) || width < 8 || height < 8 ||
        width > 32768 || height > 32768)
        return -EINVAL;
    sp_probe_settings ps;
    sp_probe_default_settings(&ps);
    probe_segment sg;
    int ret = segment_open(&sg, width, height, &ps);
    uint8_t *tmp = ret ? NULL : malloc((size_t)width * height);
    if (!ret && !tmp)
        ret = -ENOMEM;
    if (ret) {
        segment_close(&sg);
        return ret;
    }
    segment_frame(&sg, rgb, plate, plane);
    memset(mask, 0, (size_t)width * height);
    *n = *kept = 0;
    for (unsigned k = 0; k < sg.n_obj; k++) {
        const probe_object *o = &sg.obj[k];
        if (sp_depop_keeps(keep, n_keep, o->x0, o->y0, o->x1, o->y1)) {
            (*kept)++;
            continue;
        }
        if (*n < cap)
            objs[*n] = (sp_depop_object){ .x0 = o->x0, .y0 = o->y0, .x1 = o->x1, .y1 = o->y1,
                                          .shadow_px = o->shadow_area,
                                          .shadow_dx = o->shadow_area ? o->shadow_cx - o->foot_x : 0,
                                          .shadow_dy = o->shadow_area ? o->shadow_cy - o->foot_y : 0 };
        (*n)++;
        for (uint32_t y = 0; y < height; y++)
            for (uint32_t x = 0; x < width; x++) {
                size_t i = (size_t)y * width + x;
                if (sg.cls[i] != PROBE_CLS_BG && sg.lab_obj[(y / sg.block) * sg.gw + x / sg.block] == o->label)
                    mask[i] = sg.cls[i] == PROBE_CLS_OBJECT ? M_OBJECT : M_SHADOW;
            }
    }
    dilate_classes(mask, tmp, (int)width, (int)height);
    free(tmp);
    segment_close(&sg);
    return 0;
}
