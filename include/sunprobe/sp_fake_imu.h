/* SPDX-License-Identifier: MIT */
/*
 * Synthetic IMU of a person turning in place with a phone held at arm's length,
 * the camera looking back at them (a SunStage selfie capture). Deterministic for
 * given settings, with the exact ground truth queryable at any time, plus fault
 * injectors (gyro saturation, gaps, duplicated and out-of-order timestamps) for
 * tests of everything that consumes IMU streams.
 *
 * Frames: world z up (gravity along -z), the person turns about the world z axis
 * through the origin; with the default field the magnetic north is world +x.
 * Camera axes: x right, y down, z forward. imu_to_camera rotates IMU-axis vectors
 * into camera axes, so imu_to_world = camera_to_world * imu_to_camera.
 */
#ifndef SUNPROBE_SP_FAKE_IMU_H
#define SUNPROBE_SP_FAKE_IMU_H

#include <stdint.h>

#include "sp_common.h"
#include "sp_imu.h"
#include "sp_math.h"
#include "sp_source.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sp_fake_imu_settings {
    /* timing: samples at start_ns + k / rate_hz over still_before + turn + still_after */
    double rate_hz;          /* gyro and accel rate; default 200 */
    int64_t start_ns;        /* timestamp of the first sample; default 1e9 */
    double still_before_s;   /* default 1.0 */
    double turn_duration_s;  /* smooth ease-in/out yaw profile; default 10 */
    double turn_deg;         /* total yaw, may be several turns, negative or 0; default 360 */
    double still_after_s;    /* default 1.0 */
    /* pose */
    double heading_deg;      /* initial heading of the camera's forward axis from world +x about +z; 0 */
    double pitch_deg;        /* camera tilted down by this much; default 0 */
    double arm_radius_m;     /* camera distance from the turning axis; default 0.6 */
    double wobble_deg;       /* pitch/roll sway + tremor amplitude about horizontal axes; default 0.5 */
    sp_quat imu_to_camera;   /* default identity (a phone front camera is 180 deg about z: {0,0,0,1}) */
    /* sensor errors (noise densities: per-sample std = density * sqrt(rate_hz)) */
    double gyro_noise;       /* rad/s/sqrt(Hz); default 1.75e-4 (0.01 deg/s/sqrt(Hz)) */
    sp_vec3 gyro_bias;       /* rad/s, IMU axes; default (0.3, -0.5, 0.2) deg/s */
    double gyro_range;       /* rad/s, readings clip here; default 2000 deg/s */
    double accel_noise;      /* m/s^2/sqrt(Hz); default 2e-3 (about 200 ug/sqrt(Hz)) */
    sp_vec3 accel_bias;      /* m/s^2, IMU axes; default (0.02, -0.03, 0.02) */
    int magnetometer;        /* emit magnetometer samples; default 0 */
    sp_vec3 mag_field_ut;    /* world field, microtesla; default (20, 0, -44) */
    double mag_noise_ut;     /* per-sample std, microtesla; default 0.4 */
    uint32_t mag_decimation; /* one mag sample every N ticks; default 4 */
    uint64_t seed;           /* noise and sway phases; default 1 */
    /* injectors, off by default */
    double flick_at_s;       /* a fast out-and-back flick starting at this motion time; < 0 off */
    double flick_duration_s; /* default 0.12 */
    double flick_peak_dps;   /* peak rate of the flick, default 3000 (beyond the 2000 deg/s range) */
    sp_vec3 flick_axis;      /* camera axes; default (0.3, 1, 0.2) */
    double gap_at_s;         /* drop every sample in [gap_at_s, gap_at_s + gap_s); < 0 off */
    double gap_s;            /* default 0.2 */
    uint32_t duplicate_every; /* every Nth tick emits its gyro and accel twice (same timestamp); 0 off */
    uint32_t swap_every;     /* every Nth tick is emitted after the following tick; 0 off */
} sp_fake_imu_settings;

typedef struct sp_fake_imu sp_fake_imu;

SP_API void sp_fake_imu_default_settings(sp_fake_imu_settings *s);

/* Motion time span in seconds (still_before + turn + still_after). */
SP_API double sp_fake_imu_duration_s(const sp_fake_imu_settings *s);

/* s is copied; the caller owns *out and frees it with sp_fake_imu_close. -EINVAL on bad settings. */
SP_API int sp_fake_imu_open(sp_fake_imu **out, const sp_fake_imu_settings *s);
SP_API void sp_fake_imu_close(sp_fake_imu **imu);

/*
 * Next sample into *out (caller's storage): 0, or SP_EOS after the last one.
 * Samples come in timestamp order (gyro, accel, then mag on equal timestamps)
 * unless the duplicate/swap injectors say otherwise.
 */
SP_API int sp_fake_imu_next(sp_fake_imu *imu, sp_imu_sample *out);

/*
 * Exact orientation at t_ns (any time; clamped to the motion's ends). Either
 * output may be NULL. Depends only on the settings, so it can be called
 * without an open generator.
 */
SP_API int sp_fake_imu_truth(const sp_fake_imu_settings *s, int64_t t_ns, sp_quat *imu_to_world,
                             sp_quat *camera_to_world);

/* Exact camera (and IMU) position in world metres at t_ns; the person stands at the origin. */
SP_API int sp_fake_imu_truth_position(const sp_fake_imu_settings *s, int64_t t_ns, sp_vec3 *position);

/* The generator as a stream source of SP_EVENT_IMU events; the caller owns *out (sp_source_close). */
SP_API int sp_fake_imu_source_open(sp_source **out, const sp_fake_imu_settings *s);

#ifdef __cplusplus
}
#endif
#endif
