/* SPDX-License-Identifier: MIT */
/*
 * The sun from one image: people and poles stand on the ground plane and
 * their cast shadows lie on it. Back-projecting a shadow's foot and tip onto
 * the plane gives the shadow's direction (the sun's azimuth, turned half way
 * round) and length; the object's height comes from its top on the vertical
 * through the foot; elevation = atan(height / length). The camera's height
 * cancels (everything is in camera heights). Medians over the objects keep
 * one leaking shadow or a mis-boxed object from steering the answer.
 */
#include "depopulate.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

#include "common/stats.h"

typedef struct basis {
    double xc[3], yc[3], zc[3]; /* camera axes in the world (z up, y the horizontal view direction) */
} basis;

static basis camera_basis(double pitch)
{
    double c = cos(pitch), s = sin(pitch);
    return (basis){ { 1, 0, 0 }, { 0, -s, -c }, { 0, c, -s } };
}

/* Ground point (x, y) under pixel (u, v) for a camera one unit above the ground; -1 above the horizon. */
static int ground_point(const sp_depop_camera *cam, const basis *b, double u, double v, double g[2])
{
    double a = (u - cam->cx) / cam->f, e = (v - cam->cy) / cam->f, d[3];
    for (int k = 0; k < 3; k++)
        d[k] = b->xc[k] * a + b->yc[k] * e + b->zc[k];
    if (!(d[2] < -1e-9))
        return -1;
    double t = -1.0 / d[2];
    g[0] = t * d[0], g[1] = t * d[1];
    return 0;
}

/* Height (in camera heights) of the point on the vertical through ground point g that projects to row v. */
static double height_at(const sp_depop_camera *cam, const basis *b, const double g[2], double v)
{
    double k = (v - cam->cy) / cam->f;
    double A = g[1] * b->yc[1] - b->yc[2], B = b->yc[2], C = g[1] * b->zc[1] - b->zc[2], D = b->zc[2];
    double den = k * D - B;
    return fabs(den) < 1e-12 ? (double)NAN : (A - k * C) / den;
}

int sp_depop_ground_point(const sp_depop_camera *cam, double u, double v, double g[2])
{
    basis b = camera_basis(cam->pitch_deg * M_PI / 180.0);
    return ground_point(cam, &b, u, v, g);
}

int sp_depop_project(const sp_depop_camera *cam, const double p[3], double *u, double *v)
{
    basis b = camera_basis(cam->pitch_deg * M_PI / 180.0);
    double d[3] = { p[0], p[1], p[2] - 1.0 }, a = 0, e = 0, z = 0;
    for (int k = 0; k < 3; k++)
        a += d[k] * b.xc[k], e += d[k] * b.yc[k], z += d[k] * b.zc[k];
    if (!(z > 1e-9))
        return -1;
    *u = cam->cx + cam->f * a / z, *v = cam->cy + cam->f * e / z;
    return 0;
}

double sp_depop_height_at(const sp_depop_camera *cam, const double g[2], double v)
{
    basis b = camera_basis(cam->pitch_deg * M_PI / 180.0);
    return height_at(cam, &b, g, v);
}

static double wrap180(double a)
{
    while (a > 180)
        a -= 360;
    while (a <= -180)
        a += 360;
    return a;
}

/*
 * One object's shadow as (azimuth of the sun, elevation) in degrees; -1 when it gives none, or when it is open
 * and open ones are not taken.
 */
static int object_sun(const sp_depop_object *o, const sp_depop_camera *cam, const basis *b, int take_open, double *az,
                      double *el)
{
    int h = o->y1 - o->y0 + 1, w = o->x1 - o->x0 + 1;
    /* a cast shadow covers about as much ground as the object's box holds of it; specks are not one */
    /* a thin line's tip is where the line test stops (grain, a lamp post across it), not where the shadow ends */
    if (o->shadow_leak || o->shadow_thin || o->shadow_px < 10 || o->shadow_px < 0.1 * w * h ||
        hypot(o->tip_x - 0.5 * (o->x0 + o->x1), o->tip_y - o->y1) < 0.1 * h)
        return -1;
    if (!sp_depop_standing(o) || (!take_open && !sp_depop_closed_shadow(o)))
        return -1;
    double foot[2], tip[2];
    if (ground_point(cam, b, 0.5 * (o->x0 + o->x1), o->y1 + 0.5, foot) ||
        ground_point(cam, b, o->tip_x + 0.5, o->tip_y + 0.5, tip))
        return -1;
    double H = height_at(cam, b, foot, o->y0 - 0.5), sx = tip[0] - foot[0], sy = tip[1] - foot[1];
    double L = hypot(sx, sy);
    if (!(H > 0) || !(L > 0))
        return -1;
    *az = wrap180(atan2(sx, sy) * 180.0 / M_PI + 180.0);
    *el = atan2(H, L) * 180.0 / M_PI;
    return 0;
}

int sp_depop_sun_estimate(const sp_depop_object *objs, size_t n, const sp_depop_camera *cam, sp_depop_sun *out)
{
    if (!out || (!objs && n) || !cam || !(cam->f > 0 && cam->f < 1e6) || !isfinite(cam->cx) ||
        !isfinite(cam->cy) || !(cam->pitch_deg >= 0 && cam->pitch_deg < 89))
        return -EINVAL;
    *out = (sp_depop_sun){ 0 };
    double *az = malloc((n + 1) * sizeof(double)), *el = malloc((n + 1) * sizeof(double));
    if (!az || !el) {
        free(az), free(el);
        return -ENOMEM;
    }
    basis b = camera_basis(cam->pitch_deg * M_PI / 180.0);
    /* closed shadows, whose tips are their ends; only where there is none, the open ones (said in .closed) */
    size_t m = 0;
    int open = 0;
    for (size_t i = 0; i < n; i++)
        m += !object_sun(&objs[i], cam, &b, 0, &az[m], &el[m]);
    if (!m) {
        open = 1;
        for (size_t i = 0; i < n; i++)
            m += !object_sun(&objs[i], cam, &b, 1, &az[m], &el[m]);
    }
    if (m) {
        /* the azimuth's median on the circle: relative to the first, wrapped, then back */
        double ref = az[0];
        for (size_t i = 0; i < m; i++)
            az[i] = wrap180(az[i] - ref);
        double ma = sp_median_inplace(az, m), me = sp_median_inplace(el, m);
        for (size_t i = 0; i < m; i++)
            az[i] = fabs(wrap180(az[i] - ma)), el[i] = fabs(el[i] - me);
        *out = (sp_depop_sun){ 1,           wrap180(ma + ref),        me,
                               (unsigned)m, sp_median_inplace(az, m), sp_median_inplace(el, m),
                               !open };
    }
    free(az), free(el);
    return 0;
}
