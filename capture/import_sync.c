/* SPDX-License-Identifier: MIT */
/*
 * --imu-offset auto: the IMU-video time offset from the data. The frames' visual motion (the normal
 * flow between consecutive grey thumbnails, in px/s) and the gyro's
 * rate magnitude (averaged over each frame pair's interval) rise and fall together as the camera
 * turns; the offset is the shift of the gyro series that maximises their normalised
 * cross-correlation. Magnitudes make it independent of the IMU-to-camera rotation and of the focal
 * length. Method and limits: IMPORT.md, "Automatic offset".
 */
#include "import_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define THUMB_W 96
#define GRID_NS 1000000LL      /* the gyro is resampled on a 1 ms grid */
#define MIN_PAIRS 10
#define MIN_CORR 0.5           /* below this the peak is not told apart from noise */

static int grow(double **a, double **b, size_t n, size_t *cap)
{
    if (n < *cap)
        return 0;
    size_t c = *cap ? *cap * 2 : 1024;
    double *pa = realloc(*a, c * sizeof(*pa));
    if (pa)
        *a = pa;
    double *pb = pa ? realloc(*b, c * sizeof(*pb)) : NULL;
    if (pb)
        *b = pb;
    if (!pa || !pb)
        return -ENOMEM;
    *cap = c;
    return 0;
}

/* Box-averaged grey thumbnail THUMB_W wide. */
static void thumbnail(const uint8_t *rgb, uint32_t w, uint32_t h, float *out, int tw, int th)
{
    for (int ty = 0; ty < th; ty++)
        for (int tx = 0; tx < tw; tx++) {
            uint32_t x0 = (uint32_t)((uint64_t)tx * w / (uint32_t)tw), x1 = (uint32_t)((uint64_t)(tx + 1) * w / (uint32_t)tw);
            uint32_t y0 = (uint32_t)((uint64_t)ty * h / (uint32_t)th), y1 = (uint32_t)((uint64_t)(ty + 1) * h / (uint32_t)th);
            double sum = 0;
            for (uint32_t y = y0; y < y1; y++)
                for (uint32_t x = x0; x < x1; x++) {
                    const uint8_t *p = rgb + ((size_t)y * w + x) * 3;
                    sum += 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2];
                }
            size_t n = (size_t)(x1 - x0) * (y1 - y0);
            out[ty * tw + tx] = (float)(n ? sum / (double)n : 0);
        }
}

/*
 * How far the image moved from a to b, in px: the mean temporal difference over the mean spatial
 * gradient (normal flow). Unlike a one-step Lucas-Kanade translation it does not break down for shifts
 * of several pixels, nor when a face that moves with the camera covers part of the frame; it
 * saturates for very large shifts but stays monotonic, which is all a correlation needs.
 */
static double motion_magnitude(const float *a, const float *b, int w, int h)
{
    double dt = 0, grad = 0;
    for (int y = 1; y < h - 1; y++)
        for (int x = 1; x < w - 1; x++) {
            int i = y * w + x;
            double gx = 0.25 * (double)(a[i + 1] - a[i - 1] + b[i + 1] - b[i - 1]);
            double gy = 0.25 * (double)(a[i + w] - a[i - w] + b[i + w] - b[i - w]);
            dt += fabs((double)(b[i] - a[i]));
            grad += hypot(gx, gy);
        }
    return grad > 1e-6 * (double)w * h ? dt / grad : (double)NAN; /* a flat image: nothing to measure */
}

int sp_import_sync_frame(sp_import_sync *s, const uint8_t *rgb, uint32_t w, uint32_t h, int64_t t_ns)
{
    if (!s->prev) {
        s->tw = (int)(w < THUMB_W ? w : THUMB_W);
        s->th = (int)fmax(1, lround((double)h * s->tw / w));
        s->prev = malloc((size_t)s->tw * (size_t)s->th * sizeof(float));
        s->cur = malloc((size_t)s->tw * (size_t)s->th * sizeof(float));
        if (!s->prev || !s->cur)
            return -ENOMEM;
    }
    thumbnail(rgb, w, h, s->cur, s->tw, s->th);
    if (s->have_prev && t_ns > s->prev_t && s->tw >= 8 && s->th >= 8) {
        double m = motion_magnitude(s->prev, s->cur, s->tw, s->th);
        if (isfinite(m)) {
            if (s->n == s->cap) {
                size_t cap = s->cap ? s->cap * 2 : 1024;
                sp_sync_pair *p = realloc(s->pairs, cap * sizeof(*p));
                if (!p)
                    return -ENOMEM;
                s->pairs = p;
                s->cap = cap;
            }
            s->pairs[s->n++] = (sp_sync_pair){ (double)s->prev_t, (double)t_ns,
                                               m / ((double)(t_ns - s->prev_t) * 1e-9) };
        }
    }
    float *tmp = s->prev;
    s->prev = s->cur;
    s->cur = tmp;
    s->have_prev = 1;
    s->prev_t = t_ns;
    return 0;
}

int sp_import_sync_gyro(sp_import_sync *s, int64_t t_ns, const float v[3])
{
    int rc = grow(&s->gt, &s->gw, s->gn, &s->gcap);
    if (rc)
        return rc;
    s->gt[s->gn] = (double)t_ns;
    double x = (double)v[0], y = (double)v[1], z = (double)v[2];
    s->gw[s->gn++] = sqrt(x * x + y * y + z * z);
    return 0;
}

/* Prefix sums of the gyro magnitude on a 1 ms grid from its first sample (linear between samples). */
static double *gyro_grid(const sp_import_sync *s, size_t *ng)
{
    double span = s->gt[s->gn - 1] - s->gt[0];
    *ng = (size_t)(span / GRID_NS) + 2;
    double *p = malloc(*ng * sizeof(*p));
    if (!p)
        return NULL;
    p[0] = 0;
    for (size_t k = 1, j = 0; k < *ng; k++) {
        double t = s->gt[0] + (double)(k - 1) * GRID_NS;
        while (j + 2 < s->gn && s->gt[j + 1] <= t)
            j++;
        double dt = s->gt[j + 1] - s->gt[j], a = dt > 0 ? fmin(fmax((t - s->gt[j]) / dt, 0), 1) : 0;
        p[k] = p[k - 1] + s->gw[j] + a * (s->gw[j + 1] - s->gw[j]);
    }
    return p;
}

/* NCC of the visual motion with the gyro shifted by offset (IMU time + offset = video time). */
static double ncc_at(const sp_import_sync *s, const double *grid, size_t ng, double offset_ns, size_t *used)
{
    double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    size_t n = 0;
    for (size_t i = 0; i < s->n; i++) {
        const sp_sync_pair *pr = &s->pairs[i];
        double a = (pr->t0 - offset_ns - s->gt[0]) / GRID_NS, b = (pr->t1 - offset_ns - s->gt[0]) / GRID_NS;
        if (a < 0 || b >= (double)(ng - 1) || b - a < 1)
            continue;
        size_t ka = (size_t)a, kb = (size_t)b;
        double g = (grid[kb] - grid[ka]) / (double)(kb - ka);
        double x = pr->m;
        sx += x, sy += g, sxx += x * x, syy += g * g, sxy += x * g;
        n++;
    }
    *used = n;
    if (n < MIN_PAIRS)
        return (double)NAN;
    double vx = sxx - sx * sx / (double)n, vy = syy - sy * sy / (double)n;
    return vx > 0 && vy > 0 ? (sxy - sx * sy / (double)n) / sqrt(vx * vy) : (double)NAN;
}

int sp_import_sync_estimate(const sp_import_sync *s, double base_s, double range_s, double *offset_s, double *corr,
                            char *msg, size_t msg_size)
{
    if (s->n < MIN_PAIRS || s->gn < 2)
        return sp_import_fail(msg, msg_size, SP_ENODATA, "--imu-offset auto: %zu frame pairs with measurable motion "
                              "and %zu gyroscope samples; needs at least %d and 2", s->n, s->gn, MIN_PAIRS);
    size_t ng;
    double *grid = gyro_grid(s, &ng);
    if (!grid)
        return -ENOMEM;
    long steps = lround(range_s * 1e3);
    double best = -2, at = 0, nb[2];
    int overlapped = 0;
    double *c = malloc((size_t)(2 * steps + 1) * sizeof(*c));
    if (!c) {
        free(grid);
        return -ENOMEM;
    }
    for (long k = -steps; k <= steps; k++) {
        size_t used;
        double v = ncc_at(s, grid, ng, (base_s + (double)k * 1e-3) * 1e9, &used);
        c[k + steps] = v;
        overlapped |= used * 2 >= s->n;
        if (v > best && used * 2 >= s->n) {
            best = v;
            at = (double)k;
        }
    }
    if (best > -2) { /* parabola through the peak and its neighbours */
        long k = lround(at) + steps;
        nb[0] = k > 0 ? c[k - 1] : (double)NAN;
        nb[1] = k < 2 * steps ? c[k + 1] : (double)NAN;
        double den = nb[0] - 2 * best + nb[1];
        if (isfinite(den) && den < 0)
            at += fmax(-0.5, fmin(0.5, 0.5 * (nb[0] - nb[1]) / den));
    }
    free(c);
    free(grid);
    if (!overlapped)
        return sp_import_fail(msg, msg_size, SP_ENODATA, "--imu-offset auto: the gyroscope log and the frames do not "
                              "overlap by half the frames within +-%g s of the clock's mapping; give --imu-offset S",
                              range_s);
    if (!(best > -2))
        return sp_import_fail(msg, msg_size, SP_ECORRUPT, "--imu-offset auto: the gyroscope's rate or the frames' "
                              "motion does not vary, so there is nothing to match; give --imu-offset S");
    *corr = best;
    *offset_s = base_s + at * 1e-3;
    if (best < MIN_CORR || fabs(at) >= (double)steps)
        return sp_import_fail(msg, msg_size, SP_ECORRUPT, "--imu-offset auto: no clear match between the gyroscope "
                              "and the frames' motion (best correlation %.2f at %+.3f s, needs %.2f inside +-%g s; a "
                              "steady turn has no changes of speed to match: record its start or end too); give "
                              "--imu-offset S", best, *offset_s, MIN_CORR, range_s);
    return 0;
}

void sp_import_sync_free(sp_import_sync *s)
{
    free(s->prev);
    free(s->cur);
    free(s->pairs);
    free(s->gt);
    free(s->gw);
    memset(s, 0, sizeof(*s));
}
