/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe probe CAPTURE -o PROBE_DIR`: People as Scene Probes on a static
 * camera. Streams the capture through the probe and writes the clean plate,
 * the occlusion and lighting maps, the plane and shadow models and the
 * convergence report. Everything goes into PROBE_DIR.partial.PID first and is
 * renamed into place only when complete, so a failed run leaves nothing that
 * looks like a result.
 */
#include <errno.h>
#include <getopt.h>
#include <inttypes.h>
#include <signal.h>
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
#include "common/pixconv.h"
#include "common/progress.h"
#include "export/png.h"
#include "export/probe_dir.h"
#include "pipeline/stages/stages.h"
#include "sunprobe/sp_probe.h"
#include "sunprobe/sp_replay.h"

#define MAX_EMPTY 16

typedef struct probe_args {
    const char *capture, *out;
    sp_probe_settings s;
    int holdout_half, quiet, force, objects;
    uint64_t max_frames;
    uint64_t empty[MAX_EMPTY];
    unsigned n_empty;
} probe_args;

static void usage(FILE *out)
{
    fprintf(out,
            "usage: sunprobe probe CAPTURE -o PROBE_DIR [options]\n\n"
            "People as Scene Probes: uses the people and objects moving through a static camera's view\n"
            "to learn a clean plate, an occlusion map, a lighting map, the ground-plane scale (pixel height\n"
            "of a person anywhere on the ground) and a shadow model. Method: pipeline/probe/PROBE.md.\n\n"
            "options:\n"
            "  -o, --output DIR      probe directory to create (written as DIR.partial.PID, then renamed)\n"
            "      --window S        clean-plate median window in seconds (default 4)\n"
            "      --samples K       frames in that window, odd 3..31 (default 15)\n"
            "      --settle S        a person who walks in and stops stays out of the plate this long,\n"
            "                        then becomes background (default 120; 0: the median alone)\n"
            "      --threshold T     refined-mask colour distance |dR|+|dG|+|dB|, 1..765 (default 50)\n"
            "      --min-object PX   smallest object in pixels (default: width * height / 4000)\n"
            "      --detector D      shape (default) or hog (OpenCV's HOG people detector confirms)\n"
            "      --holdout-from N  frames from N on test the scale model instead of fitting it\n"
            "      --holdout-half    the same from the middle frame\n"
            "      --empty-frame N   also write frame_N.png and empty_N.png (objects removed); repeatable\n"
            "      --objects         also write objects.csv: every object of every probed frame, its box,\n"
            "                        foot point, height and class (person, car, other)\n"
            "      --max-frames N    stop after N frames\n"
            "  -f, --force           replace PROBE_DIR if it exists\n"
            "  -q, --quiet           no progress bar or summary\n"
            "  -h, --help            this text\n\n"
            "Writes clean_plate.png, occlusion.pfm/.png, occlusion_confidence.pfm/.png (how far\n"
            "each pixel's own events back its occlusion value, 0..1), lighting.pfm/.png, probe.json\n"
            "and convergence.csv/.svg (error against run time).\n");
}

#define CMD "probe"

/* After an option value's own message (tools/cmd_options.c): the usage code. */
static int checked(int bad)
{
    if (bad)
        fprintf(stderr, "sunprobe " CMD ": see --help\n");
    return bad ? SP_EXIT_USAGE : 0;
}

enum { OPT_WINDOW = 256, OPT_SAMPLES, OPT_THRESHOLD, OPT_MIN_OBJECT, OPT_DETECTOR, OPT_HOLDOUT, OPT_HOLDOUT_HALF,
       OPT_EMPTY, OPT_MAX_FRAMES, OPT_OBJECTS, OPT_SETTLE };

static int parse_option(int c, probe_args *a)
{
    static const char *const detectors[] = { "shape", "hog" };
    int i = 0, bad;
    uint64_t u = 0;
    switch (c) {
    case 'o': a->out = optarg; return 0;
    case OPT_WINDOW: return checked(sp_opt_double(CMD, "window", optarg, 0.05, 3600, &a->s.window_s));
    case OPT_SAMPLES:
        bad = sp_opt_int(CMD, "samples", optarg, 3, 31, &i);
        if (!bad && i % 2 == 0) { /* a median needs a middle sample */
            fprintf(stderr, "sunprobe " CMD ": --samples '%s': expected an odd number\n", optarg);
            bad = -1;
        }
        a->s.window_samples = bad ? a->s.window_samples : (unsigned)i;
        return checked(bad);
    case OPT_THRESHOLD:
        bad = sp_opt_int(CMD, "threshold", optarg, 1, 765, &i);
        a->s.fg_threshold = bad ? a->s.fg_threshold : (unsigned)i;
        return checked(bad);
    case OPT_MIN_OBJECT:
        bad = sp_opt_int(CMD, "min-object", optarg, 1, 10000000, &i);
        a->s.min_object_px = bad ? a->s.min_object_px : (unsigned)i;
        return checked(bad);
    case OPT_DETECTOR:
        bad = sp_opt_choice(CMD, "detector", optarg, detectors, 2, &i);
        a->s.detector = i ? SP_PROBE_DETECT_HOG : SP_PROBE_DETECT_SHAPE;
        return checked(bad);
    case OPT_HOLDOUT:
        bad = sp_opt_u64(CMD, "holdout-from", optarg, 0, INT64_MAX, &u);
        a->s.holdout_from = (int64_t)u;
        return checked(bad);
    case OPT_HOLDOUT_HALF: a->holdout_half = 1; return 0;
    case OPT_EMPTY:
        if (a->n_empty == MAX_EMPTY) {
            fprintf(stderr, "sunprobe " CMD ": --empty-frame: at most %d\n", MAX_EMPTY);
            return checked(1);
        }
        bad = sp_opt_u64(CMD, "empty-frame", optarg, 0, UINT64_MAX, &u);
        a->empty[a->n_empty] = u;
        a->n_empty += !bad;
        return checked(bad);
    case OPT_MAX_FRAMES: return checked(sp_opt_u64(CMD, "max-frames", optarg, 1, UINT64_MAX, &a->max_frames));
    case OPT_OBJECTS: a->objects = 1; return 0;
    case OPT_SETTLE: return checked(sp_opt_double(CMD, "settle", optarg, 0, 36000, &a->s.settle_s));
    case 'f': a->force = 1; return 0;
    case 'q': a->quiet = 1; return 0;
    case 'h': usage(stdout); return -1;
    default: usage(stderr); return SP_EXIT_USAGE;
    }
}

static int parse_args(int argc, char **argv, probe_args *a)
{
    static const struct option opts[] = {
        { "output", required_argument, NULL, 'o' },         { "window", required_argument, NULL, OPT_WINDOW },
        { "samples", required_argument, NULL, OPT_SAMPLES }, { "threshold", required_argument, NULL, OPT_THRESHOLD },
        { "min-object", required_argument, NULL, OPT_MIN_OBJECT },
        { "detector", required_argument, NULL, OPT_DETECTOR }, { "holdout-from", required_argument, NULL, OPT_HOLDOUT },
        { "holdout-half", no_argument, NULL, OPT_HOLDOUT_HALF }, { "empty-frame", required_argument, NULL, OPT_EMPTY },
        { "max-frames", required_argument, NULL, OPT_MAX_FRAMES }, { "force", no_argument, NULL, 'f' },
        { "objects", no_argument, NULL, OPT_OBJECTS },      { "settle", required_argument, NULL, OPT_SETTLE },
        { "quiet", no_argument, NULL, 'q' },                  { "help", no_argument, NULL, 'h' },
        { 0 },
    };
    optind = 0;
    int c, code;
    while ((c = getopt_long(argc, argv, "o:fqh", opts, NULL)) != -1)
        if ((code = parse_option(c, a)))
            return code;
    if (optind != argc - 1 || !a->out) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    a->capture = argv[optind];
    return 0;
}

/* ---- a first pass: frame count, size and the metadata's ground truth ---- */

typedef struct capture_facts {
    uint64_t frames;
    uint32_t width, height;
    char ground_truth[256];
    /* what a static camera's probe cannot take, found before any work: the first frame (1-based) of each */
    uint64_t resized_at, backwards_at;
    uint32_t resized_w, resized_h;
    int64_t last_ns;
} capture_facts;

static void meta_ground_truth(const sp_chunk *c, capture_facts *f)
{
    sp_json *root = NULL;
    char err[64];
    if (sp_json_parse((const char *)c->payload, c->payload_size, &root, err, sizeof(err)))
        return;
    const char *gt = sp_json_string(sp_json_get(root, "ground_truth"), NULL);
    if (gt)
        snprintf(f->ground_truth, sizeof(f->ground_truth), "%s", gt);
    sp_json_free(root);
}

static int first_pass(const char *path, capture_facts *f)
{
    sp_capture_reader *r = NULL;
    int code = sp_tool_open_capture("probe", path, 0, &r);
    if (code)
        return code;
    sp_chunk c;
    int ret;
    while ((ret = sp_capture_reader_next(r, &c)) == 0) {
        sp_frame_chunk fc;
        if (c.type == SP_CHUNK_META)
            meta_ground_truth(&c, f);
        else if (c.type == SP_CHUNK_FRAME && !sp_chunk_parse_frame(&c, &fc) && fc.stream_id == 0) {
            if (!f->frames++)
                f->width = fc.width, f->height = fc.height;
            else if ((fc.width != f->width || fc.height != f->height) && !f->resized_at)
                f->resized_at = f->frames, f->resized_w = fc.width, f->resized_h = fc.height;
            if (f->frames > 1 && c.timestamp_ns < f->last_ns && !f->backwards_at)
                f->backwards_at = f->frames;
            f->last_ns = c.timestamp_ns;
        }
    }
    uint64_t off = c.offset;
    sp_capture_reader_close(&r);
    return ret == SP_EOS ? 0 : sp_tool_capture_error("probe", path, ret, off);
}

/* Samples of the truth file a synthetic capture names (for the report); NULL when there is none. */
static sp_probe_truth_sample *load_truth(const char *capture, const char *name, size_t *n)
{
    *n = 0;
    if (!name[0])
        return NULL;
    const char *slash = strrchr(capture, '/');
    size_t dir = slash ? (size_t)(slash - capture + 1) : 0, len = dir + strlen(name) + 1;
    char *path = malloc(len), *text = NULL;
    if (!path)
        return NULL;
    snprintf(path, len, "%.*s%s", (int)dir, capture, name);
    FILE *fp = fopen(path, "rb");
    free(path);
    if (!fp)
        return NULL;
    size_t cap = 1 << 20, got = 0;
    text = malloc(cap);
    if (text)
        got = fread(text, 1, cap, fp);
    fclose(fp);
    sp_json *root = NULL;
    char err[64];
    sp_probe_truth_sample *out = NULL;
    if (text && got < cap && !sp_json_parse(text, got, &root, err, sizeof(err))) {
        const sp_json *s = sp_json_get(root, "samples");
        size_t k = s && s->type == SP_JSON_ARRAY ? s->count : 0;
        out = k ? calloc(k, sizeof(*out)) : NULL;
        for (size_t i = 0; out && i < k; i++) {
            const sp_json *e = sp_json_at(s, i);
            out[i] = (sp_probe_truth_sample){ sp_json_number(sp_json_get(e, "x"), 0), sp_json_number(sp_json_get(e, "y"), 0),
                                              sp_json_number(sp_json_get(e, "height"), 0),
                                              sp_json_number(sp_json_get(e, "shadow_dx"), 0),
                                              sp_json_number(sp_json_get(e, "shadow_dy"), 0) };
        }
        *n = out ? k : 0;
    }
    sp_json_free(root);
    free(text);
    return out;
}

/* ---- the output directory ---- */

/* An existing output is replaced only with --force (an empty directory is fine). */
static int check_output(const probe_args *a)
{
    struct stat st;
    if (stat(a->out, &st) != 0)
        return 0;
    if (S_ISDIR(st.st_mode) && rmdir(a->out) == 0)
        return 0; /* it was empty */
    if (a->force && S_ISDIR(st.st_mode))
        return 0;
    fprintf(stderr, "sunprobe probe: %s exists (use --force to replace it)\n", a->out);
    return sp_exit_for_error(-EEXIST);
}

/* ---- streaming ---- */

typedef struct run_state {
    const probe_args *a;
    const char *dir;
    uint8_t *rgb;
    FILE *objects; /* objects.csv, with --objects */
    int objects_err;
} run_state;

/* One row per object of the frame just probed (the directory is renamed into place only when complete). */
static int write_objects(run_state *rs, const sp_probe *probe, uint64_t index, int64_t t_ns)
{
    sp_probe_object obj[64];
    unsigned n = sp_probe_frame_objects(probe, obj, 64);
    for (unsigned i = 0; i < n && i < 64; i++)
        fprintf(rs->objects, "%" PRIu64 ",%" PRId64 ",%s,%d,%d,%d,%d,%.2f,%.2f,%.2f,%u,%d\n", index, t_ns,
                sp_probe_class_name(obj[i].cls), obj[i].x0, obj[i].y0, obj[i].x1, obj[i].y1, obj[i].foot_x,
                obj[i].foot_y, obj[i].height, obj[i].area, obj[i].touches_border);
    if (ferror(rs->objects) && !rs->objects_err)
        rs->objects_err = sp_write_error();
    return rs->objects_err;
}

static int write_empty(run_state *rs, const sp_probe *probe, const sp_frame *f, uint64_t index)
{
    uint32_t w = f->width, h = f->height;
    char name[64];
    int ret = sp_probe_empty_frame(probe, rs->rgb, w * 3);
    if (ret == -EAGAIN) {
        fprintf(stderr, "sunprobe probe: frame %" PRIu64 " comes before the clean plate is ready; not emptied\n",
                index);
        return 0;
    }
    snprintf(name, sizeof(name), "empty_%06" PRIu64 ".png", index);
    char *p = sp_path_join_alloc(rs->dir, name);
    ret = ret ? ret : p ? sp_png_write(p, rs->rgb, w, h, w * 3, 3) : -ENOMEM;
    free(p);
    snprintf(name, sizeof(name), "frame_%06" PRIu64 ".png", index);
    p = sp_path_join_alloc(rs->dir, name);
    if (!ret)
        ret = p ? sp_pixconv_frame_to_rgb24(f, rs->rgb, (size_t)w * h * 3, w * 3) : -ENOMEM;
    if (!ret)
        ret = sp_png_write(p, rs->rgb, w, h, w * 3, 3);
    free(p);
    return ret;
}

/* After each probed frame: the emptied frames the user asked for (--empty). */
static int on_frame(void *user, const sp_probe *probe, const sp_frame *f, uint64_t index)
{
    run_state *rs = user;
    int ret = rs->objects ? write_objects(rs, probe, index, f->timestamp_ns) : 0;
    for (unsigned i = 0; !ret && i < rs->a->n_empty; i++)
        if (rs->a->empty[i] == index)
            ret = write_empty(rs, probe, f, index);
    return ret;
}

static void summary(const probe_args *a, sp_probe *p, double secs)
{
    sp_probe_plane pl;
    sp_probe_shadow sh;
    sp_probe_stats st;
    sp_probe_get_plane(p, &pl);
    sp_probe_get_shadow(p, &sh);
    sp_probe_get_stats(p, &st);
    printf("%s: %s\n", a->out, sp_probe_message(p));
    printf("  %.1f s (%.1f frames/s), %.1f MB of state; %.1f%% of pixels covered, %.2f%% occluding\n", secs,
           secs > 0 ? (double)st.frames / secs : 0.0, (double)st.memory_bytes / 1e6, 100 * st.covered_fraction,
           100 * st.occluder_fraction);
    if (pl.status == SP_PROBE_PLANE_OK)
        printf("  plane: h = %.5f x + %.5f y + %.3f; %s\n", pl.a, pl.b, pl.c, pl.note);
    else
        printf("  plane: %s\n", pl.note);
    if (pl.holdout_n)
        printf("  held out: %u observations, median relative height error %.4f\n", pl.holdout_n,
               pl.holdout_error_rel);
    printf("  shadow: %s\n", sh.note);
    printf("  contact shadow: %s%s\n", sh.contact_note,
           sh.present && sh.contact_present ? " (unused: the sun model holds it)" : "");
    if (a->s.detector == SP_PROBE_DETECT_HOG)
        printf("  HOG: %" PRIu64 " of %" PRIu64 " person-shaped observations confirmed\n", st.hog_confirmed,
               st.hog_checked);
}

static int run(probe_args *a, const capture_facts *facts, const char *dir)
{
    run_state rs = { .a = a, .dir = dir };
    sp_probe_stage_settings ps = { .probe = a->s, .width = facts->width, .height = facts->height,
                                   .on_frame = on_frame, .user = &rs };
    sp_stage stage = { 0 };
    int ret = sp_stage_open(&stage, &sp_stage_probe, &ps);
    if (ret)
        return sp_cmd_fail("probe", ret, "opening the probe");
    sp_probe *probe = sp_probe_stage_probe(&stage);
    rs.rgb = malloc((size_t)facts->width * facts->height * 3);
    sp_run_settings run;
    sp_run_default_settings(&run);
    run.max_frames = a->max_frames;
    run.stop = &sp_cmd_stop_signal;
    run.progress = a->quiet ? 0 : -1;
    run.progress_label = "probe";
    run.progress_total = a->max_frames && a->max_frames < facts->frames ? a->max_frames : facts->frames;
    sp_run_stats st = { 0 };
    int64_t t0 = sp_clock_monotonic_ns();
    char *objects = a->objects ? sp_path_join_alloc(dir, "objects.csv") : NULL;
    if (a->objects && (!objects || !(rs.objects = fopen(objects, "w")))) {
        int err = objects ? -errno : -ENOMEM;
        free(objects), free(rs.rgb);
        sp_stage_close(&stage);
        return sp_cmd_fail("probe", err, "creating objects.csv in the probe directory");
    }
    free(objects);
    if (rs.objects)
        fputs("frame,t_ns,class,x0,y0,x1,y1,foot_x,foot_y,height,area,touches_border\n", rs.objects);
    ret = rs.rgb ? sp_stage_run(a->capture, &stage, &run, &st) : -ENOMEM;
    if (rs.objects && fclose(rs.objects) && !rs.objects_err)
        rs.objects_err = sp_write_error();
    int code = SP_EXIT_OK;
    if (sp_cmd_stop_signal) { /* a read cut short by the signal is no capture error */
        fprintf(stderr, "sunprobe probe: interrupted after %" PRIu64 " frames; nothing written\n", st.frames);
        code = sp_exit_for_error(-ECANCELED);
    } else if (rs.objects_err) {
        code = sp_cmd_fail("probe", rs.objects_err, "writing objects.csv in the probe directory");
    } else if (ret == SP_ENODATA) {
        fprintf(stderr, "sunprobe probe: %s: %s\n", a->capture, sp_probe_message(probe));
        code = SP_EXIT_BAD_INPUT;
    } else if (sp_err_is_write(ret)) {
        /* only a write fails so (the convergence report, as frames stream): the output's fault, not the capture's */
        code = sp_cmd_failf("probe", ret, "writing the probe directory %s", a->out);
    } else if (ret) {
        code = sp_tool_capture_error("probe", a->capture, ret, st.replay.error_offset);
    } else if ((ret = sp_probe_dir_write(dir, probe))) {
        code = sp_cmd_failf("probe", ret, "writing the probe directory %s", a->out);
    } else if (!a->quiet) {
        summary(a, probe, (double)(sp_clock_monotonic_ns() - t0) * 1e-9);
    }
    free(rs.rgb);
    sp_stage_close(&stage);
    return code;
}

int sp_cmd_probe(int argc, char **argv)
{
    probe_args a = { 0 };
    sp_probe_default_settings(&a.s);
    int code = parse_args(argc, argv, &a);
    if (code)
        return code < 0 ? SP_EXIT_OK : code;
    capture_facts facts = { 0 };
    if ((code = first_pass(a.capture, &facts)))
        return code;
    if (!facts.frames) {
        fprintf(stderr, "sunprobe probe: %s: no frames\n", a.capture);
        return SP_EXIT_BAD_INPUT;
    }
    if (facts.width < 16 || facts.height < 16 || facts.width > 16384 || facts.height > 16384) {
        fprintf(stderr, "sunprobe probe: %s: frames are %ux%u; the probe takes 16..16384 pixels a side\n", a.capture,
                facts.width, facts.height);
        return SP_EXIT_BAD_INPUT;
    }
    if (facts.resized_at) {
        fprintf(stderr, "sunprobe probe: %s: frame %" PRIu64 " is %ux%u, the first was %ux%u: a probe needs one static "
                        "camera size throughout\n", a.capture, facts.resized_at, facts.resized_w, facts.resized_h,
                facts.width, facts.height);
        return SP_EXIT_BAD_INPUT;
    }
    if (facts.backwards_at) {
        fprintf(stderr, "sunprobe probe: %s: frame %" PRIu64 "'s timestamp is before the previous frame's: times must "
                        "not go backwards\n", a.capture, facts.backwards_at);
        return SP_EXIT_BAD_INPUT;
    }
    if (a.holdout_half)
        a.s.holdout_from = (int64_t)(facts.frames / 2);
    if ((code = check_output(&a)))
        return code;
    /* from here on Ctrl-C ends the frame loop and the normal abort path removes the partial directory */
    sp_cmd_signals sig;
    sp_cmd_catch_signals(&sig);
    sp_partial partial;
    int ret = sp_partial_dir_open(&partial, a.out);
    if (ret) {
        sp_cmd_restore_signals(&sig);
        return sp_cmd_fail("probe", ret, a.out);
    }
    char *report = sp_path_join_alloc(partial.path, "convergence");
    a.s.report_prefix = report;
    size_t n_truth = 0;
    sp_probe_truth_sample *truth = load_truth(a.capture, facts.ground_truth, &n_truth);
    a.s.truth = truth, a.s.n_truth = n_truth;
    code = report ? run(&a, &facts, partial.path) : sp_cmd_fail("probe", -ENOMEM, "report path");
    free(truth);
    free(report);
    if (code == SP_EXIT_OK) /* a signal after the last frame: the final directory is left as it was */
        code = sp_cmd_stopped_code(code);
    ret = code == SP_EXIT_OK ? sp_partial_dir_commit(&partial, a.force ? SP_PARTIAL_REPLACE : 0) : 0;
    if (ret)
        code = sp_cmd_fail("probe", ret, a.out);
    sp_partial_dir_abort(&partial); /* after a commit there is nothing left to remove */
    sp_cmd_restore_signals(&sig);
    return code;
}
