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

/* Bilinear sample of channel ch of a w x h x nc float map at output texel (i, j) of an ow x oh image. */
static double sample(const float *map, int w, int h, int nc, int ch, int i, int j, int ow, int oh)
{
    double fx = ((double)i + 0.5) * w / ow - 0.5, fy = ((double)j + 0.5) * h / oh - 0.5;
    fx = fx < 0.0 ? 0.0 : fx > w - 1 ? w - 1 : fx;
    fy = fy < 0.0 ? 0.0 : fy > h - 1 ? h - 1 : fy;
    int x0 = (int)fx, y0 = (int)fy, x1 = x0 + 1 < w ? x0 + 1 : x0, y1 = y0 + 1 < h ? y0 + 1 : y0;
    double ax = fx - x0, ay = fy - y0;
#define AT(x, y) (double)map[((size_t)(y) * (size_t)w + (size_t)(x)) * (size_t)nc + (size_t)ch]
    return (1 - ay) * ((1 - ax) * AT(x0, y0) + ax * AT(x1, y0)) + ay * ((1 - ax) * AT(x0, y1) + ax * AT(x1, y1));
#undef AT
}

static int image_alloc(sp_export_image *im, int w, int h, int ch)
{
    im->width = w;
    im->height = h;
    im->channels = ch;
    im->pixels = malloc((size_t)w * (size_t)h * (size_t)ch);
    return im->pixels ? 0 : -ENOMEM;
}

static int bake_albedo(sp_export_image *im, const sp_face_asset *a, int w, int h)
{
    int ret = image_alloc(im, w, h, 3);
    for (int j = 0; !ret && j < h; j++)
        for (int i = 0; i < w; i++)
            for (int c = 0; c < 3; c++)
                im->pixels[((size_t)j * w + i) * 3 + c] =
                    to_u8(sp_srgb_encode(sample(a->albedo, a->tex_width, a->tex_height, 3, c, i, j, w, h)));
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
    float *d = malloc((size_t)w * (size_t)h * sizeof(float));
    int ret = d && s > 0.0 ? image_alloc(im, w, h, 3) : d ? SP_ECORRUPT : -ENOMEM;
    for (int j = 0; !ret && j < h; j++)
        for (int i = 0; i < w; i++)
            d[(size_t)j * w + i] =
                (float)sample(a->displacement, a->tex_width, a->tex_height, 1, 0, i, j, w, h);
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
