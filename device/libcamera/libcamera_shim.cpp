/* SPDX-License-Identifier: MIT */
/*
 * libcamera behind a C interface (libcamera 0.0.3, C++17). One CameraManager per
 * process, shared by enumeration and open cameras. Completed requests are copied
 * into pooled sp_frames on libcamera's thread, queued for sp_lc_next, and the
 * request goes straight back to the camera.
 */
#include "device/libcamera/libcamera_shim.h"

#include <cerrno>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <sys/mman.h>

#include <libcamera/libcamera.h>

using namespace libcamera;

namespace {

std::mutex g_manager_lock;
std::unique_ptr<CameraManager> g_manager;
int g_manager_users = 0;

/* The process-wide manager, started on first use; pair with release_manager. */
CameraManager *acquire_manager()
{
    std::lock_guard<std::mutex> hold(g_manager_lock);
    if (!g_manager) {
        /* libcamera's info and warnings (missing IPA modules, ...) are not the user's business by default */
        setenv("LIBCAMERA_LOG_LEVELS", "*:ERROR", 0);
        auto cm = std::make_unique<CameraManager>();
        if (cm->start() < 0)
            return nullptr;
        g_manager = std::move(cm);
    }
    g_manager_users++;
    return g_manager.get();
}

void release_manager()
{
    std::lock_guard<std::mutex> hold(g_manager_lock);
    if (--g_manager_users == 0) {
        g_manager->stop();
        g_manager.reset();
    }
}

struct ManagerRef {
    CameraManager *cm = acquire_manager();
    ~ManagerRef()
    {
        if (cm)
            release_manager();
    }
};

struct FormatMap {
    sp_pixfmt sp;
    PixelFormat lc;
};

/* sunprobe's RGB24 is R,G,B in memory, which DRM (and libcamera) call BGR888. */
const FormatMap kFormats[] = {
    { SP_PIXFMT_YUYV, formats::YUYV },    { SP_PIXFMT_NV12, formats::NV12 },  { SP_PIXFMT_MJPEG, formats::MJPEG },
    { SP_PIXFMT_RGB24, formats::BGR888 }, { SP_PIXFMT_GRAY8, formats::R8 },
};

sp_pixfmt to_sp(const PixelFormat &f)
{
    for (const auto &m : kFormats)
        if (m.lc == f)
            return m.sp;
    return SP_PIXFMT_NONE;
}

void copy_str(char *dst, size_t size, const std::string &s)
{
    std::snprintf(dst, size, "%s", s.c_str());
}

std::string model_of(const Camera &cam)
{
    auto model = cam.properties().get(properties::Model);
    return model ? *model : cam.id();
}

void describe(const Camera &cam, sp_camera_desc *d)
{
    std::memset(d, 0, sizeof(*d));
    copy_str(d->backend, sizeof(d->backend), "libcamera");
    copy_str(d->id, sizeof(d->id), cam.id());
    copy_str(d->name, sizeof(d->name), model_of(cam));
    copy_str(d->driver, sizeof(d->driver), "libcamera");
}

std::shared_ptr<Camera> find_camera(CameraManager *cm, const char *device)
{
    for (const auto &cam : cm->cameras())
        if (!device || cam->id() == device || model_of(*cam) == device)
            return cam;
    return nullptr;
}

} /* namespace */

struct sp_lc_camera {
    ManagerRef mgr;
    std::shared_ptr<Camera> cam;
    bool acquired = false;
    std::unique_ptr<CameraConfiguration> config;
    std::unique_ptr<FrameBufferAllocator> alloc;
    Stream *stream = nullptr;
    std::vector<std::unique_ptr<Request>> requests;
    std::map<const FrameBuffer *, std::vector<std::pair<uint8_t *, size_t>>> planes; /* mapped planes */
    std::vector<std::pair<void *, size_t>> maps;
    sp_frame_pool *pool = nullptr;
    sp_pixfmt format = SP_PIXFMT_NONE;
    uint32_t width = 0, height = 0, stride = 0;
    double fps = 0;
    bool lock_exposure = false;
    double lock_settle_s = 0;
    int64_t lock_at_ns = 0; /* first frame time + settle; 0 until streaming */
    bool lock_sent = false;
    sp_camera_info *info = nullptr; /* the wrapper's, valid until close */
    std::mutex m;
    std::condition_variable cv;
    std::deque<sp_frame *> ready;
    bool running = false, gone = false;
    uint64_t dropped = 0;

    ~sp_lc_camera();
    void completed(Request *req);
    void lock_when_settled(Request *req, uint64_t frame_ns);
    void disconnected();
    int map_buffers();
    sp_frame *copy_frame(Request *req, const FrameBuffer *fb);
};

sp_lc_camera::~sp_lc_camera()
{
    if (running)
        cam->stop();
    if (cam) {
        cam->requestCompleted.disconnect(this);
        cam->disconnected.disconnect(this);
    }
    requests.clear();
    for (auto &mp : maps)
        munmap(mp.first, mp.second);
    alloc.reset();
    if (acquired)
        cam->release();
    cam.reset();
    for (sp_frame *f : ready)
        sp_frame_unref(&f);
    sp_frame_pool_close(&pool);
}

extern "C" int sp_lc_enumerate(sp_camera_desc *out, size_t max, size_t *count)
{
    ManagerRef ref;
    if (!ref.cm)
        return -EIO;
    size_t n = 0;
    for (const auto &cam : ref.cm->cameras()) {
        if (n < max)
            describe(*cam, &out[n]);
        n++;
    }
    *count = n;
    return 0;
}

extern "C" int sp_lc_modes(const char *id, sp_camera_mode *out, size_t max, size_t *count)
{
    ManagerRef ref;
    std::shared_ptr<Camera> cam = ref.cm ? find_camera(ref.cm, id) : nullptr;
    if (!cam)
        return -ENODEV;
    std::unique_ptr<CameraConfiguration> cfg = cam->generateConfiguration({ StreamRole::VideoRecording });
    if (!cfg || cfg->empty())
        return -EIO;
    const StreamFormats &formats = cfg->at(0).formats();
    size_t n = 0;
    for (const PixelFormat &pf : formats.pixelformats()) {
        sp_pixfmt f = to_sp(pf);
        if (f == SP_PIXFMT_NONE)
            continue;
        std::vector<Size> sizes = formats.sizes(pf);
        if (sizes.empty()) {
            SizeRange r = formats.range(pf);
            sizes = { r.min, r.max };
        }
        for (const Size &s : sizes) {
            if (n < max)
                out[n] = sp_camera_mode{ f, s.width, s.height, 0.0 };
            n++;
        }
    }
    *count = n;
    return 0;
}

extern "C" int sp_lc_claims(const char *device)
{
    if (device && (!std::strncmp(device, "/dev/", 5) || !std::strncmp(device, "fake", 4)))
        return 0;
    ManagerRef ref;
    return ref.cm && find_camera(ref.cm, device) != nullptr;
}

static int configure(sp_lc_camera *c, const sp_camera_settings *s)
{
    c->config = c->cam->generateConfiguration({ StreamRole::VideoRecording });
    if (!c->config || c->config->empty())
        return -EIO;
    StreamConfiguration &sc = c->config->at(0);
    for (const auto &m : kFormats)
        if (m.sp == (s->format != SP_PIXFMT_NONE ? s->format : SP_PIXFMT_YUYV))
            sc.pixelFormat = m.lc;
    sc.size = Size(s->width ? s->width : 640, s->height ? s->height : 480);
    sc.bufferCount = s->buffers;
    if (c->config->validate() == CameraConfiguration::Invalid)
        return SP_EUNSUPPORTED;
    c->format = to_sp(sc.pixelFormat);
    if (c->format == SP_PIXFMT_NONE || (s->format != SP_PIXFMT_NONE && c->format != s->format))
        return SP_EUNSUPPORTED;
    int err = c->cam->configure(c->config.get());
    if (err < 0)
        return err;
    c->stream = sc.stream();
    c->width = sc.size.width;
    c->height = sc.size.height;
    c->stride = c->format == SP_PIXFMT_MJPEG ? 0 : std::max(sc.stride, sp_pixfmt_min_stride(c->format, c->width));
    return 0;
}

/* mmaps every plane of every allocated buffer (planes may share one dmabuf at different offsets). */
int sp_lc_camera::map_buffers()
{
    for (const std::unique_ptr<FrameBuffer> &fb : alloc->buffers(stream)) {
        std::vector<std::pair<uint8_t *, size_t>> mapped;
        for (const FrameBuffer::Plane &p : fb->planes()) {
            size_t len = (size_t)p.offset + p.length;
            void *base = mmap(nullptr, len, PROT_READ, MAP_SHARED, p.fd.get(), 0);
            if (base == MAP_FAILED)
                return -errno;
            maps.emplace_back(base, len);
            mapped.emplace_back((uint8_t *)base + p.offset, (size_t)p.length);
        }
        planes[fb.get()] = mapped;
    }
    return 0;
}

static int make_requests(sp_lc_camera *c)
{
    for (const std::unique_ptr<FrameBuffer> &fb : c->alloc->buffers(c->stream)) {
        std::unique_ptr<Request> req = c->cam->createRequest();
        if (!req || req->addBuffer(c->stream, fb.get()) < 0)
            return -ENOMEM;
        c->requests.push_back(std::move(req));
    }
    return 0;
}

extern "C" int sp_lc_open(sp_lc_camera **out, const sp_camera_settings *s, sp_camera_info *info)
{
    auto c = std::make_unique<sp_lc_camera>();
    if (!c->mgr.cm)
        return -EIO;
    c->cam = find_camera(c->mgr.cm, s->device);
    if (!c->cam)
        return -ENODEV;
    if (c->cam->acquire() < 0)
        return -EBUSY;
    c->acquired = true;
    int err = configure(c.get(), s);
    if (err < 0)
        return err;
    c->alloc = std::make_unique<FrameBufferAllocator>(c->cam);
    if (c->alloc->allocate(c->stream) < 0)
        return -ENOMEM;
    if ((err = c->map_buffers()) < 0 || (err = make_requests(c.get())) < 0)
        return err;
    size_t bytes = c->config->at(0).frameSize;
    if (c->format != SP_PIXFMT_MJPEG)
        bytes = std::max(bytes, sp_pixfmt_image_size(c->format, c->width, c->height, c->stride));
    if ((err = sp_frame_pool_open(&c->pool, s->pool_frames, bytes)) < 0)
        return err;
    c->fps = s->fps;
    c->lock_exposure = s->lock_exposure != 0;
    c->lock_settle_s = s->lock_settle_s;
    c->cam->requestCompleted.connect(c.get(), &sp_lc_camera::completed);
    c->cam->disconnected.connect(c.get(), &sp_lc_camera::disconnected);
    std::memset(info, 0, sizeof(*info));
    describe(*c->cam, &info->desc);
    info->format = c->format;
    info->width = c->width;
    info->height = c->height;
    info->stride = c->stride;
    info->fps = c->fps;
    const ControlInfoMap &ctl = c->cam->controls();
    c->lock_exposure = c->lock_exposure && ctl.count(&controls::AeEnable) > 0;
    info->exposure_locked = c->lock_exposure; /* the lock goes out with a request once AE settled */
    info->monotonic_timestamps = 1; /* libcamera stamps buffers on CLOCK_MONOTONIC */
    c->info = info;
    *out = c.release();
    return 0;
}

extern "C" int sp_lc_start(sp_lc_camera *c)
{
    ControlList ctrls(c->cam->controls());
    const ControlInfoMap &info = c->cam->controls();
    if (c->fps > 0 && info.count(&controls::FrameDurationLimits)) {
        int64_t us = (int64_t)std::llround(1e6 / c->fps);
        const int64_t lim[2] = { us, us };
        ctrls.set(controls::FrameDurationLimits, Span<const int64_t, 2>(lim));
    }
    if (c->lock_exposure && c->lock_settle_s <= 0) {
        ctrls.set(controls::AeEnable, false);
        if (info.count(&controls::AwbEnable))
            ctrls.set(controls::AwbEnable, false);
        c->lock_sent = true;
    }
    int err = c->cam->start(&ctrls);
    if (err < 0)
        return err;
    {
        std::lock_guard<std::mutex> hold(c->m);
        c->running = true;
    }
    for (auto &req : c->requests)
        if ((err = c->cam->queueRequest(req.get())) < 0)
            return err;
    return 0;
}

sp_frame *sp_lc_camera::copy_frame(Request *req, const FrameBuffer *fb)
{
    sp_frame *f = nullptr;
    if (sp_frame_pool_get(pool, &f) < 0)
        return nullptr;
    const auto &mapped = planes[fb];
    const FrameMetadata &md = fb->metadata();
    size_t used = 0;
    for (size_t i = 0; i < mapped.size(); i++) {
        size_t n = i < md.planes().size() ? md.planes()[i].bytesused : mapped[i].second;
        n = std::min(n, std::min(mapped[i].second, f->capacity - used));
        std::memcpy(f->data + used, mapped[i].first, n);
        used += n;
    }
    f->bytes_used = used;
    f->format = format;
    f->width = width;
    f->height = height;
    f->stride = stride;
    f->sequence = md.sequence;
    f->timestamp_ns = (int64_t)md.timestamp;
    auto exp = req->metadata().get(controls::ExposureTime);
    auto gain = req->metadata().get(controls::AnalogueGain);
    f->exposure_us = exp ? (float)*exp : NAN;
    f->gain = gain ? *gain : NAN;
    return f;
}

/* Once the settle time has passed since the first frame, the next request carries the lock (AE/AWB off). */
void sp_lc_camera::lock_when_settled(Request *req, uint64_t frame_ns)
{
    if (!lock_exposure || lock_sent)
        return;
    if (lock_at_ns == 0)
        lock_at_ns = (int64_t)frame_ns + (int64_t)(lock_settle_s * 1e9);
    if ((int64_t)frame_ns < lock_at_ns)
        return;
    req->controls().set(controls::AeEnable, false);
    if (cam->controls().count(&controls::AwbEnable))
        req->controls().set(controls::AwbEnable, false);
    lock_sent = true;
}

/* Runs on libcamera's thread. */
void sp_lc_camera::completed(Request *req)
{
    if (req->status() == Request::RequestCancelled)
        return;
    const FrameBuffer *fb = req->buffers().begin()->second;
    sp_frame *f = nullptr;
    bool settling = lock_exposure && !lock_sent; /* frames before the lock are not delivered */
    if (fb->metadata().status == FrameMetadata::FrameSuccess && !settling)
        f = copy_frame(req, fb);
    std::lock_guard<std::mutex> hold(m);
    if (f)
        ready.push_back(f);
    else if (!settling)
        dropped++;
    cv.notify_one();
    if (running) {
        req->reuse(Request::ReuseBuffers);
        lock_when_settled(req, fb->metadata().timestamp);
        cam->queueRequest(req);
    }
}

void sp_lc_camera::disconnected()
{
    std::lock_guard<std::mutex> hold(m);
    gone = true;
    cv.notify_one();
}

extern "C" int sp_lc_next(sp_lc_camera *c, int timeout_ms, sp_frame **out)
{
    std::unique_lock<std::mutex> hold(c->m);
    c->cv.wait_for(hold, std::chrono::milliseconds(timeout_ms), [c] { return !c->ready.empty() || c->gone; });
    if (!c->ready.empty()) {
        *out = c->ready.front();
        c->ready.pop_front();
        return 0;
    }
    return c->gone ? -ENODEV : -EAGAIN;
}

extern "C" int sp_lc_stop(sp_lc_camera *c)
{
    {
        std::lock_guard<std::mutex> hold(c->m);
        if (!c->running)
            return 0;
        c->running = false;
    }
    int err = c->cam->stop();
    return err == -ENODEV ? 0 : err;
}

extern "C" uint64_t sp_lc_dropped(sp_lc_camera *c)
{
    std::lock_guard<std::mutex> hold(c->m);
    return c->dropped;
}

extern "C" void sp_lc_close(sp_lc_camera *c)
{
    delete c;
}
