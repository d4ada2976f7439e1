/* SPDX-License-Identifier: MIT */
/*
 * "video-orientation": the camera orientation per frame from the video alone
 * (capture/visual_orientation.h), as a CSV with -o in the columns of the
 * "orientation" stage plus `tracked`. The CSV is written at the end, after the
 * loop closure. When the capture carries true orientations, the error is
 * reported after the one rotation that best aligns the two worlds (the
 * heading is relative), with the tilt error (camera up against world up) apart.
 */
#include "stages.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "capture/visual_orientation.h"
#include "common/atomic_file.h"
#include "common/stats.h"
#include "pipeline/sunstage/landmarks.h"
#include "sunprobe/sp_capture.h"

#define MOD "orientation"
#define ASSUMED_HFOV_DEG 65.0 /* a phone camera's, when the capture does not give its intrinsics */

typedef struct vo_row {
    uint64_t sequence;
    int64_t t_ns;
    int has_truth;
    sp_quat truth;
} vo_row;

typedef struct video_orientation_stage {
    const char *path;
    sp_vo *vo;
    sp_capture_meta meta;
    int have_meta;
    vo_row *rows;
    size_t n, cap;
    ss_lm_tracker *faces; /* finds the person when the capture brings no landmarks */
    int no_faces;         /* ... and could not be opened */
    uint8_t *rgb;
    size_t rgb_size;
    uint64_t with_face;
    float found[136];   /* the tracker's landmarks on the current frame, or the last side data's */
    int side_landmarks; /* the capture brings landmarks as side data (they follow their frame) */
    int finished;       /* finish succeeded: the orientations can be looked up */
    double accel[3];    /* the accelerometer's samples since the last frame, summed (IMU axes) */
    unsigned n_accel;
    sp_vo_result result;
} video_orientation_stage;

static int vos_open(void **ctx, const void *settings)
{
    const sp_stage_options *options = settings;
    video_orientation_stage *s = calloc(1, sizeof(*s));
    if (!s)
        return -ENOMEM;
    s->path = options ? options->output_path : NULL;
    sp_capture_meta_init(&s->meta);
    *ctx = s;
    return 0;
}

static int open_tracker(video_orientation_stage *s, const sp_frame *f)
{
    sp_vo_settings vs = { .width = f->width, .height = f->height };
    double fx = sp_capture_meta_focal_px(&s->meta);
    if (!(fx > 0)) {
        fx = 0.5 * f->width / tan(0.5 * ASSUMED_HFOV_DEG * M_PI / 180.0);
        sp_log(SP_LOG_WARN, MOD, "the capture gives no focal length: a %.0f deg wide view assumed (fx %.1f px)",
               ASSUMED_HFOV_DEG, fx);
    }
    vs.fx = fx;
    vs.fy = s->meta.fy > 0 ? s->meta.fy : fx;
    vs.cx = isfinite(s->meta.cx) ? s->meta.cx : 0.5 * (f->width - 1.0);
    vs.cy = isfinite(s->meta.cy) ? s->meta.cy : 0.5 * (f->height - 1.0);
    return sp_vo_open(&s->vo, &vs);
}

/* The face's landmarks on this frame (side data, else the landmark tracker), or NULL: the person to avoid. */
static int face_of(video_orientation_stage *s, const sp_event *ev, const float **lm)
{
    *lm = NULL;
    if (s->side_landmarks) { /* the previous frame's: side data comes after its frame, the face moves little */
        *lm = s->found;
        return 0;
    }
    if (s->no_faces || s->n == 0) /* the first frame: wait to see whether side data brings landmarks */
        return 0;
    if (!s->faces) {
        ss_lm_settings ls;
        ss_lm_default_settings(&ls);
        if (ss_lm_tracker_open(&s->faces, &ls)) {
            sp_log(SP_LOG_WARN, MOD,
                   "no landmark tracker (dlib): the person is told from the background by "
                   "motion alone");
            s->no_faces = 1;
            return 0;
        }
    }
    ss_lm_result r;
    int ret = sp_stage_frame_landmarks(s->faces, ev->frame, &s->rgb, &s->rgb_size, &r);
    if (ret || r.source == SS_LM_NONE)
        return ret;
    for (int k = 0; k < 136; k++)
        s->found[k] = (float)r.lm[k];
    *lm = s->found;
    return 0;
}

/* Side data: a frame's landmarks (for the next frame's person) or its true orientation (for the error). */
static void on_side(video_orientation_stage *s, const sp_event *ev)
{
    const float *v = ev->side_values;
    if (!v)
        return;
    if (ev->side_kind == SP_SIDE_LANDMARKS_2D && ev->side_count == 136) {
        int finite = 1;
        for (int k = 0; k < 136; k++)
            finite &= isfinite(v[k]) != 0;
        if (finite) {
            memcpy(s->found, v, sizeof(s->found));
            s->side_landmarks = 1;
        }
    } else if (ev->side_kind == SP_SIDE_TRUE_ORIENTATION && ev->side_count == 4) {
        for (size_t i = s->n; i-- > 0;) /* it follows its frame closely */
            if (s->rows[i].sequence == ev->side_sequence) {
                s->rows[i].truth = sp_quat_normalize((sp_quat){ v[0], v[1], v[2], v[3] });
                s->rows[i].has_truth = 1;
                break;
            }
    }
}

static int vos_push(void *ctx, const sp_event *ev)
{
    video_orientation_stage *s = ctx;
    if (ev->type == SP_EVENT_META && ev->meta) {
        s->meta = *ev->meta;
        return 0;
    }
    if (ev->type == SP_EVENT_SIDE)
        on_side(s, ev);
    if (ev->type == SP_EVENT_IMU && ev->imu.sensor == SP_IMU_ACCEL && isfinite(ev->imu.v[0]) &&
        isfinite(ev->imu.v[1]) && isfinite(ev->imu.v[2])) {
        for (int k = 0; k < 3; k++)
            s->accel[k] += (double)ev->imu.v[k];
        s->n_accel++;
    }
    if (ev->type != SP_EVENT_FRAME)
        return 0;
    int ret = s->vo ? 0 : open_tracker(s, ev->frame);
    if (!ret && s->n == s->cap) {
        size_t cap = s->cap ? 2 * s->cap : 256;
        vo_row *r = realloc(s->rows, sizeof(*r) * cap);
        if (!r)
            return -ENOMEM;
        s->rows = r, s->cap = cap;
    }
    const float *lm = NULL;
    if (!ret && (ret = face_of(s, ev, &lm)) == 0 && lm)
        s->with_face++;
    if (ret || (ret = sp_vo_push(s->vo, ev->frame, lm)))
        return ret;
    if (s->n_accel) { /* gravity for world up: the mean since the last frame, bias off, in camera axes */
        sp_vec3 a = { s->accel[0] / s->n_accel - s->meta.accel_bias.x, s->accel[1] / s->n_accel - s->meta.accel_bias.y,
                      s->accel[2] / s->n_accel - s->meta.accel_bias.z };
        sp_vo_gravity(s->vo, sp_quat_rotate(sp_quat_normalize(s->meta.imu_to_camera), a)); /* under 1 m/s^2: none */
        s->accel[0] = s->accel[1] = s->accel[2] = 0, s->n_accel = 0;
    }
    vo_row *r = &s->rows[s->n++];
    r->sequence = ev->frame->sequence;
    r->t_ns = ev->timestamp_ns;
    r->has_truth = 0;
    return 0;
}

/* Error against the truth after the best-aligning world rotation: median and max, tilt apart. */
static void report_truth(video_orientation_stage *s, FILE *summary, double *err)
{
    sp_quat_mean m;
    sp_quat_mean_init(&m);
    size_t k = 0;
    for (size_t i = 0; i < s->n; i++) {
        sp_quat est;
        if (!s->rows[i].has_truth || sp_vo_camera(s->vo, i, &est, NULL))
            continue;
        sp_quat_mean_add(&m, sp_quat_mul(s->rows[i].truth, sp_quat_conj(est)));
        k++;
    }
    if (!k)
        return;
    sp_quat align = sp_quat_mean_get(&m);
    double *e = malloc(sizeof(double) * k), tilt_max = 0;
    if (!e)
        return;
    k = 0;
    for (size_t i = 0; i < s->n; i++) {
        sp_quat est;
        err[i] = NAN;
        if (!s->rows[i].has_truth || sp_vo_camera(s->vo, i, &est, NULL))
            continue;
        err[i] = sp_quat_angle_between(sp_quat_mul(align, est), s->rows[i].truth) * 180.0 / M_PI;
        e[k++] = err[i];
        sp_vec3 up_est = sp_quat_rotate(sp_quat_conj(est), (sp_vec3){ 0, 0, 1 });
        sp_vec3 up_true = sp_quat_rotate(sp_quat_conj(s->rows[i].truth), (sp_vec3){ 0, 0, 1 });
        double c = fmax(-1.0, fmin(1.0, sp_vec3_dot(up_est, up_true)));
        tilt_max = fmax(tilt_max, acos(c) * 180.0 / M_PI);
    }
    double median = sp_median_inplace(e, k); /* sorted now */
    fprintf(summary,
            "video-orientation: error against ground truth after world alignment: median %.3f deg, max %.3f deg "
            "over %zu frames; tilt error max %.3f deg\n",
            median, e[k - 1], k, tilt_max);
    free(e);
}

static int write_csv(video_orientation_stage *s, const double *err)
{
    sp_atomic_file out;
    int ret = sp_atomic_file_open(&out, s->path);
    if (ret)
        return ret;
    fprintf(out.file, "sequence,timestamp_s,qw,qx,qy,qz,heading_deg,elevation_deg,error_deg,tracked\n");
    for (size_t i = 0; i < s->n; i++) {
        sp_quat q;
        int tracked = 0;
        sp_vo_camera(s->vo, i, &q, &tracked);
        sp_vec3 fwd = sp_quat_rotate(q, (sp_vec3){ 0, 0, 1 });
        fprintf(out.file, "%" PRIu64 ",%.6f,%.9f,%.9f,%.9f,%.9f,%.4f,%.4f,", s->rows[i].sequence,
                (double)s->rows[i].t_ns * 1e-9, q.w, q.x, q.y, q.z, atan2(fwd.y, fwd.x) * 180.0 / M_PI,
                asin(fmax(-1.0, fmin(1.0, fwd.z))) * 180.0 / M_PI);
        if (isfinite(err[i]))
            fprintf(out.file, "%.4f", err[i]);
        fprintf(out.file, ",%d\n", tracked);
    }
    return sp_atomic_file_finish(&out, 0);
}

static int vos_finish(void *ctx, FILE *summary)
{
    video_orientation_stage *s = ctx;
    if (!s->vo) {
        fprintf(summary, "video-orientation: the capture has no frames\n");
        return SP_ENODATA;
    }
    sp_vo_result r;
    int status = sp_vo_finish(s->vo, &r);
    s->result = r;
    if (status && status != SP_ENODATA)
        return status;
    fprintf(summary,
            "video-orientation: %" PRIu64 " frames, %" PRIu64 " coasted (too few background tracks), median %.0f "
            "tracks per step, %.1f deg of turn; the person found on %" PRIu64 " frames\n",
            r.frames, r.coasted, r.median_inliers, r.turn_deg, s->with_face);
    if (r.loop_closed)
        fprintf(summary,
                "video-orientation: loop closed at frame %" PRIu64 " (%u tracks): %.2f deg of drift spread "
                "over the turn\n",
                r.loop_frame, r.loop_inliers, r.loop_correction_deg);
    else
        fprintf(summary,
                "video-orientation: no loop closure (the turn did not come back to its start, or the "
                "start was not found again): the drift stays\n");
    if (r.up_from_gravity && isfinite(r.axis_to_gravity_deg))
        fprintf(summary, "video-orientation: world up is the accelerometer's (the turn's axis is %.1f deg from it)\n",
                r.axis_to_gravity_deg);
    else if (r.up_from_gravity)
        fprintf(summary,
                "video-orientation: world up is the accelerometer's (the turn is too short or too uneven "
                "to give its axis)\n");
    else if (r.up_from_turn)
        fprintf(summary, "video-orientation: world up is the turn's axis (%.0f%% of the rotation is about it)\n",
                100.0 * r.turn_axis_share);
    else
        fprintf(summary,
                "video-orientation: world up is the first frame's up (the turn is too short or too "
                "uneven to give its axis): the phone is assumed held upright\n");
    if (status) {
        fprintf(summary,
                "video-orientation: the background could not be tracked (a plain sky or wall, or a person "
                "filling the frame): no orientation\n");
        return status;
    }
    double *err = malloc(sizeof(double) * s->n);
    if (!err)
        return -ENOMEM;
    for (size_t i = 0; i < s->n; i++)
        err[i] = NAN;
    report_truth(s, summary, err);
    int ret = s->path ? write_csv(s, err) : 0;
    free(err);
    s->finished = ret == 0;
    return ret;
}

int sp_video_orientation_for(void *ctx, uint64_t sequence, int64_t timestamp_ns, sp_quat *camera_to_world)
{
    (void)timestamp_ns;
    const video_orientation_stage *s = ctx;
    if (!s || !s->finished)
        return -EINVAL;
    size_t lo = 0, hi = s->n; /* sequences increase in capture order */
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (s->rows[mid].sequence < sequence)
            lo = mid + 1;
        else
            hi = mid;
    }
    if (lo == s->n || s->rows[lo].sequence != sequence)
        return SP_ENODATA;
    int tracked = 0;
    int ret = sp_vo_camera(s->vo, lo, camera_to_world, &tracked);
    return ret ? ret : tracked ? 0 : SP_ENODATA; /* a coasted frame is left out of the fit */
}

int sp_video_orientation_result(void *ctx, sp_vo_result *out)
{
    const video_orientation_stage *s = ctx;
    if (!s || !s->vo || !out)
        return -EINVAL;
    *out = s->result;
    return 0;
}

static void vos_close(void *ctx)
{
    video_orientation_stage *s = ctx;
    sp_vo_close(&s->vo);
    ss_lm_tracker_close(&s->faces);
    free(s->rgb);
    free(s->rows);
    free(s);
}

const sp_stage_ops sp_stage_video_orientation = {
    .name = "video-orientation",
    .writes_output = 1,
    .description = "camera orientation per frame from the video alone, no IMU (CSV with -o)",
    .wants_tags = 0, /* no IMU filter: it would thin the first frames while it settles */
    .open = vos_open,
    .push = vos_push,
    .finish = vos_finish,
    .close = vos_close,
};
