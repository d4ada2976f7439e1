/* SPDX-License-Identifier: MIT */
/* The video-orientation pass over a whole capture, for `fit` and `check` (video_orientation.c). */
#ifndef SUNPROBE_TOOLS_VIDEO_ORIENTATION_H
#define SUNPROBE_TOOLS_VIDEO_ORIENTATION_H

#include "capture/visual_orientation.h"
#include "pipeline/stage.h"

/*
 * Runs the "video-orientation" stage over the capture at path into *stage (opened here; the caller
 * closes it, and looks frames up with sp_video_orientation_for while it is open), its summary to
 * `summary` (NULL: stdout). 0 with *r filled; SP_ENODATA when the background could not be tracked
 * (*r says how far it got); -ECANCELED on a stop signal; another error for the capture.
 */
int sp_tool_video_orientation(const char *path, int progress, FILE *summary, sp_stage *stage, sp_vo_result *r);

#endif
