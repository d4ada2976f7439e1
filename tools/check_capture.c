/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe check`: what a capture offers a SunStage fit, measured before any fitting. One pass over
 * the file: frame times, each frame's grey image (clipping, sharpness, the centre's brightness) and
 * the IMU (rate, coverage, the turn about gravity). Thresholds and their reasons: README "check".
 */
#include "check_capture.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/pixconv.h"
#include "pipeline/sunstage/landmarks.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_meta.h"

#define CLIP_LEVEL 250
#define RAD2DEG (180.0 / M_PI)

typedef struct frame_rec {
    double t, centre, clipped, sharp, expo;
    double face;      /* mean grey level inside the landmarks' box, NaN when no face was found */
    double shutter_s; /* NaN unknown */
    uint32_t width;
} frame_rec;

struct sp_check_scan {
    frame_rec *f;
    size_t nf, capf;
    double *gt, *gv; /* gyro times (s) and 3-vectors */
    size_t ng, capg;
    double acc[3];
    size_t nacc;
    uint8_t *gray, *rgb;
    size_t gray_size;
    size_t undecodable;
    double fx; /* META camera.fx, NaN unknown */
    /* the last frame waits for its side data (landmarks) before its face is looked for */
    int pending;
    uint64_t pending_seq;
    uint32_t pw, ph;
    int have_side;
    double side_lm[136];
    ss_lm_tracker *tracker; /* NULL: landmarks from side data only */
    size_t faces, face_looked;
    double face_interval_s, last_face_t; /* the tracker runs on frames at least this far apart */
    int faces_paused;
    size_t face_skipped;
};
typedef struct sp_check_scan scan;

static int grow(void **p, size_t *cap, size_t n, size_t elem)
{
    if (n < *cap)
        return 0;
    size_t c = *cap ? *cap * 2 : 1024;
    void *q = realloc(*p, c * elem);
    if (!q)
        return -ENOMEM;
    *p = q;
    *cap = c;
    return 0;
}

/* Share of clipped pixels and Laplacian energy over the whole frame; mean of the central 40 % box. */
static void measure(const uint8_t *g, uint32_t w, uint32_t h, frame_rec *r)
{
    double clip = 0, lap = 0, sum = 0, centre = 0;
    size_t nc = 0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            const uint8_t *p = g + (size_t)y * w + x;
            sum += *p;
            clip += *p >= CLIP_LEVEL;
            if (x >= w * 3 / 10 && x < w * 7 / 10 && y >= h * 3 / 10 && y < h * 7 / 10) {
                centre += *p;
                nc++;
            }
            if (x > 0 && y > 0 && x + 1 < w && y + 1 < h) {
                double l = 4.0 * p[0] - p[-1] - p[1] - p[-(long)w] - p[w];
                lap += l * l;
            }
        }
    double n = (double)w * h, mean = sum / n;
    r->clipped = clip / n;
    r->centre = nc ? centre / (double)nc : mean;
    r->sharp = lap / fmax((double)(w - 2) * (h - 2), 1) / fmax(mean * mean, 1.0);
}

/* The grey mean inside the landmarks' box, shrunk to its middle 60 % (skin, not background). */
static double face_level(const scan *s, const double *lm)
{
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (int k = 0; k < 68; k++) {
        x0 = fmin(x0, lm[2 * k]), x1 = fmax(x1, lm[2 * k]);
        y0 = fmin(y0, lm[2 * k + 1]), y1 = fmax(y1, lm[2 * k + 1]);
    }
    double mx = 0.2 * (x1 - x0), my = 0.2 * (y1 - y0), sum = 0;
    long xa = lround(fmax(x0 + mx, 0)), xb = lround(fmin(x1 - mx, s->pw - 1.0));
    long ya = lround(fmax(y0 + my, 0)), yb = lround(fmin(y1 - my, s->ph - 1.0));
    size_t n = 0;
    for (long y = ya; y <= yb; y++)
        for (long x = xa; x <= xb; x++, n++)
            sum += s->gray[(size_t)y * s->pw + (size_t)x];
    return n ? sum / (double)n : (double)NAN;
}

/* Landmarks for the pending frame: its side data, else the fit's tracker (dlib) when built. */
static int finish_face(scan *s)
{
    if (!s->pending)
        return 0;
    s->pending = 0;
    ss_lm_result res = { .source = SS_LM_NONE };
    const double *lm = NULL;
    if (s->have_side) {
        lm = s->side_lm;
    } else if (s->tracker) {
        double t = s->f[s->nf - 1].t;
        if ((s->face_looked || s->face_skipped) && t - s->last_face_t < s->face_interval_s)
            return 0; /* live: not every frame, so the check keeps up with the camera */
        s->last_face_t = t;
        if (s->faces_paused) {
            s->face_skipped++;
            return 0;
        }
        int rc = ss_lm_tracker_frame(s->tracker, s->rgb, (int)s->pw, (int)s->ph, &res);
        if (rc)
            return rc;
        lm = res.source != SS_LM_NONE ? res.lm : NULL;
    } else {
        return 0;
    }
    s->face_looked++;
    if (lm) {
        s->faces++;
        s->f[s->nf - 1].face = face_level(s, lm);
    }
    return 0;
}

static void take_side(scan *s, const sp_chunk *ch)
{
    sp_side_chunk sc;
    if (!s->pending || sp_chunk_parse_side(ch, &sc) != 0 || sc.kind != SP_SIDE_LANDMARKS_2D || sc.count != 136 ||
        sc.frame_sequence != s->pending_seq)
        return;
    for (uint32_t i = 0; i < 136; i++)
        s->side_lm[i] = (double)sp_side_value(&sc, i);
    s->have_side = 1;
}

static int take_frame(scan *s, const sp_chunk *ch)
{
    sp_frame_chunk fc;
    if (sp_chunk_parse_frame(ch, &fc) != 0 || fc.stream_id != 0)
        return 0;
    int rc = finish_face(s);
    if (rc)
        return rc;
    size_t need = (size_t)fc.width * fc.height;
    if (need > s->gray_size) {
        uint8_t *g = realloc(s->gray, need), *c = g ? realloc(s->rgb, need * 3) : NULL;
        s->gray = g ? g : s->gray;
        s->rgb = c ? c : s->rgb;
        if (!g || !c)
            return -ENOMEM;
        s->gray_size = need;
    }
    sp_pixconv_src src = { fc.format, fc.width, fc.height, fc.stride, fc.data, fc.data_size };
    rc = sp_pixconv_to_rgb24(&src, s->rgb, need * 3, fc.width * 3);
    if (rc == SP_EDISABLED)
        return rc;
    if (rc || fc.width < 3 || fc.height < 3) {
        s->undecodable++;
        return 0;
    }
    for (size_t i = 0; i < need; i++) {
        const uint8_t *p = s->rgb + i * 3;
        s->gray[i] = (uint8_t)((77 * p[0] + 150 * p[1] + 29 * p[2] + 128) >> 8);
    }
    if ((rc = grow((void **)&s->f, &s->capf, s->nf, sizeof(*s->f))) != 0)
        return rc;
    frame_rec *r = &s->f[s->nf++];
    measure(s->gray, fc.width, fc.height, r);
    r->t = (double)ch->timestamp_ns * 1e-9;
    double e = (double)fc.exposure_us * (double)fc.gain;
    double us = (double)fc.exposure_us;
    r->shutter_s = us > 0 && isfinite(us) ? us * 1e-6 : (double)NAN;
    r->width = fc.width;
    r->expo = e > 0 && isfinite(e) ? e : (us > 0 && isfinite(us) ? us : (double)NAN);
    r->face = NAN;
    s->pending = 1;
    s->pending_seq = fc.sequence;
    s->pw = fc.width;
    s->ph = fc.height;
    s->have_side = 0;
    return 0;
}

static int take_imu(scan *s, const sp_chunk *ch)
{
    int64_t n = sp_chunk_imu_count(ch);
    for (int64_t i = 0; i < n; i++) {
        sp_imu_sample smp;
        if (sp_chunk_imu_get(ch, (size_t)i, &smp) != 0)
            continue;
        if (smp.sensor == SP_IMU_ACCEL) {
            for (int a = 0; a < 3; a++)
                s->acc[a] += (double)smp.v[a];
            s->nacc++;
        } else if (smp.sensor == SP_IMU_GYRO) {
            int rc = grow((void **)&s->gt, &s->capg, s->ng, sizeof(double));
            if (rc)
                return rc;
            double *v = realloc(s->gv, s->capg * 3 * sizeof(double)); /* three per sample, same capacity */
            if (!v)
                return -ENOMEM;
            s->gv = v;
            s->gt[s->ng] = (double)smp.timestamp_ns * 1e-9;
            for (int a = 0; a < 3; a++)
                s->gv[s->ng * 3 + a] = (double)smp.v[a];
            s->ng++;
        }
    }
    return 0;
}

static int by_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, size_t n)
{
    if (!n)
        return NAN;
    qsort(v, n, sizeof(*v), by_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* The turn about gravity (IMU axes; gravity from the mean accelerometer) integrated to each frame's time. */
static void turn(const scan *s, sp_check_report *r, double *yaw_at_frame)
{
    double gn = sqrt(s->acc[0] * s->acc[0] + s->acc[1] * s->acc[1] + s->acc[2] * s->acc[2]);
    double g[3] = { 0, 0, 1 };
    if (s->nacc && gn > 0)
        for (int a = 0; a < 3; a++)
            g[a] = s->acc[a] / gn;
    double yaw = 0, lo = 0, hi = 0;
    size_t j = 0;
    for (size_t i = 0; i < s->nf; i++) {
        double t = s->f[i].t;
        for (; j + 1 < s->ng && s->gt[j + 1] <= t; j++) {
            if (s->gt[j] < s->f[0].t)
                continue; /* from the first frame on */
            const double *w = &s->gv[j * 3];
            yaw += (w[0] * g[0] + w[1] * g[1] + w[2] * g[2]) * (s->gt[j + 1] - s->gt[j]);
        }
        yaw_at_frame[i] = yaw;
        lo = fmin(lo, yaw);
        hi = fmax(hi, yaw);
    }
    r->turn_deg = fabs(yaw) * RAD2DEG;
    r->turn_range_deg = (hi - lo) * RAD2DEG;
}

/*
 * Motion blur from the gyro: rate x shutter time x focal length, in pixels of the fit's 128-px frame
 * (so a 4K frame is judged like a VGA one); the focal length is camera.fx, else 0.8 x width.
 */
static void motion_blur(const scan *s, sp_check_report *r)
{
    size_t known = 0, blurred = 0, j = 0;
    for (size_t i = 0; i < s->nf; i++) {
        const frame_rec *f = &s->f[i];
        while (j + 1 < s->ng && fabs(s->gt[j + 1] - f->t) <= fabs(s->gt[j] - f->t))
            j++;
        if (!isfinite(f->shutter_s) || !f->width)
            continue;
        const double *w = &s->gv[j * 3];
        double fx = isfinite(s->fx) && s->fx > 0 ? s->fx : 0.8 * f->width;
        double px = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) * f->shutter_s * fx * 128.0 / f->width;
        r->blur_max_px = fmax(r->blur_max_px, px);
        known++;
        blurred += px > 1.0;
    }
    r->blurred_share = known ? (double)blurred / (double)known : (double)NAN;
}

/* How much the centre's linear brightness follows the turn: first harmonic over the mean. */
static void lighting(const scan *s, const double *yaw, sp_check_report *r)
{
    double ata[3][3] = { { 0 } }, atb[3] = { 0 };
    double e0 = NAN;
    for (size_t i = 0; i < s->nf; i++)
        if (isfinite(s->f[i].expo)) {
            e0 = s->f[i].expo;
            break;
        }
    int by_face = s->faces * 2 > s->nf;
    r->light_from_face = by_face;
    for (size_t i = 0; i < s->nf; i++) {
        double level = by_face ? s->f[i].face : s->f[i].centre;
        if (!isfinite(level))
            continue;
        double lin = pow(level / 255.0, 2.2);
        if (isfinite(e0) && isfinite(s->f[i].expo))
            lin *= e0 / s->f[i].expo; /* auto-exposure undone where the frames say it */
        double x[3] = { 1, cos(yaw[i]), sin(yaw[i]) };
        for (int a = 0; a < 3; a++) {
            atb[a] += x[a] * lin;
            for (int b = 0; b < 3; b++)
                ata[a][b] += x[a] * x[b];
        }
    }
    /* 3x3 normal equations by Cramer's rule; singular when the turn covers too little */
    double det = ata[0][0] * (ata[1][1] * ata[2][2] - ata[1][2] * ata[2][1]) -
                 ata[0][1] * (ata[1][0] * ata[2][2] - ata[1][2] * ata[2][0]) +
                 ata[0][2] * (ata[1][0] * ata[2][1] - ata[1][1] * ata[2][0]);
    r->light_modulation = NAN;
    if (!(fabs(det) > 1e-9 * pow((double)s->nf, 3)))
        return;
    double sol[3];
    for (int k = 0; k < 3; k++) {
        double m[3][3];
        memcpy(m, ata, sizeof(m));
        for (int a = 0; a < 3; a++)
            m[a][k] = atb[a];
        sol[k] = (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                  m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])) / det;
    }
    r->light_modulation = sol[0] > 0 ? hypot(sol[1], sol[2]) / sol[0] : (double)NAN;
}

static void summarise(scan *s, sp_check_report *r)
{
    r->frames = s->nf;
    r->face_share = s->face_looked ? (double)s->faces / (double)s->face_looked : (double)NAN;
    r->face_skipped = s->face_skipped;
    r->undecodable = s->undecodable;
    r->gyro_samples = s->ng;
    if (s->nf < 2)
        return;
    r->duration_s = s->f[s->nf - 1].t - s->f[0].t;
    double *tmp = malloc(s->nf * sizeof(*tmp));
    double *yaw = malloc(s->nf * sizeof(*yaw));
    if (!tmp || !yaw) {
        free(tmp);
        free(yaw);
        return;
    }
    for (size_t i = 1; i < s->nf; i++) {
        tmp[i - 1] = s->f[i].t - s->f[i - 1].t;
        r->max_gap_s = fmax(r->max_gap_s, tmp[i - 1]);
    }
    double dt = median(tmp, s->nf - 1);
    r->fps = dt > 0 ? 1.0 / dt : 0;
    size_t clipped = 0;
    for (size_t i = 0; i < s->nf; i++) {
        tmp[i] = s->f[i].sharp;
        clipped += s->f[i].clipped > 0.05;
    }
    r->sharpness = median(tmp, s->nf);
    r->clipped_share = (double)clipped / (double)s->nf;
    if (s->ng >= 2) {
        r->gyro_hz = (double)(s->ng - 1) / fmax(s->gt[s->ng - 1] - s->gt[0], 1e-9);
        size_t in = 0;
        for (size_t i = 0; i < s->nf; i++)
            in += s->f[i].t >= s->gt[0] && s->f[i].t <= s->gt[s->ng - 1];
        r->imu_coverage = (double)in / (double)s->nf;
        turn(s, r, yaw);
        motion_blur(s, r);
        if (r->turn_range_deg >= 180) /* fewer degrees cannot tell the lit side from the shaded one */
            lighting(s, yaw, r);
    }
    free(tmp);
    free(yaw);
}

int sp_check_scan_open(sp_check_scan **out, int find_faces, double face_interval_s)
{
    scan *s = calloc(1, sizeof(*s));
    if (!s)
        return -ENOMEM;
    s->fx = NAN;
    s->face_interval_s = face_interval_s;
    if (find_faces) { /* without dlib (or its model) faces come from side data only */
        ss_lm_settings ls;
        ss_lm_default_settings(&ls);
        if (ss_lm_tracker_open(&s->tracker, &ls) != 0)
            s->tracker = NULL;
    }
    *out = s;
    return 0;
}

int sp_check_scan_chunk(sp_check_scan *s, const sp_chunk *ch)
{
    if (ch->type == SP_CHUNK_META) {
        sp_capture_meta m;
        sp_capture_meta_init(&m);
        if (sp_capture_meta_merge(&m, (const char *)ch->payload, ch->payload_size) == 0 && isfinite(m.fx))
            s->fx = m.fx;
    } else if (ch->type == SP_CHUNK_FRAME) {
        return take_frame(s, ch);
    } else if (ch->type == SP_CHUNK_IMU) {
        return take_imu(s, ch);
    } else if (ch->type == SP_CHUNK_SIDE) {
        take_side(s, ch);
    }
    return 0;
}

int sp_check_scan_report(sp_check_scan *s, sp_check_report *r)
{
    memset(r, 0, sizeof(*r));
    r->light_modulation = NAN;
    r->blurred_share = NAN;
    int rc = finish_face(s);
    if (!rc)
        summarise(s, r);
    return rc;
}

void sp_check_scan_pause_faces(sp_check_scan *s, int paused)
{
    s->faces_paused = paused;
}

void sp_check_scan_close(sp_check_scan **sp)
{
    scan *s = sp ? *sp : NULL;
    if (!s)
        return;
    ss_lm_tracker_close(&s->tracker);
    free(s->f);
    free(s->gt);
    free(s->gv);
    free(s->gray);
    free(s->rgb);
    free(s);
    *sp = NULL;
}

int sp_check_capture(const char *path, int find_faces, sp_check_report *r)
{
    memset(r, 0, sizeof(*r));
    r->light_modulation = NAN;
    r->blurred_share = NAN;
    sp_capture_reader *rd = NULL;
    int rc = sp_capture_reader_open(&rd, path, NULL);
    if (rc)
        return rc;
    scan *s = NULL;
    if ((rc = sp_check_scan_open(&s, find_faces, 0)) != 0) {
        sp_capture_reader_close(&rd);
        return rc;
    }
    sp_chunk ch;
    while (!rc && (rc = sp_capture_reader_next(rd, &ch)) == 0)
        rc = sp_check_scan_chunk(s, &ch);
    sp_capture_reader_close(&rd);
    if (rc == SP_EOS)
        rc = sp_check_scan_report(s, r);
    sp_check_scan_close(&s);
    return rc;
}
