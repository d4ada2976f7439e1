/* SPDX-License-Identifier: MIT */
/*
 * The keyframe reservoir: `keyframes` bins of camera yaw (heading of the
 * camera's forward axis in the IMU world) over 360 deg, plus `heldout` bins fed
 * by every 7th frame; each bin keeps its sharpest frame. Fixed size, allocated
 * at the first frame: memory does not grow with the capture.
 */
#include "pipeline/sunstage/sunstage_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

int ss_reservoir_alloc(sp_sunstage *ss)
{
    size_t px = (size_t)ss->W * (size_t)ss->H * 3;
    ss->res.n_slots = ss->set.keyframes + ss->set.heldout;
    ss->res.slots = calloc((size_t)ss->res.n_slots, sizeof(ss_frame));
    if (!ss->res.slots)
        return -ENOMEM;
    for (int i = 0; i < ss->res.n_slots; i++) {
        ss->res.slots[i].rgb = malloc(px * sizeof(float));
        ss->res.slots[i].clip = malloc(px / 3 * SS_CLIP_FLOATS * sizeof(float));
        ss->res.slots[i].exp = calloc(ss->model->n_exp + 1, sizeof(double));
        if (!ss->res.slots[i].rgb || !ss->res.slots[i].clip || !ss->res.slots[i].exp)
            return -ENOMEM;
    }
    return 0;
}

void ss_reservoir_free(sp_sunstage *ss)
{
    for (int i = 0; ss->res.slots && i < ss->res.n_slots; i++) {
        free(ss->res.slots[i].rgb);
        free(ss->res.slots[i].clip);
        free(ss->res.slots[i].exp);
        free(ss->res.slots[i].sil);
    }
    free(ss->res.slots);
    ss->res.slots = NULL;
    ss->res.n_slots = 0;
}

static double heading(sp_quat q)
{
    sp_vec3 fwd = sp_quat_rotate(q, (sp_vec3){ 0, 0, 1 });
    return atan2(fwd.y, fwd.x);
}

int ss_reservoir_offer(sp_sunstage *ss, const float *rgb, const float *clip, const double lm[136], double score,
                       double expo, uint64_t seq, int64_t t, sp_quat q, int heldout_hint, int *slot_out)
{
    if (!ss->res.slots) {
        int ret = ss_reservoir_alloc(ss);
        if (ret)
            return ret;
    }
    int K = ss->set.keyframes, Hn = ss->set.heldout;
    double yaw = heading(q);
    double u = (yaw + M_PI) / (2.0 * M_PI);
    u = u < 0.0 ? 0.0 : (u >= 1.0 ? 0.999999 : u);
    int slot = -1, held;
    if (heldout_hint >= 2) { /* direct: first free slot of the kind */
        held = heldout_hint == 2;
        for (int i = held ? K : 0; i < (held ? K + Hn : K); i++)
            if (!ss->res.slots[i].used) {
                slot = i;
                break;
            }
        if (slot < 0) /* more than the settings asked for: the caller's error, not a full disk */
            return -EINVAL;
    } else {
        held = Hn > 0 && seq % 7 == 3;
        slot = held ? K + (int)(u * Hn) : (int)(u * K);
        if (ss->res.slots[slot].used && ss->res.slots[slot].score >= score)
            return 0;
    }
    if (slot_out)
        *slot_out = slot;
    ss_frame *f = &ss->res.slots[slot];
    f->used = 1;
    f->heldout = held;
    f->sequence = seq;
    f->t = t;
    f->score = score;
    f->expo = expo > 0.0 && isfinite(expo) ? expo : 1.0;
    f->yaw = yaw;
    f->q_c2w = sp_quat_normalize(q);
    f->cam = ss->cam;
    f->win = ss->fe.win;
    if (ss->set.face_crop)
        ss_window_camera(ss, &f->win, &f->cam);
    f->has_truth = 0;
    sp_quat_to_matrix(f->q_c2w, f->R_c2w);
    size_t npx = (size_t)ss->W * (size_t)ss->H;
    memcpy(f->rgb, rgb, npx * 3 * sizeof(float));
    if (clip)
        memcpy(f->clip, clip, npx * SS_CLIP_FLOATS * sizeof(float));
    else
        memset(f->clip, 0, npx * SS_CLIP_FLOATS * sizeof(float));
    memcpy(f->lm, lm, sizeof(f->lm));
    memset(f->exp, 0, ss->model->n_exp * sizeof(double));
    return 0;
}

int ss_list_frames(const sp_sunstage *ss, int heldout, int *idx, int cap)
{
    int n = 0;
    for (int i = 0; ss->res.slots && i < ss->res.n_slots && n < cap; i++)
        if (ss->res.slots[i].used && ss->res.slots[i].heldout == heldout)
            idx[n++] = i;
    return n;
}

int sp_sunstage_n_frames(const sp_sunstage *ss)
{
    int n = 0;
    for (int i = 0; ss && ss->res.slots && i < ss->res.n_slots; i++)
        n += ss->res.slots[i].used;
    return n;
}

const ss_frame *ss_nth_frame(const sp_sunstage *ss, int i)
{
    for (int k = 0; ss && ss->res.slots && k < ss->res.n_slots; k++)
        if (ss->res.slots[k].used && i-- == 0)
            return &ss->res.slots[k];
    return NULL;
}

double ss_reservoir_yaw_range(const sp_sunstage *ss, const int *idx, int n)
{
    /* largest gap between sorted headings; coverage = 2 pi - gap */
    double y[64] = { 0 };
    n = n < 0 ? 0 : (n > 64 ? 64 : n); /* the reservoir has at most 64 training slots */
    for (int i = 0; i < n; i++)
        y[i] = ss->res.slots[idx[i]].yaw;
    for (int i = 1; i < n; i++)
        for (int j = i; j > 0 && y[j] < y[j - 1]; j--) {
            double tmp = y[j];
            y[j] = y[j - 1];
            y[j - 1] = tmp;
        }
    double gap = n ? y[0] + 2.0 * M_PI - y[n - 1] : 2.0 * M_PI;
    for (int i = 1; i < n; i++)
        gap = fmax(gap, y[i] - y[i - 1]);
    return (2.0 * M_PI - gap) * 180.0 / M_PI;
}
