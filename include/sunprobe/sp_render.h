/* SPDX-License-Identifier: MIT */
/*
 * Physically based CPU renderer with an analytic adjoint (reverse-mode
 * gradients), the inner loop of SunStage fitting. One opaque renderer holds
 * every buffer (allocated at open); a plain scene struct describes the camera,
 * mesh, textures, material and lighting of one frame. The model, the units and
 * exactly which effects are differentiated are in pipeline/render/RENDERER.md.
 *
 * Conventions (all world quantities in metres):
 *  - camera: OpenCV pinhole, x_cam = R x_world + t, camera x right, y down,
 *    z forward; pixel (i, j) has its centre at u = i, v = j.
 *  - world up is +z (it only matters for the environment map).
 *  - textures: row 0 is the top of the image (UV v = 1), texel centres at
 *    ((i + 0.5) / w, 1 - (j + 0.5) / h), bilinear with clamp to edge.
 *  - environment map: SP_RENDER_ENV_H rows by SP_RENDER_ENV_W columns, RGB
 *    radiance; row i spans polar angle [i, i+1] * pi / H measured from +z
 *    (row 0 looks straight up), column j spans azimuth [j, j+1] * 2 pi / W
 *    measured from +x towards +y.
 */
#ifndef SUNPROBE_SP_RENDER_H
#define SUNPROBE_SP_RENDER_H

#include <stdint.h>

#include "sp_common.h"
#include "sp_mesh.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SP_RENDER_CLUSTERS 10 /* specular clusters; cluster-map ids >= this get no specular */
#define SP_RENDER_ENV_H 16
#define SP_RENDER_ENV_W 32
#define SP_RENDER_ENV_FLOATS (SP_RENDER_ENV_H * SP_RENDER_ENV_W * 3)
#define SP_RENDER_MAX_LIGHTS 8 /* fill lights per scene */
#define SP_RENDER_SHININESS_MIN 1.0
#define SP_RENDER_SHININESS_MAX 1e4

typedef struct sp_renderer sp_renderer;

typedef struct sp_renderer_settings {
    int width, height;      /* output image, pixels (default 224 x 224, at most 16384) */
    int supersample;        /* S: S x S samples per pixel, box filter (default 1, at most 8) */
    int shadow_size;        /* shadow map is N x N texels (default 256, 16..8192) */
    int max_sun_samples;    /* cap on scene.sun_samples for the area sun (default 16) */
    int cull_backfaces;     /* 1: skip camera-facing-away triangles (default 1); never in the shadow map */
    double near_plane;      /* camera-space z below which geometry is clipped away (default 0.01 m) */
    double far_plane;       /* and above which (default 1e4 m) */
    /* Capacity hints so the first frames do not allocate; a larger mesh grows the buffers once. */
    uint32_t max_vertices, max_triangles;
    /*
     * SP_RENDER_SKIP_* bits: per-pixel decomposition buffers sp_render does not
     * fill (their sp_render_outputs pointers are then NULL), saving their
     * clearing and accumulation. Default 0: every buffer (the original behaviour).
     * image, radiance, coverage and the per-sample buffers are always written.
     */
    unsigned skip_outputs;
    /*
     * 1: sp_render_fit_l2 reconstructs the surface, shades (sun, lobe, soft
     * shadow, SH ambient), tone-maps (supersample 1) and differentiates all
     * of it in float structure-of-arrays kernels (faster; loss and gradients
     * then agree with the classic double path to ~1e-5 and ~1e-4 relative
     * instead of bit for bit). Such a call keeps no state for
     * sp_render_backward, which then returns -EINVAL until the next
     * sp_render; it writes image and radiance only when `out` is non-NULL,
     * and gives no barycentrics (out->bary NULL). Default 0. sp_render and sp_render_backward are unaffected.
     */
    int fit_float;
} sp_renderer_settings;

#define SP_RENDER_SKIP_DIFFUSE 0x01u
#define SP_RENDER_SKIP_SPECULAR 0x02u
#define SP_RENDER_SKIP_AMBIENT 0x04u
#define SP_RENDER_SKIP_FILL 0x08u
#define SP_RENDER_SKIP_VISIBILITY 0x10u
#define SP_RENDER_SKIP_NORMAL 0x20u
#define SP_RENDER_SKIP_ALBEDO 0x40u
#define SP_RENDER_SKIP_DECOMPOSITION 0x7fu /* all of the above */

/* A borrowed float texture: width * height * channels values, row 0 at the top (v = 1). */
typedef struct sp_render_texture {
    int width, height;
    const float *data;
} sp_render_texture;

/* A borrowed uint8 cluster-id map, row 0 at the top; sampled nearest. */
typedef struct sp_render_cluster_map {
    int width, height;
    const uint8_t *data;
} sp_render_cluster_map;

typedef struct sp_render_camera {
    double fx, fy, cx, cy; /* intrinsics, pixels of the output image */
    double R[9];           /* world -> camera rotation, row-major */
    double t[3];           /* world -> camera translation, metres */
} sp_render_camera;

enum sp_render_light_type {
    SP_RENDER_LIGHT_DIRECTIONAL = 0, /* vec = direction towards the light; rgb = irradiance */
    SP_RENDER_LIGHT_POINT = 1,       /* vec = world position; rgb = intensity, falls off as 1/d^2 */
};

/* Extra fill light for relighting: unshadowed Lambert + the same specular; forward only. */
typedef struct sp_render_light {
    enum sp_render_light_type type;
    double vec[3];
    double rgb[3];
} sp_render_light;

enum sp_render_shadow_mode {
    SP_RENDER_SHADOW_RENDER = 0, /* render the shadow map for this frame (default) */
    SP_RENDER_SHADOW_REUSE = 1,  /* reuse the map and its frame from the previous sp_render (see RENDERER.md) */
    SP_RENDER_SHADOW_OFF = 2,    /* V = 1 everywhere */
};

/*
 * One frame's scene. Every pointer is borrowed for the duration of the call
 * and must stay unchanged between an sp_render and the sp_render_backward
 * that follows it. Fill with sp_render_scene_defaults() first.
 */
typedef struct sp_render_scene {
    sp_render_camera camera;
    const sp_mesh *mesh;                 /* required; positions are world space */
    sp_render_texture albedo;            /* RGB linear albedo; required */
    sp_render_texture displacement;      /* 1 channel, metres along the coarse normal; data NULL = none */
    sp_render_cluster_map clusters;      /* data NULL = cluster 0 everywhere */
    double ks[SP_RENDER_CLUSTERS];       /* specular intensity per cluster (>= 0) */
    double shininess[SP_RENDER_CLUSTERS]; /* Blinn-Phong exponent s, clamped to [1, 1e4] */
    const float *env;                    /* SP_RENDER_ENV_FLOATS radiance values (RGB), NULL = black */
    double sun_dir[3];       /* towards the sun, any length > 1e-12 (normalised inside) */
    double sun_intensity;    /* white irradiance at normal incidence, >= 0 */
    double sun_angular_radius; /* radians; > 0 with sun_samples > 1 makes an area sun (forward only) */
    int sun_samples;         /* directions sampled over the sun disk (default 1) */
    /*
     * Radians, 0..pi/2 (default 0); > 0 makes the sun a disk of this angular radius in one pass (forward
     * only; sun_samples > 1 takes precedence): soft shadows from one map (percentage-closer, the penumbra
     * from the blocker's distance), diffuse wrapped over the terminator as the disk sets, and the
     * Blinn-Phong lobe widened by the disk (1 / s' = 1 / s + r^2 / 16). RENDERER.md, "Soft sun".
     */
    double sun_soft_radius;
    /*
     * 1: the sun is a point light at sun_position (world, metres) instead (forward only): direction and
     * sun_intensity / d^2 per surface point (sun_intensity = irradiance at 1 m), shadowed through the
     * orthographic map along the light's direction to the centre of the shadow frame (RENDERER.md,
     * "Point sun"). Default 0.
     */
    int sun_is_point;
    double sun_position[3];
    double exposure;         /* linear scale before the tone map, >= 0 (default 1) */
    double background[3];    /* linear radiance of pixels no triangle covers (default 0) */
    /* Soft shadow test V = 1 - sigmoid(k (d_hit - b d_map)); depth units in RENDERER.md. */
    double shadow_k;         /* default 800 */
    double shadow_bias;      /* b, default 1.0015 */
    double shadow_depth_offset; /* depth of the shadow frame's centre, bounding radii (default 10) */
    double shadow_center[3]; /* shadow frame centre, used when shadow_radius > 0 ... */
    double shadow_radius;    /* ... else fitted to the displaced mesh's bounding box (default 0) */
    enum sp_render_shadow_mode shadow_mode;
    int n_lights;            /* fill lights, at most SP_RENDER_MAX_LIGHTS */
    sp_render_light lights[SP_RENDER_MAX_LIGHTS];
} sp_render_scene;

/*
 * What sp_render produced; all pointers are owned by the renderer and valid
 * until its next sp_render or sp_renderer_close. Per-pixel buffers are
 * width * height (times 3 for RGB, interleaved), box filtered over the pixel's
 * samples with 0 where no triangle covers a sample (so they are premultiplied
 * by coverage). Per-sample buffers are sample_width * sample_height, the
 * supersampled grid (the same as pixels when supersample is 1).
 * diffuse .. albedo are NULL when settings.skip_outputs skips them and after
 * sp_render_fit_l2, and bary too after sp_render_fit_l2 with settings.fit_float.
 */
typedef struct sp_render_outputs {
    int width, height;
    int sample_width, sample_height;
    const float *image;      /* RGB display values in [0, 1): gamma(reinhard(exposure * radiance)) */
    const float *radiance;   /* RGB linear radiance before exposure, background included */
    const float *diffuse;    /* RGB sun diffuse (shadowed) */
    const float *specular;   /* RGB sun specular (shadowed) */
    const float *ambient;    /* RGB environment diffuse */
    const float *fill;       /* RGB fill lights */
    const float *visibility; /* sun visibility V in [0, 1] */
    const float *normal;     /* world shading normal (xyz), unit per sample */
    const float *albedo;     /* RGB sampled albedo */
    const float *coverage;   /* fraction of covered samples */
    const int32_t *tri_id;   /* per sample: triangle index or -1 */
    const float *bary;       /* per sample: 3 perspective-correct barycentrics, 0 where uncovered */
    const float *depth;      /* per sample: camera-space z in metres, 0 where uncovered */
    const int32_t *shadow_texel; /* per sample: id of the shadow-map texel footprint, -1 if none */
} sp_render_outputs;

/*
 * Gradients of a scalar loss, ADDED to what the struct holds (so frames can be
 * accumulated); zero it first with sp_render_grads_zero. Arrays are owned by
 * the caller, sized as the scene's inputs; a NULL array skips that group (and
 * the work behind it). Directions: see RENDERER.md for what is differentiated.
 */
typedef struct sp_render_grads {
    double *albedo;        /* 3 * albedo.width * albedo.height */
    double *displacement;  /* displacement.width * displacement.height */
    double *env;           /* SP_RENDER_ENV_FLOATS */
    double *positions;     /* 3 * mesh->n_vertices, world space */
    double ks[SP_RENDER_CLUSTERS];
    double shininess[SP_RENDER_CLUSTERS]; /* 0 where s was clamped */
    double sun_dir[3];     /* w.r.t. the raw scene.sun_dir (normalisation included); shading only, not shadows */
    double sun_intensity;
    double exposure;
    double camera_R[9];    /* w.r.t. each entry of R, unconstrained */
    double camera_t[3];
    double fx, fy, cx, cy;
} sp_render_grads;

/* The float kernel set renderers opened now use: "avx2" or "base" (SP_RENDER_SIMD overrides; RENDERER.md). */
SP_API const char *sp_render_kernel_set(void);
/* Fills documented defaults (224 x 224, S = 1, shadow 256, near 0.01, far 1e4). */
SP_API void sp_renderer_default_settings(sp_renderer_settings *s);
/* Allocates every buffer; *out is owned by the caller, free with sp_renderer_close. */
SP_API int sp_renderer_open(sp_renderer **out, const sp_renderer_settings *s);
/* Frees the renderer and sets *r = NULL; accepts NULL and half-built renderers. */
SP_API void sp_renderer_close(sp_renderer **r);

/* Scene defaults: identity camera with fx = fy = 200 centred on 224 x 224, ks 0, shininess 16,
 * sun straight up (+z) with intensity 0, exposure 1, shadow k 800, b 1.0015, offset 10. */
SP_API void sp_render_scene_defaults(sp_render_scene *scene);

/*
 * Renders the scene (borrowed for the call). *out receives views of
 * renderer-owned buffers. Returns 0, -EINVAL for a bad scene (with a log
 * line naming the field) or -ENOMEM if growing for a larger mesh failed.
 */
SP_API int sp_render(sp_renderer *r, const sp_render_scene *scene, sp_render_outputs *out);

/*
 * Reverse mode: given dL/d(image) (3 * width * height floats, borrowed),
 * adds dL/d(parameter) to *grads. Must follow sp_render of the same,
 * unchanged scene (it reuses that render's triangle ids, geometry and
 * per-sample sun/shadow terms; it never re-rasterises). May be called several
 * times per render (e.g. for several losses). Returns SP_EUNSUPPORTED for
 * scenes with an area sun or fill lights (forward only), -EINVAL without a
 * preceding render of this mesh.
 */
SP_API int sp_render_backward(sp_renderer *r, const sp_render_scene *scene, const float *dL_dimage,
                              sp_render_grads *grads);

/* Zeroes the arrays (sized from the scene) and scalars of grads; NULL arrays stay NULL. */
SP_API void sp_render_grads_zero(sp_render_grads *grads, const sp_render_scene *scene);

/*
 * Masked L2 loss: L = sum_p m_p sum_c (image - target)^2 / max(sum_p m_p, 1e-12),
 * with mask NULL meaning all ones. Writes L to *loss and, when dL_dimage is
 * non-NULL, 2 m_p (image - target) / sum m into it (3 * width * height floats).
 * All arrays borrowed; returns 0 or -EINVAL.
 */
SP_API int sp_render_l2_loss(const float *image, const float *target, const float *mask, int width,
                             int height, double *loss, float *dL_dimage);

/*
 * Fused fitting step: render + masked L2 loss + adjoint in one sweep, the
 * fast path for fitting loops. Equivalent to
 *
 *     sp_render(r, scene, &o);
 *     sp_render_l2_loss(o.image, target, mask, width, height, loss, dL);
 *     sp_render_backward(r, scene, dL, grads);
 *
 * with the same loss (bit for bit) and the same gradients up to rounding
 * (~1e-7 relative: the classic backward reads float copies of the forward's
 * shadow and lobe terms, the fused one their double originals). It shades
 * each sample once and differentiates it while its surface reconstruction is
 * still at hand, and writes no decomposition buffers.
 *
 * target (3 * width * height floats) and mask (width * height, NULL = all
 * ones) are borrowed and fixed by the caller (unlike o.coverage, which
 * changes with the render). grads: added to, as in sp_render_backward; NULL
 * computes only the loss. out (may be NULL) receives image, radiance,
 * coverage and the per-sample buffers; diffuse, specular, ambient, fill,
 * visibility, normal and albedo are NULL. sp_render_backward may follow it
 * (e.g. for a second loss), except with settings.fit_float (see there). Returns 0, -EINVAL (bad arguments or scene),
 * -ENOMEM, or SP_EUNSUPPORTED for an area sun or fill lights (nothing done).
 */
SP_API int sp_render_fit_l2(sp_renderer *r, const sp_render_scene *scene, const float *target, const float *mask,
                            double *loss, sp_render_grads *grads, sp_render_outputs *out);

#ifdef __cplusplus
}
#endif
#endif
