/* SPDX-License-Identifier: MIT */
/* `sunprobe record`: a live camera (+ IMU) to a capture file, until the duration, Ctrl-C or the device goes. */
#include <errno.h>
#include <getopt.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "cmd.h"
#include "live_check.h"
#include "sunprobe/sp_recorder.h"

#define CMD "record"

typedef struct record_args {
    sp_camera_settings cam;
    sp_imu_device_settings imu;
    sp_recorder_settings rec;
    const char *imu_name;
    int quiet;
    int live_check; /* selfie mode: `sunprobe check` on the capture while it is recorded */
    int live_faces; /* ... with the landmark tracker */
    double live_max_lag_s;
} record_args;

#define LIVE_FACE_INTERVAL_S 0.25 /* the landmark tracker on four frames a second keeps up on a small board */
#define LIVE_LINE_PERIOD 10       /* off a terminal, a live check line every this many 0.2 s ticks */
#define LIVE_MAX_LAG_S 1.0        /* frames older than this when the tracker's turn comes are skipped */

static void usage(FILE *out)
{
    fprintf(out,
            "usage: sunprobe record [--camera NAME|/dev/videoN[:fourcc=XXXX]|fake[:opts]]\n"
            "                       [--imu NAME[+NAME..]|fake|none]\n"
            "                       [--mode selfie|static] [--duration S] [--format F] [--size WxH] [--fps F]\n"
            "                       [--lock-exposure] [--overwrite] -o CAPTURE.spcap\n\n"
            "Records frames (and IMU samples) to a capture until the duration passes or SIGINT/SIGTERM;\n"
            "the file is valid however it ends (device unplugged, disk full). `sunprobe devices` lists ids.\n"
            "  --camera D        camera id or name; default the first found (fake options: bars, panorama,\n"
            "                    unpaced, prerender, frames=N, e.g. fake:panorama); a V4L2 node may pick the\n"
            "                    device's layout, e.g. /dev/video0:fourcc=NM21 (4:2:0 layouts are stored as nv12)\n"
            "  --backend B       camera backend: v4l2, libcamera or fake; default the one that knows D\n"
            "  --imu D           IIO device id (iio:deviceN) or name, fake, or none (default); an IMU split\n"
            "                    over devices as A+B[+C], e.g. lsm6dsm_accel+lsm6dsm_gyro (one clock)\n"
            "  --mode M          selfie (default) or static, written to the metadata; selfie checks the\n"
            "                    capture as it is recorded (turn so far, face found, clipping; `sunprobe check`)\n"
            "                    and prints the check's verdict at the end\n"
            "  --no-live-check   selfie without that check;  --no-face  the check without the landmark tracker\n"
            "  --live-max-lag S  the check skips the tracker on frames older than S when it is behind (default 1)\n"
            "  --duration S      seconds; default: until interrupted\n"
            "  --format F        yuyv, nv12, mjpeg, rgb24, gray8; default the first the camera has\n"
            "  --size WxH        default 640x480;  --fps F  default the camera's\n"
            "  --lock-exposure   lock auto exposure, gain and white balance\n"
            "  --imu-rate HZ     IMU sampling rate; default the device's\n"
            "  --queue N         frames in flight to the disk writer (default 16)\n"
            "  --writer-delay-us N  test knob: the writer sleeps N us per chunk (a slow disk)\n"
            "  --sync P          none, periodic (default) or every (fdatasync after every chunk)\n"
            "exit: 0 done, 1 usage, 3 device lost or disk full (what was recorded is kept), 4 backend not built\n");
}

static int parse_size(const char *s, uint32_t *w, uint32_t *h)
{
    int a, b;
    if (sp_opt_size(CMD, "size", s, 16384, &a, &b))
        return -1;
    *w = (uint32_t)a, *h = (uint32_t)b;
    return 0;
}

/* One option into args; -1 after a message that names a bad value. */
static int apply_option(record_args *a, int c, const char *v)
{
    static const char *const modes[] = { "selfie", "static" }, *const syncs[] = { "none", "periodic", "every" };
    static const enum sp_sync_policy policy[] = { SP_SYNC_NONE, SP_SYNC_PERIODIC, SP_SYNC_EVERY_CHUNK };
    int i = 0, bad;
    uint64_t n = 0;
    switch (c) {
    case 'c': a->cam.device = v; return 0;
    case 'b': a->cam.backend = v; return 0;
    case 'i': a->imu_name = v; return 0;
    case 'm': a->rec.kind = v; return sp_opt_choice(CMD, "mode", v, modes, 2, &i);
    case 'd': return sp_opt_double(CMD, "duration", v, 0, 1e7, &a->rec.duration_s);
    case 'f':
        a->cam.format = sp_pixfmt_from_name(v);
        if (a->cam.format == SP_PIXFMT_NONE)
            fprintf(stderr, "sunprobe " CMD ": --format '%s': not a pixel format (see `sunprobe devices`)\n", v);
        return a->cam.format == SP_PIXFMT_NONE ? -1 : 0;
    case 's': return parse_size(v, &a->cam.width, &a->cam.height);
    case 'r': return sp_opt_double(CMD, "fps", v, 0.001, 10000, &a->cam.fps);
    case 'l': a->cam.lock_exposure = 1; return 0;
    case 'o': a->rec.path = v; return 0;
    case 'w': a->rec.writer.overwrite = 1; return 0;
    case 'q': a->quiet = 1; return 0;
    case 'L': a->live_check = 0; return 0;
    case 'F': a->live_faces = 0; return 0;
    case 'G': return sp_opt_double(CMD, "live-max-lag", v, 0, 1e6, &a->live_max_lag_s);
    case 'R': return sp_opt_double(CMD, "imu-rate", v, 0.001, 100000, &a->imu.rate_hz);
    case 'Q': bad = sp_opt_u64(CMD, "queue", v, 1, 4096, &n); a->rec.frame_queue = (unsigned)n; return bad;
    case 'D':
        bad = sp_opt_u64(CMD, "writer-delay-us", v, 0, 10000000, &n);
        a->rec.writer_delay_us = (uint32_t)n;
        return bad;
    case 'S': bad = sp_opt_choice(CMD, "sync", v, syncs, 3, &i); a->rec.writer.sync = policy[i]; return bad;
    default: return -1;
    }
}

static int parse_args(int argc, char **argv, record_args *a)
{
    static const struct option opts[] = {
        { "help", no_argument, NULL, 'h' },        { "camera", required_argument, NULL, 'c' },
        { "imu", required_argument, NULL, 'i' },   { "mode", required_argument, NULL, 'm' },
        { "duration", required_argument, NULL, 'd' }, { "format", required_argument, NULL, 'f' },
        { "size", required_argument, NULL, 's' },  { "fps", required_argument, NULL, 'r' },
        { "lock-exposure", no_argument, NULL, 'l' }, { "output", required_argument, NULL, 'o' },
        { "overwrite", no_argument, NULL, 'w' },   { "quiet", no_argument, NULL, 'q' },
        { "imu-rate", required_argument, NULL, 'R' }, { "queue", required_argument, NULL, 'Q' },
        { "writer-delay-us", required_argument, NULL, 'D' }, { "sync", required_argument, NULL, 'S' },
        { "backend", required_argument, NULL, 'b' }, { "no-live-check", no_argument, NULL, 'L' },
        { "no-face", no_argument, NULL, 'F' }, { "live-max-lag", required_argument, NULL, 'G' },
        { 0 } };
    int c;
    while ((c = getopt_long(argc, argv, "ho:q", opts, NULL)) != -1) {
        if (c == 'h') {
            usage(stdout);
            return 1;
        }
        if (apply_option(a, c, optarg) < 0) {
            if (c == '?') /* getopt named the option */
                usage(stderr);
            else
                fprintf(stderr, "sunprobe " CMD ": see --help\n");
            return -EINVAL;
        }
    }
    if (optind != argc || !a->rec.path) {
        fprintf(stderr, "sunprobe record: %s\n", optind != argc ? "unexpected arguments" : "-o CAPTURE is required");
        usage(stderr);
        return -EINVAL;
    }
    return 0;
}

static void print_progress(sp_recorder *rec, const char *check)
{
    sp_recorder_stats st;
    sp_recorder_get_stats(rec, &st);
    fprintf(stderr, "\r%" PRIu64 " frames, %" PRIu64 " dropped, %" PRIu64 " imu samples, %.1f MB%s%s   ",
            st.frames_written, st.frames_dropped + st.device_dropped, st.imu_samples_written,
            (double)st.bytes_written / 1e6, check[0] ? " | " : "", check);
}

static void print_summary(const char *path, const sp_camera_info *ci, const sp_recorder_stats *st)
{
    printf("%s: %" PRIu64 " frames %s %ux%u (%.2f s), %" PRIu64 " dropped by the writer queue, %" PRIu64
           " by the device, %" PRIu64 " imu samples (%" PRIu64 " dropped), %" PRIu64 " bytes; ended: %s\n",
           path, st->frames_written, sp_pixfmt_name(ci->format), ci->width, ci->height, st->duration_s,
           st->frames_dropped, st->device_dropped, st->imu_samples_written, st->imu_samples_dropped,
           st->bytes_written, sp_recorder_end_name(st->end));
    if (st->frames_discarded)
        printf("%" PRIu64 " queued frames were not written after the write error\n", st->frames_discarded);
}

/* Runs an opened recorder to its end, a caught SIGINT/SIGTERM (sp_cmd_stop_signal) asking it to stop (a
 * signal interrupts the sleep, so within a tick); the live check's status on the progress line of a terminal,
 * else on a line of its own every two seconds. A signal that came while the recorder was opened stops it at
 * once: the capture is then whole and empty. */
static int run(sp_recorder *rec, const record_args *a, sp_live_check *check, sp_recorder_stats *st)
{
    int err = sp_recorder_start(rec);
    int tty = !a->quiet && isatty(STDERR_FILENO);
    char status[192] = "";
    for (unsigned tick = 1; err == 0 && !sp_recorder_finished(rec); tick++) {
        if (sp_cmd_stop_signal)
            sp_recorder_request_stop(rec);
        nanosleep(&(struct timespec){ 0, 200000000 }, NULL);
        if (check)
            sp_live_check_status(check, status, sizeof(status));
        if (tty)
            print_progress(rec, status);
        else if (check && !a->quiet && status[0] && tick % LIVE_LINE_PERIOD == 0)
            fprintf(stderr, "live check: %s\n", status);
    }
    if (tty)
        fputc('\n', stderr);
    if (err == 0)
        err = sp_recorder_wait(rec, st);
    return err;
}

static int open_devices(record_args *a, sp_camera **cam, sp_imu_device **imu)
{
    int err = sp_camera_open(cam, &a->cam);
    if (err < 0)
        return sp_cmd_fail("record", err, a->cam.device ? a->cam.device : "opening the first camera");
    if (a->imu_name && strcmp(a->imu_name, "none")) {
        a->imu.device = a->imu_name;
        err = sp_imu_device_open(imu, &a->imu);
        if (err < 0) {
            sp_camera_close(cam);
            return sp_cmd_fail("record", err, a->imu_name);
        }
    }
    return 0;
}

int sp_cmd_record(int argc, char **argv)
{
    record_args a;
    memset(&a, 0, sizeof(a));
    sp_camera_default_settings(&a.cam);
    sp_imu_device_default_settings(&a.imu);
    sp_recorder_default_settings(&a.rec);
    a.live_check = a.live_faces = 1;
    a.live_max_lag_s = LIVE_MAX_LAG_S;
    int err = parse_args(argc, argv, &a);
    if (err)
        return err > 0 ? SP_EXIT_OK : SP_EXIT_USAGE;
    /* room for every queued frame plus the one being written and the one being captured:
       then a slow disk shows as counted queue drops, not as a starved camera */
    a.cam.pool_frames = a.rec.frame_queue + 2;
    /* caught from the start to the process's end: a signal before the capture file exists ends the
       command with nothing written; one after it ends the recording, whole (run) */
    sp_cmd_signals sig;
    sp_cmd_catch_signals(&sig);
    sp_camera *cam = NULL;
    sp_imu_device *imu = NULL;
    int code = open_devices(&a, &cam, &imu);
    if (!code && sp_cmd_stop_signal) {
        fprintf(stderr, "sunprobe " CMD ": stopped by a signal before recording began: nothing written\n");
        code = sp_cmd_stopped_code(SP_EXIT_OK);
        sp_imu_device_close(&imu);
        sp_camera_close(&cam);
    }
    if (code)
        return code;
    a.rec.camera = cam;
    a.rec.imu = imu;
    sp_recorder *rec = NULL;
    err = sp_recorder_open(&rec, &a.rec);
    sp_recorder_stats st;
    memset(&st, 0, sizeof(st));
    if (err < 0) {
        code = sp_cmd_fail("record", err, a.rec.path);
    } else {
        sp_live_check *check = NULL;
        if (a.live_check && !strcmp(a.rec.kind, "selfie") &&
            (err = sp_live_check_start(&check, a.rec.path, a.live_faces, LIVE_FACE_INTERVAL_S, a.live_max_lag_s)) < 0)
            fprintf(stderr, "sunprobe " CMD ": no live check: %s\n", sp_strerror(err));
        err = run(rec, &a, check, &st);
        if (st.end != SP_RECORDER_RUNNING)
            print_summary(a.rec.path, sp_camera_get_info(cam), &st);
        int check_err = sp_live_check_finish(&check, stdout);
        if (check_err < 0)
            fprintf(stderr, "sunprobe " CMD ": live check: %s: %s\n", a.rec.path, sp_strerror(check_err));
        if (err < 0)
            code = sp_cmd_fail("record", err, st.end == SP_RECORDER_DEVICE_LOST ? "device lost (capture kept)"
                                              : st.end == SP_RECORDER_DISK_FULL ? "disk full (capture kept)"
                                                                                : "recording");
    }
    sp_recorder_close(&rec);
    sp_imu_device_close(&imu);
    sp_camera_close(&cam);
    /* still caught until the process ends: a signal after the capture is whole must not turn a finished
       recording into a death by signal (under a sanitizer, the exit's own checks take a while) */
    return code;
}
