/* SPDX-License-Identifier: MIT */
/* META chunk JSON -> sp_capture_meta, validating types and ranges. */
#include "sunprobe/sp_meta.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "common/json.h"

void sp_capture_meta_init(sp_capture_meta *meta)
{
    memset(meta, 0, sizeof(*meta));
    meta->fps = meta->fx = meta->fy = meta->cx = meta->cy = NAN;
    meta->focal_length_mm = meta->sensor_width_mm = NAN;
    meta->imu_rate_hz = NAN;
    meta->imu_to_camera = sp_quat_identity();
    meta->latitude = meta->longitude = meta->altitude_m = NAN;
    meta->magnetic_declination_deg = meta->start_heading_deg = NAN;
}

typedef struct {
    const char *key;
    size_t offset;
    double lo, hi; /* accepted range */
} number_field;

static int copy_string(const sp_json *obj, const char *key, char *dst, size_t size)
{
    const sp_json *v = sp_json_get(obj, key);
    if (!v)
        return 0;
    if (v->type != SP_JSON_STRING)
        return SP_ECORRUPT;
    snprintf(dst, size, "%s", v->string);
    return 0;
}

static int read_numbers(const sp_json *obj, const number_field *fields, size_t n, void *base)
{
    for (size_t i = 0; i < n; i++) {
        const sp_json *v = sp_json_get(obj, fields[i].key);
        if (!v || v->type == SP_JSON_NULL)
            continue;
        if (v->type != SP_JSON_NUMBER || !(v->number >= fields[i].lo && v->number <= fields[i].hi)) {
            sp_log(SP_LOG_ERROR, "meta", "metadata '%s' is not a number in [%g, %g]", fields[i].key,
                   fields[i].lo, fields[i].hi);
            return SP_ECORRUPT;
        }
        memcpy((char *)base + fields[i].offset, &v->number, sizeof(double));
    }
    return 0;
}

static int read_vec(const sp_json *obj, const char *key, double *out, size_t n)
{
    const sp_json *v = sp_json_get(obj, key);
    if (!v)
        return 0;
    double tmp[4];
    if (v->type != SP_JSON_ARRAY || v->count != n || sp_json_numbers(v, tmp, n) != n)
        return SP_ECORRUPT;
    for (size_t i = 0; i < n; i++)
        if (!isfinite(tmp[i]))
            return SP_ECORRUPT;
    memcpy(out, tmp, n * sizeof(double));
    return 0;
}

#define F(k, field, lo, hi) { k, offsetof(sp_capture_meta, field), lo, hi }

static int merge_camera(sp_capture_meta *m, const sp_json *cam)
{
    static const number_field fields[] = {
        F("fps", fps, 1e-3, 1e4),          F("fx", fx, 1e-3, 1e7),
        F("fy", fy, 1e-3, 1e7),            F("cx", cx, -1e6, 1e6),
        F("cy", cy, -1e6, 1e6),            F("focal_length_mm", focal_length_mm, 1e-3, 1e4),
        F("sensor_width_mm", sensor_width_mm, 1e-3, 1e3),
    };
    int ret = read_numbers(cam, fields, sizeof(fields) / sizeof(fields[0]), m);
    double w = sp_json_number(sp_json_get(cam, "width"), 0), h = sp_json_number(sp_json_get(cam, "height"), 0);
    if (!ret && (w < 0 || w > 65535 || h < 0 || h > 65535))
        ret = SP_ECORRUPT;
    if (!ret) {
        m->width = (uint32_t)w;
        m->height = (uint32_t)h;
        ret = copy_string(cam, "name", m->camera_name, sizeof(m->camera_name));
    }
    if (!ret)
        ret = copy_string(cam, "transfer", m->transfer, sizeof(m->transfer));
    if (!ret && m->transfer[0] && strcmp(m->transfer, "srgb") && strcmp(m->transfer, "sunprobe")) {
        sp_log(SP_LOG_ERROR, "meta", "camera.transfer '%s' is neither 'srgb' nor 'sunprobe'", m->transfer);
        ret = SP_ECORRUPT;
    }
    return ret ? ret : copy_string(cam, "driver", m->camera_driver, sizeof(m->camera_driver));
}

static int merge_imu(sp_capture_meta *m, const sp_json *imu)
{
    static const number_field fields[] = {
        F("rate_hz", imu_rate_hz, 1e-3, 1e6),
        F("time_offset_s", imu_time_offset_s, -10.0, 10.0),
    };
    double q[4] = { m->imu_to_camera.w, m->imu_to_camera.x, m->imu_to_camera.y, m->imu_to_camera.z };
    double gb[3] = { m->gyro_bias.x, m->gyro_bias.y, m->gyro_bias.z };
    double ab[3] = { m->accel_bias.x, m->accel_bias.y, m->accel_bias.z };
    int ret = read_numbers(imu, fields, sizeof(fields) / sizeof(fields[0]), m);
    if (!ret)
        ret = read_vec(imu, "to_camera", q, 4);
    if (!ret)
        ret = read_vec(imu, "gyro_bias", gb, 3);
    if (!ret)
        ret = read_vec(imu, "accel_bias", ab, 3);
    if (!ret && fabs(sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]) - 1.0) > 1e-3) {
        sp_log(SP_LOG_ERROR, "meta", "imu.to_camera is not a unit quaternion");
        ret = SP_ECORRUPT;
    }
    if (ret)
        return ret;
    m->imu_to_camera = sp_quat_normalize((sp_quat){ q[0], q[1], q[2], q[3] });
    m->gyro_bias = (sp_vec3){ gb[0], gb[1], gb[2] };
    m->accel_bias = (sp_vec3){ ab[0], ab[1], ab[2] };
    return copy_string(imu, "name", m->imu_name, sizeof(m->imu_name));
}

static int merge_location(sp_capture_meta *m, const sp_json *loc)
{
    static const number_field fields[] = {
        F("latitude", latitude, -90, 90),
        F("longitude", longitude, -180, 360),
        F("altitude_m", altitude_m, -1e4, 1e5),
        F("magnetic_declination_deg", magnetic_declination_deg, -180, 180),
        F("heading_deg", start_heading_deg, -360, 360),
    };
    return read_numbers(loc, fields, sizeof(fields) / sizeof(fields[0]), m);
}

int sp_capture_meta_merge(sp_capture_meta *meta, const char *json, size_t len)
{
    if (!meta || !json)
        return -EINVAL;
    char err[160];
    sp_json *root = NULL;
    int ret = sp_json_parse(json, len, &root, err, sizeof(err));
    if (ret) {
        sp_log(SP_LOG_ERROR, "meta", "%s", err);
        return ret;
    }
    sp_capture_meta m = *meta; /* work on a copy: a bad chunk changes nothing */
    if (root->type != SP_JSON_OBJECT)
        ret = SP_ECORRUPT;
    if (!ret)
        ret = copy_string(root, "kind", m.kind, sizeof(m.kind));
    if (!ret)
        ret = copy_string(root, "source", m.source, sizeof(m.source));
    if (!ret)
        ret = copy_string(root, "utc_start", m.utc_start, sizeof(m.utc_start));
    if (!ret)
        ret = copy_string(root, "ground_truth", m.ground_truth, sizeof(m.ground_truth));
    const sp_json *sub;
    if (!ret && (sub = sp_json_get(root, "camera")))
        ret = sub->type == SP_JSON_OBJECT ? merge_camera(&m, sub) : SP_ECORRUPT;
    if (!ret && (sub = sp_json_get(root, "imu")))
        ret = sub->type == SP_JSON_OBJECT ? merge_imu(&m, sub) : SP_ECORRUPT;
    if (!ret && (sub = sp_json_get(root, "location")))
        ret = sub->type == SP_JSON_OBJECT ? merge_location(&m, sub) : SP_ECORRUPT;
    if (!ret && m.kind[0] && strcmp(m.kind, "selfie") && strcmp(m.kind, "static")) {
        sp_log(SP_LOG_ERROR, "meta", "kind '%s' is neither 'selfie' nor 'static'", m.kind);
        ret = SP_ECORRUPT;
    }
    sp_json_free(root);
    if (ret)
        return ret;
    m.chunks_merged++;
    *meta = m;
    return 0;
}

double sp_capture_meta_focal_px(const sp_capture_meta *meta)
{
    if (isfinite(meta->fx))
        return meta->fx;
    if (isfinite(meta->focal_length_mm) && isfinite(meta->sensor_width_mm) && meta->width > 0)
        return meta->focal_length_mm / meta->sensor_width_mm * meta->width;
    return NAN;
}
