/* SPDX-License-Identifier: MIT */
/*
 * Camera and IMU registries and the device-free backends: the fake camera's
 * negotiation, pacing, timestamps, drops and end; the fake IMU's real-time
 * release; V4L2 format mapping, the 4:2:0 layouts' repacking into NV12 and
 * missing-device errors; libcamera enumeration
 * with no cameras present.
 */
#include "sunprobe/sp_camera.h"

#include <errno.h>
#include <math.h>
#include <string.h>

#include "check.h"
#include "common/clock.h"
#include "sp_config.h"
#include "sunprobe/sp_imu_device.h"
#if HAVE_V4L2
#include <linux/videodev2.h>

#include "device/v4l2/v4l2_formats.h"
#endif

static void test_registry(void)
{
    size_t n = 0;
    const sp_camera_ops *const *ops = sp_camera_backends(&n);
    CHECK(n >= 1);
    CHECK(!strcmp(ops[n - 1]->name, "fake"));
    CHECK(sp_camera_backend_find("fake") == ops[n - 1]);
    CHECK(sp_camera_backend_find("nope") == NULL);
    CHECK_EQ_INT(sp_camera_backend_find("v4l2") != NULL, HAVE_V4L2);
    CHECK_EQ_INT(sp_camera_backend_find("libcamera") != NULL, HAVE_LIBCAMERA);
    sp_camera_desc d[8];
    size_t count = 0;
    CHECK_EQ_INT(sp_camera_enumerate(d, 8, &count), 0);
    CHECK(count >= 1);
    size_t last = count < 8 ? count - 1 : 7;
    CHECK(!strcmp(d[last].backend, "fake") && !strcmp(d[last].id, "fake"));
    CHECK_EQ_INT(sp_camera_enumerate(NULL, 0, &count), 0); /* counting only */
    CHECK(count >= 1);
    sp_camera_mode m[64];
    CHECK_EQ_INT(sp_camera_modes(&d[last], m, 64, &count), 0);
    CHECK(count >= 4 && m[0].width > 0 && m[0].max_fps > 0);
}

static sp_camera *open_fake(const char *dev, enum sp_pixfmt fmt, double fps, unsigned pool, int *err)
{
    sp_camera_settings s;
    sp_camera_default_settings(&s);
    s.device = dev;
    s.format = fmt;
    s.width = 64;
    s.height = 48;
    s.fps = fps;
    s.pool_frames = pool;
    sp_camera *cam = NULL;
    *err = sp_camera_open(&cam, &s);
    return cam;
}

static int next_frame(sp_camera *cam, sp_frame **f)
{
    int err;
    for (int i = 0; i < 200 && (err = sp_camera_next(cam, 50, f)) == -EAGAIN; i++) {
    }
    return err;
}

/* Paced frames: sequence +1, timestamps exactly 1/fps apart on the monotonic clock, format as negotiated. */
static void test_fake_paced(void)
{
    int err;
    sp_camera *cam = open_fake("fake", SP_PIXFMT_NV12, 100.0, 4, &err);
    CHECK_EQ_INT(err, 0);
    if (!cam)
        return;
    const sp_camera_info *ci = sp_camera_get_info(cam);
    CHECK(ci->format == SP_PIXFMT_NV12 && ci->width == 64 && ci->height == 48 && ci->stride == 64);
    CHECK(ci->fps == 100.0 && ci->monotonic_timestamps && !strcmp(ci->desc.backend, "fake"));
    sp_frame *f = NULL;
    CHECK_EQ_INT(sp_camera_next(cam, 10, &f), -EINVAL); /* not started */
    int64_t t0 = sp_clock_monotonic_ns(), prev = 0;
    uint64_t prev_seq = 0, gaps = 0;
    CHECK_EQ_INT(sp_camera_start(cam), 0);
    for (uint64_t i = 0; i < 10; i++) {
        CHECK_EQ_INT(next_frame(cam, &f), 0);
        if (!f)
            break;
        CHECK(f->format == SP_PIXFMT_NV12 && f->bytes_used == 64 * 72);
        CHECK(f->timestamp_ns >= t0 && f->timestamp_ns <= sp_clock_monotonic_ns());
        /* a busy machine may make the paced camera skip frames; the sequence and the stamps say so alike */
        if (i) {
            CHECK(f->sequence > prev_seq);
            CHECK_NEAR((double)(f->timestamp_ns - prev), 1e7 * (double)(f->sequence - prev_seq), 2.0);
            gaps += f->sequence - prev_seq - 1;
        } else {
            gaps += f->sequence;
        }
        prev = f->timestamp_ns;
        prev_seq = f->sequence;
        CHECK(isfinite(f->exposure_us));
        sp_frame_unref(&f);
    }
    CHECK_EQ_INT(sp_camera_dropped(cam), gaps);
    sp_camera_close(&cam);
    CHECK(cam == NULL);
}

/* A consumer that holds every pooled frame makes a paced camera lose frames, and says how many. */
static void test_fake_drops(void)
{
    int err;
    sp_camera *cam = open_fake("fake", SP_PIXFMT_GRAY8, 200.0, 2, &err);
    if (!cam)
        return;
    CHECK_EQ_INT(sp_camera_start(cam), 0);
    sp_frame *held[2] = { NULL, NULL };
    CHECK_EQ_INT(next_frame(cam, &held[0]), 0);
    CHECK_EQ_INT(next_frame(cam, &held[1]), 0);
    sp_frame *f = NULL;
    for (int i = 0; i < 5; i++)
        CHECK_EQ_INT(sp_camera_next(cam, 20, &f), -EAGAIN);
    CHECK(sp_camera_dropped(cam) >= 3);
    sp_frame_unref(&held[0]);
    CHECK_EQ_INT(next_frame(cam, &f), 0);
    CHECK(f && held[1] && f->sequence > held[1]->sequence + 1); /* the gap shows in the sequence too */
    sp_frame_unref(&f);
    sp_frame_unref(&held[1]);
    sp_camera_close(&cam);
}

static void test_fake_options(void)
{
    int err;
    sp_camera *cam = open_fake("fake:unpaced,frames=3,panorama", SP_PIXFMT_RGB24, 30.0, 4, &err);
    CHECK_EQ_INT(err, 0);
    if (cam) {
        CHECK_EQ_INT(sp_camera_start(cam), 0);
        sp_frame *f = NULL;
        for (int i = 0; i < 3; i++) {
            CHECK_EQ_INT(sp_camera_next(cam, 0, &f), 0); /* unpaced: at once */
            CHECK(f && f->format == SP_PIXFMT_RGB24 && f->bytes_used == 64 * 48 * 3);
            sp_frame_unref(&f);
        }
        CHECK_EQ_INT(sp_camera_next(cam, 0, &f), SP_EOS);
        sp_camera_close(&cam);
    }
    cam = open_fake("fake:bogus", SP_PIXFMT_YUYV, 30.0, 4, &err);
    CHECK(cam == NULL && err == -EINVAL);
    cam = open_fake("fake", SP_PIXFMT_MJPEG, 30.0, 4, &err);
    CHECK(cam == NULL && err == SP_EUNSUPPORTED);
    cam = open_fake("fake", SP_PIXFMT_YUYV, -1.0, 4, &err);
    CHECK(cam == NULL && err == -EINVAL);
    cam = open_fake("no-such-camera-anywhere", SP_PIXFMT_YUYV, 30.0, 4, &err);
    CHECK(cam == NULL && err == -ENOENT);
    /* prerendered frames are copies that still differ from frame to frame */
    cam = open_fake("fake:unpaced,prerender", SP_PIXFMT_YUYV, 30.0, 4, &err);
    CHECK_EQ_INT(err, 0);
    if (cam) {
        sp_frame *a = NULL, *b = NULL;
        CHECK_EQ_INT(sp_camera_start(cam), 0);
        CHECK_EQ_INT(sp_camera_next(cam, 0, &a), 0);
        CHECK_EQ_INT(sp_camera_next(cam, 0, &b), 0);
        CHECK(a && b && a->bytes_used == b->bytes_used && memcmp(a->data, b->data, a->bytes_used) != 0);
        sp_frame_unref(&a);
        sp_frame_unref(&b);
        sp_camera_close(&cam);
    }
}

static void test_v4l2_mapping(void)
{
    sp_camera_settings s;
    sp_camera_default_settings(&s);
    s.device = "/dev/video-sunprobe-missing";
    sp_camera *cam = NULL;
    int err = sp_camera_open(&cam, &s);
#if HAVE_V4L2
    CHECK_EQ_INT(err, -ENOENT); /* the node does not exist */
    CHECK_EQ_INT(sp_v4l2_to_pixfmt(V4L2_PIX_FMT_YUYV), SP_PIXFMT_YUYV);
    CHECK_EQ_INT(sp_v4l2_to_pixfmt(V4L2_PIX_FMT_JPEG), SP_PIXFMT_MJPEG);
    CHECK_EQ_INT(sp_v4l2_to_pixfmt(V4L2_PIX_FMT_GREY), SP_PIXFMT_GRAY8);
    CHECK_EQ_INT(sp_v4l2_to_pixfmt(V4L2_PIX_FMT_SRGGB10), SP_PIXFMT_NONE);
    uint32_t cc[4];
    CHECK_EQ_INT(sp_v4l2_from_pixfmt(SP_PIXFMT_MJPEG, cc, 4), 2);
    CHECK_EQ_INT(sp_v4l2_from_pixfmt(SP_PIXFMT_NV12, cc, 4), 4); /* the first four of its eight layouts */
    CHECK_EQ_INT(cc[0], V4L2_PIX_FMT_NV12); /* stored as it comes, so asked for first */
    CHECK_EQ_INT(sp_v4l2_to_pixfmt(V4L2_PIX_FMT_YVU420M), SP_PIXFMT_NV12);
    CHECK_EQ_INT(sp_v4l2_from_pixfmt(SP_PIXFMT_NONE, cc, 4), 0);
#else
    CHECK_EQ_INT(err, SP_EDISABLED); /* says which meson option would have built it */
#endif
    CHECK(cam == NULL);
}

#if HAVE_V4L2
/* Known samples of a w x h 4:2:0 image: luma and each chroma sample distinct, so a swapped, shifted or
 * dropped sample shows. */
static uint8_t luma_at(size_t x, size_t y)
{
    return (uint8_t)(16 + 13 * y + x);
}
static uint8_t cb_at(size_t x, size_t y)
{
    return (uint8_t)(60 + 7 * y + x);
}
static uint8_t cr_at(size_t x, size_t y)
{
    return (uint8_t)(240 - 7 * y - x);
}

/* Writes the image in one V4L2 layout: colour planes in `buf` at `stride` (luma) and `cstride`
 * (chroma), each colour plane starting where `plane_at` says; fills strides' padding with 0xEE. */
static void write_layout(const sp_v4l2_layout *l, uint32_t w, uint32_t h, uint8_t *const plane_at[3],
                         size_t stride, size_t cstride)
{
    size_t cw = (w + 1) / 2, ch = (h + 1) / 2;
    memset(plane_at[0], 0xEE, stride * h);
    for (size_t y = 0; y < h; y++)
        for (size_t x = 0; x < w; x++)
            plane_at[0][y * stride + x] = luma_at(x, y);
    for (unsigned p = 1; p < l->planes; p++)
        memset(plane_at[p], 0xEE, cstride * ch);
    for (size_t y = 0; y < ch; y++)
        for (size_t x = 0; x < cw; x++) {
            uint8_t first = l->cr_first ? cr_at(x, y) : cb_at(x, y);
            uint8_t second = l->cr_first ? cb_at(x, y) : cr_at(x, y);
            if (l->planes == 2) {
                plane_at[1][y * cstride + 2 * x] = first;
                plane_at[1][y * cstride + 2 * x + 1] = second;
            } else {
                plane_at[1][y * cstride + x] = first;
                plane_at[2][y * cstride + x] = second;
            }
        }
}

/* 0 when dst is the image as NV12 at dst_stride with zeroed padding; else the first wrong byte + 1. */
static size_t first_wrong_nv12(const uint8_t *dst, uint32_t w, uint32_t h, size_t dst_stride)
{
    size_t cw = (w + 1) / 2, ch = (h + 1) / 2;
    for (size_t y = 0; y < h; y++)
        for (size_t x = 0; x < dst_stride; x++)
            if (dst[y * dst_stride + x] != (x < w ? luma_at(x, y) : 0))
                return y * dst_stride + x + 1;
    const uint8_t *uv = dst + h * dst_stride;
    for (size_t y = 0; y < ch; y++)
        for (size_t x = 0; x < dst_stride; x++) {
            uint8_t want = x >= 2 * cw ? 0 : x % 2 ? cr_at(x / 2, y) : cb_at(x / 2, y);
            if (uv[y * dst_stride + x] != want)
                return (h + y) * dst_stride + x + 1;
        }
    return 0;
}

/* Every 4:2:0 layout, one buffer or several, even and odd sizes, padded strides: repacked into NV12
 * sample for sample; buffers too small for the size are refused, never read past. */
static void test_v4l2_repack(void)
{
    static const uint32_t fourccs[] = { V4L2_PIX_FMT_NV12,  V4L2_PIX_FMT_NV21,   V4L2_PIX_FMT_YUV420,
                                        V4L2_PIX_FMT_YVU420, V4L2_PIX_FMT_NV12M, V4L2_PIX_FMT_NV21M,
                                        V4L2_PIX_FMT_YUV420M, V4L2_PIX_FMT_YVU420M };
    static const uint32_t sizes[][2] = { { 1, 1 }, { 2, 2 }, { 5, 3 }, { 8, 6 }, { 33, 17 } };
    for (size_t f = 0; f < sizeof(fourccs) / sizeof(fourccs[0]); f++) {
        const sp_v4l2_layout *l = sp_v4l2_layout_of(fourccs[f]);
        CHECK(l && l->format == SP_PIXFMT_NV12);
        if (!l)
            continue;
        for (size_t z = 0; z < sizeof(sizes) / sizeof(sizes[0]); z++) {
            uint32_t w = sizes[z][0], h = sizes[z][1];
            size_t cw = (w + 1) / 2, ch = (h + 1) / 2;
            /* one buffer: chroma stride as V4L2 defines it; several: strides of their own */
            size_t stride = 2 * cw + 6;
            size_t cstride = l->buffers == 1 ? (l->planes == 3 ? stride / 2 : stride) : (l->planes == 3 ? cw + 3 : 2 * cw + 10);
            size_t size = stride * h + (l->planes - 1) * cstride * ch;
            uint8_t *buf = malloc(size), *plane_at[3];
            size_t dst_stride = sp_pixfmt_min_stride(SP_PIXFMT_NV12, w);
            size_t dst_size = sp_pixfmt_image_size(SP_PIXFMT_NV12, w, h, (uint32_t)dst_stride);
            uint8_t *dst = malloc(dst_size);
            if (!buf || !dst)
                abort();
            plane_at[0] = buf;
            plane_at[1] = buf + stride * h;
            plane_at[2] = plane_at[1] + cstride * ch;
            write_layout(l, w, h, plane_at, stride, cstride);
            sp_v4l2_plane planes[3];
            if (l->buffers == 1) {
                CHECK_EQ_INT(sp_v4l2_split_planes(l, buf, size, stride, h, planes), l->planes);
                CHECK_EQ_INT(sp_v4l2_split_planes(l, buf, size - 1, stride, h, planes), 0);
                CHECK_EQ_INT(sp_v4l2_split_planes(l, buf, size, stride, h, planes), l->planes);
            } else {
                planes[0] = (sp_v4l2_plane){ plane_at[0], stride, stride * h };
                for (unsigned p = 1; p < l->planes; p++)
                    planes[p] = (sp_v4l2_plane){ plane_at[p], cstride, cstride * ch };
            }
            memset(dst, 0xAA, dst_size);
            CHECK_EQ_INT(sp_v4l2_to_nv12(l, planes, w, h, dst, dst_stride), 0);
            size_t wrong = first_wrong_nv12(dst, w, h, dst_stride);
            CHECK_MSG(wrong == 0, "%.4s %ux%u: byte %zu of the NV12 image", (const char *)&fourccs[f], w, h, wrong - 1);
            /* the last chroma row one byte short, the luma plane one row short, dst too narrow: refused */
            sp_v4l2_plane short_planes[3] = { planes[0], planes[1], planes[2] };
            short_planes[l->planes - 1].size = (ch - 1) * short_planes[l->planes - 1].stride +
                                               (l->planes == 2 ? 2 * cw : cw) - 1;
            CHECK_EQ_INT(sp_v4l2_to_nv12(l, short_planes, w, h, dst, dst_stride), -EINVAL);
            short_planes[l->planes - 1] = planes[l->planes - 1];
            short_planes[0].size = stride * (h - 1);
            CHECK_EQ_INT(sp_v4l2_to_nv12(l, short_planes, w, h, dst, dst_stride), -EINVAL);
            CHECK_EQ_INT(sp_v4l2_to_nv12(l, planes, w, h, dst, dst_stride - 1), -EINVAL);
            CHECK_EQ_INT(sp_v4l2_to_nv12(l, planes, 0, h, dst, dst_stride), -EINVAL);
            free(buf);
            free(dst);
        }
    }
    /* packed and compressed layouts are not 4:2:0 planes */
    sp_v4l2_plane planes[3];
    uint8_t byte = 0;
    CHECK_EQ_INT(sp_v4l2_split_planes(sp_v4l2_layout_of(V4L2_PIX_FMT_YUYV), &byte, 1, 1, 1, planes), 0);
    CHECK_EQ_INT(sp_v4l2_fourcc_from_string("NM21"), V4L2_PIX_FMT_NV21M);
    CHECK_EQ_INT(sp_v4l2_fourcc_from_string("GREY"), V4L2_PIX_FMT_GREY);
    CHECK_EQ_INT(sp_v4l2_fourcc_from_string("NV12X"), 0);
    CHECK_EQ_INT(sp_v4l2_fourcc_from_string(""), 0);
}

/* A device string's ":fourcc=" option: a path with a bad option or an unknown fourcc fails before any
 * device is touched, naming the string. */
static void test_v4l2_device_options(void)
{
    static const char *const bad[] = { "/dev/video-sunprobe-missing:fourcc=", "/dev/video-sunprobe-missing:fps=30",
                                       "/dev/video-sunprobe-missing:fourcc=BA81" };
    for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
        sp_camera_settings s;
        sp_camera_default_settings(&s);
        s.device = bad[i];
        sp_camera *cam = NULL;
        CHECK_MSG(sp_camera_open(&cam, &s) == -EINVAL, "%s", bad[i]);
        CHECK(cam == NULL);
    }
    sp_camera_settings s;
    sp_camera_default_settings(&s);
    s.device = "/dev/video-sunprobe-missing:fourcc=NM12";
    sp_camera *cam = NULL;
    CHECK_EQ_INT(sp_camera_open(&cam, &s), -ENOENT); /* a good option: the node itself is what is missing */
}
#endif

static void test_libcamera_enumerate(void)
{
    const sp_camera_ops *lc = sp_camera_backend_find("libcamera");
    if (!lc) {
        fprintf(stderr, "note: libcamera backend not built; enumeration not exercised\n");
        return;
    }
    size_t n = 99;
    sp_camera_desc d[4];
    CHECK_EQ_INT(lc->enumerate(d, 4, &n), 0); /* a machine without cameras lists none, without failing */
    CHECK(n < 99);
    CHECK(!lc->claims("fake") && !lc->claims("/dev/video0"));
}

/* The fake IMU hands out samples no later than they are due, in order, at its rate. */
static void test_fake_imu(void)
{
    sp_imu_device_settings s;
    sp_imu_device_default_settings(&s);
    s.device = "fake";
    s.rate_hz = 500;
    sp_imu_device *imu = NULL;
    CHECK_EQ_INT(sp_imu_device_open(&imu, &s), 0);
    if (!imu)
        return;
    const sp_imu_device_info *ii = sp_imu_device_get_info(imu);
    CHECK(ii->rate_hz == 500 && (ii->desc.sensors & SP_IMU_SENSOR_BIT(SP_IMU_GYRO)));
    CHECK_EQ_INT(sp_imu_device_start(imu), 0);
    sp_imu_sample buf[64];
    uint64_t gyro = 0;
    int64_t last = 0, first_gyro = -1, last_gyro = 0, start = sp_clock_monotonic_ns();
    while (sp_clock_monotonic_ns() - start < 200000000) {
        size_t n = 0;
        CHECK_EQ_INT(sp_imu_device_read(imu, buf, 64, 10, &n), 0);
        int64_t now = sp_clock_monotonic_ns();
        for (size_t i = 0; i < n; i++) {
            CHECK(buf[i].timestamp_ns <= now && buf[i].timestamp_ns >= last);
            CHECK(isfinite(buf[i].v[0]) && isfinite(buf[i].v[1]) && isfinite(buf[i].v[2]));
            last = buf[i].timestamp_ns;
            if (buf[i].sensor != SP_IMU_GYRO)
                continue;
            gyro++;
            if (first_gyro < 0)
                first_gyro = buf[i].timestamp_ns;
            last_gyro = buf[i].timestamp_ns;
        }
    }
    /* the stamps span what was released: count and span agree with 500 Hz */
    CHECK(gyro >= 50);
    CHECK_NEAR((double)gyro, (double)(last_gyro - first_gyro) * 500e-9 + 1.0, 1.5);
    sp_imu_device_close(&imu);
    s.device = "imu-that-does-not-exist";
    CHECK_EQ_INT(sp_imu_device_open(&imu, &s), -ENOENT);
}

int main(void)
{
    test_registry();
    test_fake_paced();
    test_fake_drops();
    test_fake_options();
    test_v4l2_mapping();
#if HAVE_V4L2
    test_v4l2_repack();
    test_v4l2_device_options();
#endif
    test_libcamera_enumerate();
    test_fake_imu();
    return check_exit();
}
