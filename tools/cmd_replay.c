/* SPDX-License-Identifier: MIT */
/* `sunprobe replay`: stream a capture through a pipeline stage, as fast as possible or in real time. */
#include <errno.h>
#include <getopt.h>
#include <inttypes.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>

#include "capture_open.h"
#include "cmd.h"
#include "pipeline/stages/stages.h"
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
            if (sp_opt_double("replay", "speed", optarg, 1e-6, 1e6, &a->speed))
                return SP_EXIT_USAGE;
            break;
        case 't':
            if (sp_opt_double("replay", "start", optarg, 0, 1e6, &a->start_s))
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

/* What the tagger's orientation filter did (stages that want tagged frames). */
static void print_filter(const sp_tagger_stats *t)
{
    if (!t->have_filter)
        return;
    const sp_orientation_stats *f = &t->filter;
    printf("orientation: %" PRIu64 " IMU samples used, dropped %" PRIu64 " duplicate / %" PRIu64 " out-of-order / %" PRIu64
           " invalid, %" PRIu64 " gaps, %" PRIu64 " saturated; gyro bias (%.3f, %.3f, %.3f) deg/s%s\n",
           f->samples_used, f->dropped_duplicate, f->dropped_out_of_order, f->dropped_invalid, f->gaps, f->saturated,
           f->gyro_bias.x * 180 / M_PI, f->gyro_bias.y * 180 / M_PI, f->gyro_bias.z * 180 / M_PI,
           f->bias_from_still ? " (from a still period)" : "");
    if (t->thinned)
        printf("orientation: %" PRIu64 " frames dropped while the filter initialised\n", t->thinned);
}

static int run_stage(const replay_args *a, const sp_stage_ops *ops, const sp_run_settings *rs)
{
    sp_stage stage = { 0 };
    sp_stage_options so = { .output_path = a->output };
    /* Ctrl-C stops before the next event, without finish: a stage output is not committed. Caught before
     * the output's temporary file exists and held until it is gone, so no signal ends the process with it left. */
    sp_cmd_signals sig;
    sp_cmd_catch_signals(&sig);
    int ret = sp_stage_open(&stage, ops, &so);
    if (ret) {
        sp_cmd_restore_signals(&sig);
        return a->output && sp_exit_for_error(ret) == SP_EXIT_IO
                   ? sp_cmd_failf("replay", ret, "opening the stage's output %s", a->output)
                   : sp_cmd_fail("replay", ret, "opening the stage");
    }
    sp_run_stats st;
    ret = sp_stage_run(a->path, &stage, rs, &st);
    int code = SP_EXIT_OK;
    if (sp_cmd_stop_signal && st.stopped) { /* a signal during finish came too late: the output is whole */
        fprintf(stderr, "sunprobe replay: interrupted after %" PRIu64 " frames%s\n", st.frames,
                a->output ? "; output not written" : "");
        code = sp_exit_for_error(-ECANCELED);
    } else if (ret == -EAGAIN && st.failed_in == SP_RUN_FAILED_SOURCE)
        code = sp_cmd_fail("replay", ret, "stage holds every frame");
    else if (st.failed_in == SP_RUN_FAILED_FINISH && a->output) {
        code = sp_cmd_failf("replay", ret, "finishing the stage (output %s not written)", a->output);
    } else if (st.failed_in == SP_RUN_FAILED_FINISH)
        code = sp_cmd_fail("replay", ret, "finishing the stage");
    else if (ret)
        code = sp_tool_capture_error("replay", a->path, ret, st.replay.error_offset);
    sp_stage_close(&stage); /* removes an uncommitted output: only then may a signal end the process */
    sp_cmd_restore_signals(&sig);
    if (st.failed_in == SP_RUN_FAILED_OPEN)
        return code;
    if (st.tagged)
        print_filter(&st.tagger);
    const sp_replay_stats *rp = &st.replay;
    double secs = st.seconds;
    printf("replay: %" PRIu64 " frames, %" PRIu64 " IMU samples in %.3f s (%.1f frames/s, %.1f MB/s)%s\n", rp->frames,
           rp->imu_samples, secs, secs > 0 ? (double)rp->frames / secs : 0.0,
           secs > 0 ? (double)rp->bytes_read / secs / 1e6 : 0.0, rp->truncated ? "; torn tail ignored" : "");
    if (rp->corrupt_chunks || rp->late_events)
        printf("replay: %" PRIu64 " corrupt chunks skipped, %" PRIu64 " events later than the reorder window\n",
               rp->corrupt_chunks, rp->late_events);
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
    if (a.output && !ops->writes_output) { /* it would be ignored, and the user left without the file */
        fprintf(stderr, "sunprobe replay: stage '%s' writes no output file: -o %s needs a stage that does "
                        "(stats, orientation, landmarks)\n", a.stage, a.output);
        return SP_EXIT_USAGE;
    }
    sp_run_settings run;
    sp_run_default_settings(&run);
    run.progress_label = "replay";
    run.stop = &sp_cmd_stop_signal;
    sp_replay_settings *rs = &run.replay;
    rs->realtime = a.realtime;
    rs->speed = a.speed;
    rs->skip_corrupt = a.skip_corrupt;
    if (!isnan(a.start_s)) {
        int64_t t0 = 0;
        int ret = first_timestamp(a.path, &t0);
        if (ret)
            return sp_tool_capture_error("replay", a.path, ret, 0);
        rs->start_ns = t0 + (int64_t)(a.start_s * 1e9);
    }
    sp_capture_reader *check = NULL; /* a capture that cannot be opened leaves no stage output behind */
    if ((code = sp_tool_open_capture("replay", a.path, a.skip_corrupt, &check)))
        return code;
    sp_capture_reader_close(&check);
    return run_stage(&a, ops, &run);
}
