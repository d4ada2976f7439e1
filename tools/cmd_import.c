/* SPDX-License-Identifier: MIT */
/* `sunprobe import`: image sequence or video (+ IMU CSV + frame times + metadata JSON) to a capture. */
#include <errno.h>
#include <getopt.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd.h"
#include "common/progress.h"
#include "sunprobe/sp_import.h"

#define CMD "import"

static void usage(FILE *out)
{
    fprintf(out,
            "usage: sunprobe import INPUT -o OUT.spcap [options]\n\n"
            "INPUT is a directory of .jpg/.jpeg/.png images (sorted by name, numbers in names compared\n"
            "as numbers), a pattern such as shots/img_%%04d.png, one image, or a video file (OpenCV).\n"
            "JPEG files are stored byte-for-byte; other images and video frames are re-encoded.\n\n"
            "options:\n"
            "  -o, --output FILE       capture to create (written as FILE.partial, renamed when complete)\n"
            "      --fps F             frame rate for timestamps, 0.001..10000 (default: frame-times CSV,\n"
            "                          the video's rate, or camera.fps of --meta; required otherwise)\n"
            "      --frame-times CSV   per-frame times: column t (seconds) or t_ns, one row per frame\n"
            "      --exposure CSV      per-frame exposure: exposure_s and/or iso or gain, one row per frame\n"
            "                          (the frame-times CSV may carry these columns too)\n"
            "      --imu LOG           IMU samples: t or t_ns, then gx,gy,gz (rad/s) ax,ay,az (m/s^2)\n"
            "                          mx,my,mz (uT); times on the frame clock, 0 = first frame\n"
            "      --imu-offset S      seconds added to every IMU time, -1e6..1e6 (default 0), or auto:\n"
            "                          estimated within +-2 s from the gyro and the frames' motion\n"
            "      --imu-format F      auto (default: by content), sunprobe, sensor-logger, opencamera, gcsv\n"
            "                          (a Sensor Logger directory or .zip may also be INPUT: video + IMU)\n"
            "      --imu-to-camera P   IMU axes to camera axes: android-front, android-back, ios-front,\n"
            "                          ios-back or identity (replaces the metadata's imu.to_camera)\n"
            "      --meta JSON         metadata (capture/FORMAT.md), merged with what the import knows\n"
            "      --kind K            selfie or static (overrides the metadata's)\n"
            "      --store M           jpeg (default) or rgb: how non-JPEG frames are stored\n"
            "      --quality Q         JPEG quality for re-encoded frames, 1..100 (default 92)\n"
            "      --max-frames N      stop after N frames\n"
            "  -f, --force             replace OUT if it exists (never one of the inputs)\n"
            "  -q, --quiet             no progress bar or summary\n"
            "  -h, --help              this text\n\n"
            "Layouts and examples: capture/IMPORT.md.\n");
}

static void on_progress(void *user, uint64_t done, uint64_t total)
{
    sp_progress *p = user;
    if (p->total != total)
        p->total = total;
    sp_progress_update(p, done, NULL);
}

enum { OPT_FPS = 256, OPT_FRAME_TIMES, OPT_IMU, OPT_IMU_OFFSET, OPT_META, OPT_KIND, OPT_STORE, OPT_QUALITY,
       OPT_MAX_FRAMES, OPT_IMU_FORMAT, OPT_TO_CAMERA, OPT_EXPOSURE };

/* Fills s from the command line; returns -1 to go on, else an exit code. */
static int parse_args(int argc, char **argv, sp_import_settings *s, int *quiet)
{
    static const struct option opts[] = {
        { "output", required_argument, NULL, 'o' },       { "fps", required_argument, NULL, OPT_FPS },
        { "frame-times", required_argument, NULL, OPT_FRAME_TIMES }, { "imu", required_argument, NULL, OPT_IMU },
        { "imu-offset", required_argument, NULL, OPT_IMU_OFFSET }, { "meta", required_argument, NULL, OPT_META },
        { "kind", required_argument, NULL, OPT_KIND },    { "store", required_argument, NULL, OPT_STORE },
        { "quality", required_argument, NULL, OPT_QUALITY }, { "max-frames", required_argument, NULL, OPT_MAX_FRAMES },
        { "imu-format", required_argument, NULL, OPT_IMU_FORMAT },
        { "exposure", required_argument, NULL, OPT_EXPOSURE },
        { "imu-to-camera", required_argument, NULL, OPT_TO_CAMERA },
        { "force", no_argument, NULL, 'f' },              { "quiet", no_argument, NULL, 'q' },
        { "help", no_argument, NULL, 'h' },               { 0 },
    };
    optind = 0; /* full getopt reset: commands may run more than once in a process (tests) */
    static const char *const stores[] = { "jpeg", "rgb" };
    static const char *const presets[] = { "identity", "android-front", "android-back", "ios-front", "ios-back" };
    static const char *const imu_formats[] = { "auto", "sunprobe", "sensor-logger", "opencamera", "gcsv" };
    int c, bad = 0, v = 0;
    while (!bad && (c = getopt_long(argc, argv, "o:fqh", opts, NULL)) != -1) {
        switch (c) {
        case 'o': s->output = optarg; break;
        case OPT_FPS: bad = sp_opt_double(CMD, "fps", optarg, SP_IMPORT_MIN_FPS, SP_IMPORT_MAX_FPS, &s->fps); break;
        case OPT_FRAME_TIMES: s->frame_times_csv = optarg; break;
        case OPT_IMU: s->imu_csv = optarg; break;
        case OPT_EXPOSURE: s->exposure_csv = optarg; break;
        case OPT_IMU_OFFSET:
            s->imu_offset_auto = strcmp(optarg, "auto") == 0;
            bad = s->imu_offset_auto ? 0 : sp_opt_double(CMD, "imu-offset", optarg, -1e6, 1e6, &s->imu_offset_s);
            break;
        case OPT_META: s->meta_json = optarg; break;
        case OPT_KIND: s->kind = optarg; break;
        case OPT_STORE:
            bad = sp_opt_choice(CMD, "store", optarg, stores, 2, &v);
            s->store = v == 1 ? SP_IMPORT_STORE_RGB : SP_IMPORT_STORE_JPEG;
            break;
        case OPT_IMU_FORMAT:
            bad = sp_opt_choice(CMD, "imu-format", optarg, imu_formats, 5, &v);
            s->imu_format = (enum sp_import_imu_format)v;
            break;
        case OPT_TO_CAMERA:
            bad = sp_opt_choice(CMD, "imu-to-camera", optarg, presets, 5, &v);
            s->imu_to_camera = (enum sp_import_to_camera)(v + SP_IMPORT_TO_CAMERA_IDENTITY);
            break;
        case OPT_QUALITY: bad = sp_opt_int(CMD, "quality", optarg, 1, 100, &s->quality); break;
        case OPT_MAX_FRAMES: bad = sp_opt_u64(CMD, "max-frames", optarg, 1, UINT64_MAX, &s->max_frames); break;
        case 'f': s->overwrite = 1; break;
        case 'q': *quiet = 1; break;
        case 'h': usage(stdout); return SP_EXIT_OK;
        default: usage(stderr); return SP_EXIT_USAGE;
        }
    }
    if (bad) {
        fprintf(stderr, "sunprobe " CMD ": see --help\n");
        return SP_EXIT_USAGE;
    }
    if (optind != argc - 1 || !s->output) {
        fprintf(stderr, "sunprobe import: %s\n", optind != argc - 1 ? "expected one INPUT" : "-o OUT is required");
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    s->input = argv[optind];
    return -1;
}

static void print_summary(const sp_import_settings *s, const sp_import_report *r)
{
    printf("%s: %llu frames %ux%u", s->output, (unsigned long long)r->frames, r->width, r->height);
    if (r->fps > 0)
        printf(" at %.6g fps", r->fps);
    printf(", %.3f s (times: %s)", (double)r->last_frame_ns * 1e-9, r->frame_clock);
    if (r->frames_copied)
        printf(", %llu JPEG files copied as-is", (unsigned long long)r->frames_copied);
    if (r->imu_clock[0])
        printf(", %llu IMU samples in %llu chunks", (unsigned long long)r->imu_samples,
               (unsigned long long)r->imu_chunks);
    printf("\n");
    if (r->imu_clock[0])
        printf("IMU clock: %s\n", r->imu_clock);
    if (s->imu_offset_auto)
        printf("IMU offset: %+.4f s estimated (gyro rate against the frames' motion, correlation %.2f)\n",
               r->imu_offset_s, r->imu_offset_corr);
}

int sp_cmd_import(int argc, char **argv)
{
    sp_import_settings s;
    sp_import_default_settings(&s);
    int quiet = 0;
    int code = parse_args(argc, argv, &s, &quiet);
    if (code >= 0)
        return code;

    sp_progress bar;
    sp_progress_start(&bar, "import", 0, quiet ? 0 : -1);
    s.progress = on_progress;
    s.progress_user = &bar;
    s.cancel = &sp_cmd_stop_signal;
    sp_cmd_signals sig;
    sp_cmd_catch_signals(&sig);

    sp_import_report report;
    int rc = sp_import_run(&s, &report);

    sp_cmd_restore_signals(&sig);
    sp_progress_finish(&bar);
    if (rc) {
        fprintf(stderr, "sunprobe import: %s\n", report.message);
        return sp_exit_for_error(rc);
    }
    if (!quiet)
        print_summary(&s, &report);
    return SP_EXIT_OK;
}
