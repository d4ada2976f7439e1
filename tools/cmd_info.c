/* SPDX-License-Identifier: MIT */
/* `sunprobe info`: what a capture holds — devices, durations, frame/IMU counts, gaps, corrupt chunks. */
#include <getopt.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "capture_open.h"
#include "cmd.h"
#include "common/json.h"
#include "sunprobe/sp_meta.h"

#define MAX_STREAMS 8
#define WARMUP 64 /* intervals used to estimate the nominal rate before gaps are judged */

/* Timing of one regular series (a camera stream or an IMU sensor): count, span, gaps. */
typedef struct series {
    uint64_t count;
    int64_t first, last;
    int64_t warm[WARMUP];
    unsigned n_warm;
    double nominal_ns; /* median of the first intervals, or from metadata */
    uint64_t gaps;     /* intervals over 1.5x (frames) or 5x (IMU) nominal */
    double max_gap_ns;
    uint64_t backwards; /* timestamps going back */
} series;

typedef struct stream_info {
    uint32_t id;
    series timing;
    uint64_t bytes, dropped;
    uint64_t last_seq;
    enum sp_pixfmt format;
    uint32_t width, height;
    int mixed_format;
    double exp_min, exp_max;
} stream_info;

typedef struct info {
    stream_info streams[MAX_STREAMS];
    unsigned n_streams;
    series imu[4]; /* by sensor kind 1..3 */
    uint64_t chunks[8], unknown, side, bad_payloads;
    sp_capture_meta meta;
    int had_end;
} info;

static int cmp_i64(const void *a, const void *b)
{
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

static void judge_gap(series *s, double dt, double factor)
{
    if (dt > factor * s->nominal_ns) {
        s->gaps++;
        if (dt > s->max_gap_ns)
            s->max_gap_ns = dt;
    }
}

static void series_add(series *s, int64_t t, double factor)
{
    if (s->count == 0) {
        s->first = s->last = t;
        s->count = 1;
        return;
    }
    if (t < s->last) {
        s->backwards++;
    } else if (s->nominal_ns > 0) {
        judge_gap(s, (double)(t - s->last), factor);
    } else if (s->n_warm < WARMUP) {
        s->warm[s->n_warm++] = t - s->last;
        if (s->n_warm == WARMUP) { /* nominal known now: judge the warm-up intervals too */
            int64_t sorted[WARMUP];
            memcpy(sorted, s->warm, sizeof(sorted));
            qsort(sorted, WARMUP, sizeof(int64_t), cmp_i64);
            s->nominal_ns = (double)sorted[WARMUP / 2];
            for (unsigned i = 0; i < WARMUP; i++)
                judge_gap(s, (double)s->warm[i], factor);
        }
    }
    s->count++;
    if (t > s->last)
        s->last = t;
}

/* Short series never fill the warm-up: judge them at the end. */
static void series_finish(series *s, double factor)
{
    if (s->nominal_ns > 0 || s->n_warm < 2)
        return;
    int64_t sorted[WARMUP];
    memcpy(sorted, s->warm, s->n_warm * sizeof(int64_t));
    qsort(sorted, s->n_warm, sizeof(int64_t), cmp_i64);
    s->nominal_ns = (double)sorted[s->n_warm / 2];
    for (unsigned i = 0; i < s->n_warm; i++)
        judge_gap(s, (double)s->warm[i], factor);
}

static stream_info *stream_for(info *in, uint32_t id)
{
    for (unsigned i = 0; i < in->n_streams; i++)
        if (in->streams[i].id == id)
            return &in->streams[i];
    if (in->n_streams == MAX_STREAMS)
        return NULL;
    stream_info *s = &in->streams[in->n_streams++];
    memset(s, 0, sizeof(*s));
    s->id = id;
    s->exp_min = INFINITY;
    s->exp_max = -INFINITY;
    return s;
}

static void add_frame(info *in, const sp_chunk *c)
{
    sp_frame_chunk f;
    stream_info *s;
    if (sp_chunk_parse_frame(c, &f) || !(s = stream_for(in, f.stream_id))) {
        in->bad_payloads++;
        return;
    }
    if (s->timing.count == 0) {
        s->format = f.format;
        s->width = f.width;
        s->height = f.height;
        if (isfinite(in->meta.fps) && in->meta.fps > 0)
            s->timing.nominal_ns = 1e9 / in->meta.fps;
    } else {
        if (f.format != s->format || f.width != s->width || f.height != s->height)
            s->mixed_format = 1;
        if (f.sequence > s->last_seq + 1)
            s->dropped += f.sequence - s->last_seq - 1;
    }
    s->last_seq = f.sequence;
    s->bytes += f.data_size;
    if (isfinite(f.exposure_us)) {
        s->exp_min = fmin(s->exp_min, f.exposure_us);
        s->exp_max = fmax(s->exp_max, f.exposure_us);
    }
    series_add(&s->timing, c->timestamp_ns, 1.5);
}

static void add_imu(info *in, const sp_chunk *c)
{
    int64_t n = sp_chunk_imu_count(c);
    if (n < 0) {
        in->bad_payloads++;
        return;
    }
    for (int64_t i = 0; i < n; i++) {
        sp_imu_sample smp;
        if (sp_chunk_imu_get(c, (size_t)i, &smp) == 0 && smp.sensor >= 1 && smp.sensor <= 3)
            series_add(&in->imu[smp.sensor], smp.timestamp_ns, 5.0);
    }
}

static void add_chunk(info *in, const sp_chunk *c)
{
    if (c->type < 8)
        in->chunks[c->type]++;
    else
        in->unknown++;
    switch (c->type) {
    case SP_CHUNK_FRAME:
        add_frame(in, c);
        break;
    case SP_CHUNK_IMU:
        add_imu(in, c);
        break;
    case SP_CHUNK_META:
        if (sp_capture_meta_merge(&in->meta, (const char *)c->payload, c->payload_size))
            in->bad_payloads++;
        break;
    default:
        break;
    }
}

static double span_s(const series *s)
{
    return s->count > 1 ? (double)(s->last - s->first) * 1e-9 : 0.0;
}

static void print_meta(const sp_capture_meta *m)
{
    char a[4 * 256 + 8], b[4 * 256 + 8]; /* the META strings, escaped: 4 bytes per character at most */
    printf("kind:        %s\n", m->kind[0] ? sp_cmd_printable(m->kind, a, sizeof(a)) : "(not given)");
    if (m->source[0])
        printf("source:      %s\n", sp_cmd_printable(m->source, a, sizeof(a)));
    if (m->camera_name[0])
        printf("camera:      %s%s%s%s\n", sp_cmd_printable(m->camera_name, a, sizeof(a)), m->camera_driver[0] ? " (" : "",
               sp_cmd_printable(m->camera_driver, b, sizeof(b)), m->camera_driver[0] ? ")" : "");
    double f = sp_capture_meta_focal_px(m);
    if (isfinite(f))
        printf("focal:       %.1f px\n", f);
    if (m->imu_name[0])
        printf("imu:         %s\n", sp_cmd_printable(m->imu_name, a, sizeof(a)));
    if (isfinite(m->latitude))
        printf("location:    %.5f, %.5f\n", m->latitude, m->longitude);
    if (m->utc_start[0])
        printf("utc start:   %s\n", sp_cmd_printable(m->utc_start, a, sizeof(a)));
}

static void print_text(const char *path, const info *in, const sp_capture_info *ci, uint64_t corrupt,
                       uint64_t first_corrupt, int truncated, uint64_t torn_at)
{
    printf("capture:     %s (format %u.%u, %" PRIu64 " bytes)\n", path, ci->version_major, ci->version_minor,
           ci->file_size);
    print_meta(&in->meta);
    for (unsigned i = 0; i < in->n_streams; i++) {
        const stream_info *s = &in->streams[i];
        double dur = span_s(&s->timing);
        printf("frames[%u]:   %" PRIu64 " %s %ux%u%s, %.2f s, %.2f fps, %" PRIu64 " gaps (max %.0f ms), "
               "%" PRIu64 " dropped by sequence\n", s->id, s->timing.count, sp_pixfmt_name(s->format), s->width,
               s->height, s->mixed_format ? " (mixed formats)" : "", dur,
               dur > 0 ? (double)(s->timing.count - 1) / dur : 0.0, s->timing.gaps, s->timing.max_gap_ns * 1e-6,
               s->dropped);
        if (s->exp_max >= s->exp_min)
            printf("exposure[%u]: %.0f..%.0f us\n", s->id, s->exp_min, s->exp_max);
        if (s->timing.backwards)
            printf("warning:     %" PRIu64 " frame timestamps go backwards\n", s->timing.backwards);
    }
    if (!in->n_streams)
        printf("frames:      none\n");
    for (int k = 1; k <= 3; k++) {
        const series *s = &in->imu[k];
        if (!s->count)
            continue;
        double dur = span_s(s);
        printf("imu %-6s   %" PRIu64 " samples, %.2f s, %.1f Hz, %" PRIu64 " gaps (max %.0f ms)%s\n",
               sp_imu_sensor_name((enum sp_imu_sensor)k), s->count, dur, dur > 0 ? (double)(s->count - 1) / dur : 0.0,
               s->gaps, s->max_gap_ns * 1e-6, s->backwards ? ", out-of-order samples" : "");
    }
    if (!in->imu[1].count && !in->imu[2].count)
        printf("imu:         none\n");
    printf("chunks:      %" PRIu64 " meta, %" PRIu64 " frame, %" PRIu64 " imu, %" PRIu64 " side, %" PRIu64
           " index, %" PRIu64 " unknown\n", in->chunks[SP_CHUNK_META], in->chunks[SP_CHUNK_FRAME],
           in->chunks[SP_CHUNK_IMU], in->chunks[SP_CHUNK_SIDE], in->chunks[SP_CHUNK_INDEX], in->unknown);
    printf("corrupt:     %" PRIu64 " chunks", corrupt);
    if (corrupt)
        printf(" (first at byte %" PRIu64 ")", first_corrupt);
    printf(", %" PRIu64 " malformed payloads\n", in->bad_payloads);
    if (truncated)
        printf("end:         torn tail at byte %" PRIu64 " (run `sunprobe recover`)\n", torn_at);
    else
        printf("end:         %s\n", in->had_end ? "closed cleanly" : "no END chunk (writer did not close)");
}

static void usage(FILE *out)
{
    fprintf(out, "usage: sunprobe info CAPTURE\n\n"
                 "Summarises a capture: devices and calibration, per-stream frame counts, formats, durations,\n"
                 "rates and timing gaps, IMU sample counts per sensor, corrupt chunks and how the file ends.\n"
                 "Corrupt chunks are skipped and counted. Exit 0 when readable, 2 when not a capture.\n");
}

int sp_cmd_info(int argc, char **argv)
{
    static const struct option opts[] = { { "help", no_argument, NULL, 'h' }, { 0 } };
    int c;
    while ((c = getopt_long(argc, argv, "h", opts, NULL)) != -1) {
        if (c == 'h') {
            usage(stdout);
            return SP_EXIT_OK;
        }
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    if (optind != argc - 1) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    const char *path = argv[optind];
    sp_capture_reader *r = NULL;
    int code = sp_tool_open_capture("info", path, 1, &r);
    if (code)
        return code;
    info *in = calloc(1, sizeof(*in));
    if (!in) {
        sp_capture_reader_close(&r);
        return sp_cmd_fail("info", -12, "allocating");
    }
    sp_capture_meta_init(&in->meta);
    sp_chunk chunk;
    int ret;
    while ((ret = sp_capture_reader_next(r, &chunk)) == 0)
        add_chunk(in, &chunk);
    in->had_end = sp_capture_reader_saw_end(r);
    for (unsigned i = 0; i < in->n_streams; i++)
        series_finish(&in->streams[i].timing, 1.5);
    for (int k = 1; k <= 3; k++)
        series_finish(&in->imu[k], 5.0);
    if (ret == SP_EOS || ret == SP_ETRUNCATED) {
        print_text(path, in, sp_capture_reader_info(r), sp_capture_reader_corrupt_count(r),
                   sp_capture_reader_first_corrupt_offset(r), ret == SP_ETRUNCATED, chunk.offset);
        code = SP_EXIT_OK;
    } else {
        code = sp_tool_capture_error("info", path, ret, chunk.offset);
    }
    free(in);
    sp_capture_reader_close(&r);
    return code;
}
