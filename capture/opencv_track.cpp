/* SPDX-License-Identifier: MIT */
/* OpenCV's corner detector and pyramidal Lucas-Kanade behind a C API, for the visual orientation tracker. */
#include "opencv_shim.h"

#include <cerrno>
#include <cmath>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "opencv_guard.hpp"

namespace
{

/* the point x, y moved by the 3x3 homography H (row-major); false when it maps to infinity */
bool map_point(const double H[9], float x, float y, cv::Point2f &out)
{
    double u = H[0] * x + H[1] * y + H[2], v = H[3] * x + H[4] * y + H[5], w = H[6] * x + H[7] * y + H[8];
    if (!(std::fabs(w) > 1e-9))
        return false;
    out = cv::Point2f((float)(u / w), (float)(v / w));
    return std::isfinite(out.x) && std::isfinite(out.y);
}

} // namespace

extern "C" int sp_cv_track_corners(const uint8_t *from, const uint8_t *to, uint32_t width, uint32_t height,
                                   const uint8_t *mask, const double guess[9], unsigned max_corners,
                                   double min_distance, double min_eigen, double max_fb_px, float *pairs, unsigned *n)
{
    if (!from || !to || !guess || !pairs || !n || width < 16 || height < 16 || !max_corners)
        return -EINVAL;
    *n = 0;
    sp_cv::quiet_opencv();
    return sp_cv::guarded("track corners", [&]() -> int {
        cv::Mat a((int)height, (int)width, CV_8UC1, const_cast<uint8_t *>(from));
        cv::Mat b((int)height, (int)width, CV_8UC1, const_cast<uint8_t *>(to));
        cv::Mat m;
        if (mask)
            m = cv::Mat((int)height, (int)width, CV_8UC1, const_cast<uint8_t *>(mask));
        std::vector<cv::Point2f> p0, p1, back;
        cv::goodFeaturesToTrack(a, p0, (int)max_corners, 0.01, min_distance, m, 5);
        if (p0.size() < 2)
            return 0;
        /* the detector's threshold is relative to the strongest corner: on a flat image it finds noise */
        cv::Mat eig;
        if (min_eigen > 0)
            cv::cornerMinEigenVal(a, eig, 5, 3);
        std::vector<cv::Point2f> start;
        for (const cv::Point2f &p : p0) {
            cv::Point2f q;
            if (min_eigen > 0 && eig.at<float>((int)std::lround(p.y), (int)std::lround(p.x)) < min_eigen)
                continue;
            if (map_point(guess, p.x, p.y, q))
                start.push_back(p), p1.push_back(q);
        }
        if (start.size() < 2)
            return 0;
        std::vector<uchar> ok, ok_back;
        std::vector<float> err;
        const cv::Size win(21, 21);
        const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
        cv::calcOpticalFlowPyrLK(a, b, start, p1, ok, err, win, 3, stop, cv::OPTFLOW_USE_INITIAL_FLOW);
        back = start; /* the way back starts where it should end */
        cv::calcOpticalFlowPyrLK(b, a, p1, back, ok_back, err, win, 3, stop, cv::OPTFLOW_USE_INITIAL_FLOW);
        unsigned k = 0;
        for (size_t i = 0; i < start.size(); i++) {
            if (!ok[i] || !ok_back[i] || cv::norm(back[i] - start[i]) > max_fb_px)
                continue;
            if (p1[i].x < 0 || p1[i].y < 0 || p1[i].x > (float)(width - 1) || p1[i].y > (float)(height - 1))
                continue;
            pairs[4 * k] = start[i].x, pairs[4 * k + 1] = start[i].y;
            pairs[4 * k + 2] = p1[i].x, pairs[4 * k + 3] = p1[i].y;
            k++;
        }
        *n = k;
        return 0;
    });
}
