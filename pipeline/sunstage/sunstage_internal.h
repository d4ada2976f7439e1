/* SPDX-License-Identifier: MIT */
/* Internal state of the SunStage fitter, shared by its files (not installed). */
#ifndef SUNPROBE_SUNSTAGE_INTERNAL_H
#define SUNPROBE_SUNSTAGE_INTERNAL_H

#include <stddef.h>
#include <stdint.h>

#include "sunprobe/sp_meta.h"
#include "sunprobe/sp_render.h"
#include "sunprobe/sp_sunstage.h"

#define SS_ENV_BASIS 9 /* non-negative environment lobes used by the fast solver */

/* Where a fit image lies in its capture frame: fit pixel = (capture pixel + 0.5 - x0) * s - 0.5. */
typedef struct ss_window {
    double x0, y0; /* capture position of the fit image's top-left corner */
    double s;      /* fit pixels per capture pixel */
} ss_window;

/* One reservoir slot: a fit-resolution frame and its per-frame parameters. */
/*
 * A footprint that touched a clipped (255) value has no known radiance, but its mean with the clipped
 * values taken at the clip level is a lower bound of it. rgb holds 1.0 there (the face mask drops it);
 * clip[4 i .. 4 i + 2] holds that bound per channel in the fit's encoding and clip[4 i + 3] the channels
 * that touched the clip as bits (1 red, 2 green, 4 blue; an unclipped channel's value is exact). Zeros
 * everywhere else. The fast solver keeps such pixels as one-sided observations (fast.c).
 */
#define SS_CLIP_FLOATS 4

typedef struct ss_frame {
    int used, heldout;
    uint64_t sequence;
    int64_t t;
    double score;       /* sharpness; the best frame wins its bin */
    double expo;        /* exposure relative to the capture's first frame (exposure_us x gain), else 1 */
    double yaw;         /* camera heading, radians */
    float *rgb;         /* W * H * 3 display values */
    float *clip;        /* W * H * 4: footprints the camera clipped (frontend.c, SS_CLIP_*), else zeros */
    double lm[136];     /* landmarks at fit resolution */
    sp_face_camera cam; /* the frame's intrinsics at fit resolution (identity pose) */
    ss_window win;      /* where the fit image lies in the capture frame */
    double R_c2w[9];    /* camera to world */
    sp_quat q_c2w;
    int has_truth;      /* true orientation side data (synthetic captures) */
    sp_quat truth_q;
    double *exp;        /* n_exp */
    double rotvec[3], t_face[3];
    float *sil;         /* W * H distance (px) to the skin-mask boundary, NULL when not computed */
    int sil_ok;         /* the mask was found: the silhouette loss applies to this frame */
} ss_frame;

/* The front end's per-stream state (frontend.c). */
/* What the landmark tracker found on one frame (the fit's own record, written as landmarks.csv). */
typedef struct ss_lm_entry {
    uint64_t sequence;
    int source;       /* ss_lm_source */
    float drift;
    float lm[136];    /* capture pixels */
} ss_lm_entry;

typedef struct ss_frontend {
    struct ss_lm_tracker *landmarks; /* landmark tracker (landmarks.h), opened at the first frame that needs it */
    int landmarks_failed;
    int cap_w, cap_h;           /* capture size */
    uint8_t *rgb24;             /* capture-size conversion buffer */
    float *work_rgb;            /* W * H * 3: the frame at fit resolution */
    float *work_clip;           /* W * H * 4: its clipped footprints (ss_frame.clip) */
    double sharp_mean;          /* running mean of the sharpness (blur check) */
    uint64_t sharp_n;
    double expo_ref;            /* exposure_us x gain of the first frame, 0 when unknown */
    ss_window win;              /* the current frame's window (whole frame, or its face crop) */
    int64_t frame_t[2], imu_t[2]; /* first and last timestamps seen: explain frames the IMU never covered */
    int srgb;                   /* frames are sRGB-encoded: decoded to linear light through lut (frontend.c) */
    float lut[256];
    ss_lm_entry *lm_log;        /* every frame the tracker ran on, in order (about 0.6 kB a frame) */
    size_t lm_n, lm_cap;
} ss_frontend;

/* The keyframe reservoir (reservoir.c): `keyframes` yaw bins, then the held-out bins. */
typedef struct ss_reservoir {
    int n_slots;
    ss_frame *slots;
} ss_reservoir;

/*
 * Upper bound of a cluster's specular ks (the normalised Blinn-Phong lobe's albedo): a dielectric of
 * refractive index 1.5 reflects 9.2 % of light averaged over incidence (cosine-weighted Fresnel), skin
 * (1.4) 7.7 %. Unbounded, the chin's ks reached 0.13-0.71 on path-traced selfies: a sheen painted over shading.
 */
#define SS_KS_MAX 0.1

/* The shared fitted state: what stage 1 and the solvers write, the result and the face directory read. */
#define SS_LM_FITTED_FLOATS 137 /* ss_fit_state.lm_fitted per frame: the RMS residual, then x0, y0 .. x67, y67 */

typedef struct ss_fit_state {
    double *id;                 /* n_id identity coefficients */
    double scale;
    int tw, th;                 /* texture size */
    int matched_rows;           /* texture_size 0: rows of one texel per face pixel (after stage 1), else 0 */
    float *albedo, *disp;
    uint8_t *observed;          /* per texel: 1 when a keyframe saw it, 0 when filled from its neighbours,
                                   SS_TEXEL_SYNTHESISED when filled with synthesised skin (skin_fill.c) */
    int have_observed;          /* the fast solver set `observed` (the Adam reference fills nothing) */
    double ks[SP_RENDER_CLUSTERS], shin[SP_RENDER_CLUSTERS];
    float env[SP_RENDER_ENV_FLOATS];
    double sun_dir[3], sun_I;
    int sun_dropped, unobservable, fitted;
    char notes[512];
    char disp_note[160];        /* why the displacement map stays zero, "" when fitted */
    char texture_note[160];     /* texture_size 0: why the map has the rows it has, "" otherwise */
    int texture_coarse;         /* that choice left detail out (a coarser map won on the held-out frames) */
    double yaw_range, train_psnr, heldout_psnr, seconds;
    double frontend_s, align_s, solve_s, refine_s; /* wall time per phase */
    int64_t t0;                 /* start of the fit, for progress times */
    float *lm_fitted;           /* SS_LM_FITTED_FLOATS per fe.lm_log entry: RMS residual (capture px; NaN: none),
                                   then the model's 68 landmark vertices fitted to that frame, capture pixels
                                   (ss_fit_logged_landmarks) */
} ss_fit_state;

/* The sun from the clock (clock_sun.c): what the frames say about north, and the ephemeris sun. */
typedef struct ss_clock_sun {
    uint64_t oriented, magnetic; /* oriented frames, and those whose heading a magnetometer anchored */
    double first_forward_deg;   /* world angle of the first oriented frame's forward axis, NaN before */
    int have;                   /* dir, azimuth_deg and elevation_deg hold the ephemeris sun */
    double dir[3], azimuth_deg, elevation_deg;
    double angle_deg;           /* between it and the fitted sun; NaN when either is missing */
    char heading_from[32];      /* where north came from */
    char note[160];             /* why there is none */
} ss_clock_sun;

struct sp_sunstage {
    sp_sunstage_settings set;
    const sp_face_model *model;
    uint8_t *scalp;             /* per model vertex: the cranium, whose outline only pulls outward */
    sp_capture_meta meta;       /* as the last META event left it (the source merges) */
    int W, H;                   /* fit resolution */
    sp_face_camera cam;         /* the capture's intrinsics at fit resolution (whole-frame mode); every keyframe gets
                                   a copy, moved to its window in face-crop mode */
    double cap_fx, cap_fy, cap_cx, cap_cy; /* the capture's intrinsics in capture pixels */
    ss_frontend fe;
    ss_reservoir res;
    sp_sunstage_counts counts;
    ss_fit_state fit;
    ss_clock_sun clock;
};

/* ---- sunstage.c ---- */
/* The world rotation of a face: R_c2w * R(rotvec). */
void ss_rotvec_to_matrix(const double r[3], double R[9]);
/* The face parameters of frame f under the shared fit (views into ss and f). */
void ss_frame_params(const sp_sunstage *ss, const ss_frame *f, sp_face_params *p);


/* ---- clock_sun.c ---- */
void ss_clock_sun_init(ss_clock_sun *c);
/* Per tagged frame: north's evidence. */
void ss_clock_sun_note(ss_clock_sun *c, const sp_frame_tags *tags);
/* Before the solve: the ephemeris sun in the fit's world, or the logged reason it is left out. */
void ss_clock_sun_prepare(sp_sunstage *ss);
/* After the solve: the angle between it and the fitted sun. */
void ss_clock_sun_compare(sp_sunstage *ss);

/* ---- reservoir.c ---- */
/* Allocates the slots (fit resolution known); -ENOMEM. */
int ss_reservoir_alloc(sp_sunstage *ss);
/* (Re)allocates the albedo (at 0.5), displacement and observed maps at `rows` (sunstage.c). */
int ss_fit_alloc_maps(sp_sunstage *ss, int rows);
#define SS_TEXTURE_ROWS 128 /* the map's rows by default, and the finer choice of texture_size 0 */
void ss_reservoir_free(sp_sunstage *ss);
/*
 * Offers a frame to its yaw bin (heldout_hint 0: by sequence; 2 / 3: the first free held-out /
 * training slot); *slot_out (may be NULL) gets the slot it took, untouched when it lost.
 */
int ss_reservoir_offer(sp_sunstage *ss, const float *rgb, const float *clip, const double lm[136], double score,
                       double expo, uint64_t seq, int64_t t, sp_quat q, int heldout_hint, int *slot_out);
/* The fit camera of a window: the capture's intrinsics moved and scaled into it. */
void ss_window_camera(const sp_sunstage *ss, const ss_window *w, sp_face_camera *cam);
/* A frame's exposure_us x gain, a factor that is unknown (NaN, <= 0) taken as 1; 0 when both are unknown. */
double ss_exposure_product(double exposure_us, double gain);
/* The face-crop window around 68 landmarks in capture pixels (W x W fit pixels). */
void ss_window_around(const sp_sunstage *ss, const double *lm_capture, ss_window *w);
/* The window of a frame whose landmarks (capture pixels) are lm: the whole frame, or in face-crop mode its crop. */
void ss_window_of(const sp_sunstage *ss, const double *lm_capture, ss_window *w);
/* Landmarks in capture pixels (src) into window w's fit pixels (lm). */
void ss_window_landmarks(const ss_window *w, const double *src, double lm[136]);
/* Fitted frames in slot order: fills idx with the used training (heldout = 0) or held-out slots. */
int ss_list_frames(const sp_sunstage *ss, int heldout, int *idx, int cap);
/* The i-th used slot, training and held-out alike; NULL past the end. */
const ss_frame *ss_nth_frame(const sp_sunstage *ss, int i);
/* Camera yaw the listed slots cover, degrees (360 minus the largest gap between headings). */
double ss_reservoir_yaw_range(const sp_sunstage *ss, const int *idx, int n);

/* ---- frontend.c ---- */
/* One tagged frame (borrowed) through the checks into the reservoir. */
int ss_frontend_frame(sp_sunstage *ss, const sp_frame *frame, int64_t t, const sp_frame_tags *tags);


/* ---- align.c: stage 1 ---- */
/* Gauss-Newton (LM) on robust landmark residuals; returns RMS pixel error or a negative error. */
double ss_align_landmarks(sp_sunstage *ss, const int *idx, int n, int shared, int iterations);
/* The same for one frame outside the reservoir, shared parameters fixed. */
double ss_align_one(sp_sunstage *ss, ss_frame *f, int iterations);
/*
 * ss->fit.lm_fitted for every frame in the tracker's log (fitted identity and scale); cb (may be NULL) gets
 * progress and may stop it (the frames not reached stay without). 0 or -ENOMEM.
 */
int ss_fit_logged_landmarks(sp_sunstage *ss, sp_sunstage_callback cb, void *user);

/* ---- silhouette.c: silhouette loss (stage 1 and the Adam solver) ---- */
#define SS_SIL_HUBER 1.0 /* px: quadratic below, linear above */
#define SS_SIL_MAX 6.0   /* px: outline vertices farther than this from the mask boundary are ignored (outliers) */
#define SS_SIL_SCALP 0x80000000u /* flag on an outline index: a cranium vertex */
#define SS_SIL_CAP(w, h) (2 * (h) + (w)) /* outline indices per frame at most */
/*
 * Signed distance (px) to the boundary of the frame's skin mask into dist (w * h), negative
 * inside the skin; boundary pixel count or negative.
 */
int ss_silhouette_target(const float *rgb, int w, int h, const double lm[136], float *dist);
/*
 * Outline vertices at params (camera frame, cam at identity): per image row the leftmost and
 * rightmost vertex of the face mask and of scalp (may be NULL: the face only), per column the
 * topmost, kept when seen at a grazing angle; scalp vertices are tagged SS_SIL_SCALP. idx
 * (cap >= 2, SS_SIL_CAP for all) gets up to cap indices; work: 6 * n_vertices doubles.
 */
int ss_silhouette_vertices(const sp_face_model *m, const uint8_t *scalp, const sp_face_params *p,
                           const sp_face_camera *cam, int w, int h, uint32_t *idx, int cap, double *work);
/*
 * r[j] >= 0 for outline index idx[j], one-sided since neither side of the skin's edge can be
 * trusted everywhere: a face vertex, how far outside the skin it projects (inside, the neck or an
 * ear may continue the skin); a scalp vertex, how far inside (outside, hair may hide the cranium;
 * skin beyond it is a bald head's). jac (n x n_params, may be NULL) its derivatives.
 */
int ss_silhouette_residuals(const sp_face_model *m, const sp_face_params *p, const sp_face_camera *cam,
                            const uint32_t *idx, int n, const float *dist, int w, int h, double *r, double *jac);
/* Fills every used slot's distance map (allocated once per slot). */
int ss_silhouette_prepare(sp_sunstage *ss);

/* ---- scene.c: rendering one frame of the current fit ---- */
typedef struct ss_scene {
    sp_renderer *r;
    float *pos;        /* 3 * n_vertices world positions */
    double *posd;      /* camera-frame positions */
    uint8_t *observed_tri; /* per triangle: all corners face skin, or all an eyeball: what the fit sees */
    sp_mesh mesh;      /* view of the model mesh with pos */
    float white[3];
} ss_scene;

int ss_scene_open(ss_scene *sc, const sp_sunstage *ss);
void ss_scene_close(ss_scene *sc);
/* Evaluates frame f's geometry and fills scene (pointers into ss and sc). */
int ss_scene_setup(ss_scene *sc, const sp_sunstage *ss, const ss_frame *f, sp_render_scene *scene);
/* Pixel i is skin, fully covered, not on the rim and not saturated in the target: the one mask test of every
 * solver. */
int ss_scene_is_observed(const ss_scene *sc, const sp_render_outputs *o, const float *target, int i);
/* The geometric half of that test: pixel i is fully covered by skin (or an eyeball) the fit sees. */
int ss_scene_covers(const ss_scene *sc, const sp_render_outputs *o, int i);
/* Covered with its four neighbours: not on the rim of the seen region (scene.c says why). */
int ss_scene_inside(const ss_scene *sc, const sp_render_outputs *o, int i);
/* That test for every pixel (W * H floats, 1 or 0). */
void ss_scene_mask(const ss_scene *sc, const sp_render_outputs *o, const float *target, float *mask);
double ss_psnr(const float *img, const float *target, const float *mask, int n);
/* Training and held-out PSNR of the current fit. */
int ss_evaluate(sp_sunstage *ss, ss_scene *sc, double *train, double *heldout);

/* ---- fast.c / adam.c: stage 2; the driver (sunstage.c) calls both files, they never call each other ---- */
#define SS_FAST_PHASES 8 /* rows the fast path reports: sphere, 2 pattern searches, 2 shadow rounds, sun, solve, refinement */
int ss_fit_fast(sp_sunstage *ss, sp_sunstage_callback cb, void *user);
int ss_fit_adam(sp_sunstage *ss, sp_sunstage_callback cb, void *user);
/*
 * The fast solver's overcast decision alone (its sun search and sky-only
 * comparison, the same code): sets ss->sun_dropped and the note; leaves the
 * albedo and lighting state as they were. Run before the Adam solver.
 */
int ss_fast_overcast_check(sp_sunstage *ss);
/*
 * Photometric refinement after the fast solver (adam.c, its machinery): Adam steps on per-frame
 * pose and expression, shared shape and the displacement map with albedo and
 * lighting fixed; kept only when the held-out PSNR rises (else reverted, with
 * the reason in ss->disp_note).
 */
int ss_refine_geometry(sp_sunstage *ss, int steps);

/* ---- albedo.c: priors and fill of the albedo map ---- */
#define SS_ALBEDO_SMOOTH 0.1 /* neighbour prior, relative to the median observed texel's data weight (chosen over 0.01..0.5 on
                                 synthetic seeds 1-3 and both path-traced selfies: each gains held-out PSNR, summed sun error falls) */
/* Median data weight (den[t * 3]) of the seen texels with data; 0 when none. */
double ss_albedo_typical_weight(const double *den, const uint8_t *seen, size_t n_texels);
/* Mean of the 4 neighbours of texel t3 / 3 (rows of w texels, RGB; mirrored at the borders) into out. */
void ss_albedo_neighbours(const float *albedo, int w, int h, size_t t3, double out[3]);
/* Replaces the texels with observed == 0 by a push-pull interpolation of the others; -ENOMEM. */
int ss_albedo_fill_unobserved(float *albedo, int w, int h, const uint8_t *observed);
/* ---- skin_fill.c: the face's unseen skin ---- */
#define SS_TEXEL_SYNTHESISED 2 /* `observed` value of a texel filled with synthesised skin */
/*
 * Push-pull for every unobserved texel, then synthesised skin for those of a skin cluster, from the
 * observed plain skin, the cluster's own first (marked SS_TEXEL_SYNTHESISED); -ENOMEM.
 */
int ss_albedo_complete(sp_sunstage *ss);
/*
 * The synthesis part alone, on a w x h map (RGB) whose unobserved texels hold push-pull's colours;
 * clusters: a cw x ch map of cluster ids (nearest sample per texel). Also for a face directory's maps.
 */
int ss_skin_synthesise(float *albedo, int w, int h, uint8_t *observed, const uint8_t *clusters, int cw, int ch,
                       int threads);

/* ---- lsq.c: small dense solves ---- */
/* Solves (A + lambda diag) x = b in place of b for symmetric positive A (n x n, row-major); -EDOM if singular. */
int ss_cholesky_solve(double *A, double *b, int n);
/* Non-negative least squares by active-set clamping on normal equations A (n x n), b (n); x out. */
int ss_nnls(const double *A, const double *b, int n, double *x);
/*
 * NNLS with x[s] <= cap * x[0] for s in [first, first + count) (a cluster's ks against the sun's intensity).
 * A bound the solution breaks is held (x[s] = cap x[0] substituted into A and b, which change) and the rest
 * solved again until none breaks. With one bounded unknown that is as exact as ss_nnls (a convex problem whose
 * relaxed optimum breaks one constraint has it active at the optimum); with more, a feasible point. -EINVAL,
 * -ENOMEM, or ss_nnls's error.
 */
int ss_nnls_capped(double *A, double *b, int n, int first, int count, double cap, double *x);

/* Tone map and its inverse (display value <-> linear radiance, exposure 1). */
double ss_tonemap(double x);
double ss_tonemap_inverse(double g, double *dg_dx);

#endif
