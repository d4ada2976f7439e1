/* SPDX-License-Identifier: MIT */
/*
 * The shadow model without a network. A person's cast shadow, seen as the
 * shadow pixels of the person's component, is the person's mask projected
 * along one image direction: a mask point at height fraction t lands at
 * foot + t (dx, dy) h. Since the projection is affine, the shadow's centroid
 * is the mask's centroid moved by tbar (dx, dy) h, which gives (dx, dy) per
 * observation. A robust linear fit of dx and dy over the normalised ground
 * point captures perspective; the ratio of shadowed to lit plate colour gives
 * the attenuation. Too few hard shadows (overcast) or directions that disagree
 * leave the model out, with the reason.
 */
#include "probe_internal.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/stats.h"

#define SHADOW_REC 4          /* u, v, dx, dy */
#define MIN_AREA_FRACTION 0.1 /* shadow pixels over mask pixels for a hard shadow */
#define MIN_LENGTH 0.15       /* |(dx, dy)|: contact shadows under the feet are shorter */
#define MAX_RATIO 0.7         /* a hard shadow keeps at most this much of the light (soft ones, overcast: more) */
#define MIN_HARD_FRACTION 0.25
#define MIN_HARD 8
#define ABSENT_CANDIDATES 100 /* person observations before "no hard shadows" is trusted while probing */
#define MIN_RESULTANT 0.7     /* mean resultant length of the directions: about 48 degrees of spread */

int shadows_open(probe_shadows *sh, unsigned cap, uint64_t seed)
{
    memset(sh, 0, sizeof(*sh));
    return reservoir_open(&sh->obs, cap, SHADOW_REC, seed ^ 0x5ad0u);
}

void shadows_close(probe_shadows *sh)
{
    reservoir_close(&sh->obs);
}

/* The bin of a shadow/lit ratio in the ratio histograms (over [0, 2); 2 and above in the last). */
static size_t ratio_bin(double r)
{
    size_t b = (size_t)(r * 0.5 * PROBE_RATIO_BINS);
    return b < PROBE_RATIO_BINS ? b : PROBE_RATIO_BINS - 1;
}

static void add_ratios(probe_shadows *sh, const probe_segment *sg, const probe_object *o, const uint8_t *rgb,
                       const uint8_t *plate)
{
    const int32_t *box = sg->comp + 5 * o->label; /* the component's cell bounding box */
    uint32_t x0 = (uint32_t)box[0] * sg->block, y0 = (uint32_t)box[1] * sg->block;
    uint32_t x1 = (uint32_t)(box[2] + 1) * sg->block, y1 = (uint32_t)(box[3] + 1) * sg->block;
    x1 = x1 < sg->width ? x1 : sg->width;
    y1 = y1 < sg->height ? y1 : sg->height;
    for (uint32_t y = y0; y < y1; y++) {
        const uint8_t *c = sg->cls + (size_t)y * sg->width;
        const int32_t *lab = sg->lab_obj + (size_t)(y / sg->block) * sg->gw;
        for (uint32_t x = x0; x < x1; x++) {
            if (c[x] != PROBE_CLS_SHADOW || lab[x / sg->block] != o->label)
                continue;
            size_t i = ((size_t)y * sg->width + x) * 3;
            for (int k = 0; k < 3; k++) {
                if (!plate[i + k])
                    continue;
                sh->ratio_hist[k][ratio_bin((double)rgb[i + k] / plate[i + k])]++;
            }
        }
    }
}

/*
 * The ground beside a person's feet against the plate (R + G + B over the plate's), by distance from the foot across the image in units
 * of CONTACT_ACROSS h, in quarter rings out to twice that: rows within a band around the foot row only, so
 * the camera's foreshortening of the ground (unknown here) does not enter. Object pixels (the person's
 * legs, anyone else) do not count; ground and shadow pixels do.
 */
#define CONTACT_ACROSS 0.25
static void add_contact(probe_shadows *sh, const probe_segment *sg, const probe_object *o, const uint8_t *rgb,
                        const uint8_t *plate)
{
    double a = CONTACT_ACROSS * o->height;
    if (!(a >= 2))
        return; /* too small a figure for rings */
    int band = (int)fmax(1, 0.03 * o->height), yf = (int)floor(o->foot_y);
    int x0 = (int)floor(o->foot_x - 2 * a), x1 = (int)ceil(o->foot_x + 2 * a);
    uint64_t got = 0;
    for (int y = yf - band < 0 ? 0 : yf - band; y <= yf + band && y < (int)sg->height; y++)
        for (int x = x0 < 0 ? 0 : x0; x <= x1 && x < (int)sg->width; x++) {
            size_t i = (size_t)y * sg->width + (size_t)x;
            double rho = fabs(x + 0.5 - o->foot_x) / a;
            if (rho >= 2 || sg->cls[i] == PROBE_CLS_OBJECT)
                continue;
            const uint8_t *c = rgb + 3 * i, *q = plate + 3 * i;
            int lit = q[0] + q[1] + q[2];
            if (lit < 12)
                continue; /* black plate: no ratio to tell */
            sh->contact_hist[(int)(rho * 4)][ratio_bin((double)(c[0] + c[1] + c[2]) / lit)]++;
            got++;
        }
    sh->contact_obs += got > 0;
}

int shadows_add(probe_shadows *sh, const probe_segment *sg, const probe_object *o, const uint8_t *rgb,
                const uint8_t *plate)
{
    sh->candidates++;
    if (o->height > 0 && !isfinite(o->cut_foot)) /* a foot behind a low occluder: its top edge is no ground */
        add_contact(sh, sg, o, rgb, plate);
    if (o->shadow_area < MIN_AREA_FRACTION * o->area || !(o->tbar > 0.1) || !(o->height > 0) ||
        !(o->shadow_ratio <= MAX_RATIO))
        return 0;
    double dx = (o->shadow_cx - o->cx) / (o->tbar * o->height);
    double dy = (o->shadow_cy - o->foot_y) / (o->tbar * o->height);
    if (!(hypot(dx, dy) >= MIN_LENGTH) || !isfinite(dx) || !isfinite(dy))
        return 0;
    sh->hard++;
    float rec[SHADOW_REC] = { (float)(o->foot_x / sg->width), (float)(o->foot_y / sg->height), (float)dx,
                              (float)dy };
    reservoir_add(&sh->obs, rec);
    add_ratios(sh, sg, o, rgb, plate);
    return 1;
}

/* Huber IRLS of column `col` on [1, u, v] (p = 3) or [1] (p = 1); scratch holds 2 n doubles. */
static int huber_fit(const float *rec, unsigned n, unsigned col, unsigned p, double *scratch, double beta[3])
{
    double *w = scratch, *r = scratch + n;
    for (unsigned i = 0; i < n; i++)
        w[i] = 1;
    for (int it = 0; it < 15; it++) {
        double A[9] = { 0 }, b[3] = { 0 };
        for (unsigned i = 0; i < n; i++) {
            const float *q = rec + (size_t)i * SHADOW_REC;
            double phi[3] = { 1, (double)q[0], (double)q[1] };
            for (unsigned a = 0; a < p; a++) {
                for (unsigned c = 0; c < p; c++)
                    A[a * p + c] += w[i] * phi[a] * phi[c];
                b[a] += w[i] * phi[a] * (double)q[col];
            }
        }
        if (p == 1) {
            if (!(A[0] > 0))
                return -1;
            beta[0] = b[0] / A[0];
        } else if (probe_solve3(A, b, beta)) {
            return -1;
        }
        for (unsigned i = 0; i < n; i++) {
            const float *q = rec + (size_t)i * SHADOW_REC;
            double pred = p == 1 ? beta[0] : beta[0] + beta[1] * (double)q[0] + beta[2] * (double)q[1];
            r[i] = fabs((double)q[col] - pred);
        }
        memcpy(w, r, n * sizeof(double));
        double s = 1.4826 * sp_median_inplace(w, n), k = 1.345 * (s > 0.01 ? s : 0.01);
        for (unsigned i = 0; i < n; i++)
            w[i] = r[i] <= k ? 1.0 : k / r[i];
    }
    return 0;
}

/* Median ratio of a ratio histogram (bins over [0, 2)); NaN when empty. */
static double hist_median(const uint64_t *hist)
{
    uint64_t total = 0, acc = 0;
    for (size_t i = 0; i < PROBE_RATIO_BINS; i++)
        total += hist[i];
    if (!total)
        return (double)NAN;
    for (size_t i = 0; i < PROBE_RATIO_BINS; i++) {
        acc += hist[i];
        if (2 * acc >= total)
            return ((double)i + 0.5) * 2.0 / PROBE_RATIO_BINS;
    }
    return (double)NAN;
}

/* Mean resultant length of the observed directions and the circular spread in degrees. */
static double direction_spread(const probe_reservoir *obs, double *spread_deg)
{
    double sx = 0, sy = 0;
    unsigned n = 0;
    for (unsigned i = 0; i < obs->n; i++) {
        const float *q = obs->v + (size_t)i * SHADOW_REC;
        double qx = q[2], qy = q[3], len = hypot(qx, qy);
        if (len > 0) {
            sx += qx / len, sy += qy / len;
            n++;
        }
    }
    double R = n ? hypot(sx, sy) / n : 0;
    *spread_deg = R > 0 ? sqrt(-2.0 * log(fmin(R, 1.0))) * 180.0 / M_PI : 180.0;
    return R;
}

/* Position spread of the observations: a plane through one line is not identifiable. */
static int positions_span_plane(const probe_reservoir *obs)
{
    double mu = 0, mv = 0, cuu = 0, cuv = 0, cvv = 0;
    for (unsigned i = 0; i < obs->n; i++)
        mu += (double)obs->v[(size_t)i * SHADOW_REC], mv += (double)obs->v[(size_t)i * SHADOW_REC + 1];
    mu /= obs->n, mv /= obs->n;
    for (unsigned i = 0; i < obs->n; i++) {
        double u = (double)obs->v[(size_t)i * SHADOW_REC] - mu, v = (double)obs->v[(size_t)i * SHADOW_REC + 1] - mv;
        cuu += u * u, cuv += u * v, cvv += v * v;
    }
    double tr = (cuu + cvv) / obs->n, det = (cuu * cvv - cuv * cuv) / ((double)obs->n * obs->n);
    double l2 = tr / 2 - sqrt(fmax(tr * tr / 4 - det, 0));
    return obs->n >= 6 && l2 > 0.01 * 0.01;
}

static int fit_offsets(const probe_shadows *sh, sp_probe_shadow *out)
{
    unsigned n = sh->obs.n, p = positions_span_plane(&sh->obs) ? 3 : 1;
    double *scratch = malloc(2 * (size_t)n * sizeof(double));
    if (!scratch)
        return -ENOMEM;
    double bx[3] = { 0 }, by[3] = { 0 };
    int ret = huber_fit(sh->obs.v, n, 2, p, scratch, bx);
    if (!ret)
        ret = huber_fit(sh->obs.v, n, 3, p, scratch, by);
    free(scratch);
    if (ret)
        return ret;
    memcpy(out->ox, bx, sizeof(bx));
    memcpy(out->oy, by, sizeof(by));
    return p;
}

#define CONTACT_MIN_OBS 10      /* person observations */
#define CONTACT_MEASURABLE 0.97 /* the darker of the two inner rings against the reference: less is no darkening */

/* The contact profile from the rings (sp_probe_shadow.contact), or the reason there is none. */
static void contact_fit(const probe_shadows *sh, sp_probe_shadow *out)
{
    out->n_contact = (unsigned)(sh->contact_obs < UINT32_MAX ? sh->contact_obs : UINT32_MAX);
    if (out->n_contact < CONTACT_MIN_OBS) {
        snprintf(out->contact_note, sizeof(out->contact_note),
                 "left out: %u person observations with ground beside the feet, need %d", out->n_contact,
                 CONTACT_MIN_OBS);
        return;
    }
    uint64_t ref[PROBE_RATIO_BINS];
    for (size_t i = 0; i < PROBE_RATIO_BINS; i++)
        ref[i] = sh->contact_hist[PROBE_CONTACT_RINGS - 2][i] + sh->contact_hist[PROBE_CONTACT_RINGS - 1][i];
    double r0 = hist_median(ref);
    if (!(r0 > 0)) {
        snprintf(out->contact_note, sizeof(out->contact_note), "left out: no ground seen beyond the feet");
        return;
    }
    for (int k = 0; k < SP_PROBE_CONTACT_BINS; k++) {
        double r = hist_median(sh->contact_hist[k]) / r0;
        out->contact[k] = isfinite(r) ? r : 1.0;
        if (!isfinite(r)) {
            snprintf(out->contact_note, sizeof(out->contact_note),
                     "left out: no ground seen at ring %d beside the feet (always covered)", k);
            return;
        }
    }
    double inner = fmin(out->contact[0], out->contact[1]);
    if (!(inner <= CONTACT_MEASURABLE)) {
        snprintf(out->contact_note, sizeof(out->contact_note),
                 "left out: people do not darken the ground at their feet (%.3f of the ground around)", inner);
        return;
    }
    out->contact_present = 1;
    snprintf(out->contact_note, sizeof(out->contact_note),
             "learned from %u person observations: %.3f of the ground around at the feet", out->n_contact, inner);
}

int shadows_absent(const probe_shadows *sh)
{
    return sh->candidates >= ABSENT_CANDIDATES && (double)sh->hard < MIN_HARD_FRACTION * (double)sh->candidates;
}

void shadows_fit(const probe_shadows *sh, uint32_t width, uint32_t height, sp_probe_shadow *out)
{
    memset(out, 0, sizeof(*out));
    contact_fit(sh, out);
    out->n_shadows = (unsigned)(sh->hard < UINT32_MAX ? sh->hard : UINT32_MAX);
    out->n_candidates = (unsigned)(sh->candidates < UINT32_MAX ? sh->candidates : UINT32_MAX);
    double R = direction_spread(&sh->obs, &out->direction_spread_deg);
    if (sh->candidates < 10) {
        snprintf(out->note, sizeof(out->note), "left out: only %u person observations, too few to judge shadows",
                 out->n_candidates);
        return;
    }
    if (sh->hard < MIN_HARD || (double)sh->hard < MIN_HARD_FRACTION * (double)sh->candidates) {
        snprintf(out->note, sizeof(out->note),
                 "left out: overcast or no hard shadows (%u of %u person observations cast one; need %.0f%%)",
                 out->n_shadows, out->n_candidates, 100.0 * MIN_HARD_FRACTION);
        return;
    }
    if (R < MIN_RESULTANT) {
        snprintf(out->note, sizeof(out->note),
                 "left out: shadow directions disagree (circular spread %.0f degrees): no single sun",
                 out->direction_spread_deg);
        return;
    }
    int p = fit_offsets(sh, out);
    for (int c = 0; c < 3; c++)
        out->ratio[c] = hist_median(sh->ratio_hist[c]);
    if (p < 0 || !isfinite(out->ratio[0]) || !isfinite(out->ratio[1]) || !isfinite(out->ratio[2])) {
        snprintf(out->note, sizeof(out->note), "left out: the shadow fit failed");
        return;
    }
    out->present = 1;
    snprintf(out->note, sizeof(out->note), "learned from %u hard shadows of %u person observations (%s)",
             out->n_shadows, out->n_candidates,
             p == 3 ? "direction varies over the image" : "one direction: positions too close to fit its change");
    (void)width, (void)height;
}
