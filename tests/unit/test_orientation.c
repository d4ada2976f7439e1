/* SPDX-License-Identifier: MIT */
/*
 * Orientation filter on the synthetic turning-person IMU, whose truth is known:
 * accuracy over a 360 deg turn, and the extremes (saturation, gaps, duplicated and
 * out-of-order samples, no motion, magnetometer, NaN, huge dt, exact-sample queries,
 * camera-IMU rotation and time offset). Also checks the generator against its truth.
 */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "check.h"
#include "sunprobe/sp_fake_imu.h"
#include "sunprobe/sp_orientation.h"
#include "sunprobe/sp_source.h"

#define DEG (M_PI / 180.0)
#define FRAME_NS 33333333 /* 30 fps */

typedef struct run_opts {
    double offset_s;       /* camera time = IMU time + offset, for the frame clock */
    int absolute;          /* compare heading absolutely (magnetometer) instead of from the first frame */
    uint32_t nan_every;    /* push a NaN sample after every Nth sample; 0 off */
} run_opts;

typedef struct run_result {
    double max_err_deg, final_err_deg, max_err_before_deg; /* before: frames before `split_s` */
    double split_s;
    int frames, nodata, nonfinite;
    uint64_t pushed, rejected;
    sp_orientation_stats stats;
} run_result;

static double heading_deg_of(sp_quat cam_to_world)
{
    sp_vec3 f = sp_quat_rotate(cam_to_world, (sp_vec3){ 0, 0, 1 });
    return atan2(f.y, f.x);
}

static void eval_frame(const sp_fake_imu_settings *g, int64_t tc, int64_t off_ns, sp_quat est, int absolute,
                       double *yaw_align, int *have_align, run_result *r)
{
    sp_quat truth;
    CHECK_EQ_INT(sp_fake_imu_truth(g, tc - off_ns, NULL, &truth), 0);
    if (!isfinite(est.w) || !isfinite(est.x) || !isfinite(est.y) || !isfinite(est.z)) {
        r->nonfinite++;
        return;
    }
    if (!*have_align) { /* no magnetometer: heading is only defined relative to the first frame */
        *yaw_align = absolute ? 0.0 : heading_deg_of(truth) - heading_deg_of(est);
        *have_align = 1;
    }
    sp_quat al = sp_quat_mul(sp_quat_from_axis_angle((sp_vec3){ 0, 0, 1 }, *yaw_align), est);
    double e = sp_quat_angle_between(truth, al) / DEG;
    if (!isfinite(e)) {
        r->nonfinite++;
        return;
    }
    r->max_err_deg = fmax(r->max_err_deg, e);
    if ((double)(tc - off_ns - g->start_ns) * 1e-9 < r->split_s)
        r->max_err_before_deg = fmax(r->max_err_before_deg, e);
    r->final_err_deg = e;
    r->frames++;
}

/* Streams the generator into the filter; after each sample, answers every frame the filter can. */
static void run(const sp_fake_imu_settings *g, const sp_orientation_settings *fs, const run_opts *opt,
                run_result *r)
{
    double split = r->split_s;
    memset(r, 0, sizeof(*r));
    r->split_s = split;
    sp_fake_imu *imu = NULL;
    sp_orientation *o = NULL;
    CHECK_EQ_INT(sp_fake_imu_open(&imu, g), 0);
    CHECK_EQ_INT(sp_orientation_open(&o, fs), 0);
    if (!imu || !o)
        goto done;
    int64_t off_ns = llround(opt->offset_s * 1e9), next_frame = g->start_ns + off_ns;
    double yaw_align = 0;
    int have_align = 0;
    sp_imu_sample smp;
    while (sp_fake_imu_next(imu, &smp) == 0) {
        r->pushed++;
        if (sp_orientation_push(o, &smp) == SP_ENODATA)
            r->rejected++;
        if (opt->nan_every && r->pushed % opt->nan_every == 0) {
            sp_imu_sample bad = smp;
            bad.v[r->pushed % 3] = NAN;
            CHECK(sp_orientation_push(o, &bad) == SP_ENODATA);
        }
        for (;;) {
            sp_quat q;
            int err = sp_orientation_camera_at(o, next_frame, &q);
            if (err == -EAGAIN)
                break;
            if (err == 0)
                eval_frame(g, next_frame, off_ns, q, opt->absolute, &yaw_align, &have_align, r);
            else if (err == SP_ENODATA)
                r->nodata++;
            else
                CHECK_MSG(0, "camera_at: %s", sp_strerror(err));
            next_frame += FRAME_NS;
        }
    }
    CHECK_EQ_INT(sp_orientation_get_stats(o, &r->stats), 0);
done:
    sp_orientation_close(&o);
    sp_fake_imu_close(&imu);
    CHECK(o == NULL && imu == NULL);
}

static void report(const char *name, const run_result *r)
{
    printf("%-28s frames %4d  max %.3f deg  final %.3f deg  nodata %d  gaps %llu  sat %llu  dup %llu  ooo %llu  "
           "invalid %llu  still %llu  bias (%.4f %.4f %.4f) deg/s\n",
           name, r->frames, r->max_err_deg, r->final_err_deg, r->nodata, (unsigned long long)r->stats.gaps,
           (unsigned long long)r->stats.saturated, (unsigned long long)r->stats.dropped_duplicate,
           (unsigned long long)r->stats.dropped_out_of_order, (unsigned long long)r->stats.dropped_invalid,
           (unsigned long long)r->stats.still_periods, r->stats.gyro_bias.x / DEG, r->stats.gyro_bias.y / DEG,
           r->stats.gyro_bias.z / DEG);
}

static int expected_frames(const sp_fake_imu_settings *g) { return (int)(sp_fake_imu_duration_s(g) * 30.0); }

/* ---- the generator against its own truth ---- */

static sp_vec3 numeric_rate(const sp_fake_imu_settings *g, int64_t t)
{
    const int64_t h = 100000; /* 0.1 ms */
    sp_quat a, b;
    sp_fake_imu_truth(g, t - h, &a, NULL);
    sp_fake_imu_truth(g, t + h, &b, NULL);
    return sp_vec3_scale(sp_quat_to_rotvec(sp_quat_mul(sp_quat_conj(a), b)), 1.0 / (2e-9 * (double)h));
}

static sp_vec3 numeric_specific_force(const sp_fake_imu_settings *g, int64_t t)
{
    const int64_t h = 1000000; /* 1 ms */
    sp_vec3 p0, p1, p2;
    sp_fake_imu_truth_position(g, t - h, &p0);
    sp_fake_imu_truth_position(g, t, &p1);
    sp_fake_imu_truth_position(g, t + h, &p2);
    sp_vec3 acc = sp_vec3_scale(sp_vec3_add(sp_vec3_sub(p0, sp_vec3_scale(p1, 2.0)), p2), 1.0 / 1e-6);
    sp_quat q;
    sp_fake_imu_truth(g, t, &q, NULL);
    return sp_quat_rotate(sp_quat_conj(q), sp_vec3_add(acc, (sp_vec3){ 0, 0, 9.80665 }));
}

static void test_generator(void)
{
    sp_fake_imu_settings g;
    sp_fake_imu_default_settings(&g);
    g.gyro_noise = g.accel_noise = 0;
    g.gyro_bias = g.accel_bias = (sp_vec3){ 0, 0, 0 };
    g.pitch_deg = 12;
    g.wobble_deg = 2;
    g.imu_to_camera = sp_quat_from_axis_angle((sp_vec3){ 1, -2, 0.5 }, 1.1);
    sp_fake_imu *imu = NULL;
    CHECK_EQ_INT(sp_fake_imu_open(&imu, &g), 0);
    sp_imu_sample smp;
    int64_t last_t = INT64_MIN;
    int n = 0, ngyro = 0, order_ok = 1;
    double max_w_err = 0, max_a_err = 0;
    while (imu && sp_fake_imu_next(imu, &smp) == 0) {
        order_ok &= smp.timestamp_ns >= last_t;
        last_t = smp.timestamp_ns;
        sp_vec3 v = { smp.v[0], smp.v[1], smp.v[2] };
        double tau = (double)(smp.timestamp_ns - g.start_ns) * 1e-9;
        if (n++ % 7 != 0 || tau < 0.01 || tau > 11.99) /* a sample of the stream, away from the clamped ends */
            continue;
        if (smp.sensor == SP_IMU_GYRO) {
            ngyro++;
            max_w_err = fmax(max_w_err, sp_vec3_norm(sp_vec3_sub(v, numeric_rate(&g, smp.timestamp_ns))));
        } else if (smp.sensor == SP_IMU_ACCEL) {
            max_a_err = fmax(max_a_err, sp_vec3_norm(sp_vec3_sub(v, numeric_specific_force(&g, smp.timestamp_ns))));
        }
    }
    CHECK(order_ok);
    CHECK(ngyro > 100);
    CHECK_EQ_INT(n, 2 * ((int)(12.0 * 200.0) + 1));
    CHECK(sp_fake_imu_next(imu, &smp) == SP_EOS);
    printf("generator vs numeric truth: gyro %.2e rad/s, accel %.2e m/s^2\n", max_w_err, max_a_err);
    CHECK_MSG(max_w_err < 2e-5, "gyro %g", max_w_err);
    CHECK_MSG(max_a_err < 2e-4, "accel %g", max_a_err);
    sp_fake_imu_close(&imu);
    CHECK(imu == NULL);

    /* truth composition and the turn itself */
    sp_quat qi, qc;
    CHECK_EQ_INT(sp_fake_imu_truth(&g, g.start_ns + 3000000000LL, &qi, &qc), 0);
    CHECK(sp_quat_angle_between(qi, sp_quat_mul(qc, g.imu_to_camera)) < 1e-9);
    g.turn_deg = 90;
    g.wobble_deg = 0;
    sp_quat q0, q1;
    sp_fake_imu_truth(&g, g.start_ns, NULL, &q0);
    sp_fake_imu_truth(&g, g.start_ns + 12000000000LL, NULL, &q1);
    CHECK_NEAR(heading_deg_of(q1) - heading_deg_of(q0), 90 * DEG, 1e-9);
    CHECK_NEAR(sp_quat_angle_between(q0, q1), 90 * DEG, 1e-9);
    /* camera looks at the person at the origin, from arm's length */
    sp_vec3 p;
    CHECK_EQ_INT(sp_fake_imu_truth_position(&g, g.start_ns + 5000000000LL, &p), 0);
    sp_fake_imu_truth(&g, g.start_ns + 5000000000LL, NULL, &qc);
    sp_vec3 fwd = sp_quat_rotate(qc, (sp_vec3){ 0, 0, 1 });
    CHECK_NEAR(sp_vec3_norm(p), 0.6, 1e-12);
    CHECK_NEAR(sp_vec3_dot(sp_vec3_normalize(p), sp_vec3_normalize((sp_vec3){ fwd.x, fwd.y, 0 })), -1.0, 1e-9);
    /* at rest, accel is +g up in body axes: checked against the formula, not the generator */
    g.turn_deg = 0;
    g.turn_duration_s = 0;
    CHECK_EQ_INT(sp_fake_imu_open(&imu, &g), 0);
    CHECK_EQ_INT(sp_fake_imu_next(imu, &smp), 0);
    CHECK_EQ_INT(sp_fake_imu_next(imu, &smp), 0);
    CHECK_EQ_INT(smp.sensor, SP_IMU_ACCEL);
    sp_fake_imu_truth(&g, smp.timestamp_ns, &qi, NULL);
    sp_vec3 up = sp_quat_rotate(sp_quat_conj(qi), (sp_vec3){ 0, 0, 9.80665 });
    CHECK_NEAR(smp.v[0], up.x, 1e-5);
    CHECK_NEAR(smp.v[1], up.y, 1e-5);
    CHECK_NEAR(smp.v[2], up.z, 1e-5);
    sp_fake_imu_close(&imu);
}

static void test_generator_api(void)
{
    sp_fake_imu_settings g;
    sp_fake_imu_default_settings(&g);
    g.magnetometer = 1;
    /* deterministic: same settings, same stream; another seed, another stream */
    sp_fake_imu *a = NULL, *b = NULL, *c = NULL;
    sp_source *src = NULL;
    CHECK_EQ_INT(sp_fake_imu_open(&a, &g), 0);
    CHECK_EQ_INT(sp_fake_imu_source_open(&src, &g), 0);
    g.seed = 2;
    CHECK_EQ_INT(sp_fake_imu_open(&c, &g), 0);
    int same = 1, differs = 0, mags = 0, gyros = 0;
    for (int i = 0; i < 500 && a && src && c; i++) {
        sp_imu_sample x, z;
        sp_event ev;
        CHECK_EQ_INT(sp_fake_imu_next(a, &x), 0);
        CHECK_EQ_INT(sp_source_next(src, &ev), 0);
        CHECK_EQ_INT(sp_fake_imu_next(c, &z), 0);
        same &= ev.type == SP_EVENT_IMU && ev.timestamp_ns == x.timestamp_ns && memcmp(&ev.imu, &x, sizeof(x)) == 0;
        differs |= memcmp(&z, &x, sizeof(x)) != 0;
        mags += x.sensor == SP_IMU_MAG;
        gyros += x.sensor == SP_IMU_GYRO;
        sp_event_release(&ev);
    }
    CHECK(same);
    CHECK(differs);
    CHECK_EQ_INT(mags, (gyros + 3) / 4); /* one every 4 ticks, from the first */
    CHECK(strcmp(sp_source_name(src), "fake-imu") == 0);
    sp_source_close(&src);
    sp_fake_imu_close(&a);
    sp_fake_imu_close(&c);
    CHECK(src == NULL);
    /* bad settings are refused, close accepts NULL */
    sp_fake_imu_default_settings(&g);
    g.rate_hz = NAN;
    CHECK(sp_fake_imu_open(&b, &g) == -EINVAL && b == NULL);
    sp_fake_imu_default_settings(&g);
    g.turn_duration_s = 0; /* a 360 deg turn in no time */
    CHECK(sp_fake_imu_open(&b, &g) == -EINVAL);
    CHECK(sp_fake_imu_truth(&g, 0, NULL, NULL) == -EINVAL);
    CHECK(sp_fake_imu_open(NULL, &g) == -EINVAL);
    sp_fake_imu_close(&b);
    sp_fake_imu_close(NULL);
}

/* ---- the filter ---- */

static void test_turn(void)
{
    sp_fake_imu_settings g;
    sp_orientation_settings fs;
    run_opts opt = { 0 };
    run_result r = { 0 };
    sp_fake_imu_default_settings(&g);
    sp_orientation_default_settings(&fs);
    run(&g, &fs, &opt, &r);
    report("360 deg in 10 s", &r);
    CHECK_MSG(r.max_err_deg < 1.0, "max error %.3f deg", r.max_err_deg);
    CHECK_MSG(r.final_err_deg < 1.0, "final error %.3f deg", r.final_err_deg);
    CHECK(r.frames >= expected_frames(&g) - 2);
    CHECK_EQ_INT(r.nonfinite, 0);
    CHECK_EQ_INT(r.nodata, 0);
    CHECK(r.stats.initialized && !r.stats.using_magnetometer && r.stats.bias_from_still);
    CHECK(r.stats.still_periods >= 2); /* before and after the turn */
    CHECK_EQ_INT(r.stats.gaps + r.stats.saturated + r.stats.dropped_duplicate + r.stats.dropped_invalid, 0);
    CHECK_EQ_INT(r.stats.samples_used, r.pushed);
    /* the bias estimate: its part about the vertical (unobservable otherwise) matters most */
    sp_vec3 db = sp_vec3_sub(r.stats.gyro_bias, g.gyro_bias);
    sp_quat q0;
    sp_fake_imu_truth(&g, g.start_ns, &q0, NULL);
    double db_yaw = sp_vec3_dot(db, sp_quat_rotate(sp_quat_conj(q0), (sp_vec3){ 0, 0, 1 }));
    printf("bias error %.4f deg/s, about the vertical %.4f deg/s\n", sp_vec3_norm(db) / DEG, db_yaw / DEG);
    CHECK(fabs(db_yaw) < 0.02 * DEG);
    CHECK(sp_vec3_norm(db) < 0.15 * DEG);

    /* several turns, the other way, phone pitched down, more sway */
    g.turn_deg = -720;
    g.pitch_deg = 20;
    g.wobble_deg = 1.0;
    g.seed = 7;
    run(&g, &fs, &opt, &r);
    report("-720 deg in 10 s", &r);
    CHECK_MSG(r.max_err_deg < 1.0, "max error %.3f deg", r.max_err_deg);
    CHECK_EQ_INT(r.nonfinite, 0);

    /* a longer or shorter arm than the filter assumes (0.6 m) */
    sp_fake_imu_default_settings(&g);
    g.arm_radius_m = 0.4;
    run(&g, &fs, &opt, &r);
    report("360 deg, 0.4 m arm", &r);
    CHECK_MSG(r.max_err_deg < 1.0, "max error %.3f deg", r.max_err_deg);
    g.arm_radius_m = 0.8;
    run(&g, &fs, &opt, &r);
    report("360 deg, 0.8 m arm", &r);
    CHECK_MSG(r.max_err_deg < 1.0, "max error %.3f deg", r.max_err_deg);

    /* the turn compensation is what keeps centripetal force out of the tilt */
    g.arm_radius_m = 0.6;
    run(&g, &fs, &opt, &r);
    fs.turn_radius_m = 0;
    run_result r0 = { 0 };
    run(&g, &fs, &opt, &r0);
    report("360 deg, no turn correction", &r0);
    CHECK(r0.max_err_deg > r.max_err_deg);
}

static void test_zero_motion(void)
{
    sp_fake_imu_settings g;
    sp_orientation_settings fs;
    run_opts opt = { 0 };
    run_result r = { 0 };
    sp_fake_imu_default_settings(&g);
    g.turn_deg = 0;
    g.wobble_deg = 0;
    sp_orientation_default_settings(&fs);
    run(&g, &fs, &opt, &r);
    report("no motion", &r);
    /* what remains is the accelerometer bias's tilt (0.17 deg) and frame 0's single-sample attitude */
    CHECK_MSG(r.max_err_deg < 0.5, "max error %.3f deg", r.max_err_deg);
    CHECK_MSG(r.final_err_deg < 0.25, "final error %.3f deg", r.final_err_deg);
    CHECK(r.frames >= expected_frames(&g) - 2);
    CHECK_EQ_INT(r.stats.still_periods, 1); /* one long still period */
    CHECK(sp_vec3_norm(sp_vec3_sub(r.stats.gyro_bias, g.gyro_bias)) < 0.02 * DEG);
}

static void test_magnetometer(void)
{
    sp_fake_imu_settings g;
    sp_orientation_settings fs;
    run_opts opt = { .absolute = 1 };
    run_result r = { 0 };
    sp_fake_imu_default_settings(&g);
    sp_orientation_default_settings(&fs);
    g.magnetometer = 1;
    g.heading_deg = 37;
    run(&g, &fs, &opt, &r);
    report("magnetometer, absolute", &r);
    CHECK(r.stats.using_magnetometer);
    CHECK_MSG(r.max_err_deg < 1.5, "max error %.3f deg", r.max_err_deg);
    CHECK_MSG(r.final_err_deg < 1.0, "final error %.3f deg", r.final_err_deg);

    /* present but switched off: heading falls back to the first still period */
    fs.use_magnetometer = SP_ORIENTATION_MAG_OFF;
    run(&g, &fs, &opt, &r);
    CHECK(!r.stats.using_magnetometer);
    CHECK(r.max_err_deg > 30); /* absolute comparison now fails by the 37 deg heading */

    /* no still period to estimate the bias: only the magnetometer can hold the heading */
    sp_orientation_default_settings(&fs);
    g.still_before_s = 0;
    g.gyro_bias = (sp_vec3){ 0.0, 1.0 * DEG, 0.0 }; /* mostly about the vertical */
    run_result rm = { 0 }, rn = { 0 };
    run(&g, &fs, &opt, &rm);
    g.magnetometer = 0;
    opt.absolute = 0;
    run(&g, &fs, &opt, &rn);
    report("no still, magnetometer", &rm);
    report("no still, no magnetometer", &rn);
    CHECK_MSG(rm.final_err_deg < 2.0, "final %.3f", rm.final_err_deg);
    CHECK(rn.final_err_deg > 2.0 * rm.final_err_deg);
    CHECK_EQ_INT(rm.nonfinite + rn.nonfinite, 0);
}

static void test_saturation(void)
{
    sp_fake_imu_settings g;
    sp_orientation_settings fs;
    run_opts opt = { 0 };
    run_result r = { .split_s = 5.0 };
    sp_fake_imu_default_settings(&g);
    sp_orientation_default_settings(&fs);
    g.flick_at_s = 5.0; /* mid-turn, 3000 deg/s peak against a 2000 deg/s range */
    run(&g, &fs, &opt, &r);
    report("saturating flick", &r);
    CHECK(r.stats.saturated > 5);
    CHECK_EQ_INT(r.nonfinite, 0);
    CHECK(r.frames >= expected_frames(&g) - 2);
    CHECK_MSG(r.max_err_before_deg < 1.0, "before %.3f", r.max_err_before_deg);
    /* what clipping lost about the vertical is unobservable: bounded, not fixed; tilt recovers */
    CHECK_MSG(r.final_err_deg < 5.0, "final %.3f", r.final_err_deg);
    CHECK(r.stats.bias_from_still);
    /* the magnetometer observes heading: it pulls the clipped yaw back */
    g.magnetometer = 1;
    opt.absolute = 1;
    run_result rm = { .split_s = 5.0 };
    run(&g, &fs, &opt, &rm);
    report("saturating flick, magnetometer", &rm);
    CHECK(rm.stats.saturated > 5);
    CHECK_MSG(rm.final_err_deg < 1.0, "final %.3f", rm.final_err_deg);
    CHECK(rm.final_err_deg < r.final_err_deg);
}

static void test_gaps(void)
{
    sp_fake_imu_settings g;
    sp_orientation_settings fs;
    run_opts opt = { 0 };
    run_result r = { 0 };
    sp_fake_imu_default_settings(&g);
    sp_orientation_default_settings(&fs);
    g.gap_at_s = 5.0; /* 200 ms mid-turn: integrated across */
    run(&g, &fs, &opt, &r);
    report("200 ms gap mid-turn", &r);
    CHECK_EQ_INT(r.stats.gaps, 1);
    CHECK_EQ_INT(r.stats.long_gaps, 0);
    CHECK_EQ_INT(r.nodata, 0);
    CHECK_MSG(r.max_err_deg < 1.0, "max %.3f", r.max_err_deg);
    CHECK(r.frames >= expected_frames(&g) - 2);

    g.gap_at_s = 11.2; /* 600 ms while still afterwards: not integrated, frames inside have no data */
    g.gap_s = 0.6;
    run(&g, &fs, &opt, &r);
    report("600 ms gap when still", &r);
    CHECK_EQ_INT(r.stats.long_gaps, 1);
    CHECK(r.nodata >= 15 && r.nodata <= 19);
    CHECK_MSG(r.max_err_deg < 1.0, "max %.3f", r.max_err_deg);
    CHECK_EQ_INT(r.nonfinite, 0);
}

static void test_duplicates_and_order(void)
{
    sp_fake_imu_settings g;
    sp_orientation_settings fs;
    run_opts opt = { .nan_every = 97 };
    run_result r = { 0 };
    sp_fake_imu_default_settings(&g);
    sp_orientation_default_settings(&fs);
    g.duplicate_every = 7;
    g.swap_every = 11;
    run(&g, &fs, &opt, &r);
    report("duplicates, swaps, NaN", &r);
    CHECK(r.stats.dropped_duplicate > 300);
    CHECK(r.stats.dropped_out_of_order > 300);
    CHECK_EQ_INT(r.stats.dropped_invalid, r.pushed / 97);
    CHECK_EQ_INT(r.stats.samples_used + r.stats.dropped_duplicate + r.stats.dropped_out_of_order, r.pushed);
    CHECK_EQ_INT(r.rejected, r.stats.dropped_duplicate + r.stats.dropped_out_of_order);
    CHECK_MSG(r.max_err_deg < 1.0, "max %.3f", r.max_err_deg);
    CHECK_EQ_INT(r.nonfinite, 0);
}

/* Pushes a still device's gyro + accel at t (rate 0 + bias, gravity along IMU z). */
static void push_still(sp_orientation *o, int64_t t)
{
    sp_imu_sample gy = { .timestamp_ns = t, .sensor = SP_IMU_GYRO, .v = { 0.001f, -0.002f, 0.0005f } };
    sp_imu_sample ac = { .timestamp_ns = t, .sensor = SP_IMU_ACCEL, .v = { 0.0f, 0.0f, 9.80665f } };
    CHECK_EQ_INT(sp_orientation_push(o, &gy), 0);
    CHECK_EQ_INT(sp_orientation_push(o, &ac), 0);
}

static int finite_quat(sp_quat q) { return isfinite(q.w) && isfinite(q.x) && isfinite(q.y) && isfinite(q.z); }

static void test_invalid_and_huge_dt(void)
{
    sp_orientation_settings fs;
    sp_orientation_default_settings(&fs);
    sp_orientation *o = NULL;
    CHECK_EQ_INT(sp_orientation_open(&o, &fs), 0);
    if (!o)
        return;
    sp_quat q;
    CHECK(sp_orientation_camera_at(o, 0, &q) == -EAGAIN); /* nothing yet */
    sp_imu_sample bad = { .timestamp_ns = 5, .sensor = SP_IMU_GYRO, .v = { NAN, 0, 0 } };
    CHECK(sp_orientation_push(o, &bad) == SP_ENODATA);
    bad.sensor = SP_IMU_ACCEL;
    bad.v[0] = INFINITY;
    CHECK(sp_orientation_push(o, &bad) == SP_ENODATA);
    bad.sensor = 42;
    bad.v[0] = 1;
    CHECK(sp_orientation_push(o, &bad) == SP_ENODATA);
    CHECK(sp_orientation_push(o, NULL) == -EINVAL);
    CHECK(sp_orientation_push(NULL, &bad) == -EINVAL);

    const int64_t dt = 5000000, t0 = 1000000000;
    int64_t t = t0;
    for (int i = 0; i < 400; i++, t += dt) /* 2 s still */
        push_still(o, t);
    sp_orientation_stats st;
    sp_orientation_get_stats(o, &st);
    CHECK_EQ_INT(st.dropped_invalid, 3);
    CHECK(st.initialized);
    CHECK(st.bias_from_still);
    CHECK_NEAR(st.gyro_bias.x, 0.001, 2e-5);
    CHECK_NEAR(st.gyro_bias.y, -0.002, 2e-5);
    CHECK_EQ_INT(sp_orientation_camera_at(o, t - dt, &q), 0);
    sp_quat before = q;
    /* tilt is gravity's: camera z (= IMU z here) points up */
    CHECK_NEAR(sp_quat_rotate(q, (sp_vec3){ 0, 0, 1 }).z, 1.0, 1e-6);

    /* an hour without samples: held, not integrated, and the gap itself has no data */
    int64_t t_gap = t - dt, t_after = t_gap + 3600LL * 1000000000LL;
    for (int i = 0; i < 100; i++)
        push_still(o, t_after + i * dt);
    sp_orientation_get_stats(o, &st);
    CHECK_EQ_INT(st.long_gaps, 1);
    CHECK(sp_orientation_camera_at(o, t_gap + 1800LL * 1000000000LL, &q) == SP_ENODATA);
    CHECK_EQ_INT(sp_orientation_camera_at(o, t_after + 50 * dt, &q), 0);
    CHECK(finite_quat(q));
    CHECK(sp_quat_angle_between(q, before) < 0.05 * DEG);

    /* timestamps at the ends of int64: no overflow, no NaN */
    sp_imu_sample far = { .timestamp_ns = INT64_MAX - 1, .sensor = SP_IMU_GYRO, .v = { 1e30f, -1e30f, 0 } };
    CHECK_EQ_INT(sp_orientation_push(o, &far), 0); /* finite, clipped at the range: saturated */
    far.sensor = SP_IMU_ACCEL;
    far.v[0] = 0;
    far.v[1] = 0;
    far.v[2] = 9.8f;
    CHECK_EQ_INT(sp_orientation_push(o, &far), 0);
    far.sensor = SP_IMU_GYRO;
    far.timestamp_ns = INT64_MAX;
    far.v[0] = far.v[1] = 0;
    CHECK_EQ_INT(sp_orientation_push(o, &far), 0);
    CHECK_EQ_INT(sp_orientation_camera_at(o, INT64_MAX, &q), 0);
    CHECK(finite_quat(q));
    CHECK(sp_orientation_camera_at(o, INT64_MIN, &q) == SP_ENODATA);
    sp_orientation_get_stats(o, &st);
    CHECK_EQ_INT(st.long_gaps, 2);
    CHECK(st.saturated >= 1);
    CHECK(isfinite(st.gyro_bias.x) && isfinite(st.gyro_bias.y) && isfinite(st.gyro_bias.z));
    sp_orientation_close(&o);
    CHECK(o == NULL);
    sp_orientation_close(&o);

    /* bad settings */
    sp_orientation_default_settings(&fs);
    fs.kp = NAN;
    CHECK(sp_orientation_open(&o, &fs) == -EINVAL && o == NULL);
    sp_orientation_default_settings(&fs);
    fs.history_len = 1;
    CHECK(sp_orientation_open(&o, &fs) == -EINVAL);
    sp_orientation_default_settings(&fs);
    fs.max_gap_s = fs.gap_s / 2;
    CHECK(sp_orientation_open(&o, &fs) == -EINVAL);
    sp_orientation_default_settings(&fs);
    fs.imu_to_camera = (sp_quat){ 0, 0, 0, 0 };
    CHECK(sp_orientation_open(&o, &fs) == -EINVAL);
    CHECK(sp_orientation_open(NULL, &fs) == -EINVAL);
}

static void test_exact_samples_and_history(void)
{
    sp_fake_imu_settings g;
    sp_orientation_settings fs;
    sp_fake_imu_default_settings(&g);
    sp_orientation_default_settings(&fs);
    fs.history_len = 64; /* bounded: about 0.3 s at 200 Hz */
    g.still_after_s = 0;
    g.turn_duration_s = 3;
    g.turn_deg = 180;
    sp_fake_imu *imu = NULL;
    sp_orientation *o = NULL;
    CHECK_EQ_INT(sp_fake_imu_open(&imu, &g), 0);
    CHECK_EQ_INT(sp_orientation_open(&o, &fs), 0);
    sp_imu_sample smp;
    int64_t last_gyro = 0, prev_gyro = 0;
    while (imu && o && sp_fake_imu_next(imu, &smp) == 0) {
        sp_orientation_push(o, &smp);
        if (smp.sensor == SP_IMU_GYRO) {
            prev_gyro = last_gyro;
            last_gyro = smp.timestamp_ns;
        }
    }
    if (!o)
        goto done;
    sp_quat qa, qb, qm, qa2, qn;
    /* exactly on the newest sample, and 1 ns later (not there yet) */
    CHECK_EQ_INT(sp_orientation_imu_at(o, last_gyro, &qb), 0);
    CHECK(sp_orientation_imu_at(o, last_gyro + 1, &qn) == -EAGAIN);
    CHECK_EQ_INT(sp_orientation_imu_at(o, prev_gyro, &qa), 0);
    CHECK_EQ_INT(sp_orientation_imu_at(o, prev_gyro, &qa2), 0);
    CHECK(memcmp(&qa, &qa2, sizeof(qa)) == 0);
    CHECK(sp_quat_angle_between(qa, qb) > 0); /* still turning: distinct states */
    /* halfway is the slerp of the two; 1 ns after a sample is next to it */
    CHECK_EQ_INT(sp_orientation_imu_at(o, prev_gyro + (last_gyro - prev_gyro) / 2, &qm), 0);
    CHECK(sp_quat_angle_between(qm, sp_quat_slerp(qa, qb, 0.5)) < 1e-9);
    CHECK_EQ_INT(sp_orientation_imu_at(o, prev_gyro + 1, &qn), 0);
    CHECK(sp_quat_angle_between(qn, qa) < sp_quat_angle_between(qa, qb) * 1e-5);
    /* older than the bounded history */
    int64_t oldest = last_gyro - 63 * 5000000LL;
    CHECK_EQ_INT(sp_orientation_imu_at(o, oldest, &qn), 0);
    CHECK(sp_orientation_imu_at(o, oldest - 1, &qn) == SP_ENODATA);
    CHECK(sp_orientation_imu_at(o, g.start_ns, &qn) == SP_ENODATA);
    /* the camera query is the IMU query rotated by imu_to_camera (identity here) */
    CHECK_EQ_INT(sp_orientation_camera_at(o, last_gyro, &qn), 0);
    CHECK(sp_quat_angle_between(qn, qb) < 1e-12);
done:
    sp_orientation_close(&o);
    sp_fake_imu_close(&imu);
}

static void test_offset_and_rotation(void)
{
    sp_fake_imu_settings g;
    sp_orientation_settings fs;
    run_opts opt = { .offset_s = 0.04 };
    run_result r = { 0 }, wrong_rot = { 0 }, wrong_off = { 0 };
    sp_fake_imu_default_settings(&g);
    sp_orientation_default_settings(&fs);
    g.imu_to_camera = sp_quat_from_axis_angle((sp_vec3){ 1, 2, 3 }, 70 * DEG);
    fs.imu_to_camera = g.imu_to_camera;
    fs.time_offset_s = opt.offset_s;
    run(&g, &fs, &opt, &r);
    report("camera-IMU rotation+offset", &r);
    CHECK_MSG(r.max_err_deg < 1.0, "max %.3f", r.max_err_deg);
    CHECK(r.frames >= expected_frames(&g) - 4);

    fs.imu_to_camera = sp_quat_identity();
    run(&g, &fs, &opt, &wrong_rot);
    fs.imu_to_camera = g.imu_to_camera;
    fs.time_offset_s = 0;
    run(&g, &fs, &opt, &wrong_off);
    report("  wrong rotation", &wrong_rot);
    report("  wrong offset", &wrong_off);
    CHECK(wrong_rot.max_err_deg > 10.0);
    CHECK(wrong_off.max_err_deg > 2.0); /* 40 ms at ~67 deg/s */

    /* the phone front camera's usual axes: 180 deg about z */
    g.imu_to_camera = fs.imu_to_camera = (sp_quat){ 0, 0, 0, 1 };
    run(&g, &fs, &opt, &wrong_off);
    CHECK_MSG(wrong_off.max_err_deg > 2.0, "still wrong offset %.3f", wrong_off.max_err_deg);
    fs.time_offset_s = opt.offset_s;
    run(&g, &fs, &opt, &r);
    report("front camera axes", &r);
    CHECK_MSG(r.max_err_deg < 1.0, "max %.3f", r.max_err_deg);
}

int main(void)
{
    test_generator();
    test_generator_api();
    test_turn();
    test_zero_motion();
    test_magnetometer();
    test_saturation();
    test_gaps();
    test_duplicates_and_order();
    test_invalid_and_huge_dt();
    test_exact_samples_and_history();
    test_offset_and_rotation();
    return check_exit();
}
