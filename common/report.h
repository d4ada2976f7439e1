/* SPDX-License-Identifier: MIT */
/*
 * Error-against-run-time reports: every long computation appends rows of
 * (wall seconds, metric values...) here; the CSV is written as rows arrive
 * under a temporary name, the SVG plot is drawn at the end, and both are
 * renamed into place together, so a failed or interrupted run leaves the
 * previous report as it was and no partial one.
 */
#ifndef SUNPROBE_COMMON_REPORT_H
#define SUNPROBE_COMMON_REPORT_H

#include <stddef.h>
#include "common/private_api.h"

#define SP_REPORT_MAX_SERIES 12

typedef struct sp_report sp_report;

/*
 * Opens PREFIX.csv's temporary for writing; the SVG goes to PREFIX.svg at close. `names`
 * are the metric column names (borrowed for the call), `log_scale` draws the y
 * axis logarithmically (non-positive values are skipped in the plot).
 */
SP_PRIVATE int sp_report_open(sp_report **out, const char *prefix, const char *title, const char *const *names,
                   size_t n_series, int log_scale);
/* Appends one row; NaN marks a value not measured at this time (empty CSV cell, gap in the plot). */
SP_PRIVATE int sp_report_add(sp_report *r, double seconds, const double *values);
/*
 * Closes the CSV, writes the SVG and commits both (the SVG only when a row came); *r becomes NULL.
 * Returns the first write error, if any: then neither is committed.
 */
SP_PRIVATE int sp_report_close(sp_report **r);
/* Drops the report of a failed run: its temporaries are removed, a previous report stays; *r becomes NULL. */
SP_PRIVATE void sp_report_abort(sp_report **r);

/*
 * Draws n_rows x n_series values against x as an SVG of stacked panels, one per series with its own
 * y axis labelled by the series' name (which should carry the unit); used by sp_report and benchmarks.
 */
int sp_svg_plot_write(const char *path, const char *title, const char *x_label, const double *x,
                      const double *values, size_t n_rows, const char *const *names, size_t n_series, int log_scale);

#endif
