/* SPDX-License-Identifier: MIT */
/*
 * "orientation": the orientation tagger's camera orientation per frame (slerped
 * at the frame's timestamp with the capture's IMU-to-camera rotation and time
 * offset), as a CSV with -o. When the capture carries true orientations
 * (synthetic captures), the error is reported after aligning the arbitrary
 * initial heading on the first frame.
 */
#include "stages.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/atomic_file.h"

typedef struct orientation_stage {
    FILE *csv;                 /* = out.file while the CSV is written, else NULL */
    sp_atomic_file out;        /* the CSV under a temporary name until finish succeeds */
    uint64_t resolved, unresolved, imu_samples;
    int have_align;
    sp_quat align; /* maps the filter's world onto the truth's world */
    double err_max, err_sum, err_last;
    uint64_t err_n;
} orientation_stage;

static int orient_open(void **ctx, const void *settings)
{
    const sp_stage_options *options = settings;
    orientation_stage *s = calloc(1, sizeof(*s));
    if (!s)
        return -ENOMEM;
    if (options && options->output_path) {
        int err = sp_atomic_file_open(&s->out, options->output_path);
        if (err) {
            free(s);
            return err;
        }
        s->csv = s->out.file;
        fprintf(s->csv, "sequence,timestamp_s,qw,qx,qy,qz,heading_deg,elevation_deg,error_deg\n");
    }
    *ctx = s;
    return 0;
}

static double record_error(orientation_stage *s, const sp_frame_tags *tags, sp_quat est)
{
    if (!tags->has_true_orientation)
        return NAN;
    sp_quat truth = tags->true_camera_to_world;
    if (!s->have_align) {
        s->align = sp_quat_mul(truth, sp_quat_conj(est));
        s->have_align = 1;
    }
    double err = sp_quat_angle_between(sp_quat_mul(s->align, est), truth) * 180.0 / M_PI;
    s->err_max = fmax(s->err_max, err);
    s->err_sum += err;
    s->err_last = err;
    s->err_n++;
    return err;
}

static void emit(orientation_stage *s, const sp_event *ev)
{
    sp_quat q = ev->tags->camera_to_world;
    double err = record_error(s, ev->tags, q);
    s->resolved++;
    if (!s->csv)
        return;
    sp_vec3 fwd = sp_quat_rotate(q, (sp_vec3){ 0, 0, 1 });
    double heading = atan2(fwd.y, fwd.x) * 180.0 / M_PI;
    double elevation = asin(fmax(-1.0, fmin(1.0, fwd.z))) * 180.0 / M_PI;
    fprintf(s->csv, "%" PRIu64 ",%.6f,%.9f,%.9f,%.9f,%.9f,%.4f,%.4f,", ev->frame->sequence,
            (double)ev->timestamp_ns * 1e-9, q.w, q.x, q.y, q.z, heading, elevation);
    if (isfinite(err))
        fprintf(s->csv, "%.4f", err);
    fputc('\n', s->csv);
}

static int orient_push(void *ctx, const sp_event *ev)
{
    orientation_stage *s = ctx;
    if (ev->type == SP_EVENT_IMU)
        s->imu_samples++;
    if (ev->type != SP_EVENT_FRAME)
        return 0;
    if (!ev->tags)
        return -EINVAL; /* the stage runs behind the tagger (wants_tags) */
    if (ev->tags->orientation == SP_ORIENTATION_OK)
        emit(s, ev);
    else
        s->unresolved++;
    return 0;
}

/* Puts the CSV in place only after a complete run (status 0); else removes it. Returns status or the error. */
static int commit_csv(orientation_stage *s, int status)
{
    if (!s->csv)
        return status;
    s->csv = NULL;
    return sp_atomic_file_finish(&s->out, status);
}

static int orient_finish(void *ctx, FILE *summary)
{
    orientation_stage *s = ctx;
    fprintf(summary, "orientation: %" PRIu64 " frames oriented, %" PRIu64 " without IMU coverage\n", s->resolved,
            s->unresolved);
    if (!s->imu_samples)
        fprintf(summary, "orientation: the capture has no IMU samples\n");
    else if (!s->resolved)
        fprintf(summary, "orientation: no frame lies within the IMU log's time span (do their clocks overlap?)\n");
    if (s->err_n)
        fprintf(summary, "orientation: error against ground truth: mean %.3f deg, max %.3f deg, last frame %.3f deg\n",
                s->err_sum / (double)s->err_n, s->err_max, s->err_last);
    return commit_csv(s, s->imu_samples && s->resolved ? 0 : SP_ENODATA); /* an empty CSV is no result */
}

static void orient_close(void *ctx)
{
    orientation_stage *s = ctx;
    if (s->csv) /* not finished, or finish failed: the previous CSV (if any) stays */
        sp_atomic_file_finish(&s->out, -ECANCELED);
    free(s);
}

const sp_stage_ops sp_stage_orientation = {
    .name = "orientation",
    .writes_output = 1,
    .description = "IMU-fused camera orientation per frame (CSV with -o; error when ground truth is present)",
    .wants_tags = 1,
    .open = orient_open,
    .push = orient_push,
    .finish = orient_finish,
    .close = orient_close,
};
