/* SPDX-License-Identifier: MIT */
/* Solar position (NOAA's equations) and ISO 8601 UTC times; sp_solar.h. */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>

#include "sunprobe/sp_solar.h"

#define DEG (M_PI / 180.0)

static double wrap360(double a)
{
    a = fmod(a, 360.0);
    return a < 0.0 ? a + 360.0 : a;
}

/* Atmospheric refraction in degrees at apparent-less elevation e (NOAA's fit; 0 below -0.575 deg). */
static double refraction_deg(double e)
{
    if (e > 85.0)
        return 0.0;
    double t = tan(e * DEG), arcsec;
    if (e > 5.0)
        arcsec = 58.1 / t - 0.07 / (t * t * t) + 0.000086 / pow(t, 5);
    else if (e > -0.575)
        arcsec = 1735.0 + e * (-518.2 + e * (103.4 + e * (-12.79 + e * 0.711)));
    else
        arcsec = -20.772 / t;
    return arcsec / 3600.0;
}

int sp_sun_position_at(double unix_s, double latitude_deg, double longitude_deg, sp_sun_position *out)
{
    if (!out || !isfinite(unix_s) || !(fabs(latitude_deg) <= 90.0) || !(fabs(longitude_deg) <= 360.0))
        return -EINVAL;
    double jd = unix_s / 86400.0 + 2440587.5;
    double T = (jd - 2451545.0) / 36525.0; /* Julian centuries since J2000.0 */
    double L0 = wrap360(280.46646 + T * (36000.76983 + T * 0.0003032));
    double M = 357.52911 + T * (35999.05029 - 0.0001537 * T);
    double ecc = 0.016708634 - T * (0.000042037 + 0.0000001267 * T);
    double C = sin(M * DEG) * (1.914602 - T * (0.004817 + 0.000014 * T)) + sin(2 * M * DEG) * (0.019993 - 0.000101 * T) +
               sin(3 * M * DEG) * 0.000289;
    double omega = 125.04 - 1934.136 * T;
    double lambda = L0 + C - 0.00569 - 0.00478 * sin(omega * DEG); /* apparent longitude */
    double eps0 = 23.0 + (26.0 + (21.448 - T * (46.815 + T * (0.00059 - T * 0.001813))) / 60.0) / 60.0;
    double eps = eps0 + 0.00256 * cos(omega * DEG);
    double decl = asin(sin(eps * DEG) * sin(lambda * DEG));
    double y = tan(eps * DEG / 2.0);
    y *= y;
    double eot = 4.0 / DEG *
                 (y * sin(2 * L0 * DEG) - 2 * ecc * sin(M * DEG) + 4 * ecc * y * sin(M * DEG) * cos(2 * L0 * DEG) -
                  0.5 * y * y * sin(4 * L0 * DEG) - 1.25 * ecc * ecc * sin(2 * M * DEG));
    double day_min = fmod(unix_s, 86400.0) / 60.0;
    if (day_min < 0.0)
        day_min += 1440.0;
    double hour_angle = (day_min + eot + 4.0 * longitude_deg) / 4.0 - 180.0; /* true solar time, degrees */
    double phi = latitude_deg * DEG, H = hour_angle * DEG;
    double cz = sin(phi) * sin(decl) + cos(phi) * cos(decl) * cos(H);
    double e = asin(fmax(-1.0, fmin(1.0, cz))) / DEG;
    /* azimuth from north, clockwise: atan2 stays defined at the poles' horizon and at the zenith */
    double az = atan2(sin(H), cos(H) * sin(phi) - tan(decl) * cos(phi)) / DEG + 180.0;
    out->azimuth_deg = wrap360(az);
    out->elevation_deg = e + refraction_deg(e);
    out->declination_deg = decl / DEG;
    out->equation_of_time_min = eot;
    return 0;
}

void sp_sun_world_direction(const sp_sun_position *p, double north_angle_deg, double dir[3])
{
    double phi = (north_angle_deg - p->azimuth_deg) * DEG, e = p->elevation_deg * DEG;
    dir[0] = cos(e) * cos(phi);
    dir[1] = cos(e) * sin(phi);
    dir[2] = sin(e);
}

/* Reads exactly n digits; -1 when they are not there. */
static int digits(const char **s, int n)
{
    int v = 0;
    for (int i = 0; i < n; i++, (*s)++) {
        if (!isdigit((unsigned char)**s))
            return -1;
        v = v * 10 + (**s - '0');
    }
    return v;
}

static int expect(const char **s, char c)
{
    return **s == c ? ((*s)++, 0) : -1;
}

/* Days from 1970-01-01 to y-m-d in the proleptic Gregorian calendar (valid for any year here). */
static long days_from_civil(long y, int m, int d)
{
    y -= m <= 2;
    long era = (y >= 0 ? y : y - 399) / 400;
    long yoe = y - era * 400;
    long doy = (153 * (m + (m > 2 ? -3 : 9)) + 2) / 5 + d - 1;
    long doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    return era * 146097 + doe - 719468;
}

static int days_in_month(int y, int m)
{
    static const int n[12] = { 31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31 };
    int leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
    return n[m - 1] + (m == 2 && leap);
}

int sp_utc_parse(const char *iso, double *unix_s)
{
    if (!iso || !unix_s)
        return -EINVAL;
    const char *s = iso;
    int Y = digits(&s, 4);
    int ok = Y >= 0 && !expect(&s, '-');
    int Mo = ok ? digits(&s, 2) : -1;
    ok = ok && Mo >= 1 && Mo <= 12 && !expect(&s, '-');
    int D = ok ? digits(&s, 2) : -1;
    ok = ok && D >= 1 && D <= days_in_month(Y, Mo) && (*s == 'T' || *s == 't' || *s == ' ');
    s += ok;
    int h = ok ? digits(&s, 2) : -1;
    ok = ok && h >= 0 && h <= 23 && !expect(&s, ':');
    int mi = ok ? digits(&s, 2) : -1;
    ok = ok && mi >= 0 && mi <= 59 && !expect(&s, ':');
    int se = ok ? digits(&s, 2) : -1;
    ok = ok && se >= 0 && se <= 60; /* 60: a leap second, read as the next second's start */
    if (!ok)
        return SP_ECORRUPT;
    double frac = 0.0, scale = 0.1;
    if (*s == '.' || *s == ',') {
        s++;
        if (!isdigit((unsigned char)*s))
            return SP_ECORRUPT;
        for (; isdigit((unsigned char)*s); s++, scale *= 0.1)
            frac += (*s - '0') * scale;
    }
    int offset_min = 0;
    if (*s == 'Z' || *s == 'z') {
        s++;
    } else if (*s == '+' || *s == '-') {
        int sign = *s++ == '-' ? -1 : 1;
        int oh = digits(&s, 2);
        if (oh < 0 || oh > 23)
            return SP_ECORRUPT;
        if (*s == ':') /* "+hh:mm" and "+hhmm" are both ISO 8601 */
            s++;
        int om = digits(&s, 2);
        if (om < 0 || om > 59)
            return SP_ECORRUPT;
        offset_min = sign * (oh * 60 + om);
    } else {
        return SP_ECORRUPT;
    }
    if (*s)
        return SP_ECORRUPT;
    *unix_s = (double)days_from_civil(Y, Mo, D) * 86400.0 + h * 3600.0 + mi * 60.0 + se + frac - offset_min * 60.0;
    return 0;
}
