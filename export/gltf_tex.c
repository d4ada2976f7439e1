/* SPDX-License-Identifier: MIT */
/* Textures of the exported face: sRGB albedo, specular/roughness from the cluster map, normal map from displacement. */
#include "export/gltf_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MOD "export"

double sp_export_roughness(double s)
{
    if (!(s >= 0.0))
        s = 0.0;
    if (s > 1e4) /* the renderer's clamp; also keeps Inf out */
        s = 1e4;
    double alpha = sqrt(2.0 / (s + 2.0)); /* Blinn-Phong s <-> Beckmann/GGX alpha: s = 2 / alpha^2 - 2 */
    return sqrt(alpha);                   /* glTF roughness is perceptual: alpha = roughness^2 */
}

double sp_export_specular(double ks)
{
    if (!(ks > 0.0))
        return 0.0;
    double v = ks / 0.04; /* F0 of glTF's default dielectric (ior 1.5) = full strength */
    return v > 1.0 ? 1.0 : v;
}

static uint8_t to_u8(double v)
{
    if (!(v > 0.0))
        return 0;
    return v >= 1.0 ? 255 : (uint8_t)(v * 255.0 + 0.5);
}

/* Mitchell-Netravali cubic (B = C = 1/3): little ringing, little blur, weights of any phase sum to 1. */
static double mitchell(double x)
{
    x = fabs(x);
    if (x < 1.0)
        return (7.0 * x * x * x - 12.0 * x * x + 16.0 / 3.0) / 6.0;
    if (x < 2.0)
        return (-7.0 / 3.0 * x * x * x + 12.0 * x * x - 20.0 * x + 32.0 / 3.0) / 6.0;
    return 0.0;
}

/*
 * One axis: n samples (stride sn between them, nc channels each) to m (stride dn). The kernel is
 * widened by n / m when shrinking (an area filter, no aliasing); weights are normalised per output
 * sample and the edge is clamped, so a constant stays that constant.
 */
static void resample_axis(const float *src, int n, size_t sn, float *dst, int m, size_t dn, int nc)
{
    double scale = (double)n / m, width = scale > 1.0 ? scale : 1.0, r = 2.0 * width;
    for (int o = 0; o < m; o++) {
        double centre = (o + 0.5) * scale - 0.5, acc[4] = { 0, 0, 0, 0 }, wsum = 0.0;
        for (int i = (int)floor(centre - r); i <= (int)ceil(centre + r); i++) {
            double w = mitchell((i - centre) / width);
            if (w == 0.0)
                continue;
            int k = i < 0 ? 0 : i >= n ? n - 1 : i;
            for (int c = 0; c < nc; c++)
                acc[c] += w * (double)src[(size_t)k * sn + (size_t)c];
            wsum += w;
        }
        for (int c = 0; c < nc; c++)
            dst[(size_t)o * dn + (size_t)c] = (float)(acc[c] / wsum);
    }
}

/* A w x h x nc (<= 4) float map resampled to ow x oh (rows, then columns); caller frees; NULL on no memory. */
float *sp_export_resample(const float *map, int w, int h, int nc, int ow, int oh)
{
    float *tmp = malloc((size_t)ow * (size_t)h * (size_t)nc * sizeof(float));
    float *out = malloc((size_t)ow * (size_t)oh * (size_t)nc * sizeof(float));
    if (!tmp || !out || nc < 1 || nc > 4) {
        free(tmp);
        free(out);
        return NULL;
    }
    size_t row = (size_t)nc;
    for (int j = 0; j < h; j++)
        resample_axis(map + (size_t)j * (size_t)w * row, w, row, tmp + (size_t)j * (size_t)ow * row, ow, row, nc);
    for (int i = 0; i < ow; i++)
        resample_axis(tmp + (size_t)i * row, h, (size_t)ow * row, out + (size_t)i * row, oh, (size_t)ow * row, nc);
    free(tmp);
    return out;
}

static int image_alloc(sp_export_image *im, int w, int h, int ch)
{
    im->width = w;
    im->height = h;
    im->channels = ch;
    im->pixels = malloc((size_t)w * (size_t)h * (size_t)ch);
    return im->pixels ? 0 : -ENOMEM;
}

/* Resampled in linear light, then encoded sRGB. */
static int bake_albedo(sp_export_image *im, const sp_face_asset *a, int w, int h)
{
    float *lin = sp_export_resample(a->albedo, a->tex_width, a->tex_height, 3, w, h);
    int ret = lin ? image_alloc(im, w, h, 3) : -ENOMEM;
    for (size_t i = 0; !ret && i < (size_t)w * (size_t)h * 3; i++)
        im->pixels[i] = to_u8(sp_srgb_encode((double)lin[i]));
    free(lin);
    return ret;
}

static int bake_spec(sp_export_image *im, const sp_face_asset *a, int w, int h)
{
    int ret = image_alloc(im, w, h, 4);
    for (int j = 0; !ret && j < h; j++)
        for (int i = 0; i < w; i++) {
            int cx = (int)(((double)i + 0.5) * a->cluster_width / w);
            int cy = (int)(((double)j + 0.5) * a->cluster_height / h);
            uint8_t id = a->clusters[(size_t)cy * (size_t)a->cluster_width + (size_t)cx];
            uint8_t *p = im->pixels + ((size_t)j * w + i) * 4;
            int ok = id < SP_RENDER_CLUSTERS;
            p[0] = 255; /* occlusion slot: unused */
            p[1] = to_u8(ok ? sp_export_roughness(a->shininess[id]) : 1.0);
            p[2] = 0; /* dielectric */
            p[3] = to_u8(ok ? sp_export_specular(a->ks[id]) : 0.0);
        }
    return ret;
}

/* Metres per unit of UV: sqrt(surface area / UV area) over the mesh; 0 when degenerate. */
static double metres_per_uv(const sp_mesh *m)
{
    double a3 = 0.0, a2 = 0.0;
    for (uint32_t t = 0; t < m->n_triangles; t++) {
        const uint32_t *v = m->tri_vertices + (size_t)t * 3, *u = m->tri_uvs + (size_t)t * 3;
        const float *p0 = m->positions + (size_t)v[0] * 3, *p1 = m->positions + (size_t)v[1] * 3,
                    *p2 = m->positions + (size_t)v[2] * 3;
        double e1[3], e2[3];
        for (int d = 0; d < 3; d++)
            e1[d] = (double)(p1[d] - p0[d]), e2[d] = (double)(p2[d] - p0[d]);
        double cx = e1[1] * e2[2] - e1[2] * e2[1], cy = e1[2] * e2[0] - e1[0] * e2[2],
               cz = e1[0] * e2[1] - e1[1] * e2[0];
        a3 += 0.5 * sqrt(cx * cx + cy * cy + cz * cz);
        const float *q0 = m->uvs + (size_t)u[0] * 2, *q1 = m->uvs + (size_t)u[1] * 2, *q2 = m->uvs + (size_t)u[2] * 2;
        a2 += 0.5 * fabs((double)((q1[0] - q0[0]) * (q2[1] - q0[1]) - (q2[0] - q0[0]) * (q1[1] - q0[1])));
    }
    return a2 > 1e-20 && a3 > 0.0 ? sqrt(a3 / a2) : 0.0;
}

/* Tangent space: x = +u (right), y = +v (up in the image), z = the surface normal. */
static int bake_normal(sp_export_image *im, const sp_face_asset *a, int w, int h)
{
    double s = metres_per_uv(&a->mesh);
    float *d = sp_export_resample(a->displacement, a->tex_width, a->tex_height, 1, w, h);
    int ret = d && s > 0.0 ? image_alloc(im, w, h, 3) : d ? SP_ECORRUPT : -ENOMEM;
    double dx = s / w, dy = s / h; /* metres per texel */
    for (int j = 0; !ret && j < h; j++)
        for (int i = 0; i < w; i++) {
            int il = i > 0 ? i - 1 : i, ir = i + 1 < w ? i + 1 : i;
            int ju = j > 0 ? j - 1 : j, jd = j + 1 < h ? j + 1 : j;
            double gx = ((double)d[(size_t)j * w + ir] - (double)d[(size_t)j * w + il]) / ((ir - il) * dx + 1e-300);
            double gy = ((double)d[(size_t)ju * w + i] - (double)d[(size_t)jd * w + i]) / ((jd - ju) * dy + 1e-300);
            if (ir == il)
                gx = 0.0;
            if (jd == ju)
                gy = 0.0;
            double n[3] = { -gx, -gy, 1.0 }, len = sqrt(n[0] * n[0] + n[1] * n[1] + 1.0);
            for (int c = 0; c < 3; c++)
                im->pixels[((size_t)j * w + i) * 3 + c] = to_u8(0.5 + 0.5 * n[c] / len);
        }
    free(d);
    return ret;
}

/* The map is used only when the fit kept it, but NaN or Inf anywhere means a corrupt directory either way. */
static int check_displacement(const sp_face_asset *a)
{
    size_t n = (size_t)a->tex_width * (size_t)a->tex_height;
    for (size_t i = 0; i < n; i++)
        if (!isfinite(a->displacement[i]))
            return SP_ECORRUPT;
    return 0;
}

int sp_export_textures_build(sp_export_textures *t, const sp_face_asset *a, int size, unsigned left_out)
{
    if (!t || !a || size < 0)
        return -EINVAL;
    memset(t, 0, sizeof(*t));
    int w = a->tex_width, h = a->tex_height;
    if (size > 0) {
        double k = (double)size / (w > h ? w : h);
        w = (int)lround(w * k);
        h = (int)lround(h * k);
        w = w < 1 ? 1 : w;
        h = h < 1 ? 1 : h;
    }
    int ret = check_displacement(a);
    if (ret) {
        sp_log(SP_LOG_ERROR, MOD, "displacement map holds NaN or Inf");
        return ret;
    }
    ret = bake_albedo(&t->albedo, a, w, h);
    t->has_specular = !(left_out & SP_FACE_LEFT_OUT_SPECULAR);
    if (!ret && t->has_specular)
        ret = bake_spec(&t->spec_rough, a, w, h);
    t->has_normal = !(left_out & SP_FACE_LEFT_OUT_DISPLACEMENT);
    if (!ret && t->has_normal)
        ret = bake_normal(&t->normal, a, w, h);
    if (ret)
        sp_export_textures_free(t);
    return ret;
}

void sp_export_textures_free(sp_export_textures *t)
{
    if (!t)
        return;
    free(t->albedo.pixels);
    free(t->spec_rough.pixels);
    free(t->normal.pixels);
    memset(t, 0, sizeof(*t));
}
