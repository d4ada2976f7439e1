/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe fit CAPTURE -o FACE_DIR`: streams a rotating-selfie capture through
 * the SunStage front end, fits, and writes the face directory into
 * FACE_DIR.partial.<pid>, renamed to FACE_DIR only when every file is written.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "capture_open.h"
#include "cmd.h"
#include "common/clock.h"
#include "common/file_util.h"
#include "common/json.h"
#include "common/module.h"
#include "common/progress.h"
#include "common/report.h"
#include "export/face_dir.h"
#include "pipeline/stages/stages.h"
#include "video_orientation.h"
#include "sunprobe/sp_face_model.h"
#include "sunprobe/sp_sunstage.h"

enum { ORIENT_AUTO, ORIENT_IMU, ORIENT_VIDEO }; /* --orientation */

typedef struct fit_args {
    const char *capture, *out, *report;
    sp_sunstage_settings set;
    int progress;
    const char *face;     /* auto, generic, ict */
    int orientation;      /* ORIENT_* */
    sp_stage video;       /* the video-orientation pre-pass, when it ran */
    char truth[4096];     /* truth.json of a synthetic capture, "" when none */
    sp_partial pd;        /* FACE_DIR.partial.PID: made before the fit, so a bad location fails at once */
} fit_args;

static void fit_usage(FILE *out)
{
    fprintf(out,
            "usage: sunprobe fit CAPTURE -o FACE_DIR [options]\n\n"
            "Fits face geometry, reflectance, sun and sky and per-frame cameras to a rotating-selfie\n"
            "capture (frames + IMU; landmarks from side data, else dlib).\n"
            "  --solver fast|adam     photometric solver (default fast)\n"
            "  --keyframes N          training keyframes, one per camera-yaw bin (default 12)\n"
            "  --heldout N            held-out keyframes (default 3)\n"
            "  --fit-width W          fitting resolution: the face crop's side, or the frame's width\n"
            "  --face-crop            fit a square crop around the face instead of the whole frame\n"
            "  --texture N|auto       albedo/displacement rows, 8-2048 (default 128); auto: one texel per\n"
            "                         face pixel of the best keyframe\n"
            "  --iterations N         Adam steps (default 300)\n"
            "  --time-budget S        stop the photometric stage after S seconds\n"
            "  --min-rotation DEG     below this camera-yaw range lighting is unobservable (default 90)\n"
            "  --silhouette W         silhouette loss weight per outline vertex (default 0.5; 0 = off)\n"
            "  --refine N             fast solver: photometric refinement steps of geometry and\n"
            "                         displacement, kept if the held-out PSNR rises (default 20; 0 = off)\n"
            "  --threads N            solver threads (default 0 = the online CPUs; the result does not\n"
            "                         depend on it)\n"
            "  --fixed-exposure       frames without their exposure in the capture are all at one exposure\n"
            "                         (it was locked); by default, when no frame gives it, each keyframe's\n"
            "                         is estimated from the fit\n"
            "  --no-dlib              never run the dlib detector\n"
            "  --dlib-model PATH      shape_predictor_68_face_landmarks.dat location\n"
            "  --report PREFIX        error against run time: PREFIX.csv and PREFIX.svg (when the fit succeeds)\n"
            "  --face auto|generic|ict  face model (default auto: ICT when its data exists)\n"
            "  --orientation auto|imu|video  camera orientation per frame: from the IMU, or from the video\n"
            "                         alone (background tracked by rotation, a pass before the fit); auto\n"
            "                         (default): the IMU when the capture has one, else the video\n"
            "  --no-progress          no progress bar\n");
}

static int parse_fit(int argc, char **argv, fit_args *a)
{
    static const struct option opts[] = {
        { "help", no_argument, NULL, 'h' },
        { "output", required_argument, NULL, 'o' },
        { "solver", required_argument, NULL, 's' },
        { "keyframes", required_argument, NULL, 'k' },
        { "heldout", required_argument, NULL, 'H' },
        { "fit-width", required_argument, NULL, 'w' },
        { "texture", required_argument, NULL, 't' },
        { "iterations", required_argument, NULL, 'i' },
        { "time-budget", required_argument, NULL, 'b' },
        { "min-rotation", required_argument, NULL, 'r' },
        { "no-dlib", no_argument, NULL, 'n' },
        { "dlib-model", required_argument, NULL, 'd' },
        { "report", required_argument, NULL, 'R' },
        { "no-progress", no_argument, NULL, 'P' },
        { "face", required_argument, NULL, 'f' },
        { "silhouette", required_argument, NULL, 'S' },
        { "refine", required_argument, NULL, 'F' },
        { "face-crop", no_argument, NULL, 'C' },
        { "threads", required_argument, NULL, 'T' },
        { "fixed-exposure", no_argument, NULL, 'E' },
        { "orientation", required_argument, NULL, 'O' },
        { 0 },
    };
    static const char *const solvers[] = { "fast", "adam" }, *const faces[] = { "auto", "generic", "ict" };
    static const char *const orientations[] = { "auto", "imu", "video" };
    int c, bad = 0, li = -1, choice = 0;
    while (!bad && (c = getopt_long(argc, argv, "ho:", opts, &li)) != -1) {
        const char *on = li >= 0 ? opts[li].name : "";
        li = -1;
        switch (c) {
        case 'h': fit_usage(stdout); return 1;
        case 'o': a->out = optarg; break;
        case 's':
            bad = sp_opt_choice("fit", on, optarg, solvers, 2, &choice);
            a->set.solver = choice == 1 ? SP_SUNSTAGE_SOLVER_ADAM : SP_SUNSTAGE_SOLVER_FAST;
            break;
        case 'k': bad = sp_opt_int("fit", on, optarg, 2, 64, &a->set.keyframes); break;
        case 'H': bad = sp_opt_int("fit", on, optarg, 0, 16, &a->set.heldout); break;
        case 'w': bad = sp_opt_int("fit", on, optarg, 16, 1024, &a->set.fit_width); break;
        case 't':
            if (strcmp(optarg, "auto") == 0)
                a->set.texture_size = 0;
            else
                bad = sp_opt_int("fit", on, optarg, 8, 2048, &a->set.texture_size);
            break;
        case 'i': bad = sp_opt_int("fit", on, optarg, 0, 100000, &a->set.adam_iterations); break;
        case 'b': bad = sp_opt_double("fit", on, optarg, 0, 1e6, &a->set.time_budget_s); break;
        case 'r': bad = sp_opt_double("fit", on, optarg, 0, 360, &a->set.min_rotation_deg); break;
        case 'n': a->set.use_dlib = 0; break;
        case 'C': a->set.face_crop = 1; break;
        case 'E':
            a->set.fixed_exposure = 1;
            break;
        case 'S': bad = sp_opt_double("fit", on, optarg, 0, 100, &a->set.silhouette_weight); break;
        case 'F': bad = sp_opt_int("fit", on, optarg, 0, 10000, &a->set.refine_steps); break;
        case 'T': bad = sp_opt_int("fit", on, optarg, 0, 64, &a->set.threads); break;
        case 'd': a->set.dlib_model = optarg; break;
        case 'R': a->report = optarg; break;
        case 'P': a->progress = 0; break;
        case 'O':
            bad = sp_opt_choice("fit", on, optarg, orientations, 3, &choice);
            a->orientation = choice;
            break;
        case 'f':
            a->face = optarg;
            bad = sp_opt_choice("fit", on, optarg, faces, 3, &choice);
            break;
        default: bad = 1; /* getopt has said which option */
        }
    }
    if (bad) {
        fprintf(stderr, "sunprobe fit: see --help\n");
        return -1;
    }
    if (optind != argc - 1 || !a->out) {
        fprintf(stderr, "sunprobe fit: expected CAPTURE and -o FACE_DIR (see --help)\n");
        return -1;
    }
    a->capture = argv[optind];
    return 0;
}

typedef struct fit_cb_ctx {
    sp_report *report;
    sp_progress *bar;
    const sp_sunstage *ss;
    int have_truth;
    double true_sun[3];
} fit_cb_ctx;

/* Angle between the fitted sun (mapped into the truth's world) and the true sun, degrees; NaN without truth. */
static double sun_error_deg(const fit_cb_ctx *c)
{
    double R[9];
    sp_sunstage_result r;
    if (!c->have_truth || sp_sunstage_align_world(c->ss, R) || sp_sunstage_get_result(c->ss, &r))
        return NAN;
    double d = 0.0;
    for (int i = 0; i < 3; i++)
        d += (R[i * 3] * r.sun_dir[0] + R[i * 3 + 1] * r.sun_dir[1] + R[i * 3 + 2] * r.sun_dir[2]) * c->true_sun[i];
    return acos(fmax(-1.0, fmin(1.0, d))) * 180.0 / M_PI;
}

static int on_progress(void *user, const sp_sunstage_progress *p)
{
    fit_cb_ctx *c = user;
    if (c->report && !strcmp(p->stage, "photometric")) {
        double v[3] = { p->loss, p->heldout_psnr, sun_error_deg(c) };
        sp_report_add(c->report, p->seconds, v);
    }
    char detail[96];
    if (isfinite(p->loss))
        snprintf(detail, sizeof(detail), "%s loss %.4g", p->stage, p->loss);
    else
        snprintf(detail, sizeof(detail), "%s", p->stage);
    c->bar->total = (uint64_t)(p->total > 0 ? p->total : 1);
    sp_progress_update(c->bar, (uint64_t)p->iteration, detail);
    return sp_cmd_stop_signal != 0; /* Ctrl-C: the fit ends early and nothing is written */
}

static void find_truth(fit_args *a, const char *rel)
{
    char base[4096];
    snprintf(base, sizeof(base), "%s", a->capture);
    char *slash = strrchr(base, '/');
    if (slash)
        slash[1] = 0;
    else
        base[0] = 0;
    struct stat st;
    int n = snprintf(a->truth, sizeof(a->truth), "%s%s", rel[0] == '/' ? "" : base, rel);
    if (n > 0 && (size_t)n < sizeof(a->truth) - 12 && stat(a->truth, &st) == 0 && S_ISDIR(st.st_mode))
        strcat(a->truth, "/truth.json");
}

/* The true sun direction from truth.json (lighting.sun.direction_world); 0 when found. */
static int read_true_sun(const char *path, double sun[3])
{
    void *buf = NULL;
    size_t n = 0;
    int ret = sp_read_whole_file(path, (1 << 20) - 1, &buf, &n);
    if (ret)
        return ret;
    sp_json *root = NULL;
    char err[128];
    ret = sp_json_parse(buf, n, &root, err, sizeof(err));
    free(buf);
    if (ret)
        return ret;
    const sp_json *s = sp_json_get(sp_json_get(sp_json_get(root, "lighting"), "sun"), "direction_world");
    ret = sp_json_numbers(s, sun, 3) == 3 ? 0 : SP_ENODATA;
    sp_json_free(root);
    return ret;
}

/* 1 when the capture carries a gyroscope sample (read up to the first), 0 when not, or an error: the IMU's
   orientation needs one; an accelerometer alone gives the video's orientation its world up. */
static int capture_has_gyro(const char *path)
{
    sp_source *src = NULL;
    sp_replay_settings rs;
    sp_replay_default_settings(&rs);
    int ret = sp_replay_open(&src, path, &rs);
    sp_event ev;
    while (!ret && (ret = sp_source_next(src, &ev)) == 0) {
        int imu = ev.type == SP_EVENT_IMU && ev.imu.sensor == SP_IMU_GYRO;
        sp_event_release(&ev);
        if (imu)
            ret = 1;
    }
    sp_source_close(&src);
    return ret == SP_EOS ? 0 : ret;
}

/*
 * Without an IMU (or with --orientation video): the camera orientation of every frame from the
 * video, a whole pass before the fit (the loop closure needs the end of the turn). Exit code on failure.
 */
static int orient_from_video(fit_args *a)
{
    int has_gyro = a->orientation == ORIENT_AUTO ? capture_has_gyro(a->capture) : 0;
    if (has_gyro < 0) /* unreadable: the fit's own pass says why */
        return SP_EXIT_OK;
    if (a->orientation == ORIENT_IMU || has_gyro)
        return SP_EXIT_OK;
    if (a->orientation == ORIENT_AUTO)
        printf("fit: no gyroscope in the capture (no IMU, or an accelerometer alone): the camera orientation "
               "comes from the video (--orientation)\n");
    sp_vo_result r;
    int ret = sp_tool_video_orientation(a->capture, a->progress, NULL, &a->video, &r);
    if (ret == -ECANCELED)
        return sp_cmd_fail("fit", ret, a->out);
    if (ret == SP_EMODULE) { /* no OpenCV here: the fit goes on without, and says what is missing */
        sp_stage_close(&a->video);
        printf("fit: this build cannot orient the video (no OpenCV): frames without an IMU orientation are "
               "skipped\n");
        return SP_EXIT_OK;
    }
    if (ret == SP_ENODATA && r.frames)
        return sp_cmd_failf("fit", ret,
                            "%s: the camera orientation cannot be found from the video (see above): "
                            "record with an IMU, or in front of a textured background far away",
                            a->capture);
    if (ret)
        return sp_cmd_failf("fit", ret, "%s: video orientation", a->capture);
    return SP_EXIT_OK;
}

/* Streams the capture through the orientation tagger into the fitter's front end. */
static int stream(fit_args *a, const sp_stage *stage)
{
    sp_run_settings rs;
    sp_run_default_settings(&rs);
    if (a->video.ctx) {
        rs.tagger.orientation_for = sp_video_orientation_for;
        rs.tagger.orientation_user = a->video.ctx;
    }
    rs.progress = a->progress ? -1 : 0;
    rs.stop = &sp_cmd_stop_signal;
    sp_run_stats st;
    int ret = sp_stage_run(a->capture, stage, &rs, &st);
    if (sp_cmd_stop_signal) /* a read cut short by the signal is no capture error */
        return -ECANCELED;
    if (st.meta.ground_truth[0]) /* relative to the capture's directory */
        find_truth(a, st.meta.ground_truth);
    if (ret && st.failed_in == SP_RUN_FAILED_OPEN)
        fprintf(stderr, "sunprobe fit: cannot read capture %s: %s\n", a->capture, sp_strerror(ret));
    else if (ret && st.failed_in == SP_RUN_FAILED_SOURCE) /* the chunk's offset, as probe and replay say it */
        sp_tool_capture_error("fit", a->capture, ret, st.replay.error_offset);
    else if (ret)
        fprintf(stderr, "sunprobe fit: reading %s: %s\n", a->capture, sp_strerror(ret));
    return ret;
}

static int write_output(fit_args *a, const sp_sunstage *ss)
{
    int ret = sp_face_dir_write_all(ss, a->pd.path);
    if (!ret && sp_cmd_stop_signal) /* the last moment a signal can keep the face directory out */
        ret = -ECANCELED;
    if (!ret)
        ret = sp_partial_dir_commit(&a->pd, 0);
    return ret;
}

static void print_summary(const sp_sunstage *ss)
{
    sp_sunstage_result r;
    sp_sunstage_counts c;
    sp_sunstage_get_result(ss, &r);
    sp_sunstage_get_counts(ss, &c);
    printf("fit: %llu frames (%llu dark, %llu saturated, %llu blurred, %llu no face, %llu no orientation, "
           "%llu undecodable skipped; %llu thinned while the IMU filter initialised); %d keyframes + %d held out over "
           "%.0f deg of yaw\n",
           (unsigned long long)c.frames, (unsigned long long)c.skipped_dark, (unsigned long long)c.skipped_saturated,
           (unsigned long long)c.skipped_blurred, (unsigned long long)c.skipped_no_face,
           (unsigned long long)c.skipped_no_orientation, (unsigned long long)c.skipped_undecodable,
           (unsigned long long)c.thinned_early, c.keyframes, c.heldout, r.yaw_range_deg);
    printf("fit: sun (%.3f, %.3f, %.3f) intensity %.3f%s%s; train PSNR %.2f dB, held-out %.2f dB; %.1f s\n",
           r.sun_dir[0], r.sun_dir[1], r.sun_dir[2], r.sun_intensity, r.sun_dropped ? " [dropped: overcast]" : "",
           r.lighting_unobservable ? " [lighting unobservable]" : "", r.train_psnr, r.heldout_psnr, r.seconds);
    printf("fit: time: front end %.1f s (while streaming), alignment %.1f s, photometric solve %.1f s, refinement "
           "%.1f s; %d solver thread(s)\n",
           r.frontend_seconds, r.align_seconds, r.solve_seconds, r.refine_seconds, r.threads);
    if (r.notes[0])
        printf("fit: %s\n", r.notes);
    if (r.have_clock_sun)
        printf("fit: sun from the clock (%.3f, %.3f, %.3f): %.1f deg from the fitted sun\n", r.clock_sun_dir[0],
               r.clock_sun_dir[1], r.clock_sun_dir[2], r.clock_sun_angle_deg);
}

static int run_fit(fit_args *a, const sp_face_model *model)
{
    sp_stage stage = { 0 };
    sp_fit_stage_settings fs = { .fit = a->set, .model = model };
    int ret = sp_stage_open(&stage, &sp_stage_fit, &fs);
    if (ret)
        return sp_cmd_fail("fit", ret, "settings");
    sp_sunstage *ss = stage.ctx;
    int code = SP_EXIT_OK;
    sp_report *rep = NULL;
    const char *names[3] = { "photometric loss [masked L2 of display values, training keyframes]", "held-out PSNR [dB]",
                             "sun error [degrees]" };
    /* the report is opened before any work, so an unwritable PREFIX fails at once rather than after the fit */
    if (a->report && (ret = sp_report_open(&rep, a->report, "sunprobe fit", names, 3, 0))) {
        code = sp_cmd_failf("fit", ret, "cannot write the report %s", a->report);
        goto done;
    }
    if ((code = orient_from_video(a)) != SP_EXIT_OK)
        goto done;
    if ((ret = stream(a, &stage))) {
        code = ret == -ECANCELED ? sp_cmd_fail("fit", ret, a->out) : sp_exit_for_error(ret);
        goto done;
    }
    fit_cb_ctx cb = { .ss = ss };
    if (a->truth[0] && read_true_sun(a->truth, cb.true_sun) == 0)
        cb.have_truth = 1;
    sp_progress bar;
    sp_progress_start(&bar, "fit", 1, a->progress ? -1 : 0);
    cb.report = rep;
    cb.bar = &bar;
    ret = sp_sunstage_fit(ss, on_progress, &cb);
    sp_progress_finish(&bar);
    if (!ret && sp_cmd_stop_signal)
        ret = -ECANCELED;
    if (ret == -ECANCELED) {
        code = sp_cmd_fail("fit", ret, a->out);
        goto done;
    }
    if (ret) {
        code = sp_cmd_fail("fit", ret, "nothing to fit (see the message above)");
        goto done;
    }
    print_summary(ss);
    if (cb.have_truth)
        printf("fit: ground truth %s: sun direction error %.2f deg\n", a->truth, sun_error_deg(&cb));
    if ((ret = write_output(a, ss)))
        code = sp_cmd_fail("fit", ret, a->out);
    else
        printf("fit: wrote %s\n", a->out);
done:
    /* the report of a failed or interrupted fit is dropped with the face directory: nothing half-written stays */
    if (code != SP_EXIT_OK)
        sp_report_abort(&rep);
    else if (rep && (ret = sp_report_close(&rep)))
        code = sp_cmd_failf("fit", ret, "writing the report %s", a->report);
    sp_stage_close(&stage);
    sp_stage_close(&a->video);
    return code;
}

int sp_cmd_fit(int argc, char **argv)
{
    fit_args a = { .progress = 1 };
    sp_sunstage_default_settings(&a.set);
    int p = parse_fit(argc, argv, &a);
    if (p)
        return p > 0 ? SP_EXIT_OK : SP_EXIT_USAGE;
    struct stat st;
    if (stat(a.out, &st) == 0) {
        fprintf(stderr, "sunprobe fit: %s exists; remove it or choose another FACE_DIR\n", a.out);
        return SP_EXIT_USAGE;
    }
    sp_cmd_signals sig; /* Ctrl-C/SIGTERM from here on: the partial directory is removed, 128+N */
    sp_cmd_catch_signals(&sig);
    int ret = sp_partial_dir_open(&a.pd, a.out);
    if (ret) {
        sp_cmd_restore_signals(&sig);
        return sp_cmd_failf("fit", ret, "cannot create the face directory %s", a.out);
    }
    sp_face_model model;
    if (a.face && !strcmp(a.face, "generic")) {
        ret = sp_face_model_generic(&model);
    } else if (a.face && !strcmp(a.face, "ict")) {
        sp_face_load_settings ls;
        sp_face_load_default_settings(&ls);
        ret = sp_face_model_load(&model, &ls);
        if (!ret && strncmp(model.source, "ict", 3)) {
            sp_face_model_free(&model);
            ret = -ENOENT;
            fprintf(stderr, "sunprobe fit: the ICT face model is missing (tools/fetch-ict-facekit.sh)\n");
        }
    } else {
        ret = sp_face_model_load_default(&model);
    }
    int code = ret ? sp_cmd_fail("fit", ret, "loading the face model") : run_fit(&a, &model);
    if (!ret)
        sp_face_model_free(&model);
    sp_partial_dir_abort(&a.pd); /* a no-op once committed */
    sp_cmd_restore_signals(&sig);
    return code;
}
