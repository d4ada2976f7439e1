/* SPDX-License-Identifier: MIT */
/*
 * Synthetic turning-person IMU. The pose is an analytic function of time, so the
 * gyro (body rate), accelerometer (specific force) and truth come from the same
 * formulas and agree exactly before noise, bias and clipping are added.
 *
 * camera_to_world(t) = Yaw(heading + psi(t)) * Sway(t) * Pitch * Axes * Flick(t):
 * yaw about world z; sway = roll and pitch about the level frame's horizontal axes;
 * Axes maps camera (x right, y down, z forward) onto the level frame (x forward,
 * y left, z up); Flick is the saturation injector, about an axis in camera axes.
 */
#include "sunprobe/sp_fake_imu.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GRAVITY 9.80665
#define DEG (M_PI / 180.0)
#define QUEUE_CAP 16

struct sp_fake_imu {
    sp_fake_imu_settings s;
    int64_t tick;     /* next tick to generate */
    int64_t n_ticks;
    uint64_t rng;
    int have_spare;
    double spare;     /* Box-Muller's second value */
    sp_imu_sample queue[QUEUE_CAP];
    unsigned q_head, q_len;
};

void sp_fake_imu_default_settings(sp_fake_imu_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->rate_hz = 200.0;
    s->start_ns = 1000000000;
    s->still_before_s = 1.0;
    s->turn_duration_s = 10.0;
    s->turn_deg = 360.0;
    s->still_after_s = 1.0;
    s->arm_radius_m = 0.6;
    s->wobble_deg = 0.5;
    s->imu_to_camera = sp_quat_identity();
    s->gyro_noise = 0.01 * DEG;
    s->gyro_bias = (sp_vec3){ 0.3 * DEG, -0.5 * DEG, 0.2 * DEG };
    s->gyro_range = 2000.0 * DEG;
    s->accel_noise = 2e-3;
    s->accel_bias = (sp_vec3){ 0.02, -0.03, 0.02 };
    s->mag_field_ut = (sp_vec3){ 20.0, 0.0, -44.0 };
    s->mag_noise_ut = 0.4;
    s->mag_decimation = 4;
    s->seed = 1;
    s->flick_at_s = -1.0;
    s->flick_duration_s = 0.12;
    s->flick_peak_dps = 3000.0;
    s->flick_axis = (sp_vec3){ 0.3, 1.0, 0.2 };
    s->gap_at_s = -1.0;
    s->gap_s = 0.2;
}

static int finite_vec(sp_vec3 v) { return isfinite(v.x) && isfinite(v.y) && isfinite(v.z); }

static int in_range(double v, double lo, double hi) { return isfinite(v) && v >= lo && v <= hi; }

static int check_settings(const sp_fake_imu_settings *s)
{
    if (!s)
        return -EINVAL;
    sp_quat q = s->imu_to_camera;
    double qn = sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
    int ok = in_range(s->rate_hz, 1.0, 1e5) && in_range(s->still_before_s, 0, 1e6) &&
             in_range(s->turn_duration_s, 0, 1e6) && in_range(s->still_after_s, 0, 1e6) &&
             in_range(s->turn_deg, -1e6, 1e6) && (s->turn_duration_s > 0 || s->turn_deg == 0) &&
             in_range(s->heading_deg, -1e6, 1e6) && in_range(s->pitch_deg, -90, 90) &&
             in_range(s->arm_radius_m, 0, 100) && in_range(s->wobble_deg, 0, 45) && in_range(qn, 1e-9, 1e9) &&
             in_range(s->gyro_noise, 0, 10) && finite_vec(s->gyro_bias) && in_range(s->gyro_range, 1e-6, 1e6) &&
             in_range(s->accel_noise, 0, 100) && finite_vec(s->accel_bias) && finite_vec(s->mag_field_ut) &&
             in_range(s->mag_noise_ut, 0, 1e4) && s->mag_decimation >= 1;
    if (ok && s->flick_at_s >= 0)
        ok = isfinite(s->flick_at_s) && in_range(s->flick_duration_s, 1e-6, 1e3) &&
             in_range(s->flick_peak_dps, 0, 1e6) && finite_vec(s->flick_axis) && sp_vec3_norm(s->flick_axis) > 0;
    if (ok && s->gap_at_s >= 0)
        ok = isfinite(s->gap_at_s) && in_range(s->gap_s, 0, 1e6);
    double total = sp_fake_imu_duration_s(s);
    /* the last timestamp must fit in int64 nanoseconds */
    if (ok && (double)s->start_ns + total * 1e9 > 9.2e18)
        ok = 0;
    return ok ? 0 : -EINVAL;
}

double sp_fake_imu_duration_s(const sp_fake_imu_settings *s)
{
    return s ? s->still_before_s + s->turn_duration_s + s->still_after_s : 0.0;
}

/* ---- deterministic randomness (splitmix64, Box-Muller) ---- */

static uint64_t splitmix(uint64_t *state)
{
    uint64_t z = (*state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Uniform in (0, 1): never 0, so log() below stays finite. */
static double uniform(uint64_t *state) { return ((double)(splitmix(state) >> 11) + 0.5) / 9007199254740992.0; }

static double gauss(sp_fake_imu *g)
{
    if (g->have_spare) {
        g->have_spare = 0;
        return g->spare;
    }
    double r = sqrt(-2.0 * log(uniform(&g->rng)));
    double a = 2.0 * M_PI * uniform(&g->rng);
    g->spare = r * sin(a);
    g->have_spare = 1;
    return r * cos(a);
}

/* Sway phase i for a seed, so truth needs no open generator. */
static double phase(uint64_t seed, unsigned i)
{
    uint64_t st = seed * 0x100000001B3ull + i * 0x9E3779B97F4A7C15ull;
    return 2.0 * M_PI * uniform(&st);
}

/* ---- motion ---- */

typedef struct pose {
    sp_quat cam_to_world;
    sp_vec3 omega_cam; /* body angular rate in camera axes, rad/s */
    sp_vec3 pos, acc;  /* camera position and acceleration, world */
} pose;

/* Seconds from a to b without int64 overflow. */
static double ns_diff_s(int64_t b, int64_t a)
{
    if ((a < 0 && b > INT64_MAX + a) || (a > 0 && b < INT64_MIN + a))
        return ((double)b - (double)a) * 1e-9;
    return (double)(b - a) * 1e-9;
}

/* Yaw psi(tau) relative to the heading, with its first two derivatives (smootherstep, C2). */
static void yaw_profile(const sp_fake_imu_settings *s, double tau, double y[3])
{
    double T = s->turn_duration_s, turn = s->turn_deg * DEG;
    y[0] = y[1] = y[2] = 0.0;
    if (!(T > 0))
        return;
    double u = (tau - s->still_before_s) / T;
    if (u <= 0)
        return;
    if (u >= 1) {
        y[0] = turn;
        return;
    }
    y[0] = turn * u * u * u * (10.0 - 15.0 * u + 6.0 * u * u);
    y[1] = turn / T * 30.0 * u * u * (1 - u) * (1 - u);
    y[2] = turn / (T * T) * 60.0 * u * (1 - u) * (1 - 2 * u);
}

/* One sway angle: slow sway plus a small tremor, value and rate. */
static void sway_angle(const sp_fake_imu_settings *s, unsigned k, const double f[3], double tau, double out[2])
{
    static const double w[3] = { 0.7, 0.3, 0.1 };
    double amp = s->wobble_deg * DEG;
    out[0] = out[1] = 0.0;
    for (unsigned i = 0; i < 3; i++) {
        double om = 2.0 * M_PI * f[i], ph = phase(s->seed, 3 * k + i);
        out[0] += amp * w[i] * sin(om * tau + ph);
        out[1] += amp * w[i] * om * cos(om * tau + ph);
    }
}

/* Flick angle and rate: out and back, peak rate flick_peak_dps. */
static void flick_profile(const sp_fake_imu_settings *s, double tau, double out[2])
{
    out[0] = out[1] = 0.0;
    if (s->flick_at_s < 0)
        return;
    double D = s->flick_duration_s, u = (tau - s->flick_at_s) / D;
    if (!(u > 0 && u < 1))
        return;
    double F = s->flick_peak_dps * DEG * D / M_PI;
    out[0] = 0.5 * F * (1.0 - cos(2.0 * M_PI * u));
    out[1] = F * M_PI * sin(2.0 * M_PI * u) / D;
}

static sp_quat axes_quat(void)
{
    /* columns: camera x -> level -y, camera y -> level -z, camera z -> level +x */
    static const double m[9] = { 0, 0, 1, -1, 0, 0, 0, -1, 0 };
    return sp_quat_from_matrix(m);
}

static void pose_at(const sp_fake_imu_settings *s, double tau, pose *p)
{
    static const double fa[3] = { 0.45, 1.3, 8.7 }, fb[3] = { 0.37, 1.1, 9.3 };
    double tot = sp_fake_imu_duration_s(s);
    tau = tau < 0 ? 0 : tau > tot ? tot : tau;
    double y[3], a[2], b[2], fl[2];
    yaw_profile(s, tau, y);
    sway_angle(s, 0, fa, tau, a);
    sway_angle(s, 1, fb, tau, b);
    flick_profile(s, tau, fl);
    double psi = s->heading_deg * DEG + y[0];
    sp_vec3 X = { 1, 0, 0 }, Y = { 0, 1, 0 }, Z = { 0, 0, 1 };
    sp_vec3 n = sp_vec3_normalize(s->flick_axis);
    sp_quat qy = sp_quat_from_axis_angle(Z, psi);
    sp_quat qrb = sp_quat_from_axis_angle(Y, b[0]);
    sp_quat qs = sp_quat_mul(sp_quat_from_axis_angle(X, a[0]), qrb);
    sp_quat qpc = sp_quat_mul(sp_quat_from_axis_angle(Y, s->pitch_deg * DEG), axes_quat());
    sp_quat qf = s->flick_at_s >= 0 ? sp_quat_from_axis_angle(n, fl[0]) : sp_quat_identity();
    p->cam_to_world = sp_quat_normalize(sp_quat_mul(sp_quat_mul(sp_quat_mul(qy, qs), qpc), qf));
    /* body rate of a product A*B is R_B^T w_A + w_B, applied factor by factor */
    sp_vec3 w_s = sp_vec3_add(sp_quat_rotate(sp_quat_conj(qrb), sp_vec3_scale(X, a[1])), sp_vec3_scale(Y, b[1]));
    sp_vec3 w = sp_vec3_add(sp_quat_rotate(sp_quat_conj(qs), sp_vec3_scale(Z, y[1])), w_s);
    w = sp_quat_rotate(sp_quat_conj(sp_quat_mul(qpc, qf)), w);
    p->omega_cam = sp_vec3_add(w, sp_vec3_scale(n, fl[1]));
    /* camera on a circle of the arm's radius, looking at the person at the origin */
    double r = s->arm_radius_m, c = cos(psi), sn = sin(psi);
    p->pos = (sp_vec3){ -r * c, -r * sn, 0.0 };
    p->acc = (sp_vec3){ r * y[1] * y[1] * c + r * y[2] * sn, r * y[1] * y[1] * sn - r * y[2] * c, 0.0 };
}

int sp_fake_imu_truth(const sp_fake_imu_settings *s, int64_t t_ns, sp_quat *imu_to_world, sp_quat *camera_to_world)
{
    int err = check_settings(s);
    if (err < 0)
        return err;
    pose p;
    pose_at(s, ns_diff_s(t_ns, s->start_ns), &p);
    if (camera_to_world)
        *camera_to_world = p.cam_to_world;
    if (imu_to_world)
        *imu_to_world = sp_quat_normalize(sp_quat_mul(p.cam_to_world, sp_quat_normalize(s->imu_to_camera)));
    return 0;
}

int sp_fake_imu_truth_position(const sp_fake_imu_settings *s, int64_t t_ns, sp_vec3 *position)
{
    int err = check_settings(s);
    if (err < 0 || !position)
        return err < 0 ? err : -EINVAL;
    pose p;
    pose_at(s, ns_diff_s(t_ns, s->start_ns), &p);
    *position = p.pos;
    return 0;
}

/* ---- sampling ---- */

static double tick_time_s(const sp_fake_imu *g, int64_t k) { return (double)k / g->s.rate_hz; }

static int64_t tick_ns(const sp_fake_imu *g, int64_t k) { return g->s.start_ns + llround(tick_time_s(g, k) * 1e9); }

static int in_gap(const sp_fake_imu *g, int64_t k)
{
    double tau = tick_time_s(g, k);
    return g->s.gap_at_s >= 0 && tau >= g->s.gap_at_s && tau < g->s.gap_at_s + g->s.gap_s;
}

static sp_imu_sample make_sample(sp_fake_imu *g, int64_t t, enum sp_imu_sensor sensor, sp_vec3 v, double sd)
{
    sp_imu_sample out = { .timestamp_ns = t, .sensor = (uint32_t)sensor };
    double c[3] = { v.x, v.y, v.z };
    for (int i = 0; i < 3; i++) {
        c[i] += sd * gauss(g);
        if (sensor == SP_IMU_GYRO) /* a real gyro clips at its range: the saturation case */
            c[i] = c[i] > g->s.gyro_range ? g->s.gyro_range : c[i] < -g->s.gyro_range ? -g->s.gyro_range : c[i];
        out.v[i] = (float)c[i];
    }
    return out;
}

static void push_queue(sp_fake_imu *g, sp_imu_sample smp)
{
    if (g->q_len < QUEUE_CAP)
        g->queue[(g->q_head + g->q_len++) % QUEUE_CAP] = smp;
}

/* All samples of tick k into out[] (at most 5); returns their count. */
static unsigned gen_tick(sp_fake_imu *g, int64_t k, sp_imu_sample out[5])
{
    const sp_fake_imu_settings *s = &g->s;
    pose p;
    pose_at(s, tick_time_s(g, k), &p);
    sp_quat q_ic = sp_quat_normalize(s->imu_to_camera);
    sp_quat q_wi = sp_quat_conj(sp_quat_mul(p.cam_to_world, q_ic)); /* world -> IMU */
    sp_vec3 gyro = sp_vec3_add(sp_quat_rotate(sp_quat_conj(q_ic), p.omega_cam), s->gyro_bias);
    sp_vec3 f = sp_vec3_add(p.acc, (sp_vec3){ 0, 0, GRAVITY }); /* specific force, world */
    sp_vec3 accel = sp_vec3_add(sp_quat_rotate(q_wi, f), s->accel_bias);
    double sg = s->gyro_noise * sqrt(s->rate_hz), sa = s->accel_noise * sqrt(s->rate_hz);
    int dup = s->duplicate_every && (k + 1) % s->duplicate_every == 0;
    int64_t t = tick_ns(g, k);
    unsigned n = 0;
    out[n++] = make_sample(g, t, SP_IMU_GYRO, gyro, sg);
    if (dup)
        out[n++] = make_sample(g, t, SP_IMU_GYRO, gyro, sg);
    out[n++] = make_sample(g, t, SP_IMU_ACCEL, accel, sa);
    if (dup)
        out[n++] = make_sample(g, t, SP_IMU_ACCEL, accel, sa);
    if (s->magnetometer && k % s->mag_decimation == 0)
        out[n++] = make_sample(g, t, SP_IMU_MAG, sp_quat_rotate(q_wi, s->mag_field_ut), s->mag_noise_ut);
    return n;
}

/* Index of the next tick at or after k outside the gap, or n_ticks. */
static int64_t next_live_tick(const sp_fake_imu *g, int64_t k)
{
    while (k < g->n_ticks && in_gap(g, k))
        k++;
    return k;
}

static int refill(sp_fake_imu *g)
{
    sp_imu_sample a[5], b[5];
    int64_t k = next_live_tick(g, g->tick);
    if (k >= g->n_ticks)
        return SP_EOS;
    unsigned na = gen_tick(g, k, a);
    g->tick = k + 1;
    int swap = g->s.swap_every && (k + 1) % g->s.swap_every == 0;
    int64_t k2 = swap ? next_live_tick(g, g->tick) : g->n_ticks;
    if (k2 < g->n_ticks) { /* emit the following tick first: out of order */
        unsigned nb = gen_tick(g, k2, b);
        g->tick = k2 + 1;
        for (unsigned i = 0; i < nb; i++)
            push_queue(g, b[i]);
    }
    for (unsigned i = 0; i < na; i++)
        push_queue(g, a[i]);
    return 0;
}

int sp_fake_imu_next(sp_fake_imu *imu, sp_imu_sample *out)
{
    if (!imu || !out)
        return -EINVAL;
    if (imu->q_len == 0) {
        int err = refill(imu);
        if (err < 0)
            return err;
    }
    *out = imu->queue[imu->q_head];
    imu->q_head = (imu->q_head + 1) % QUEUE_CAP;
    imu->q_len--;
    return 0;
}

int sp_fake_imu_open(sp_fake_imu **out, const sp_fake_imu_settings *s)
{
    if (!out)
        return -EINVAL;
    *out = NULL;
    int err = check_settings(s);
    if (err < 0)
        return err;
    sp_fake_imu *g = calloc(1, sizeof(*g));
    if (!g)
        return -ENOMEM;
    g->s = *s;
    g->n_ticks = (int64_t)floor(sp_fake_imu_duration_s(s) * s->rate_hz + 1e-9) + 1;
    g->rng = s->seed ^ 0x5DEECE66Dull;
    *out = g;
    return 0;
}

void sp_fake_imu_close(sp_fake_imu **imu)
{
    if (!imu || !*imu)
        return;
    free(*imu);
    *imu = NULL;
}

/* ---- as a stream source ---- */

static int source_next(void *ctx, sp_event *ev)
{
    int err = sp_fake_imu_next(ctx, &ev->imu);
    if (err < 0)
        return err;
    ev->type = SP_EVENT_IMU;
    ev->timestamp_ns = ev->imu.timestamp_ns;
    return 0;
}

static void source_close(void *ctx)
{
    sp_fake_imu *g = ctx;
    sp_fake_imu_close(&g);
}

static const sp_source_ops fake_imu_source_ops = {
    .name = "fake-imu",
    .next = source_next,
    .close = source_close,
};

int sp_fake_imu_source_open(sp_source **out, const sp_fake_imu_settings *s)
{
    if (!out)
        return -EINVAL;
    *out = NULL;
    sp_fake_imu *g = NULL;
    int err = sp_fake_imu_open(&g, s);
    if (err < 0)
        return err;
    err = sp_source_create(out, &fake_imu_source_ops, g);
    if (err < 0)
        sp_fake_imu_close(&g);
    return err;
}
