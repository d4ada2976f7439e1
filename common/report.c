/* SPDX-License-Identifier: MIT */
#include "report.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <unistd.h>

#include "atomic_file.h"
#include "file_set.h"
#include "file_util.h"

struct sp_report {
    FILE *csv;                   /* the CSV's temporary, written as rows arrive */
    sp_file_set files;           /* PREFIX.csv (and PREFIX.svg), renamed into place together at close */
    char *svg_path, *title;
    char *names[SP_REPORT_MAX_SERIES];
    size_t n_series;
    int log_scale;
    double *x, *v; /* kept for the plot: one row per add, grows geometrically */
    size_t n_rows, cap;
    int error;
};

int sp_report_open(sp_report **out, const char *prefix, const char *title, const char *const *names,
                   size_t n_series, int log_scale)
{
    if (!out || !prefix || !names || n_series == 0 || n_series > SP_REPORT_MAX_SERIES)
        return -EINVAL;
    sp_report *r = calloc(1, sizeof(*r));
    if (!r)
        return -ENOMEM;
    size_t n = strlen(prefix) + 8;
    char *csv_path = malloc(n);
    r->svg_path = malloc(n);
    r->title = strdup(title ? title : "");
    int ret = csv_path && r->svg_path && r->title ? 0 : -ENOMEM;
    for (size_t i = 0; !ret && i < n_series; i++)
        if (!(r->names[i] = strdup(names[i])))
            ret = -ENOMEM;
    r->n_series = n_series;
    r->log_scale = log_scale;
    const char *csv_temp = NULL;
    if (!ret) {
        snprintf(csv_path, n, "%s.csv", prefix);
        snprintf(r->svg_path, n, "%s.svg", prefix);
        ret = sp_file_set_add(&r->files, csv_path, &csv_temp);
    }
    if (!ret && !(r->csv = fopen(csv_temp, "w")))
        ret = -errno;
    free(csv_path);
    if (ret) {
        sp_report_abort(&r);
        return ret;
    }
    fprintf(r->csv, "seconds");
    for (size_t i = 0; i < n_series; i++)
        fprintf(r->csv, ",%s", names[i]);
    fputc('\n', r->csv);
    fflush(r->csv);
    *out = r;
    return 0;
}

int sp_report_add(sp_report *r, double seconds, const double *values)
{
    if (!r || !values)
        return -EINVAL;
    if (r->n_rows == r->cap) {
        size_t cap = r->cap ? r->cap * 2 : 64;
        double *x = realloc(r->x, cap * sizeof(double));
        if (x)
            r->x = x;
        double *v = x ? realloc(r->v, cap * r->n_series * sizeof(double)) : NULL;
        if (!v)
            return -ENOMEM;
        r->v = v;
        r->cap = cap;
    }
    r->x[r->n_rows] = seconds;
    memcpy(r->v + r->n_rows * r->n_series, values, r->n_series * sizeof(double));
    r->n_rows++;
    fprintf(r->csv, "%.4f", seconds);
    for (size_t i = 0; i < r->n_series; i++) {
        if (isfinite(values[i]))
            fprintf(r->csv, ",%.9g", values[i]);
        else
            fputc(',', r->csv);
    }
    fputc('\n', r->csv);
    if (fflush(r->csv) != 0 && !r->error)
        r->error = sp_write_error();
    return r->error;
}

static void report_free(sp_report *r)
{
    for (size_t i = 0; i < SP_REPORT_MAX_SERIES; i++)
        free(r->names[i]);
    free(r->svg_path);
    free(r->title);
    free(r->x);
    free(r->v);
    free(r);
}

int sp_report_close(sp_report **rp)
{
    if (!rp || !*rp)
        return 0;
    sp_report *r = *rp;
    int ret = r->error;
    if (fflush(r->csv) != 0 || fsync(fileno(r->csv)) != 0)
        ret = ret ? ret : sp_write_error();
    if (fclose(r->csv) != 0 && !ret)
        ret = sp_write_error();
    r->csv = NULL;
    const char *svg_temp = NULL;
    if (!ret && r->n_rows && !(ret = sp_file_set_add(&r->files, r->svg_path, &svg_temp)))
        ret = sp_svg_plot_write(svg_temp, r->title, "wall time (s)", r->x, r->v, r->n_rows,
                                (const char *const *)r->names, r->n_series, r->log_scale);
    if (!ret)
        ret = sp_file_set_commit(&r->files);
    else
        sp_file_set_abort(&r->files);
    report_free(r);
    *rp = NULL;
    return ret;
}

void sp_report_abort(sp_report **rp)
{
    if (!rp || !*rp)
        return;
    sp_report *r = *rp;
    if (r->csv)
        fclose(r->csv);
    sp_file_set_abort(&r->files);
    report_free(r);
    *rp = NULL;
}

/* ---- SVG ---- */

/*
 * One panel per series, stacked, sharing the time axis: each quantity gets an axis of its own, labelled
 * with its name (and the unit the name carries), so series in different units never share a scale.
 */
#define W 720.0
#define LEFT 78.0
#define RIGHT 24.0
#define TOP 40.0
#define PANEL 110.0
#define GAP 26.0
#define BOTTOM 46.0

static const char *const palette[SP_REPORT_MAX_SERIES] = {
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b",
    "#e377c2", "#7f7f7f", "#bcbd22", "#17becf", "#000000", "#aec7e8",
};

static int usable(double v, int log_scale)
{
    return isfinite(v) && (!log_scale || v > 0);
}

static double ymap(double v, int log_scale)
{
    return log_scale ? log10(v) : v;
}

static void xml_text(FILE *f, const char *s)
{
    for (; *s; s++) {
        if (*s == '<')
            fputs("&lt;", f);
        else if (*s == '>')
            fputs("&gt;", f);
        else if (*s == '&')
            fputs("&amp;", f);
        else
            fputc(*s, f);
    }
}

/* Panel frame at top edge `top`: grid, y tick labels, the series' name along the y axis; x ticks when `last`. */
static void draw_panel(FILE *f, double top, double x0, double x1, double y0, double y1, int log_scale,
                       const char *name, const char *colour, int last)
{
    double pw = W - LEFT - RIGHT;
    fprintf(f, "<rect x='%.1f' y='%.1f' width='%.1f' height='%.1f' fill='none' stroke='#444'/>\n", LEFT, top, pw,
            PANEL);
    for (int i = 0; i <= 2; i++) {
        double fy = top + PANEL * (1.0 - i / 2.0), yv = y0 + (y1 - y0) * i / 2.0;
        fprintf(f, "<line x1='%.1f' y1='%.1f' x2='%.1f' y2='%.1f' stroke='#ddd'/>\n", LEFT, fy, LEFT + pw, fy);
        fprintf(f, "<text x='%.1f' y='%.1f' font-size='10' text-anchor='end'>%.3g</text>\n", LEFT - 5, fy + 4,
                log_scale ? pow(10.0, yv) : yv);
    }
    for (int i = 0; i <= 4; i++) {
        double fx = LEFT + pw * i / 4.0;
        fprintf(f, "<line x1='%.1f' y1='%.1f' x2='%.1f' y2='%.1f' stroke='#eee'/>\n", fx, top, fx, top + PANEL);
        if (last)
            fprintf(f, "<text x='%.1f' y='%.1f' font-size='11' text-anchor='middle'>%.3g</text>\n", fx,
                    top + PANEL + 15, x0 + (x1 - x0) * i / 4.0);
    }
    fprintf(f, "<text x='%.1f' y='%.1f' font-size='11' fill='%s'>", LEFT + 4, top - 5, colour);
    xml_text(f, name);
    fputs(log_scale ? " (log scale)</text>\n" : "</text>\n", f);
}

int sp_svg_plot_write(const char *path, const char *title, const char *x_label, const double *x,
                      const double *values, size_t n_rows, const char *const *names, size_t n_series, int log_scale)
{
    if (!path || !x || !values || !names || n_series == 0 || n_series > SP_REPORT_MAX_SERIES)
        return -EINVAL;
    double x0 = INFINITY, x1 = -INFINITY;
    for (size_t r = 0; r < n_rows; r++) {
        x0 = fmin(x0, x[r]);
        x1 = fmax(x1, x[r]);
    }
    if (!isfinite(x0))
        x0 = 0, x1 = 1;
    if (!(x1 > x0))
        x1 = x0 + 1.0;
    double height = TOP + (double)n_series * (PANEL + GAP) - GAP + BOTTOM, pw = W - LEFT - RIGHT;
    sp_atomic_file af;
    int ret = sp_atomic_file_open(&af, path);
    if (ret)
        return ret;
    FILE *f = af.file;
    fprintf(f, "<svg xmlns='http://www.w3.org/2000/svg' width='%.0f' height='%.0f' font-family='sans-serif'>\n"
               "<rect width='100%%' height='100%%' fill='white'/>\n<text x='%.1f' y='20' font-size='14'>",
            W, height, LEFT);
    xml_text(f, title ? title : "");
    fputs("</text>\n", f);
    for (size_t s = 0; s < n_series; s++) {
        double y0 = INFINITY, y1 = -INFINITY, top = TOP + (double)s * (PANEL + GAP);
        for (size_t r = 0; r < n_rows; r++) {
            double v = values[r * n_series + s];
            if (usable(v, log_scale)) {
                y0 = fmin(y0, ymap(v, log_scale));
                y1 = fmax(y1, ymap(v, log_scale));
            }
        }
        if (!isfinite(y0))
            y0 = 0, y1 = 1;
        if (!(y1 > y0)) /* flat series: give it a visible band */
            y0 -= 0.5, y1 += 0.5;
        draw_panel(f, top, x0, x1, y0, y1, log_scale, names[s], palette[s], s + 1 == n_series);
        fprintf(f, "<polyline fill='none' stroke='%s' stroke-width='1.5' points='", palette[s]);
        for (size_t r = 0; r < n_rows; r++) {
            double v = values[r * n_series + s];
            if (!usable(v, log_scale))
                continue;
            fprintf(f, "%.1f,%.1f ", LEFT + pw * (x[r] - x0) / (x1 - x0),
                    top + PANEL * (1.0 - (ymap(v, log_scale) - y0) / (y1 - y0)));
        }
        fputs("'/>\n", f);
    }
    fprintf(f, "<text x='%.1f' y='%.1f' font-size='12' text-anchor='middle'>", LEFT + pw / 2, height - 10);
    xml_text(f, x_label ? x_label : "");
    fputs("</text>\n</svg>\n", f);
    return sp_atomic_file_finish(&af, ferror(f) ? -EIO : 0);
}
