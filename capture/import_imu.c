/* SPDX-License-Identifier: MIT */
/* The IMU CSV of the importers, read one row at a time (layout in IMPORT.md). */
#include "import_internal.h"

#include <math.h>
#include <string.h>

static const char *const sensor_cols[3][3] = { { "gx", "gy", "gz" }, { "ax", "ay", "az" }, { "mx", "my", "mz" } };
static const uint32_t sensor_kinds[3] = { SP_IMU_GYRO, SP_IMU_ACCEL, SP_IMU_MAG };

int sp_import_imu_open(sp_import_imu *r, const char *path, int64_t shift_ns, char *msg, size_t msg_size)
{
    memset(r, 0, sizeof(*r));
    int rc = sp_csv_open(&r->csv, path, msg, msg_size);
    if (rc)
        return rc;
    r->open = 1;
    if ((rc = sp_csv_time_columns(&r->csv, &r->col_t, &r->col_tns)) != 0)
        return rc;
    int sensors = 0;
    for (int k = 0; k < 3; k++) {
        int found = 0;
        for (int a = 0; a < 3; a++) {
            r->cols[k][a] = sp_csv_column(&r->csv, sensor_cols[k][a]);
            found += r->cols[k][a] >= 0;
        }
        for (int a = 0; a < 3 && found && found < 3; a++)
            if (r->cols[k][a] < 0)
                return sp_csv_fail(&r->csv, SP_ECORRUPT, "missing column '%s' (a sensor needs all three axes)",
                                   sensor_cols[k][a]);
        sensors += found == 3;
    }
    if (!sensors)
        return sp_csv_fail(&r->csv, SP_ECORRUPT,
                           "no sensor columns: expected gx,gy,gz and/or ax,ay,az and/or mx,my,mz");
    r->shift_ns = shift_ns;
    return 0;
}

/* One sensor's three cells of the current row: 1 sample, 0 all empty, or an error. */
static int imu_cells(sp_import_imu *r, int k, int64_t t, sp_imu_sample *out)
{
    int empty = 0;
    for (int a = 0; a < 3; a++)
        empty += sp_csv_empty(&r->csv, r->cols[k][a]);
    if (empty == 3)
        return 0;
    if (empty)
        return sp_csv_fail(&r->csv, SP_ECORRUPT, "%s,%s,%s are partly empty", sensor_cols[k][0], sensor_cols[k][1],
                           sensor_cols[k][2]);
    if (r->have_sensor[k] && t <= r->last_ns[k])
        return sp_csv_fail(&r->csv, SP_ECORRUPT, "second %s sample at the same time",
                           sp_imu_sensor_name((enum sp_imu_sensor)sensor_kinds[k]));
    *out = (sp_imu_sample){ .timestamp_ns = t + r->shift_ns, .sensor = sensor_kinds[k] };
    for (int a = 0; a < 3; a++) {
        double v;
        int rc = sp_csv_double(&r->csv, r->cols[k][a], &v);
        if (rc)
            return rc;
        if (fabs(v) > 1e30) /* would not survive the float conversion */
            return sp_csv_fail(&r->csv, SP_ECORRUPT, "column '%s': %g is out of range", sensor_cols[k][a], v);
        out->v[a] = (float)v;
    }
    r->have_sensor[k] = 1;
    r->last_ns[k] = t;
    return 1;
}

static int imu_read_row(sp_import_imu *r)
{
    int rc = sp_csv_next(&r->csv);
    if (rc)
        return rc;
    int64_t t;
    if ((rc = sp_csv_time_ns(&r->csv, r->col_t, r->col_tns, &t)) != 0)
        return rc;
    if (r->have_row && t < r->last_row_ns)
        return sp_csv_fail(&r->csv, SP_ECORRUPT, "time goes backwards (%.9f s after %.9f s)", (double)t * 1e-9,
                           (double)r->last_row_ns * 1e-9);
    r->have_row = 1;
    r->last_row_ns = t;
    r->nrow = r->irow = 0;
    for (int k = 0; k < 3; k++) {
        if (r->cols[k][0] < 0)
            continue;
        rc = imu_cells(r, k, t, &r->row[r->nrow]);
        if (rc < 0)
            return rc;
        r->nrow += rc;
    }
    if (r->nrow == 0)
        return sp_csv_fail(&r->csv, SP_ECORRUPT, "row has a time but no sensor values");
    return 0;
}

void sp_import_imu_from_log(sp_import_imu *r, const sp_import_log *log, int64_t shift_ns)
{
    memset(r, 0, sizeof(*r));
    r->log = log;
    r->shift_ns = shift_ns;
    r->open = 1;
}

/* The next sample without taking it: 0, SP_EOS, or an error (message already set). */
int sp_import_imu_peek(sp_import_imu *r, const sp_imu_sample **out)
{
    if (r->log) {
        if (r->ilog >= r->log->n)
            return SP_EOS;
        r->row[0] = r->log->s[r->ilog];
        r->row[0].timestamp_ns += r->shift_ns;
        *out = &r->row[0];
        return 0;
    }
    while (r->irow >= r->nrow) {
        if (r->eof)
            return SP_EOS;
        int rc = imu_read_row(r);
        if (rc == SP_EOS)
            r->eof = 1;
        else if (rc)
            return rc;
    }
    *out = &r->row[r->irow];
    return 0;
}

void sp_import_imu_pop(sp_import_imu *r)
{
    if (r->log && r->ilog < r->log->n)
        r->ilog++;
    else if (r->irow < r->nrow)
        r->irow++;
}

void sp_import_imu_close(sp_import_imu *r)
{
    if (r->open && !r->log)
        sp_csv_close(&r->csv);
    r->open = 0;
}
