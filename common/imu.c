/* SPDX-License-Identifier: MIT */
#include "sunprobe/sp_imu.h"

const char *sp_imu_sensor_name(enum sp_imu_sensor sensor)
{
    switch (sensor) {
    case SP_IMU_GYRO:
        return "gyro";
    case SP_IMU_ACCEL:
        return "accel";
    case SP_IMU_MAG:
        return "mag";
    }
    return "unknown";
}
