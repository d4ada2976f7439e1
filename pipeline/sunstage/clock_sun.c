/* SPDX-License-Identifier: MIT */
/*
 * The sun from the clock (common/SOLAR.md): with utc_start and location in the metadata and a world whose
 * north is known (a magnetometer anchored the heading, or location.heading_deg gives the camera's bearing
 * at the first frame), the ephemeris sun seeds the sun search and is compared with the fitted one.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "pipeline/sunstage/sunstage_internal.h"
#include "sunprobe/sp_solar.h"

#define MOD "sunstage"

void ss_clock_sun_init(ss_clock_sun *c)
{
    memset(c, 0, sizeof(*c));
    c->first_forward_deg = c->angle_deg = NAN;
}

void ss_clock_sun_note(ss_clock_sun *c, const sp_frame_tags *tags)
{
    if (tags->orientation != SP_ORIENTATION_OK)
        return;
    if (!c->oriented++) {
        sp_vec3 f = sp_quat_rotate(tags->camera_to_world, (sp_vec3){ 0, 0, 1 });
        c->first_forward_deg = atan2(f.y, f.x) * 180.0 / M_PI;
    }
    c->magnetic += tags->heading_magnetic != 0;
}

/* World angle of true north, from +x towards +y; NaN (with the reason in c->note) when unknown. */
static double north_angle(sp_sunstage *ss, ss_clock_sun *c)
{
    const sp_capture_meta *m = &ss->meta;
    if (c->oriented && c->magnetic == c->oriented) {
        double d = m->magnetic_declination_deg;
        if (isfinite(d)) {
            snprintf(c->heading_from, sizeof(c->heading_from), "magnetometer");
            return d;
        }
        snprintf(c->heading_from, sizeof(c->heading_from), "magnetometer, declination 0");
        sp_log(SP_LOG_WARN, MOD, "sun from the clock: location.magnetic_declination_deg is not given; magnetic "
               "north taken as true north, so its azimuth is off by the local declination");
        return 0.0;
    }
    if (isfinite(m->start_heading_deg) && isfinite(c->first_forward_deg)) {
        snprintf(c->heading_from, sizeof(c->heading_from), "heading_deg");
        return c->first_forward_deg + m->start_heading_deg;
    }
    snprintf(c->note, sizeof(c->note), "the world's heading is relative (no magnetometer on every frame, no "
             "location.heading_deg)");
    return NAN;
}

void ss_clock_sun_prepare(sp_sunstage *ss)
{
    ss_clock_sun *c = &ss->clock;
    const sp_capture_meta *m = &ss->meta;
    double t;
    c->have = 0;
    if (!m->utc_start[0] || !isfinite(m->latitude) || !isfinite(m->longitude)) {
        snprintf(c->note, sizeof(c->note), "the capture carries no utc_start and location");
        sp_log(SP_LOG_INFO, MOD, "sun from the clock: left out: %s", c->note);
        return;
    }
    if (sp_utc_parse(m->utc_start, &t)) {
        snprintf(c->note, sizeof(c->note), "utc_start is not an ISO 8601 time with a zone");
        sp_log(SP_LOG_WARN, MOD, "sun from the clock: left out: %s", c->note);
        return;
    }
    double north = north_angle(ss, c);
    if (!isfinite(north)) {
        sp_log(SP_LOG_INFO, MOD, "sun from the clock: left out: %s", c->note);
        return;
    }
    t += 0.5e-9 * (double)(ss->fe.frame_t[1] - ss->fe.frame_t[0]); /* the middle of the turn */
    sp_sun_position p;
    if (sp_sun_position_at(t, m->latitude, m->longitude, &p)) {
        snprintf(c->note, sizeof(c->note), "location out of range");
        return;
    }
    c->azimuth_deg = p.azimuth_deg;
    c->elevation_deg = p.elevation_deg;
    sp_sun_world_direction(&p, north, c->dir);
    c->have = 1;
    sp_log(SP_LOG_INFO, MOD, "sun from the clock: azimuth %.2f deg, elevation %.2f deg (heading from %s): world "
           "(%.3f %.3f %.3f)%s", p.azimuth_deg, p.elevation_deg, c->heading_from, c->dir[0], c->dir[1], c->dir[2],
           p.elevation_deg > 0.0 ? "" : "; below the horizon, not used as a start");
    if (p.elevation_deg > 0.0)
        memcpy(ss->fit.sun_dir, c->dir, sizeof(c->dir)); /* the Adam solver's start; the fast one adds a start */
}

void ss_clock_sun_compare(sp_sunstage *ss)
{
    ss_clock_sun *c = &ss->clock;
    c->angle_deg = NAN;
    if (!c->have || ss->fit.sun_dropped || ss->fit.unobservable || !ss->fit.fitted)
        return;
    const double *s = ss->fit.sun_dir;
    double dot = s[0] * c->dir[0] + s[1] * c->dir[1] + s[2] * c->dir[2];
    c->angle_deg = acos(fmax(-1.0, fmin(1.0, dot))) * 180.0 / M_PI;
    sp_log(SP_LOG_INFO, MOD, "sun from the clock vs the photometric sun: %.2f deg apart", c->angle_deg);
}
