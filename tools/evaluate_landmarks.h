/* SPDX-License-Identifier: MIT */
/* The fit's landmark record (FACE_DIR/landmarks.csv) against a capture's gt/landmarks.csv (evaluate_landmarks.c). */
#ifndef SUNPROBE_TOOLS_EVALUATE_LANDMARKS_H
#define SUNPROBE_TOOLS_EVALUATE_LANDMARKS_H

#include <stddef.h>

typedef struct landmark_score {
    int faces;      /* truth frames with a visible face (at least 17 of the 68 points visible) */
    int tried;      /* of those, frames the fit ran its tracker on (others were skipped before: dark, blurred...) */
    int found;      /* of those, frames it placed landmarks on */
    double mean, p90, max; /* per-frame mean error over the visible points, over the true inter-ocular distance */
} landmark_score;

/*
 * 0, or a negative error with a message naming the file and line in err. n_frames: the capture's frame count
 * (indices 0 .. n_frames - 1; a row beyond is refused); 0 for no count (up to a million).
 */
int evaluate_landmarks(const char *fit_csv, const char *truth_csv, int n_frames, landmark_score *out, char *err,
                       size_t err_size);

#endif
