/* SPDX-License-Identifier: MIT */
/* `sunprobe export-video`: capture frames to numbered PNG files or to an .avi (MJPG) / .mp4 (mp4v) file. */
#include <errno.h>
#include <fcntl.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "capture/opencv_shim.h"
#include "capture_open.h"
#include "cmd.h"
#include "common/pixconv.h"
#include "common/progress.h"
#include "export/png.h"
#include "sp_config.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_meta.h"

#define CMD "export-video"

typedef struct export_opts {
    const char *capture, *out;
    uint64_t every, max_frames;
    double scale, fps;
    uint32_t stream;
    int force, quiet;
} export_opts;

typedef struct exporter {
    const export_opts *o;
    int video;                 /* 1: one video file, 0: a directory of PNGs */
    char *video_tmp;           /* the video is written here, renamed at the end */
    sp_cv_video_writer *writer;
    sp_capture_meta meta;
    uint8_t *rgb, *scaled;
    size_t rgb_cap, scaled_cap;
    uint32_t out_w, out_h, src_w, src_h;
    uint32_t *x0, *x1;         /* source column range of each output column */
    uint64_t seen, written;    /* frames of the stream seen, exported */
    int made_dir;              /* PNG output: this run created the directory */
    uint64_t *done;            /* PNG output: the frame indices this run wrote, removed again if it fails */
    size_t n_done, cap_done;
} exporter;

static void usage(FILE *out)
{
    fprintf(out, "usage: sunprobe export-video CAPTURE -o OUT [options]\n\n"
                 "OUT ending in .avi (MJPG) or .mp4 (mp4v) is one video file (needs OpenCV); anything else is\n"
                 "a directory (created if needed) of frame_NNNNNN.png, numbered by frame index in the stream.\n\n"
                 "options:\n"
                 "  -o, --output OUT     video file or PNG directory\n"
                 "      --every N        keep every Nth frame (default 1)\n"
                 "      --max-frames N   stop after writing N frames\n"
                 "      --scale S        resize by S in (0, 8] (area average when shrinking; default 1)\n"
                 "      --fps F          video frame rate (default: camera.fps of the capture / N, else 30)\n"
                 "      --stream ID      camera stream to export (default 0)\n"
                 "  -f, --force          replace an existing video file\n"
                 "  -q, --quiet          no progress bar or summary\n"
                 "  -h, --help           this text\n");
}

static int has_ext(const char *name, const char *ext)
{
    size_t n = strlen(name), e = strlen(ext);
    return n > e && strcasecmp(name + n - e, ext) == 0;
}

enum { OPT_EVERY = 256, OPT_MAX, OPT_SCALE, OPT_FPS, OPT_STREAM };

static int parse_args(int argc, char **argv, export_opts *o)
{
    static const struct option opts[] = {
        { "output", required_argument, NULL, 'o' }, { "every", required_argument, NULL, OPT_EVERY },
        { "max-frames", required_argument, NULL, OPT_MAX }, { "scale", required_argument, NULL, OPT_SCALE },
        { "fps", required_argument, NULL, OPT_FPS }, { "stream", required_argument, NULL, OPT_STREAM },
        { "force", no_argument, NULL, 'f' },        { "quiet", no_argument, NULL, 'q' },
        { "help", no_argument, NULL, 'h' },         { 0 },
    };
    optind = 0;
    int c, bad = 0;
    uint64_t v = 0;
    while (!bad && (c = getopt_long(argc, argv, "o:fqh", opts, NULL)) != -1) {
        switch (c) {
        case 'o': o->out = optarg; break;
        case OPT_EVERY: bad = sp_opt_u64(CMD, "every", optarg, 1, 1000000000, &o->every); break;
        case OPT_MAX: bad = sp_opt_u64(CMD, "max-frames", optarg, 1, UINT64_MAX, &o->max_frames); break;
        case OPT_SCALE: bad = sp_opt_double(CMD, "scale", optarg, 1e-6, 8, &o->scale); break;
        case OPT_FPS: bad = sp_opt_double(CMD, "fps", optarg, 1e-3, 1e4, &o->fps); break;
        case OPT_STREAM:
            bad = sp_opt_u64(CMD, "stream", optarg, 0, 65535, &v);
            o->stream = (uint32_t)v;
            break;
        case 'f': o->force = 1; break;
        case 'q': o->quiet = 1; break;
        case 'h': usage(stdout); return SP_EXIT_OK;
        default: usage(stderr); return SP_EXIT_USAGE;
        }
    }
    if (bad) {
        fprintf(stderr, "sunprobe " CMD ": see --help\n");
        return SP_EXIT_USAGE;
    }
    if (optind != argc - 1 || !o->out) {
        fprintf(stderr, "sunprobe " CMD ": %s\n", optind != argc - 1 ? "expected one CAPTURE" : "-o OUT is required");
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    o->capture = argv[optind];
    return -1;
}

static int grow(uint8_t **buf, size_t *cap, size_t need)
{
    if (need <= *cap)
        return 0;
    uint8_t *p = realloc(*buf, need);
    if (!p)
        return -ENOMEM;
    *buf = p;
    *cap = need;
    return 0;
}

/* Output size and the column ranges of the area-average resampler, once per source size. */
static int plan_scale(exporter *e, uint32_t w, uint32_t h)
{
    double s = e->o->scale;
    uint32_t ow = (uint32_t)fmax(1.0, floor(w * s + 0.5)), oh = (uint32_t)fmax(1.0, floor(h * s + 0.5));
    if (e->video && has_ext(e->o->out, ".mp4")) { /* MPEG-4 part 2 wants even sizes */
        ow = ow > 2 ? ow & ~1u : 2;
        oh = oh > 2 ? oh & ~1u : 2;
    }
    free(e->x0);
    free(e->x1);
    e->x0 = malloc(ow * sizeof(uint32_t));
    e->x1 = malloc(ow * sizeof(uint32_t));
    if (!e->x0 || !e->x1)
        return -ENOMEM;
    for (uint32_t x = 0; x < ow; x++) {
        e->x0[x] = (uint32_t)((uint64_t)x * w / ow);
        uint32_t end = (uint32_t)(((uint64_t)(x + 1) * w + ow - 1) / ow);
        e->x1[x] = end > e->x0[x] ? end : e->x0[x] + 1;
    }
    e->src_w = w;
    e->src_h = h;
    e->out_w = ow;
    e->out_h = oh;
    return grow(&e->scaled, &e->scaled_cap, (size_t)ow * oh * 3);
}

/* Each output pixel is the mean of the source pixels its footprint covers (one pixel when enlarging). */
static void resample(const exporter *e, const uint8_t *src, uint8_t *dst)
{
    uint32_t w = e->src_w, h = e->src_h, ow = e->out_w, oh = e->out_h;
    for (uint32_t oy = 0; oy < oh; oy++) {
        uint32_t y0 = (uint32_t)((uint64_t)oy * h / oh);
        uint32_t y1 = (uint32_t)(((uint64_t)(oy + 1) * h + oh - 1) / oh);
        if (y1 <= y0)
            y1 = y0 + 1;
        for (uint32_t ox = 0; ox < ow; ox++) {
            uint64_t sum[3] = { 0, 0, 0 };
            for (uint32_t y = y0; y < y1; y++)
                for (uint32_t x = e->x0[ox]; x < e->x1[ox]; x++)
                    for (int c = 0; c < 3; c++)
                        sum[c] += src[((size_t)y * w + x) * 3 + c];
            uint64_t n = (uint64_t)(y1 - y0) * (e->x1[ox] - e->x0[ox]);
            for (int c = 0; c < 3; c++)
                dst[((size_t)oy * ow + ox) * 3 + c] = (uint8_t)((sum[c] + n / 2) / n);
        }
    }
}

#if HAVE_OPENCV
static double video_fps(const exporter *e)
{
    if (e->o->fps > 0)
        return e->o->fps;
    double fps = isfinite(e->meta.fps) && e->meta.fps > 0 ? e->meta.fps : 30.0;
    fps /= (double)e->o->every;
    return fps >= 1e-3 ? fps : 1e-3;
}

static int open_video(exporter *e)
{
    /* OpenCV reports no errno: create the file first, so a read-only or full file system is named as such */
    int fd = open(e->video_tmp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
    if (fd < 0 || close(fd) != 0) {
        int rc = -errno;
        fprintf(stderr, "sunprobe " CMD ": %s: cannot create the video: %s\n", e->o->out, sp_strerror(rc));
        return rc;
    }
    int rc = sp_cv_video_writer_open(&e->writer, e->video_tmp, e->out_w, e->out_h, video_fps(e));
    if (rc)
        fprintf(stderr, "sunprobe " CMD ": %s: OpenCV cannot create this video: %s\n", e->o->out, sp_strerror(rc));
    return rc;
}
#else
static int open_video(exporter *e)
{
    fprintf(stderr, "sunprobe " CMD ": %s: writing video needs OpenCV; rebuild with -Dopencv=enabled, or export "
                    "PNG frames to a directory\n", e->o->out);
    return SP_EDISABLED;
}
#endif

static int write_frame(exporter *e, const uint8_t *rgb)
{
    if (e->video) {
#if HAVE_OPENCV
        int rc = e->writer ? 0 : open_video(e);
        if (!rc)
            rc = sp_cv_video_write(e->writer, rgb, e->out_w * 3);
        return rc;
#else
        return open_video(e);
#endif
    }
    char path[4096];
    snprintf(path, sizeof(path), "%s/frame_%06llu.png", e->o->out, (unsigned long long)e->seen);
    if (e->n_done == e->cap_done) {
        size_t cap = e->cap_done ? 2 * e->cap_done : 256;
        uint64_t *d = realloc(e->done, cap * sizeof(*d));
        if (!d)
            return -ENOMEM;
        e->done = d, e->cap_done = cap;
    }
    int rc = sp_png_write(path, rgb, e->out_w, e->out_h, e->out_w * 3, 3);
    if (rc)
        fprintf(stderr, "sunprobe " CMD ": %s: %s\n", path, sp_strerror(rc));
    else
        e->done[e->n_done++] = e->seen;
    return rc;
}

/* Removes the PNGs this run wrote, then the directory if this run made it (and it is empty). */
static void discard_frames(exporter *e)
{
    char path[4096];
    for (size_t i = 0; i < e->n_done; i++) {
        snprintf(path, sizeof(path), "%s/frame_%06llu.png", e->o->out, (unsigned long long)e->done[i]);
        if (unlink(path) != 0 && errno != ENOENT)
            fprintf(stderr, "sunprobe " CMD ": could not remove %s: %s\n", path, strerror(errno));
    }
    if (e->made_dir && rmdir(e->o->out) != 0)
        fprintf(stderr, "sunprobe " CMD ": could not remove %s: %s\n", e->o->out, strerror(errno));
}

static int export_frame(exporter *e, const sp_chunk *ch)
{
    sp_frame_chunk fc;
    int rc = sp_chunk_parse_frame(ch, &fc);
    if (rc) {
        fprintf(stderr, "sunprobe " CMD ": %s: bad frame chunk at byte %llu: %s\n", e->o->capture,
                (unsigned long long)ch->offset, sp_strerror(rc));
        return rc;
    }
    if (fc.stream_id != e->o->stream)
        return 0;
    uint64_t index = e->seen;
    if (index % e->o->every != 0) {
        e->seen++;
        return 0;
    }
    if (e->video && e->writer && (fc.width != e->src_w || fc.height != e->src_h)) {
        fprintf(stderr, "sunprobe " CMD ": %s: frame %llu is %ux%u, but the video was started at %ux%u\n",
                e->o->capture, (unsigned long long)index, fc.width, fc.height, e->src_w, e->src_h);
        return SP_EUNSUPPORTED;
    }
    if (fc.width != e->src_w || fc.height != e->src_h)
        rc = plan_scale(e, fc.width, fc.height);
    if (!rc)
        rc = grow(&e->rgb, &e->rgb_cap, (size_t)fc.width * fc.height * 3);
    sp_pixconv_src src = { fc.format, fc.width, fc.height, fc.stride, fc.data, fc.data_size };
    if (!rc)
        rc = sp_pixconv_to_rgb24(&src, e->rgb, e->rgb_cap, fc.width * 3);
    if (rc) {
        fprintf(stderr, "sunprobe " CMD ": %s: frame %llu (%s) at byte %llu: %s%s\n", e->o->capture,
                (unsigned long long)index, sp_pixfmt_name(fc.format), (unsigned long long)ch->offset,
                sp_strerror(rc), rc == SP_EDISABLED ? " (rebuild with -Djpeg=enabled)" : "");
        return rc;
    }
    const uint8_t *out = e->rgb;
    if (e->out_w != fc.width || e->out_h != fc.height) {
        resample(e, e->rgb, e->scaled);
        out = e->scaled;
    }
    rc = write_frame(e, out);
    e->seen++;
    e->written += rc == 0;
    return rc;
}

static int prepare_output(exporter *e)
{
    const char *out = e->o->out;
    e->video = has_ext(out, ".avi") || has_ext(out, ".mp4");
    if (!e->video) {
        if (mkdir(out, 0777) == 0)
            e->made_dir = 1;
        else if (errno != EEXIST)
            return -errno;
        struct stat st;
        return stat(out, &st) == 0 && S_ISDIR(st.st_mode) ? 0 : -ENOTDIR;
    }
#if !HAVE_OPENCV
    return open_video(e);
#else
    if (!e->o->force && access(out, F_OK) == 0)
        return -EEXIST;
    /* "clip.avi" is written as "clip.partial.avi": OpenCV picks the container from the extension */
    size_t n = strlen(out), ext = 4;
    e->video_tmp = malloc(n + sizeof(".partial"));
    if (!e->video_tmp)
        return -ENOMEM;
    snprintf(e->video_tmp, n + sizeof(".partial"), "%.*s.partial%s", (int)(n - ext), out, out + n - ext);
    return 0;
#endif
}

#if HAVE_OPENCV
/* Why writing to path fails: appends up to 1 MiB to it (it is discarded anyway); -EIO if that works. */
static int write_error(const char *path)
{
    static const char block[65536];
    int fd = open(path, O_WRONLY | O_APPEND | O_CLOEXEC);
    if (fd < 0)
        return -errno;
    int err = -EIO;
    for (int i = 0; i < 16 && err == -EIO; i++)
        if (write(fd, block, sizeof(block)) < 0)
            err = -errno;
    if (err == -EIO && fsync(fd) != 0)
        err = -errno;
    close(fd);
    return err;
}

/*
 * OpenCV's writer drops write errors: on a full disk it leaves a truncated
 * file and reports nothing. So the finished file is read back, and it must
 * hold every frame written.
 */
static int check_video(const exporter *e)
{
    sp_cv_video_reader *r = NULL;
    sp_cv_video_info info = { 0 };
    uint64_t frames = 0;
    uint8_t *buf = NULL;
    int rc = sp_cv_video_open(&r, e->video_tmp, &info);
    size_t size = (size_t)info.width * info.height * 3;
    if (!rc && !(buf = malloc(size ? size : 1)))
        rc = -ENOMEM;
    while (!rc && (rc = sp_cv_video_read(r, buf, size, info.width * 3)) == 0)
        frames++;
    sp_cv_video_close(&r);
    free(buf);
    if (rc == -ENOMEM)
        return rc;
    return (rc == SP_EOS || rc == 0) && frames == e->written ? 0 : write_error(e->video_tmp);
}

static int sync_file(const char *path)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return -errno;
    int err = fsync(fd) != 0 ? -errno : 0;
    close(fd);
    return err;
}
#endif

static int finish_video(exporter *e, int rc)
{
#if HAVE_OPENCV
    if (e->writer) {
        int crc = sp_cv_video_writer_close(&e->writer);
        rc = rc ? rc : crc;
    }
    if (!rc && e->video_tmp)
        rc = check_video(e);
    if (!rc && e->video_tmp)
        rc = sync_file(e->video_tmp);
#endif
    if (!e->video_tmp)
        return rc;
    if (!rc && rename(e->video_tmp, e->o->out) != 0)
        rc = -errno;
    if (rc)
        unlink(e->video_tmp);
    return rc;
}

/* Reads the capture in file order, exporting frames as they come. */
static int run(exporter *e, sp_capture_reader *r, sp_progress *bar)
{
    sp_chunk ch;
    int rc;
    while ((rc = sp_capture_reader_next(r, &ch)) == 0) {
        if (ch.type == SP_CHUNK_META && sp_capture_meta_merge(&e->meta, (const char *)ch.payload, ch.payload_size))
            fprintf(stderr, "sunprobe " CMD ": %s: ignoring a bad META chunk at byte %llu\n", e->o->capture,
                    (unsigned long long)ch.offset);
        if (ch.type == SP_CHUNK_FRAME && (rc = export_frame(e, &ch)) != 0)
            return sp_exit_for_error(rc);
        sp_progress_update(bar, ch.offset, NULL);
        if (sp_cmd_stop_signal) {
            fprintf(stderr, "sunprobe " CMD ": interrupted after %llu frames; nothing written\n",
                    (unsigned long long)e->written);
            return sp_exit_for_error(-ECANCELED);
        }
        if (e->o->max_frames && e->written >= e->o->max_frames)
            return SP_EXIT_OK;
    }
    if (rc != SP_EOS)
        return sp_tool_capture_error(CMD, e->o->capture, rc, ch.offset);
    return SP_EXIT_OK;
}

int sp_cmd_export_video(int argc, char **argv)
{
    export_opts o = { .every = 1, .scale = 1.0 };
    int code = parse_args(argc, argv, &o);
    if (code >= 0)
        return code;
    exporter e = { .o = &o };
    sp_capture_meta_init(&e.meta);
    sp_capture_reader *r = NULL;
    code = sp_tool_open_capture(CMD, o.capture, 0, &r);
    if (code)
        return code;
    /* Ctrl-C ends the loop, and the failure path below removes what this run wrote; caught before the
       output directory or the video's temporary exists, so a signal cannot leave either behind */
    sp_cmd_signals sig;
    sp_cmd_catch_signals(&sig);
    int rc = prepare_output(&e);
    if (rc) {
        sp_cmd_restore_signals(&sig);
        if (rc != SP_EDISABLED)
            fprintf(stderr, "sunprobe " CMD ": %s: %s%s\n", o.out, sp_strerror(rc),
                    rc == -EEXIST ? " (use --force to replace it)" : "");
        sp_capture_reader_close(&r);
        free(e.video_tmp);
        return sp_exit_for_error(rc);
    }
    sp_progress bar;
    sp_progress_start(&bar, CMD, sp_capture_reader_info(r)->file_size, o.quiet ? 0 : -1);
    code = run(&e, r, &bar);
    sp_progress_finish(&bar);
    if (code == SP_EXIT_OK && e.written == 0) {
        fprintf(stderr, "sunprobe " CMD ": %s: no frames in stream %u\n", o.capture, o.stream);
        code = sp_exit_for_error(SP_ENODATA);
    }
    if (code == SP_EXIT_OK && sp_cmd_stop_signal) /* a signal after the last frame: nothing is put in place */
        code = sp_cmd_fail(CMD, -ECANCELED, o.out);
    rc = finish_video(&e, code == SP_EXIT_OK ? 0 : -EIO);
    if (rc && code == SP_EXIT_OK) {
        fprintf(stderr, "sunprobe " CMD ": %s: writing the video: %s\n", o.out, sp_strerror(rc));
        code = sp_exit_for_error(rc);
    }
    if (code != SP_EXIT_OK && !e.video) /* a failed export leaves no frames of its own, nor the directory it made */
        discard_frames(&e);
    sp_cmd_restore_signals(&sig);
    if (code == SP_EXIT_OK && !o.quiet)
        printf("%s: %llu frames %ux%u\n", o.out, (unsigned long long)e.written, e.out_w, e.out_h);
    sp_capture_reader_close(&r);
    free(e.video_tmp);
    free(e.rgb);
    free(e.scaled);
    free(e.x0);
    free(e.x1);
    free(e.done);
    return code;
}
