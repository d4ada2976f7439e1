/* SPDX-License-Identifier: MIT */
/*
 * "orientation": fuses the IMU stream and gives every frame a camera orientation
 * (slerped at the frame's timestamp with the capture's IMU-to-camera rotation and
 * time offset). Frames wait in a bounded ring until the IMU has passed their time.
 * When the capture carries true orientations (synthetic captures), the error is
 * reported after aligning the arbitrary initial heading on the first frame.
 */
#include "stages.h"

#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_meta.h"
#include "sunprobe/sp_orientation.h"

#define RING 512 /* frames waiting for IMU coverage; at 30 fps, 17 s of IMU latency */

typedef struct waiting_frame {
    uint64_t sequence;
    int64_t t;
    int has_truth;
    sp_quat truth;
} waiting_frame;

typedef struct orientation_stage {
    FILE *csv;
    sp_capture_meta meta;
    sp_orientation *filter;
    waiting_frame ring[RING];
    size_t head, count;
    uint64_t resolved, unresolved;
    int have_align;
    sp_quat align; /* maps the filter's world onto the truth's world */
    double err_max, err_sum, err_last;
    uint64_t err_n;
} orientation_stage;

static int orient_open(void **ctx, const sp_stage_options *options)
{
    orientation_stage *s = calloc(1, sizeof(*s));
    if (!s)
        return -ENOMEM;
    sp_capture_meta_init(&s->meta);
    if (options->output_path) {
        if (!(s->csv = fopen(options->output_path, "w"))) {
            int err = -errno;
            free(s);
            return err;
        }
        fprintf(s->csv, "sequence,timestamp_s,qw,qx,qy,qz,heading_deg,elevation_deg,error_deg\n");
    }
    *ctx = s;
    return 0;
}

static int open_filter(orientation_stage *s)
{
    sp_orientation_settings os;
    sp_orientation_default_settings(&os);
    os.imu_to_camera = s->meta.imu_to_camera;
    os.time_offset_s = s->meta.imu_time_offset_s;
    return sp_orientation_open(&s->filter, &os);
}

static double record_error(orientation_stage *s, const waiting_frame *w, sp_quat est)
{
    if (!w->has_truth)
        return NAN;
    if (!s->have_align) {
        s->align = sp_quat_mul(w->truth, sp_quat_conj(est));
        s->have_align = 1;
    }
    double err = sp_quat_angle_between(sp_quat_mul(s->align, est), w->truth) * 180.0 / M_PI;
    s->err_max = fmax(s->err_max, err);
    s->err_sum += err;
    s->err_last = err;
    s->err_n++;
    return err;
}

static void emit(orientation_stage *s, const waiting_frame *w, sp_quat q)
{
    double err = record_error(s, w, q);
    s->resolved++;
    if (!s->csv)
        return;
    sp_vec3 fwd = sp_quat_rotate(q, (sp_vec3){ 0, 0, 1 });
    double heading = atan2(fwd.y, fwd.x) * 180.0 / M_PI;
    double elevation = asin(fmax(-1.0, fmin(1.0, fwd.z))) * 180.0 / M_PI;
    fprintf(s->csv, "%" PRIu64 ",%.6f,%.9f,%.9f,%.9f,%.9f,%.4f,%.4f,", w->sequence, (double)w->t * 1e-9, q.w, q.x,
            q.y, q.z, heading, elevation);
    if (isfinite(err))
        fprintf(s->csv, "%.4f", err);
    fputc('\n', s->csv);
}

/* Resolves waiting frames in order; stops at the first the IMU has not reached (or all, at the end). */
static void resolve(orientation_stage *s, int final)
{
    while (s->count) {
        waiting_frame *w = &s->ring[s->head];
        sp_quat q;
        int ret = s->filter ? sp_orientation_camera_at(s->filter, w->t, &q) : -EAGAIN;
        if (ret == -EAGAIN && !final && s->count < RING)
            return;
        if (ret == 0)
            emit(s, w, q);
        else
            s->unresolved++;
        s->head = (s->head + 1) % RING;
        s->count--;
    }
}

static int orient_process(void *ctx, const sp_event *ev)
{
    orientation_stage *s = ctx;
    switch (ev->type) {
    case SP_EVENT_META:
        sp_capture_meta_merge(&s->meta, ev->meta_json, ev->meta_len); /* a bad chunk was logged by replay */
        return 0;
    case SP_EVENT_IMU:
        if (!s->filter) {
            int ret = open_filter(s);
            if (ret)
                return ret;
        }
        sp_orientation_push(s->filter, &ev->imu); /* drops are counted in the filter's stats */
        resolve(s, 0);
        return 0;
    case SP_EVENT_FRAME:
        if (s->count == RING)
            resolve(s, 0); /* ring full: the oldest frame gives up waiting */
        s->ring[(s->head + s->count) % RING] = (waiting_frame){ .sequence = ev->frame->sequence, .t = ev->timestamp_ns };
        s->count++;
        return 0;
    case SP_EVENT_SIDE:
        if (ev->side_kind == SP_SIDE_TRUE_ORIENTATION && ev->side_count == 4)
            for (size_t i = 0; i < s->count; i++) {
                waiting_frame *w = &s->ring[(s->head + i) % RING];
                if (w->sequence == ev->side_sequence) {
                    const float *v = ev->side_values;
                    w->truth = sp_quat_normalize((sp_quat){ v[0], v[1], v[2], v[3] });
                    w->has_truth = 1;
                }
            }
        return 0;
    }
    return 0;
}

static int orient_finish(void *ctx, FILE *summary)
{
    orientation_stage *s = ctx;
    resolve(s, 1);
    fprintf(summary, "orientation: %" PRIu64 " frames oriented, %" PRIu64 " without IMU coverage\n", s->resolved,
            s->unresolved);
    if (s->filter) {
        sp_orientation_stats st;
        sp_orientation_get_stats(s->filter, &st);
        fprintf(summary, "orientation: %" PRIu64 " IMU samples used, dropped %" PRIu64 " duplicate / %" PRIu64
                         " out-of-order / %" PRIu64 " invalid, %" PRIu64 " gaps, %" PRIu64
                         " saturated; gyro bias (%.3f, %.3f, %.3f) deg/s%s\n",
                st.samples_used, st.dropped_duplicate, st.dropped_out_of_order, st.dropped_invalid, st.gaps,
                st.saturated, st.gyro_bias.x * 180 / M_PI, st.gyro_bias.y * 180 / M_PI, st.gyro_bias.z * 180 / M_PI,
                st.bias_from_still ? " (from a still period)" : "");
    } else {
        fprintf(summary, "orientation: the capture has no IMU samples\n");
    }
    if (s->err_n)
        fprintf(summary, "orientation: error against ground truth: mean %.3f deg, max %.3f deg, last frame %.3f deg\n",
                s->err_sum / (double)s->err_n, s->err_max, s->err_last);
    if (s->csv && fflush(s->csv) != 0)
        return -EIO;
    return s->filter ? 0 : SP_ENODATA;
}

static void orient_close(void *ctx)
{
    orientation_stage *s = ctx;
    if (s->csv)
        fclose(s->csv);
    sp_orientation_close(&s->filter);
    free(s);
}

const sp_stage_ops sp_stage_orientation = {
    .name = "orientation",
    .description = "IMU-fused camera orientation per frame (CSV with -o; error when ground truth is present)",
    .open = orient_open,
    .process = orient_process,
    .finish = orient_finish,
    .close = orient_close,
};
