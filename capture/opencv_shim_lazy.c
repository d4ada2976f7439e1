/* SPDX-License-Identifier: MIT */
/* opencv_shim.h's functions forwarded to the sunprobe-opencv-import module, loaded on first use (common/module.h). */
#include "opencv_shim.h"

#include <errno.h>
#include <stddef.h>

#include "common/module.h"

typedef int (*video_open_fn)(sp_cv_video_reader **, const char *, sp_cv_video_info *);
typedef int (*video_read_fn)(sp_cv_video_reader *, uint8_t *, size_t, uint32_t);
typedef void (*video_close_fn)(sp_cv_video_reader **);
typedef int (*image_read_fn)(const char *, uint8_t **, size_t *, uint32_t *, uint32_t *);
typedef int (*image_decode_fn)(const uint8_t *, size_t, uint8_t **, size_t *, uint32_t *, uint32_t *);
typedef int (*writer_open_fn)(sp_cv_video_writer **, const char *, uint32_t, uint32_t, double);
typedef int (*video_write_fn)(sp_cv_video_writer *, const uint8_t *, uint32_t);
typedef int (*writer_close_fn)(sp_cv_video_writer **);
typedef int (*track_corners_fn)(const uint8_t *, const uint8_t *, uint32_t, uint32_t, const uint8_t *, const double *,
                                unsigned, double, double, double, float *, unsigned *);

/* name's function from the module, looked up once (each forwarder has its slot, name##_slot) */
#define SYMBOL(type, name) ((type)sp_module_symbol_cached(&sp_module_opencv_import, #name, &name##_slot))

static sp_module_slot sp_cv_video_open_slot;
int sp_cv_video_open(sp_cv_video_reader **out, const char *path, sp_cv_video_info *info)
{
    video_open_fn fn = SYMBOL(video_open_fn, sp_cv_video_open);
    return fn ? fn(out, path, info) : SP_EMODULE;
}

static sp_module_slot sp_cv_video_read_slot;
int sp_cv_video_read(sp_cv_video_reader *r, uint8_t *dst, size_t dst_size, uint32_t dst_stride)
{
    video_read_fn fn = SYMBOL(video_read_fn, sp_cv_video_read);
    return fn ? fn(r, dst, dst_size, dst_stride) : SP_EMODULE;
}

typedef int (*video_time_fn)(sp_cv_video_reader *, int64_t *);
static sp_module_slot sp_cv_video_time_ns_slot;
int sp_cv_video_time_ns(sp_cv_video_reader *r, int64_t *out)
{
    video_time_fn fn = SYMBOL(video_time_fn, sp_cv_video_time_ns);
    return fn ? fn(r, out) : SP_EMODULE;
}

static sp_module_slot sp_cv_video_close_slot;
void sp_cv_video_close(sp_cv_video_reader **r)
{
    video_close_fn fn = r && *r ? SYMBOL(video_close_fn, sp_cv_video_close) : NULL; /* nothing open: no load */
    if (fn)
        fn(r);
}

static sp_module_slot sp_cv_image_read_slot;
int sp_cv_image_read(const char *path, uint8_t **buf, size_t *cap, uint32_t *width, uint32_t *height)
{
    image_read_fn fn = SYMBOL(image_read_fn, sp_cv_image_read);
    return fn ? fn(path, buf, cap, width, height) : SP_EMODULE;
}

static sp_module_slot sp_cv_image_decode_slot;
int sp_cv_image_decode(const uint8_t *data, size_t size, uint8_t **buf, size_t *cap, uint32_t *width,
                       uint32_t *height)
{
    image_decode_fn fn = SYMBOL(image_decode_fn, sp_cv_image_decode);
    return fn ? fn(data, size, buf, cap, width, height) : SP_EMODULE;
}

static sp_module_slot sp_cv_video_writer_open_slot;
int sp_cv_video_writer_open(sp_cv_video_writer **out, const char *path, uint32_t width, uint32_t height,
                            double fps)
{
    writer_open_fn fn = SYMBOL(writer_open_fn, sp_cv_video_writer_open);
    return fn ? fn(out, path, width, height, fps) : SP_EMODULE;
}

static sp_module_slot sp_cv_video_write_slot;
int sp_cv_video_write(sp_cv_video_writer *w, const uint8_t *rgb, uint32_t stride)
{
    video_write_fn fn = SYMBOL(video_write_fn, sp_cv_video_write);
    return fn ? fn(w, rgb, stride) : SP_EMODULE;
}

static sp_module_slot sp_cv_video_writer_close_slot;
int sp_cv_video_writer_close(sp_cv_video_writer **w)
{
    if (!w || !*w)
        return 0;
    writer_close_fn fn = SYMBOL(writer_close_fn, sp_cv_video_writer_close);
    return fn ? fn(w) : SP_EMODULE;
}

static sp_module_slot sp_cv_track_corners_slot;
int sp_cv_track_corners(const uint8_t *from, const uint8_t *to, uint32_t width, uint32_t height, const uint8_t *mask,
                        const double guess[9], unsigned max_corners, double min_distance, double min_eigen,
                        double max_fb_px, float *pairs, unsigned *n)
{
    track_corners_fn fn = SYMBOL(track_corners_fn, sp_cv_track_corners);
    return fn ? fn(from, to, width, height, mask, guess, max_corners, min_distance, min_eigen, max_fb_px, pairs, n)
              : SP_EMODULE;
}
