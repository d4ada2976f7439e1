/* SPDX-License-Identifier: MIT */
/* OpenCV behind a C API for the probe: HOG people scores, MOG2, Telea and GrabCut; exceptions stop here. */
#include "opencv_probe_shim.h"

#include <cerrno>
#include <cmath>
#include <algorithm>
#include <new>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/objdetect.hpp>
#include <opencv2/photo.hpp>
#include <opencv2/video/background_segm.hpp>

#include "capture/opencv_guard.hpp"
#include "sunprobe/sp_common.h"

struct sp_cv_hog {
    cv::HOGDescriptor hog;
    std::vector<float> weights; /* descriptor weights, then the bias */
    std::vector<float> desc;
    cv::Mat patch, window;
};

struct sp_cv_mog2 {
    cv::Ptr<cv::BackgroundSubtractorMOG2> mog;
};

namespace {

using sp_cv::guarded;

} // namespace

extern "C" int sp_cv_hog_open(sp_cv_hog **out)
{
    if (!out)
        return -EINVAL;
    *out = nullptr;
    sp_cv::quiet_opencv();
    sp_cv_hog *h = new (std::nothrow) sp_cv_hog;
    if (!h)
        return -ENOMEM;
    int rc = guarded("HOG people detector", [&]() -> int {
        h->weights = cv::HOGDescriptor::getDefaultPeopleDetector();
        return h->weights.size() == h->hog.getDescriptorSize() + 1 ? 0 : -EIO;
    });
    if (rc) {
        delete h;
        return rc;
    }
    *out = h;
    return 0;
}

extern "C" int sp_cv_hog_score(sp_cv_hog *h, const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride,
                               int x0, int y0, int x1, int y1, double *score)
{
    if (!h || !rgb || !score || x1 < x0 || y1 < y0 || width == 0 || height == 0 || stride < width * 3)
        return -EINVAL;
    return guarded("HOG score", [&]() -> int {
        cv::Mat img((int)height, (int)width, CV_8UC3, const_cast<uint8_t *>(rgb), stride);
        double bh = y1 - y0 + 1, wh = 1.25 * bh; /* the training windows leave 16 of 128 rows above and below */
        cv::Point2f centre((float)(0.5 * (x0 + x1)), (float)(0.5 * (y0 + y1)));
        cv::getRectSubPix(img, cv::Size((int)(0.5 * wh + 0.5), (int)(wh + 0.5)), centre, h->patch);
        cv::resize(h->patch, h->window, h->hog.winSize, 0, 0, cv::INTER_AREA);
        h->hog.compute(h->window, h->desc);
        if (h->desc.size() + 1 != h->weights.size())
            return -EIO;
        double s = h->weights.back();
        for (size_t i = 0; i < h->desc.size(); i++)
            s += (double)h->desc[i] * h->weights[i];
        *score = s;
        return 0;
    });
}

extern "C" int sp_cv_hog_detect(sp_cv_hog *h, const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride,
                                double upscale, int *boxes, unsigned cap, unsigned *n)
{
    if (!h || !rgb || !n || (!boxes && cap) || width == 0 || height == 0 || stride < width * 3 ||
        !(upscale >= 1 && upscale <= 4))
        return -EINVAL;
    return guarded("HOG detect", [&]() -> int {
        cv::Mat img((int)height, (int)width, CV_8UC3, const_cast<uint8_t *>(rgb), stride);
        cv::Mat big;
        if (upscale > 1)
            cv::resize(img, big, cv::Size(), upscale, upscale, cv::INTER_LINEAR);
        else
            big = img;
        cv::HOGDescriptor d;
        d.setSVMDetector(h->weights);
        std::vector<cv::Rect> found;
        d.detectMultiScale(big, found, 0, cv::Size(8, 8), cv::Size(16, 16), 1.05, 2);
        *n = (unsigned)found.size();
        for (unsigned i = 0; i < *n && i < cap; i++) {
            const cv::Rect &r = found[i];
            int x0 = (int)(r.x / upscale), y0 = (int)(r.y / upscale);
            int x1 = (int)((r.x + r.width) / upscale) - 1, y1 = (int)((r.y + r.height) / upscale) - 1;
            boxes[4 * i] = std::max(0, x0), boxes[4 * i + 1] = std::max(0, y0);
            boxes[4 * i + 2] = std::min((int)width - 1, x1), boxes[4 * i + 3] = std::min((int)height - 1, y1);
        }
        return 0;
    });
}

extern "C" int sp_cv_inpaint_telea(uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride,
                                   const uint8_t *mask, double radius)
{
    if (!rgb || !mask || width == 0 || height == 0 || stride < width * 3 || !(radius >= 1 && radius <= 64))
        return -EINVAL;
    return guarded("Telea inpainting", [&]() -> int {
        cv::Mat img((int)height, (int)width, CV_8UC3, rgb, stride);
        cv::Mat m((int)height, (int)width, CV_8UC1, const_cast<uint8_t *>(mask), width);
        cv::Mat m8 = m != 0, out;
        cv::inpaint(img, m8, out, radius, cv::INPAINT_TELEA);
        out.copyTo(img);
        return img.data == rgb ? 0 : -EIO;
    });
}

extern "C" int sp_cv_grabcut_box(const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, int x0, int y0,
                                 int x1, int y1, int iterations, int min_height, uint8_t *mask)
{
    if (!rgb || !mask || width == 0 || height == 0 || width > 32768 || height > 32768 || stride < width * 3 || x0 < 0 ||
        y0 < 0 || x1 < x0 || y1 < y0 || x1 >= (int)width || y1 >= (int)height || iterations < 1 || iterations > 10 ||
        min_height < 0 || min_height > 4096)
        return -EINVAL;
    int bw = x1 - x0 + 1, bh = y1 - y0 + 1;
    /* the colour models learn the background from a frame around the box, not the whole image */
    int mx = std::max(8, bw / 2), my = std::max(8, bh / 4);
    cv::Rect crop(cv::Point(std::max(0, x0 - mx), std::max(0, y0 - my)),
                  cv::Point(std::min((int)width, x1 + 1 + mx), std::min((int)height, y1 + 1 + my)));
    cv::Rect box(x0 - crop.x, y0 - crop.y, bw, bh);
    if (bw < 3 || bh < 3 || crop.area() - box.area() < 64)
        return SP_ENODATA; /* too small a box, or no background around it to learn */
    return guarded("GrabCut", [&]() -> int {
        cv::Mat img((int)height, (int)width, CV_8UC3, const_cast<uint8_t *>(rgb), stride);
        cv::Mat gc, bgd, fgd;
        cv::theRNG().state = 0x5eed; /* the GMMs start from k-means: the same box, the same mask */
        /* a small box has too few pixels for the smoothness term: cut it enlarged, the crop within a
           megapixel (a wide, short box would otherwise grow without bound) */
        double k = std::min((double)min_height / bh, std::sqrt((double)(1 << 20) / crop.area()));
        if (k > 1) {
            cv::Mat big, big_gc;
            cv::resize(img(crop), big, cv::Size(), k, k, cv::INTER_CUBIC);
            cv::Rect big_box = cv::Rect((int)std::lround(box.x * k), (int)std::lround(box.y * k),
                                        (int)std::lround(bw * k), (int)std::lround(bh * k)) &
                cv::Rect(0, 0, big.cols, big.rows);
            cv::grabCut(big, big_gc, big_box, bgd, fgd, iterations, cv::GC_INIT_WITH_RECT);
            /* each pixel takes its enlarged block's first label, up to half a pixel off its centre: read at
               the centres, or foreground where any of the block is, measured worse (DEPOPULATE.md) */
            cv::resize(big_gc, gc, crop.size(), 0, 0, cv::INTER_NEAREST);
        } else
            cv::grabCut(img(crop), gc, box, bgd, fgd, iterations, cv::GC_INIT_WITH_RECT);
        for (int y = 0; y < bh; y++)
            for (int x = 0; x < bw; x++) {
                uint8_t v = gc.at<uint8_t>(box.y + y, box.x + x);
                if (v == cv::GC_FGD || v == cv::GC_PR_FGD)
                    mask[(size_t)(y0 + y) * width + (size_t)(x0 + x)] = 1;
            }
        return 0;
    });
}

extern "C" void sp_cv_hog_close(sp_cv_hog **h)
{
    if (!h || !*h)
        return;
    delete *h;
    *h = nullptr;
}

extern "C" int sp_cv_mog2_open(sp_cv_mog2 **out, int history, double var_threshold, int detect_shadows)
{
    if (!out || history < 1 || !(var_threshold > 0))
        return -EINVAL;
    *out = nullptr;
    sp_cv::quiet_opencv();
    sp_cv_mog2 *m = new (std::nothrow) sp_cv_mog2;
    if (!m)
        return -ENOMEM;
    int rc = guarded("MOG2", [&]() -> int {
        m->mog = cv::createBackgroundSubtractorMOG2(history, var_threshold, detect_shadows != 0);
        return m->mog ? 0 : -EIO;
    });
    if (rc) {
        delete m;
        return rc;
    }
    *out = m;
    return 0;
}

extern "C" int sp_cv_mog2_apply(sp_cv_mog2 *m, const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride,
                                uint8_t *mask, uint32_t mask_stride)
{
    if (!m || !rgb || !mask || stride < width * 3 || mask_stride < width)
        return -EINVAL;
    return guarded("MOG2 apply", [&]() -> int {
        cv::Mat img((int)height, (int)width, CV_8UC3, const_cast<uint8_t *>(rgb), stride);
        cv::Mat out((int)height, (int)width, CV_8UC1, mask, mask_stride);
        m->mog->apply(img, out);
        return out.data == mask ? 0 : -EIO; /* OpenCV must have written into our buffer */
    });
}

extern "C" void sp_cv_mog2_close(sp_cv_mog2 **m)
{
    if (!m || !*m)
        return;
    delete *m;
    *m = nullptr;
}

extern "C" void sp_cv_set_threads(int n)
{
    guarded("threads", [&]() -> int {
        cv::setNumThreads(n);
        return 0;
    });
}
