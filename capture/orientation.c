/* SPDX-License-Identifier: MIT */
/*
 * Mahony complementary filter on unit quaternions (see capture/ORIENTATION.md):
 * gyro integration with a coning term, accelerometer (and magnetometer) feedback
 * weighted by how trustworthy the reading is, a centripetal/tangential correction
 * for a camera swung on an arm around a vertical axis, gyro bias from still
 * periods, and a bounded ring of (t, q) states for frame-time queries.
 */
#include "sunprobe/sp_orientation.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define DEG (M_PI / 180.0)
#define MAX_GUARD 8
#define MAG_MAX_AGE_S 0.1
#define MAG_AVERAGE_S 0.5
#define YAW_ACC_TAU_S 0.1
#define STILL_UPDATE_MIN_S 1.0

/* Running sums over still windows; t is seconds from the still period's origin. */
typedef struct still_sums {
    double dur;
    double ng;     /* gyro samples */
    sp_vec3 sw;    /* sum of rates */
    double sww[6]; /* sum of w w^T: xx yy zz xy xz yz */
    double na;     /* accel samples */
    sp_vec3 sa;
    double saa;    /* sum of |a|^2 */
    double st, stt;
    sp_vec3 sta, sphi, stphi; /* sums of t a, phi, t phi (phi: integrated raw gyro) */
} still_sums;

struct sp_orientation {
    sp_orientation_settings s;
    sp_quat q_ic;      /* imu_to_camera, normalised */
    int64_t offset_ns;
    sp_quat q;         /* imu_to_world */
    int have_q;
    sp_vec3 bias;
    uint64_t bias_period; /* period id that set the bias */
    /* last accepted timestamp per sensor (index = enum sp_imu_sensor) */
    int64_t last_t[4];
    int have_last[4];
    sp_vec3 gyro_prev; /* previous gyro reading (clipped), raw */
    int64_t gyro_t;
    int have_gyro;
    sp_vec3 accel, mag;
    int64_t accel_t, mag_t;
    int have_accel, have_mag;
    double yaw_rate_prev, yaw_acc; /* for the tangential term */
    int have_yaw_rate;
    int64_t recover_until;
    int recovering;
    int64_t first_t;
    int use_mag;
    double mag_norm;
    sp_vec3 mag_world; /* recent field in world axes (heading reference at initialisation) */
    int have_mag_world;
    /* still detection */
    still_sums win, period, pending[MAX_GUARD];
    uint32_t n_pending, skip; /* skip: windows still to ignore at the start of a period */
    int64_t win_t0, period_t0;
    int win_active;
    sp_vec3 phi;
    uint64_t period_id;
    int period_counted;
    /* history ring */
    int64_t *ring_t;
    sp_quat *ring_q;
    uint8_t *ring_break;
    size_t head, count;
    sp_orientation_stats st;
};

void sp_orientation_default_settings(sp_orientation_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->kp = 1.0;
    s->ki = 0.02;
    s->kp_fast = 3.0;
    s->kp_mag = 1.0;
    s->recover_s = 1.0;
    s->motion_rate_dps = 20.0;
    s->accel_gate = 0.1;
    s->turn_radius_m = 0.6;
    s->still_window_s = 0.25;
    s->still_yaw_std_dps = 0.6;
    s->still_tilt_std_dps = 10.0;
    s->still_rate_dps = 0.5;
    s->still_accel_std = 0.3;
    s->still_guard_windows = 2;
    s->update_bias_when_still = 1;
    s->init_timeout_s = 3.0;
    s->use_magnetometer = SP_ORIENTATION_MAG_AUTO;
    s->imu_to_camera = sp_quat_identity();
    s->gap_s = 0.05;
    s->max_gap_s = 0.5;
    s->gyro_range = 2000.0 * DEG;
    s->accel_max_age_s = 0.05;
    s->history_len = 2048;
    s->gravity = 9.80665;
}

static int in_range(double v, double lo, double hi) { return isfinite(v) && v >= lo && v <= hi; }

static int check_settings(const sp_orientation_settings *s)
{
    sp_quat q = s->imu_to_camera;
    double qn = sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
    int ok = in_range(s->kp, 0, 1e3) && in_range(s->ki, 0, 1e3) && in_range(s->kp_fast, 0, 1e3) &&
             in_range(s->kp_mag, 0, 1e3) && in_range(s->recover_s, 0, 1e6) &&
             in_range(s->motion_rate_dps, 1e-6, 1e6) && in_range(s->accel_gate, 1e-6, 10) &&
             in_range(s->turn_radius_m, 0, 100) && in_range(s->still_window_s, 1e-3, 60) &&
             in_range(s->still_yaw_std_dps, 0, 1e4) && in_range(s->still_tilt_std_dps, 0, 1e4) &&
             in_range(s->still_rate_dps, 0, 1e4) && in_range(s->still_accel_std, 0, 1e4) &&
             s->still_guard_windows < MAX_GUARD && in_range(s->init_timeout_s, 0, 1e6) &&
             (s->use_magnetometer == SP_ORIENTATION_MAG_AUTO || s->use_magnetometer == SP_ORIENTATION_MAG_OFF ||
              s->use_magnetometer == SP_ORIENTATION_MAG_ON) &&
             in_range(qn, 1e-9, 1e9) && in_range(s->time_offset_s, -1e6, 1e6) && in_range(s->gap_s, 1e-6, 1e6) &&
             in_range(s->max_gap_s, s->gap_s, 1e6) && in_range(s->gyro_range, 1e-6, 1e6) &&
             in_range(s->accel_max_age_s, 1e-6, 1e3) && s->history_len >= 2 && s->history_len <= (1u << 26) &&
             in_range(s->gravity, 1e-3, 1e3);
    return ok ? 0 : -EINVAL;
}

/* Seconds from a to b; exact int64 difference when it cannot overflow. */
static double ns_diff_s(int64_t b, int64_t a)
{
    if ((a < 0 && b > INT64_MAX + a) || (a > 0 && b < INT64_MIN + a))
        return ((double)b - (double)a) * 1e-9;
    return (double)(b - a) * 1e-9;
}

/* t + seconds, saturating instead of overflowing. */
static int64_t add_s(int64_t t, double sec)
{
    double r = (double)t + sec * 1e9;
    if (r >= 9.2e18)
        return INT64_MAX;
    return t + (int64_t)(sec * 1e9);
}

static int finite3(const float v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

static sp_vec3 up_in_body(sp_quat q) { return sp_quat_rotate(sp_quat_conj(q), (sp_vec3){ 0, 0, 1 }); }

/* ---- history ring ---- */

static size_t ring_index(const sp_orientation *o, size_t i) { return (o->head + i) % o->s.history_len; }

static void ring_record(sp_orientation *o, int64_t t, int brk)
{
    if (o->count > 0) {
        size_t last = ring_index(o, o->count - 1);
        if (o->ring_t[last] > t) /* never out of order: the lookup bisects */
            return;
        if (o->ring_t[last] == t) { /* same instant: keep the newest state */
            o->ring_q[last] = o->q;
            o->ring_break[last] |= (uint8_t)brk;
            return;
        }
    }
    size_t i;
    if (o->count < o->s.history_len) {
        i = ring_index(o, o->count++);
    } else { /* full: drop the oldest */
        i = o->head;
        o->head = ring_index(o, 1);
    }
    o->ring_t[i] = t;
    o->ring_q[i] = o->q;
    o->ring_break[i] = (uint8_t)brk;
}

/* Left-multiplies every state by a world rotation (heading anchoring). */
static void ring_rotate(sp_orientation *o, sp_quat d)
{
    for (size_t i = 0; i < o->count; i++) {
        size_t k = ring_index(o, i);
        o->ring_q[k] = sp_quat_normalize(sp_quat_mul(d, o->ring_q[k]));
    }
    o->q = sp_quat_normalize(sp_quat_mul(d, o->q));
}

/* ---- initial attitude and heading ---- */

/* Shortest rotation taking unit vector a onto unit vector b; any 180 deg turn when opposite. */
static sp_quat rotation_between(sp_vec3 a, sp_vec3 b)
{
    double d = sp_vec3_dot(a, b);
    if (d < -1.0 + 1e-12) {
        sp_vec3 axis = sp_vec3_cross(a, (sp_vec3){ 1, 0, 0 });
        if (sp_vec3_norm(axis) < 1e-6)
            axis = sp_vec3_cross(a, (sp_vec3){ 0, 1, 0 });
        return sp_quat_from_axis_angle(axis, M_PI);
    }
    sp_vec3 c = sp_vec3_cross(a, b);
    return sp_quat_normalize((sp_quat){ 1.0 + d, c.x, c.y, c.z });
}

/* Heading angle (about world z from +x) of the horizontal part of v, or NAN when v is vertical. */
static double heading_of(sp_vec3 v)
{
    if (hypot(v.x, v.y) < 1e-6 * (sp_vec3_norm(v) + 1e-300))
        return NAN;
    return atan2(v.y, v.x);
}

/* World yaw that makes the heading reference point along +x: the magnetic field's
 * horizontal part when m_world is given, else the camera's forward (or, looking
 * straight up/down, its up) axis. */
static sp_quat heading_anchor(const sp_orientation *o, const sp_vec3 *m_world)
{
    double h = NAN;
    if (m_world)
        h = heading_of(*m_world);
    if (!isfinite(h)) {
        sp_quat q_cw = sp_quat_mul(o->q, sp_quat_conj(o->q_ic));
        h = heading_of(sp_quat_rotate(q_cw, (sp_vec3){ 0, 0, 1 }));
        if (!isfinite(h))
            h = heading_of(sp_quat_rotate(q_cw, (sp_vec3){ 0, -1, 0 }));
    }
    return isfinite(h) ? sp_quat_from_axis_angle((sp_vec3){ 0, 0, 1 }, -h) : sp_quat_identity();
}

/* First attitude from one accelerometer reading: tilt exact, heading anchored like init. */
static int attitude_from_accel(sp_orientation *o, sp_vec3 a)
{
    double n = sp_vec3_norm(a);
    if (!(fabs(n / o->s.gravity - 1.0) < 0.5))
        return 0; /* far from 1 g: wait for a calmer reading */
    o->q = rotation_between(sp_vec3_scale(a, 1.0 / n), (sp_vec3){ 0, 0, 1 });
    o->q = sp_quat_normalize(sp_quat_mul(heading_anchor(o, NULL), o->q));
    return 1;
}

/*
 * States before initialisation were integrated without a bias estimate. Their
 * heading drift, b_v per second about the vertical, is removed now that b is
 * known (tilt drift was held down by the accelerometer meanwhile).
 */
static void undo_prior_drift(sp_orientation *o, int64_t t)
{
    double bv = sp_vec3_dot(o->bias, up_in_body(o->q));
    for (size_t i = 0; i < o->count; i++) {
        size_t k = ring_index(o, i);
        sp_quat d = sp_quat_from_axis_angle((sp_vec3){ 0, 0, 1 }, bv * ns_diff_s(t, o->ring_t[k]));
        o->ring_q[k] = sp_quat_normalize(sp_quat_mul(d, o->ring_q[k]));
    }
}

static void initialize(sp_orientation *o, int64_t t)
{
    sp_vec3 m_world = o->mag_world;
    int mag = o->s.use_magnetometer != SP_ORIENTATION_MAG_OFF && o->have_mag_world &&
              isfinite(heading_of(m_world));
    if (!mag && o->s.use_magnetometer == SP_ORIENTATION_MAG_ON)
        sp_log(SP_LOG_WARN, "orientation", "magnetometer requested but none usable; heading is relative");
    if (o->st.bias_from_still)
        undo_prior_drift(o, t);
    ring_rotate(o, heading_anchor(o, mag ? &m_world : NULL));
    o->use_mag = mag;
    o->mag_norm = mag ? sp_vec3_norm(m_world) : 0.0;
    o->st.initialized = 1;
    o->st.using_magnetometer = mag;
    o->st.initialized_at_ns = t;
}

/* ---- still detection and bias ---- */

static void sums_add(still_sums *a, const still_sums *b)
{
    a->dur += b->dur;
    a->ng += b->ng;
    a->sw = sp_vec3_add(a->sw, b->sw);
    for (int i = 0; i < 6; i++)
        a->sww[i] += b->sww[i];
    a->na += b->na;
    a->sa = sp_vec3_add(a->sa, b->sa);
    a->saa += b->saa;
    a->st += b->st;
    a->stt += b->stt;
    a->sta = sp_vec3_add(a->sta, b->sta);
    a->sphi = sp_vec3_add(a->sphi, b->sphi);
    a->stphi = sp_vec3_add(a->stphi, b->stphi);
}

/*
 * Bias from a still period. About gravity: the mean rate (no motion is assumed
 * there). About horizontal axes, where hand sway moves the device, the accel
 * trend explains the sway: a(t) - a0 x phi(t) = a(0) - (a0 x b) t, so the
 * regression slope c gives b_perp = a0 x c / |a0|^2.
 */
static int bias_from_sums(const still_sums *p, sp_vec3 *out)
{
    if (p->na < 10 || p->ng < 10)
        return 0;
    sp_vec3 a0 = sp_vec3_scale(p->sa, 1.0 / p->na);
    double a2 = sp_vec3_dot(a0, a0);
    if (!(a2 > 1e-6))
        return 0;
    sp_vec3 ahat = sp_vec3_normalize(a0), wm = sp_vec3_scale(p->sw, 1.0 / p->ng);
    sp_vec3 b_par = sp_vec3_scale(ahat, sp_vec3_dot(wm, ahat));
    sp_vec3 b_perp = sp_vec3_sub(wm, b_par);
    double den = p->stt - p->st * p->st / p->na;
    if (den > 1e-9 * p->na) {
        sp_vec3 sty = sp_vec3_sub(p->sta, sp_vec3_cross(a0, p->stphi));
        sp_vec3 sy = sp_vec3_sub(p->sa, sp_vec3_cross(a0, p->sphi));
        sp_vec3 c = sp_vec3_scale(sp_vec3_sub(sty, sp_vec3_scale(sy, p->st / p->na)), 1.0 / den);
        b_perp = sp_vec3_scale(sp_vec3_cross(a0, c), 1.0 / a2);
    }
    *out = sp_vec3_add(b_par, b_perp);
    return isfinite(out->x) && isfinite(out->y) && isfinite(out->z);
}

static int window_is_still(const sp_orientation *o, const still_sums *w)
{
    if (w->ng < 3 || w->na < 3)
        return 0;
    sp_vec3 m = sp_vec3_scale(w->sw, 1.0 / w->ng), am = sp_vec3_scale(w->sa, 1.0 / w->na);
    sp_vec3 u = sp_vec3_normalize(am);
    double an = sp_vec3_norm(am);
    if (!(an > 0) || fabs(an / o->s.gravity - 1.0) > o->s.accel_gate)
        return 0;
    const double *s = w->sww;
    double n = w->ng;
    double c[6] = { s[0] / n - m.x * m.x, s[1] / n - m.y * m.y, s[2] / n - m.z * m.z,
                    s[3] / n - m.x * m.y, s[4] / n - m.x * m.z, s[5] / n - m.y * m.z };
    double yaw_var = u.x * u.x * c[0] + u.y * u.y * c[1] + u.z * u.z * c[2] +
                     2.0 * (u.x * u.y * c[3] + u.x * u.z * c[4] + u.y * u.z * c[5]);
    double tilt_var = c[0] + c[1] + c[2] - yaw_var;
    double acc_var = w->saa / w->na - an * an;
    double known = o->st.bias_from_still ? 1.0 : 10.0;
    double yaw_mean = sp_vec3_dot(sp_vec3_sub(m, o->st.bias_from_still ? o->bias : (sp_vec3){ 0, 0, 0 }), u);
    double ys = o->s.still_yaw_std_dps * DEG, ts = o->s.still_tilt_std_dps * DEG;
    return yaw_var < ys * ys && tilt_var < ts * ts && fabs(yaw_mean) < known * o->s.still_rate_dps * DEG &&
           acc_var < o->s.still_accel_std * o->s.still_accel_std;
}

/* Starts a new still period at t; after motion or a gap its first windows are skipped, as the
 * end of a motion (a slow stop) looks still but is not. */
static void still_reset(sp_orientation *o, int64_t t, int after_motion)
{
    memset(&o->win, 0, sizeof(o->win));
    memset(&o->period, 0, sizeof(o->period));
    o->n_pending = 0;
    o->skip = after_motion ? o->s.still_guard_windows : 0;
    o->win_t0 = o->period_t0 = t;
    o->win_active = 1;
    o->phi = (sp_vec3){ 0, 0, 0 };
    o->period_id++;
    o->period_counted = 0;
}

static void commit_window(sp_orientation *o, const still_sums *w, int64_t t)
{
    sums_add(&o->period, w);
    if (!o->period_counted) {
        o->period_counted = 1;
        o->st.still_periods++;
    }
    sp_vec3 b;
    int first = !o->st.bias_from_still || o->bias_period == o->period_id;
    int update = first || (o->s.update_bias_when_still && o->period.dur >= STILL_UPDATE_MIN_S);
    if (update && bias_from_sums(&o->period, &b)) {
        o->bias = b;
        o->bias_period = o->period_id;
        sp_log(SP_LOG_DEBUG, "orientation", "bias (%.4f %.4f %.4f) deg/s from %.2f s still at t=%.3f s",
               b.x / DEG, b.y / DEG, b.z / DEG, o->period.dur, (double)t * 1e-9);
        o->st.bias_from_still = 1;
    }
    if (!o->st.initialized)
        initialize(o, t);
}

/* Closes the current window at t: still windows wait guard windows before use. */
static void close_window(sp_orientation *o, int64_t t)
{
    o->win.dur = ns_diff_s(t, o->win_t0);
    if (!window_is_still(o, &o->win)) {
        still_reset(o, t, 1);
        return;
    }
    if (o->skip > 0)
        o->skip--;
    else
        o->pending[o->n_pending++] = o->win;
    if (o->n_pending > o->s.still_guard_windows) {
        still_sums oldest = o->pending[0];
        memmove(o->pending, o->pending + 1, (o->n_pending - 1) * sizeof(o->pending[0]));
        o->n_pending--;
        commit_window(o, &oldest, t);
    }
    memset(&o->win, 0, sizeof(o->win));
    o->win_t0 = t;
}

static void still_add_gyro(sp_orientation *o, sp_vec3 w)
{
    still_sums *s = &o->win;
    s->ng += 1;
    s->sw = sp_vec3_add(s->sw, w);
    s->sww[0] += w.x * w.x;
    s->sww[1] += w.y * w.y;
    s->sww[2] += w.z * w.z;
    s->sww[3] += w.x * w.y;
    s->sww[4] += w.x * w.z;
    s->sww[5] += w.y * w.z;
}

static void still_add_accel(sp_orientation *o, int64_t t, sp_vec3 a)
{
    if (!o->win_active || !o->have_gyro)
        return;
    still_sums *s = &o->win;
    double tr = ns_diff_s(t, o->period_t0);
    /* phi at the accel time, extrapolated from the last gyro step */
    sp_vec3 phi = sp_vec3_add(o->phi, sp_vec3_scale(o->gyro_prev, ns_diff_s(t, o->gyro_t)));
    s->na += 1;
    s->sa = sp_vec3_add(s->sa, a);
    s->saa += sp_vec3_dot(a, a);
    s->st += tr;
    s->stt += tr * tr;
    s->sta = sp_vec3_add(s->sta, sp_vec3_scale(a, tr));
    s->sphi = sp_vec3_add(s->sphi, phi);
    s->stphi = sp_vec3_add(s->stphi, sp_vec3_scale(phi, tr));
}

/* ---- propagation ---- */

/* Specific force of turning about a vertical axis that lies turn_radius ahead of the IMU along
 * the camera's level forward direction h (the person the camera looks at): centripetal s^2 r h
 * plus tangential -r ds/dt (u x h), s being the rate about the vertical u. */
static sp_vec3 turn_accel(const sp_orientation *o, sp_vec3 u)
{
    double r = o->s.turn_radius_m;
    if (!(r > 0))
        return (sp_vec3){ 0, 0, 0 };
    sp_vec3 fwd = sp_quat_rotate(sp_quat_conj(o->q_ic), (sp_vec3){ 0, 0, 1 });
    sp_vec3 h = sp_vec3_normalize(sp_vec3_sub(fwd, sp_vec3_scale(u, sp_vec3_dot(fwd, u))));
    if (sp_vec3_norm(h) < 0.5)
        return (sp_vec3){ 0, 0, 0 };
    double s = o->yaw_rate_prev;
    return sp_vec3_scale(sp_vec3_sub(sp_vec3_scale(h, s * s), sp_vec3_scale(sp_vec3_cross(u, h), o->yaw_acc)), r);
}

static void track_yaw_rate(sp_orientation *o, sp_vec3 w, sp_vec3 u, double dt)
{
    double s = sp_vec3_dot(w, u);
    if (o->have_yaw_rate && dt > 0) {
        double k = dt / YAW_ACC_TAU_S;
        o->yaw_acc += ((s - o->yaw_rate_prev) / dt - o->yaw_acc) * (k < 1 ? k : 1);
    } else {
        o->yaw_acc = 0;
    }
    o->yaw_rate_prev = s;
    o->have_yaw_rate = 1;
}

/* Mahony accelerometer term: body-frame correction rate; also feeds the integral (bias). */
static sp_vec3 accel_correction(sp_orientation *o, int64_t t, sp_vec3 w, double dt, int fast)
{
    sp_vec3 zero = { 0, 0, 0 };
    if (!o->have_accel || fabs(ns_diff_s(t, o->accel_t)) > o->s.accel_max_age_s)
        return zero;
    sp_vec3 u = up_in_body(o->q);
    sp_vec3 a = sp_vec3_sub(o->accel, turn_accel(o, u));
    double n = sp_vec3_norm(a);
    if (!(n > 0) || !isfinite(n))
        return zero;
    double w_acc = 1.0 - fabs(n / o->s.gravity - 1.0) / o->s.accel_gate;
    if (!(w_acc > 0))
        return zero;
    double r = sp_vec3_norm(w) / (o->s.motion_rate_dps * DEG);
    double w_rate = 1.0 / (1.0 + r * r);
    sp_vec3 e = sp_vec3_cross(sp_vec3_scale(a, 1.0 / n), u);
    if (fast)
        return sp_vec3_scale(e, o->s.kp_fast * w_acc);
    o->bias = sp_vec3_sub(o->bias, sp_vec3_scale(e, o->s.ki * w_acc * w_rate * dt));
    return sp_vec3_scale(e, o->s.kp * w_acc * w_rate);
}

/* Magnetometer term, restricted to the vertical axis so it never tilts the estimate; its
 * integral learns the heading part of the bias, which nothing else observes. */
static sp_vec3 mag_correction(sp_orientation *o, int64_t t, double dt, int fast)
{
    sp_vec3 zero = { 0, 0, 0 };
    if (!o->use_mag || !o->have_mag || fabs(ns_diff_s(t, o->mag_t)) > MAG_MAX_AGE_S)
        return zero;
    double n = sp_vec3_norm(o->mag);
    if (!(fabs(n / o->mag_norm - 1.0) < 0.3)) /* disturbed field */
        return zero;
    sp_vec3 u = up_in_body(o->q);
    sp_vec3 north = sp_quat_rotate(sp_quat_conj(o->q), (sp_vec3){ 1, 0, 0 });
    sp_vec3 mh = sp_vec3_normalize(sp_vec3_sub(o->mag, sp_vec3_scale(u, sp_vec3_dot(o->mag, u))));
    sp_vec3 nh = sp_vec3_normalize(sp_vec3_sub(north, sp_vec3_scale(u, sp_vec3_dot(north, u))));
    double e = sp_vec3_dot(sp_vec3_cross(mh, nh), u);
    if (!isfinite(e))
        return zero;
    if (!fast)
        o->bias = sp_vec3_sub(o->bias, sp_vec3_scale(u, o->s.ki * e * dt));
    return sp_vec3_scale(u, (fast ? o->s.kp_fast : o->s.kp_mag) * e);
}

static void propagate(sp_orientation *o, int64_t t, double dt, sp_vec3 w0_raw, sp_vec3 w1_raw)
{
    int fast = !o->st.initialized || t < o->recover_until;
    sp_vec3 w0 = sp_vec3_sub(w0_raw, o->bias), w1 = sp_vec3_sub(w1_raw, o->bias);
    track_yaw_rate(o, w1, up_in_body(o->q), dt);
    sp_vec3 corr = accel_correction(o, t, w1, dt, fast);
    if (o->st.initialized)
        corr = sp_vec3_add(corr, mag_correction(o, t, dt, fast));
    /* trapezoid rate plus the second-order coning term of two rate samples */
    sp_vec3 mean = sp_vec3_scale(sp_vec3_add(w0, w1), 0.5);
    sp_vec3 dtheta = sp_vec3_scale(sp_vec3_add(mean, corr), dt);
    dtheta = sp_vec3_add(dtheta, sp_vec3_scale(sp_vec3_cross(w0, w1), dt * dt / 12.0));
    o->q = sp_quat_normalize(sp_quat_mul(o->q, sp_quat_from_rotvec(dtheta)));
}

/* ---- sample handling ---- */

static sp_vec3 clip_gyro(sp_orientation *o, const float v[3], int64_t t)
{
    double r = o->s.gyro_range, c[3];
    int sat = 0;
    for (int i = 0; i < 3; i++) {
        c[i] = v[i];
        if (fabs(c[i]) >= 0.999 * r)
            sat = 1;
        c[i] = c[i] > r ? r : c[i] < -r ? -r : c[i];
    }
    if (sat) { /* the true rate is unknown beyond the range: lean on the accelerometer afterwards */
        o->st.saturated++;
        o->recover_until = add_s(t, o->s.recover_s);
    }
    return (sp_vec3){ c[0], c[1], c[2] };
}

static void on_gyro(sp_orientation *o, int64_t t, const float v[3])
{
    sp_vec3 w = clip_gyro(o, v, t);
    if (!o->have_gyro) {
        o->have_gyro = 1;
        still_reset(o, t, 0);
        if (o->have_q)
            ring_record(o, t, 0);
    } else {
        double dt = ns_diff_s(t, o->gyro_t);
        int brk = 0;
        if (dt > o->s.gap_s) {
            o->st.gaps++;
            still_reset(o, t, 1);
        }
        if (dt > o->s.max_gap_s) { /* rotation over the gap is unknown: hold, then re-level fast */
            o->st.long_gaps++;
            o->recover_until = add_s(t, o->s.recover_s);
            o->have_yaw_rate = 0;
            brk = 1;
        } else {
            o->phi = sp_vec3_add(o->phi, sp_vec3_scale(sp_vec3_add(o->gyro_prev, w), 0.5 * dt));
            if (o->have_q)
                propagate(o, t, dt, o->gyro_prev, w);
        }
        if (o->win_active && ns_diff_s(t, o->win_t0) >= o->s.still_window_s)
            close_window(o, t);
        if (o->have_q)
            ring_record(o, t, brk);
    }
    still_add_gyro(o, w);
    o->gyro_prev = w;
    o->gyro_t = t;
    if (!o->st.initialized && o->have_q && ns_diff_s(t, o->first_t) > o->s.init_timeout_s)
        initialize(o, t);
}

static void on_accel(sp_orientation *o, int64_t t, const float v[3])
{
    sp_vec3 a = { v[0], v[1], v[2] };
    o->accel = a;
    o->accel_t = t;
    o->have_accel = 1;
    if (!o->have_q && attitude_from_accel(o, a)) {
        o->have_q = 1;
        o->first_t = t;
        if (o->have_gyro) /* states live at gyro times only, so the ring stays ordered */
            ring_record(o, o->gyro_t, 0);
    }
    still_add_accel(o, t, a);
}

static void on_mag(sp_orientation *o, int64_t t, const float v[3])
{
    o->mag = (sp_vec3){ v[0], v[1], v[2] };
    if (o->have_q) { /* averaged over about MAG_AVERAGE_S, so noise barely moves the anchor */
        sp_vec3 mw = sp_quat_rotate(o->q, o->mag);
        double k = o->have_mag_world ? ns_diff_s(t, o->mag_t) / MAG_AVERAGE_S : 1.0; /* mag_t: previous */
        k = k < 1.0 ? k : 1.0;
        o->mag_world = sp_vec3_add(o->mag_world, sp_vec3_scale(sp_vec3_sub(mw, o->mag_world), k));
        o->have_mag_world = 1;
    }
    o->mag_t = t;
    o->have_mag = 1;
}

int sp_orientation_push(sp_orientation *o, const sp_imu_sample *sample)
{
    if (!o || !sample)
        return -EINVAL;
    uint32_t k = sample->sensor;
    if (k < SP_IMU_GYRO || k > SP_IMU_MAG || !finite3(sample->v)) {
        o->st.dropped_invalid++;
        return SP_ENODATA;
    }
    int64_t t = sample->timestamp_ns;
    if (o->have_last[k] && t <= o->last_t[k]) {
        if (t == o->last_t[k])
            o->st.dropped_duplicate++;
        else
            o->st.dropped_out_of_order++;
        return SP_ENODATA;
    }
    o->have_last[k] = 1;
    o->last_t[k] = t;
    if (k == SP_IMU_GYRO)
        on_gyro(o, t, sample->v);
    else if (k == SP_IMU_ACCEL)
        on_accel(o, t, sample->v);
    else
        on_mag(o, t, sample->v);
    o->st.samples_used++;
    return 0;
}

/* ---- queries ---- */

int sp_orientation_imu_at(sp_orientation *o, int64_t t, sp_quat *imu_to_world)
{
    if (!o || !imu_to_world)
        return -EINVAL;
    if (!o->st.initialized || o->count == 0 || t > o->ring_t[ring_index(o, o->count - 1)])
        return -EAGAIN;
    if (t < o->ring_t[o->head])
        return SP_ENODATA;
    size_t lo = 0, hi = o->count - 1; /* last state with time <= t */
    while (lo < hi) {
        size_t mid = lo + (hi - lo + 1) / 2;
        if (o->ring_t[ring_index(o, mid)] <= t)
            lo = mid;
        else
            hi = mid - 1;
    }
    size_t a = ring_index(o, lo);
    if (o->ring_t[a] == t) {
        *imu_to_world = o->ring_q[a];
        return 0;
    }
    size_t b = ring_index(o, lo + 1);
    if (o->ring_break[b])
        return SP_ENODATA;
    double f = ns_diff_s(t, o->ring_t[a]) / ns_diff_s(o->ring_t[b], o->ring_t[a]);
    *imu_to_world = sp_quat_slerp(o->ring_q[a], o->ring_q[b], f);
    return 0;
}

int sp_orientation_camera_at(sp_orientation *o, int64_t frame_timestamp_ns, sp_quat *camera_to_world)
{
    if (!o || !camera_to_world)
        return -EINVAL;
    int64_t off = o->offset_ns, t = frame_timestamp_ns;
    if ((off > 0 && t < INT64_MIN + off) || (off < 0 && t > INT64_MAX + off))
        return SP_ENODATA; /* no IMU clock time can match */
    sp_quat q;
    int err = sp_orientation_imu_at(o, t - off, &q);
    if (err < 0)
        return err;
    *camera_to_world = sp_quat_normalize(sp_quat_mul(q, sp_quat_conj(o->q_ic)));
    return 0;
}

int sp_orientation_get_stats(const sp_orientation *o, sp_orientation_stats *out)
{
    if (!o || !out)
        return -EINVAL;
    *out = o->st;
    out->gyro_bias = o->bias;
    return 0;
}

/* ---- lifecycle ---- */

int sp_orientation_open(sp_orientation **out, const sp_orientation_settings *s)
{
    if (!out)
        return -EINVAL;
    *out = NULL;
    if (!s || check_settings(s) < 0)
        return -EINVAL;
    sp_orientation *o = calloc(1, sizeof(*o));
    if (!o)
        return -ENOMEM;
    o->s = *s;
    o->ring_t = calloc(s->history_len, sizeof(*o->ring_t));
    o->ring_q = calloc(s->history_len, sizeof(*o->ring_q));
    o->ring_break = calloc(s->history_len, sizeof(*o->ring_break));
    if (!o->ring_t || !o->ring_q || !o->ring_break) {
        sp_orientation_close(&o);
        return -ENOMEM;
    }
    o->q_ic = sp_quat_normalize(s->imu_to_camera);
    o->offset_ns = llround(s->time_offset_s * 1e9);
    o->q = sp_quat_identity();
    *out = o;
    return 0;
}

void sp_orientation_close(sp_orientation **o)
{
    if (!o || !*o)
        return;
    free((*o)->ring_t);
    free((*o)->ring_q);
    free((*o)->ring_break);
    free(*o);
    *o = NULL;
}
