/* SPDX-License-Identifier: MIT */
/*
 * The C face of the OpenCV shim (opencv_shim.cpp, compiled only under HAVE_OPENCV):
 * read video files frame by frame, decode image files, write MJPG .avi or mp4v
 * .mp4 files. All pixels cross this boundary as packed RGB24. No C++ exception
 * escapes: each becomes an error code. Internal, not installed.
 */
#ifndef SUNPROBE_CAPTURE_OPENCV_SHIM_H
#define SUNPROBE_CAPTURE_OPENCV_SHIM_H

#include <stddef.h>
#include <stdint.h>
#include "common/private_api.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct sp_cv_video_reader sp_cv_video_reader;

typedef struct sp_cv_video_info {
    uint32_t width, height;
    double fps;          /* as the container declares it; 0 or NaN when unknown */
    int64_t frame_count; /* as the container declares it (may be approximate); <= 0 when unknown */
} sp_cv_video_info;

/*
 * Opens a video file; `path` is borrowed. Returns 0, -ENOENT when the file is
 * missing, SP_EFORMAT when OpenCV cannot open or decode it.
 */
SP_PRIVATE int sp_cv_video_open(sp_cv_video_reader **out, const char *path, sp_cv_video_info *info);
/*
 * Decodes the next frame into dst as RGB24 (rows dst_stride apart, dst_size
 * bytes). SP_EOS after the last frame; SP_ECORRUPT if the size changes mid-stream.
 */
SP_PRIVATE int sp_cv_video_read(sp_cv_video_reader *r, uint8_t *dst, size_t dst_size, uint32_t dst_stride);
/*
 * The presentation time of the frame the last sp_cv_video_read returned, in ns from the stream's start
 * (the container's timestamps: a variable frame rate keeps its timing). SP_ENODATA when the container
 * gives none.
 */
int sp_cv_video_time_ns(sp_cv_video_reader *r, int64_t *out);
SP_PRIVATE void sp_cv_video_close(sp_cv_video_reader **r);

/*
 * Decodes an image file (PNG, JPEG, BMP, ...; 16-bit and alpha are reduced to
 * 8-bit RGB) into *buf as packed RGB24, growing *buf (malloc'd, *cap bytes,
 * caller frees) as needed. -ENOENT when missing, SP_EFORMAT when unreadable.
 */
int sp_cv_image_read(const char *path, uint8_t **buf, size_t *cap, uint32_t *width, uint32_t *height);
/* The same for an encoded image already in memory (`data` borrowed); SP_EFORMAT when undecodable. */
int sp_cv_image_decode(const uint8_t *data, size_t size, uint8_t **buf, size_t *cap, uint32_t *width,
                       uint32_t *height);

typedef struct sp_cv_video_writer sp_cv_video_writer;

/*
 * Creates a video file: the codec follows the extension (".avi": MJPG, ".mp4": mp4v).
 * -EINVAL for another extension or bad sizes; -EIO when OpenCV cannot open it.
 */
SP_PRIVATE int sp_cv_video_writer_open(sp_cv_video_writer **out, const char *path, uint32_t width, uint32_t height,
                            double fps);
/* Appends one RGB24 frame of the size given at open (rows `stride` bytes apart, borrowed). */
SP_PRIVATE int sp_cv_video_write(sp_cv_video_writer *w, const uint8_t *rgb, uint32_t stride);
/* Finishes the file; *w becomes NULL. */
SP_PRIVATE int sp_cv_video_writer_close(sp_cv_video_writer **w);

/*
 * Rotation tracking (opencv_track.cpp): up to max_corners Shi-Tomasi corners of `from` (8-bit grey,
 * width x height, rows packed; corners only where mask != 0, mask may be NULL), at least min_distance
 * px apart, tracked into `to` by pyramidal Lucas-Kanade starting from where the homography `guess`
 * (3x3 row-major, from -> to pixels) puts them, and kept when tracking back lands within max_fb_px of
 * the start. Corners whose smaller structure-tensor eigenvalue (cv::cornerMinEigenVal, 5x5, on the
 * 0..1 scale OpenCV gives 8-bit images) is under min_eigen are dropped (0: keep all). The kept pairs go to pairs as x0, y0, x1, y1 (room for 4 * max_corners floats); *n of them.
 */
int sp_cv_track_corners(const uint8_t *from, const uint8_t *to, uint32_t width, uint32_t height, const uint8_t *mask,
                        const double guess[9], unsigned max_corners, double min_distance, double min_eigen,
                        double max_fb_px, float *pairs, unsigned *n);

#ifdef __cplusplus
}
#endif
#endif
