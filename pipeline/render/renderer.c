/* SPDX-License-Identifier: MIT */
/* Public entry points of the renderer: lifecycle, validation, the forward pass and the L2 loss helper. */
#include "sunprobe/sp_render.h"

#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

#include "pipeline/render/render_internal.h"
#include "pipeline/render/shade_simd.h"
#include "pipeline/render/simd_kernels.h"
#include "pipeline/render/tonemap.h"
#include "pipeline/render/vec3.h"

#define MODULE "render"
#define PASS_BASE 1
#define PASS_SUN 2
#define MAX_TEXTURE_SIDE 32768

void sp_renderer_default_settings(sp_renderer_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->width = 224;
    s->height = 224;
    s->supersample = 1;
    s->shadow_size = 256;
    s->max_sun_samples = 16;
    s->cull_backfaces = 1;
    s->near_plane = 0.01;
    s->far_plane = 1e4;
    s->max_vertices = 16384;
    s->max_triangles = 32768;
}

void sp_render_scene_defaults(sp_render_scene *sc)
{
    if (!sc)
        return;
    memset(sc, 0, sizeof(*sc));
    sc->camera.fx = sc->camera.fy = 200.0;
    sc->camera.cx = sc->camera.cy = 111.5;
    sc->camera.R[0] = sc->camera.R[4] = sc->camera.R[8] = 1.0;
    for (int c = 0; c < SP_RENDER_CLUSTERS; c++)
        sc->shininess[c] = 16.0;
    sc->sun_dir[2] = 1.0;
    sc->sun_samples = 1;
    sc->exposure = 1.0;
    sc->shadow_k = 800.0;
    sc->shadow_bias = 1.0015;
    sc->shadow_depth_offset = 10.0;
    sc->shadow_mode = SP_RENDER_SHADOW_RENDER;
}

void sp_renderer_close(sp_renderer **pr)
{
    if (!pr || !*pr)
        return;
    sp_renderer *r = *pr;
    float **f[] = {&r->image, &r->radiance, &r->diffuse, &r->specular, &r->ambient, &r->fill,
                   &r->visibility, &r->normal, &r->albedo, &r->coverage, &r->bary, &r->depth};
    for (size_t i = 0; i < sizeof(f) / sizeof(f[0]); i++)
        free(*f[i]);
    free(r->radiance64);
    free(r->image64);
    free(r->sun_cache);
    free(r->recs);
    free(r->row_first);
    free(r->batches);
    free(r->tri_id);
    free(r->shadow_texel);
    free(r->env_basis);
    geom_free(&r->geo);
    shadow_map_free(&r->sm);
    free(r);
    *pr = NULL;
}

static int bad(const char *what)
{
    sp_log(SP_LOG_ERROR, MODULE, "invalid %s", what);
    return -EINVAL;
}

static int validate_settings(const sp_renderer_settings *s)
{
    if (s->width < 1 || s->width > 16384 || s->height < 1 || s->height > 16384)
        return bad("settings width/height (1..16384)");
    if (s->supersample < 1 || s->supersample > 8)
        return bad("settings supersample (1..8)");
    if (s->shadow_size < 16 || s->shadow_size > 8192)
        return bad("settings shadow_size (16..8192)");
    if (s->max_sun_samples < 1 || s->max_sun_samples > 4096)
        return bad("settings max_sun_samples (1..4096)");
    if (!(s->near_plane > 0.0) || !(s->far_plane > s->near_plane) || !isfinite(s->far_plane))
        return bad("settings near/far planes (0 < near < far, finite)");
    return 0;
}

#define HUGE_PAGE ((size_t)2 << 20)

/*
 * A zeroed image plane. Planes of 2 MB or more are asked for in transparent huge pages where the kernel
 * offers them (madvise mode, Debian's default): a 1024 x 1024 relight at 2x2 samples first-touches about
 * 230 MB, and faulting that in 4 kB pages was half of the command's CPU time (0.89 s -> 0.36 s median with
 * huge pages). The contents are the same zeros either way.
 */
static void *plane_calloc(size_t n, size_t size)
{
    if (size && n > SIZE_MAX / size)
        return NULL;
    size_t bytes = n * size;
#ifdef MADV_HUGEPAGE
    if (bytes >= HUGE_PAGE) {
        size_t rounded = (bytes + HUGE_PAGE - 1) / HUGE_PAGE * HUGE_PAGE;
        void *p = aligned_alloc(HUGE_PAGE, rounded);
        if (p) {
            madvise(p, rounded, MADV_HUGEPAGE); /* advice only: without it the plane is ordinary memory */
            memset(p, 0, bytes);
            return p;
        }
    }
#endif
    return calloc(n, size);
}

static int alloc_buffers(sp_renderer *r)
{
    r->npix = (size_t)r->set.width * (size_t)r->set.height;
    r->nsamp = (size_t)r->sw * (size_t)r->sh;
    int ok = 1;
    float **rgb[] = {&r->image, &r->radiance, &r->diffuse, &r->specular, &r->ambient, &r->fill, &r->normal,
                     &r->albedo};
    for (size_t i = 0; i < sizeof(rgb) / sizeof(rgb[0]); i++)
        ok &= (*rgb[i] = plane_calloc(r->npix * 3, sizeof(float))) != NULL;
    ok &= (r->radiance64 = plane_calloc(r->npix * 3, sizeof(double))) != NULL;
    ok &= (r->image64 = plane_calloc(r->npix * 3, sizeof(double))) != NULL;
    ok &= (r->visibility = plane_calloc(r->npix, sizeof(float))) != NULL;
    ok &= (r->coverage = plane_calloc(r->npix, sizeof(float))) != NULL;
    ok &= (r->bary = plane_calloc(r->nsamp * 3, sizeof(float))) != NULL;
    ok &= (r->depth = plane_calloc(r->nsamp, sizeof(float))) != NULL;
    ok &= (r->tri_id = plane_calloc(r->nsamp, sizeof(int32_t))) != NULL;
    ok &= (r->sun_cache = plane_calloc(r->nsamp, sizeof(sun_cache))) != NULL;
    /* S^2 <= 64 = SIMD_BATCH records: one pixel's (classic fused) or one batch's (fit_float) */
    ok &= (r->recs = calloc(SIMD_BATCH, sizeof(shade_rec))) != NULL;
    ok &= (r->row_first = calloc(SIMD_BATCH + 1, sizeof(int))) != NULL;
    if (r->set.fit_float)
        ok &= (r->batches = calloc(1, sizeof(simd_batch))) != NULL;
    ok &= (r->shadow_texel = plane_calloc(r->nsamp, sizeof(int32_t))) != NULL;
    ok &= (r->env_basis = calloc((size_t)ENV_TEXELS * ENV_SH_N, sizeof(double))) != NULL;
    return ok ? 0 : -ENOMEM;
}

int sp_renderer_open(sp_renderer **out, const sp_renderer_settings *s)
{
    if (!out || !s)
        return -EINVAL;
    *out = NULL;
    int err = validate_settings(s);
    if (err)
        return err;
    sp_renderer *r = calloc(1, sizeof(*r));
    if (!r)
        return -ENOMEM;
    r->set = *s;
    r->sw = s->width * s->supersample;
    r->sh = s->height * s->supersample;
    err = alloc_buffers(r);
    if (!err)
        err = shadow_map_init(&r->sm, s->shadow_size);
    if (!err)
        err = geom_reserve(&r->geo, s->max_vertices, s->max_triangles);
    if (!err)
        err = geom_reserve_raster(&r->geo, r->sw + r->sh);
    if (!err)
        err = shadow_map_reserve(&r->sm, s->max_vertices);
    if (err) {
        sp_renderer_close(&r);
        return err;
    }
    env_basis_init(r->env_basis);
    if (s->fit_float) { /* the fastest kernel set this CPU runs, once per renderer */
        r->simd = simd_kernels_select();
        sp_log(SP_LOG_DEBUG, MODULE, "fit_float kernels: %s (%d lanes)", r->simd->name, r->simd->lanes);
    }
    *out = r;
    return 0;
}

static int finite_n(const double *v, int n)
{
    for (int i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

static int texture_ok(int w, int h, const void *data)
{
    return data && w >= 1 && h >= 1 && w <= MAX_TEXTURE_SIDE && h <= MAX_TEXTURE_SIDE;
}

static int validate_camera(const sp_render_camera *c)
{
    if (!finite_n(&c->fx, 4) || !(c->fx > 0.0) || !(c->fy > 0.0))
        return bad("camera intrinsics (finite, fx and fy > 0)");
    if (!finite_n(c->R, 9) || !finite_n(c->t, 3))
        return bad("camera pose (finite R and t)");
    return 0;
}

static int validate_material(const sp_render_scene *sc)
{
    if (!texture_ok(sc->albedo.width, sc->albedo.height, sc->albedo.data))
        return bad("albedo texture (data and size 1..32768 required)");
    if (sc->displacement.data && !texture_ok(sc->displacement.width, sc->displacement.height, sc->displacement.data))
        return bad("displacement texture size");
    if (sc->clusters.data && !texture_ok(sc->clusters.width, sc->clusters.height, sc->clusters.data))
        return bad("cluster map size");
    for (int c = 0; c < SP_RENDER_CLUSTERS; c++)
        if (!isfinite(sc->ks[c]) || sc->ks[c] < 0.0 || !isfinite(sc->shininess[c]))
            return bad("ks (finite, >= 0) or shininess (finite)");
    return 0;
}

static int validate_lighting(const sp_render_scene *sc)
{
    if (!finite_n(sc->sun_dir, 3) || !(v3_norm(sc->sun_dir) > 1e-12))
        return bad("sun_dir (finite, non-zero)");
    if (!isfinite(sc->sun_intensity) || sc->sun_intensity < 0.0)
        return bad("sun_intensity (finite, >= 0)");
    if (!(sc->sun_angular_radius >= 0.0 && sc->sun_angular_radius <= 0.5) || sc->sun_samples < 1)
        return bad("area sun (angular radius 0..0.5 rad, samples >= 1)");
    if (!(sc->sun_soft_radius >= 0.0 && sc->sun_soft_radius <= 0.5 * M_PI))
        return bad("soft sun (angular radius 0..pi/2 rad)");
    if (sc->sun_is_point && !finite_n(sc->sun_position, 3))
        return bad("sun_position (finite)");
    if (!isfinite(sc->exposure) || sc->exposure < 0.0 || !finite_n(sc->background, 3))
        return bad("exposure (finite, >= 0) or background");
    if (!isfinite(sc->shadow_k) || sc->shadow_k < 0.0 || !isfinite(sc->shadow_bias) || !(sc->shadow_bias > 0.0))
        return bad("shadow_k (finite, >= 0) or shadow_bias (finite, > 0)");
    if (!isfinite(sc->shadow_depth_offset) || !(sc->shadow_depth_offset > 1.0) ||
        !finite_n(sc->shadow_center, 3) || !isfinite(sc->shadow_radius) || sc->shadow_radius < 0.0)
        return bad("shadow frame (offset > 1, finite centre, radius >= 0)");
    if (sc->shadow_mode < SP_RENDER_SHADOW_RENDER || sc->shadow_mode > SP_RENDER_SHADOW_OFF)
        return bad("shadow_mode");
    if (sc->n_lights < 0 || sc->n_lights > SP_RENDER_MAX_LIGHTS)
        return bad("n_lights (0..SP_RENDER_MAX_LIGHTS)");
    for (int j = 0; j < sc->n_lights; j++) {
        const sp_render_light *l = &sc->lights[j];
        if ((l->type != SP_RENDER_LIGHT_DIRECTIONAL && l->type != SP_RENDER_LIGHT_POINT) ||
            !finite_n(l->vec, 3) || !finite_n(l->rgb, 3) || l->rgb[0] < 0.0 || l->rgb[1] < 0.0 ||
            l->rgb[2] < 0.0)
            return bad("fill light (type, finite vec, rgb >= 0)");
    }
    return 0;
}

/*
 * sp_mesh_validate, shortened for a mesh whose counts, positions and indices
 * equal the last validated frame's (same: geom_mesh_unchanged; the key is
 * only taken by geom_forward after validation): only the UVs are not in the
 * key. An unreadable index array is refused before anything is compared.
 */
static int mesh_ok(const sp_renderer *r, const sp_mesh *m, int *same)
{
    *same = 0;
    if (m->n_triangles && (!m->tri_vertices || !m->tri_uvs))
        return 0;
    *same = geom_mesh_unchanged(&r->geo, m);
    if (!*same)
        return sp_mesh_validate(m) == 0;
    for (size_t i = 0; i < (size_t)m->n_uvs * 2; i++)
        if (!isfinite(m->uvs[i]))
            return 0;
    return 1;
}

static int validate_scene(const sp_renderer *r, const sp_render_scene *sc, int *same_mesh)
{
    *same_mesh = 0;
    if (!sc->mesh)
        return bad("scene mesh (NULL)");
    if (!mesh_ok(r, sc->mesh, same_mesh))
        return bad("scene mesh (indices out of range or non-finite values)");
    if (sc->mesh->n_triangles > (uint32_t)INT32_MAX)
        return bad("scene mesh (too many triangles)");
    int err = validate_camera(&sc->camera);
    if (!err)
        err = validate_material(sc);
    if (!err)
        err = validate_lighting(sc);
    return err;
}

static int ensure_capacity(sp_renderer *r, const sp_mesh *mesh)
{
    if (mesh->n_vertices > r->geo.cap_v || mesh->n_triangles > r->geo.cap_t)
        sp_log(SP_LOG_DEBUG, MODULE, "growing mesh buffers to %u vertices, %u triangles", mesh->n_vertices,
               mesh->n_triangles);
    int err = geom_reserve(&r->geo, mesh->n_vertices, mesh->n_triangles);
    if (!err)
        err = geom_reserve_raster(&r->geo, r->sw + r->sh);
    if (!err)
        err = shadow_map_reserve(&r->sm, mesh->n_vertices);
    if (err)
        r->have_render = 0;
    return err;
}

static int sun_sample_count(const sp_renderer *r, const sp_render_scene *sc)
{
    if (!(sc->sun_angular_radius > 0.0))
        return 1;
    return sc->sun_samples < r->set.max_sun_samples ? sc->sun_samples : r->set.max_sun_samples;
}

static void setup_frame(sp_renderer *r, const sp_render_scene *sc, int n_sun)
{
    const sp_render_camera *c = &sc->camera;
    r->cam = (raster_camera){.fx = c->fx, .fy = c->fy, .cx = c->cx, .cy = c->cy, .inv_fx = 1.0 / c->fx,
                             .inv_fy = 1.0 / c->fy, .inv_s = 1.0 / (double)r->set.supersample,
                             .near_plane = r->set.near_plane, .far_plane = r->set.far_plane,
                             .supersample = r->set.supersample, .sample_width = r->sw, .sample_height = r->sh,
                             .cull_backfaces = r->set.cull_backfaces};
    shade_ctx *x = &r->ctx;
    memset(x, 0, sizeof(*x));
    x->sc = sc;
    x->geo = &r->geo;
    x->cam = &r->cam;
    m3_tmul(c->R, c->t, x->eye);
    v3_scale(x->eye, -1.0, x->eye);
    x->sun_len = v3_normalize(sc->sun_dir, x->sun_l);
    x->sun_I = sc->sun_intensity / (double)n_sun;
    env_project(r->env_basis, sc->env, &x->sh);
    x->shadow_k = sc->shadow_k;
    x->shadow_b = sc->shadow_bias;
    for (int k = 0; k < SP_RENDER_CLUSTERS; k++) {
        double s = sc->shininess[k];
        x->ks[k] = sc->ks[k];
        x->s_clamped[k] = !(s >= SP_RENDER_SHININESS_MIN && s <= SP_RENDER_SHININESS_MAX);
        x->s[k] = s < SP_RENDER_SHININESS_MIN ? SP_RENDER_SHININESS_MIN
                                              : (s > SP_RENDER_SHININESS_MAX ? SP_RENDER_SHININESS_MAX : s);
    }
    if (n_sun == 1 && sc->sun_soft_radius > 0.0) { /* the soft sun (forward only) */
        double rr = sc->sun_soft_radius;
        x->soft_tan = tan(rr < 1.4 ? rr : 1.4); /* the penumbra is capped anyway; no tan(pi/2) */
        x->soft_sin = sin(rr);
        for (int k = 0; k < SP_RENDER_CLUSTERS; k++) /* the lobe seen through the disk: variances add */
            x->s[k] = fmax(SP_RENDER_SHININESS_MIN, 1.0 / (1.0 / x->s[k] + rr * rr / 16.0));
    }
}

/* The shadow map for direction l: NULL when off; the previous one for REUSE (unless force). */
const shadow_map *render_prepare_shadow(sp_renderer *r, const sp_render_scene *sc, const double l[3], int force)
{
    if (sc->shadow_mode == SP_RENDER_SHADOW_OFF)
        return NULL;
    if (sc->shadow_mode == SP_RENDER_SHADOW_REUSE && r->sm.valid && !force)
        return &r->sm;
    double c[3], rad;
    if (sc->shadow_radius > 0.0) {
        memcpy(c, sc->shadow_center, sizeof(c));
        rad = sc->shadow_radius;
    } else {
        shadow_bounds(r->geo.pd, sc->mesh->n_vertices, c, &rad);
    }
    double lp[3];
    if (sc->sun_is_point) { /* towards the point light from the frame's centre (or along l if it is there) */
        v3_sub(sc->sun_position, c, lp);
        if (v3_normalize(lp, lp) > 1e-9)
            l = lp;
    }
    shadow_frame_init(&r->sm.f, l, c, rad, sc->shadow_depth_offset, r->sm.n);
    shadow_map_render(&r->sm, r->geo.pd, sc->mesh);
    return &r->sm;
}

/* The decomposition buffer if the settings ask for it, else NULL. */
static float *wanted(const sp_renderer *r, float *buf, unsigned bit)
{
    return (r->set.skip_outputs & bit) ? NULL : buf;
}

static void clear_pixels(sp_renderer *r)
{
    size_t n3 = r->npix * 3;
    r->out_diffuse = wanted(r, r->diffuse, SP_RENDER_SKIP_DIFFUSE);
    r->out_specular = wanted(r, r->specular, SP_RENDER_SKIP_SPECULAR);
    r->out_ambient = wanted(r, r->ambient, SP_RENDER_SKIP_AMBIENT);
    r->out_fill = wanted(r, r->fill, SP_RENDER_SKIP_FILL);
    r->out_visibility = wanted(r, r->visibility, SP_RENDER_SKIP_VISIBILITY);
    r->out_normal = wanted(r, r->normal, SP_RENDER_SKIP_NORMAL);
    r->out_albedo = wanted(r, r->albedo, SP_RENDER_SKIP_ALBEDO);
    float *rgb[] = {r->out_diffuse, r->out_specular, r->out_ambient, r->out_fill, r->out_normal, r->out_albedo};
    for (size_t i = 0; i < sizeof(rgb) / sizeof(rgb[0]); i++)
        if (rgb[i])
            memset(rgb[i], 0, n3 * sizeof(float));
    memset(r->radiance64, 0, n3 * sizeof(double));
    if (r->out_visibility)
        memset(r->visibility, 0, r->npix * sizeof(float));
    memset(r->coverage, 0, r->npix * sizeof(float));
    for (size_t s = 0; s < r->nsamp; s++)
        r->shadow_texel[s] = -1;
}

static void accumulate_base(sp_renderer *r, size_t p, const shade_rec *rec, double w)
{
    for (int c = 0; c < 3; c++) {
        size_t i = p * 3 + (size_t)c;
        r->radiance64[i] += w * (rec->amb[c] + rec->fill[c]);
        if (r->out_ambient)
            r->out_ambient[i] += to_float(w * rec->amb[c]);
        if (rec->fill[c] != 0.0 && r->out_fill)
            r->out_fill[i] += to_float(w * rec->fill[c]);
        if (r->out_normal)
            r->out_normal[i] += to_float(w * rec->n[c]);
        if (r->out_albedo)
            r->out_albedo[i] += to_float(w * rec->a[c]);
    }
    r->coverage[p] += (float)w;
}

static void accumulate_sun(sp_renderer *r, size_t p, const shade_rec *rec, double w, double wv)
{
    for (int c = 0; c < 3; c++) {
        size_t i = p * 3 + (size_t)c;
        r->radiance64[i] += w * (rec->diff[c] + rec->spec);
        if (r->out_diffuse)
            r->out_diffuse[i] += to_float(w * rec->diff[c]);
        if (r->out_specular)
            r->out_specular[i] += to_float(w * rec->spec);
    }
    if (r->out_visibility)
        r->out_visibility[p] += to_float(wv * rec->V);
}

/* One sweep over covered samples; PASS_SUN adds the sun from direction l with irradiance I. */
static void shade_pass(sp_renderer *r, int flags, const double l[3], double I, const shadow_map *sm, double wsun)
{
    const shade_ctx *ctx = &r->ctx;
    int S = r->set.supersample;
    double w = 1.0 / (double)(S * S);
    for (int sy = 0; sy < r->sh; sy++) {
        for (int sx = 0; sx < r->sw; sx++) {
            size_t s = (size_t)sy * (size_t)r->sw + (size_t)sx;
            int32_t tri = r->tri_id[s];
            shade_rec rec;
            if (tri < 0)
                continue;
            if (!shade_geometry(ctx, sx, sy, tri, &rec)) { /* degenerate hit: treat as uncovered */
                r->tri_id[s] = -1;
                r->depth[s] = FLT_MAX;
                continue;
            }
            size_t p = (size_t)(sy / S) * (size_t)r->set.width + (size_t)(sx / S);
            if (flags & PASS_BASE) {
                shade_ambient(ctx, &rec);
                if (ctx->sc->n_lights)
                    shade_fill(ctx, &rec);
                accumulate_base(r, p, &rec, w);
            }
            if (flags & PASS_SUN) {
                double lp[3], Ip = I;
                if (ctx->sc->sun_is_point) { /* this point's own direction and falloff */
                    v3_sub(ctx->sc->sun_position, rec.p, lp);
                    double d = v3_normalize(lp, lp);
                    Ip = d > 1e-6 ? I / (d * d) : 0.0;
                }
                shade_sun(ctx, &rec, ctx->sc->sun_is_point ? lp : l, Ip, sm, r->sun_cache + s);
                accumulate_sun(r, p, &rec, w, w * wsun);
                r->shadow_texel[s] = rec.shadow.texel;
            }
        }
    }
}

/* Area sun: Vogel-spiral directions over a disk of the given angular radius around l. */
static void area_sun(sp_renderer *r, const sp_render_scene *sc, int n)
{
    shadow_frame basis;
    const double *l = r->ctx.sun_l;
    shadow_frame_init(&basis, l, l, 1.0, 2.0, 16);
    for (int j = 0; j < n; j++) {
        double rho = sc->sun_angular_radius * sqrt(((double)j + 0.5) / (double)n);
        double phi = (double)j * 2.39996322972865332; /* golden angle */
        double dir[3], u[3];
        for (int k = 0; k < 3; k++)
            dir[k] = cos(rho) * l[k] + sin(rho) * (cos(phi) * basis.e1[k] + sin(phi) * basis.e2[k]);
        v3_normalize(dir, u);
        const shadow_map *sm = render_prepare_shadow(r, sc, u, 1);
        shade_pass(r, PASS_SUN, u, r->ctx.sun_I, sm, 1.0 / (double)n);
    }
    r->sm.valid = 0; /* the last sample's map is not the sun's: REUSE must re-render */
}

static void resolve(sp_renderer *r, const sp_render_scene *sc)
{
    double bg_img[3]; /* most uncovered pixels share it: one pow each */
    for (int c = 0; c < 3; c++)
        bg_img[c] = tonemap_eval(sc->exposure * sc->background[c], NULL);
    for (size_t p = 0; p < r->npix; p++) {
        double bgw = 1.0 - (double)r->coverage[p];
        for (int c = 0; c < 3; c++) {
            size_t i = p * 3 + (size_t)c;
            if (bgw > 0.0)
                r->radiance64[i] += bgw * sc->background[c];
            r->image64[i] = bgw == 1.0 ? bg_img[c] : tonemap_eval(sc->exposure * r->radiance64[i], NULL);
            r->radiance[i] = to_float(r->radiance64[i]);
            r->image[i] = to_float(r->image64[i]);
        }
    }
    for (size_t s = 0; s < r->nsamp; s++)
        if (r->tri_id[s] < 0)
            r->depth[s] = 0.0f;
}

const double *render_image_f64(const sp_renderer *r)
{
    return r ? r->image64 : NULL;
}

void render_fill_outputs(const sp_renderer *r, sp_render_outputs *out)
{
    *out = (sp_render_outputs){
        .width = r->set.width, .height = r->set.height, .sample_width = r->sw, .sample_height = r->sh,
        .image = r->image, .radiance = r->radiance, .diffuse = r->out_diffuse, .specular = r->out_specular,
        .ambient = r->out_ambient, .fill = r->out_fill, .visibility = r->out_visibility,
        .normal = r->out_normal, .albedo = r->out_albedo, .coverage = r->coverage, .tri_id = r->tri_id,
        .bary = r->bary, .depth = r->depth, .shadow_texel = r->shadow_texel,
    };
}

int render_begin(sp_renderer *r, const sp_render_scene *sc, int need_backward, int want_bary, int *n_sun)
{
    int same_mesh;
    int err = validate_scene(r, sc, &same_mesh);
    if (!err)
        err = ensure_capacity(r, sc->mesh);
    if (err)
        return err;
    *n_sun = sun_sample_count(r, sc);
    if (need_backward && (*n_sun != 1 || sc->n_lights != 0 || sc->sun_soft_radius > 0.0 || sc->sun_is_point)) {
        sp_log(SP_LOG_ERROR, MODULE, "no gradients for an area sun or fill lights (forward only)");
        return SP_EUNSUPPORTED;
    }
    same_mesh = same_mesh && r->geo.key_valid; /* a grown geom (ensure_capacity) has no key: rebuild */
    geom_forward_known(&r->geo, sc->mesh, same_mesh, &sc->displacement, sc->camera.R, sc->camera.t);
    setup_frame(r, sc, *n_sun);
    raster_camera_draw(&r->cam, r->geo.xc, sc->mesh, r->tri_id, r->depth, want_bary ? r->bary : NULL,
                       r->geo.tri_k, r->geo.xs, r->geo.col_dx);
    return 0;
}

void render_end(sp_renderer *r, const sp_render_scene *sc, int n_sun)
{
    r->last_mesh = sc->mesh;
    r->last_nv = sc->mesh->n_vertices;
    r->last_nt = sc->mesh->n_triangles;
    r->have_render = 1;
    r->backward_ok = n_sun == 1 && sc->n_lights == 0 && !(sc->sun_soft_radius > 0.0) && !sc->sun_is_point;
}

int sp_render(sp_renderer *r, const sp_render_scene *sc, sp_render_outputs *out)
{
    if (!r || !sc || !out)
        return -EINVAL;
    int n_sun = 1;
    int err = render_begin(r, sc, 0, 1, &n_sun);
    if (err)
        return err;
    clear_pixels(r);
    if (n_sun == 1) {
        r->ctx.sm = render_prepare_shadow(r, sc, r->ctx.sun_l, 0);
        shade_pass(r, PASS_BASE | PASS_SUN, r->ctx.sun_l, r->ctx.sun_I, r->ctx.sm, 1.0);
    } else {
        shade_pass(r, PASS_BASE, r->ctx.sun_l, 0.0, NULL, 0.0);
        area_sun(r, sc, n_sun);
    }
    resolve(r, sc);
    render_fill_outputs(r, out);
    render_end(r, sc, n_sun);
    return 0;
}

int sp_render_backward(sp_renderer *r, const sp_render_scene *sc, const float *dL_dimage, sp_render_grads *grads)
{
    if (!r || !sc || !dL_dimage || !grads)
        return -EINVAL;
    if (!r->have_render || sc->mesh != r->last_mesh || sc->mesh->n_vertices != r->last_nv ||
        sc->mesh->n_triangles != r->last_nt) {
        sp_log(SP_LOG_ERROR, MODULE, "backward needs a preceding sp_render of the same scene");
        return -EINVAL;
    }
    if (!r->backward_ok) {
        sp_log(SP_LOG_ERROR, MODULE, "no gradients for an area sun or fill lights (forward only)");
        return SP_EUNSUPPORTED;
    }
    return render_backward_pass(r, sc, dL_dimage, grads);
}

void sp_render_grads_zero(sp_render_grads *g, const sp_render_scene *sc)
{
    if (!g)
        return;
    sp_render_grads keep = *g;
    memset(g, 0, sizeof(*g));
    g->albedo = keep.albedo;
    g->displacement = keep.displacement;
    g->env = keep.env;
    g->positions = keep.positions;
    if (!sc)
        return;
    if (g->albedo && sc->albedo.width > 0 && sc->albedo.height > 0)
        memset(g->albedo, 0, (size_t)sc->albedo.width * (size_t)sc->albedo.height * 3 * sizeof(double));
    if (g->displacement && sc->displacement.width > 0 && sc->displacement.height > 0)
        memset(g->displacement, 0,
               (size_t)sc->displacement.width * (size_t)sc->displacement.height * sizeof(double));
    if (g->env)
        memset(g->env, 0, SP_RENDER_ENV_FLOATS * sizeof(double));
    if (g->positions && sc->mesh)
        memset(g->positions, 0, (size_t)sc->mesh->n_vertices * 3 * sizeof(double));
}

int sp_render_l2_loss(const float *image, const float *target, const float *mask, int width, int height,
                      double *loss, float *dL_dimage)
{
    if (!image || !target || !loss || width < 1 || height < 1)
        return -EINVAL;
    size_t n = (size_t)width * (size_t)height;
    double msum = 0.0, sum = 0.0;
    for (size_t p = 0; p < n; p++) {
        double m = mask ? (double)mask[p] : 1.0;
        msum += m;
        for (int c = 0; c < 3; c++) {
            double d = (double)image[p * 3 + (size_t)c] - (double)target[p * 3 + (size_t)c];
            sum += m * d * d;
        }
    }
    double norm = msum > 1e-12 ? msum : 1e-12;
    *loss = sum / norm;
    if (!dL_dimage)
        return 0;
    for (size_t p = 0; p < n; p++) {
        double m = mask ? (double)mask[p] : 1.0;
        for (int c = 0; c < 3; c++) {
            size_t i = p * 3 + (size_t)c;
            dL_dimage[i] = to_float(2.0 * m * ((double)image[i] - (double)target[i]) / norm);
        }
    }
    return 0;
}
