/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe synth`: synthetic captures with ground truth. `turn`: a person turning
 * in place with the camera at arm's length — fake IMU (noise, bias) plus a fake
 * camera seeing a panorama at the true yaw, and the true camera orientation per
 * frame as side data, so orientation and replay can be checked end to end.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cmd.h"
#include "common/json.h"
#include "common/progress.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_fake_camera.h"
#include "sunprobe/sp_fake_imu.h"

typedef struct turn_args {
    const char *out;
    sp_fake_camera_settings cam;
    sp_fake_imu_settings imu;
    int sync_every_chunk;
} turn_args;

static void turn_usage(FILE *out)
{
    fprintf(out, "usage: sunprobe synth turn -o OUT.spcap [options]\n\n"
                 "A person turning in place holding the camera at arm's length: fake IMU samples with\n"
                 "realistic noise and bias, fake camera frames of a panorama at the true heading, and the\n"
                 "true camera orientation of every frame as side data.\n"
                 "  --width W --height H   frame size (default 640x480)\n"
                 "  --fps F                frame rate (default 30)\n"
                 "  --format F             yuyv, nv12, gray8 or rgb24 (default yuyv)\n"
                 "  --turn-deg D           total turn (default 360)\n"
                 "  --turn-seconds S       duration of the turn (default 10), 1 s still before and after\n"
                 "  --imu-rate HZ          gyro/accel rate (default 200)\n"
                 "  --magnetometer         also emit magnetometer samples\n"
                 "  --noiseless            no sensor noise or bias\n"
                 "  --seed N               noise seed (default 1)\n"
                 "  --fsync                fdatasync after every chunk\n");
}

static int parse_turn(int argc, char **argv, turn_args *a)
{
    static const struct option opts[] = {
        { "help", no_argument, NULL, 'h' },          { "output", required_argument, NULL, 'o' },
        { "width", required_argument, NULL, 'W' },   { "height", required_argument, NULL, 'H' },
        { "fps", required_argument, NULL, 'f' },     { "format", required_argument, NULL, 'F' },
        { "turn-deg", required_argument, NULL, 'd' }, { "turn-seconds", required_argument, NULL, 's' },
        { "imu-rate", required_argument, NULL, 'r' }, { "magnetometer", no_argument, NULL, 'm' },
        { "noiseless", no_argument, NULL, 'n' },     { "seed", required_argument, NULL, 'S' },
        { "fsync", no_argument, NULL, 'y' },         { 0 },
    };
    double v = 0;
    int c, bad = 0, li = -1;
    while (!bad && (c = getopt_long(argc, argv, "ho:", opts, &li)) != -1) {
        const char *on = li >= 0 ? opts[li].name : "";
        li = -1;
        switch (c) {
        case 'h': turn_usage(stdout); return -1;
        case 'o': a->out = optarg; break;
        case 'W': bad = sp_opt_double("synth turn", on, optarg, 16, 4096, &v); a->cam.width = (uint32_t)v & ~1u; break;
        case 'H': bad = sp_opt_double("synth turn", on, optarg, 16, 4096, &v); a->cam.height = (uint32_t)v & ~1u; break;
        case 'f': bad = sp_opt_double("synth turn", on, optarg, 1, 240, &a->cam.fps); break;
        case 'F':
            a->cam.format = sp_pixfmt_from_name(optarg);
            if ((bad = a->cam.format == SP_PIXFMT_NONE))
                fprintf(stderr, "sunprobe synth turn: --format '%s': not a pixel format (yuyv, nv12, rgb24, ...)\n",
                        optarg);
            break;
        case 'd': bad = sp_opt_double("synth turn", on, optarg, -3600, 3600, &a->imu.turn_deg); break;
        case 's': bad = sp_opt_double("synth turn", on, optarg, 0.5, 3600, &a->imu.turn_duration_s); break;
        case 'r': bad = sp_opt_double("synth turn", on, optarg, 10, 8000, &a->imu.rate_hz); break;
        case 'm': a->imu.magnetometer = 1; break;
        case 'n':
            a->imu.gyro_noise = a->imu.accel_noise = a->imu.mag_noise_ut = 0;
            a->imu.gyro_bias = a->imu.accel_bias = (sp_vec3){ 0, 0, 0 };
            break;
        case 'S': bad = sp_opt_double("synth turn", on, optarg, 0, 1e15, &v); a->imu.seed = (uint64_t)v; break;
        case 'y': a->sync_every_chunk = 1; break;
        default: bad = 1;
        }
    }
    if (bad) { /* the option's own message is out; getopt's for an unknown one */
        fprintf(stderr, "sunprobe synth turn: see --help\n");
        return SP_EXIT_USAGE;
    }
    if (!a->out || optind != argc) {
        turn_usage(stderr);
        return SP_EXIT_USAGE;
    }
    return 0;
}

static int write_turn_meta(sp_capture_writer *w, const turn_args *a)
{
    double f = 0.5 * a->cam.width / tan(0.5 * a->cam.hfov_deg * M_PI / 180.0);
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"kind\":\"selfie\",\"source\":\"sunprobe synth turn\",\"camera\":{\"name\":\"fake camera\","
                         "\"driver\":\"fake\",\"width\":%u,\"height\":%u,\"fps\":%.17g,\"fx\":%.17g,\"fy\":%.17g,"
                         "\"cx\":%.17g,\"cy\":%.17g},\"imu\":{\"name\":\"fake imu\",\"rate_hz\":%.17g,"
                         "\"to_camera\":[%.17g,%.17g,%.17g,%.17g],\"time_offset_s\":0}}",
                     a->cam.width, a->cam.height, a->cam.fps, f, f, 0.5 * a->cam.width, 0.5 * a->cam.height,
                     a->imu.rate_hz, a->imu.imu_to_camera.w, a->imu.imu_to_camera.x, a->imu.imu_to_camera.y,
                     a->imu.imu_to_camera.z);
    int ret = b.failed ? -ENOMEM : sp_capture_write_meta(w, a->imu.start_ns, b.data, b.len);
    sp_strbuf_free(&b);
    return ret;
}

/* Writes IMU samples with timestamps up to t_ns in batches; keeps the one sample read past it. */
static int write_imu_until(sp_capture_writer *w, sp_fake_imu *imu, sp_imu_sample *held, int *have_held, int64_t t_ns)
{
    sp_imu_sample batch[256];
    size_t n = 0;
    int ret = 0;
    for (;;) {
        if (!*have_held) {
            ret = sp_fake_imu_next(imu, held);
            if (ret == SP_EOS) {
                ret = 0;
                break;
            }
            if (ret)
                break;
            *have_held = 1;
        }
        if (held->timestamp_ns > t_ns)
            break;
        batch[n++] = *held;
        *have_held = 0;
        if (n == 256) {
            if ((ret = sp_capture_write_imu(w, batch, n)))
                return ret;
            n = 0;
        }
    }
    return !ret && n ? sp_capture_write_imu(w, batch, n) : ret;
}

/* Heading that the panorama pattern expects: azimuth of the view, increasing to the right. */
static double view_yaw(sp_quat camera_to_world)
{
    sp_vec3 fwd = sp_quat_rotate(camera_to_world, (sp_vec3){ 0, 0, 1 });
    return -atan2(fwd.y, fwd.x);
}

static int write_frame(sp_capture_writer *w, sp_fake_camera *cam, const turn_args *a, uint64_t i, int64_t t)
{
    sp_quat q;
    int ret = sp_fake_imu_truth(&a->imu, t, NULL, &q);
    sp_frame *f = NULL;
    if (!ret)
        ret = sp_fake_camera_frame(cam, i, t, view_yaw(q), &f);
    if (!ret)
        ret = sp_capture_write_frame(w, f);
    sp_frame_unref(&f);
    float truth[4] = { (float)q.w, (float)q.x, (float)q.y, (float)q.z };
    if (!ret)
        ret = sp_capture_write_side(w, t, i, SP_SIDE_TRUE_ORIENTATION, truth, 4);
    return ret;
}

static int synth_turn(const turn_args *a, const char *partial)
{
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    ws.sync = a->sync_every_chunk ? SP_SYNC_EVERY_CHUNK : SP_SYNC_PERIODIC;
    ws.overwrite = 1;
    sp_capture_writer *w = NULL;
    sp_fake_camera *cam = NULL;
    sp_fake_imu *imu = NULL;
    int ret = sp_capture_writer_open(&w, partial, &ws);
    if (!ret)
        ret = sp_fake_camera_open(&cam, &a->cam);
    if (!ret)
        ret = sp_fake_imu_open(&imu, &a->imu);
    if (!ret)
        ret = write_turn_meta(w, a);
    uint64_t n_frames = (uint64_t)floor(sp_fake_imu_duration_s(&a->imu) * a->cam.fps) + 1;
    sp_progress bar;
    sp_progress_start(&bar, "synth", n_frames, -1);
    sp_imu_sample held;
    int have_held = 0;
    for (uint64_t i = 0; !ret && i < n_frames; i++) {
        int64_t t = a->imu.start_ns + (int64_t)llround((double)i * 1e9 / a->cam.fps);
        ret = sp_cmd_stop_signal ? -ECANCELED : write_imu_until(w, imu, &held, &have_held, t);
        if (!ret)
            ret = write_frame(w, cam, a, i, t);
        sp_progress_update(&bar, i + 1, NULL);
    }
    if (!ret) /* the IMU samples after the last frame */
        ret = write_imu_until(w, imu, &held, &have_held, INT64_MAX);
    sp_progress_finish(&bar);
    int close_ret = sp_capture_writer_close(&w);
    sp_fake_camera_close(&cam);
    sp_fake_imu_close(&imu);
    return ret ? ret : close_ret;
}

static int cmd_turn(int argc, char **argv)
{
    turn_args a = { 0 };
    sp_fake_camera_default_settings(&a.cam);
    a.cam.pattern = SP_FAKE_PATTERN_PANORAMA;
    sp_fake_imu_default_settings(&a.imu);
    int code = parse_turn(argc, argv, &a);
    if (code)
        return code < 0 ? SP_EXIT_OK : code;
    size_t n = strlen(a.out) + 16;
    char *partial = malloc(n);
    if (!partial)
        return sp_cmd_fail("synth", -ENOMEM, "allocating");
    snprintf(partial, n, "%s.partial", a.out);
    sp_cmd_signals sig; /* Ctrl-C ends the frame loop: the partial file is removed */
    sp_cmd_catch_signals(&sig);
    int ret = synth_turn(&a, partial);
    if (!ret && sp_cmd_stop_signal) /* a signal after the last frame: the old OUT stays */
        ret = -ECANCELED;
    if (!ret && rename(partial, a.out) != 0)
        ret = -errno;
    /* restored only now: a signal between the check above and the rename must not kill the run with the
       partial file left behind; one after the rename is too late to matter (OUT is whole, exit 0) */
    sp_cmd_restore_signals(&sig);
    if (ret) {
        unlink(partial);
        free(partial);
        return sp_cmd_fail("synth turn", ret, a.out);
    }
    free(partial);
    printf("%s: synthetic turn, %.1f s, %ux%u %s at %.0f fps, IMU at %.0f Hz\n", a.out,
           sp_fake_imu_duration_s(&a.imu), a.cam.width, a.cam.height, sp_pixfmt_name(a.cam.format), a.cam.fps,
           a.imu.rate_hz);
    return SP_EXIT_OK;
}

static void usage(FILE *out)
{
    fprintf(out, "usage: sunprobe synth KIND [options]   (sunprobe synth KIND --help)\n\n"
                 "kinds:\n"
                 "  turn     a person turning in place: fake camera + fake IMU with ground truth\n"
                 "  street   a static camera watching people walk past occluders, with ground truth\n"
                 "  selfie   a rendered face turning under the sun: MJPEG + IMU + landmarks + truth dir\n");
}

int sp_cmd_synth(int argc, char **argv)
{
    if (argc < 2) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
        usage(stdout);
        return SP_EXIT_OK;
    }
    if (!strcmp(argv[1], "turn"))
        return cmd_turn(argc - 1, argv + 1);
    if (!strcmp(argv[1], "street")) /* tools/cmd_synth_street.c */
        return sp_cmd_synth_street(argc - 1, argv + 1);
    if (!strcmp(argv[1], "selfie")) /* tools/cmd_synth_selfie.c */
        return sp_cmd_synth_selfie(argc - 1, argv + 1);
    fprintf(stderr, "sunprobe synth: unknown kind '%s'\n", argv[1]);
    usage(stderr);
    return SP_EXIT_USAGE;
}
