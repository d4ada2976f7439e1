/* SPDX-License-Identifier: MIT */
/* V4L2 fourcc <-> sp_pixfmt. */
#include "device/v4l2/v4l2_formats.h"

#include <linux/videodev2.h>

static const struct {
    uint32_t fourcc;
    enum sp_pixfmt fmt;
} map[] = {
    { V4L2_PIX_FMT_YUYV, SP_PIXFMT_YUYV },   { V4L2_PIX_FMT_NV12, SP_PIXFMT_NV12 },
    { V4L2_PIX_FMT_MJPEG, SP_PIXFMT_MJPEG }, { V4L2_PIX_FMT_JPEG, SP_PIXFMT_MJPEG },
    { V4L2_PIX_FMT_RGB24, SP_PIXFMT_RGB24 }, { V4L2_PIX_FMT_GREY, SP_PIXFMT_GRAY8 },
};
#define N_MAP (sizeof(map) / sizeof(map[0]))

enum sp_pixfmt sp_v4l2_to_pixfmt(uint32_t fourcc)
{
    for (size_t i = 0; i < N_MAP; i++)
        if (map[i].fourcc == fourcc)
            return map[i].fmt;
    return SP_PIXFMT_NONE;
}

size_t sp_v4l2_from_pixfmt(enum sp_pixfmt fmt, uint32_t *fourccs, size_t max)
{
    size_t n = 0;
    for (size_t i = 0; i < N_MAP && n < max; i++)
        if (map[i].fmt == fmt)
            fourccs[n++] = map[i].fourcc;
    return n;
}
