/* SPDX-License-Identifier: MIT */
/* Capture metadata (META chunks, JSON) parsed into a plain struct; keys in capture/FORMAT.md. */
#ifndef SUNPROBE_SP_META_H
#define SUNPROBE_SP_META_H

#include <stddef.h>
#include <stdint.h>

#include "sp_common.h"
#include "sp_math.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Unknown numbers are NaN, unknown strings empty. */
typedef struct sp_capture_meta {
    char kind[16];         /* "selfie", "static" or "" */
    char source[128];
    char camera_name[128];
    char camera_driver[64];
    uint32_t width, height;
    double fps;
    double fx, fy, cx, cy; /* pixels */
    double focal_length_mm, sensor_width_mm;
    char transfer[16];     /* camera.transfer, how pixel values encode linear light: "srgb" (what cameras write;
                              assumed when absent) or "sunprobe" (the synthesiser's gamma 2.2 of x / (1 + x)) */
    char imu_name[128];
    double imu_rate_hz;
    sp_quat imu_to_camera; /* identity when not given */
    double imu_time_offset_s;
    sp_vec3 gyro_bias, accel_bias;
    double latitude, longitude, altitude_m;
    double magnetic_declination_deg; /* location.*: true bearing of magnetic north, east positive */
    double start_heading_deg;        /* location.heading_deg: true bearing of the camera's forward axis at the
                                        first frame, for captures whose IMU has no magnetometer */
    char utc_start[40];
    char ground_truth[256];
    unsigned chunks_merged; /* how many META chunks contributed */
} sp_capture_meta;

SP_API void sp_capture_meta_init(sp_capture_meta *meta);
/*
 * Merges one META chunk's JSON into meta (later chunks override earlier keys).
 * SP_ECORRUPT for malformed JSON or a value of the wrong type or NaN-like range
 * (e.g. negative focal length); meta is unchanged then.
 */
SP_API int sp_capture_meta_merge(sp_capture_meta *meta, const char *json, size_t len);
/* Focal length in pixels: fx if known, else from focal_length_mm and sensor_width_mm, else NaN. */
SP_API double sp_capture_meta_focal_px(const sp_capture_meta *meta);

#ifdef __cplusplus
}
#endif
#endif
