/* SPDX-License-Identifier: MIT */
/* OpenImageIO behind a C API: float maps to OpenEXR; exceptions stop here. */
#include "oiio_shim.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
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
    spec.attribute("DateTime", ""); /* else the writer stamps the clock's time: the same run, other bytes */
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

struct sp_tiled_image {
    std::unique_ptr<OIIO::ImageOutput> out;
    std::string path;
    uint32_t width, height, tile, rows_in = 0, rows_out = 0;
    std::unique_ptr<float[]> band; /* one row of tiles */
};

namespace {

/* The buffered tile row (rows_out .. rows_in) to the file, every tile of it. */
int flush_tiles(sp_tiled_image *t)
{
    uint32_t h = t->rows_in - t->rows_out;
    bool ok = t->out->write_tiles(0, (int)t->width, (int)t->rows_out, (int)(t->rows_out + h), 0, 1,
                                  OIIO::TypeDesc::FLOAT, t->band.get());
    if (!ok) {
        sp_log(SP_LOG_ERROR, "oiio", "%s: %s", t->path.c_str(), t->out->geterror().c_str());
        return -EIO;
    }
    t->rows_out = t->rows_in;
    return 0;
}

} // namespace

extern "C" int sp_tiled_open(sp_tiled_image **out, const char *path, uint32_t width, uint32_t height, uint32_t tile)
{
    if (!out || !path || !width || !height || tile < 16 || tile % 16 || width > (1u << 30) || height > (1u << 30))
        return -EINVAL;
    *out = nullptr;
    return guarded(path, [&] {
        std::unique_ptr<sp_tiled_image> t(new sp_tiled_image());
        t->path = path;
        t->width = width, t->height = height, t->tile = tile;
        t->out = OIIO::ImageOutput::create(path);
        if (!t->out || !t->out->supports("tiles")) {
            sp_log(SP_LOG_ERROR, "oiio", "%s: no tiled writer for this extension", path);
            return -EINVAL;
        }
        bool exr = t->out->format_name() == std::string("openexr");
        OIIO::ImageSpec spec((int)width, (int)height, 3, exr ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8);
        spec.tile_width = spec.tile_height = (int)tile;
        spec.attribute("compression", "zip");
        spec.attribute("DateTime", ""); /* reproducible bytes, as above */
        t->band.reset(new float[(size_t)width * tile * 3]);
        if (!t->out->open(path, spec)) {
            sp_log(SP_LOG_ERROR, "oiio", "%s: %s", path, t->out->geterror().c_str());
            return -EIO;
        }
        *out = t.release();
        return 0;
    });
}

extern "C" int sp_tiled_rows(sp_tiled_image *t, uint32_t n, const float *rgb)
{
    if (!t || !rgb || n > t->height - t->rows_in)
        return -EINVAL;
    return guarded(t->path.c_str(), [&] {
        for (uint32_t y = 0; y < n; y++) {
            std::memcpy(t->band.get() + (size_t)(t->rows_in - t->rows_out) * t->width * 3,
                        rgb + (size_t)y * t->width * 3, sizeof(float) * 3 * t->width);
            t->rows_in++;
            if (t->rows_in - t->rows_out == t->tile || t->rows_in == t->height) {
                int ret = flush_tiles(t);
                if (ret)
                    return ret;
            }
        }
        return 0;
    });
}

extern "C" int sp_tiled_close(sp_tiled_image **tp)
{
    sp_tiled_image *t = tp ? *tp : nullptr;
    if (!t)
        return 0;
    *tp = nullptr;
    int ret = guarded(t->path.c_str(), [&] {
        int r = t->rows_out == t->height ? 0 : -EINVAL;
        if (!t->out->close() && !r) {
            sp_log(SP_LOG_ERROR, "oiio", "%s: %s", t->path.c_str(), t->out->geterror().c_str());
            r = -EIO;
        }
        return r;
    });
    delete t;
    return ret;
}

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
