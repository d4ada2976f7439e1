/* SPDX-License-Identifier: MIT */
/*
 * Landmark coverage and error (evaluate_landmarks.h). The truth is per frame
 * and point (frame, landmark, u, v, visible); the error of a frame is the mean
 * distance over its visible points divided by the true distance between the
 * outer eye corners (points 36 and 45), as tests/integration/check_capture_truth.py
 * scores `replay --stage landmarks`.
 */
#include "tools/evaluate_landmarks.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "capture/import_csv.h"
#include "sunprobe/sp_common.h"

#define MAX_FRAMES 1000000
#define MAX_COORD 1e6 /* pixels: farther out than any frame is a corrupt coordinate, not a landmark */

typedef struct truth_frame {
    float uv[136];
    uint8_t visible[68];
    uint8_t given[68]; /* the row for this point was read (each must be, once) */
    int n_points;
    unsigned long line; /* where the frame's first row is, for messages */
} truth_frame;

typedef struct fit_frame {
    int tried, found;
    float lm[136];
} fit_frame;

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Grows a zeroed array of records to hold index i, below limit (the column named in messages). */
static int reserve(sp_csv *c, const char *column, int limit, void **arr, size_t *cap, size_t size, int64_t i)
{
    if (i < 0 || i >= limit)
        return sp_csv_fail(c, SP_ECORRUPT, "%s %lld is out of range (0 to %d)", column, (long long)i, limit - 1);
    if ((size_t)i < *cap)
        return 0;
    size_t n = *cap ? *cap : 256;
    while (n <= (size_t)i)
        n *= 2;
    if (n > (size_t)limit) /* never past the bound: one stray index must not cost a doubling */
        n = (size_t)limit;
    void *p = realloc(*arr, n * size);
    if (!p)
        return -ENOMEM;
    memset((char *)p + *cap * size, 0, (n - *cap) * size);
    *arr = p, *cap = n;
    return 0;
}

/* A pixel coordinate from field col: finite (sp_csv_double) and within MAX_COORD. */
static int coordinate(sp_csv *c, int col, float *out)
{
    double v;
    int ret = sp_csv_double(c, col, &v);
    if (!ret && !(fabs(v) <= MAX_COORD))
        ret = sp_csv_fail(c, SP_ECORRUPT, "column '%s': %g is no pixel coordinate (beyond %g)", c->names[col], v,
                          MAX_COORD);
    if (!ret)
        *out = (float)v;
    return ret;
}

static int read_truth(const char *path, int limit, truth_frame **out, size_t *n, char *err, size_t err_size)
{
    sp_csv c;
    int ret = sp_csv_open(&c, path, err, err_size);
    if (ret)
        return ret;
    int cf = sp_csv_column(&c, "frame"), ck = sp_csv_column(&c, "landmark"), cu = sp_csv_column(&c, "u"),
        cv = sp_csv_column(&c, "v"), cvis = sp_csv_column(&c, "visible");
    if (cf < 0 || ck < 0 || cu < 0 || cv < 0 || cvis < 0)
        ret = sp_csv_fail(&c, SP_ECORRUPT, "needs the columns frame, landmark, u, v, visible");
    while (!ret && !(ret = sp_csv_next(&c))) {
        int64_t f, k, vis;
        float u, v;
        if ((ret = sp_csv_int64(&c, cf, &f)) || (ret = sp_csv_int64(&c, ck, &k)) || (ret = coordinate(&c, cu, &u)) ||
            (ret = coordinate(&c, cv, &v)) || (ret = sp_csv_int64(&c, cvis, &vis)))
            break;
        if (k < 0 || k >= 68) {
            ret = sp_csv_fail(&c, SP_ECORRUPT, "landmark %lld is not one of the 68", (long long)k);
            break;
        }
        if (vis != 0 && vis != 1) {
            ret = sp_csv_fail(&c, SP_ECORRUPT, "column 'visible': %lld is neither 0 nor 1", (long long)vis);
            break;
        }
        if ((ret = reserve(&c, "frame", limit, (void **)out, n, sizeof(truth_frame), f)))
            break;
        truth_frame *t = &(*out)[f];
        if (t->given[k]) {
            ret = sp_csv_fail(&c, SP_ECORRUPT, "frame %lld, landmark %lld appears twice", (long long)f, (long long)k);
            break;
        }
        if (!t->n_points)
            t->line = c.line;
        t->uv[2 * k] = u, t->uv[2 * k + 1] = v;
        t->visible[k] = (uint8_t)vis;
        t->given[k] = 1;
        t->n_points++;
    }
    if (ret == SP_EOS) /* every frame named must have all 68 points: a missing one would drop the frame unseen */
        for (size_t f = 0; f < *n && ret == SP_EOS; f++)
            if ((*out)[f].n_points > 0 && (*out)[f].n_points < 68)
                ret = sp_csv_fail(&c, SP_ECORRUPT, "frame %zu (from line %lu) has %d of the 68 landmarks", f,
                                  (*out)[f].line, (*out)[f].n_points);
    sp_csv_close(&c);
    return ret == SP_EOS ? 0 : ret;
}

static int read_fit(const char *path, int limit, fit_frame **out, size_t *n, char *err, size_t err_size)
{
    sp_csv c;
    int ret = sp_csv_open(&c, path, err, err_size);
    if (ret)
        return ret;
    int cs = sp_csv_column(&c, "sequence"), csrc = sp_csv_column(&c, "source"), col[136];
    if (cs < 0 || csrc < 0)
        ret = sp_csv_fail(&c, SP_ECORRUPT, "needs the columns sequence, source and x0, y0 .. x67, y67");
    for (int k = 0; k < 136 && !ret; k++) { /* by name: a file written in another column order reads the same */
        char name[8];
        snprintf(name, sizeof(name), "%c%d", k % 2 ? 'y' : 'x', k / 2);
        if ((col[k] = sp_csv_column(&c, name)) < 0)
            ret = sp_csv_fail(&c, SP_ECORRUPT, "has no column '%s' (needs x0, y0 .. x67, y67)", name);
    }
    while (!ret && !(ret = sp_csv_next(&c))) {
        int64_t s;
        if ((ret = sp_csv_int64(&c, cs, &s)) ||
            (ret = reserve(&c, "sequence", limit, (void **)out, n, sizeof(fit_frame), s)))
            break;
        fit_frame *f = &(*out)[s];
        if (f->tried) {
            ret = sp_csv_fail(&c, SP_ECORRUPT, "sequence %lld appears twice", (long long)s);
            break;
        }
        f->tried = 1;
        f->found = strcmp(c.fields[csrc], "none") != 0;
        for (int k = 0; f->found && k < 136 && !ret; k++)
            ret = coordinate(&c, col[k], &f->lm[k]);
    }
    sp_csv_close(&c);
    return ret == SP_EOS ? 0 : ret;
}

int evaluate_landmarks(const char *fit_csv, const char *truth_csv, int n_frames, landmark_score *out, char *err,
                       size_t err_size)
{
    int limit = n_frames > 0 && n_frames < MAX_FRAMES ? n_frames : MAX_FRAMES;
    truth_frame *truth = NULL;
    fit_frame *fit = NULL;
    size_t nt = 0, nf = 0;
    double *errs = NULL;
    memset(out, 0, sizeof(*out));
    int ret = read_truth(truth_csv, limit, &truth, &nt, err, err_size);
    if (!ret)
        ret = read_fit(fit_csv, limit, &fit, &nf, err, err_size);
    if (!ret && !(errs = malloc(sizeof(double) * (nt ? nt : 1))))
        ret = -ENOMEM;
    for (size_t f = 0; !ret && f < nt; f++) {
        const truth_frame *t = &truth[f];
        int seen = 0;
        for (int k = 0; k < 68; k++)
            seen += t->visible[k];
        if (t->n_points < 68 || seen < 17)
            continue;
        out->faces++;
        if (f >= nf || !fit[f].tried)
            continue;
        out->tried++;
        if (!fit[f].found)
            continue;
        double iod = hypot((double)t->uv[90] - (double)t->uv[72], (double)t->uv[91] - (double)t->uv[73]), e = 0.0;
        for (int k = 0; k < 68; k++)
            if (t->visible[k])
                e += hypot((double)fit[f].lm[2 * k] - (double)t->uv[2 * k],
                           (double)fit[f].lm[2 * k + 1] - (double)t->uv[2 * k + 1]);
        errs[out->found++] = iod > 0.0 ? e / seen / iod : (double)INFINITY;
    }
    if (!ret && out->found) {
        double sum = 0.0;
        for (int i = 0; i < out->found; i++)
            sum += errs[i];
        qsort(errs, (size_t)out->found, sizeof(double), cmp_double);
        out->mean = sum / out->found;
        out->p90 = errs[(int)(0.9 * (out->found - 1))];
        out->max = errs[out->found - 1];
    }
    free(truth);
    free(fit);
    free(errs);
    return ret;
}
