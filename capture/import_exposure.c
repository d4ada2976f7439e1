/* SPDX-License-Identifier: MIT */
/*
 * Per-frame exposure for the importers: columns exposure_s (shutter time) and iso or gain, one row per
 * frame, from the frame-times CSV or a CSV of their own (--exposure). Stored in each FRAME's
 * exposure_us and gain, which the fit reads (IMPORT.md, "Per-frame exposure").
 */
#include "import_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>

/* Shutter times beyond an hour or gains beyond 1e6 are typos or wrong units, not exposures. */
#define MAX_EXPOSURE_S 3600.0
#define MAX_GAIN 1e6

int sp_import_exposure_columns(sp_csv *csv, int col[3])
{
    col[0] = sp_csv_column(csv, "exposure_s");
    col[1] = sp_csv_column(csv, "iso");
    col[2] = sp_csv_column(csv, "gain");
    if (col[1] >= 0 && col[2] >= 0)
        return sp_csv_fail(csv, SP_ECORRUPT, "has both 'iso' and 'gain' columns; keep one");
    return col[0] >= 0 || col[1] >= 0 || col[2] >= 0;
}

/* One cell: NaN when empty (unknown for this frame), else a number in (0, max]. */
static int cell(sp_csv *csv, int col, double max, double *out)
{
    *out = NAN;
    if (col < 0 || sp_csv_empty(csv, col))
        return 0;
    int rc = sp_csv_double(csv, col, out);
    if (!rc && !(*out > 0 && *out <= max))
        rc = sp_csv_fail(csv, SP_ECORRUPT, "column '%s': %g is not in (0, %g]", csv->names[col], *out, max);
    return rc;
}

int sp_import_exposure_row(sp_import_exposure *x, sp_csv *csv, const int col[3])
{
    double e, iso, gain;
    int rc = cell(csv, col[0], MAX_EXPOSURE_S, &e);
    if (!rc)
        rc = cell(csv, col[1], MAX_GAIN * 100, &iso);
    if (!rc)
        rc = cell(csv, col[2], MAX_GAIN, &gain);
    if (rc)
        return rc;
    if (x->n == x->cap) {
        size_t cap = x->cap ? x->cap * 2 : 1024;
        float(*p)[2] = realloc(x->v, cap * sizeof(*p));
        if (!p)
            return -ENOMEM;
        x->v = p;
        x->cap = cap;
    }
    x->v[x->n][0] = (float)(e * 1e6);
    x->v[x->n][1] = (float)(col[1] >= 0 ? iso / 100.0 : gain); /* ISO 100 = gain 1 */
    x->n++;
    return 0;
}

int sp_import_exposure_load(sp_import_exposure *x, const char *path, char *msg, size_t msg_size)
{
    sp_csv csv;
    int rc = sp_csv_open(&csv, path, msg, msg_size);
    if (rc)
        return rc;
    int col[3];
    rc = sp_import_exposure_columns(&csv, col);
    if (rc == 0)
        rc = sp_csv_fail(&csv, SP_ECORRUPT, "needs a column exposure_s, iso or gain");
    else if (rc > 0)
        rc = 0;
    while (!rc && (rc = sp_csv_next(&csv)) == 0)
        rc = sp_import_exposure_row(x, &csv, col);
    if (rc == SP_EOS)
        rc = x->n ? 0 : sp_csv_fail(&csv, SP_ENODATA, "no rows after the header");
    x->path = path;
    sp_csv_close(&csv);
    return rc;
}

void sp_import_exposure_free(sp_import_exposure *x)
{
    free(x->v);
    x->v = NULL;
    x->n = x->cap = 0;
}
