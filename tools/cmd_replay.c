/* SPDX-License-Identifier: MIT */
/* `sunprobe replay`: stream a capture through a pipeline stage, as fast as possible or in real time. */
#include <errno.h>
#include <getopt.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "capture_open.h"
#include "cmd.h"
#include "common/clock.h"
#include "common/progress.h"
#include "pipeline/stage.h"
#include "sunprobe/sp_replay.h"

static void usage(FILE *out)
{
    fprintf(out, "usage: sunprobe replay CAPTURE [--stage NAME] [--realtime] [--speed X] [--start S]\n"
                 "                       [--skip-corrupt] [-o OUTPUT]\n\n"
                 "Streams a capture's frames and IMU samples, in timestamp order, through a stage.\n"
                 "  --stage NAME     stage to run (default null); --list-stages shows them\n"
                 "  --realtime       pace events by their timestamps (default: as fast as possible)\n"
                 "  --speed X        real-time speed factor (default 1)\n"
                 "  --start S        start S seconds after the first chunk (seeks via the index)\n"
                 "  --skip-corrupt   skip corrupt chunks instead of stopping\n"
                 "  -o, --output F   stage output file (CSV for stages that write one)\n");
    fprintf(out, "\nstages:\n");
    for (const sp_stage_ops *const *s = sp_stage_registry(); *s; s++)
        fprintf(out, "  %-12s %s\n", (*s)->name, (*s)->description);
}

typedef struct replay_args {
    const char *path, *stage, *output;
    int realtime, skip_corrupt;
    double speed, start_s;
} replay_args;

static int parse_args(int argc, char **argv, replay_args *a)
{
    static const struct option opts[] = {
        { "help", no_argument, NULL, 'h' },          { "stage", required_argument, NULL, 's' },
        { "realtime", no_argument, NULL, 'r' },      { "speed", required_argument, NULL, 'x' },
        { "start", required_argument, NULL, 't' },   { "skip-corrupt", no_argument, NULL, 'k' },
        { "output", required_argument, NULL, 'o' },  { "list-stages", no_argument, NULL, 'l' },
        { 0 },
    };
    *a = (replay_args){ .stage = "null", .speed = 1.0, .start_s = NAN };
    int c;
    char *end;
    while ((c = getopt_long(argc, argv, "hs:rx:t:ko:l", opts, NULL)) != -1) {
        switch (c) {
        case 'h':
        case 'l':
            usage(stdout);
            return -1;
        case 's': a->stage = optarg; break;
        case 'r': a->realtime = 1; break;
        case 'k': a->skip_corrupt = 1; break;
        case 'o': a->output = optarg; break;
        case 'x':
            a->speed = strtod(optarg, &end);
            if (*end || !(a->speed > 0 && a->speed < 1e6))
                return SP_EXIT_USAGE;
            break;
        case 't':
            a->start_s = strtod(optarg, &end);
            if (*end || !(a->start_s >= 0 && a->start_s < 1e6))
                return SP_EXIT_USAGE;
            break;
        default:
            return SP_EXIT_USAGE;
        }
    }
    if (optind != argc - 1)
        return SP_EXIT_USAGE;
    a->path = argv[optind];
    return 0;
}

/* Timestamp of the first chunk, so --start is relative to the capture's beginning. */
static int first_timestamp(const char *path, int64_t *t0)
{
    sp_capture_reader *r = NULL;
    sp_capture_reader_settings rs;
    sp_capture_reader_default_settings(&rs);
    rs.skip_corrupt = 1;
    int ret = sp_capture_reader_open(&r, path, &rs);
    sp_chunk c;
    if (!ret)
        ret = sp_capture_reader_next(r, &c);
    if (!ret)
        *t0 = c.timestamp_ns;
    sp_capture_reader_close(&r);
    return ret;
}

static int run_stage(const replay_args *a, const sp_stage_ops *ops, sp_source *src)
{
    void *ctx = NULL;
    sp_stage_options so = { .output_path = a->output };
    int ret = ops->open(&ctx, &so);
    if (ret)
        return sp_cmd_fail("replay", ret, "opening the stage");
    sp_progress bar;
    sp_progress_start(&bar, "replay", 0, -1);
    int64_t t_start = sp_clock_monotonic_ns();
    uint64_t events = 0, frames = 0;
    sp_event ev;
    while ((ret = sp_source_next(src, &ev)) == 0) {
        events++;
        frames += ev.type == SP_EVENT_FRAME;
        ret = ops->process(ctx, &ev);
        sp_event_release(&ev);
        if (ret)
            break;
        if ((events & 255) == 0)
            sp_progress_update(&bar, frames, "frames");
    }
    sp_progress_finish(&bar);
    double secs = (double)(sp_clock_monotonic_ns() - t_start) * 1e-9;
    int code = SP_EXIT_OK;
    if (ret != SP_EOS) {
        code = ret == -EAGAIN ? sp_cmd_fail("replay", ret, "stage holds every frame")
                              : sp_tool_capture_error("replay", a->path, ret, 0);
    } else if ((ret = ops->finish(ctx, stdout))) {
        code = sp_cmd_fail("replay", ret, "finishing the stage");
    }
    ops->close(ctx);
    sp_replay_stats st;
    sp_replay_get_stats(src, &st);
    printf("replay: %" PRIu64 " frames, %" PRIu64 " IMU samples in %.3f s (%.1f frames/s, %.1f MB/s)%s\n", st.frames,
           st.imu_samples, secs, secs > 0 ? (double)st.frames / secs : 0.0,
           secs > 0 ? (double)st.bytes_read / secs / 1e6 : 0.0, st.truncated ? "; torn tail ignored" : "");
    if (st.corrupt_chunks || st.late_events)
        printf("replay: %" PRIu64 " corrupt chunks skipped, %" PRIu64 " events later than the reorder window\n",
               st.corrupt_chunks, st.late_events);
    return code;
}

int sp_cmd_replay(int argc, char **argv)
{
    replay_args a;
    int code = parse_args(argc, argv, &a);
    if (code) {
        if (code > 0)
            usage(stderr);
        return code > 0 ? code : SP_EXIT_OK;
    }
    const sp_stage_ops *ops = sp_stage_find(a.stage);
    if (!ops) {
        fprintf(stderr, "sunprobe replay: unknown stage '%s' (see --list-stages)\n", a.stage);
        return SP_EXIT_USAGE;
    }
    sp_replay_settings rs;
    sp_replay_default_settings(&rs);
    rs.realtime = a.realtime;
    rs.speed = a.speed;
    rs.skip_corrupt = a.skip_corrupt;
    if (!isnan(a.start_s)) {
        int64_t t0 = 0;
        int ret = first_timestamp(a.path, &t0);
        if (ret)
            return sp_tool_capture_error("replay", a.path, ret, 0);
        rs.start_ns = t0 + (int64_t)(a.start_s * 1e9);
    }
    sp_source *src = NULL;
    int ret = sp_replay_open(&src, a.path, &rs);
    if (ret)
        return sp_tool_capture_error("replay", a.path, ret, 0);
    code = run_stage(&a, ops, src);
    sp_source_close(&src);
    return code;
}
