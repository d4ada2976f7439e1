/* SPDX-License-Identifier: MIT */
/*
 * The analytic sky as a 16x32 environment map (layout of sp_render.h): a clear
 * sky whose blue deepens towards the zenith, brightens towards the horizon and
 * around the sun, or a CIE-like overcast sky (zenith three times the horizon);
 * below the horizon the ground reflects what the sun and sky put on it. The
 * sun itself is not in the map: the renderer adds it as a directional light.
 */
#include "pipeline/synth/synth_internal.h"

#include <math.h>
#include <string.h>

#define DEG (M_PI / 180.0)

void synth_sun_direction(double elevation_deg, double azimuth_deg, double out[3])
{
    double el = elevation_deg * DEG, az = azimuth_deg * DEG;
    out[0] = cos(el) * cos(az);
    out[1] = cos(el) * sin(az);
    out[2] = sin(el);
}

static void texel_dir(int i, int j, double d[3])
{
    double th = (i + 0.5) * M_PI / SP_RENDER_ENV_H, ph = (j + 0.5) * 2.0 * M_PI / SP_RENDER_ENV_W;
    d[0] = sin(th) * cos(ph);
    d[1] = sin(th) * sin(ph);
    d[2] = cos(th);
}

static void clear_sky(const double d[3], const double sun[3], double k, double out[3])
{
    static const double zenith[3] = { 0.06, 0.11, 0.24 }, horizon[3] = { 0.22, 0.25, 0.28 };
    double w = pow(1.0 - fmin(fmax(d[2], 0.0), 1.0), 1.5);
    double cg = d[0] * sun[0] + d[1] * sun[1] + d[2] * sun[2];
    double g = acos(fmin(fmax(cg, -1.0), 1.0));
    double glow = 1.0 + 1.5 * exp(-g * g / (2.0 * 0.35 * 0.35));
    for (int c = 0; c < 3; c++)
        out[c] = k * (zenith[c] + w * (horizon[c] - zenith[c])) * glow;
}

static void overcast_sky(const double d[3], double k, double out[3])
{
    double v = 0.6 * k * (1.0 + 2.0 * fmax(d[2], 0.0)) / 3.0;
    out[0] = out[1] = out[2] = v;
}

/* Irradiance the upper rows put on a horizontal ground (exact solid angle per row). */
static void sky_irradiance(const float *env, double E[3])
{
    E[0] = E[1] = E[2] = 0.0;
    for (int i = 0; i < SP_RENDER_ENV_H / 2; i++) {
        double t0 = i * M_PI / SP_RENDER_ENV_H, t1 = (i + 1) * M_PI / SP_RENDER_ENV_H;
        /* integral of cos(theta) sin(theta) over the row, times the column's azimuth span */
        double w = 0.5 * (sin(t1) * sin(t1) - sin(t0) * sin(t0)) * 2.0 * M_PI / SP_RENDER_ENV_W;
        for (int j = 0; j < SP_RENDER_ENV_W; j++)
            for (int c = 0; c < 3; c++)
                E[c] += w * (double)env[((size_t)i * SP_RENDER_ENV_W + (size_t)j) * 3 + (size_t)c];
    }
}

void synth_build_env(const sp_synth_selfie_settings *s, const double sun_dir[3], double sun_intensity,
                     double ground_albedo, float *env)
{
    static const double ground_tint[3] = { 1.05, 1.0, 0.85 };
    double d[3], rgb[3];
    memset(env, 0, SP_RENDER_ENV_FLOATS * sizeof(float));
    for (int i = 0; i < SP_RENDER_ENV_H / 2; i++)
        for (int j = 0; j < SP_RENDER_ENV_W; j++) {
            texel_dir(i, j, d);
            if (s->overcast)
                overcast_sky(d, s->sky_intensity, rgb);
            else
                clear_sky(d, sun_dir, s->sky_intensity, rgb);
            for (int c = 0; c < 3; c++)
                env[((size_t)i * SP_RENDER_ENV_W + (size_t)j) * 3 + (size_t)c] = (float)rgb[c];
        }
    double E[3];
    sky_irradiance(env, E);
    double sun_h = sun_intensity * fmax(sun_dir[2], 0.0);
    for (int i = SP_RENDER_ENV_H / 2; i < SP_RENDER_ENV_H; i++)
        for (int j = 0; j < SP_RENDER_ENV_W; j++)
            for (int c = 0; c < 3; c++)
                env[((size_t)i * SP_RENDER_ENV_W + (size_t)j) * 3 + (size_t)c] =
                    (float)(ground_albedo * ground_tint[c] / M_PI * (sun_h + E[c]));
}

void synth_env_lookup(const float *env, const double dir[3], double rgb[3])
{
    double th = acos(fmin(fmax(dir[2], -1.0), 1.0));
    double ph = atan2(dir[1], dir[0]);
    if (ph < 0)
        ph += 2.0 * M_PI;
    double y = th / M_PI * SP_RENDER_ENV_H - 0.5, x = ph / (2.0 * M_PI) * SP_RENDER_ENV_W - 0.5;
    double y0 = floor(y), x0 = floor(x), fy = y - y0, fx = x - x0;
    int r0 = (int)y0, r1 = r0 + 1, c0 = (int)x0, c1 = c0 + 1;
    r0 = r0 < 0 ? 0 : r0 >= SP_RENDER_ENV_H ? SP_RENDER_ENV_H - 1 : r0;
    r1 = r1 < 0 ? 0 : r1 >= SP_RENDER_ENV_H ? SP_RENDER_ENV_H - 1 : r1;
    c0 = (c0 % SP_RENDER_ENV_W + SP_RENDER_ENV_W) % SP_RENDER_ENV_W;
    c1 = (c1 % SP_RENDER_ENV_W + SP_RENDER_ENV_W) % SP_RENDER_ENV_W;
    for (int c = 0; c < 3; c++) {
        double a = env[((size_t)r0 * SP_RENDER_ENV_W + (size_t)c0) * 3 + (size_t)c];
        double b = env[((size_t)r0 * SP_RENDER_ENV_W + (size_t)c1) * 3 + (size_t)c];
        double e = env[((size_t)r1 * SP_RENDER_ENV_W + (size_t)c0) * 3 + (size_t)c];
        double f = env[((size_t)r1 * SP_RENDER_ENV_W + (size_t)c1) * 3 + (size_t)c];
        rgb[c] = (1 - fy) * ((1 - fx) * a + fx * b) + fy * ((1 - fx) * e + fx * f);
    }
}
