/* SPDX-License-Identifier: MIT */
/* IMU samples as devices deliver them and captures store them, in SI units. */
#ifndef SUNPROBE_SP_IMU_H
#define SUNPROBE_SP_IMU_H

#include <stdint.h>

#include "sp_common.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Sensor kinds; values are on-disk codes. Axes are the IMU's own body axes. */
enum sp_imu_sensor {
    SP_IMU_GYRO = 1,  /* angular rate, rad/s */
    SP_IMU_ACCEL = 2, /* specific force, m/s^2 (reads +9.81 up when at rest) */
    SP_IMU_MAG = 3,   /* magnetic field, microtesla */
};

typedef struct sp_imu_sample {
    int64_t timestamp_ns; /* monotonic, same clock as frame timestamps */
    uint32_t sensor;      /* enum sp_imu_sensor */
    float v[3];
} sp_imu_sample;

SP_API const char *sp_imu_sensor_name(enum sp_imu_sensor sensor);

#ifdef __cplusplus
}
#endif
#endif
