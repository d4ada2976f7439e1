/* SPDX-License-Identifier: MIT */
/*
 * IMU orientation filter: fuses gyro, accelerometer and (optionally) magnetometer
 * samples into the device orientation (a Mahony complementary filter with gyro
 * bias from still periods), keeps a bounded history of states and answers "where
 * was the camera looking at frame time t" by interpolating that history.
 *
 * World frame: z up (gravity along -z). Heading: with a magnetometer world +x is
 * magnetic north (horizontal part of the field); without one, world +x is the
 * horizontal direction of the camera's forward axis when the filter initialises
 * (the end of the first still window, see capture/ORIENTATION.md).
 * Camera axes: x right, y down, z forward. Quaternions rotate body vectors into world.
 */
#ifndef SUNPROBE_SP_ORIENTATION_H
#define SUNPROBE_SP_ORIENTATION_H

#include <stddef.h>
#include <stdint.h>

#include "sp_common.h"
#include "sp_imu.h"
#include "sp_math.h"

#ifdef __cplusplus
extern "C" {
#endif

enum sp_orientation_mag {
    SP_ORIENTATION_MAG_AUTO = 0, /* use it if magnetometer samples arrive before initialisation */
    SP_ORIENTATION_MAG_OFF = 1,
    SP_ORIENTATION_MAG_ON = 2,   /* as AUTO, but warns when none arrived */
};

typedef struct sp_orientation_settings {
    /* Mahony gains */
    double kp;               /* 1/s, accelerometer pull on tilt when steady; default 1.0 */
    double ki;               /* 1/s^2, online gyro-bias (integral) gain; default 0.02 */
    double kp_fast;          /* 1/s, before initialisation and while recovering; default 3.0 */
    double kp_mag;           /* 1/s, magnetometer pull on heading; default 1.0 */
    double recover_s;        /* fast gain after a long gap or saturated gyro; default 1.0 */
    double motion_rate_dps;  /* accel weight halves at this body rate; default 20 */
    double accel_gate;       /* accel weight falls to 0 when | |a|/g - 1 | reaches this; default 0.1 */
    double turn_radius_m;    /* camera distance to the vertical turning axis in front of it, for the
                                centripetal/tangential correction; 0 = off; default 0.6 */
    /* still detection and bias */
    double still_window_s;     /* default 0.25 */
    double still_yaw_std_dps;  /* max std of rate about gravity in a window; default 0.6 */
    double still_tilt_std_dps; /* max std of rate about horizontal axes (hand sway); default 10 */
    double still_rate_dps;     /* max |mean rate| about gravity after bias removal; default 0.5
                                  (before any bias is known, 10 times this) */
    double still_accel_std;    /* m/s^2, max accel std in a window; default 0.3 */
    uint32_t still_guard_windows; /* windows ignored at both ends of a still period, so a slow
                                     start or end of motion is not taken for bias; default 2 */
    int update_bias_when_still; /* later still periods (>= 1 s) replace the bias; default 1 */
    double init_timeout_s;   /* initialise without a still period after this; default 3.0 */
    /* sensors and timing */
    enum sp_orientation_mag use_magnetometer; /* default AUTO */
    sp_quat imu_to_camera;   /* rotates IMU-axis vectors into camera axes; default identity */
    double time_offset_s;    /* camera time = IMU time + offset; default 0 */
    double gap_s;            /* gyro spacing above this counts as a gap; default 0.05 */
    double max_gap_s;        /* gaps longer than this are not integrated (history breaks); 0.5 */
    double gyro_range;       /* rad/s; readings at the range count as saturated; default 2000 deg/s */
    double accel_max_age_s;  /* accel older than this is not used for a gyro step; default 0.05 */
    size_t history_len;      /* states kept (one per gyro sample); default 2048 */
    double gravity;          /* m/s^2; default 9.80665 */
} sp_orientation_settings;

typedef struct sp_orientation_stats {
    uint64_t samples_used;
    uint64_t dropped_duplicate;    /* same timestamp as the previous sample of that sensor */
    uint64_t dropped_out_of_order; /* older than the previous sample of that sensor */
    uint64_t dropped_invalid;      /* non-finite values or unknown sensor */
    uint64_t gaps;                 /* gyro spacing > gap_s (long ones included) */
    uint64_t long_gaps;            /* > max_gap_s: not integrated, history broken */
    uint64_t saturated;            /* gyro samples at the range */
    uint64_t still_periods;        /* still periods that contributed to the bias */
    sp_vec3 gyro_bias;             /* current estimate, rad/s, IMU axes */
    int bias_from_still;           /* the estimate came from a still period */
    int initialized;               /* heading anchored; camera_at answers */
    int using_magnetometer;
    int64_t initialized_at_ns;     /* IMU time of initialisation */
} sp_orientation_stats;

typedef struct sp_orientation sp_orientation;

SP_API void sp_orientation_default_settings(sp_orientation_settings *s);

/* s is copied; memory is fixed at open (history_len states). The caller owns *out. */
SP_API int sp_orientation_open(sp_orientation **out, const sp_orientation_settings *s);
SP_API void sp_orientation_close(sp_orientation **o);

/*
 * Feeds one sample (borrowed for the call), in timestamp order per sensor with
 * sensors interleaved. Returns 0 when used, SP_ENODATA when it was counted and
 * dropped (duplicate, out of order, non-finite, unknown sensor; not fatal),
 * -EINVAL for NULL arguments.
 */
SP_API int sp_orientation_push(sp_orientation *o, const sp_imu_sample *sample);

/*
 * Camera orientation at a frame timestamp (camera clock): slerp between the
 * history states bracketing (t - time_offset). 0 on success; -EAGAIN when the
 * IMU has not reached that time yet or the filter is not initialised; SP_ENODATA
 * when it is older than the history or inside a long gap.
 */
SP_API int sp_orientation_camera_at(sp_orientation *o, int64_t frame_timestamp_ns, sp_quat *camera_to_world);

/* Same for the IMU body at an IMU-clock time. */
SP_API int sp_orientation_imu_at(sp_orientation *o, int64_t imu_timestamp_ns, sp_quat *imu_to_world);

/* Copies the counters and estimates into *out (caller's storage). */
SP_API int sp_orientation_get_stats(const sp_orientation *o, sp_orientation_stats *out);

#ifdef __cplusplus
}
#endif
#endif
