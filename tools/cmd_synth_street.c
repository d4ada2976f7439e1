/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe synth street`: the options of the street generator (sp_synth_street_write in
 * pipeline/synth/synth_street.c) and its one-line summary.
 */
#include <getopt.h>
#include <stdio.h>

#include "cmd.h"
#include "export/png.h"
#include "sunprobe/sp_synth.h"

static void usage(FILE *out)
{
    fprintf(out,
            "usage: sunprobe synth street -o OUT.spcap [options]\n\n"
            "A static camera watching a street: figures of known height walk past a lamp pole with a sign\n"
            "and a pillar, under a sun (shadows, a wall's shadow on the left) or an overcast sky. Ground\n"
            "truth beside OUT: .truth.json, .background.png, .hidden-far/.hidden-near/.seen-far/.hidden-count.pgm.\n"
            "  --width W --height H   frame size (default 320x240)\n"
            "  --fps F                frame rate (default 10)\n"
            "  --seconds S            duration (default 40)\n"
            "  --figures N            walking figures, 0..%d (default 10)\n"
            "  --overcast             no sun, no cast shadows (the ground darkens at each figure's feet)\n"
            "  --sun-azimuth DEG      from the view direction towards the right (default -30: front left)\n"
            "  --sun-elevation DEG    5..85 (default 40)\n"
            "  --pan DEG_PER_S        turn the camera (a moving camera, for bad-input tests)\n"
            "  --linger S             every other figure stops once, for 5 s up to S s (default 0: none)\n"
            "  --noise SIGMA          sensor noise, standard deviation in 8-bit levels (default 0)\n"
            "  --cars N               cars driving past behind the walkers, 0..%d (default 0)\n"
            "  --jpeg Q               store the frames as MJPEG at quality 1..100 (default: raw RGB24)\n"
            "  --indoor               a hall: back wall, wooden floor, a counter, a cabinet and a chair as\n"
            "                         the occluders, lamps (no sun)\n"
            "  --seed N               (default 1)\n",
            SP_SYNTH_STREET_MAX_FIGURES, SP_SYNTH_STREET_MAX_CARS);
}

static int parse_args(int argc, char **argv, sp_synth_street_settings *a, const char **out)
{
    static const struct option opts[] = {
        { "help", no_argument, NULL, 'h' },
        { "output", required_argument, NULL, 'o' },
        { "width", required_argument, NULL, 'W' },
        { "height", required_argument, NULL, 'H' },
        { "fps", required_argument, NULL, 'f' },
        { "seconds", required_argument, NULL, 's' },
        { "figures", required_argument, NULL, 'n' },
        { "overcast", no_argument, NULL, 'c' },
        { "sun-azimuth", required_argument, NULL, 'a' },
        { "sun-elevation", required_argument, NULL, 'e' },
        { "pan", required_argument, NULL, 'p' },
        { "seed", required_argument, NULL, 'S' },
        { "linger", required_argument, NULL, 'L' },
        { "noise", required_argument, NULL, 'N' },
        { "cars", required_argument, NULL, 'C' },
        { "jpeg", required_argument, NULL, 'J' },
        { "indoor", no_argument, NULL, 'I' },
        { 0 },
    };
    double v = 0;
    int c, bad = 0, li = -1;
    optind = 0;
    while (!bad && (c = getopt_long(argc, argv, "ho:", opts, &li)) != -1) {
        const char *on = li >= 0 ? opts[li].name : "";
        li = -1;
        switch (c) {
        case 'h': usage(stdout); return -1;
        case 'o': *out = optarg; break;
        case 'W': bad = sp_opt_double("synth street", on, optarg, 32, 4096, &v); a->width = (uint32_t)v; break;
        case 'H': bad = sp_opt_double("synth street", on, optarg, 32, 4096, &v); a->height = (uint32_t)v; break;
        case 'f': bad = sp_opt_double("synth street", on, optarg, 1, 240, &a->fps); break;
        case 's': bad = sp_opt_double("synth street", on, optarg, 0.01, 36000, &a->seconds); break;
        case 'n': bad = sp_opt_double("synth street", on, optarg, 0, SP_SYNTH_STREET_MAX_FIGURES, &v); a->figures = (unsigned)v; break;
        case 'c': a->overcast = 1; break;
        case 'a': bad = sp_opt_double("synth street", on, optarg, -360, 360, &a->sun_azimuth_deg); break;
        case 'e': bad = sp_opt_double("synth street", on, optarg, 5, 85, &a->sun_elevation_deg); break;
        case 'p': bad = sp_opt_double("synth street", on, optarg, -90, 90, &a->pan_deg_s); break;
        case 'S': bad = sp_opt_double("synth street", on, optarg, 0, 4e9, &v); a->seed = (uint64_t)v; break;
        case 'L': bad = sp_opt_double("synth street", on, optarg, 0, 3600, &a->linger_s); break;
        case 'N': bad = sp_opt_double("synth street", on, optarg, 0, 64, &a->noise); break;
        case 'I':
            a->indoor = 1;
            break;
        case 'J':
            bad = sp_opt_double("synth street", on, optarg, 1, 100, &v);
            a->jpeg_quality = (int)v;
            break;
        case 'C':
            bad = sp_opt_double("synth street", on, optarg, 0, SP_SYNTH_STREET_MAX_CARS, &v);
            a->cars = (unsigned)v;
            break;
        default: bad = 1;
        }
    }
    if (bad) { /* the option's own message is out; getopt's for an unknown one */
        fprintf(stderr, "sunprobe synth street: see --help\n");
        return SP_EXIT_USAGE;
    }
    if (!*out || optind != argc) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    return 0;
}


int sp_cmd_synth_street(int argc, char **argv)
{
    sp_synth_street_settings s;
    sp_synth_street_default_settings(&s);
    const char *out = NULL;
    int code = parse_args(argc, argv, &s, &out);
    if (code)
        return code < 0 ? SP_EXIT_OK : code;
    s.write_image = sp_png_write;
    s.progress = -1;
    s.cancel = &sp_cmd_stop_signal;
    sp_cmd_signals sig; /* Ctrl-C ends the frame loop: nothing of this run is left */
    sp_cmd_catch_signals(&sig);
    sp_synth_street_report rep;
    int ret = sp_synth_street_write(&s, out, &rep);
    sp_cmd_restore_signals(&sig);
    if (ret)
        return sp_cmd_fail("synth street", ret, out);
    char fmt[24] = "rgb24";
    if (s.jpeg_quality > 0)
        snprintf(fmt, sizeof(fmt), "mjpeg q%d", s.jpeg_quality);
    printf("%s: synthetic street, %.1f s, %ux%u %s at %.0f fps, %u figures, %u cars, %s\n", out, s.seconds, s.width,
           s.height, fmt, s.fps, rep.figures, rep.cars,
           s.indoor         ? "indoor"
               : s.overcast ? "overcast"
                            : "sunny");
    return SP_EXIT_OK;
}
