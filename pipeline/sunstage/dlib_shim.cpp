/* SPDX-License-Identifier: MIT */
/* dlib behind a C interface: exceptions stay inside, errors become codes. */
#include "pipeline/sunstage/dlib_shim.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <fstream>
#include <new>

#include <dlib/image_processing.h>
#include <dlib/image_processing/frontal_face_detector.h>

#include "sunprobe/sp_common.h"

namespace {
struct dlib_ctx {
    dlib::frontal_face_detector detector = dlib::get_frontal_face_detector();
    dlib::shape_predictor predictor;
};
} // namespace

extern "C" int sp_dlib_open(void **ctx, const char *path)
{
    if (!ctx || !path)
        return -EINVAL;
    *ctx = nullptr;
    std::ifstream probe(path, std::ios::binary);
    if (!probe)
        return -ENOENT;
    probe.close();
    try {
        auto *c = new dlib_ctx;
        dlib::deserialize(path) >> c->predictor;
        *ctx = c;
        return 0;
    } catch (const std::bad_alloc &) {
        return -ENOMEM;
    } catch (...) {
        return SP_ECORRUPT;
    }
}

extern "C" void sp_dlib_close(void *ctx)
{
    delete static_cast<dlib_ctx *>(ctx);
}

namespace {
// dlib wants its own image type; the copy is small next to what the detector does with it.
void to_dlib(const uint8_t *gray, int w, int h, dlib::array2d<unsigned char> &img)
{
    img.set_size(h, w);
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            img[y][x] = gray[(size_t)y * (size_t)w + (size_t)x];
}
} // namespace

extern "C" int sp_dlib_detect(void *ctx, const uint8_t *gray, int w, int h, double adjust, sp_dlib_face *faces,
                              int max)
{
    if (!ctx || !gray || w <= 0 || h <= 0 || !faces || max <= 0)
        return -EINVAL;
    auto *c = static_cast<dlib_ctx *>(ctx);
    try {
        dlib::array2d<unsigned char> img;
        to_dlib(gray, w, h, img);
        std::vector<dlib::rect_detection> found;
        c->detector(img, found, adjust);
        std::sort(found.begin(), found.end(),
                  [](const dlib::rect_detection &a, const dlib::rect_detection &b) {
                      return a.detection_confidence > b.detection_confidence;
                  });
        int n = 0;
        for (const auto &d : found) {
            if (n == max)
                break;
            const dlib::rectangle &r = d.rect;
            faces[n++] = sp_dlib_face{ { (double)r.left(), (double)r.top(), (double)r.right(), (double)r.bottom() },
                                       d.detection_confidence };
        }
        return n;
    } catch (const std::bad_alloc &) {
        return -ENOMEM;
    } catch (...) {
        return SP_ENODATA;
    }
}

extern "C" int sp_dlib_shape(void *ctx, const uint8_t *gray, int w, int h, const double box[4], float lm[136])
{
    if (!ctx || !gray || w <= 0 || h <= 0 || !box || !lm)
        return -EINVAL;
    auto *c = static_cast<dlib_ctx *>(ctx);
    try {
        dlib::array2d<unsigned char> img;
        to_dlib(gray, w, h, img);
        dlib::rectangle r((long)std::lround(box[0]), (long)std::lround(box[1]), (long)std::lround(box[2]),
                          (long)std::lround(box[3]));
        dlib::full_object_detection shape = c->predictor(img, r);
        if (shape.num_parts() != 68)
            return SP_ENODATA;
        for (unsigned k = 0; k < 68; k++) {
            lm[2 * k] = (float)shape.part(k).x();
            lm[2 * k + 1] = (float)shape.part(k).y();
        }
        return 0;
    } catch (const std::bad_alloc &) {
        return -ENOMEM;
    } catch (...) {
        return SP_ENODATA;
    }
}
