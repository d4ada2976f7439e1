/* SPDX-License-Identifier: MIT */
/*
 * Where the sun is from the clock and the place: the NOAA solar-position equations (Meeus' low-precision
 * series), about 0.01 deg in 1800..2100 against the full VSOP87 answer; refraction by NOAA's piecewise
 * formula for a standard atmosphere. Used to seed and check the photometric sun of a selfie fit and the
 * single-image street sun. Conventions in common/SOLAR.md.
 */
#ifndef SUNPROBE_SP_SOLAR_H
#define SUNPROBE_SP_SOLAR_H

#include "sp_common.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sp_sun_position {
    double azimuth_deg;          /* clockwise from true north, 0..360 */
    double elevation_deg;        /* apparent: above the horizon, refraction included */
    double declination_deg;      /* of the sun, geocentric */
    double equation_of_time_min; /* apparent minus mean solar time */
} sp_sun_position;

/*
 * The sun seen from latitude/longitude (degrees, north and east positive) at unix_s (seconds since
 * 1970-01-01 UTC, leap seconds ignored). -EINVAL for a non-finite input, |latitude| > 90 or |longitude| > 360 (0..360 east is accepted as
 * metadata allows it).
 */
SP_API int sp_sun_position_at(double unix_s, double latitude_deg, double longitude_deg, sp_sun_position *out);

/*
 * Parses an ISO 8601 date-time as capture metadata writes it: "YYYY-MM-DDThh:mm:ss", optional fraction,
 * then "Z" or an offset "+hh:mm"/"-hh:mm" (a time without a zone is refused: it would be local time).
 * SP_ECORRUPT for anything else, including impossible dates (month 13, 31 April, 29 February 2023).
 */
SP_API int sp_utc_parse(const char *iso, double *unix_s);

/*
 * Unit vector towards the sun in a z-up world whose true north lies at north_angle_deg, measured from
 * world +x towards +y (the orientation filter's world with a magnetometer: +x magnetic north, so
 * north_angle_deg is the magnetic declination, east positive).
 */
SP_API void sp_sun_world_direction(const sp_sun_position *p, double north_angle_deg, double dir[3]);

#ifdef __cplusplus
}
#endif
#endif
