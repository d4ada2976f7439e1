/* SPDX-License-Identifier: MIT */
/*
 * What both OpenCV shims (capture/opencv_shim.cpp, pipeline/probe/
 * opencv_probe_shim.cpp) need at their C boundary: exceptions turned into
 * error codes with a logged reason, and OpenCV's own logging kept off our
 * stderr unless debugging. C++ only; include after the OpenCV headers.
 */
#ifndef SUNPROBE_CAPTURE_OPENCV_GUARD_HPP
#define SUNPROBE_CAPTURE_OPENCV_GUARD_HPP

#include <cerrno>
#include <exception>
#include <new>

#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>

#include "sunprobe/sp_common.h"

namespace sp_cv {

/* Runs fn (returning 0 or a negative error); an exception becomes -ENOMEM or -EIO with a log line naming what. */
template <typename F> int guarded(const char *what, F &&fn)
{
    try {
        return fn();
    } catch (const std::bad_alloc &) {
        return -ENOMEM;
    } catch (const std::exception &e) { /* cv::Exception included */
        sp_log(SP_LOG_ERROR, "opencv", "%s: %s", what, e.what());
        return -EIO;
    } catch (...) {
        sp_log(SP_LOG_ERROR, "opencv", "%s: unknown exception", what);
        return -EIO;
    }
}

/* OpenCV's log level follows ours: silent unless SP_LOG=debug. Once per process. */
inline void quiet_opencv()
{
    static bool done = false;
    if (done)
        return;
    done = true;
    cv::utils::logging::setLogLevel(sp_log_get_level() >= SP_LOG_DEBUG ? cv::utils::logging::LOG_LEVEL_INFO
                                                                        : cv::utils::logging::LOG_LEVEL_SILENT);
}

} // namespace sp_cv

#endif
