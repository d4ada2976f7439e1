/* SPDX-License-Identifier: MIT */
/*
 * Compositing cut-outs with what the probe learned: the height from the
 * plane (eq. 3.7), hidden pixels from the occlusion map (eq. 3.2: a pixel
 * occludes objects whose bottom row is at most its value), brightness scaled by
 * the lighting map under the object (eq. 3.4), and a shadow: the cut-out's
 * alpha projected along the learned direction, darkening the ground by the
 * learned ratio except where the ground is already in shadow. Objects are drawn
 * back to front by ground row; each one's shadow before it.
 */
#include "probe_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MAX_SUPERSAMPLE 6

void sp_composite_default_settings(sp_composite_settings *s)
{
    if (!s)
        return;
    s->occlusion = 1;
    s->lighting = 1;
    s->shadow = 1;
}

/* The cut-out's visible content (alpha > 0) and its placement on screen. */
typedef struct placed {
    const sp_composite_object *o;
    int left, top, right, bottom; /* content box in the cut-out, inclusive */
    double k;                     /* screen pixels per cut-out pixel */
    double uc;                    /* content centre column (continuous) */
    double x, yb;                 /* screen: ground point column centre, bottom edge (y + 0.5) */
    double h;                     /* screen height */
} placed;

static int content_box(const sp_composite_object *o, placed *p)
{
    p->left = (int)o->width, p->top = (int)o->height, p->right = -1, p->bottom = -1;
    for (uint32_t y = 0; y < o->height; y++)
        for (uint32_t x = 0; x < o->width; x++)
            if (o->rgba[(size_t)y * o->stride + 4 * x + 3]) {
                p->left = (int)x < p->left ? (int)x : p->left;
                p->right = (int)x > p->right ? (int)x : p->right;
                p->top = (int)y < p->top ? (int)y : p->top;
                p->bottom = (int)y;
            }
    return p->right >= 0 ? 0 : SP_ENODATA;
}

/* Bilinear sample of the premultiplied cut-out at continuous (u, v); out = r a, g a, b a, a in 0..1. */
static void sample(const sp_composite_object *o, double u, double v, double out[4])
{
    double fx = u - 0.5, fy = v - 0.5;
    int x0 = (int)floor(fx), y0 = (int)floor(fy);
    double ax = fx - x0, ay = fy - y0;
    memset(out, 0, 4 * sizeof(double));
    for (int j = 0; j < 2; j++)
        for (int i = 0; i < 2; i++) {
            int x = x0 + i, y = y0 + j;
            if (x < 0 || y < 0 || x >= (int)o->width || y >= (int)o->height)
                continue;
            double w = (i ? ax : 1 - ax) * (j ? ay : 1 - ay);
            const uint8_t *p = o->rgba + (size_t)y * o->stride + 4 * (size_t)x;
            double a = p[3] / 255.0;
            out[0] += w * a * p[0] / 255.0, out[1] += w * a * p[1] / 255.0, out[2] += w * a * p[2] / 255.0;
            out[3] += w * a;
        }
}

/* Area-averaged sample of the screen pixel (X, Y): supersampled when the cut-out shrinks. */
static void screen_sample(const placed *p, double X, double Y, double out[4])
{
    int s = p->k < 1 ? (int)ceil(1.0 / p->k) : 1;
    s = s > MAX_SUPERSAMPLE ? MAX_SUPERSAMPLE : s;
    memset(out, 0, 4 * sizeof(double));
    for (int j = 0; j < s; j++)
        for (int i = 0; i < s; i++) {
            double sx = X + (i + 0.5) / s, sy = Y + (j + 0.5) / s, v[4];
            double u = (sx - p->x - 0.5) / p->k + p->uc, w = (sy - p->yb) / p->k + p->bottom + 1;
            sample(p->o, u, w, v);
            for (int c = 0; c < 4; c++)
                out[c] += v[c] / (s * s);
        }
}

static int hidden(const sp_probe_maps *m, const sp_composite_settings *s, size_t i, double ground_row)
{
    return s->occlusion && m->occlusion && m->occlusion[i] >= 0 && ground_row <= (double)m->occlusion[i];
}

/* Eq. 3.4: the mean relative lighting under the object's footprint, 1 where nothing was seen. */
static void lighting_gain(const sp_probe_maps *m, const placed *p, int x0, int y0, int x1, int y1, double g[3])
{
    double sum[3] = { 0, 0, 0 }, wsum = 0;
    for (int Y = y0; Y <= y1 && m->lighting; Y++)
        for (int X = x0; X <= x1; X++) {
            const float *l = m->lighting + 3 * ((size_t)Y * m->width + (size_t)X);
            if (!(l[0] > 0 || l[1] > 0 || l[2] > 0))
                continue;
            double v[4];
            screen_sample(p, X, Y, v);
            for (int c = 0; c < 3; c++)
                sum[c] += v[3] * (double)l[c];
            wsum += v[3];
        }
    for (int c = 0; c < 3; c++) {
        double gc = wsum > 0 ? sum[c] / wsum : 1.0;
        g[c] = gc < 0.1 ? 0.1 : gc > 4.0 ? 4.0 : gc;
    }
}

static void screen_box(const sp_probe_maps *m, const placed *p, int *x0, int *y0, int *x1, int *y1)
{
    double l = p->x + 0.5 + (p->left - p->uc) * p->k, r = p->x + 0.5 + (p->right + 1 - p->uc) * p->k;
    *x0 = (int)floor(l) - 1, *x1 = (int)ceil(r) + 1;
    *y0 = (int)floor(p->yb - p->h) - 1, *y1 = (int)ceil(p->yb) + 1;
    *x0 = *x0 < 0 ? 0 : *x0, *y0 = *y0 < 0 ? 0 : *y0;
    *x1 = *x1 >= (int)m->width ? (int)m->width - 1 : *x1;
    *y1 = *y1 >= (int)m->height ? (int)m->height - 1 : *y1;
}

static void draw_object(const sp_probe_maps *m, const sp_composite_settings *s, const placed *p, uint8_t *rgb,
                        uint32_t stride, sp_composite_report *rep)
{
    int x0, y0, x1, y1;
    screen_box(m, p, &x0, &y0, &x1, &y1);
    double g[3] = { 1, 1, 1 };
    if (s->lighting)
        lighting_gain(m, p, x0, y0, x1, y1, g);
    double row = floor(p->yb - 0.5);
    for (int Y = y0; Y <= y1; Y++)
        for (int X = x0; X <= x1; X++) {
            double v[4];
            screen_sample(p, X, Y, v);
            if (v[3] <= 0)
                continue;
            if (hidden(m, s, (size_t)Y * m->width + (size_t)X, row)) {
                rep->pixels_hidden++;
                continue;
            }
            uint8_t *d = rgb + (size_t)Y * stride + 3 * (size_t)X;
            for (int c = 0; c < 3; c++) {
                double out = v[c] * g[c] * 255.0 + (1 - v[3]) * d[c];
                d[c] = (uint8_t)(out < 0 ? 0 : out > 255 ? 255 : lrint(out));
            }
            rep->pixels_drawn++;
        }
    memcpy(rep->gain, g, sizeof(g));
}

/* How much of the full shadow darkening the ground at pixel i can still take (pre-existing shadow: less). */
static double lit_fraction(const sp_probe_maps *m, size_t i, const double ratio[3])
{
    if (!m->lighting)
        return 1.0;
    const float *l = m->lighting + 3 * i;
    double L = 0.299 * (double)l[0] + 0.587 * (double)l[1] + 0.114 * (double)l[2];
    double r = 0.299 * ratio[0] + 0.587 * ratio[1] + 0.114 * ratio[2];
    if (!(L > 0) || !(r < 0.98))
        return 1.0; /* nothing seen here, or shadows that barely darken */
    double f = (L - r) / (1.0 - r);
    return f < 0 ? 0 : f > 1 ? 1 : f;
}

static void draw_shadow(const sp_probe_maps *m, const sp_composite_settings *s, const sp_probe_shadow *sh,
                        const placed *p, uint8_t *rgb, uint32_t stride, sp_composite_report *rep)
{
    double u = p->x / m->width, v = floor(p->yb - 0.5) / m->height;
    double Ox = (sh->ox[0] + sh->ox[1] * u + sh->ox[2] * v) * p->h;
    double Oy = (sh->oy[0] + sh->oy[1] * u + sh->oy[2] * v) * p->h;
    if (!isfinite(Ox) || !isfinite(Oy))
        return;
    /* a shadow seen edge-on keeps a tenth of the height, roughly the depth of the feet */
    double min_oy = 0.1 * p->h;
    Oy = fabs(Oy) < min_oy ? (Oy < 0 ? -min_oy : min_oy) : Oy;
    int ox0, oy0, ox1, oy1;
    screen_box(m, p, &ox0, &oy0, &ox1, &oy1);
    double xa = fmin(ox0, ox0 + Ox), xb = fmax(ox1, ox1 + Ox), ya = fmin(p->yb, p->yb + Oy), yb = fmax(p->yb, p->yb + Oy);
    int X0 = (int)fmax(0, floor(xa) - 1), X1 = (int)fmin(m->width - 1, ceil(xb) + 1);
    int Y0 = (int)fmax(0, floor(ya) - 1), Y1 = (int)fmin(m->height - 1, ceil(yb) + 1);
    for (int Y = Y0; Y <= Y1; Y++)
        for (int X = X0; X <= X1; X++) {
            /* invert the projection: the ground point (X, Y) is the shadow of the object point at height t */
            double t = (Y + 0.5 - p->yb) / Oy, sv[4];
            if (t < 0 || t > 1)
                continue;
            double px = X + 0.5 - t * Ox, py = p->yb - t * p->h;
            screen_sample(p, px - 0.5, py - 0.5, sv);
            size_t i = (size_t)Y * m->width + (size_t)X;
            if (sv[3] <= 0 || hidden(m, s, i, Y))
                continue;
            double lit = lit_fraction(m, i, sh->ratio);
            uint8_t *d = rgb + (size_t)Y * stride + 3 * (size_t)X;
            for (int c = 0; c < 3; c++) {
                double f = 1.0 - sv[3] * lit * (1.0 - sh->ratio[c]);
                double out = d[c] * f;
                d[c] = (uint8_t)(out < 0 ? 0 : out > 255 ? 255 : lrint(out));
            }
            rep->shadow_pixels++;
        }
}

/* The contact profile at normalised distance rho: through the rings' centres, the first one inward and 1 at
   the reference's centre (1.75) and beyond. */
static double contact_at(const sp_probe_shadow *sh, double rho)
{
    double x0 = 0.125, y0 = sh->contact[0];
    if (rho <= x0)
        return y0;
    for (int k = 1; k <= SP_PROBE_CONTACT_BINS; k++) {
        double x1 = k < SP_PROBE_CONTACT_BINS ? (k + 0.5) / 4 : 1.75,
               y1 = k < SP_PROBE_CONTACT_BINS ? sh->contact[k] : 1;
        if (rho <= x1)
            return y0 + (y1 - y0) * (rho - x0) / (x1 - x0);
        x0 = x1, y0 = y1;
    }
    return 1.0;
}

/*
 * Without a sun model, the soft darkening people were seen to make around their feet (the probe's contact
 * profile, measured across the foot row in units of 0.25 h): here an ellipse around this object's foot
 * whose semi-axes are 0.25 h across and a third of that deep (the probe does not know the camera's
 * foreshortening), out to 1.75 of them. Ground the occlusion map hides is left; the object is drawn over its
 * own part.
 */
static void draw_contact(const sp_probe_maps *m, const sp_composite_settings *s, const sp_probe_shadow *sh,
                         const placed *p, uint8_t *rgb, uint32_t stride, sp_composite_report *rep)
{
    double a = 0.25 * p->h, b = a / 3;
    if (!(b > 0.25))
        return;
    int X0 = (int)fmax(0, floor(p->x - 1.75 * a)), X1 = (int)fmin(m->width - 1, ceil(p->x + 1.75 * a));
    int Y0 = (int)fmax(0, floor(p->yb - 1.75 * b)), Y1 = (int)fmin(m->height - 1, ceil(p->yb + 1.75 * b));
    for (int Y = Y0; Y <= Y1; Y++)
        for (int X = X0; X <= X1; X++) {
            double du = (X + 0.5 - p->x) / a, dv = (Y + 0.5 - p->yb) / b, f = contact_at(sh, sqrt(du * du + dv * dv));
            size_t i = (size_t)Y * m->width + (size_t)X;
            if (!(f < 1) || hidden(m, s, i, Y))
                continue;
            uint8_t *d = rgb + (size_t)Y * stride + 3 * (size_t)X;
            for (int c = 0; c < 3; c++) {
                double out = d[c] * f; /* a caller's profile may be anything: clamped */
                d[c] = (uint8_t)(out < 0 ? 0 : out > 255 ? 255 : lrint(out));
            }
            rep->contact_pixels++;
        }
}

static int check_args(const sp_probe_maps *m, const sp_composite_object *objs, size_t n, const uint8_t *rgb,
                      uint32_t stride)
{
    if (!m || !rgb || (!objs && n) || m->width == 0 || m->height == 0 || stride < m->width * 3)
        return -EINVAL;
    for (size_t i = 0; i < n; i++) {
        const sp_composite_object *o = &objs[i];
        if (!o->rgba || !o->width || !o->height || o->stride < o->width * 4 || !isfinite(o->x) ||
            !isfinite(o->y) || o->x < 0 || o->y < 0 || o->x >= m->width || o->y >= m->height ||
            !(o->height_px >= 0 && o->height_px < 1e6) || !(o->height_scale >= 0 && o->height_scale < 1e3))
            return -EINVAL;
    }
    return 0;
}

static int place(const sp_composite_object *o, const sp_probe_plane *plane, placed *p)
{
    memset(p, 0, sizeof(*p));
    p->o = o;
    int ret = content_box(o, p);
    if (ret)
        return ret;
    double scale = o->height_scale > 0 ? o->height_scale : 1.0;
    p->h = o->height_px > 0 ? o->height_px : sp_probe_plane_height(plane, o->x, o->y) * scale;
    if (!(p->h >= 1.0))
        return SP_ENODATA; /* the plane does not say how tall things are here */
    p->k = p->h / (double)(p->bottom - p->top + 1);
    p->uc = 0.5 * (p->left + p->right + 1);
    p->x = o->x;
    p->yb = o->y + 0.5;
    return 0;
}

int sp_composite(const sp_probe_maps *maps, const sp_probe_plane *plane, const sp_probe_shadow *shadow,
                 const sp_composite_settings *s, const sp_composite_object *objects, size_t n, uint8_t *rgb,
                 uint32_t stride, sp_composite_report *report)
{
    int ret = check_args(maps, objects, n, rgb, stride);
    if (ret)
        return ret;
    sp_composite_settings def;
    sp_composite_default_settings(&def);
    s = s ? s : &def;
    placed *pl = calloc(n ? n : 1, sizeof(*pl));
    if (!pl)
        return -ENOMEM;
    for (size_t i = 0; i < n && !ret; i++)
        ret = place(&objects[i], plane, &pl[i]);
    /* back to front: farther objects (smaller ground row) first; insertion sort keeps equal rows in order */
    for (size_t i = 1; i < n && !ret; i++)
        for (size_t j = i; j > 0 && pl[j - 1].yb > pl[j].yb; j--) {
            placed t = pl[j];
            pl[j] = pl[j - 1];
            pl[j - 1] = t;
        }
    sp_composite_report rep = { 0 };
    for (size_t i = 0; i < n && !ret; i++) {
        if (s->shadow && shadow && shadow->present)
            draw_shadow(maps, s, shadow, &pl[i], rgb, stride, &rep);
        else if (s->shadow && shadow && shadow->contact_present)
            draw_contact(maps, s, shadow, &pl[i], rgb, stride, &rep);
        draw_object(maps, s, &pl[i], rgb, stride, &rep);
        rep.height_px = pl[i].h;
    }
    free(pl);
    if (report && !ret)
        *report = rep;
    return ret;
}
