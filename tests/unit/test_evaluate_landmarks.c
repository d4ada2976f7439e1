/* SPDX-License-Identifier: MIT */
/*
 * `sunprobe evaluate`'s landmark score (tools/evaluate_landmarks.c) on small records written here: the error
 * it reports against one worked by hand, the fit's columns read by name, and damaged records refused with
 * SP_ECORRUPT and a message naming the line, not scored into a wrong figure.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sunprobe/sp_common.h"
#include "check.h"
#include "tools/evaluate_landmarks.h"

static char dir[] = "/tmp/sp_evlm_XXXXXX";

/* Writes the truth: frames 0 and 1, point k at (10 k, 5), all visible unless k is in 60-67 on frame 1. */
static void write_truth(const char *path, const char *extra_row)
{
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    fprintf(f, "frame,landmark,u,v,visible\n");
    for (int fr = 0; fr < 2; fr++)
        for (int k = 0; k < 68; k++)
            fprintf(f, "%d,%d,%d,5,%d\n", fr, k, 10 * k, fr == 1 && k >= 60 ? 0 : 1);
    if (extra_row)
        fputs(extra_row, f);
    fclose(f);
}

/*
 * The fit: frame 0 every point 3 px right of the truth, frame 1 "none". Columns in the order given by
 * `xy_first` (0: x0,y0,x1,y1 ..., the writer's; 1: all x then all y). `bad` replaces the value of x5.
 */
static void write_fit(const char *path, int xy_first, const char *bad, const char *extra_row)
{
    FILE *f = fopen(path, "w");
    CHECK(f != NULL);
    fprintf(f, "sequence,source,rms_px");
    for (int k = 0; k < 136; k++) {
        int j = xy_first ? (k < 68 ? 2 * k : 2 * (k - 68) + 1) : k;
        fprintf(f, ",%c%d", j % 2 ? 'y' : 'x', j / 2);
    }
    fprintf(f, "\n0,detect,0.5");
    for (int k = 0; k < 136; k++) {
        int j = xy_first ? (k < 68 ? 2 * k : 2 * (k - 68) + 1) : k;
        if (j == 10 && bad)
            fprintf(f, ",%s", bad);
        else
            fprintf(f, ",%d", j % 2 ? 5 : 10 * (j / 2) + 3);
    }
    fprintf(f, "\n1,none,nan");
    for (int k = 0; k < 136; k++)
        fprintf(f, ",0");
    fprintf(f, "\n");
    if (extra_row)
        fputs(extra_row, f);
    fclose(f);
}

/* One more found row of the fit, for sequence seq. */
static void fit_row(char *row, size_t size, long seq)
{
    int m = snprintf(row, size, "%ld,detect,0.5", seq);
    for (int k = 0; k < 136; k++)
        m += snprintf(row + m, size - (size_t)m, ",1");
    snprintf(row + m, size - (size_t)m, "\n");
}

static int score(const char *fit, const char *truth, landmark_score *s, char *err, size_t n)
{
    err[0] = 0;
    return evaluate_landmarks(fit, truth, 0, s, err, n);
}

int main(void)
{
    CHECK(mkdtemp(dir) != NULL);
    char truth[256], fit[256], err[512];
    snprintf(truth, sizeof(truth), "%s/truth.csv", dir);
    snprintf(fit, sizeof(fit), "%s/fit.csv", dir);
    landmark_score s;

    /* 3 px off on every point, eye corners 36 and 45 are 90 px apart: 3.33 %; frame 1 tried, nothing found */
    write_truth(truth, NULL);
    for (int order = 0; order <= 1; order++) {
        write_fit(fit, order, NULL, NULL);
        CHECK(score(fit, truth, &s, err, sizeof(err)) == 0);
        CHECK(s.faces == 2 && s.tried == 2 && s.found == 1);
        CHECK_NEAR(s.mean, 3.0 / 90.0, 1e-9); /* the same whatever the column order */
    }

    /* damaged records: refused, the message naming the column or the file */
    const char *bad_values[] = { "1e300", "1e39", "-2e6" };
    for (size_t i = 0; i < sizeof(bad_values) / sizeof(*bad_values); i++) {
        write_fit(fit, 0, bad_values[i], NULL);
        CHECK_MSG(score(fit, truth, &s, err, sizeof(err)) == SP_ECORRUPT && strstr(err, "x5"), "x5 = %s: %s",
                  bad_values[i], err);
    }
    char row[2048];
    fit_row(row, sizeof(row), 0); /* frame 0 again */
    write_fit(fit, 0, NULL, row);
    CHECK_MSG(score(fit, truth, &s, err, sizeof(err)) == SP_ECORRUPT && strstr(err, "twice"), "%s", err);
    fit_row(row, sizeof(row), 9999999); /* would have been a dense array of 10 million records */
    write_fit(fit, 0, NULL, row);
    CHECK_MSG(score(fit, truth, &s, err, sizeof(err)) == SP_ECORRUPT && strstr(err, "out of range") &&
                  strstr(err, "fit.csv"),
              "%s", err);
    fit_row(row, sizeof(row), 2); /* a frame the capture (of 2 frames) does not have */
    write_fit(fit, 0, NULL, row);
    CHECK(evaluate_landmarks(fit, truth, 3, &s, err, sizeof(err)) == 0 && s.found == 1);
    CHECK_MSG(evaluate_landmarks(fit, truth, 2, &s, err, sizeof(err)) == SP_ECORRUPT && strstr(err, "0 to 1"), "%s",
              err);

    write_fit(fit, 0, NULL, NULL);
    write_truth(truth, "0,36,0,5,1\n"); /* a point given twice */
    CHECK_MSG(score(fit, truth, &s, err, sizeof(err)) == SP_ECORRUPT && strstr(err, "twice"), "%s", err);
    write_truth(truth, "2,0,0,5,1\n"); /* a frame with one point of 68 */
    CHECK_MSG(score(fit, truth, &s, err, sizeof(err)) == SP_ECORRUPT && strstr(err, "1 of the 68"), "%s", err);
    write_truth(truth, "2,0,0,5,2\n");
    CHECK_MSG(score(fit, truth, &s, err, sizeof(err)) == SP_ECORRUPT && strstr(err, "visible"), "%s", err);
    write_truth(truth, "2,0,nan,5,1\n");
    CHECK_MSG(score(fit, truth, &s, err, sizeof(err)) == SP_ECORRUPT && strstr(err, "truth.csv"), "%s", err);

    remove(truth), remove(fit), remove(dir);
    return check_exit();
}
