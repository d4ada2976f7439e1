/* SPDX-License-Identifier: MIT */
/* Solar position against published figures (the SPA report's worked example, the 2024 equinox and
 * solstice, the equation of time's extremes), at the poles and the date line, and the ISO 8601 parser. */
#include <errno.h>
#include <math.h>
#include <string.h>

#include "check.h"
#include "sunprobe/sp_solar.h"

static double at(const char *iso)
{
    double t = NAN;
    CHECK_MSG(sp_utc_parse(iso, &t) == 0, "%s", iso);
    return t;
}

/* Reda & Andreas, "Solar Position Algorithm for Solar Radiation Applications", NREL/TP-560-34302 (2004),
 * worked example: 2003-10-17 12:30:30 at UTC-7, 39.742476 N 105.1786 W: topocentric zenith 50.11162 deg,
 * azimuth 194.34024 deg (its refraction at 820 mbar is 0.004 deg below the standard atmosphere's here). */
static void test_spa_example(void)
{
    sp_sun_position p;
    CHECK(sp_sun_position_at(at("2003-10-17T12:30:30-07:00"), 39.742476, -105.1786, &p) == 0);
    CHECK_NEAR(90.0 - p.elevation_deg, 50.11162, 0.02);
    CHECK_NEAR(p.azimuth_deg, 194.34024, 0.02);
}

/* 2024 equinox 03:06 UTC on 20 March and solstice 20:51 UTC on 20 June (US Naval Observatory); the
 * solstice declination is that year's obliquity, 23.436 deg. */
static void test_equinox_solstice(void)
{
    sp_sun_position p;
    CHECK(sp_sun_position_at(at("2024-03-20T03:06:00Z"), 0, 0, &p) == 0);
    CHECK_NEAR(p.declination_deg, 0.0, 0.01);
    CHECK(sp_sun_position_at(at("2024-06-20T20:51:00Z"), 0, 0, &p) == 0);
    CHECK_NEAR(p.declination_deg, 23.436, 0.01);
    /* equation of time near its extremes: +16.4 min on 3 November, -14.2 min on 11 February */
    CHECK(sp_sun_position_at(at("2024-11-03T12:00:00Z"), 0, 0, &p) == 0);
    CHECK_NEAR(p.equation_of_time_min, 16.4, 0.15);
    CHECK(sp_sun_position_at(at("2024-02-11T12:00:00Z"), 0, 0, &p) == 0);
    CHECK_NEAR(p.equation_of_time_min, -14.2, 0.15);
}

/* Solar noon is due south north of the tropics and due north south of them, at 90 - latitude +
 * declination. */
static void test_noon_geometry(void)
{
    sp_sun_position p;
    double noon = at("2024-03-20T12:00:00Z");
    CHECK(sp_sun_position_at(noon - 60.0 * -7.5, 48.85, 0.0, &p) == 0); /* 7.5 min EoT late on 20 March */
    CHECK_NEAR(p.azimuth_deg, 180.0, 0.5);
    CHECK_NEAR(p.elevation_deg, 90.0 - 48.85 + p.declination_deg, 0.03); /* 0.02 deg of refraction */
    CHECK(sp_sun_position_at(noon - 60.0 * -7.5, -33.9, 0.0, &p) == 0);
    CHECK(p.azimuth_deg < 0.5 || p.azimuth_deg > 359.5);
    /* the same instant seen 90 deg east is six hours later: the sun sets there (west, near the horizon) */
    CHECK(sp_sun_position_at(noon - 60.0 * -7.5, 0.0, 90.0, &p) == 0);
    CHECK_NEAR(p.azimuth_deg, 270.0, 1.0);
    CHECK(fabs(p.elevation_deg) < 1.0);
}

/* Poles and the date line: finite answers; at a pole the elevation is the declination all day. */
static void test_extremes(void)
{
    sp_sun_position p;
    for (int h = 0; h < 24; h += 5) {
        double t = at("2024-06-21T00:00:00Z") + h * 3600.0;
        CHECK(sp_sun_position_at(t, 90.0, 0.0, &p) == 0);
        CHECK_NEAR(p.elevation_deg - p.declination_deg, 0.037, 0.005); /* refraction at 23 deg */
        CHECK(isfinite(p.azimuth_deg) && p.azimuth_deg >= 0.0 && p.azimuth_deg < 360.0);
        CHECK(sp_sun_position_at(t, -90.0, 180.0, &p) == 0);
        CHECK(p.elevation_deg < 0.0 && isfinite(p.azimuth_deg));
        CHECK(sp_sun_position_at(t, 12.0, -180.0, &p) == 0);
        sp_sun_position q;
        CHECK(sp_sun_position_at(t, 12.0, 180.0, &q) == 0); /* the same meridian */
        CHECK_NEAR(p.azimuth_deg, q.azimuth_deg, 1e-9);
    }
    CHECK(sp_sun_position_at(at("1900-01-01T00:00:00Z"), 10, 10, &p) == 0 && isfinite(p.elevation_deg));
    CHECK(sp_sun_position_at(at("2100-12-31T23:59:59Z"), 10, 10, &p) == 0 && isfinite(p.elevation_deg));
    CHECK(sp_sun_position_at(NAN, 0, 0, &p) == -EINVAL);
    CHECK(sp_sun_position_at(0, 90.0001, 0, &p) == -EINVAL);
    CHECK(sp_sun_position_at(0, 0, -360.5, &p) == -EINVAL);
    sp_sun_position q;
    CHECK(sp_sun_position_at(1e9, 10, 350.0, &p) == 0 && sp_sun_position_at(1e9, 10, -10.0, &q) == 0);
    CHECK_NEAR(p.azimuth_deg, q.azimuth_deg, 1e-9);
    CHECK(sp_sun_position_at(0, NAN, 0, &p) == -EINVAL);
}

/* World directions: z up; with true north on +x, the eastern sun lies towards -y (+y is west). */
static void test_world_direction(void)
{
    sp_sun_position p = { .azimuth_deg = 90.0, .elevation_deg = 30.0 };
    double d[3];
    sp_sun_world_direction(&p, 0.0, d);
    CHECK_NEAR(d[0], 0.0, 1e-12);
    CHECK_NEAR(d[1], -cos(30.0 * M_PI / 180.0), 1e-12);
    CHECK_NEAR(d[2], 0.5, 1e-12);
    p.azimuth_deg = 10.0; /* 10 deg east of true north, with true north 10 deg towards +y: along +x */
    sp_sun_world_direction(&p, 10.0, d);
    CHECK_NEAR(d[1], 0.0, 1e-12);
    CHECK(d[0] > 0.8);
}

static void test_parse(void)
{
    double t;
    CHECK(sp_utc_parse("1970-01-01T00:00:00Z", &t) == 0 && t == 0.0);
    CHECK(sp_utc_parse("2024-06-21T12:00:00.250Z", &t) == 0);
    CHECK_NEAR(t, 1718971200.25, 1e-6);
    CHECK(sp_utc_parse("2024-06-21T14:00:00+02:00", &t) == 0 && t == 1718971200.0);
    CHECK(sp_utc_parse("2024-06-21T14:00:00+0200", &t) == 0 && t == 1718971200.0);
    CHECK(sp_utc_parse("2024-02-29T00:00:00Z", &t) == 0);
    CHECK(sp_utc_parse("1969-12-31T23:59:59Z", &t) == 0 && t == -1.0);
    const char *bad[] = { "2023-02-29T00:00:00Z", "2024-04-31T00:00:00Z", "2024-13-01T00:00:00Z",
                          "2024-06-21T12:00:00", "2024-06-21T24:00:00Z", "2024-06-21T12:60:00Z",
                          "2024-06-21T12:00:00Zjunk", "2024-6-21T12:00:00Z", "", "2024-06-21T12:00:00.Z",
                          "2024-06-21T12:00:00+25:00" };
    for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++)
        CHECK_MSG(sp_utc_parse(bad[i], &t) == SP_ECORRUPT, "'%s' accepted", bad[i]);
    CHECK(sp_utc_parse(NULL, &t) == -EINVAL);
}

int main(void)
{
    test_spa_example();
    test_equinox_solstice();
    test_noon_geometry();
    test_extremes();
    test_world_direction();
    test_parse();
    return check_exit();
}
