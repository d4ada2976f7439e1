/* SPDX-License-Identifier: MIT */
/* Camera orientation from the video alone (visual_orientation.h). */
#include "capture/visual_orientation.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "capture/opencv_shim.h"
#include "common/pixconv.h"
#include "common/module.h"
#include "common/stats.h"
#include "sp_config.h"
#include "sunprobe/sp_common.h"

#define MOD "orientation"
#define WORK_WIDTH 480 /* frames wider than this are tracked at about this width */
#define MAX_CORNERS 400
#define MIN_DISTANCE 8.0 /* px at the working size: corners spread over the background */
/* a corner needs about 8 grey levels per px both ways: render grain and sensor noise on a plain wall or
   sky stay under it (cv::cornerMinEigenVal's scale) */
#define MIN_EIGEN 0.001
#define MAX_FB_PX 0.7 /* forward-backward tracking disagreement allowed, working px */
#define INLIER_PX 1.2 /* a track agrees with a rotation within this many working px */
#define RANSAC_ROUNDS 200
#define MIN_INLIERS 12      /* fewer agreeing tracks: the step is not trusted */
#define STILL_DEG 0.08      /* a motion this small is "stuck to the camera" when another motion is found */
#define MAX_COASTED 0.2     /* more coasted steps than this share: the background is not trackable */
#define LOOP_MIN_TURN 270.0 /* degrees of turn before the first frame is looked for again */
#define LOOP_MAX_DEG 40.0   /* ... within this angle of the first frame, as the chain says and as matched */
#define LOOP_MIN_INLIERS 20
#define AXIS_MIN_TURN 60.0 /* a shorter turn does not say where its axis is */
#define AXIS_MIN_SHARE 0.8

typedef struct vo_frame {
    sp_quat c;       /* camera to world (world = the first camera until finish) */
    double path_deg; /* turn so far */
    int tracked;
    int has_up;  /* the accelerometer's up at this frame is known */
    float up[3]; /* ... in camera axes, unit */
} vo_frame;

struct sp_vo {
    sp_vo_settings s;
    int scale;             /* working pixel = scale x scale capture pixels */
    uint32_t ww, wh;       /* working size */
    double fx, fy, cx, cy; /* intrinsics at the working size */
    uint8_t *gray_full, *first, *prev, *cur;
    uint8_t *mask; /* where corners may be taken: off the person (working size) */
    float *pairs;
    double *b0, *b1;
    uint8_t *in, *in_best, *rest;
    vo_frame *f;
    size_t n, cap;
    sp_quat step; /* the last step's rotation (bearing in the previous frame -> in this one) */
    double *inlier_counts;
    uint64_t coasted;
    int loop_closed;
    size_t loop_frame;
    unsigned loop_inliers;
    sp_quat loop_c;    /* camera to world of loop_frame as the first frame sees it */
    double loop_angle; /* its measured angle from the first camera (smaller: more overlap) */
    uint64_t rng;
};

static uint32_t rnd(sp_vo *v)
{
    v->rng ^= v->rng << 13, v->rng ^= v->rng >> 7, v->rng ^= v->rng << 17;
    return (uint32_t)(v->rng >> 16);
}

int sp_vo_open(sp_vo **out, const sp_vo_settings *s)
{
    if (!out || !s || s->width < 32 || s->height < 32 || s->width > 16384 || s->height > 16384 || !(s->fx > 0) ||
        !(s->fy > 0) || !isfinite(s->cx) || !isfinite(s->cy))
        return -EINVAL;
    sp_vo *v = calloc(1, sizeof(*v));
    if (!v)
        return -ENOMEM;
    v->s = *s;
    v->scale = s->width > WORK_WIDTH * 3 / 2 ? (int)((s->width + WORK_WIDTH - 1) / WORK_WIDTH) : 1;
    v->ww = s->width / (uint32_t)v->scale, v->wh = s->height / (uint32_t)v->scale;
    v->fx = s->fx / v->scale, v->fy = s->fy / v->scale;
    v->cx = (s->cx + 0.5) / v->scale - 0.5, v->cy = (s->cy + 0.5) / v->scale - 0.5;
    size_t full = (size_t)s->width * s->height, work = (size_t)v->ww * v->wh;
    v->gray_full = malloc(full);
    v->first = malloc(work), v->prev = malloc(work), v->cur = malloc(work), v->mask = malloc(work);
    v->pairs = malloc(sizeof(float) * 4 * MAX_CORNERS);
    v->b0 = malloc(sizeof(double) * 3 * MAX_CORNERS), v->b1 = malloc(sizeof(double) * 3 * MAX_CORNERS);
    v->in = malloc(MAX_CORNERS), v->in_best = malloc(MAX_CORNERS), v->rest = malloc(MAX_CORNERS);
    if (!v->gray_full || !v->first || !v->prev || !v->cur || !v->mask || !v->pairs || !v->b0 || !v->b1 || !v->in ||
        !v->in_best || !v->rest) {
        sp_vo_close(&v);
        return -ENOMEM;
    }
    memset(v->mask, 255, work);
    v->step = sp_quat_identity();
    v->rng = 0x9e3779b97f4a7c15ULL;
    *out = v;
    return 0;
}

void sp_vo_close(sp_vo **pv)
{
    if (!pv || !*pv)
        return;
    sp_vo *v = *pv;
    free(v->gray_full), free(v->mask), free(v->first), free(v->prev), free(v->cur), free(v->pairs);
    free(v->b0), free(v->b1), free(v->in), free(v->in_best), free(v->rest);
    free(v->f), free(v->inlier_counts);
    free(v);
    *pv = NULL;
}

/* The frame in grey at the working size (box average of scale x scale pixels). */
static int to_work(sp_vo *v, const sp_frame *frame, uint8_t *dst)
{
    int ret = sp_pixconv_frame_to_gray8(frame, v->gray_full, (size_t)v->s.width * v->s.height, v->s.width);
    if (ret)
        return ret;
    int k = v->scale;
    for (uint32_t y = 0; y < v->wh; y++)
        for (uint32_t x = 0; x < v->ww; x++) {
            unsigned sum = 0;
            for (int dy = 0; dy < k; dy++)
                for (int dx = 0; dx < k; dx++)
                    sum += v->gray_full[((size_t)y * k + dy) * v->s.width + (size_t)x * k + dx];
            dst[(size_t)y * v->ww + x] = (uint8_t)((sum + (unsigned)(k * k) / 2) / (unsigned)(k * k));
        }
    return 0;
}

#if HAVE_OPENCV /* the corner tracker needs OpenCV; without it nothing calls these */
static void bearing(const sp_vo *v, double x, double y, double b[3])
{
    double u = (x - v->cx) / v->fx, w = (y - v->cy) / v->fy, n = sqrt(u * u + w * w + 1.0);
    b[0] = u / n, b[1] = w / n, b[2] = 1.0 / n;
}

/* The homography K R K^-1 that moves pixels of one frame to the next under the rotation q. */
static void rotation_homography(const sp_vo *v, sp_quat q, double H[9])
{
    double R[9], K[9] = { v->fx, 0, v->cx, 0, v->fy, v->cy, 0, 0, 1 };
    double Ki[9] = { 1 / v->fx, 0, -v->cx / v->fx, 0, 1 / v->fy, -v->cy / v->fy, 0, 0, 1 }, T[9];
    sp_quat_to_matrix(q, R);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            T[3 * i + j] = R[3 * i] * Ki[j] + R[3 * i + 1] * Ki[3 + j] + R[3 * i + 2] * Ki[6 + j];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            H[3 * i + j] = K[3 * i] * T[j] + K[3 * i + 1] * T[3 + j] + K[3 * i + 2] * T[6 + j];
}
#endif

static void cross(const double a[3], const double b[3], double c[3])
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

static int triad(const double a[3], const double b[3], double M[9])
{
    double t2[3], t3[3];
    cross(a, b, t2);
    double n = sqrt(t2[0] * t2[0] + t2[1] * t2[1] + t2[2] * t2[2]);
    if (n < 1e-3) /* the two bearings are too close to fix a rotation */
        return -1;
    for (int k = 0; k < 3; k++)
        t2[k] /= n;
    cross(a, t2, t3);
    for (int k = 0; k < 3; k++) /* columns a, t2, t3 */
        M[3 * k] = a[k], M[3 * k + 1] = t2[k], M[3 * k + 2] = t3[k];
    return 0;
}

/* The rotation taking bearings a0, c0 to a1, c1 exactly in a0's direction (the two-point sample). */
static int two_point(const double *a0, const double *c0, const double *a1, const double *c1, double R[9])
{
    double M0[9], M1[9];
    if (triad(a0, c0, M0) || triad(a1, c1, M1))
        return -1;
    for (int i = 0; i < 3; i++) /* R = M1 M0^T */
        for (int j = 0; j < 3; j++)
            R[3 * i + j] = M1[3 * i] * M0[3 * j] + M1[3 * i + 1] * M0[3 * j + 1] + M1[3 * i + 2] * M0[3 * j + 2];
    return 0;
}

/* Marks (in) the pairs among `use` that R maps within thr (radians) of their partner; returns how many. */
static unsigned count_inliers(const sp_vo *v, const double R[9], unsigned n, const uint8_t *use, double thr,
                              uint8_t *in)
{
    unsigned k = 0;
    double t2 = thr * thr;
    for (unsigned i = 0; i < n; i++) {
        in[i] = 0;
        if (use && !use[i])
            continue;
        const double *p = v->b0 + 3 * i, *q = v->b1 + 3 * i;
        double e = 0;
        for (int r = 0; r < 3; r++) {
            double d = q[r] - (R[3 * r] * p[0] + R[3 * r + 1] * p[1] + R[3 * r + 2] * p[2]);
            e += d * d;
        }
        if (e < t2)
            in[i] = 1, k++;
    }
    return k;
}

/* Least-squares rotation over the marked pairs, Gauss-Newton from q (small steps: q is already close). */
static sp_quat refine(const sp_vo *v, sp_quat q, unsigned n, const uint8_t *in)
{
    for (int it = 0; it < 6; it++) {
        double R[9], A[9] = { 0 }, g[3] = { 0 };
        sp_quat_to_matrix(q, R);
        for (unsigned i = 0; i < n; i++) {
            if (!in[i])
                continue;
            const double *b = v->b0 + 3 * i, *t = v->b1 + 3 * i;
            double p[3], r[3], pr[3];
            for (int k = 0; k < 3; k++)
                p[k] = R[3 * k] * b[0] + R[3 * k + 1] * b[1] + R[3 * k + 2] * b[2];
            for (int k = 0; k < 3; k++)
                r[k] = t[k] - p[k];
            cross(p, r, pr);
            for (int a = 0; a < 3; a++) {
                g[a] += pr[a];
                for (int c = 0; c < 3; c++) /* I - p p^T */
                    A[3 * a + c] += (a == c) - p[a] * p[c];
            }
        }
        /* solve A w = g (A symmetric positive definite when two bearings differ) */
        double c0 = A[4] * A[8] - A[5] * A[7], c1 = A[5] * A[6] - A[3] * A[8], c2 = A[3] * A[7] - A[4] * A[6];
        double det = A[0] * c0 + A[1] * c1 + A[2] * c2;
        if (!(fabs(det) > 1e-18))
            break;
        double inv[9] = { c0, A[2] * A[7] - A[1] * A[8], A[1] * A[5] - A[2] * A[4],
                          c1, A[0] * A[8] - A[2] * A[6], A[2] * A[3] - A[0] * A[5],
                          c2, A[1] * A[6] - A[0] * A[7], A[0] * A[4] - A[1] * A[3] };
        sp_vec3 w = { (inv[0] * g[0] + inv[1] * g[1] + inv[2] * g[2]) / det,
                      (inv[3] * g[0] + inv[4] * g[1] + inv[5] * g[2]) / det,
                      (inv[6] * g[0] + inv[7] * g[1] + inv[8] * g[2]) / det };
        q = sp_quat_normalize(sp_quat_mul(sp_quat_from_rotvec(w), q));
        if (sp_vec3_norm(w) < 1e-9)
            break;
    }
    return q;
}

/* Best-supported rotation among the pairs `use` marks (NULL: all): inliers into in_best, count returned. */
static unsigned ransac(sp_vo *v, unsigned n, const uint8_t *use, double thr, sp_quat *best)
{
    unsigned idx[MAX_CORNERS], m = 0, best_n = 0;
    for (unsigned i = 0; i < n; i++)
        if (!use || use[i])
            idx[m++] = i;
    if (m < 2)
        return 0;
    double R[9];
    for (int round = 0; round < RANSAC_ROUNDS; round++) {
        unsigned a = idx[rnd(v) % m], c = idx[rnd(v) % m];
        if (a == c || two_point(v->b0 + 3 * a, v->b0 + 3 * c, v->b1 + 3 * a, v->b1 + 3 * c, R))
            continue;
        unsigned k = count_inliers(v, R, n, use, thr, v->in);
        if (k > best_n) {
            best_n = k;
            *best = sp_quat_from_matrix(R);
            memcpy(v->in_best, v->in, n);
        }
    }
    if (best_n < 3)
        return best_n;
    *best = refine(v, *best, n, v->in_best);
    sp_quat_to_matrix(*best, R);
    return count_inliers(v, R, n, use, thr, v->in_best);
}

/* Corner pairs from `from` to `to` (working size) around where guess puts them, as bearings in b0, b1. */
static int track_pairs(sp_vo *v, const uint8_t *from, const uint8_t *to, sp_quat guess, unsigned *n)
{
    *n = 0;
#if HAVE_OPENCV
    double H[9];
    rotation_homography(v, guess, H);
    int ret = sp_cv_track_corners(from, to, v->ww, v->wh, v->mask, H, MAX_CORNERS, MIN_DISTANCE, MIN_EIGEN, MAX_FB_PX,
                                  v->pairs, n);
    if (ret)
        return ret;
    for (unsigned i = 0; i < *n; i++) {
        bearing(v, v->pairs[4 * i], v->pairs[4 * i + 1], v->b0 + 3 * i);
        bearing(v, v->pairs[4 * i + 2], v->pairs[4 * i + 3], v->b1 + 3 * i);
    }
    return 0;
#else
    (void)v, (void)from, (void)to, (void)guess;
    sp_log(SP_LOG_ERROR, MOD, "this build has no OpenCV to track the video's corners (build with -Dopencv=enabled)");
    return SP_EMODULE;
#endif
}

/*
 * The rotation from frame `from` to frame `to` (both at the working size), starting from guess, into
 * *out, and how many tracks agree with it into *agree. Of two well-supported motions, the still one is
 * the person's.
 */
static int step_rotation(sp_vo *v, const uint8_t *from, const uint8_t *to, sp_quat guess, sp_quat *out, unsigned *agree)
{
    unsigned n;
    int ret = track_pairs(v, from, to, guess, &n);
    if (ret)
        return ret;
    double thr = INLIER_PX / v->fx;
    sp_quat q1 = sp_quat_identity(), q2 = sp_quat_identity();
    unsigned k1 = ransac(v, n, NULL, thr, &q1);
    *out = q1, *agree = k1;
    sp_log(SP_LOG_DEBUG, MOD, "frame %zu: %u tracks, best motion %u (%.3f deg)", v->n, n, k1,
           sp_quat_angle_between(q1, sp_quat_identity()) * 180.0 / M_PI);
    if (k1 < MIN_INLIERS || sp_quat_angle_between(q1, sp_quat_identity()) * 180.0 / M_PI >= STILL_DEG)
        return 0;
    /* the largest motion is still: the person, or a camera at rest; look for another */
    for (unsigned i = 0; i < n; i++)
        v->rest[i] = !v->in_best[i];
    unsigned k2 = ransac(v, n, v->rest, thr, &q2);
    double a2 = sp_quat_angle_between(q2, sp_quat_identity()) * 180.0 / M_PI;
    if (k2 >= MIN_INLIERS && 4 * k2 >= k1 && a2 > 4 * STILL_DEG)
        *out = q2, *agree = k2;
    return 0;
}

static int grow(sp_vo *v)
{
    if (v->n < v->cap)
        return 0;
    size_t cap = v->cap ? 2 * v->cap : 256;
    vo_frame *f = realloc(v->f, sizeof(*f) * cap);
    if (!f)
        return -ENOMEM;
    v->f = f;
    double *c = realloc(v->inlier_counts, sizeof(double) * cap);
    if (!c)
        return -ENOMEM;
    v->inlier_counts = c;
    v->cap = cap;
    return 0;
}

/*
 * When the turn has come round, match the first frame again; keep the match closest to it. The chain
 * comes up short when the background is near (the camera's own motion along its circle slows the
 * background's: about 360 deg x arm / distance, 16 deg at 10 m), so the match is also tried from
 * guesses turned further and less far about the camera's vertical.
 */
static int try_loop(sp_vo *v, const vo_frame *fr)
{
    static const double offsets_deg[] = { 0, 15, -15, 30, -30 };
    double ang = sp_quat_angle_between(fr->c, v->f[0].c) * 180.0 / M_PI;
    if (fr->path_deg < LOOP_MIN_TURN || ang > LOOP_MAX_DEG)
        return 0;
    sp_quat chain = sp_quat_mul(sp_quat_conj(fr->c), v->f[0].c); /* bearing in the first camera -> this one */
    sp_quat best = chain;
    unsigned best_k = 0;
    for (size_t i = 0; i < sizeof(offsets_deg) / sizeof(offsets_deg[0]); i++) {
        sp_quat turn = sp_quat_from_axis_angle((sp_vec3){ 0, 1, 0 }, offsets_deg[i] * M_PI / 180.0), q;
        unsigned k;
        int ret = step_rotation(v, v->first, v->cur, sp_quat_mul(turn, chain), &q, &k);
        if (ret)
            return ret;
        /* a still match is the person, who is in both frames where the background was not found */
        double seen = sp_quat_angle_between(q, sp_quat_identity()) * 180.0 / M_PI;
        if (k > best_k && seen > 4 * STILL_DEG && sp_quat_angle_between(q, chain) * 180.0 / M_PI <= LOOP_MAX_DEG)
            best = q, best_k = k;
        if (best_k >= LOOP_MIN_INLIERS && i == 0)
            break; /* found from the chain's own guess */
    }
    double seen = sp_quat_angle_between(best, sp_quat_identity()) * 180.0 / M_PI;
    if (best_k < LOOP_MIN_INLIERS || (v->loop_closed && seen >= v->loop_angle))
        return 0;
    v->loop_closed = 1;
    v->loop_frame = v->n;
    v->loop_inliers = best_k;
    v->loop_c = sp_quat_mul(v->f[0].c, sp_quat_conj(best));
    v->loop_angle = seen;
    return 0;
}

/*
 * The person off limits, from the face's 68 points (capture pixels): the face box widened for the ears
 * and raised for the top of the head, and below the chin the shoulders and body to the frame's bottom,
 * three faces wide. A frame without points keeps the last outline (the face moves little in a selfie).
 */
static void person_mask(sp_vo *v, const float *lm)
{
    double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
    for (int k = 0; k < 68; k++) {
        double x = lm[2 * k] / v->scale, y = lm[2 * k + 1] / v->scale;
        if (!isfinite(x) || !isfinite(y))
            return;
        x0 = fmin(x0, x), x1 = fmax(x1, x), y0 = fmin(y0, y), y1 = fmax(y1, y);
    }
    double fw = x1 - x0, fh = y1 - y0, mid = 0.5 * (x0 + x1);
    if (!(fw > 2) || !(fh > 2))
        return;
    double hx0 = x0 - 0.3 * fw, hx1 = x1 + 0.3 * fw, hy0 = y0 - 0.9 * fh; /* head and hair */
    double neck = y1 + 0.25 * fh;                                         /* then the body widens */
    for (uint32_t y = 0; y < v->wh; y++)
        for (uint32_t x = 0; x < v->ww; x++) {
            int off = 1;
            if (y >= hy0 && y <= neck && x >= hx0 && x <= hx1)
                off = 0;
            else if (y > neck) {
                double half = 0.8 * fw + 2.0 * (y - neck); /* shoulders spread fast below the neck */
                half = fmin(half, 1.6 * fw);
                if (fabs(x - mid) <= half)
                    off = 0;
            }
            v->mask[(size_t)y * v->ww + x] = off ? 255 : 0;
        }
}

int sp_vo_push(sp_vo *v, const sp_frame *frame, const float *landmarks)
{
    if (!v || !frame)
        return -EINVAL;
    if (frame->width != v->s.width || frame->height != v->s.height)
        return -EINVAL;
    int ret = grow(v);
    if (ret || (ret = to_work(v, frame, v->cur)))
        return ret;
    if (landmarks)
        person_mask(v, landmarks);
    vo_frame fr = { sp_quat_identity(), 0.0, 1, 0, { 0, 0, 0 } };
    if (v->n == 0) {
        memcpy(v->first, v->cur, (size_t)v->ww * v->wh);
    } else {
        sp_quat q;
        unsigned k;
        if ((ret = step_rotation(v, v->prev, v->cur, v->step, &q, &k)))
            return ret;
        v->inlier_counts[v->n - 1] = k;
        if (k >= MIN_INLIERS)
            v->step = q;
        else
            fr.tracked = 0, v->coasted++; /* keep turning as the last step did */
        const vo_frame *p = &v->f[v->n - 1];
        fr.c = sp_quat_normalize(sp_quat_mul(p->c, sp_quat_conj(v->step)));
        fr.path_deg = p->path_deg + sp_quat_angle_between(v->step, sp_quat_identity()) * 180.0 / M_PI;
        if ((ret = try_loop(v, &fr)))
            return ret;
    }
    v->f[v->n++] = fr;
    uint8_t *t = v->prev;
    v->prev = v->cur, v->cur = t;
    return 0;
}

int sp_vo_gravity(sp_vo *v, sp_vec3 up_in_camera)
{
    double n = sp_vec3_norm(up_in_camera);
    if (!v || v->n == 0 || !isfinite(n) || n < 1.0)
        return -EINVAL;
    vo_frame *f = &v->f[v->n - 1];
    f->has_up = 1;
    f->up[0] = (float)(up_in_camera.x / n), f->up[1] = (float)(up_in_camera.y / n),
    f->up[2] = (float)(up_in_camera.z / n);
    return 0;
}

/* The loop's drift spread over the turn by each frame's share of the turn up to the closing frame. */
static void close_loop(sp_vo *v, double *correction_deg)
{
    const vo_frame *end = &v->f[v->loop_frame];
    sp_quat delta = sp_quat_mul(v->loop_c, sp_quat_conj(end->c)); /* world-side correction at the closure */
    sp_vec3 w = sp_quat_to_rotvec(delta);
    *correction_deg = sp_vec3_norm(w) * 180.0 / M_PI;
    double total = end->path_deg > 0 ? end->path_deg : 1.0;
    for (size_t i = 0; i < v->n; i++) {
        double share = i >= v->loop_frame ? 1.0 : v->f[i].path_deg / total;
        v->f[i].c = sp_quat_normalize(sp_quat_mul(sp_quat_from_rotvec(sp_vec3_scale(w, share)), v->f[i].c));
    }
}

/* The accelerometer's up in the world: the frames' measured up turned by their cameras, averaged (the arm's
   centripetal and the turn's own accelerations average out over a turn). Zero vector when under half the
   frames have one. */
static sp_vec3 gravity_up(const sp_vo *v)
{
    sp_vec3 sum = { 0, 0, 0 };
    size_t k = 0;
    for (size_t i = 0; i < v->n; i++)
        if (v->f[i].has_up) {
            sp_vec3 u = { v->f[i].up[0], v->f[i].up[1], v->f[i].up[2] };
            sum = sp_vec3_add(sum, sp_quat_rotate(v->f[i].c, u)), k++;
        }
    return k * 2 >= v->n && sp_vec3_norm(sum) > 0.5 * (double)k ? sp_vec3_normalize(sum) : (sp_vec3){ 0, 0, 0 };
}

/* World up: the accelerometer's when it is known; else the turn's axis (the principal direction of the
   steps' world rotation vectors), signed towards the first frame's up; else the first frame's up. The
   turn's axis is found in every case, and its angle to gravity reported. */
static sp_vec3 world_up(const sp_vo *v, sp_vo_result *res)
{
    double M[9] = { 0 }, tr = 0;
    for (size_t i = 1; i < v->n; i++) {
        sp_vec3 w = sp_quat_to_rotvec(sp_quat_mul(v->f[i].c, sp_quat_conj(v->f[i - 1].c)));
        double a[3] = { w.x, w.y, w.z };
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                M[3 * r + c] += a[r] * a[c];
        tr += a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    }
    sp_vec3 cam_up = sp_quat_rotate(v->f[0].c, (sp_vec3){ 0, -1, 0 });
    double x[3] = { cam_up.x, cam_up.y, cam_up.z }, lambda = 0;
    for (int it = 0; it < 100 && tr > 0; it++) {
        double y[3];
        for (int r = 0; r < 3; r++)
            y[r] = M[3 * r] * x[0] + M[3 * r + 1] * x[1] + M[3 * r + 2] * x[2];
        double n = sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]);
        if (!(n > 0))
            break;
        lambda = n;
        for (int r = 0; r < 3; r++)
            x[r] = y[r] / n;
    }
    res->turn_axis_share = tr > 0 ? lambda / tr : 0.0;
    int turn_says = res->turn_deg >= AXIS_MIN_TURN && res->turn_axis_share >= AXIS_MIN_SHARE;
    sp_vec3 axis = { x[0], x[1], x[2] }, g = gravity_up(v);
    axis = sp_vec3_dot(axis, cam_up) < 0 ? sp_vec3_scale(axis, -1.0) : axis;
    if (sp_vec3_norm(g) > 0) {
        res->up_from_gravity = 1;
        if (turn_says)
            res->axis_to_gravity_deg = acos(fmax(-1.0, fmin(1.0, sp_vec3_dot(axis, g)))) * 180.0 / M_PI;
        return g;
    }
    res->up_from_turn = turn_says;
    return turn_says ? axis : cam_up;
}

int sp_vo_finish(sp_vo *v, sp_vo_result *r)
{
    if (!v || !r)
        return -EINVAL;
    memset(r, 0, sizeof(*r));
    r->axis_to_gravity_deg = NAN;
    r->frames = v->n;
    r->coasted = v->coasted;
    if (v->n < 2)
        return SP_ENODATA;
    size_t steps = v->n - 1;
    double *tmp = malloc(sizeof(double) * steps);
    if (!tmp)
        return -ENOMEM;
    memcpy(tmp, v->inlier_counts, sizeof(double) * steps);
    r->median_inliers = sp_median_inplace(tmp, steps);
    free(tmp);
    r->turn_deg = v->f[v->n - 1].path_deg;
    if (v->loop_closed) {
        r->loop_closed = 1, r->loop_frame = v->loop_frame, r->loop_inliers = v->loop_inliers;
        close_loop(v, &r->loop_correction_deg);
    }
    sp_vec3 up = world_up(v, r);
    /* the world turned so that up is +z and the first camera looks along +x */
    sp_vec3 fwd = sp_quat_rotate(v->f[0].c, (sp_vec3){ 0, 0, 1 });
    fwd = sp_vec3_sub(fwd, sp_vec3_scale(up, sp_vec3_dot(fwd, up)));
    if (sp_vec3_norm(fwd) < 1e-6) /* looking straight up or down: any horizontal direction */
        fwd = sp_quat_rotate(v->f[0].c, (sp_vec3){ 1, 0, 0 });
    fwd = sp_vec3_normalize(fwd);
    sp_vec3 left = sp_vec3_cross(up, fwd);
    double W[9] = { fwd.x, fwd.y, fwd.z, left.x, left.y, left.z, up.x, up.y, up.z }; /* rows: new axes */
    sp_quat wq = sp_quat_from_matrix(W);
    for (size_t i = 0; i < v->n; i++)
        v->f[i].c = sp_quat_normalize(sp_quat_mul(wq, v->f[i].c));
    if (r->median_inliers < MIN_INLIERS || (double)v->coasted > MAX_COASTED * (double)steps)
        return SP_ENODATA;
    return 0;
}

int sp_vo_camera(const sp_vo *v, size_t i, sp_quat *camera_to_world, int *tracked)
{
    if (!v || !camera_to_world)
        return -EINVAL;
    if (i >= v->n)
        return -ERANGE;
    *camera_to_world = v->f[i].c;
    if (tracked)
        *tracked = v->f[i].tracked;
    return 0;
}
