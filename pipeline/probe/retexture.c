/* SPDX-License-Identifier: MIT */
/*
 * Texture transfer onto the ground plane (RETEXTURE.md). The plane model says a
 * person standing at (x, y) is h = a x + b y + c pixels tall, so the ground
 * there lies at depth Z = f H / h and sideways X = t H / h, t the distance
 * along the horizon from the image centre (H: the person's nominal height).
 * The texture is laid at a fixed size in metres, sampled from a mip pyramid
 * at the pixel's footprint, and multiplied by the plate's shading: its
 * low-passed linear colour over that of the lit ground.
 */
#include "retexture.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sunprobe/sp_math.h"

#define MAX_MIPS 24

void sp_retexture_default_settings(sp_retexture_settings *s)
{
    *s = (sp_retexture_settings){ .metres = 1.0, .focal_px = 0, .shading_m = 0.15 };
}

static int full_plane(const sp_probe_plane *p)
{
    return p && p->status == SP_PROBE_PLANE_OK && isfinite(p->a) && isfinite(p->b) && isfinite(p->c) &&
           hypot(p->a, p->b) > 1e-9;
}

int sp_retexture_ground(const sp_probe_plane *plane, const float *occlusion, uint32_t w, uint32_t h,
                        uint8_t *region)
{
    if (!plane || !region || !w || !h)
        return -EINVAL;
    if (!full_plane(plane))
        return SP_ENODATA;
    uint64_t n = 0;
    for (uint32_t y = 0; y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            double hp = plane->a * x + plane->b * y + plane->c;
            region[i] = hp >= 2.0 && (!occlusion || !(occlusion[i] >= 0));
            n += region[i];
        }
    return n ? 0 : SP_ENODATA;
}

typedef struct mip {
    float *px[MAX_MIPS];
    int w[MAX_MIPS], h[MAX_MIPS], n;
} mip;

static void mip_free(mip *m)
{
    for (int l = 0; l < m->n; l++)
        free(m->px[l]);
    memset(m, 0, sizeof(*m));
}

/* Linear-light pyramid of the texture, 2 x 2 box (wrapping), down to one pixel. */
static int mip_build(mip *m, const float *tex, int tw, int th)
{
    memset(m, 0, sizeof(*m));
    if (!(m->px[0] = malloc(sizeof(float) * 3 * (size_t)tw * th)))
        return -ENOMEM;
    m->w[0] = tw, m->h[0] = th, m->n = 1;
    for (size_t i = 0; i < (size_t)tw * th * 3; i++)
        m->px[0][i] = (float)sp_srgb_decode(tex[i] < 0 ? 0 : tex[i] > 1 ? 1 : tex[i]);
    while (m->n < MAX_MIPS && (m->w[m->n - 1] > 1 || m->h[m->n - 1] > 1)) {
        int l = m->n, pw = m->w[l - 1], ph = m->h[l - 1], cw = (pw + 1) / 2, ch = (ph + 1) / 2;
        if (!(m->px[l] = malloc(sizeof(float) * 3 * (size_t)cw * ch)))
            return -ENOMEM;
        for (int y = 0; y < ch; y++)
            for (int x = 0; x < cw; x++)
                for (int c = 0; c < 3; c++) {
                    float s = 0;
                    for (int k = 0; k < 4; k++)
                        s += m->px[l - 1][3 * ((size_t)((2 * y + k / 2) % ph) * pw + (size_t)((2 * x + k % 2) % pw)) + c];
                    m->px[l][3 * ((size_t)y * cw + x) + c] = s / 4;
                }
        m->w[l] = cw, m->h[l] = ch, m->n++;
    }
    return 0;
}

/* Bilinear, repeating, at level l; u, v in level-0 pixels. */
static void mip_sample(const mip *m, int l, double u, double v, double out[3])
{
    double s = ldexp(1.0, -l), fu = u * s - 0.5, fv = v * s - 0.5, x0 = floor(fu), y0 = floor(fv);
    double ax = fu - x0, ay = fv - y0;
    int W = m->w[l], H = m->h[l];
    long xi = (long)fmod(x0, (double)W), yi = (long)fmod(y0, (double)H);
    xi += xi < 0 ? W : 0, yi += yi < 0 ? H : 0;
    out[0] = out[1] = out[2] = 0;
    for (int k = 0; k < 4; k++) {
        int x = (int)((xi + k % 2) % W), y = (int)((yi + k / 2) % H);
        double wgt = (k % 2 ? ax : 1 - ax) * (k / 2 ? ay : 1 - ay);
        for (int c = 0; c < 3; c++)
            out[c] += wgt * (double)m->px[l][3 * ((size_t)y * W + x) + c];
    }
}

typedef struct mapping {
    double a, b, c, g, t0, f, per_px; /* per_px: texture pixels per metre */
} mapping;

/* Texture coordinates (level-0 pixels) of image point (x, y); 0 above the horizon. */
static int map_uv(const mapping *mp, double x, double y, double *u, double *v)
{
    double hp = mp->a * x + mp->b * y + mp->c;
    if (!(hp > 1e-3))
        return 0;
    double t = (-mp->b * x + mp->a * y) / mp->g;
    *u = (t - mp->t0) * SP_RETEXTURE_PERSON_M / hp * mp->per_px;
    *v = mp->f * SP_RETEXTURE_PERSON_M / hp * mp->per_px;
    return 1;
}

/* The texture's linear colour seen at pixel (x, y): trilinear at the footprint of one pixel. */
static void texel(const mip *m, const mapping *mp, int x, int y, double out[3])
{
    double u, v, ux, vx, uy, vy;
    map_uv(mp, x, y, &u, &v);
    if (!map_uv(mp, x + 1, y, &ux, &vx))
        ux = u, vx = v;
    if (!map_uv(mp, x, y - 1, &uy, &vy) && !map_uv(mp, x, y + 1, &uy, &vy)) /* the row above, else below */
        uy = u, vy = v;
    double fp = fmax(hypot(ux - u, vx - v), hypot(uy - u, vy - v)), lv = fp > 1 ? log2(fp) : 0;
    int l0 = (int)lv < m->n - 1 ? (int)lv : m->n - 1, l1 = l0 + 1 < m->n ? l0 + 1 : l0;
    double a0[3], a1[3], t = lv - l0 < 1 ? lv - l0 : 1;
    mip_sample(m, l0, u, v, a0);
    mip_sample(m, l1, u, v, a1);
    for (int c = 0; c < 3; c++)
        out[c] = a0[c] + t * (a1[c] - a0[c]);
}

typedef struct shading {
    double *sat; /* (w + 1) x (h + 1) x 4: linear r, g, b times region, and region */
    double *lp;  /* w x h x 3: the low-passed linear colour over the region */
} shading;

static int shading_build(shading *sh, const uint8_t *plate, const uint8_t *region, int w, int h, const mapping *mp,
                         double radius_m)
{
    size_t W1 = (size_t)w + 1;
    sh->sat = calloc(W1 * ((size_t)h + 1) * 4, sizeof(double));
    sh->lp = malloc(sizeof(double) * 3 * (size_t)w * h);
    if (!sh->sat || !sh->lp)
        return -ENOMEM;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x, o = 4 * ((size_t)(y + 1) * W1 + x + 1);
            for (int k = 0; k < 4; k++) {
                double v = !region[i] ? 0 : k == 3 ? 1 : sp_srgb_decode(plate[3 * i + k] / 255.0);
                sh->sat[o + k] = v + sh->sat[o - 4 + k] + sh->sat[o - 4 * W1 + k] - sh->sat[o - 4 * W1 - 4 + k];
            }
        }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            double hp = mp->a * x + mp->b * y + mp->c, r = radius_m * hp / SP_RETEXTURE_PERSON_M;
            int R = r < 1 ? 1 : r > 64 ? 64 : (int)lrint(r);
            int x0 = x - R < 0 ? 0 : x - R, x1 = x + R + 1 > w ? w : x + R + 1;
            int y0 = y - R < 0 ? 0 : y - R, y1 = y + R + 1 > h ? h : y + R + 1;
            double s[4];
            for (int k = 0; k < 4; k++)
                s[k] = sh->sat[4 * ((size_t)y1 * W1 + x1) + k] - sh->sat[4 * ((size_t)y0 * W1 + x1) + k] -
                       sh->sat[4 * ((size_t)y1 * W1 + x0) + k] + sh->sat[4 * ((size_t)y0 * W1 + x0) + k];
            for (int c = 0; c < 3; c++)
                sh->lp[3 * ((size_t)y * w + x) + c] = s[3] > 0.5 ? s[c] / s[3] : 0.0;
        }
    return 0;
}

/* The lit ground's colour: the mean low-passed colour over the brighter half of the region. */
static void lit_colour(const shading *sh, const uint8_t *region, size_t n, double lit[3])
{
    enum { BINS = 1024 };
    uint64_t hist[BINS] = { 0 }, total = 0, acc = 0;
    for (size_t i = 0; i < n; i++)
        if (region[i]) {
            double Y = 0.2126 * sh->lp[3 * i] + 0.7152 * sh->lp[3 * i + 1] + 0.0722 * sh->lp[3 * i + 2];
            hist[Y >= 1 ? BINS - 1 : (int)(Y * BINS)]++, total++;
        }
    int med = 0;
    while (med < BINS - 1 && (acc += hist[med]) * 2 < total)
        med++;
    double s[3] = { 0, 0, 0 }, k = 0;
    for (size_t i = 0; i < n; i++) {
        double Y = 0.2126 * sh->lp[3 * i] + 0.7152 * sh->lp[3 * i + 1] + 0.0722 * sh->lp[3 * i + 2];
        if (region[i] && Y * BINS >= med)
            s[0] += sh->lp[3 * i], s[1] += sh->lp[3 * i + 1], s[2] += sh->lp[3 * i + 2], k += 1;
    }
    for (int c = 0; c < 3; c++)
        lit[c] = k > 0 && s[c] / k > 1e-6 ? s[c] / k : 1e-6;
}

static uint8_t to8(double linear)
{
    double e = sp_srgb_encode(linear < 0 ? 0 : linear > 1 ? 1 : linear) * 255.0 + 0.5;
    return (uint8_t)(e > 255 ? 255 : e);
}

int sp_retexture(const uint8_t *plate, uint32_t w, uint32_t h, const sp_probe_plane *plane, const uint8_t *region,
                 const float *tex, uint32_t tw, uint32_t th, const sp_retexture_settings *s, uint8_t *out,
                 sp_retexture_report *rep)
{
    if (!plate || !plane || !region || !tex || !s || !out || !rep || !w || !h || !tw || !th || w > 65536 ||
        h > 65536 || !(s->metres > 0) || !(s->focal_px >= 0) || !(s->shading_m >= 0))
        return -EINVAL;
    if (!full_plane(plane))
        return SP_ENODATA;
    memset(rep, 0, sizeof(*rep));
    rep->near_px_per_m = 0, rep->far_px_per_m = INFINITY;
    double g = hypot(plane->a, plane->b), cx = 0.5 * (w - 1.0), cy = 0.5 * (h - 1.0);
    mapping mp = { plane->a, plane->b, plane->c, g, (-plane->b * cx + plane->a * cy) / g,
                   s->focal_px > 0 ? s->focal_px : (double)w, (double)tw / s->metres };
    mip m;
    shading sh = { 0 };
    int ret = mip_build(&m, tex, (int)tw, (int)th);
    if (!ret)
        ret = shading_build(&sh, plate, region, (int)w, (int)h, &mp, s->shading_m);
    if (!ret)
        lit_colour(&sh, region, (size_t)w * h, rep->lit);
    for (uint32_t y = 0; !ret && y < h; y++)
        for (uint32_t x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            double hp = plane->a * x + plane->b * y + plane->c, t[3];
            if (!region[i] || !(hp > 1e-3)) {
                memcpy(out + 3 * i, plate + 3 * i, 3);
                continue;
            }
            texel(&m, &mp, (int)x, (int)y, t);
            for (int c = 0; c < 3; c++)
                out[3 * i + c] = to8(t[c] * sh.lp[3 * i + c] / rep->lit[c]);
            rep->pixels++;
            rep->near_px_per_m = fmax(rep->near_px_per_m, hp / SP_RETEXTURE_PERSON_M);
            rep->far_px_per_m = fmin(rep->far_px_per_m, hp / SP_RETEXTURE_PERSON_M);
        }
    if (!ret && !rep->pixels)
        ret = SP_ENODATA;
    free(sh.sat), free(sh.lp);
    mip_free(&m);
    return ret;
}
