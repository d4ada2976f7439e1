/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe synth selfie`: a rendered rotating-selfie capture with ground truth
 * (pipeline/synth, documented in pipeline/synth/SYNTH.md), optionally with a
 * contact sheet PNG of frames and one frame's component decomposition.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd.h"
#include "export/png.h"
#include "sunprobe/sp_solar.h"
#include "sunprobe/sp_synth.h"

#define DEG (M_PI / 180.0)

typedef struct selfie_args {
    sp_synth_selfie_settings s;
    const char *out, *truth, *sheet;
    int no_truth, sheet_frames, sheet_columns;
    int sun_angles; /* --sun-elevation or --sun-azimuth was given */
    double sheet_at; /* fraction of the capture for the decomposed frame */
} selfie_args;

static void usage(FILE *out)
{
    fprintf(out,
            "usage: sunprobe synth selfie -o OUT.spcap [options]\n\n"
            "A rendered head (ICT or the generic head) held at arm's length by a person turning in place\n"
            "under a sun and a sky: MJPEG frames, IMU samples, per-frame 2-D landmarks and true camera\n"
            "orientation as side data, plus a ground-truth directory (default OUT.truth, the .spcap\n"
            "extension replaced) with held-out relit and novel-view frames. Deterministic for a seed.\n"
            "camera:   --width W --height H (320x320)  --fps F (30)  --focal-ratio R (fx = R*width, 0.8)\n"
            "          --format auto|mjpeg|rgb24  --jpeg-quality Q (90)  --shutter S (1/240 s)\n"
            "          --motion-blur N (sub-frames, 1 = off)  --noise K (sensor noise scale, 1; 0 = off)\n"
            "          --exposure E (0 = meter frame 0)  --no-ae  --ae-speed A (0.15)  --ae-drift D (0.01)\n"
            "motion:   --still S (1 s before and after)  --turn-seconds S (10)  --turn-deg D (360)\n"
            "          --heading D  --pitch D  --arm M (0.5)  --wobble D (0.5)  --camera-height M (0)\n"
            "          --head-wobble D (1)  --imu-rate HZ (200)  --gyro-noise N  --accel-noise N\n"
            "          --gyro-bias X,Y,Z (deg/s)  --accel-bias X,Y,Z (m/s^2)  --imu-noiseless\n"
            "          --no-imu (no IMU samples and no IMU in META; the motion and true orientation stay)\n"
            "face:     --face auto|generic|ict  --identity-sigma S (0.7)  --expression-max E (0.15)\n"
            "          --albedo-size ROWS (512)\n"
            "light:    --sun-elevation D (35)  --sun-azimuth D (150, from world +x towards +y)\n"
            "          --sun-intensity I (3)  --sky-intensity K (1)  --overcast\n"
            "          --utc ISO8601 --location LAT,LON   the sun from the clock instead of the two angles:\n"
            "                         world +x is magnetic north, the IMU gets a magnetometer\n"
            "          --backdrop sky|city   what the background shows (sky): the sky map, or a city panorama\n"
            "                         at infinity (buildings, windows, paving) shaded by that sky, for\n"
            "                         rotation-only tracking; the head is lit by the sky either way\n"
            "          --backdrop-distance M  the city on a sphere of radius M about the turning axis\n"
            "                         (0 = at infinity, the default; else at least 2 m: the camera must stay\n"
            "                         inside the sphere), so the arm's motion adds parallax\n"
            "render:   --supersample S (2)  --shadow-size N (512)\n"
            "truth:    --truth DIR  --no-truth  --relit N (6)  --novel N (6)\n"
            "sheet:    --contact-sheet FILE.png  --sheet-frames N (8)  --sheet-columns C (4)\n"
            "          --sheet-at F (decomposed frame at this fraction of the capture, 0.5)\n"
            "other:    --seed N (1)  --noiseless (no sensor noise, no IMU noise or bias)  --progress\n");
}

#define CMD "synth selfie"

static int num(const char *o, const char *s, double lo, double hi, double *out)
{
    return sp_opt_double(CMD, o, s, lo, hi, out);
}

static int inum(const char *o, const char *s, int lo, int hi, int *out)
{
    return sp_opt_int(CMD, o, s, lo, hi, out);
}

static int u32num(const char *o, const char *s, int lo, int hi, uint32_t *out)
{
    int v = 0, bad = sp_opt_int(CMD, o, s, lo, hi, &v);
    *out = bad ? *out : (uint32_t)v;
    return bad;
}

/* n comma-separated finite numbers; `form` names them in the message */
static int numbers(const char *o, const char *s, int n, const char *form, double *v)
{
    if (!sp_opt_numbers(s, v, n))
        return 0;
    fprintf(stderr, "sunprobe " CMD ": --%s '%s': expected %s (%d finite numbers)\n", o, s, form, n);
    return -1;
}

/* X,Y,Z: three finite numbers, scaled */
static int vec3(const char *o, const char *s, double scale, sp_vec3 *out)
{
    double v[3];
    if (numbers(o, s, 3, "X,Y,Z", v))
        return -1;
    *out = (sp_vec3){ v[0] * scale, v[1] * scale, v[2] * scale };
    return 0;
}

/* 0 (at infinity) or a distance of at least SP_SYNTH_BACKDROP_MIN_DISTANCE_M metres */
static int backdrop_distance(const char *o, const char *s, double *out)
{
    double v = 0.0;
    int bad = num(o, s, 0, 1e9, &v);
    if (!bad && v > 0.0 && v < SP_SYNTH_BACKDROP_MIN_DISTANCE_M) {
        fprintf(stderr,
                "sunprobe " CMD ": --%s '%s': expected 0 (at infinity) or at least %g m: the camera must stay "
                "inside the city's sphere\n",
                o, s, SP_SYNTH_BACKDROP_MIN_DISTANCE_M);
        return -1;
    }
    *out = bad ? *out : v;
    return bad;
}

/* LAT,LON in degrees */
static int location(const char *o, const char *s, sp_synth_selfie_settings *out)
{
    double v[2];
    if (numbers(o, s, 2, "LAT,LON", v))
        return -1;
    if (fabs(v[0]) > 90.0 || fabs(v[1]) > 360.0) {
        fprintf(stderr, "sunprobe " CMD ": --%s '%s': latitude must be within -90..90 and longitude -360..360\n", o, s);
        return -1;
    }
    out->latitude = v[0];
    out->longitude = v[1];
    return 0;
}

/* An ISO 8601 time with a zone, checked here so the message names the option */
static int utc(const char *o, const char *s, sp_synth_selfie_settings *out)
{
    double t;
    if (strlen(s) >= sizeof(out->utc_start) || sp_utc_parse(s, &t)) {
        fprintf(stderr, "sunprobe " CMD ": --%s '%s': expected an ISO 8601 time with a zone, e.g. "
                "2024-06-21T12:00:00Z\n", o, s);
        return -1;
    }
    memcpy(out->utc_start, s, strlen(s) + 1);
    return 0;
}

enum opt_code {
    O_WIDTH = 256,
    O_HEIGHT,
    O_FPS,
    O_FOCAL,
    O_FORMAT,
    O_JPEGQ,
    O_SHUTTER,
    O_BLUR,
    O_NOISE,
    O_EXPOSURE,
    O_NOAE,
    O_AESPEED,
    O_AEDRIFT,
    O_STILL,
    O_TURNS,
    O_TURND,
    O_HEADING,
    O_PITCH,
    O_ARM,
    O_WOBBLE,
    O_CAMH,
    O_HEADW,
    O_IMURATE,
    O_GNOISE,
    O_ANOISE,
    O_GBIAS,
    O_ABIAS,
    O_IMUQUIET,
    O_FACE,
    O_IDS,
    O_EXPMAX,
    O_ALBEDO,
    O_SUNEL,
    O_SUNAZ,
    O_SUNI,
    O_SKYI,
    O_OVERCAST,
    O_SS,
    O_SHADOW,
    O_TRUTH,
    O_NOTRUTH,
    O_RELIT,
    O_NOVEL,
    O_SHEET,
    O_SHEETN,
    O_SHEETC,
    O_SHEETAT,
    O_SEED,
    O_NOISELESS,
    O_PROGRESS,
    O_UTC,
    O_LOCATION,
    O_BACKDROP,
    O_BACKDROPD,
    O_NOIMU,
};

static const struct option opts[] = {
    { "help", no_argument, NULL, 'h' },
    { "output", required_argument, NULL, 'o' },
    { "width", required_argument, NULL, O_WIDTH },
    { "height", required_argument, NULL, O_HEIGHT },
    { "fps", required_argument, NULL, O_FPS },
    { "focal-ratio", required_argument, NULL, O_FOCAL },
    { "format", required_argument, NULL, O_FORMAT },
    { "jpeg-quality", required_argument, NULL, O_JPEGQ },
    { "shutter", required_argument, NULL, O_SHUTTER },
    { "motion-blur", required_argument, NULL, O_BLUR },
    { "noise", required_argument, NULL, O_NOISE },
    { "exposure", required_argument, NULL, O_EXPOSURE },
    { "no-ae", no_argument, NULL, O_NOAE },
    { "ae-speed", required_argument, NULL, O_AESPEED },
    { "ae-drift", required_argument, NULL, O_AEDRIFT },
    { "still", required_argument, NULL, O_STILL },
    { "turn-seconds", required_argument, NULL, O_TURNS },
    { "turn-deg", required_argument, NULL, O_TURND },
    { "heading", required_argument, NULL, O_HEADING },
    { "pitch", required_argument, NULL, O_PITCH },
    { "arm", required_argument, NULL, O_ARM },
    { "wobble", required_argument, NULL, O_WOBBLE },
    { "camera-height", required_argument, NULL, O_CAMH },
    { "head-wobble", required_argument, NULL, O_HEADW },
    { "imu-rate", required_argument, NULL, O_IMURATE },
    { "gyro-noise", required_argument, NULL, O_GNOISE },
    { "accel-noise", required_argument, NULL, O_ANOISE },
    { "gyro-bias", required_argument, NULL, O_GBIAS },
    { "accel-bias", required_argument, NULL, O_ABIAS },
    { "imu-noiseless", no_argument, NULL, O_IMUQUIET },
    { "face", required_argument, NULL, O_FACE },
    { "identity-sigma", required_argument, NULL, O_IDS },
    { "expression-max", required_argument, NULL, O_EXPMAX },
    { "albedo-size", required_argument, NULL, O_ALBEDO },
    { "utc", required_argument, NULL, O_UTC },
    { "location", required_argument, NULL, O_LOCATION },
    { "sun-elevation", required_argument, NULL, O_SUNEL },
    { "sun-azimuth", required_argument, NULL, O_SUNAZ },
    { "sun-intensity", required_argument, NULL, O_SUNI },
    { "sky-intensity", required_argument, NULL, O_SKYI },
    { "overcast", no_argument, NULL, O_OVERCAST },
    { "supersample", required_argument, NULL, O_SS },
    { "shadow-size", required_argument, NULL, O_SHADOW },
    { "truth", required_argument, NULL, O_TRUTH },
    { "no-truth", no_argument, NULL, O_NOTRUTH },
    { "relit", required_argument, NULL, O_RELIT },
    { "novel", required_argument, NULL, O_NOVEL },
    { "contact-sheet", required_argument, NULL, O_SHEET },
    { "sheet-frames", required_argument, NULL, O_SHEETN },
    { "sheet-columns", required_argument, NULL, O_SHEETC },
    { "sheet-at", required_argument, NULL, O_SHEETAT },
    { "seed", required_argument, NULL, O_SEED },
    { "noiseless", no_argument, NULL, O_NOISELESS },
    { "progress", no_argument, NULL, O_PROGRESS },
    { "backdrop", required_argument, NULL, O_BACKDROP },
    { "backdrop-distance", required_argument, NULL, O_BACKDROPD },
    { "no-imu", no_argument, NULL, O_NOIMU },
    { 0 },
};

static void imu_quiet(sp_fake_imu_settings *imu)
{
    imu->gyro_noise = imu->accel_noise = imu->mag_noise_ut = 0;
    imu->gyro_bias = imu->accel_bias = (sp_vec3){ 0, 0, 0 };
}

/* Camera, exposure and image options; 1 when c is not one of them. */
static int opt_camera(int c, const char *o, const char *v, sp_synth_selfie_settings *s)
{
    static const char *const formats[] = { "auto", "mjpeg", "rgb24" };
    int i = 0, bad;
    switch (c) {
    case O_WIDTH: return u32num(o, v, 16, 4096, &s->width);
    case O_HEIGHT: return u32num(o, v, 16, 4096, &s->height);
    case O_FPS: return num(o, v, 0.1, 1000, &s->fps);
    case O_FOCAL: return num(o, v, 0.05, 20, &s->focal_ratio);
    case O_FORMAT:
        bad = sp_opt_choice(CMD, o, v, formats, 3, &i);
        s->format = (enum sp_synth_frame_format)i;
        return bad;
    case O_JPEGQ: return inum(o, v, 1, 100, &s->jpeg_quality);
    case O_SHUTTER: return num(o, v, 0, 10, &s->shutter_s);
    case O_BLUR: return inum(o, v, 1, 64, &s->motion_blur_samples);
    case O_NOISE: return num(o, v, 0, 100, &s->noise);
    case O_EXPOSURE: return num(o, v, 0, 1e6, &s->exposure);
    case O_NOAE: s->auto_exposure = 0; return 0;
    case O_AESPEED: return num(o, v, 0, 1, &s->ae_speed);
    case O_AEDRIFT: return num(o, v, 0, 1, &s->ae_drift);
    case O_SS: return inum(o, v, 1, 8, &s->supersample);
    case O_SHADOW: return inum(o, v, 16, 8192, &s->shadow_size);
    default: return 1;
    }
}

static int opt_motion(int c, const char *o, const char *v, sp_synth_selfie_settings *s)
{
    sp_fake_imu_settings *m = &s->imu;
    int bad;
    switch (c) {
    case O_STILL: bad = num(o, v, 0, 3600, &m->still_before_s); m->still_after_s = m->still_before_s; return bad;
    case O_TURNS: return num(o, v, 0.1, 3600, &m->turn_duration_s);
    case O_TURND: return num(o, v, -3600, 3600, &m->turn_deg);
    case O_HEADING: return num(o, v, -3600, 3600, &m->heading_deg);
    case O_PITCH: return num(o, v, -60, 60, &m->pitch_deg);
    case O_ARM: return num(o, v, 0.2, 10, &m->arm_radius_m);
    case O_WOBBLE: return num(o, v, 0, 45, &m->wobble_deg);
    case O_CAMH: return num(o, v, -2, 2, &s->camera_height_m);
    case O_HEADW: return num(o, v, 0, 30, &s->head_wobble_deg);
    case O_IMURATE: return num(o, v, 10, 8000, &m->rate_hz);
    case O_GNOISE: return num(o, v, 0, 10, &m->gyro_noise);
    case O_ANOISE: return num(o, v, 0, 100, &m->accel_noise);
    case O_GBIAS: return vec3(o, v, DEG, &m->gyro_bias);
    case O_ABIAS: return vec3(o, v, 1.0, &m->accel_bias);
    case O_IMUQUIET: imu_quiet(m); return 0;
    case O_NOIMU:
        s->no_imu = 1;
        return 0;
    default: return 1;
    }
}

static int opt_scene(int c, const char *o, const char *v, sp_synth_selfie_settings *s)
{
    static const char *const faces[] = { "auto", "generic", "ict" }, *const backdrops[] = { "sky", "city" };
    int i = 0, bad;
    switch (c) {
    case O_FACE: bad = sp_opt_choice(CMD, o, v, faces, 3, &i); s->face = (enum sp_synth_face_source)i; return bad;
    case O_BACKDROP:
        bad = sp_opt_choice(CMD, o, v, backdrops, 2, &i);
        s->backdrop = (enum sp_synth_backdrop)i;
        return bad;
    case O_BACKDROPD:
        return backdrop_distance(o, v, &s->backdrop_distance_m);
    case O_IDS: return num(o, v, 0, 10, &s->identity_sigma);
    case O_EXPMAX: return num(o, v, 0, 1, &s->expression_max);
    case O_ALBEDO: return u32num(o, v, 16, 4096, &s->albedo_height);
    case O_SUNEL: return num(o, v, -90, 90, &s->sun_elevation_deg);
    case O_SUNAZ: return num(o, v, -3600, 3600, &s->sun_azimuth_deg);
    case O_SUNI: return num(o, v, 0, 1e5, &s->sun_intensity);
    case O_SKYI: return num(o, v, 0, 1e5, &s->sky_intensity);
    case O_OVERCAST: s->overcast = 1; return 0;
    case O_UTC: return utc(o, v, s);
    case O_LOCATION: return location(o, v, s);
    case O_RELIT: return inum(o, v, 0, 64, &s->n_relit);
    case O_NOVEL: return inum(o, v, 0, 64, &s->n_novel);
    case O_SEED: return sp_opt_u64(CMD, o, v, 0, UINT64_MAX, &s->seed);
    case O_NOISELESS: s->noise = 0; imu_quiet(&s->imu); return 0;
    case O_PROGRESS: s->progress = 1; return 0;
    default: return 1;
    }
}

static int opt_output(int c, const char *o, const char *v, selfie_args *a)
{
    switch (c) {
    case 'o': a->out = v; return 0;
    case O_TRUTH: a->truth = v; return 0;
    case O_NOTRUTH: a->no_truth = 1; return 0;
    case O_SHEET: a->sheet = v; return 0;
    case O_SHEETN: return inum(o, v, 0, 256, &a->sheet_frames);
    case O_SHEETC: return inum(o, v, 1, 64, &a->sheet_columns);
    case O_SHEETAT: return num(o, v, 0, 1, &a->sheet_at);
    default: return 1;
    }
}

static const char *opt_name(int c)
{
    for (const struct option *o = opts; o->name; o++)
        if (o->val == c)
            return o->name;
    return "?";
}

static int parse(int argc, char **argv, selfie_args *a)
{
    int c, bad = 0;
    while (!bad && (c = getopt_long(argc, argv, "ho:", opts, NULL)) != -1) {
        if (c == 'h') {
            usage(stdout);
            return -1;
        }
        const char *o = opt_name(c);
        a->sun_angles |= c == O_SUNEL || c == O_SUNAZ;
        bad = opt_camera(c, o, optarg, &a->s);
        if (bad == 1)
            bad = opt_motion(c, o, optarg, &a->s);
        if (bad == 1)
            bad = opt_scene(c, o, optarg, &a->s);
        if (bad == 1)
            bad = opt_output(c, o, optarg, a);
    }
    if (bad < 0) { /* the value's message is out */
        fprintf(stderr, "sunprobe " CMD ": see --help\n");
        return SP_EXIT_USAGE;
    }
    if (bad || !a->out || optind != argc) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    if (!a->s.utc_start[0] != !isfinite(a->s.latitude) || (a->s.utc_start[0] && a->sun_angles)) {
        fprintf(stderr, "sunprobe " CMD ": the sun from the clock needs both --utc and --location, and then no "
                "--sun-elevation/--sun-azimuth\n");
        return SP_EXIT_USAGE;
    }
    return 0;
}

/* OUT.spcap -> OUT.truth; any other name gets ".truth" appended. */
static char *default_truth(const char *out)
{
    size_t n = strlen(out);
    char *t = malloc(n + 8);
    if (!t)
        return NULL;
    memcpy(t, out, n + 1);
    if (n > 6 && !strcmp(out + n - 6, ".spcap"))
        t[n - 6] = '\0';
    strcat(t, ".truth");
    return t;
}

static int contact_sheet(sp_synth_selfie *g, const selfie_args *a)
{
    const sp_synth_selfie_truth *t = sp_synth_selfie_get_truth(g);
    uint64_t at = (uint64_t)llround(a->sheet_at * (double)(t->n_frames - 1));
    uint8_t *rgb = NULL;
    uint32_t w = 0, h = 0;
    int ret = sp_synth_selfie_contact_sheet(g, a->out, a->sheet_frames, at, a->sheet_columns, &rgb, &w, &h);
    if (!ret)
        ret = sp_png_write(a->sheet, rgb, w, h, w * 3, 3);
    free(rgb);
    if (!ret)
        printf("%s: contact sheet %ux%u: %d frames, then frame %llu as final, diffuse, specular, ambient, "
               "visibility, normals, albedo, mask\n",
               a->sheet, w, h, a->sheet_frames, (unsigned long long)at);
    return ret;
}

/*
 * The generator's memory follows its options alone (frame size times supersampling, shadow map, albedo),
 * so running out means they asked for more than this machine has: the usage code, naming them.
 */
static int out_of_memory(const selfie_args *a, const char *when)
{
    fprintf(stderr,
            "sunprobe " CMD ": out of memory %s: --width %u --height %u --supersample %d (renders %ux%u), "
            "--shadow-size %d, --albedo-size %u ask for more than this machine has; lower them\n",
            when, a->s.width, a->s.height, a->s.supersample, a->s.width * (unsigned)a->s.supersample,
            a->s.height * (unsigned)a->s.supersample, a->s.shadow_size, a->s.albedo_height);
    return SP_EXIT_USAGE;
}

static int run(selfie_args *a)
{
    char *truth = NULL;
    if (!a->no_truth && !(truth = a->truth ? strdup(a->truth) : default_truth(a->out)))
        return sp_cmd_fail("synth selfie", -ENOMEM, "allocating");
    sp_synth_selfie *g = NULL;
    sp_synth_selfie_report rep;
    int ret = sp_synth_selfie_open(&g, &a->s);
    if (ret) {
        free(truth);
        return ret == -ENOMEM ? out_of_memory(a, "setting up the generator")
                              : sp_cmd_fail("synth selfie", ret, "setting up the generator");
    }
    sp_cmd_signals sig; /* Ctrl-C: the generator stops between frames and removes what it wrote */
    sp_cmd_catch_signals(&sig);
    ret = sp_synth_selfie_write(g, a->out, truth, &rep);
    if (ret) {
        sp_cmd_restore_signals(&sig);
        sp_synth_selfie_close(&g);
        int code;
        if (ret == -ENOMEM) {
            code = out_of_memory(a, "rendering");
        } else if (ret == -EEXIST && truth)
            code = sp_cmd_failf(CMD, ret, "%s is not empty and holds no truth.json: choose another --truth DIR",
                                truth);
        else
            code = sp_cmd_fail(CMD, ret, a->out);
        free(truth);
        return code;
    }
    const sp_synth_selfie_truth *t = sp_synth_selfie_get_truth(g);
    printf("%s: synthetic selfie, %llu frames %ux%u at %.0f fps, %llu IMU samples, %llu bytes, face %s, %.2f s\n",
           a->out, (unsigned long long)rep.frames, a->s.width, a->s.height, a->s.fps,
           (unsigned long long)rep.imu_samples, (unsigned long long)rep.capture_bytes, t->model->source, rep.seconds);
    if (truth)
        printf("%s: ground truth, %llu held-out frames\n", truth, (unsigned long long)rep.heldout_frames);
    if (a->sheet && (ret = contact_sheet(g, a))) /* still caught: its temporary is renamed or removed first */
        ret = sp_cmd_fail("synth selfie", ret, a->sheet);
    sp_cmd_restore_signals(&sig);
    sp_synth_selfie_close(&g);
    free(truth);
    return ret ? ret : SP_EXIT_OK;
}

int sp_cmd_synth_selfie(int argc, char **argv)
{
    selfie_args a = { .sheet_frames = 8, .sheet_columns = 4, .sheet_at = 0.5 };
    sp_synth_selfie_default_settings(&a.s);
    a.s.write_image = sp_png_write;
    a.s.progress = -1;
    int code = parse(argc, argv, &a);
    if (code)
        return code < 0 ? SP_EXIT_OK : code;
    a.s.imu.seed = a.s.seed; /* one seed for appearance, noise, sway and IMU noise */
    a.s.cancel = &sp_cmd_stop_signal;
    return run(&a);
}
