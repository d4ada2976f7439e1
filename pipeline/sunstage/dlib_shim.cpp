/* SPDX-License-Identifier: MIT */
/* dlib behind a C interface: exceptions stay inside, errors become codes. */
#include "pipeline/sunstage/dlib_shim.h"

#include <cerrno>
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

extern "C" int sp_dlib_landmarks(void *ctx, const uint8_t *gray, int w, int h, float lm[136])
{
    if (!ctx || !gray || w <= 0 || h <= 0 || !lm)
        return -EINVAL;
    auto *c = static_cast<dlib_ctx *>(ctx);
    try {
        dlib::array2d<unsigned char> img(h, w);
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++)
                img[y][x] = gray[(size_t)y * (size_t)w + (size_t)x];
        std::vector<dlib::rectangle> faces = c->detector(img);
        if (faces.empty())
            return SP_ENODATA;
        size_t best = 0;
        for (size_t i = 1; i < faces.size(); i++)
            if (faces[i].area() > faces[best].area())
                best = i;
        dlib::full_object_detection shape = c->predictor(img, faces[best]);
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
