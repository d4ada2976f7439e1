/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe synth`: synthetic captures with ground truth, one generator per kind
 * (pipeline/synth, sp_synth.h); this file holds the kinds' dispatch and the options
 * of `turn` (sp_synth_turn_write: a person turning in place, fake camera + fake IMU).
 */
#include <getopt.h>
#include <stdio.h>
#include <string.h>

#include "cmd.h"
#include "sunprobe/sp_synth.h"

typedef struct turn_args {
    const char *out;
    sp_synth_turn_settings s;
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
        case 'W': bad = sp_opt_double("synth turn", on, optarg, 16, 4096, &v); a->s.camera.width = (uint32_t)v & ~1u; break;
        case 'H': bad = sp_opt_double("synth turn", on, optarg, 16, 4096, &v); a->s.camera.height = (uint32_t)v & ~1u; break;
        case 'f': bad = sp_opt_double("synth turn", on, optarg, 1, 240, &a->s.camera.fps); break;
        case 'F':
            a->s.camera.format = sp_pixfmt_from_name(optarg);
            if ((bad = a->s.camera.format == SP_PIXFMT_NONE))
                fprintf(stderr, "sunprobe synth turn: --format '%s': not a pixel format (yuyv, nv12, rgb24, ...)\n",
                        optarg);
            break;
        case 'd': bad = sp_opt_double("synth turn", on, optarg, -3600, 3600, &a->s.imu.turn_deg); break;
        case 's': bad = sp_opt_double("synth turn", on, optarg, 0.5, 3600, &a->s.imu.turn_duration_s); break;
        case 'r': bad = sp_opt_double("synth turn", on, optarg, 10, 8000, &a->s.imu.rate_hz); break;
        case 'm': a->s.imu.magnetometer = 1; break;
        case 'n':
            a->s.imu.gyro_noise = a->s.imu.accel_noise = a->s.imu.mag_noise_ut = 0;
            a->s.imu.gyro_bias = a->s.imu.accel_bias = (sp_vec3){ 0, 0, 0 };
            break;
        case 'S': bad = sp_opt_double("synth turn", on, optarg, 0, 1e15, &v); a->s.imu.seed = (uint64_t)v; break;
        case 'y': a->s.sync_every_chunk = 1; break;
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

static int cmd_turn(int argc, char **argv)
{
    turn_args a = { 0 };
    sp_synth_turn_default_settings(&a.s);
    int code = parse_turn(argc, argv, &a);
    if (code)
        return code < 0 ? SP_EXIT_OK : code;
    a.s.progress = -1;
    a.s.cancel = &sp_cmd_stop_signal;
    sp_cmd_signals sig; /* Ctrl-C ends the frame loop: the partial file is removed */
    sp_cmd_catch_signals(&sig);
    int ret = sp_synth_turn_write(&a.s, a.out);
    sp_cmd_restore_signals(&sig);
    if (ret)
        return sp_cmd_fail("synth turn", ret, a.out);
    printf("%s: synthetic turn, %.1f s, %ux%u %s at %.0f fps, IMU at %.0f Hz\n", a.out,
           sp_fake_imu_duration_s(&a.s.imu), a.s.camera.width, a.s.camera.height,
           sp_pixfmt_name(a.s.camera.format), a.s.camera.fps, a.s.imu.rate_hz);
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
