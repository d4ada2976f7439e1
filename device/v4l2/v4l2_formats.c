/* SPDX-License-Identifier: MIT */
/* V4L2 fourcc <-> sp_pixfmt, and repacking the 4:2:0 layouts into NV12. */
#include "device/v4l2/v4l2_formats.h"

#include <errno.h>
#include <string.h>

#include <linux/videodev2.h>

/* Best first within a format: layouts stored as they come (NV12 in one plane), then one memory plane
 * before several (fewer mappings per buffer). */
static const sp_v4l2_layout layouts[] = {
    { V4L2_PIX_FMT_YUYV, SP_PIXFMT_YUYV, 1, 1, 0 },    { V4L2_PIX_FMT_NV12, SP_PIXFMT_NV12, 1, 2, 0 },
    { V4L2_PIX_FMT_NV21, SP_PIXFMT_NV12, 1, 2, 1 },    { V4L2_PIX_FMT_YUV420, SP_PIXFMT_NV12, 1, 3, 0 },
    { V4L2_PIX_FMT_YVU420, SP_PIXFMT_NV12, 1, 3, 1 },  { V4L2_PIX_FMT_NV12M, SP_PIXFMT_NV12, 2, 2, 0 },
    { V4L2_PIX_FMT_NV21M, SP_PIXFMT_NV12, 2, 2, 1 },   { V4L2_PIX_FMT_YUV420M, SP_PIXFMT_NV12, 3, 3, 0 },
    { V4L2_PIX_FMT_YVU420M, SP_PIXFMT_NV12, 3, 3, 1 }, { V4L2_PIX_FMT_MJPEG, SP_PIXFMT_MJPEG, 1, 1, 0 },
    { V4L2_PIX_FMT_JPEG, SP_PIXFMT_MJPEG, 1, 1, 0 },   { V4L2_PIX_FMT_RGB24, SP_PIXFMT_RGB24, 1, 1, 0 },
    { V4L2_PIX_FMT_GREY, SP_PIXFMT_GRAY8, 1, 1, 0 },
};
#define N_LAYOUTS (sizeof(layouts) / sizeof(layouts[0]))

const sp_v4l2_layout *sp_v4l2_layout_of(uint32_t fourcc)
{
    for (size_t i = 0; i < N_LAYOUTS; i++)
        if (layouts[i].fourcc == fourcc)
            return &layouts[i];
    return NULL;
}

enum sp_pixfmt sp_v4l2_to_pixfmt(uint32_t fourcc)
{
    const sp_v4l2_layout *l = sp_v4l2_layout_of(fourcc);
    return l ? l->format : SP_PIXFMT_NONE;
}

size_t sp_v4l2_from_pixfmt(enum sp_pixfmt fmt, uint32_t *fourccs, size_t max)
{
    size_t n = 0;
    for (size_t i = 0; i < N_LAYOUTS && n < max; i++)
        if (layouts[i].format == fmt)
            fourccs[n++] = layouts[i].fourcc;
    return n;
}

uint32_t sp_v4l2_fourcc_from_string(const char *s)
{
    size_t len = s ? strlen(s) : 0;
    if (len == 0 || len > 4)
        return 0;
    char c[4] = { ' ', ' ', ' ', ' ' };
    memcpy(c, s, len);
    return v4l2_fourcc(c[0], c[1], c[2], c[3]);
}

static size_t half_up(size_t v)
{
    return (v + 1) / 2;
}

/* Bytes a plane must hold for `rows` rows of `row_bytes` at `stride`. */
static int plane_holds(const sp_v4l2_plane *p, size_t row_bytes, size_t rows)
{
    return p->data && p->stride >= row_bytes && rows > 0 && p->size / p->stride >= rows - 1 &&
           p->size - (rows - 1) * p->stride >= row_bytes;
}

unsigned sp_v4l2_split_planes(const sp_v4l2_layout *l, const uint8_t *data, size_t size, size_t stride,
                              uint32_t height, sp_v4l2_plane *planes)
{
    size_t chroma_rows = half_up(height);
    size_t chroma_stride = l->planes == 3 ? stride / 2 : stride;
    size_t luma_bytes = stride * height, chroma_bytes = chroma_stride * chroma_rows;
    if (l->planes < 2 || height == 0 || stride == 0 || stride > SIZE_MAX / height / 2 ||
        size < luma_bytes + (l->planes - 1) * chroma_bytes)
        return 0;
    planes[0] = (sp_v4l2_plane){ data, stride, luma_bytes };
    for (unsigned p = 1; p < l->planes; p++)
        planes[p] = (sp_v4l2_plane){ data + luma_bytes + (p - 1) * chroma_bytes, chroma_stride, chroma_bytes };
    return l->planes;
}

int sp_v4l2_to_nv12(const sp_v4l2_layout *l, const sp_v4l2_plane *planes, uint32_t width, uint32_t height,
                    uint8_t *dst, size_t dst_stride)
{
    size_t cw = half_up(width), ch = half_up(height);
    if (width == 0 || height == 0 || l->planes < 2 || dst_stride < 2 * cw || !plane_holds(&planes[0], width, height))
        return -EINVAL;
    for (unsigned p = 1; p < l->planes; p++)
        if (!plane_holds(&planes[p], l->planes == 2 ? 2 * cw : cw, ch))
            return -EINVAL;
    for (uint32_t y = 0; y < height; y++) { /* padding zeroed: captures stay deterministic */
        memcpy(dst + y * dst_stride, planes[0].data + y * planes[0].stride, width);
        memset(dst + y * dst_stride + width, 0, dst_stride - width);
    }
    uint8_t *uv = dst + (size_t)height * dst_stride;
    /* Cb goes first in NV12: which source plane (or byte of the pair) holds it */
    int cb = l->cr_first ? 1 : 0;
    for (size_t y = 0; y < ch; y++, uv += dst_stride) {
        memset(uv + 2 * cw, 0, dst_stride - 2 * cw);
        if (l->planes == 2) {
            const uint8_t *src = planes[1].data + y * planes[1].stride;
            if (!l->cr_first) {
                memcpy(uv, src, 2 * cw);
                continue;
            }
            for (size_t x = 0; x < cw; x++) {
                uv[2 * x] = src[2 * x + 1];
                uv[2 * x + 1] = src[2 * x];
            }
            continue;
        }
        const uint8_t *cb_row = planes[1 + cb].data + y * planes[1 + cb].stride;
        const uint8_t *cr_row = planes[2 - cb].data + y * planes[2 - cb].stride;
        for (size_t x = 0; x < cw; x++) {
            uv[2 * x] = cb_row[x];
            uv[2 * x + 1] = cr_row[x];
        }
    }
    return 0;
}
