/* SPDX-License-Identifier: MIT */
/* OpenImageIO behind a C API: float maps to OpenEXR; exceptions stop here. */
#include "oiio_shim.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>

#include <unistd.h>

#include <OpenImageIO/imageio.h>

#include "sunprobe/sp_common.h"

namespace {

int write_exr(const std::string &path, const float *pixels, uint32_t width, uint32_t height, int channels)
{
    auto out = OIIO::ImageOutput::create(path);
    if (!out) {
        sp_log(SP_LOG_ERROR, "oiio", "%s: %s", path.c_str(), OIIO::geterror().c_str());
        return -EIO;
    }
    OIIO::ImageSpec spec((int)width, (int)height, channels, OIIO::TypeDesc::FLOAT);
    spec.attribute("compression", "zip");
    bool ok = out->open(path, spec) && out->write_image(OIIO::TypeDesc::FLOAT, pixels);
    if (!ok)
        sp_log(SP_LOG_ERROR, "oiio", "%s: %s", path.c_str(), out->geterror().c_str());
    ok = out->close() && ok;
    return ok ? 0 : -EIO;
}

int read_rgb(const char *path, float **rgb, uint32_t *width, uint32_t *height)
{
    auto in = OIIO::ImageInput::open(path);
    if (!in) {
        std::string e = OIIO::geterror();
        sp_log(SP_LOG_ERROR, "oiio", "%s: %s", path, e.c_str());
        return e.find("No such file") != std::string::npos || e.find("not exist") != std::string::npos ? -ENOENT
                                                                                                         : SP_EFORMAT;
    }
    const OIIO::ImageSpec &spec = in->spec();
    int nc = spec.nchannels;
    if (spec.width < 1 || spec.height < 1 || nc < 1 || (long long)spec.width * spec.height > (1LL << 28)) {
        sp_log(SP_LOG_ERROR, "oiio", "%s: %dx%d with %d channels: not a usable image", path, spec.width, spec.height, nc);
        return SP_EFORMAT;
    }
    size_t n = (size_t)spec.width * (size_t)spec.height;
    std::unique_ptr<float[]> all(new float[n * (size_t)nc]);
    if (!in->read_image(0, 0, 0, nc, OIIO::TypeDesc::FLOAT, all.get())) {
        sp_log(SP_LOG_ERROR, "oiio", "%s: %s", path, in->geterror().c_str());
        return -EIO;
    }
    float *out = static_cast<float *>(std::malloc(sizeof(float) * n * 3));
    if (!out)
        return -ENOMEM;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++)
            out[i * 3 + (size_t)k] = all[i * (size_t)nc + (size_t)(nc >= 3 ? k : 0)];
    *rgb = out;
    *width = (uint32_t)spec.width;
    *height = (uint32_t)spec.height;
    return 0;
}

/* Runs f, turning any exception into an error code with the path logged: none crosses into C. */
template <class F> int guarded(const char *path, F f)
{
    try {
        return f();
    } catch (const std::bad_alloc &) {
        return -ENOMEM;
    } catch (const std::exception &e) {
        sp_log(SP_LOG_ERROR, "oiio", "%s: %s", path, e.what());
        return -EIO;
    } catch (...) {
        sp_log(SP_LOG_ERROR, "oiio", "%s: unknown exception", path);
        return -EIO;
    }
}

} // namespace

extern "C" int sp_image_read_rgb(const char *path, float **rgb, uint32_t *width, uint32_t *height)
{
    if (!path || !rgb || !width || !height)
        return -EINVAL;
    *rgb = nullptr;
    return guarded(path, [&] { return read_rgb(path, rgb, width, height); });
}

extern "C" int sp_exr_write(const char *path, const float *pixels, uint32_t width, uint32_t height, int channels)
{
    if (!path || !pixels || !width || !height || channels < 1 || channels > 4)
        return -EINVAL;
    return guarded(path, [&] {
        /* the temporary keeps the extension: OIIO picks the format by it */
        std::string tmp = std::string(path) + ".tmp." + std::to_string((long)getpid()) + ".exr";
        int ret = write_exr(tmp, pixels, width, height, channels);
        if (!ret && std::rename(tmp.c_str(), path) != 0)
            ret = -errno;
        if (ret)
            std::remove(tmp.c_str());
        return ret;
    });
}
