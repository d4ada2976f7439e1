/* SPDX-License-Identifier: MIT */
/*
 * V4L2 camera backend: plain ioctls on /dev/videoN. Enumerates capture nodes,
 * their formats, sizes and rates; negotiates a format; streams through a small
 * ring of mmap buffers. Each dequeued buffer is copied into a pooled sp_frame and
 * handed straight back to the driver, so a slow consumer costs pooled frames
 * (counted drops), never the device's ring. Single- and multi-planar nodes alike
 * (most ARM ISPs are multi-planar); the 4:2:0 layouts other than one-plane NV12
 * (NV21, YUV420, the two- and three-buffer "M" formats) are repacked into NV12
 * while copying.
 */
#include "device/backends.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <linux/videodev2.h>

#include "common/clock.h"
#include "device/v4l2/v4l2_formats.h"
#include "device/node_scan.h"

#define MAX_BUFFERS 32
#define MAX_NODES 64

typedef struct v4l2_ctx {
    int fd;
    char path[64];
    uint32_t buf_type; /* V4L2_BUF_TYPE_VIDEO_CAPTURE or its _MPLANE twin */
    struct {
        struct {
            void *start;
            size_t length;
        } mem[VIDEO_MAX_PLANES];
    } bufs[MAX_BUFFERS];
    unsigned n_bufs, n_mem;          /* buffers, and memory planes in each */
    uint32_t mem_stride[VIDEO_MAX_PLANES]; /* the driver's bytesperline of each memory plane */
    const sp_v4l2_layout *layout;    /* what the device delivers */
    int repack;                      /* the layout is turned into NV12 while copying */
    sp_frame_pool *pool;
    enum sp_pixfmt format;
    uint32_t width, height, stride, sizeimage;
    int has_exposure, gain_cid; /* controls read per frame (0 = absent) */
    int warned_clock;
    int streaming;
    int lock_pending;        /* lock exposure once the settle time has passed (in start) */
    double lock_settle_s;
    sp_camera_info *info;    /* the wrapper's, valid until close: start reports the lock there */
    uint64_t seq_high, last_seq, frames, dropped;
    uint32_t prev_seq32;
} v4l2_ctx;

static int xioctl(int fd, unsigned long req, void *arg)
{
    int r;
    do
        r = ioctl(fd, req, arg);
    while (r < 0 && errno == EINTR);
    return r < 0 ? -errno : 0;
}

static uint32_t caps_of(const struct v4l2_capability *cap)
{
    return (cap->capabilities & V4L2_CAP_DEVICE_CAPS) ? cap->device_caps : cap->capabilities;
}

static int is_capture_node(int fd, struct v4l2_capability *cap)
{
    memset(cap, 0, sizeof(*cap));
    if (xioctl(fd, VIDIOC_QUERYCAP, cap) < 0)
        return 0;
    uint32_t c = caps_of(cap);
    return (c & (V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_VIDEO_CAPTURE_MPLANE)) && (c & V4L2_CAP_STREAMING);
}

static int is_mplane(uint32_t buf_type)
{
    return buf_type == V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE;
}

/* The buffer type to talk to a capture node with: single-planar when it offers both. */
static uint32_t buf_type_of(const struct v4l2_capability *cap)
{
    return (caps_of(cap) & V4L2_CAP_VIDEO_CAPTURE) ? V4L2_BUF_TYPE_VIDEO_CAPTURE
                                                   : V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE;
}

/* Numbers N of /dev/videoN, sorted. */
static size_t list_nodes(int *nodes, size_t max)
{
    return sp_scan_numbered_entries("/dev", "video", nodes, max);
}

static void fill_desc(sp_camera_desc *d, const char *path, const struct v4l2_capability *cap)
{
    memset(d, 0, sizeof(*d));
    sp_dev_copy_string(d->backend, sizeof(d->backend), "v4l2");
    sp_dev_copy_string(d->id, sizeof(d->id), path);
    sp_dev_copy_string(d->name, sizeof(d->name), (const char *)cap->card);
    sp_dev_copy_string(d->driver, sizeof(d->driver), (const char *)cap->driver);
}

static int v4l2_enumerate(sp_camera_desc *out, size_t max, size_t *count)
{
    int nodes[MAX_NODES];
    size_t n_nodes = list_nodes(nodes, MAX_NODES), n = 0;
    for (size_t i = 0; i < n_nodes; i++) {
        char path[64];
        snprintf(path, sizeof(path), "/dev/video%d", nodes[i]);
        int fd = open(path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
        if (fd < 0)
            continue;
        struct v4l2_capability cap;
        if (is_capture_node(fd, &cap)) {
            if (n < max)
                fill_desc(&out[n], path, &cap);
            n++;
        }
        close(fd);
    }
    *count = n;
    return 0;
}

/* Fastest rate the driver lists for a format and size, 0 when it lists none. */
static double max_fps_of(int fd, uint32_t fourcc, uint32_t w, uint32_t h)
{
    double best = 0;
    struct v4l2_frmivalenum iv = { .pixel_format = fourcc, .width = w, .height = h };
    for (iv.index = 0; xioctl(fd, VIDIOC_ENUM_FRAMEINTERVALS, &iv) == 0; iv.index++) {
        const struct v4l2_fract *f = iv.type == V4L2_FRMIVAL_TYPE_DISCRETE ? &iv.discrete : &iv.stepwise.min;
        if (f->numerator > 0 && f->denominator > 0)
            best = fmax(best, (double)f->denominator / f->numerator);
        if (iv.type != V4L2_FRMIVAL_TYPE_DISCRETE)
            break;
    }
    return best;
}

static void add_mode(int fd, uint32_t fourcc, enum sp_pixfmt fmt, uint32_t w, uint32_t h, sp_camera_mode *out,
                     size_t max, size_t *n)
{
    for (size_t i = 0; i < *n && i < max; i++) /* several layouts of one format (NV12, NV21M, ...) list once */
        if (out[i].format == fmt && out[i].width == w && out[i].height == h)
            return;
    if (*n < max)
        out[*n] = (sp_camera_mode){ fmt, w, h, max_fps_of(fd, fourcc, w, h) };
    (*n)++;
}

static void sizes_of(int fd, uint32_t fourcc, enum sp_pixfmt fmt, sp_camera_mode *out, size_t max, size_t *n)
{
    struct v4l2_frmsizeenum fs = { .pixel_format = fourcc };
    for (fs.index = 0; xioctl(fd, VIDIOC_ENUM_FRAMESIZES, &fs) == 0; fs.index++) {
        if (fs.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
            add_mode(fd, fourcc, fmt, fs.discrete.width, fs.discrete.height, out, max, n);
            continue;
        }
        /* stepwise or continuous: the two ends say what the range is */
        add_mode(fd, fourcc, fmt, fs.stepwise.min_width, fs.stepwise.min_height, out, max, n);
        add_mode(fd, fourcc, fmt, fs.stepwise.max_width, fs.stepwise.max_height, out, max, n);
        break;
    }
}

static int v4l2_modes(const char *id, sp_camera_mode *out, size_t max, size_t *count)
{
    int fd = open(id, O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return -errno;
    struct v4l2_capability cap;
    if (!is_capture_node(fd, &cap)) {
        close(fd);
        return -ENODEV;
    }
    size_t n = 0;
    struct v4l2_fmtdesc fd_desc = { .type = buf_type_of(&cap) };
    for (fd_desc.index = 0; xioctl(fd, VIDIOC_ENUM_FMT, &fd_desc) == 0; fd_desc.index++) {
        enum sp_pixfmt fmt = sp_v4l2_to_pixfmt(fd_desc.pixelformat);
        if (fmt != SP_PIXFMT_NONE)
            sizes_of(fd, fd_desc.pixelformat, fmt, out, max, &n);
    }
    close(fd);
    *count = n;
    return 0;
}

static int v4l2_claims(const char *device)
{
    if (device && !strncmp(device, "/dev/", 5))
        return 1;
    sp_camera_desc d[16];
    size_t n = 0;
    v4l2_enumerate(d, 16, &n);
    if (!device)
        return n > 0; /* the first camera is a V4L2 one when any exists */
    for (size_t i = 0; i < n && i < 16; i++)
        if (!strcmp(d[i].name, device))
            return 1;
    return 0;
}

/*
 * Maps the device string (path, card name, NULL = first) to a node path. A path may carry
 * ":fourcc=XXXX" (as v4l2-ctl --list-formats prints it) to pick the device's layout of a format,
 * e.g. "/dev/video0:fourcc=NM21"; *fourcc is 0 when it does not.
 */
static int resolve_path(const char *device, char *path, size_t size, uint32_t *fourcc)
{
    *fourcc = 0;
    if (device && !strncmp(device, "/dev/", 5)) {
        const char *opt = strchr(device, ':');
        size_t len = opt ? (size_t)(opt - device) : strlen(device);
        if (len >= size)
            return -ENAMETOOLONG;
        memcpy(path, device, len);
        path[len] = '\0';
        if (!opt)
            return 0;
        if (strncmp(opt, ":fourcc=", 8) || !(*fourcc = sp_v4l2_fourcc_from_string(opt + 8))) {
            sp_log(SP_LOG_ERROR, "v4l2", "'%s': the only option after the node is ':fourcc=XXXX' (1-4 characters)",
                   device);
            return -EINVAL;
        }
        if (!sp_v4l2_layout_of(*fourcc)) {
            sp_log(SP_LOG_ERROR, "v4l2", "'%s': sunprobe cannot store fourcc '%s'", device, opt + 8);
            return -EINVAL;
        }
        return 0;
    }
    sp_camera_desc d[16];
    size_t n = 0;
    v4l2_enumerate(d, 16, &n);
    for (size_t i = 0; i < n && i < 16; i++)
        if (!device || !strcmp(d[i].name, device)) {
            sp_dev_copy_string(path, size, d[i].id);
            return 0;
        }
    return -ENODEV;
}

static int supports_fourcc(int fd, uint32_t buf_type, uint32_t fourcc)
{
    struct v4l2_fmtdesc d = { .type = buf_type };
    for (d.index = 0; xioctl(fd, VIDIOC_ENUM_FMT, &d) == 0; d.index++)
        if (d.pixelformat == fourcc)
            return 1;
    return 0;
}

/* The fourcc to ask for: the one forced through the device string, else the requested format's best
 * layout the device has, else the first of the preference list the device has. */
static int choose_fourcc(v4l2_ctx *c, enum sp_pixfmt want, uint32_t forced, uint32_t *fourcc)
{
    if (forced) {
        const sp_v4l2_layout *l = sp_v4l2_layout_of(forced);
        if (!supports_fourcc(c->fd, c->buf_type, forced) || (want && l->format != want)) {
            sp_log(SP_LOG_ERROR, "v4l2", "%s: fourcc %.4s %s", c->path, (const char *)&forced,
                   want && l->format != want ? "does not carry the requested format" : "is not offered by the device");
            return SP_EUNSUPPORTED;
        }
        *fourcc = forced;
        return 0;
    }
    static const enum sp_pixfmt prefs[] = { SP_PIXFMT_YUYV, SP_PIXFMT_NV12, SP_PIXFMT_MJPEG, SP_PIXFMT_RGB24,
                                            SP_PIXFMT_GRAY8 };
    for (size_t i = 0; i < sizeof(prefs) / sizeof(prefs[0]); i++) {
        if (want != SP_PIXFMT_NONE && prefs[i] != want)
            continue;
        uint32_t cands[16];
        size_t nc = sp_v4l2_from_pixfmt(prefs[i], cands, 16);
        for (size_t k = 0; k < nc; k++)
            if (supports_fourcc(c->fd, c->buf_type, cands[k])) {
                *fourcc = cands[k];
                return 0;
            }
    }
    sp_log(SP_LOG_ERROR, "v4l2", "device offers no %s format", want ? sp_pixfmt_name(want) : "usable");
    return SP_EUNSUPPORTED;
}

/* Sets the format and reads back what the driver chose: fourcc, size and each memory plane's stride. */
static int set_format(v4l2_ctx *c, uint32_t fourcc, uint32_t width, uint32_t height, uint32_t *got)
{
    struct v4l2_format f = { .type = c->buf_type };
    if (is_mplane(c->buf_type)) {
        f.fmt.pix_mp.pixelformat = fourcc;
        f.fmt.pix_mp.width = width;
        f.fmt.pix_mp.height = height;
        f.fmt.pix_mp.field = V4L2_FIELD_NONE;
        f.fmt.pix_mp.num_planes = (uint8_t)sp_v4l2_layout_of(fourcc)->buffers;
    } else {
        f.fmt.pix.pixelformat = fourcc;
        f.fmt.pix.width = width;
        f.fmt.pix.height = height;
        f.fmt.pix.field = V4L2_FIELD_NONE;
    }
    int err = xioctl(c->fd, VIDIOC_S_FMT, &f);
    if (err < 0)
        return err;
    if (!is_mplane(c->buf_type)) {
        *got = f.fmt.pix.pixelformat;
        c->width = f.fmt.pix.width;
        c->height = f.fmt.pix.height;
        c->n_mem = 1;
        c->mem_stride[0] = f.fmt.pix.bytesperline;
        c->sizeimage = f.fmt.pix.sizeimage;
        return 0;
    }
    *got = f.fmt.pix_mp.pixelformat;
    c->width = f.fmt.pix_mp.width;
    c->height = f.fmt.pix_mp.height;
    c->n_mem = f.fmt.pix_mp.num_planes;
    if (c->n_mem == 0 || c->n_mem > VIDEO_MAX_PLANES)
        return SP_EUNSUPPORTED;
    c->sizeimage = 0;
    for (unsigned p = 0; p < c->n_mem; p++) {
        c->mem_stride[p] = f.fmt.pix_mp.plane_fmt[p].bytesperline;
        c->sizeimage += f.fmt.pix_mp.plane_fmt[p].sizeimage;
    }
    return 0;
}

static int negotiate_format(v4l2_ctx *c, const sp_camera_settings *s, uint32_t forced_fourcc)
{
    uint32_t fourcc = 0, got = 0;
    int err = choose_fourcc(c, s->format, forced_fourcc, &fourcc);
    if (err < 0)
        return err;
    if ((err = set_format(c, fourcc, s->width ? s->width : 640, s->height ? s->height : 480, &got)) < 0)
        return err;
    c->layout = sp_v4l2_layout_of(got);
    c->format = c->layout ? c->layout->format : SP_PIXFMT_NONE;
    if (c->format == SP_PIXFMT_NONE || (s->format && c->format != s->format) || c->n_mem != c->layout->buffers ||
        (forced_fourcc && got != forced_fourcc)) {
        sp_log(SP_LOG_ERROR, "v4l2", "driver answered with an unusable format %.4s in %u memory planes",
               (const char *)&got, c->n_mem);
        return SP_EUNSUPPORTED;
    }
    c->repack = c->format == SP_PIXFMT_NV12 && got != V4L2_PIX_FMT_NV12;
    if (c->repack) {
        c->stride = sp_pixfmt_min_stride(SP_PIXFMT_NV12, c->width);
        c->sizeimage = (uint32_t)sp_pixfmt_image_size(SP_PIXFMT_NV12, c->width, c->height, c->stride);
        sp_log(SP_LOG_INFO, "v4l2", "%s: %.4s in %u memory plane%s, repacked into nv12", c->path, (const char *)&got,
               c->n_mem, c->n_mem == 1 ? "" : "s");
    } else {
        c->stride = c->format == SP_PIXFMT_MJPEG ? 0 : c->mem_stride[0];
    }
    if (c->format != SP_PIXFMT_MJPEG) {
        if (c->stride < sp_pixfmt_min_stride(c->format, c->width))
            c->stride = sp_pixfmt_min_stride(c->format, c->width);
        size_t need = sp_pixfmt_image_size(c->format, c->width, c->height, c->stride);
        if (need == 0 || need > UINT32_MAX)
            return SP_EUNSUPPORTED;
        if (c->sizeimage < need)
            c->sizeimage = (uint32_t)need;
    }
    if (c->sizeimage == 0)
        return SP_EUNSUPPORTED;
    if (s->width && (c->width != s->width || c->height != s->height))
        sp_log(SP_LOG_WARN, "v4l2", "asked for %ux%u, the driver gave %ux%u", s->width, s->height, c->width,
               c->height);
    return 0;
}

/* Sets the frame rate when asked and reads back the rate in force (0 when the driver does not say). */
static double negotiate_rate(v4l2_ctx *c, double fps)
{
    struct v4l2_streamparm p = { .type = c->buf_type };
    if (fps > 0) {
        p.parm.capture.timeperframe.numerator = 1000;
        p.parm.capture.timeperframe.denominator = (uint32_t)lround(fps * 1000.0);
        if (xioctl(c->fd, VIDIOC_S_PARM, &p) < 0)
            sp_log(SP_LOG_WARN, "v4l2", "%s: cannot set %.3g fps", c->path, fps);
    }
    memset(&p, 0, sizeof(p));
    p.type = c->buf_type;
    if (xioctl(c->fd, VIDIOC_G_PARM, &p) < 0 || !(p.parm.capture.capability & V4L2_CAP_TIMEPERFRAME))
        return 0;
    const struct v4l2_fract *t = &p.parm.capture.timeperframe;
    return t->numerator && t->denominator ? (double)t->denominator / t->numerator : 0;
}

static int has_control(int fd, uint32_t id)
{
    struct v4l2_queryctrl q = { .id = id };
    return xioctl(fd, VIDIOC_QUERYCTRL, &q) == 0 && !(q.flags & V4L2_CTRL_FLAG_DISABLED);
}

static int set_control(int fd, uint32_t id, int32_t value)
{
    struct v4l2_control ctl = { .id = id, .value = value };
    return xioctl(fd, VIDIOC_S_CTRL, &ctl);
}

/* Switches every automatic exposure, gain and white-balance loop present to manual; 1 when all did. */
static int lock_exposure(v4l2_ctx *c)
{
    static const struct {
        uint32_t id;
        int32_t value;
        const char *what;
    } autos[] = {
        { V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL, "auto exposure" },
        { V4L2_CID_AUTOGAIN, 0, "auto gain" },
        { V4L2_CID_AUTO_WHITE_BALANCE, 0, "auto white balance" },
    };
    int ok = 1;
    for (size_t i = 0; i < sizeof(autos) / sizeof(autos[0]); i++) {
        if (!has_control(c->fd, autos[i].id))
            continue;
        int err = set_control(c->fd, autos[i].id, autos[i].value);
        if (err < 0) {
            sp_log(SP_LOG_WARN, "v4l2", "%s: cannot lock %s: %s", c->path, autos[i].what, sp_strerror(err));
            ok = 0;
        } else {
            sp_log(SP_LOG_INFO, "v4l2", "%s: %s locked", c->path, autos[i].what);
        }
    }
    return ok;
}

/* A buffer description for QUERYBUF/QBUF/DQBUF; multi-planar ones point at `planes`. */
static struct v4l2_buffer buffer_desc(const v4l2_ctx *c, unsigned index, struct v4l2_plane *planes)
{
    struct v4l2_buffer b = { .type = c->buf_type, .memory = V4L2_MEMORY_MMAP, .index = index };
    if (is_mplane(c->buf_type)) {
        memset(planes, 0, sizeof(*planes) * VIDEO_MAX_PLANES);
        b.m.planes = planes;
        b.length = c->n_mem;
    }
    return b;
}

static int setup_buffers(v4l2_ctx *c, unsigned count)
{
    struct v4l2_requestbuffers rb = { .count = count, .type = c->buf_type, .memory = V4L2_MEMORY_MMAP };
    int err = xioctl(c->fd, VIDIOC_REQBUFS, &rb);
    if (err < 0)
        return err;
    if (rb.count < 2 || rb.count > MAX_BUFFERS)
        return -ENOMEM;
    for (unsigned i = 0; i < rb.count; i++) {
        struct v4l2_plane planes[VIDEO_MAX_PLANES];
        struct v4l2_buffer b = buffer_desc(c, i, planes);
        if ((err = xioctl(c->fd, VIDIOC_QUERYBUF, &b)) < 0)
            return err;
        c->n_bufs = i + 1; /* from here close() unmaps what this buffer has mapped */
        for (unsigned p = 0; p < c->n_mem; p++) {
            size_t length = is_mplane(c->buf_type) ? planes[p].length : b.length;
            off_t offset = is_mplane(c->buf_type) ? planes[p].m.mem_offset : b.m.offset;
            void *start = mmap(NULL, length, PROT_READ | PROT_WRITE, MAP_SHARED, c->fd, offset);
            if (start == MAP_FAILED)
                return -errno;
            c->bufs[i].mem[p].start = start;
            c->bufs[i].mem[p].length = length;
        }
    }
    return 0;
}

static void v4l2_close(void *ctx)
{
    v4l2_ctx *c = ctx;
    if (!c)
        return;
    for (unsigned i = 0; i < c->n_bufs; i++)
        for (unsigned p = 0; p < c->n_mem; p++)
            if (c->bufs[i].mem[p].start)
                munmap(c->bufs[i].mem[p].start, c->bufs[i].mem[p].length);
    if (c->fd >= 0) {
        struct v4l2_requestbuffers rb = { .count = 0, .type = c->buf_type, .memory = V4L2_MEMORY_MMAP };
        (void)xioctl(c->fd, VIDIOC_REQBUFS, &rb);
        close(c->fd);
    }
    sp_frame_pool_close(&c->pool);
    free(c);
}

static void fill_info(v4l2_ctx *c, sp_camera_info *info, double fps, int locked)
{
    struct v4l2_capability cap;
    memset(info, 0, sizeof(*info));
    if (is_capture_node(c->fd, &cap))
        fill_desc(&info->desc, c->path, &cap);
    info->format = c->format;
    info->width = c->width;
    info->height = c->height;
    info->stride = c->stride;
    info->fps = fps;
    info->exposure_locked = locked;
    info->monotonic_timestamps = 1; /* until a buffer says otherwise (then stamped at dequeue) */
}

static int v4l2_open(void **out, const sp_camera_settings *s, sp_camera_info *info)
{
    v4l2_ctx *c = calloc(1, sizeof(*c));
    if (!c)
        return -ENOMEM;
    c->fd = -1;
    struct v4l2_capability cap;
    uint32_t forced_fourcc = 0;
    int err = resolve_path(s->device, c->path, sizeof(c->path), &forced_fourcc);
    if (err == 0) {
        c->fd = open(c->path, O_RDWR | O_NONBLOCK | O_CLOEXEC);
        err = c->fd < 0 ? -errno : 0;
    }
    if (err == 0 && !is_capture_node(c->fd, &cap)) {
        sp_log(SP_LOG_ERROR, "v4l2", "%s is not a streaming video capture device", c->path);
        err = -ENODEV;
    }
    if (err == 0) {
        c->buf_type = buf_type_of(&cap);
        err = negotiate_format(c, s, forced_fourcc);
    }
    double fps = err == 0 ? negotiate_rate(c, s->fps) : 0;
    if (err == 0)
        err = setup_buffers(c, s->buffers);
    if (err == 0)
        err = sp_frame_pool_open(&c->pool, s->pool_frames, c->sizeimage);
    if (err < 0) {
        sp_log(SP_LOG_ERROR, "v4l2", "%s: %s", c->path[0] ? c->path : "(no device)", sp_strerror(err));
        v4l2_close(c);
        return err;
    }
    c->has_exposure = has_control(c->fd, V4L2_CID_EXPOSURE_ABSOLUTE);
    c->gain_cid = has_control(c->fd, V4L2_CID_ANALOGUE_GAIN) ? V4L2_CID_ANALOGUE_GAIN
                  : has_control(c->fd, V4L2_CID_GAIN)         ? V4L2_CID_GAIN
                                                             : 0;
    fill_info(c, info, fps, 0);
    c->info = info;
    c->lock_pending = s->lock_exposure != 0;
    c->lock_settle_s = s->lock_settle_s;
    *out = c;
    return 0;
}

static int queue_buffer(v4l2_ctx *c, unsigned index)
{
    struct v4l2_plane planes[VIDEO_MAX_PLANES];
    struct v4l2_buffer b = buffer_desc(c, index, planes);
    return xioctl(c->fd, VIDIOC_QBUF, &b);
}

/* Streams without delivering until the automatic loops had lock_settle_s to converge, then locks them. */
static int settle_and_lock(v4l2_ctx *c)
{
    int64_t until = sp_clock_monotonic_ns() + (int64_t)(c->lock_settle_s * 1e9);
    while (sp_clock_monotonic_ns() < until) {
        struct pollfd p = { .fd = c->fd, .events = POLLIN };
        if (poll(&p, 1, 100) <= 0)
            continue;
        struct v4l2_plane planes[VIDEO_MAX_PLANES];
        struct v4l2_buffer b = buffer_desc(c, 0, planes);
        int err = xioctl(c->fd, VIDIOC_DQBUF, &b);
        if (err == -ENODEV || err == -EPIPE || err == -ENXIO)
            return -ENODEV;
        if (err == 0 && (err = queue_buffer(c, b.index)) < 0)
            return err;
    }
    c->info->exposure_locked = lock_exposure(c);
    c->lock_pending = 0;
    return 0;
}

static int v4l2_start(void *ctx)
{
    v4l2_ctx *c = ctx;
    for (unsigned i = 0; i < c->n_bufs; i++) {
        int err = queue_buffer(c, i);
        if (err < 0)
            return err;
    }
    int type = (int)c->buf_type;
    int err = xioctl(c->fd, VIDIOC_STREAMON, &type);
    if (err < 0)
        return err;
    c->streaming = 1;
    c->frames = 0;
    return c->lock_pending ? settle_and_lock(c) : 0;
}

static int v4l2_stop(void *ctx)
{
    v4l2_ctx *c = ctx;
    if (!c->streaming)
        return 0;
    c->streaming = 0;
    int type = (int)c->buf_type;
    int err = xioctl(c->fd, VIDIOC_STREAMOFF, &type);
    return err == -ENODEV ? 0 : err; /* a vanished device is stopped already */
}

static float read_control(int fd, uint32_t id, float unit)
{
    struct v4l2_control ctl = { .id = id };
    return xioctl(fd, VIDIOC_G_CTRL, &ctl) == 0 ? (float)ctl.value * unit : NAN;
}

/* The 32-bit driver sequence extended to 64 bits; gaps are frames the driver lost. */
static uint64_t track_sequence(v4l2_ctx *c, uint32_t seq32)
{
    if (c->frames > 0 && seq32 < c->prev_seq32)
        c->seq_high += UINT64_C(1) << 32;
    c->prev_seq32 = seq32;
    uint64_t seq = c->seq_high | seq32;
    if (c->frames > 0 && seq > c->last_seq + 1)
        c->dropped += seq - c->last_seq - 1;
    c->last_seq = seq;
    c->frames++;
    return seq;
}

static int64_t buffer_time(v4l2_ctx *c, const struct v4l2_buffer *b)
{
    if ((b->flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC)
        return (int64_t)b->timestamp.tv_sec * 1000000000 + (int64_t)b->timestamp.tv_usec * 1000;
    if (!c->warned_clock) {
        sp_log(SP_LOG_WARN, "v4l2", "%s: buffers carry no monotonic timestamp; stamping at dequeue", c->path);
        c->warned_clock = 1;
    }
    return sp_clock_monotonic_ns();
}

/*
 * The image bytes of each memory plane of a dequeued buffer: past the plane's data_offset, up to what
 * the driver filled (its whole length when it does not say). 0 when a plane's numbers do not fit it.
 */
static int filled_planes(const v4l2_ctx *c, const struct v4l2_buffer *b, sp_v4l2_plane *mem)
{
    for (unsigned p = 0; p < c->n_mem; p++) {
        size_t length = c->bufs[b->index].mem[p].length, used, offset = 0;
        if (is_mplane(c->buf_type)) {
            used = b->m.planes[p].bytesused ? b->m.planes[p].bytesused : length;
            offset = b->m.planes[p].data_offset; /* counted in bytesused */
        } else {
            used = b->bytesused ? b->bytesused : length;
        }
        if (used > length || offset >= used)
            return 0;
        mem[p] = (sp_v4l2_plane){ (const uint8_t *)c->bufs[b->index].mem[p].start + offset, c->mem_stride[p],
                                  used - offset };
    }
    return 1;
}

/* Repacks a 4:2:0 layout into NV12 at dst; 0 when the buffer is too small for the negotiated size. */
static int repack_into(const v4l2_ctx *c, const sp_v4l2_plane *mem, uint8_t *dst)
{
    sp_v4l2_plane colour[3];
    const sp_v4l2_plane *planes = mem;
    if (c->layout->buffers == 1) {
        if (!sp_v4l2_split_planes(c->layout, mem[0].data, mem[0].size, mem[0].stride, c->height, colour))
            return 0;
        planes = colour;
    }
    return sp_v4l2_to_nv12(c->layout, planes, c->width, c->height, dst, c->stride) == 0;
}

/* Copies a dequeued buffer into a pooled frame; -EAGAIN (counted) when the buffer is unusable or the pool is empty. */
static int copy_out(v4l2_ctx *c, const struct v4l2_buffer *b, sp_frame **out)
{
    uint64_t seq = track_sequence(c, b->sequence);
    sp_v4l2_plane mem[VIDEO_MAX_PLANES];
    size_t need = c->format == SP_PIXFMT_MJPEG ? 1 : sp_pixfmt_image_size(c->format, c->width, c->height, c->stride);
    if ((b->flags & V4L2_BUF_FLAG_ERROR) || !filled_planes(c, b, mem) || (!c->repack && mem[0].size < need)) {
        c->dropped++;
        return -EAGAIN;
    }
    sp_frame *f = NULL;
    if (sp_frame_pool_get(c->pool, &f) < 0) {
        c->dropped++;
        return -EAGAIN;
    }
    size_t n = c->format == SP_PIXFMT_MJPEG ? mem[0].size : need;
    if (n > f->capacity)
        n = f->capacity;
    if (!c->repack) {
        memcpy(f->data, mem[0].data, n);
    } else if (!repack_into(c, mem, f->data)) {
        sp_frame_unref(&f);
        c->dropped++;
        return -EAGAIN;
    }
    f->bytes_used = n;
    f->format = c->format;
    f->width = c->width;
    f->height = c->height;
    f->stride = c->stride;
    f->sequence = seq;
    f->timestamp_ns = buffer_time(c, b);
    /* V4L2_CID_EXPOSURE_ABSOLUTE counts 100 us units */
    f->exposure_us = c->has_exposure ? read_control(c->fd, V4L2_CID_EXPOSURE_ABSOLUTE, 100.0f) : NAN;
    f->gain = c->gain_cid ? read_control(c->fd, (uint32_t)c->gain_cid, 1.0f) : NAN;
    *out = f;
    return 0;
}

static int v4l2_next(void *ctx, int timeout_ms, sp_frame **out)
{
    v4l2_ctx *c = ctx;
    struct pollfd p = { .fd = c->fd, .events = POLLIN };
    int r = poll(&p, 1, timeout_ms);
    if (r < 0)
        return errno == EINTR ? -EAGAIN : -errno;
    if (r == 0)
        return -EAGAIN;
    /* on POLLERR the dequeue below tells why (ENODEV when the device went away) */
    struct v4l2_plane planes[VIDEO_MAX_PLANES];
    struct v4l2_buffer b = buffer_desc(c, 0, planes);
    int err = xioctl(c->fd, VIDIOC_DQBUF, &b);
    if (err == -EAGAIN && (p.revents & (POLLERR | POLLHUP)))
        return -ENODEV;
    if (err < 0)
        return err == -EPIPE || err == -ENXIO ? -ENODEV : err;
    if (b.index >= c->n_bufs)
        return -EIO;
    err = copy_out(c, &b, out);
    int qerr = queue_buffer(c, b.index);
    if (qerr < 0 && qerr != -ENODEV)
        sp_log(SP_LOG_WARN, "v4l2", "%s: requeue failed: %s", c->path, sp_strerror(qerr));
    return err;
}

static uint64_t v4l2_dropped(void *ctx)
{
    return ((v4l2_ctx *)ctx)->dropped;
}

const sp_camera_ops sp_camera_v4l2_ops = {
    .name = "v4l2",
    .enumerate = v4l2_enumerate,
    .modes = v4l2_modes,
    .claims = v4l2_claims,
    .open = v4l2_open,
    .start = v4l2_start,
    .next = v4l2_next,
    .stop = v4l2_stop,
    .close = v4l2_close,
    .dropped = v4l2_dropped,
};
