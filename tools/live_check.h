/* SPDX-License-Identifier: MIT */
/* `record --mode selfie`'s live capture check: `sunprobe check` on the capture while it is written. */
#ifndef SUNPROBE_TOOLS_LIVE_CHECK_H
#define SUNPROBE_TOOLS_LIVE_CHECK_H

#include <stddef.h>
#include <stdio.h>

typedef struct sp_live_check sp_live_check;

/*
 * Starts a thread that follows the capture at path (borrowed until finish) as the recorder appends to
 * it, feeding each chunk to the check's measurements (check_capture.h) and refreshing a one-line
 * status. It reads behind the writer and never slows it; find_faces as for `sunprobe check`, with
 * the landmark tracker on frames at least face_interval_s apart, and skipped (counted) on frames
 * older than max_lag_s when their turn comes, so that a slow tracker lets the check catch up.
 */
int sp_live_check_start(sp_live_check **out, const char *path, int find_faces, double face_interval_s,
                        double max_lag_s);
/* The latest status ("turn 140 deg of 300 | face 92 % | clipped 0 % | gyro 200 Hz"); "" before the
 * first frames. Safe to call from another thread than the check's. */
void sp_live_check_status(sp_live_check *lc, char *buf, size_t size);
/*
 * After the recorder has closed the capture: reads what is left, stops the thread and prints the
 * check's full verdict to out (one line per item, then what to do). Frees *lc; 0 or the error that
 * stopped reading the capture.
 */
int sp_live_check_finish(sp_live_check **lc, FILE *out);

#endif
