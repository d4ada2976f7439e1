/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe relight`'s pieces shared by its files: cmd_relight.c (options, view, light, render),
 * relight_io.c (environment maps in, images and passes out), relight_edit.c (backgrounds, paint).
 */
#ifndef SUNPROBE_TOOLS_RELIGHT_H
#define SUNPROBE_TOOLS_RELIGHT_H

#include <stdint.h>

#include "common/json.h"
#include "sunprobe/sp_face_model.h"
#include "sunprobe/sp_render.h"
#include "sunprobe/sp_sunstage.h"

#define MAX_FILLS 8

typedef struct fill_light {
    double az, el, intensity, rgb[3];
    int point; /* a point light 1 m from the head's centre, else directional */
} fill_light;

typedef struct relight_args {
    const char *dir, *out, *env, *capture;
    int background_keyframe, have_view; /* --background capture:N (-1: none) */
    const char *background_file;        /* --background FILE */
    const char *passes_dir;             /* --passes DIR */
    const char *paint;                  /* --albedo-paint PNG */
    const char *paint_image;            /* --albedo-paint-image PNG,KEYFRAME: the PNG ... */
    int paint_keyframe;                 /* ... and the keyframe */
    double az, el, intensity, exposure, sun_size, env_rotate;
    fill_light fill[MAX_FILLS];
    int n_fill;
    int have_sun, scale, keyframe, width, height, have_orbit, supersample, panel;
    double sky_turn; /* degrees the sky is turned about the vertical (the panel's new light) */
    double orbit_az, orbit_el, fov_deg, focal_mm;
    double spec_scale[SP_RENDER_CLUSTERS];
    const char *camera_in, *camera_out; /* --camera FILE, --save-camera FILE */
} relight_args;

typedef struct relight_ctx {
    relight_args *a;
    sp_face_asset fa;
    sp_json *cams, *manifest;
    int srgb;
    double kf_exposure; /* the view's keyframe's exposure (cameras.json), 1 when absent */
    double centre[3];   /* the head's centre in the world (the mesh's centroid), for point fills */
    double ks_fitted[SP_RENDER_CLUSTERS]; /* before --specular-scale */
    float *bg;          /* --background: linear RGB, bg_w x bg_h */
    uint8_t *bg_raw;    /* capture:N: the frame's RGB24 as decoded */
    uint32_t bg_w, bg_h;
    int bg_is_capture;  /* the face's own frame: blend through the eroded face mask */
    double bg_crop[2];  /* the fit's window origin in the frame (face-crop fits) */
    sp_face_model model; /* for its face mask, when its topology is the asset's */
    int have_model;
    uint8_t *fit_mask;   /* per vertex: the face's skin and eyes, what the fit observed */
} relight_ctx;

/* The passes --passes writes, in this order (relight_io.c names them). */
enum relight_pass {
    PASS_BEAUTY, PASS_DIFFUSE, PASS_SPECULAR, PASS_AMBIENT, PASS_VISIBILITY, PASS_NORMAL, PASS_ALBEDO,
    PASS_ALPHA, PASS_FACE, PASS_COUNT
};
int relight_pass_channels(int pass);

int relight_ends_with(const char *s, const char *tail);
/* --env into env (SP_RENDER_ENV_FLOATS); 0 or a negative error, message printed. */
int relight_read_env(const relight_args *a, float *env);
/* RGBA in the output's encoding (sRGB for an sRGB capture or a picture, else the fit's tone map) of n pixels. */
void relight_encode(const relight_ctx *c, const float *radiance, const float *cover, size_t n, double exposure,
                    uint8_t *rgba);
/* -o OUT: PNG (capture encoding), .exr (RGBA linear, OpenImageIO) or .pfm (RGB linear); 0 or -errno. */
int relight_write_image(const relight_ctx *c, const float *radiance, const float *cover, int W, int H,
                        double exposure);
/* Every pass (buffers W x H x channels) into dir as PFM (and EXR where built), plus passes.json. */
int relight_write_passes(const char *dir, float *const pass[PASS_COUNT], int W, int H, double exposure);

/* --background capture:N: keyframe N's frame of --capture into c->bg; 0 or an exit code (message printed). */
int relight_read_background(relight_ctx *c);
/* --background FILE into c->bg; 0 or an exit code (message printed). */
int relight_read_background_file(relight_ctx *c);
/* The head over c->bg resampled to W x H, in linear light; cover is the head's (or face's) coverage. */
void relight_composite(const relight_ctx *c, float *sum, const float *cover, int W, int H, double exposure);
/* c->a's picture as RGBA in the output's encoding (*rgba malloc'd, *W x *H); 0 or an exit code. */
int relight_tile(relight_ctx *c, uint8_t **rgba, int *W, int *H);
/*
 * --albedo-paint-image: the RGBA PNG at path, painted over keyframe N's frame (view v at the frame's size,
 * depth its per-pixel z), laid over the albedo texels that view sees; 0 or an exit code (message printed).
 */
int relight_paint_image(relight_ctx *c, const sp_face_view *v, const float *depth, const char *path);
/* --panel: the figure of relight_panel.c into c->a->out; an exit code. */
int relight_panel(relight_ctx *c);
/* --albedo-paint: the RGBA PNG composited over c->fa.albedo; 0 or an exit code (message printed). */
int relight_paint(relight_ctx *c);

#endif
