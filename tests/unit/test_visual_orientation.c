/* SPDX-License-Identifier: MIT */
/*
 * Camera orientation from the video alone (capture/visual_orientation.h): a
 * camera turning once about the vertical, with a little pitch and roll, in
 * front of a blocky world at infinity, with a textured patch fixed to the
 * camera (the person), once at infinity and once on a sphere of 5 m about the
 * turning axis (parallax against the arm's half metre). The orientations must
 * match the truth within a fraction of a degree after the one aligning
 * rotation, the loop must close and world up must come from the turn. A short
 * turn with the phone held up takes world up from an accelerometer when given
 * one, and is 15 degrees off without. A flat sky is refused, not guessed; bad
 * settings, frames and gravity samples are refused.
 */
#include "capture/visual_orientation.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../common/check.h"
#include "common/module.h" /* SP_EMODULE */
#include "sunprobe/sp_common.h"

#define W 240
#define H 180
#define FX 200.0
#define FRAMES 100
#define DEG (M_PI / 180.0)

static uint32_t hash2(int32_t a, int32_t b)
{
    uint32_t h = (uint32_t)a * 0x9e3779b1u ^ (uint32_t)b * 0x85ebca77u;
    h ^= h >> 15, h *= 0x2c1b3c6du, h ^= h >> 12;
    return h;
}

/* The world at infinity: 3 x 3 degree blocks of random grey, brighter towards the zenith. */
static double world(const double d[3])
{
    double az = atan2(d[1], d[0]) / DEG, el = asin(fmax(-1.0, fmin(1.0, d[2]))) / DEG;
    double cell = (double)(hash2((int32_t)floor(az / 3.0), (int32_t)floor(el / 3.0)) & 255u);
    return 40.0 + 0.6 * cell + 0.3 * el;
}

static double held_pitch_deg; /* the phone tilted up by this much throughout (the short turn's test) */

/* Camera-to-world of frame i: one turn about +z, pitch and roll wobbling by a few degrees. */
static sp_quat true_camera(int i)
{
    double yaw = 360.0 * i / (FRAMES - 4) * DEG, pitch = (held_pitch_deg + 4.0 * sin(0.21 * i)) * DEG;
    double roll = 2.0 * sin(0.13 * i) * DEG;
    /* an upright camera looking along +x: x right = -y world, y down = -z world, z forward = +x world */
    double m[9] = { 0, 0, 1, -1, 0, 0, 0, -1, 0 };
    sp_quat base = sp_quat_from_matrix(m);
    sp_quat q = sp_quat_mul(sp_quat_from_axis_angle((sp_vec3){ 0, 0, 1 }, yaw), base);
    q = sp_quat_mul(q, sp_quat_from_axis_angle((sp_vec3){ 1, 0, 0 }, pitch)); /* about the camera's own axes */
    return sp_quat_mul(q, sp_quat_from_axis_angle((sp_vec3){ 0, 0, 1 }, roll));
}

/*
 * Frame i in grey: the world through the camera (2 x 2 samples per pixel), the person patch on top.
 * distance 0: the world at infinity; else on a sphere of that radius about the turning axis, the camera
 * half a metre from the axis looking at it (a selfie at arm's length): parallax.
 */
static void render(sp_frame *f, uint8_t *px, int i, int flat, double distance)
{
    sp_quat q = true_camera(i);
    sp_vec3 fwd = sp_quat_rotate(q, (sp_vec3){ 0, 0, 1 });
    sp_vec3 cam = sp_vec3_scale(sp_vec3_normalize((sp_vec3){ fwd.x, fwd.y, 0 }), -0.5);
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            double acc = 0;
            for (int s = 0; s < 4; s++) {
                sp_vec3 c = { (x + 0.25 + 0.5 * (s & 1) - 0.5 * (W - 1)) / FX,
                              (y + 0.25 + 0.5 * (s >> 1) - 0.5 * (H - 1)) / FX, 1.0 };
                sp_vec3 d = sp_vec3_normalize(sp_quat_rotate(q, c));
                if (distance > 0) { /* where the ray meets the sphere, seen from the axis */
                    double b = sp_vec3_dot(cam, d);
                    double t = -b + sqrt(b * b - sp_vec3_dot(cam, cam) + distance * distance);
                    d = sp_vec3_normalize(sp_vec3_add(cam, sp_vec3_scale(d, t)));
                }
                double dd[3] = { d.x, d.y, d.z };
                acc += flat ? 120.0 + 60.0 * d.z : world(dd);
            }
            double v = acc / 4 + (double)(hash2(x + 1000 * i, y) % 5) - 2.0; /* sensor noise */
            if (!flat && x > W / 3 && x < 2 * W / 3 && y > H / 2) /* the person: textured, moves with the camera */
                v = (double)(hash2(x / 6, y / 6) & 127u) + 60.0;
            px[(size_t)y * W + x] = (uint8_t)fmax(0.0, fmin(255.0, v));
        }
    memset(f, 0, sizeof(*f));
    f->format = SP_PIXFMT_GRAY8;
    f->width = W, f->height = H, f->stride = W;
    f->data = px, f->capacity = f->bytes_used = (size_t)W * H;
    f->sequence = (uint64_t)i;
}

/* The worst angle between the estimated and the true up over the first n frames. */
static double worst_tilt(const sp_vo *v, int n)
{
    double tilt = 0;
    for (int i = 0; i < n; i++) {
        sp_quat est;
        sp_vo_camera(v, (size_t)i, &est, NULL);
        sp_vec3 u0 = sp_quat_rotate(sp_quat_conj(est), (sp_vec3){ 0, 0, 1 });
        sp_vec3 u1 = sp_quat_rotate(sp_quat_conj(true_camera(i)), (sp_vec3){ 0, 0, 1 });
        tilt = fmax(tilt, acos(fmin(1.0, sp_vec3_dot(u0, u1))) / DEG);
    }
    return tilt;
}

static void test_turn(double distance, double max_worst)
{
    sp_vo_settings s = { W, H, FX, FX, 0.5 * (W - 1), 0.5 * (H - 1) };
    sp_vo *v = NULL;
    CHECK_EQ_INT(sp_vo_open(&v, &s), 0);
    static uint8_t px[W * H];
    sp_frame f;
    for (int i = 0; i < FRAMES; i++) {
        render(&f, px, i, 0, distance);
        int ret = sp_vo_push(v, &f, NULL);
        if (ret == SP_EMODULE) {
            sp_vo_close(&v);
            printf("SKIP: no OpenCV in this build\n");
            exit(77);
        }
        CHECK_EQ_INT(ret, 0);
    }
    sp_vo_result r;
    CHECK_EQ_INT(sp_vo_finish(v, &r), 0);
    CHECK(r.loop_closed);
    CHECK(r.up_from_turn);
    CHECK(r.coasted == 0);
    /* 100 frames of 3.75 deg, plus the wobble; a near world's comes up short by ~360 x 0.5 / distance */
    CHECK(fabs(r.turn_deg + (distance > 0 ? 360 * 0.5 / distance : 0) - 375.0) < 20.0);
    sp_quat_mean m;
    sp_quat_mean_init(&m);
    for (int i = 0; i < FRAMES; i++) {
        sp_quat est;
        CHECK_EQ_INT(sp_vo_camera(v, (size_t)i, &est, NULL), 0);
        sp_quat_mean_add(&m, sp_quat_mul(true_camera(i), sp_quat_conj(est)));
    }
    sp_quat align = sp_quat_mean_get(&m);
    double worst = 0, tilt = worst_tilt(v, FRAMES);
    for (int i = 0; i < FRAMES; i++) {
        sp_quat est;
        sp_vo_camera(v, (size_t)i, &est, NULL);
        worst = fmax(worst, sp_quat_angle_between(sp_quat_mul(align, est), true_camera(i)) / DEG);
    }
    printf("world at %g m: turn %.1f deg, loop at frame %llu (%.2f deg of drift), worst error %.3f deg, worst tilt "
           "%.3f deg\n",
           distance, r.turn_deg, (unsigned long long)r.loop_frame, r.loop_correction_deg, worst, tilt);
    CHECK(worst < max_worst);
    CHECK(tilt < 1.5); /* world up is the turn's axis, which this wobble's rates bias (0.84 deg measured) */
    sp_quat q;
    CHECK_EQ_INT(sp_vo_camera(v, FRAMES, &q, NULL), -ERANGE);
    sp_vo_close(&v);
}

/*
 * A 50-degree turn with the phone held 15 degrees up: too short to give its axis, so without an
 * accelerometer world up is the first frame's and 15 degrees off; with one (its up in camera axes, plus
 * half a metre per second squared of arm motion) it is gravity's. Bad gravity samples are refused.
 */
static void test_gravity(void)
{
    enum { N = 14 };
    held_pitch_deg = 15;
    for (int with_gravity = 0; with_gravity < 2; with_gravity++) {
        sp_vo_settings s = { W, H, FX, FX, 0.5 * (W - 1), 0.5 * (H - 1) };
        sp_vo *v = NULL;
        CHECK_EQ_INT(sp_vo_open(&v, &s), 0);
        CHECK_EQ_INT(sp_vo_gravity(v, (sp_vec3){ 0, -9.8, 0 }), -EINVAL); /* before a frame */
        static uint8_t px[W * H];
        sp_frame f;
        for (int i = 0; i < N; i++) {
            render(&f, px, i, 0, 0);
            CHECK_EQ_INT(sp_vo_push(v, &f, NULL), 0);
            sp_vec3 up = sp_vec3_scale(sp_quat_rotate(sp_quat_conj(true_camera(i)), (sp_vec3){ 0, 0, 1 }), 9.81);
            sp_vec3 arm = { 0.5 * sin(1.3 * i), 0.5 * cos(0.7 * i), 0.5 * sin(2.1 * i) };
            if (with_gravity)
                CHECK_EQ_INT(sp_vo_gravity(v, sp_vec3_add(up, arm)), 0);
        }
        CHECK_EQ_INT(sp_vo_gravity(v, (sp_vec3){ 0, 0.5, 0 }), -EINVAL); /* not gravity */
        CHECK_EQ_INT(sp_vo_gravity(v, (sp_vec3){ NAN, 9.8, 0 }), -EINVAL);
        sp_vo_result r;
        CHECK_EQ_INT(sp_vo_finish(v, &r), 0);
        double tilt = worst_tilt(v, N);
        printf("a %.0f-deg turn held %.0f deg up, %s: worst tilt %.2f deg\n", r.turn_deg, held_pitch_deg,
               with_gravity ? "with gravity" : "without", tilt);
        CHECK(!r.up_from_turn && r.up_from_gravity == with_gravity && isnan(r.axis_to_gravity_deg));
        CHECK(with_gravity ? tilt < 0.5 : tilt > 10);
        sp_vo_close(&v);
    }
    held_pitch_deg = 0;
}

static void test_flat_sky_refused(void)
{
    sp_vo_settings s = { W, H, FX, FX, 0.5 * (W - 1), 0.5 * (H - 1) };
    sp_vo *v = NULL;
    CHECK_EQ_INT(sp_vo_open(&v, &s), 0);
    static uint8_t px[W * H];
    sp_frame f;
    for (int i = 0; i < 30; i++) {
        render(&f, px, i, 1, 0);
        CHECK_EQ_INT(sp_vo_push(v, &f, NULL), 0);
    }
    sp_vo_result r;
    CHECK_EQ_INT(sp_vo_finish(v, &r), SP_ENODATA);
    CHECK(r.coasted > 20);
    sp_vo_close(&v);
}

static void test_bad_input(void)
{
    sp_vo *v = NULL;
    sp_vo_settings s = { W, H, 0.0, FX, 0.5 * W, 0.5 * H };
    CHECK_EQ_INT(sp_vo_open(&v, &s), -EINVAL);
    s.fx = FX, s.cy = NAN;
    CHECK_EQ_INT(sp_vo_open(&v, &s), -EINVAL);
    s.cy = 0.5 * H, s.width = 8;
    CHECK_EQ_INT(sp_vo_open(&v, &s), -EINVAL);
    s.width = W;
    CHECK_EQ_INT(sp_vo_open(&v, &s), 0);
    static uint8_t px[W * H];
    sp_frame f;
    render(&f, px, 0, 1, 0);
    f.width = W / 2; /* another size */
    CHECK_EQ_INT(sp_vo_push(v, &f, NULL), -EINVAL);
    sp_vo_result r;
    CHECK_EQ_INT(sp_vo_finish(v, &r), SP_ENODATA); /* no frame */
    sp_vo_close(&v);
    sp_vo_close(&v); /* twice is harmless */
}

int main(void)
{
    test_bad_input();
    test_flat_sky_refused();
    test_turn(0, 0.5);
    test_turn(5, 1.5); /* the loop closes over the ~32 deg the chain comes up short; parallax: 1.02 measured */
    test_gravity();
    return check_exit();
}
