/* SPDX-License-Identifier: MIT */
/* OpenImageIO behind a C API: float maps to OpenEXR; exceptions stop here. */
#include "oiio_shim.h"

#include <cerrno>
#include <cstdio>
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

} // namespace

extern "C" int sp_exr_write(const char *path, const float *pixels, uint32_t width, uint32_t height, int channels)
{
    if (!path || !pixels || !width || !height || channels < 1 || channels > 4)
        return -EINVAL;
    try {
        /* the temporary keeps the extension: OIIO picks the format by it */
        std::string tmp = std::string(path) + ".tmp." + std::to_string((long)getpid()) + ".exr";
        int ret = write_exr(tmp, pixels, width, height, channels);
        if (!ret && std::rename(tmp.c_str(), path) != 0)
            ret = -errno;
        if (ret)
            std::remove(tmp.c_str());
        return ret;
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
