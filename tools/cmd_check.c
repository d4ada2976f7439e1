/* SPDX-License-Identifier: MIT */
/* `sunprobe check CAPTURE`: says before fitting whether a selfie capture can work and what to re-shoot. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check_capture.h"
#include "cmd.h"
#include "common/atomic_file.h"
#include "common/module.h"
#include "video_orientation.h"

#define CMD "check"

/* Product limits, not fitted to any capture: README "check" gives the reasons. */
#define MIN_FRAMES 10
#define MIN_COVERAGE 0.9
#define MIN_GYRO_HZ 50
#define MIN_TURN_DEG 180
#define GOOD_TURN_DEG SP_CHECK_GOOD_TURN_DEG
#define MAX_CLIPPED 0.2
#define MAX_BLURRED 0.25
#define MIN_MODULATION 0.1
#define MIN_FACES 0.5
#define GOOD_FACES 0.8

static void usage(FILE *out)
{
    fprintf(out, "usage: sunprobe check CAPTURE [--json FILE] [--no-face]\n\n"
                 "Measures a selfie capture before fitting: frames and their timing, IMU rate and coverage, the\n"
                 "turn about gravity, clipped and blurred frames, and whether the brightness of the frame's\n"
                 "centre (the face) follows the turn (lighting observable). Prints one verdict per item with\n"
                 "what to re-shoot. Exit 0 when nothing fails, 2 when the capture cannot work.\n"
                 "  --json FILE   the measurements as JSON too\n"
                 "  --no-face     do not run the landmark tracker (dlib) on frames without landmarks\n");
}

typedef struct verdicts {
    sp_check_verdicts *count;
    FILE *out;
} verdicts;

static void say(verdicts *v, int level, const char *what, const char *fmt, ...) SP_PRINTF(4, 5);
static void say(verdicts *v, int level, const char *what, const char *fmt, ...)
{
    static const char *const tag[] = { "ok  ", "warn", "FAIL" };
    v->count->warns += level == 1;
    v->count->fails += level == 2;
    fprintf(v->out, "%s %-9s ", tag[level], what);
    va_list ap;
    va_start(ap, fmt);
    vfprintf(v->out, fmt, ap);
    va_end(ap);
    fprintf(v->out, "\n");
}

static void judge(const sp_check_report *r, verdicts *v);

void sp_check_judge(const sp_check_report *r, FILE *out, sp_check_verdicts *count)
{
    verdicts v = { count, out };
    judge(r, &v);
}

static void judge(const sp_check_report *r, verdicts *v)
{
    say(v, r->frames < MIN_FRAMES ? 2 : 0, "frames", "%zu frames over %.1f s at %.1f fps%s", r->frames, r->duration_s,
        r->fps, r->frames < MIN_FRAMES ? ": too few to fit" : "");
    if (r->undecodable)
        say(v, 1, "frames", "%zu frames do not decode; the fit skips them", r->undecodable);
    if (r->fps > 0 && r->max_gap_s > 5 / r->fps)
        say(v, 1, "gaps", "a gap of %.2f s between frames: frames were dropped", r->max_gap_s);
    char skipped[96] = ""; /* only a live check skips */
    if (r->face_skipped)
        snprintf(skipped, sizeof(skipped), " (%zu sampled frames skipped: the check was behind the camera)",
                 r->face_skipped);
    if (!isfinite(r->face_share) && r->face_skipped)
        say(v, 1, "face", "not looked for%s: run `sunprobe check` on the capture", skipped);
    else if (!isfinite(r->face_share))
        say(v, 1, "face", "not looked for: no landmark side data, and %s", "no dlib tracker (build with -Ddlib, "
            "install its model, or drop --no-face)");
    else
        say(v, r->face_share < MIN_FACES ? 2 : r->face_share < GOOD_FACES ? 1 : 0, "face", "found on %.0f %% of frames%s%s",
            100 * r->face_share, skipped,
            r->face_share < GOOD_FACES ? ": keep the whole face in the frame, lit, at arm's length" : "");
    if (!r->gyro_samples && r->video_checked && r->video_ok) {
        say(v, 0, "imu", "none: the camera orientation comes from the video (%zu of %zu frames tracked%s)",
            r->video_frames - r->video_coasted, r->video_frames, r->video_loop_closed ? ", the loop closed" : "");
    } else if (!r->gyro_samples) {
        say(v, 2, "imu",
            "no gyroscope samples%s (import one with --imu, or film in front of a textured background "
            "far away)",
            r->video_checked ? ", and the background cannot be tracked in the video" : "");
        return;
    } else {
        say(v,
            r->imu_coverage < MIN_COVERAGE ? 2
                : r->gyro_hz < MIN_GYRO_HZ ? 1
                                           : 0,
            "imu", "gyro at %.0f Hz covering %.0f %% of the frames%s", r->gyro_hz, 100 * r->imu_coverage,
            r->imu_coverage < MIN_COVERAGE ? ": the clocks do not line up (import --imu-offset)"
                : r->gyro_hz < MIN_GYRO_HZ ? ": record the gyroscope at 100 Hz or more"
                                           : "");
    }
    say(v, r->turn_range_deg < MIN_TURN_DEG ? 2 : r->turn_range_deg < GOOD_TURN_DEG ? 1 : 0, "turn",
        "%.0f deg turned about gravity (net %.0f deg)%s", r->turn_range_deg, r->turn_deg,
        r->turn_range_deg < GOOD_TURN_DEG ? ": re-shoot turning a full circle in place" : "");
    say(v, r->clipped_share > MAX_CLIPPED ? 1 : 0, "exposure", "%.0f %% of frames clipped%s", 100 * r->clipped_share,
        r->clipped_share > MAX_CLIPPED ? ": lower the exposure (or lock it before turning)" : "");
    if (!isfinite(r->blurred_share))
        say(v, 1, "blur", "not judged: the frames carry no shutter time");
    else
        say(v, r->blurred_share > MAX_BLURRED ? 1 : 0, "blur",
            "%.0f %% of frames smeared over a pixel at the fit's 128 px (at most %.1f px)%s", 100 * r->blurred_share,
            r->blur_max_px, r->blurred_share > MAX_BLURRED ? ": turn more slowly, or shoot in more light" : "");
    if (!isfinite(r->light_modulation))
        say(v, 1, "lighting", "not judged: the turn is too short to compare sides");
    else
        say(v, r->light_modulation < MIN_MODULATION ? 1 : 0, "lighting",
            "the %s's brightness varies by %.2f of its mean over the turn: %s",
            r->light_from_face ? "face" : "frame centre", r->light_modulation,
            r->light_modulation < MIN_MODULATION ? "flat (overcast?): the fit will probably leave the sun out; "
                                                   "shoot in direct sun"
                                                 : "lighting observable");
}

static int write_json(const char *path, const sp_check_report *r, const sp_check_verdicts *v)
{
    sp_atomic_file f;
    int rc = sp_atomic_file_open(&f, path);
    if (rc)
        return rc;
    char light[32] = "null", blur[32] = "null", face[32] = "null"; /* JSON has no NaN */
    if (isfinite(r->face_share))
        snprintf(face, sizeof(face), "%.6g", r->face_share);
    if (isfinite(r->light_modulation))
        snprintf(light, sizeof(light), "%.6g", r->light_modulation);
    if (isfinite(r->blurred_share))
        snprintf(blur, sizeof(blur), "%.6g", r->blurred_share);
    fprintf(f.file,
            "{\"frames\": %zu, \"undecodable\": %zu, \"duration_s\": %.6g, \"fps\": %.6g, \"max_gap_s\": %.6g,\n"
            " \"gyro_samples\": %zu, \"gyro_hz\": %.6g, \"imu_coverage\": %.6g, \"turn_deg\": %.6g,\n"
            " \"turn_range_deg\": %.6g, \"clipped_share\": %.6g, \"blurred_share\": %s, \"blur_max_px\": %.6g,\n"
            " \"sharpness\": %.6g,"
            " \"light_modulation\": %s, \"light_from_face\": %d, \"face_share\": %s, \"fails\": %d, \"warnings\": %d}\n",
            r->frames, r->undecodable, r->duration_s, r->fps, r->max_gap_s, r->gyro_samples, r->gyro_hz,
            r->imu_coverage, r->turn_deg, r->turn_range_deg, r->clipped_share,
            blur, r->blur_max_px, r->sharpness, light,
            r->light_from_face, face, v->fails, v->warns);
    /* a stop signal before the rename: FILE as it was */
    return sp_atomic_file_finish(&f, ferror(f.file) ? -EIO : sp_cmd_stop_signal ? -ECANCELED : 0);
}

/* No gyroscope: the background tracked as the fit would, its turn in place of the IMU's. */
static int check_video(const char *path, sp_check_report *r)
{
    char *text = NULL;
    size_t len = 0;
    FILE *quiet = open_memstream(&text, &len); /* the stage's summary: the verdict says it shorter */
    if (!quiet)
        return -ENOMEM;
    sp_stage stage = { 0 };
    sp_vo_result vr;
    int ret = sp_tool_video_orientation(path, 0, quiet, &stage, &vr);
    sp_stage_close(&stage);
    fclose(quiet);
    free(text);
    if (ret && ret != SP_ENODATA && ret != SP_EMODULE)
        return ret;
    r->video_checked = ret != SP_EMODULE; /* a build without OpenCV cannot look */
    r->video_ok = ret == 0;
    r->video_loop_closed = vr.loop_closed;
    r->video_frames = vr.frames, r->video_coasted = vr.coasted;
    if (r->video_ok)
        r->turn_deg = r->turn_range_deg = vr.turn_deg;
    return 0;
}

int sp_cmd_check(int argc, char **argv)
{
    static const struct option opts[] = { { "json", required_argument, NULL, 'j' }, { "no-face", no_argument, NULL, 'n' },
                                          { "help", no_argument, NULL, 'h' }, { 0 } };
    optind = 0;
    const char *json = NULL;
    int c, faces = 1;
    while ((c = getopt_long(argc, argv, "h", opts, NULL)) != -1) {
        if (c == 'j')
            json = optarg;
        else if (c == 'n')
            faces = 0;
        else if (c == 'h') {
            usage(stdout);
            return SP_EXIT_OK;
        } else {
            usage(stderr);
            return SP_EXIT_USAGE;
        }
    }
    if (optind != argc - 1) {
        fprintf(stderr, "sunprobe " CMD ": expected one CAPTURE\n");
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    const char *path = argv[optind];
    sp_check_report r;
    sp_cmd_signals sig; /* a stop signal is acted on before --json is written; once it is, the run ends */
    sp_cmd_catch_signals(&sig);
    int rc = sp_check_capture(path, faces, &r);
    if (!rc && !r.gyro_samples && r.frames)
        rc = check_video(path, &r);
    if (!rc && sp_cmd_stop_signal)
        return sp_cmd_fail(CMD, -ECANCELED, path);
    if (rc) {
        fprintf(stderr, "sunprobe " CMD ": %s: %s%s\n", path, sp_strerror(rc),
                rc == SP_EDISABLED ? " (decoding MJPEG frames needs libjpeg: rebuild with -Djpeg=enabled)" : "");
        return sp_exit_for_error(rc);
    }
    sp_check_verdicts v = { 0 };
    sp_check_judge(&r, stdout, &v);
    printf("%s: %s\n", path, v.fails ? "this capture cannot work: re-shoot as said above"
                       : v.warns ? "usable, with the warnings above" : "good to fit");
    if (json && (rc = write_json(json, &r, &v)) != 0)
        return sp_cmd_fail(CMD, rc, json);
    return v.fails ? SP_EXIT_BAD_INPUT : SP_EXIT_OK;
}
