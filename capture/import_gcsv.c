/* SPDX-License-Identifier: MIT */
/*
 * Gyroflow .gcsv: a "GYROFLOW IMU LOG" line, key,value header lines (tscale, gscale, ascale, ...),
 * then a CSV of scaled integers: t x tscale = seconds on the video clock, gyro x gscale = rad/s,
 * accel x ascale = g. Layout: IMPORT.md, "IMU logs".
 */
#include "import_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define STANDARD_G 9.80665

typedef struct gcsv_header {
    double tscale, gscale, ascale; /* 0 when absent */
    unsigned long lines;           /* header lines before the column names */
    long data_pos;                 /* file offset of the column names */
} gcsv_header;

/* A positive finite scale from "key,value"; 0 when line is not that key. */
static int header_scale(const char *line, const char *key, double *out)
{
    size_t k = strlen(key);
    if (strncmp(line, key, k) != 0 || line[k] != ',')
        return 0;
    char *end;
    double v = strtod(line + k + 1, &end);
    while (*end == ' ' || *end == '\r' || *end == '\n')
        end++;
    if (*end || !isfinite(v) || !(v > 0))
        return -1;
    *out = v;
    return 1;
}

static int read_header(FILE *f, const char *path, gcsv_header *h, char *msg, size_t msg_size)
{
    char line[1024];
    static const char *const keys[] = { "tscale", "gscale", "ascale" };
    double *vals[] = { &h->tscale, &h->gscale, &h->ascale };
    memset(h, 0, sizeof(*h));
    for (;;) {
        long pos = ftell(f);
        if (!fgets(line, sizeof(line), f))
            return sp_import_fail(msg, msg_size, SP_ECORRUPT, "%s:%lu: the header ends without the column names "
                                  "(t,gx,gy,gz,...)", path, h->lines);
        if (h->lines == 0 && strncmp(line, "GYROFLOW IMU LOG", 16) != 0 && strncmp(line, "CAMERA IMU LOG", 14) != 0)
            return sp_import_fail(msg, msg_size, SP_ECORRUPT, "%s:1: a .gcsv starts with 'GYROFLOW IMU LOG'", path);
        if (strncmp(line, "t,", 2) == 0) {
            h->data_pos = pos;
            return fseek(f, pos, SEEK_SET) == 0 ? 0 : -EIO;
        }
        h->lines++;
        for (int k = 0; k < 3; k++)
            if (header_scale(line, keys[k], vals[k]) < 0)
                return sp_import_fail(msg, msg_size, SP_ECORRUPT, "%s:%lu: %s must be a positive number", path,
                                      h->lines, keys[k]);
    }
}

/* A needed scale that the header lacks: named with the line of the column names. */
static int missing(sp_csv *c, const char *scale, const char *cols)
{
    return sp_csv_fail(c, SP_ECORRUPT, "the header has no %s, needed to read %s", scale, cols);
}

static int read_rows(sp_import_log *log, sp_csv *c, const gcsv_header *h)
{
    int ct = sp_csv_column(c, "t");
    int cols[2][3] = { { sp_csv_column(c, "gx"), sp_csv_column(c, "gy"), sp_csv_column(c, "gz") },
                       { sp_csv_column(c, "ax"), sp_csv_column(c, "ay"), sp_csv_column(c, "az") } };
    const double scale[2] = { h->gscale, h->ascale * STANDARD_G };
    const uint32_t kinds[2] = { SP_IMU_GYRO, SP_IMU_ACCEL };
    int have[2] = { cols[0][0] >= 0 && cols[0][1] >= 0 && cols[0][2] >= 0,
                    cols[1][0] >= 0 && cols[1][1] >= 0 && cols[1][2] >= 0 };
    if (!h->tscale)
        return missing(c, "tscale", "t");
    if (!have[0])
        return sp_csv_fail(c, SP_ECORRUPT, "needs the columns gx,gy,gz");
    if (!h->gscale)
        return missing(c, "gscale", "gx,gy,gz");
    if (have[1] && !h->ascale)
        return missing(c, "ascale", "ax,ay,az");
    int rc;
    int64_t last = 0;
    int any = 0;
    while ((rc = sp_csv_next(c)) == 0) {
        double t;
        if ((rc = sp_csv_double(c, ct, &t)) != 0)
            return rc;
        int64_t ns = llround(t * h->tscale * 1e9);
        if (fabs(t * h->tscale) > 4e9)
            return sp_csv_fail(c, SP_ECORRUPT, "t x tscale = %g s is out of range", t * h->tscale);
        if (any && ns == last)
            return sp_csv_fail(c, SP_ECORRUPT, "duplicate row: t %g again", t);
        if (any && ns < last)
            return sp_csv_fail(c, SP_ECORRUPT, "time goes backwards (t %g)", t);
        last = ns;
        any = 1;
        for (int k = 0; k < 2; k++) {
            double v[3];
            if (!have[k])
                continue;
            for (int a = 0; a < 3; a++) {
                if ((rc = sp_csv_double(c, cols[k][a], &v[a])) != 0)
                    return rc;
                v[a] *= scale[k];
                if (fabs(v[a]) > 1e30)
                    return sp_csv_fail(c, SP_ECORRUPT, "column '%s' is out of range", c->names[cols[k][a]]);
            }
            if ((rc = sp_import_log_push(log, ns, kinds[k], v)) != 0)
                return rc;
        }
    }
    return rc == SP_EOS ? (any ? 0 : sp_csv_fail(c, SP_ENODATA, "no samples after the column names")) : rc;
}

int sp_import_log_gcsv(sp_import_log *log, const char *path, char *msg, size_t msg_size)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        int rc = -errno;
        return sp_import_fail(msg, msg_size, rc, "%s: cannot open: %s", path, sp_strerror(rc));
    }
    gcsv_header h;
    int rc = read_header(f, path, &h, msg, msg_size);
    if (rc) {
        fclose(f);
        return rc;
    }
    log->format = "Gyroflow gcsv";
    log->clock = SP_CLOCK_VIDEO;
    sp_csv c;
    if ((rc = sp_csv_open_stream(&c, f, path, h.lines, 1, msg, msg_size)) != 0)
        return rc;
    if (sp_csv_column(&c, "mx") >= 0)
        sp_log(SP_LOG_INFO, "import", "%s: magnetometer columns are not imported (mscale's unit is not settled)",
               path);
    rc = read_rows(log, &c, &h);
    sp_csv_close(&c);
    return rc;
}
