/* SPDX-License-Identifier: MIT */
/*
 * IMU logs written by phone apps and cameras, read whole into one time-sorted table with their
 * clock: Sensor Logger (per-sensor CSVs, epoch ns), OpenCamera-Sensors (headerless x,y,z,ns plus
 * frame times) and Gyroflow .gcsv (scaled integers). Layouts and clocks: IMPORT.md, "IMU logs".
 * A log is a few MB for a selfie (200 Hz x 3 sensors x 32 B x minutes), so reading it whole is cheap
 * and lets the import check its clock against the frames before anything is written.
 */
#include "import_internal.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "sunprobe/sp_import.h"

int sp_import_log_push(sp_import_log *log, int64_t t, uint32_t sensor, const double v[3])
{
    if (log->n == log->cap) {
        size_t cap = log->cap ? log->cap * 2 : 4096;
        sp_imu_sample *p = realloc(log->s, cap * sizeof(*p));
        if (!p)
            return -ENOMEM;
        log->s = p;
        log->cap = cap;
    }
    log->s[log->n++] = (sp_imu_sample){ .timestamp_ns = t, .sensor = sensor,
                                        .v = { (float)v[0], (float)v[1], (float)v[2] } };
    return 0;
}

static int by_time(const void *a, const void *b)
{
    const sp_imu_sample *x = a, *y = b;
    if (x->timestamp_ns != y->timestamp_ns)
        return x->timestamp_ns < y->timestamp_ns ? -1 : 1;
    return (x->sensor > y->sensor) - (x->sensor < y->sensor);
}

void sp_import_log_free(sp_import_log *log)
{
    if (log->video_temp && log->video[0])
        unlink(log->video);
    free(log->s);
    free(log->frame_ns);
    memset(log, 0, sizeof(*log));
}

static int ends_with_ci(const char *s, const char *suffix)
{
    size_t n = strlen(s), k = strlen(suffix);
    return n >= k && strcasecmp(s + n - k, suffix) == 0;
}

static int match_suffix(const char *name, const void *suffix)
{
    return ends_with_ci(name, suffix);
}

/* One row's three values, finite and within float range. */
static int read_xyz(sp_csv *c, const int col[3], double v[3])
{
    for (int a = 0; a < 3; a++) {
        int rc = sp_csv_double(c, col[a], &v[a]);
        if (rc)
            return rc;
        if (fabs(v[a]) > 1e30)
            return sp_csv_fail(c, SP_ECORRUPT, "column '%s': %g is out of range", c->names[col[a]], v[a]);
    }
    return 0;
}

/* A sensor's times must increase: a repeated time is a duplicated row, an earlier one a reordering. */
static int check_order(sp_csv *c, int64_t t, int64_t *last, int *have)
{
    if (*have && t == *last)
        return sp_csv_fail(c, SP_ECORRUPT, "duplicate row: time %lld ns again", (long long)t);
    if (*have && t < *last)
        return sp_csv_fail(c, SP_ECORRUPT, "time goes backwards (%lld ns after %lld ns)", (long long)t,
                           (long long)*last);
    *last = t;
    *have = 1;
    return 0;
}

/* ---- Sensor Logger ---- */

typedef struct sl_file {
    const char *name;    /* base name in the export */
    uint32_t sensor;
} sl_file;

/* Opens the export's CSV called name as c (shown: its name in messages, kept by the caller while c is open);
 * SP_ENODATA (message empty) when the export has none. */
static int sl_open(sp_import_bundle *b, const char *name, sp_csv *c, char shown[4200], char *msg, size_t msg_size)
{
    char found[4096];
    if (!sp_import_bundle_find(b, sp_import_match_name, name, found, sizeof(found)))
        return SP_ENODATA;
    if (b->zip)
        snprintf(shown, 4200, "%s:%s", b->path, found);
    else
        snprintf(shown, 4200, "%s", found);
    FILE *f;
    int rc = sp_import_bundle_fopen(b, found, &f, msg, msg_size);
    return rc ? rc : sp_csv_open_stream(c, f, shown, 0, 1, msg, msg_size);
}

/* Reads one Sensor Logger CSV (time, seconds_elapsed, z, y, x in any order) into log; *session: time - elapsed of row 1. */
static int sl_read(sp_import_bundle *b, const char *name, uint32_t sensor, sp_import_log *log, int64_t *session,
                   char *msg, size_t msg_size)
{
    sp_csv c;
    char shown[4200];
    int rc = sl_open(b, name, &c, shown, msg, msg_size);
    if (rc)
        return rc;
    int ct = sp_csv_column(&c, "time"), ce = sp_csv_column(&c, "seconds_elapsed");
    int col[3] = { sp_csv_column(&c, "x"), sp_csv_column(&c, "y"), sp_csv_column(&c, "z") };
    if (ct < 0 || col[0] < 0 || col[1] < 0 || col[2] < 0)
        rc = sp_csv_fail(&c, SP_ECORRUPT, "a Sensor Logger CSV needs the columns time, x, y, z");
    int64_t last = 0;
    int have = 0;
    while (!rc && (rc = sp_csv_next(&c)) == 0) {
        int64_t t;
        double v[3], el = 0;
        if ((rc = sp_csv_int64(&c, ct, &t)) || (rc = check_order(&c, t, &last, &have)) || (rc = read_xyz(&c, col, v)))
            break;
        if (session && log->n == 0 && ce >= 0) {
            if ((rc = sp_csv_double(&c, ce, &el)) != 0)
                break;
            *session = t - llround(el * 1e9);
        }
        rc = sp_import_log_push(log, t, sensor, v);
    }
    if (rc == SP_EOS)
        rc = have ? 0 : sp_csv_fail(&c, SP_ENODATA, "no samples after the header");
    sp_csv_close(&c);
    return rc;
}

/* Accelerometer.csv is without gravity on both platforms: gravity (Gravity.csv, nearest in time) is added back. */
static int sl_accel_with_gravity(sp_import_bundle *b, sp_import_log *log, char *msg, size_t msg_size)
{
    sp_import_log acc = { 0 }, grav = { 0 };
    int rc = sl_read(b, "Accelerometer.csv", SP_IMU_ACCEL, &acc, NULL, msg, msg_size);
    if (!rc)
        rc = sl_read(b, "Gravity.csv", SP_IMU_ACCEL, &grav, NULL, msg, msg_size);
    if (rc == SP_ENODATA && !msg[0]) {
        sp_log(SP_LOG_WARN, "import", "%s: no TotalAcceleration.csv, nor Accelerometer.csv with Gravity.csv: the "
               "capture gets no accelerometer (gravity), only the gyroscope", b->path);
        rc = 0;
    }
    for (size_t i = 0, j = 0; !rc && i < acc.n; i++) {
        while (j + 1 < grav.n && llabs(grav.s[j + 1].timestamp_ns - acc.s[i].timestamp_ns) <=
                                 llabs(grav.s[j].timestamp_ns - acc.s[i].timestamp_ns))
            j++;
        double v[3];
        for (int a = 0; a < 3; a++)
            v[a] = (double)acc.s[i].v[a] + (double)grav.s[j].v[a];
        rc = sp_import_log_push(log, acc.s[i].timestamp_ns, SP_IMU_ACCEL, v);
    }
    sp_import_log_free(&acc);
    sp_import_log_free(&grav);
    return rc;
}

/*
 * Location.csv, optional: the fix with the smallest horizontal accuracy. A negative accuracy is iOS's
 * "no valid fix", and 0,0 is what both platforms log before the first fix; neither is a place.
 */
static int sl_location(sp_import_bundle *b, sp_import_log *log, char *msg, size_t msg_size)
{
    sp_csv c;
    char shown[4200];
    int rc = sl_open(b, "Location.csv", &c, shown, msg, msg_size);
    if (rc)
        return rc == SP_ENODATA && !msg[0] ? 0 : rc;
    int clat = sp_csv_column(&c, "latitude"), clon = sp_csv_column(&c, "longitude");
    int calt = sp_csv_column(&c, "altitude"), cacc = sp_csv_column(&c, "horizontalAccuracy");
    if (clat < 0 || clon < 0)
        rc = sp_csv_fail(&c, SP_ECORRUPT, "a Sensor Logger Location.csv needs the columns latitude, longitude");
    double best = INFINITY;
    size_t rows = 0;
    while (!rc && (rc = sp_csv_next(&c)) == 0) {
        double lat, lon, alt = NAN, acc = NAN;
        rows++;
        if ((rc = sp_csv_double(&c, clat, &lat)) || (rc = sp_csv_double(&c, clon, &lon)) ||
            (calt >= 0 && (rc = sp_csv_double(&c, calt, &alt))) || (cacc >= 0 && (rc = sp_csv_double(&c, cacc, &acc))))
            break;
        if (fabs(lat) > 90 || fabs(lon) > 180) {
            rc = sp_csv_fail(&c, SP_ECORRUPT, "latitude %g, longitude %g: outside -90..90, -180..180", lat, lon);
            break;
        }
        if ((lat == 0 && lon == 0) || acc < 0)
            continue;
        double rank = isnan(acc) ? 1e300 : acc; /* rows without an accuracy: the first one */
        if (!log->has_location || rank < best) {
            best = rank;
            log->has_location = 1;
            log->location[0] = lat;
            log->location[1] = lon;
            log->location[2] = alt;
            log->location_accuracy_m = acc;
        }
    }
    if (rc == SP_EOS) {
        rc = 0;
        if (!log->has_location)
            sp_log(SP_LOG_WARN, "import", "%s: %zu rows, none a valid fix: the capture gets no location", c.path,
                   rows);
    }
    sp_csv_close(&c);
    return rc;
}

/* Sensor Logger names its video <epoch ms>.mp4 after the session start; 0 when the name is not that. */
static int64_t video_name_epoch_ns(const char *path)
{
    const char *base = strrchr(path, '/') ? strrchr(path, '/') + 1 : path;
    char *end = NULL;
    errno = 0;
    long long ms = strtoll(base, &end, 10);
    if (errno || end == base || *end != '.' || ms < 100000000000LL || ms > 99999999999999LL)
        return 0;
    return (int64_t)ms * 1000000;
}

static int sl_video(sp_import_bundle *b, sp_import_log *log, const char *near, char *msg, size_t msg_size)
{
    char found[4096];
    if (!sp_import_bundle_find(b, sp_import_match_video, NULL, found, sizeof(found)))
        return sp_import_fail(msg, msg_size, SP_ENODATA, "%s: the export holds no video (.mp4 or .mov): record with "
                              "the Camera sensor in Video mode, or give the video as INPUT", b->path);
    int64_t epoch = video_name_epoch_ns(found);
    if (epoch) {
        log->has_start = 1;
        log->start_ns = epoch;
        log->start_from = "video start from the video's file name (epoch ms)";
    }
    if (!b->zip)
        return snprintf(log->video, sizeof(log->video), "%s", found) < (int)sizeof(log->video) ? 0 : -ENAMETOOLONG;
    log->video_temp = 1;
    return sp_import_bundle_extract(b, found, near, log->video, sizeof(log->video), msg, msg_size);
}

static int load_sensor_logger(sp_import_log *log, const char *path, const char *near, int want_video, char *msg,
                              size_t msg_size)
{
    char dir[4096];
    struct stat st;
    if (stat(path, &st) == 0 && S_ISREG(st.st_mode) && !sp_import_is_zip(path)) { /* one of its CSVs: the folder */
        const char *slash = strrchr(path, '/');
        snprintf(dir, sizeof(dir), "%.*s", slash ? (int)(slash - path) : 1, slash ? path : ".");
        path = dir;
    }
    sp_import_bundle b;
    int rc = sp_import_bundle_open(&b, path, msg, msg_size);
    if (rc)
        return rc;
    log->format = "Sensor Logger";
    log->clock = SP_CLOCK_EPOCH;
    int64_t session = 0;
    rc = sl_read(&b, "Gyroscope.csv", SP_IMU_GYRO, log, &session, msg, msg_size);
    if (rc == SP_ENODATA && !msg[0])
        rc = sp_import_fail(msg, msg_size, rc, "%s: no Gyroscope.csv: not a Sensor Logger export, or recorded "
                            "without the gyroscope", path);
    if (!rc) {
        rc = sl_read(&b, "TotalAcceleration.csv", SP_IMU_ACCEL, log, NULL, msg, msg_size);
        if (rc == SP_ENODATA && !msg[0])
            rc = sl_accel_with_gravity(&b, log, msg, msg_size);
    }
    if (!rc && (rc = sl_read(&b, "Magnetometer.csv", SP_IMU_MAG, log, NULL, msg, msg_size)) == SP_ENODATA && !msg[0])
        rc = 0;
    if (!rc)
        rc = sl_location(&b, log, msg, msg_size);
    if (!rc && want_video)
        rc = sl_video(&b, log, near, msg, msg_size);
    if (!rc && !log->has_start && session) {
        log->has_start = 1;
        log->start_ns = session;
        log->start_from = "video start taken as the recording's (time - seconds_elapsed)";
    }
    sp_import_bundle_close(&b);
    return rc;
}

/* ---- OpenCamera-Sensors ---- */

/* Reads PREFIX+suffix (x,y,z,timestamp_ns per line, no header); SP_ENODATA when absent. */
static int oc_read(const char *prefix, const char *suffix, uint32_t sensor, sp_import_log *log, char *msg,
                   size_t msg_size)
{
    char path[4200];
    snprintf(path, sizeof(path), "%s%s", prefix, suffix);
    FILE *f = fopen(path, "r");
    if (!f)
        return errno == ENOENT ? SP_ENODATA : sp_import_fail(msg, msg_size, -errno, "%s: %s", path, strerror(errno));
    sp_csv c;
    int rc = sp_csv_open_stream(&c, f, path, 0, 0, msg, msg_size);
    int64_t last = 0;
    int have = 0;
    static const int col[3] = { 0, 1, 2 };
    while (!rc && (rc = sp_csv_next(&c)) == 0) {
        int64_t t;
        double v[3];
        if (c.nfields != 4) {
            rc = sp_csv_fail(&c, SP_ECORRUPT, "expected x,y,z,timestamp_ns (4 fields), found %zu", c.nfields);
            break;
        }
        if ((rc = sp_csv_int64(&c, 3, &t)) || (rc = check_order(&c, t, &last, &have)) || (rc = read_xyz(&c, col, v)))
            break;
        rc = sp_import_log_push(log, t, sensor, v);
    }
    if (rc == SP_EOS)
        rc = have ? 0 : sp_csv_fail(&c, SP_ENODATA, "no samples");
    sp_csv_close(&c);
    return rc;
}

/* PREFIX+timestamps.csv: one frame time (ns) per line, first field. */
static int oc_frames(const char *prefix, sp_import_log *log, char *msg, size_t msg_size)
{
    char path[4200];
    snprintf(path, sizeof(path), "%stimestamps.csv", prefix);
    FILE *f = fopen(path, "r");
    if (!f)
        return errno == ENOENT ? 0 : sp_import_fail(msg, msg_size, -errno, "%s: %s", path, strerror(errno));
    sp_csv c;
    int rc = sp_csv_open_stream(&c, f, path, 0, 0, msg, msg_size);
    size_t cap = 0;
    while (!rc && (rc = sp_csv_next(&c)) == 0) {
        int64_t t;
        if ((rc = sp_csv_int64(&c, 0, &t)) != 0)
            break;
        if (log->nframes && t <= log->frame_ns[log->nframes - 1]) {
            rc = sp_csv_fail(&c, SP_ECORRUPT, "frame time is not after the previous line's");
            break;
        }
        if (log->nframes == cap) {
            cap = cap ? cap * 2 : 1024;
            int64_t *p = realloc(log->frame_ns, cap * sizeof(*p));
            if (!p) {
                rc = -ENOMEM;
                break;
            }
            log->frame_ns = p;
        }
        log->frame_ns[log->nframes++] = t;
    }
    if (rc == SP_EOS)
        rc = log->nframes ? 0 : sp_csv_fail(&c, SP_ENODATA, "no frame times");
    sp_csv_close(&c);
    return rc;
}

static int load_opencamera(sp_import_log *log, const char *path, char *msg, size_t msg_size)
{
    char prefix[4096];
    struct stat st;
    if (stat(path, &st) == 0 && S_ISDIR(st.st_mode)) {
        sp_import_bundle b = { .path = path };
        if (!sp_import_bundle_find(&b, match_suffix, "gyro.csv", prefix, sizeof(prefix)))
            return sp_import_fail(msg, msg_size, SP_ENODATA, "%s: no *_gyro.csv in this directory", path);
    } else {
        snprintf(prefix, sizeof(prefix), "%s", path);
    }
    static const char *const suffixes[] = { "gyro.csv", "accel.csv", "magnetic.csv", "timestamps.csv" };
    size_t cut = 0;
    for (size_t i = 0; !cut && i < 4; i++)
        if (ends_with_ci(prefix, suffixes[i]))
            cut = strlen(prefix) - strlen(suffixes[i]);
    if (!cut)
        return sp_import_fail(msg, msg_size, SP_ECORRUPT, "%s: an OpenCamera-Sensors log is named "
                              "VIDEO_gyro.csv (or _accel.csv, _timestamps.csv)", path);
    prefix[cut] = 0;
    log->format = "OpenCamera-Sensors";
    log->clock = SP_CLOCK_SHARED;
    int rc = oc_read(prefix, "gyro.csv", SP_IMU_GYRO, log, msg, msg_size);
    if (rc == SP_ENODATA && !msg[0])
        rc = sp_import_fail(msg, msg_size, rc, "%sgyro.csv: missing", prefix);
    if (!rc && (rc = oc_read(prefix, "accel.csv", SP_IMU_ACCEL, log, msg, msg_size)) == SP_ENODATA && !msg[0])
        rc = 0;
    if (!rc && (rc = oc_read(prefix, "magnetic.csv", SP_IMU_MAG, log, msg, msg_size)) == SP_ENODATA && !msg[0])
        rc = 0;
    if (!rc)
        rc = oc_frames(prefix, log, msg, msg_size);
    if (!rc && log->nframes) {
        log->has_start = 1;
        log->start_ns = log->frame_ns[0];
        log->start_from = "video start from *_timestamps.csv";
    }
    return rc;
}

/* ---- detection ---- */

/* The first line that is neither blank nor a comment, trimmed. */
static int first_line(const char *path, char *out, size_t n)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return -errno;
    out[0] = 0;
    while (fgets(out, (int)n, f)) {
        char *s = out;
        while (*s == ' ' || *s == '\t' || *s == '\r' || *s == '\n')
            s++;
        if (*s && *s != '#') {
            memmove(out, s, strlen(s) + 1);
            break;
        }
        out[0] = 0;
    }
    fclose(f);
    out[strcspn(out, "\r\n")] = 0;
    return 0;
}

static int numeric_fields(const char *line)
{
    int n = 0;
    for (const char *p = line; *p;) {
        char *end;
        strtod(p, &end);
        if (end == p)
            return 0;
        n++;
        while (*end == ' ' || *end == '\t')
            end++;
        if (*end && *end != ',')
            return 0;
        p = *end ? end + 1 : end;
    }
    return n;
}

int sp_import_log_detect(const char *path, int format, int *out, char *msg, size_t msg_size)
{
    *out = format;
    if (format != SP_IMPORT_IMU_AUTO)
        return 0;
    struct stat st;
    if (stat(path, &st) != 0) {
        int rc = -errno;
        return sp_import_fail(msg, msg_size, rc, "%s: %s", path, sp_strerror(rc));
    }
    char line[512];
    if (S_ISDIR(st.st_mode)) {
        sp_import_bundle b = { .path = path };
        if (sp_import_bundle_find(&b, sp_import_match_name, "Gyroscope.csv", line, sizeof(line)))
            *out = SP_IMPORT_IMU_SENSOR_LOGGER;
        else if (sp_import_bundle_find(&b, match_suffix, "gyro.csv", line, sizeof(line)))
            *out = SP_IMPORT_IMU_OPENCAMERA;
        else
            return sp_import_fail(msg, msg_size, SP_ECORRUPT, "%s: a directory with neither Sensor Logger CSVs "
                                  "(Gyroscope.csv) nor an OpenCamera-Sensors *_gyro.csv", path);
        return 0;
    }
    if (sp_import_is_zip(path)) {
        *out = SP_IMPORT_IMU_SENSOR_LOGGER;
        return 0;
    }
    int rc = first_line(path, line, sizeof(line));
    if (rc)
        return sp_import_fail(msg, msg_size, rc, "%s: cannot open: %s", path, sp_strerror(rc));
    if (strncmp(line, "GYROFLOW IMU LOG", 16) == 0 || strncmp(line, "CAMERA IMU LOG", 14) == 0)
        *out = SP_IMPORT_IMU_GCSV;
    else if (strstr(line, "seconds_elapsed"))
        *out = SP_IMPORT_IMU_SENSOR_LOGGER;
    else if (numeric_fields(line) == 4)
        *out = SP_IMPORT_IMU_OPENCAMERA;
    else
        *out = SP_IMPORT_IMU_SUNPROBE;
    return 0;
}

int sp_import_log_load(sp_import_log *log, const char *path, int format, const char *near, int want_video, char *msg,
                       size_t msg_size)
{
    memset(log, 0, sizeof(*log));
    int rc;
    switch (format) {
    case SP_IMPORT_IMU_SENSOR_LOGGER: rc = load_sensor_logger(log, path, near, want_video, msg, msg_size); break;
    case SP_IMPORT_IMU_OPENCAMERA: rc = load_opencamera(log, path, msg, msg_size); break;
    case SP_IMPORT_IMU_GCSV: rc = sp_import_log_gcsv(log, path, msg, msg_size); break;
    default: return sp_import_fail(msg, msg_size, -EINVAL, "unknown IMU log format %d", format);
    }
    if (!rc)
        qsort(log->s, log->n, sizeof(*log->s), by_time);
    return rc;
}
