/* SPDX-License-Identifier: MIT */
/*
 * Internal: V4L2 fourcc <-> sp_pixfmt, and the YUV 4:2:0 layouts (one or more memory planes, either
 * chroma order) the backend repacks into the pipeline's NV12. Kept apart so it is testable without a
 * device.
 */
#ifndef SUNPROBE_DEVICE_V4L2_FORMATS_H
#define SUNPROBE_DEVICE_V4L2_FORMATS_H

#include <stddef.h>
#include <stdint.h>

#include "sunprobe/sp_frame.h"

/* How a fourcc lays out its pixels in memory. */
typedef struct sp_v4l2_layout {
    uint32_t fourcc;
    enum sp_pixfmt format; /* what the frames carry */
    unsigned buffers;      /* memory planes (V4L2's num_planes): 1, or 2-3 for the "M" formats */
    unsigned planes;       /* colour planes: 1 packed, 2 Y + interleaved chroma, 3 Y, Cb, Cr */
    int cr_first;          /* chroma order Cr before Cb (NV21, YVU420) */
} sp_v4l2_layout;

/* One colour plane of a dequeued buffer. */
typedef struct sp_v4l2_plane {
    const uint8_t *data;
    size_t stride; /* bytes per row */
    size_t size;   /* bytes readable at data */
} sp_v4l2_plane;

/* The layout of a fourcc, NULL when sunprobe cannot use it. */
const sp_v4l2_layout *sp_v4l2_layout_of(uint32_t fourcc);
/* The sunprobe format of a V4L2 fourcc, SP_PIXFMT_NONE when it has none. */
enum sp_pixfmt sp_v4l2_to_pixfmt(uint32_t fourcc);
/* The fourccs that carry a sunprobe format (NV12 has eight layouts, MJPEG two), best first: those
 * stored without repacking, then one memory plane before several. Returns how many were written. */
size_t sp_v4l2_from_pixfmt(enum sp_pixfmt fmt, uint32_t *fourccs, size_t max);
/* A fourcc written as V4L2 prints it ("NM12"); 1-4 characters, shorter ones space-padded. 0 if empty
 * or too long. */
uint32_t sp_v4l2_fourcc_from_string(const char *s);

/*
 * Splits one memory plane holding every colour plane of a 4:2:0 layout (NV12, NV21, YUV420, YVU420)
 * into colour planes: luma rows of `stride` bytes, then the chroma rows (interleaved: `stride` bytes;
 * separate Cb and Cr: stride / 2 each, as V4L2 defines them). Returns the colour planes written, 0
 * when `size` is too small for `height` rows.
 */
unsigned sp_v4l2_split_planes(const sp_v4l2_layout *l, const uint8_t *data, size_t size, size_t stride,
                              uint32_t height, sp_v4l2_plane *planes);
/*
 * Repacks a 4:2:0 image given as colour planes (2 for NV12/NV21, 3 for YUV420/YVU420, Cb and Cr in
 * the layout's order) into NV12 at dst: `height` luma rows then ceil(height / 2) CbCr rows, each
 * dst_stride bytes (at least width rounded up to even). Odd sizes keep the last half chroma sample.
 * 0, or -EINVAL when a plane is too small for the size or dst_stride is too narrow.
 */
int sp_v4l2_to_nv12(const sp_v4l2_layout *l, const sp_v4l2_plane *planes, uint32_t width, uint32_t height,
                    uint8_t *dst, size_t dst_stride);

#endif
