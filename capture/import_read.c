/* SPDX-License-Identifier: MIT */
/* The importers' frames: image files (JPEG kept as it is, PNG decoded) and video frames through OpenCV. */
#include "capture/import_ctx.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "sp_config.h"
/* ---- reading one image ---- */

static int read_file(import_ctx *c, const char *path)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        int rc = -errno;
        return FAIL(c, rc, "%s: cannot open: %s", path, sp_strerror(rc));
    }
    struct stat st;
    int rc = fstat(fd, &st) ? -errno : 0;
    if (!rc && (st.st_size <= 0 || (uint64_t)st.st_size > MAX_IMAGE_FILE))
        rc = FAIL(c, SP_EFORMAT, "%s: %s", path, st.st_size <= 0 ? "empty file" : "file too large for one frame");
    if (!rc && (size_t)st.st_size > c->file_cap) {
        uint8_t *p = realloc(c->file_buf, (size_t)st.st_size);
        rc = p ? 0 : -ENOMEM;
        if (p) {
            c->file_buf = p;
            c->file_cap = (size_t)st.st_size;
        }
    }
    size_t got = 0;
    while (!rc && got < (size_t)st.st_size) {
        ssize_t n = read(fd, c->file_buf + got, (size_t)st.st_size - got);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0)
            rc = n < 0 ? -errno : -EIO; /* the file shrank under us */
        else
            got += (size_t)n;
    }
    close(fd);
    c->file_size = got;
    return rc ? FAIL(c, rc, "%s: read failed: %s", path, sp_strerror(rc)) : 0;
}

static int ensure_rgb(import_ctx *c, uint32_t w, uint32_t h)
{
    size_t need = (size_t)w * h * 3;
    if (need <= c->rgb_cap)
        return 0;
    uint8_t *p = realloc(c->rgb, need);
    if (!p)
        return -ENOMEM;
    c->rgb = p;
    c->rgb_cap = need;
    return 0;
}

/* Fills f with the RGB24 image in c->rgb, or its JPEG re-encoding. */
static int frame_from_rgb(import_ctx *c, const char *what, uint32_t w, uint32_t h, sp_frame *f)
{
    f->width = w;
    f->height = h;
    c->rgb_fresh = 1;
    if (c->dry)
        return 0;
    if (c->s->store == SP_IMPORT_STORE_RGB) {
        f->format = SP_PIXFMT_RGB24;
        f->stride = w * 3;
        f->data = c->rgb;
        f->bytes_used = (size_t)w * h * 3;
        return 0;
    }
    int rc = sp_jpeg_encode_rgb24(c->rgb, w, h, w * 3, c->s->quality, &c->jpeg);
    if (rc == SP_EDISABLED)
        return FAIL(c, rc, "%s: storing as JPEG needs libjpeg; rebuild with -Djpeg=enabled or use --store rgb", what);
    if (rc)
        return FAIL(c, rc, "%s: JPEG encoding failed: %s", what, sp_strerror(rc));
    f->format = SP_PIXFMT_MJPEG;
    f->stride = 0;
    f->data = c->jpeg.data;
    f->bytes_used = c->jpeg.size;
    return 0;
}

/*
 * 1 when the file ends in EOI (some writers pad after it: the last KiB is searched). Entropy-coded data
 * never holds FF D9 (0xFF is stuffed there); only the tail is searched, as an EXIF thumbnail has its own.
 */
static int has_eoi(const uint8_t *d, size_t n)
{
    for (size_t i = n; i >= 2 && n - i < 1024; i--)
        if (d[i - 2] == 0xFF && d[i - 1] == 0xD9)
            return 1;
    return 0;
}

/*
 * A JPEG stored as it is must decode later (export-video, fit): decoded once here, with libjpeg; without
 * it, at least not cut short.
 */
static int check_stored_jpeg(import_ctx *c, const char *path, const sp_jpeg_header *hdr)
{
    if (c->index > 0 && (hdr->width != c->rep->width || hdr->height != c->rep->height))
        return 0; /* refused by check_size, with a better message */
    if (!sp_jpeg_available())
        return has_eoi(c->file_buf, c->file_size) ? 0
                                                  : FAIL(c, SP_ETRUNCATED, "%s: truncated JPEG (no end marker)", path);
    int rc = ensure_rgb(c, hdr->width, hdr->height);
    if (!rc)
        rc = sp_jpeg_decode(c->file_buf, c->file_size, SP_PIXFMT_RGB24, hdr->width, hdr->height, c->rgb, c->rgb_cap,
                            hdr->width * 3);
    if (rc == -ENOMEM)
        return FAIL(c, rc, "%s: %s", path, sp_strerror(rc));
    c->rgb_fresh = !rc;
    return rc ? FAIL(c, SP_ECORRUPT, "%s: damaged or truncated JPEG: it does not decode (%s)", path, sp_strerror(rc))
              : 0;
}

static int frame_from_jpeg_file(import_ctx *c, const char *path, sp_frame *f)
{
    sp_jpeg_header hdr;
    int rc = sp_jpeg_parse_header(c->file_buf, c->file_size, &hdr);
    if (rc)
        return FAIL(c, SP_EFORMAT, "%s: not a valid JPEG (%s)", path, sp_strerror(rc));
    if (hdr.components == 4)
        return FAIL(c, SP_EUNSUPPORTED, "%s: CMYK JPEG is not supported", path);
    if (c->s->store == SP_IMPORT_STORE_JPEG) { /* byte-for-byte: no generation loss */
        if ((rc = check_stored_jpeg(c, path, &hdr)))
            return rc;
        *f = (sp_frame){ .format = SP_PIXFMT_MJPEG, .width = hdr.width, .height = hdr.height,
                         .data = c->file_buf, .bytes_used = c->file_size };
        c->rep->frames_copied++;
        return 0;
    }
    if ((rc = ensure_rgb(c, hdr.width, hdr.height)) != 0)
        return FAIL(c, rc, "%s: %s", path, sp_strerror(rc));
    rc = sp_jpeg_decode(c->file_buf, c->file_size, SP_PIXFMT_RGB24, hdr.width, hdr.height, c->rgb, c->rgb_cap,
                        hdr.width * 3);
    if (rc == SP_EDISABLED)
        return FAIL(c, rc, "%s: decoding JPEG for --store rgb needs libjpeg; rebuild with -Djpeg=enabled", path);
    if (rc)
        return FAIL(c, SP_EFORMAT, "%s: cannot decode JPEG: %s", path, sp_strerror(rc));
    return frame_from_rgb(c, path, hdr.width, hdr.height, f);
}

static int frame_from_png_file(import_ctx *c, const char *path, sp_frame *f)
{
#if HAVE_OPENCV
    uint32_t w = 0, h = 0;
    int rc = sp_cv_image_decode(c->file_buf, c->file_size, &c->rgb, &c->rgb_cap, &w, &h);
    if (rc)
        return FAIL(c, rc, "%s: cannot decode image: %s", path, sp_strerror(rc));
    return frame_from_rgb(c, path, w, h, f);
#else
    (void)f;
    return FAIL(c, SP_EDISABLED, "%s: decoding PNG needs OpenCV; rebuild with -Dopencv=enabled (JPEG sequences "
                "import without it)", path);
#endif
}

static int next_image(import_ctx *c, sp_frame *f)
{
    if (c->index >= c->images.count)
        return SP_EOS;
    const char *path = c->images.items[c->index];
    int rc = read_file(c, path);
    if (rc)
        return rc;
    static const uint8_t png_magic[8] = { 0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n' };
    if (c->file_size >= 2 && c->file_buf[0] == 0xFF && c->file_buf[1] == 0xD8)
        return frame_from_jpeg_file(c, path, f);
    if (c->file_size >= 8 && memcmp(c->file_buf, png_magic, 8) == 0)
        return frame_from_png_file(c, path, f);
    return FAIL(c, SP_EFORMAT, "%s: neither a JPEG nor a PNG file", path);
}

/* ---- video ---- */

int sp_import_open_video(import_ctx *c, const char *path)
{
#if HAVE_OPENCV
    sp_cv_video_info info;
    int rc = sp_cv_video_open(&c->video, path, &info);
    c->video_path = path;
    if (rc == SP_EFORMAT)
        return FAIL(c, rc, "%s: OpenCV cannot open or decode this as a video", path);
    if (rc)
        return FAIL(c, rc, "%s: %s", path, sp_strerror(rc));
    if ((rc = ensure_rgb(c, info.width, info.height)) != 0)
        return rc;
    c->video_w = info.width;
    c->video_h = info.height;
    c->total = info.frame_count > 0 ? (uint64_t)info.frame_count : 0;
    if (isfinite(info.fps) && info.fps > 0 && info.fps <= 1000)
        c->video_fps = info.fps;
    if (c->s->store == SP_IMPORT_STORE_JPEG && !sp_jpeg_available())
        return FAIL(c, SP_EDISABLED, "%s: storing video frames as JPEG needs libjpeg; rebuild with "
                    "-Djpeg=enabled or use --store rgb", path);
    return 0;
#else
    return FAIL(c, SP_EDISABLED, "%s: importing video needs OpenCV; rebuild with -Dopencv=enabled", path);
#endif
}

static int next_video_frame(import_ctx *c, sp_frame *f)
{
#if HAVE_OPENCV
    int rc = sp_cv_video_read(c->video, c->rgb, c->rgb_cap, c->video_w * 3);
    if (rc == SP_EOS)
        return rc;
    int64_t pts = 0;
    int have = !rc && sp_cv_video_time_ns(c->video, &pts) == 0;
    if (c->index == 0) { /* the container's clock unless the user set one (--fps, --frame-times) */
        c->pts_ok = have && !c->times && !(c->s->fps > 0);
        c->pts0 = pts;
    }
    c->pts = have ? pts : INT64_MIN;
    if (rc)
        return FAIL(c, rc == SP_ECORRUPT ? SP_EFORMAT : rc, "%s: frame %llu: %s", c->s->input,
                    (unsigned long long)c->index, rc == SP_ECORRUPT ? "frame size changed" : sp_strerror(rc));
    return frame_from_rgb(c, c->s->input, c->video_w, c->video_h, f);
#else
    (void)f;
    return FAIL(c, SP_EDISABLED, "%s: importing video needs OpenCV; rebuild with -Dopencv=enabled", c->s->input);
#endif
}

/* ---- frame times ---- */

int sp_import_next_frame(import_ctx *c, sp_frame *f)
{
    memset(f, 0, sizeof(*f));
    c->rgb_fresh = 0;
    int rc = c->video ? next_video_frame(c, f) : next_image(c, f);
    if (rc)
        return rc;
    f->sequence = c->index;
    f->exposure_us = NAN;
    f->gain = NAN;
    if (c->expo.n && c->index >= c->expo.n)
        return FAIL(c, SP_ECORRUPT, "%s: has exposures for %zu frames, but the input has more frames", c->expo.path,
                    c->expo.n);
    if (c->expo.n) {
        f->exposure_us = c->expo.v[c->index][0];
        f->gain = c->expo.v[c->index][1];
    }
    return 0;
}
