/* SPDX-License-Identifier: MIT */
/* Vectors and unit quaternions, written to stay finite at the degenerate inputs. */
#include "sunprobe/sp_math.h"

#include <math.h>

sp_vec3 sp_vec3_add(sp_vec3 a, sp_vec3 b) { return (sp_vec3){ a.x + b.x, a.y + b.y, a.z + b.z }; }
sp_vec3 sp_vec3_sub(sp_vec3 a, sp_vec3 b) { return (sp_vec3){ a.x - b.x, a.y - b.y, a.z - b.z }; }
sp_vec3 sp_vec3_scale(sp_vec3 a, double s) { return (sp_vec3){ a.x * s, a.y * s, a.z * s }; }
double sp_vec3_dot(sp_vec3 a, sp_vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

sp_vec3 sp_vec3_cross(sp_vec3 a, sp_vec3 b)
{
    return (sp_vec3){ a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x };
}

double sp_vec3_norm(sp_vec3 a)
{
    return hypot(hypot(a.x, a.y), a.z); /* no overflow for huge components */
}

sp_vec3 sp_vec3_normalize(sp_vec3 a)
{
    double n = sp_vec3_norm(a);
    if (!(n > 0.0) || !isfinite(n))
        return (sp_vec3){ 0, 0, 0 };
    return sp_vec3_scale(a, 1.0 / n);
}

sp_quat sp_quat_identity(void) { return (sp_quat){ 1, 0, 0, 0 }; }

sp_quat sp_quat_mul(sp_quat a, sp_quat b)
{
    return (sp_quat){
        a.w * b.w - a.x * b.x - a.y * b.y - a.z * b.z,
        a.w * b.x + a.x * b.w + a.y * b.z - a.z * b.y,
        a.w * b.y - a.x * b.z + a.y * b.w + a.z * b.x,
        a.w * b.z + a.x * b.y - a.y * b.x + a.z * b.w,
    };
}

sp_quat sp_quat_conj(sp_quat q) { return (sp_quat){ q.w, -q.x, -q.y, -q.z }; }

sp_quat sp_quat_normalize(sp_quat q)
{
    double n = sqrt(q.w * q.w + q.x * q.x + q.y * q.y + q.z * q.z);
    if (!(n > 0.0) || !isfinite(n))
        return sp_quat_identity();
    return (sp_quat){ q.w / n, q.x / n, q.y / n, q.z / n };
}

sp_quat sp_quat_from_rotvec(sp_vec3 v)
{
    double angle = sp_vec3_norm(v);
    if (!isfinite(angle))
        return sp_quat_identity();
    double half = 0.5 * angle;
    /* sin(half)/angle via its series near zero avoids 0/0. */
    double k = angle < 1e-6 ? 0.5 - angle * angle / 48.0 : sin(half) / angle;
    return sp_quat_normalize((sp_quat){ cos(half), v.x * k, v.y * k, v.z * k });
}

sp_vec3 sp_quat_to_rotvec(sp_quat q)
{
    q = sp_quat_normalize(q);
    if (q.w < 0) /* shortest rotation */
        q = (sp_quat){ -q.w, -q.x, -q.y, -q.z };
    double s = sqrt(q.x * q.x + q.y * q.y + q.z * q.z);
    double angle = 2.0 * atan2(s, q.w);
    double k = s < 1e-12 ? 2.0 : angle / s;
    return (sp_vec3){ q.x * k, q.y * k, q.z * k };
}

sp_quat sp_quat_from_axis_angle(sp_vec3 axis, double angle)
{
    return sp_quat_from_rotvec(sp_vec3_scale(sp_vec3_normalize(axis), angle));
}

sp_vec3 sp_quat_rotate(sp_quat q, sp_vec3 v)
{
    sp_vec3 u = { q.x, q.y, q.z };
    sp_vec3 t = sp_vec3_scale(sp_vec3_cross(u, v), 2.0);
    return sp_vec3_add(sp_vec3_add(v, sp_vec3_scale(t, q.w)), sp_vec3_cross(u, t));
}

sp_quat sp_quat_slerp(sp_quat a, sp_quat b, double t)
{
    double d = a.w * b.w + a.x * b.x + a.y * b.y + a.z * b.z;
    if (d < 0) {
        b = (sp_quat){ -b.w, -b.x, -b.y, -b.z };
        d = -d;
    }
    double wa, wb;
    if (d > 0.9995) { /* nearly equal: lerp then normalise avoids sin(0) division */
        wa = 1.0 - t;
        wb = t;
    } else {
        double theta = acos(d > 1.0 ? 1.0 : d);
        double s = sin(theta);
        wa = sin((1.0 - t) * theta) / s;
        wb = sin(t * theta) / s;
    }
    return sp_quat_normalize((sp_quat){ wa * a.w + wb * b.w, wa * a.x + wb * b.x, wa * a.y + wb * b.y,
                                        wa * a.z + wb * b.z });
}

double sp_quat_angle_between(sp_quat a, sp_quat b)
{
    sp_quat d = sp_quat_mul(sp_quat_conj(sp_quat_normalize(a)), sp_quat_normalize(b));
    double s = sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    return 2.0 * atan2(s, fabs(d.w)); /* atan2 keeps precision at tiny angles, unlike acos */
}

double sp_srgb_encode(double c)
{
    if (!(c > 0.0))
        return 0.0;
    return c <= 0.0031308 ? 12.92 * c : 1.055 * pow(c, 1.0 / 2.4) - 0.055;
}

double sp_srgb_decode(double g)
{
    if (!(g > 0.0))
        return 0.0;
    return g <= 0.04045 ? g / 12.92 : pow((g + 0.055) / 1.055, 2.4);
}

void sp_quat_mean_init(sp_quat_mean *m)
{
    *m = (sp_quat_mean){ { 0, 0, 0, 0 }, { 1, 0, 0, 0 }, 0 };
}

void sp_quat_mean_add(sp_quat_mean *m, sp_quat q)
{
    if (m->n++ == 0)
        m->first = q;
    double s = q.w * m->first.w + q.x * m->first.x + q.y * m->first.y + q.z * m->first.z < 0.0 ? -1.0 : 1.0;
    m->sum.w += s * q.w;
    m->sum.x += s * q.x;
    m->sum.y += s * q.y;
    m->sum.z += s * q.z;
}

sp_quat sp_quat_mean_get(const sp_quat_mean *m)
{
    return m->n ? sp_quat_normalize(m->sum) : sp_quat_identity();
}

void sp_quat_to_matrix(sp_quat q, double m[9])
{
    q = sp_quat_normalize(q);
    double w = q.w, x = q.x, y = q.y, z = q.z;
    m[0] = 1 - 2 * (y * y + z * z);
    m[1] = 2 * (x * y - w * z);
    m[2] = 2 * (x * z + w * y);
    m[3] = 2 * (x * y + w * z);
    m[4] = 1 - 2 * (x * x + z * z);
    m[5] = 2 * (y * z - w * x);
    m[6] = 2 * (x * z - w * y);
    m[7] = 2 * (y * z + w * x);
    m[8] = 1 - 2 * (x * x + y * y);
}

sp_quat sp_quat_from_matrix(const double m[9])
{
    /* Shepperd's method: branch on the largest diagonal term for accuracy. */
    double tr = m[0] + m[4] + m[8];
    sp_quat q;
    if (tr > 0) {
        double s = sqrt(tr + 1.0) * 2;
        q = (sp_quat){ 0.25 * s, (m[7] - m[5]) / s, (m[2] - m[6]) / s, (m[3] - m[1]) / s };
    } else if (m[0] > m[4] && m[0] > m[8]) {
        double s = sqrt(1.0 + m[0] - m[4] - m[8]) * 2;
        q = (sp_quat){ (m[7] - m[5]) / s, 0.25 * s, (m[1] + m[3]) / s, (m[2] + m[6]) / s };
    } else if (m[4] > m[8]) {
        double s = sqrt(1.0 + m[4] - m[0] - m[8]) * 2;
        q = (sp_quat){ (m[2] - m[6]) / s, (m[1] + m[3]) / s, 0.25 * s, (m[5] + m[7]) / s };
    } else {
        double s = sqrt(1.0 + m[8] - m[0] - m[4]) * 2;
        q = (sp_quat){ (m[3] - m[1]) / s, (m[2] + m[6]) / s, (m[5] + m[7]) / s, 0.25 * s };
    }
    return sp_quat_normalize(q);
}
