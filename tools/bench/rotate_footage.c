/* SPDX-License-Identifier: MIT */
/*
 * rotate_footage IN.spcap OUT.spcap [--seed N]: real footage as seen by a turning camera, for the
 * video-orientation tracker (capture/ORIENTATION.md). Each frame of a static-camera capture (e.g.
 * vtest.avi imported) is resampled as a camera of 480x360 and fx 600 would see it after a known
 * rotation (panning +-12 deg, tilting +-5, rolling +-3, smooth random sinusoids from the seed), treating
 * the source as an image at infinity: the texture, noise and walking people are real, the motion is
 * exactly a rotation. The true camera-to-world goes in as side data, so `replay --stage
 * video-orientation` reports its error. Parallax is absent by construction.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/pixconv.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_math.h"
#include "sunprobe/sp_replay.h"

#define OW 480
#define OH 360
#define OF 600.0
#define DEG (M_PI / 180.0)

typedef struct wave {
    double amp, freq, phase;
} wave;

static double wave_at(const wave *w, int n, double t)
{
    double s = 0;
    for (int i = 0; i < n; i++)
        s += w[i].amp * sin(w[i].freq * t + w[i].phase);
    return s;
}

static double urand(unsigned *s)
{
    *s = *s * 1103515245u + 12345u;
    return (double)((*s >> 8) & 0xffffff) / 16777216.0;
}

int main(int argc, char **argv)
{
    if (argc < 3)
        return fprintf(stderr, "usage: rotate_footage IN.spcap OUT.spcap [--seed N]\n"), 1;
    unsigned seed = argc > 4 && !strcmp(argv[3], "--seed") ? (unsigned)atoi(argv[4]) : 1;
    wave pan[2], tilt[2], roll[2];
    for (int i = 0; i < 2; i++) { /* about 12 / 5 / 3 degrees at most, periods of 8-40 s at 10 fps */
        pan[i] = (wave){ (i ? 4.0 : 8.0) * DEG, 0.016 + 0.05 * urand(&seed), 6.28 * urand(&seed) };
        tilt[i] = (wave){ (i ? 1.5 : 3.5) * DEG, 0.02 + 0.06 * urand(&seed), 6.28 * urand(&seed) };
        roll[i] = (wave){ (i ? 1.0 : 2.0) * DEG, 0.02 + 0.06 * urand(&seed), 6.28 * urand(&seed) };
    }
    sp_replay_settings rs;
    sp_replay_default_settings(&rs);
    sp_source *src = NULL;
    sp_capture_writer *w = NULL;
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    int ret = sp_replay_open(&src, argv[1], &rs);
    if (!ret)
        ret = sp_capture_writer_open(&w, argv[2], &ws);
    char meta[256];
    snprintf(meta, sizeof(meta),
             "{\"kind\":\"selfie\",\"source\":\"rotate_footage\",\"camera\":{\"fx\":%.1f,\"fy\":%.1f,\"cx\":%.1f,"
             "\"cy\":%.1f}}",
             OF, OF, 0.5 * (OW - 1), 0.5 * (OH - 1));
    if (!ret)
        ret = sp_capture_write_meta(w, 0, meta, strlen(meta));
    uint8_t *in = NULL, *out = malloc((size_t)OW * OH * 3);
    size_t in_size = 0;
    /* an upright camera looking along +x: x right = -y, y down = -z, z forward = +x */
    const double base_m[9] = { 0, 0, 1, -1, 0, 0, 0, -1, 0 };
    sp_quat base = sp_quat_from_matrix(base_m);
    uint64_t n = 0;
    sp_event ev;
    while (!ret && (ret = sp_source_next(src, &ev)) == 0) {
        if (ev.type != SP_EVENT_FRAME) {
            sp_event_release(&ev);
            continue;
        }
        const sp_frame *f = ev.frame;
        size_t need = (size_t)f->width * f->height * 3;
        if (need > in_size) {
            free(in);
            in = malloc(need), in_size = need;
        }
        ret = sp_pixconv_frame_to_rgb24(f, in, need, f->width * 3);
        double t = (double)n;
        sp_quat q = sp_quat_mul(sp_quat_from_axis_angle((sp_vec3){ 0, 0, 1 }, wave_at(pan, 2, t)), base);
        q = sp_quat_mul(q, sp_quat_from_axis_angle((sp_vec3){ 1, 0, 0 }, wave_at(tilt, 2, t)));
        q = sp_quat_mul(q, sp_quat_from_axis_angle((sp_vec3){ 0, 0, 1 }, wave_at(roll, 2, t)));
        /* the source is the view of the unrotated camera (base), its focal length the same */
        sp_quat rel = sp_quat_mul(sp_quat_conj(base), q); /* this camera in the source camera's frame */
        double R[9], sfx = OF, scx = 0.5 * (f->width - 1.0), scy = 0.5 * (f->height - 1.0);
        sp_quat_to_matrix(rel, R);
        for (int y = 0; !ret && y < OH; y++)
            for (int x = 0; x < OW; x++) {
                double d[3] = { (x - 0.5 * (OW - 1)) / OF, (y - 0.5 * (OH - 1)) / OF, 1.0 }, e[3];
                for (int k = 0; k < 3; k++)
                    e[k] = R[3 * k] * d[0] + R[3 * k + 1] * d[1] + R[3 * k + 2] * d[2];
                double u = scx + sfx * e[0] / e[2], v = scy + sfx * e[1] / e[2];
                int u0 = (int)floor(u), v0 = (int)floor(v);
                double fu = u - u0, fv = v - v0;
                uint8_t *o = out + 3 * ((size_t)y * OW + x);
                if (e[2] <= 0 || u0 < 0 || v0 < 0 || u0 + 1 >= (int)f->width || v0 + 1 >= (int)f->height) {
                    o[0] = o[1] = o[2] = 0; /* outside the source: black, as a border would be */
                    continue;
                }
                for (int c = 0; c < 3; c++) {
                    const uint8_t *p = in + 3 * ((size_t)v0 * f->width + u0) + c;
                    size_t row = (size_t)f->width * 3;
                    double val = (1 - fv) * ((1 - fu) * p[0] + fu * p[3]) + fv * ((1 - fu) * p[row] + fu * p[row + 3]);
                    o[c] = (uint8_t)lrint(val);
                }
            }
        sp_frame of = { .format = SP_PIXFMT_RGB24,
                        .width = OW,
                        .height = OH,
                        .stride = OW * 3,
                        .data = out,
                        .capacity = (size_t)OW * OH * 3,
                        .bytes_used = (size_t)OW * OH * 3,
                        .timestamp_ns = ev.timestamp_ns,
                        .sequence = n,
                        .exposure_us = NAN,
                        .gain = NAN };
        if (!ret)
            ret = sp_capture_write_frame(w, &of);
        float truth[4] = { (float)q.w, (float)q.x, (float)q.y, (float)q.z };
        if (!ret)
            ret = sp_capture_write_side(w, ev.timestamp_ns, n, SP_SIDE_TRUE_ORIENTATION, truth, 4);
        sp_event_release(&ev);
        n++;
    }
    if (ret == SP_EOS)
        ret = 0;
    int cret = w ? sp_capture_writer_close(&w) : 0;
    sp_source_close(&src);
    free(in), free(out);
    if (ret || cret)
        return fprintf(stderr, "rotate_footage: %s\n", sp_strerror(ret ? ret : cret)), 1;
    printf("%s: %llu frames of %dx%d, rotated\n", argv[2], (unsigned long long)n, OW, OH);
    return 0;
}
