/* SPDX-License-Identifier: MIT */
/* OpenCV behind a C API: video read/write and image decode in RGB24; exceptions stop here. */
#include "opencv_shim.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <new>

#include <strings.h>
#include <sys/stat.h>

#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "opencv_guard.hpp"
#include "sunprobe/sp_common.h"

struct sp_cv_video_reader {
    cv::VideoCapture cap;
    cv::Mat bgr;
    uint32_t width = 0, height = 0;
    bool pending = false; /* bgr holds the first frame, decoded at open to learn the size */
    double pending_ms = NAN; /* that frame's presentation time */
    double last_ms = NAN;    /* the presentation time of the frame read last */
};

struct sp_cv_video_writer {
    cv::VideoWriter out;
    cv::Mat bgr;
    uint32_t width = 0, height = 0;
};

namespace {

using sp_cv::guarded;
using sp_cv::quiet_opencv;

int missing_or(const char *path, int otherwise)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return -errno;
    return S_ISDIR(st.st_mode) ? -EISDIR : otherwise;
}

bool dst_fits(uint32_t w, uint32_t h, size_t dst_size, uint32_t dst_stride)
{
    uint64_t row = (uint64_t)w * 3;
    return dst_stride >= row && (uint64_t)dst_size >= (uint64_t)(h - 1) * dst_stride + row;
}

/*
 * File backends only: CAP_ANY would also probe camera backends (dc1394, gphoto2) for a
 * file it cannot read, which is slow and leaks inside libusb.
 */
bool open_file_capture(cv::VideoCapture &cap, const char *path)
{
    for (int api : { cv::CAP_FFMPEG, cv::CAP_GSTREAMER })
        if (cap.open(path, api) && cap.isOpened())
            return true;
    return false;
}

bool has_ext(const char *path, const char *ext)
{
    size_t n = strlen(path), e = strlen(ext);
    return n > e && strcasecmp(path + n - e, ext) == 0;
}

} // namespace

extern "C" int sp_cv_video_open(sp_cv_video_reader **out, const char *path, sp_cv_video_info *info)
{
    if (!out || !path || !info)
        return -EINVAL;
    *out = nullptr;
    int rc = missing_or(path, 0);
    if (rc)
        return rc;
    quiet_opencv();
    sp_cv_video_reader *r = new (std::nothrow) sp_cv_video_reader;
    if (!r)
        return -ENOMEM;
    rc = guarded("open video", [&]() -> int {
        if (!open_file_capture(r->cap, path))
            return SP_EFORMAT;
        if (!r->cap.read(r->bgr) || r->bgr.empty() || r->bgr.type() != CV_8UC3)
            return SP_EFORMAT;
        r->pending = true;
        r->pending_ms = r->cap.get(cv::CAP_PROP_POS_MSEC);
        r->width = (uint32_t)r->bgr.cols;
        r->height = (uint32_t)r->bgr.rows;
        info->width = r->width;
        info->height = r->height;
        info->fps = r->cap.get(cv::CAP_PROP_FPS);
        double n = r->cap.get(cv::CAP_PROP_FRAME_COUNT);
        info->frame_count = std::isfinite(n) && n > 0 && n < 9e18 ? (int64_t)n : 0;
        return 0;
    });
    if (rc) {
        delete r;
        return rc;
    }
    *out = r;
    return 0;
}

extern "C" int sp_cv_video_read(sp_cv_video_reader *r, uint8_t *dst, size_t dst_size, uint32_t dst_stride)
{
    if (!r || !dst || !dst_fits(r->width, r->height, dst_size, dst_stride))
        return -EINVAL;
    return guarded("read video frame", [&]() -> int {
        if (!r->pending && (!r->cap.read(r->bgr) || r->bgr.empty()))
            return SP_EOS;
        /* the FFmpeg backend gives the frame's presentation time from the start of the stream */
        r->last_ms = r->pending ? r->pending_ms : r->cap.get(cv::CAP_PROP_POS_MSEC);
        r->pending = false;
        if ((uint32_t)r->bgr.cols != r->width || (uint32_t)r->bgr.rows != r->height || r->bgr.type() != CV_8UC3)
            return SP_ECORRUPT;
        cv::Mat rgb((int)r->height, (int)r->width, CV_8UC3, dst, dst_stride);
        cv::cvtColor(r->bgr, rgb, cv::COLOR_BGR2RGB);
        return 0;
    });
}

extern "C" int sp_cv_video_time_ns(sp_cv_video_reader *r, int64_t *out)
{
    if (!r || !out)
        return -EINVAL;
    if (!std::isfinite(r->last_ms) || r->last_ms < 0 || r->last_ms > 1e14)
        return SP_ENODATA;
    *out = (int64_t)std::llround(r->last_ms * 1e6);
    return 0;
}

extern "C" void sp_cv_video_close(sp_cv_video_reader **r)
{
    if (!r || !*r)
        return;
    guarded("close video", [&]() -> int {
        (*r)->cap.release();
        return 0;
    });
    delete *r;
    *r = nullptr;
}

namespace {

/* Converts a decoded BGR image into the caller's growing RGB24 buffer. */
int bgr_to_buffer(const cv::Mat &img, uint8_t **buf, size_t *cap, uint32_t *width, uint32_t *height)
{
    if (img.empty() || img.type() != CV_8UC3)
        return SP_EFORMAT;
    size_t need = (size_t)img.cols * (size_t)img.rows * 3;
    if (need > *cap) {
        uint8_t *p = (uint8_t *)realloc(*buf, need);
        if (!p)
            return -ENOMEM;
        *buf = p;
        *cap = need;
    }
    cv::Mat rgb(img.rows, img.cols, CV_8UC3, *buf, (size_t)img.cols * 3);
    cv::cvtColor(img, rgb, cv::COLOR_BGR2RGB);
    *width = (uint32_t)img.cols;
    *height = (uint32_t)img.rows;
    return 0;
}

/* EXIF rotation is ignored so a decoded JPEG matches the same file stored as-is. */
const int image_flags = cv::IMREAD_COLOR | cv::IMREAD_IGNORE_ORIENTATION;

} // namespace

extern "C" int sp_cv_image_read(const char *path, uint8_t **buf, size_t *cap, uint32_t *width, uint32_t *height)
{
    if (!path || !buf || !cap || !width || !height)
        return -EINVAL;
    int rc = missing_or(path, 0);
    if (rc)
        return rc;
    quiet_opencv();
    return guarded("read image", [&]() -> int {
        return bgr_to_buffer(cv::imread(path, image_flags), buf, cap, width, height);
    });
}

extern "C" int sp_cv_image_decode(const uint8_t *data, size_t size, uint8_t **buf, size_t *cap, uint32_t *width,
                                  uint32_t *height)
{
    if (!data || size == 0 || size > (size_t)INT32_MAX || !buf || !cap || !width || !height)
        return -EINVAL;
    quiet_opencv();
    return guarded("decode image", [&]() -> int {
        /* imdecode only reads the bytes; the Mat header needs a non-const pointer */
        cv::Mat in(1, (int)size, CV_8UC1, const_cast<uint8_t *>(data));
        return bgr_to_buffer(cv::imdecode(in, image_flags), buf, cap, width, height);
    });
}

extern "C" int sp_cv_video_writer_open(sp_cv_video_writer **out, const char *path, uint32_t width, uint32_t height,
                                       double fps)
{
    if (!out || !path || width == 0 || height == 0 || width > 32768 || height > 32768 || !(fps > 0 && fps < 1e4))
        return -EINVAL;
    *out = nullptr;
    int fourcc;
    if (has_ext(path, ".avi"))
        fourcc = cv::VideoWriter::fourcc('M', 'J', 'P', 'G');
    else if (has_ext(path, ".mp4"))
        fourcc = cv::VideoWriter::fourcc('m', 'p', '4', 'v');
    else
        return -EINVAL;
    quiet_opencv();
    sp_cv_video_writer *w = new (std::nothrow) sp_cv_video_writer;
    if (!w)
        return -ENOMEM;
    int rc = guarded("open video writer", [&]() -> int {
        cv::Size size((int)width, (int)height);
        if (!w->out.open(path, cv::CAP_FFMPEG, fourcc, fps, size, true) &&
            !w->out.open(path, cv::CAP_ANY, fourcc, fps, size, true))
            return -EIO;
        if (!w->out.isOpened())
            return -EIO;
        w->width = width;
        w->height = height;
        return 0;
    });
    if (rc) {
        delete w;
        return rc;
    }
    *out = w;
    return 0;
}

extern "C" int sp_cv_video_write(sp_cv_video_writer *w, const uint8_t *rgb, uint32_t stride)
{
    if (!w || !rgb || stride < (uint64_t)w->width * 3)
        return -EINVAL;
    return guarded("write video frame", [&]() -> int {
        /* OpenCV wants a non-const pointer for a Mat header; the data is only read */
        cv::Mat in((int)w->height, (int)w->width, CV_8UC3, const_cast<uint8_t *>(rgb), stride);
        cv::cvtColor(in, w->bgr, cv::COLOR_RGB2BGR);
        w->out.write(w->bgr);
        return 0;
    });
}

extern "C" int sp_cv_video_writer_close(sp_cv_video_writer **w)
{
    if (!w || !*w)
        return 0;
    int rc = guarded("close video writer", [&]() -> int {
        (*w)->out.release();
        return 0;
    });
    delete *w;
    *w = nullptr;
    return rc;
}
