/* SPDX-License-Identifier: MIT */
/*
 * Importers: image sequence or video (+ IMU CSV, frame times, META JSON) -> .spcap.
 * The capture is written to "<out>.partial" and renamed into place only when
 * complete, so a failed or interrupted import never leaves a file that looks valid.
 * Memory is bounded by one decoded frame, one encoded frame and one IMU batch,
 * plus the list of input file names and the frame-times table.
 */
#include "sunprobe/sp_import.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "capture/container_format.h"
#include "capture/import_csv.h"
#include "capture/opencv_shim.h"
#include "common/jpeg.h"
#include "common/json.h"
#include "sp_config.h"
#include "sunprobe/sp_capture.h"
#include "sunprobe/sp_meta.h"

#define MAX_IMAGE_FILE (SPC_MAX_PAYLOAD - SPC_FRAME_HDR_SIZE)
#define MAX_META_FILE (1u << 20)
#define MAX_IMU_OFFSET_S 1e6

typedef struct path_list {
    char **items;
    size_t count, cap;
} path_list;

/* The IMU CSV, read one row at a time; a row yields up to one sample per sensor. */
typedef struct imu_reader {
    sp_csv csv;
    int open;
    int col_t, col_tns;
    int cols[3][3];         /* [gyro, accel, mag][x, y, z] column indices, -1 when absent */
    int64_t shift_ns;       /* added to CSV times: --imu-offset minus the first frame's CSV time */
    int64_t last_row_ns;
    int64_t last_ns[3];
    int have_row, have_sensor[3];
    sp_imu_sample row[3];
    int nrow, irow;
    int eof;
} imu_reader;

typedef struct import_ctx {
    const sp_import_settings *s;
    sp_import_report *rep;
    path_list images;        /* image sequence, or empty for a video */
    sp_cv_video_reader *video;
    uint32_t video_w, video_h;
    double video_fps;        /* as the video declares it, 0 if unknown */
    uint64_t total;          /* frames expected, 0 if unknown */
    uint64_t index;          /* next frame */
    double fps;
    int64_t *times;          /* frame-times CSV in ns, or NULL */
    size_t ntimes;
    imu_reader imu;
    sp_imu_sample *batch;
    size_t nbatch;
    sp_json *meta_root;      /* the user's META JSON, or NULL */
    sp_capture_meta meta;
    sp_capture_writer *writer;
    char *partial;
    uint8_t *file_buf;
    size_t file_cap, file_size;
    uint8_t *rgb;
    size_t rgb_cap;
    sp_jpeg_buffer jpeg;
} import_ctx;

static const char *const sensor_cols[3][3] = { { "gx", "gy", "gz" }, { "ax", "ay", "az" }, { "mx", "my", "mz" } };
static const uint32_t sensor_kinds[3] = { SP_IMU_GYRO, SP_IMU_ACCEL, SP_IMU_MAG };

/* Keeps the first message: it names the cause, later ones only the consequences. */
static int fail(import_ctx *c, int rc, const char *fmt, ...) SP_PRINTF(3, 4);
static int fail(import_ctx *c, int rc, const char *fmt, ...)
{
    if (c->rep->message[0] == 0) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(c->rep->message, sizeof(c->rep->message), fmt, ap);
        va_end(ap);
    }
    return rc;
}

void sp_import_default_settings(sp_import_settings *s)
{
    if (!s)
        return;
    memset(s, 0, sizeof(*s));
    s->store = SP_IMPORT_STORE_JPEG;
    s->quality = 92;
    s->imu_batch = 256;
}

/* ---- input file lists ---- */

static int list_add(path_list *l, const char *dir, const char *name)
{
    if (l->count == l->cap) {
        size_t cap = l->cap ? l->cap * 2 : 64;
        char **p = realloc(l->items, cap * sizeof(*p));
        if (!p)
            return -ENOMEM;
        l->items = p;
        l->cap = cap;
    }
    size_t n = (dir ? strlen(dir) + 1 : 0) + strlen(name) + 1;
    char *path = malloc(n);
    if (!path)
        return -ENOMEM;
    if (dir)
        snprintf(path, n, "%s/%s", dir, name);
    else
        snprintf(path, n, "%s", name);
    l->items[l->count++] = path;
    return 0;
}

static void list_free(path_list *l)
{
    for (size_t i = 0; i < l->count; i++)
        free(l->items[i]);
    free(l->items);
    memset(l, 0, sizeof(*l));
}

static int has_ext(const char *name, const char *ext)
{
    size_t n = strlen(name), e = strlen(ext);
    return n > e && strcasecmp(name + n - e, ext) == 0;
}

static int is_image_name(const char *name)
{
    return has_ext(name, ".jpg") || has_ext(name, ".jpeg") || has_ext(name, ".png");
}

/* Name order in which digit runs compare as numbers: img_2 before img_10. */
static int natural_cmp(const char *a, const char *b)
{
    const char *a0 = a, *b0 = b;
    while (*a && *b) {
        if (isdigit((unsigned char)*a) && isdigit((unsigned char)*b)) {
            while (*a == '0')
                a++;
            while (*b == '0')
                b++;
            size_t na = 0, nb = 0;
            while (isdigit((unsigned char)a[na]))
                na++;
            while (isdigit((unsigned char)b[nb]))
                nb++;
            if (na != nb)
                return na < nb ? -1 : 1;
            int d = memcmp(a, b, na);
            if (d)
                return d;
            a += na;
            b += nb;
        } else if (*a != *b) {
            return (unsigned char)*a - (unsigned char)*b;
        } else {
            a++;
            b++;
        }
    }
    if (*a || *b)
        return (unsigned char)*a - (unsigned char)*b;
    return strcmp(a0, b0); /* equal numbers with different zero padding: still a total order */
}

static int path_cmp(const void *pa, const void *pb)
{
    return natural_cmp(*(char *const *)pa, *(char *const *)pb);
}

static int is_regular(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

static int list_directory(import_ctx *c, const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) {
        int rc = -errno;
        return fail(c, rc, "%s: cannot open directory: %s", dir, sp_strerror(rc));
    }
    int rc = 0;
    struct dirent *e;
    while (!rc && (e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.' || !is_image_name(e->d_name))
            continue;
        rc = list_add(&c->images, dir, e->d_name);
        if (!rc && !is_regular(c->images.items[c->images.count - 1]))
            free(c->images.items[--c->images.count]); /* a directory called x.png */
    }
    closedir(d);
    if (rc)
        return fail(c, rc, "%s: listing: %s", dir, sp_strerror(rc));
    if (c->images.count == 0)
        return fail(c, SP_ENODATA, "%s: no .jpg, .jpeg or .png files in this directory", dir);
    qsort(c->images.items, c->images.count, sizeof(char *), path_cmp);
    return 0;
}

/* A printf pattern with exactly one %d, %0Nd or %Nd; "%%" is a literal percent sign. */
typedef struct pattern {
    char prefix[4096], suffix[4096];
    int width, zero;
} pattern;

static int parse_pattern(const char *in, pattern *p)
{
    memset(p, 0, sizeof(*p));
    char *out = p->prefix;
    size_t n = 0, cap = sizeof(p->prefix);
    int convs = 0;
    for (const char *s = in; *s; s++) {
        if (*s == '%' && s[1] == '%') {
            s++;
        } else if (*s == '%') {
            s++;
            p->zero = *s == '0';
            while (isdigit((unsigned char)*s))
                p->width = p->width * 10 + (*s++ - '0');
            if (*s != 'd' || p->width > 12 || ++convs > 1)
                return -EINVAL;
            out[n] = 0;
            out = p->suffix;
            n = 0;
            cap = sizeof(p->suffix);
            continue;
        }
        if (n + 1 >= cap)
            return -ENAMETOOLONG;
        out[n++] = *s;
    }
    out[n] = 0;
    return convs == 1 ? 0 : -EINVAL;
}

static void expand_pattern(const pattern *p, long i, char *out, size_t size)
{
    if (p->zero)
        snprintf(out, size, "%s%0*ld%s", p->prefix, p->width, i, p->suffix);
    else
        snprintf(out, size, "%s%*ld%s", p->prefix, p->width, i, p->suffix);
}

static int list_pattern(import_ctx *c, const char *in)
{
    pattern *p = malloc(sizeof(*p));
    char *path = malloc(8300);
    if (!p || !path) {
        free(p);
        free(path);
        return -ENOMEM;
    }
    int rc = parse_pattern(in, p);
    if (rc) {
        rc = fail(c, -EINVAL, "%s: not a file, and not a pattern with one %%d, %%0Nd or %%Nd", in);
        goto out;
    }
    long first = 0; /* like other tools, the sequence may start at any index from 0 to 4 */
    for (; first <= 4; first++) {
        expand_pattern(p, first, path, 8300);
        if (is_regular(path))
            break;
    }
    for (long i = first; !rc && first <= 4; i++) {
        expand_pattern(p, i, path, 8300);
        if (!is_regular(path))
            break;
        rc = list_add(&c->images, NULL, path);
    }
    if (!rc && c->images.count == 0)
        rc = fail(c, SP_ENODATA, "%s: no file matches this pattern (first index tried 0 to 4)", in);
out:
    free(p);
    free(path);
    return rc;
}

/* ---- reading one image ---- */

static int read_file(import_ctx *c, const char *path)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
        int rc = -errno;
        return fail(c, rc, "%s: cannot open: %s", path, sp_strerror(rc));
    }
    struct stat st;
    int rc = fstat(fd, &st) ? -errno : 0;
    if (!rc && (st.st_size <= 0 || (uint64_t)st.st_size > MAX_IMAGE_FILE))
        rc = fail(c, SP_EFORMAT, "%s: %s", path, st.st_size <= 0 ? "empty file" : "file too large for one frame");
    if (!rc && (size_t)st.st_size > c->file_cap) {
        uint8_t *p = realloc(c->file_buf, (size_t)st.st_size);
        rc = p ? 0 : -ENOMEM;
        if (p) {
            c->file_buf = p;
            c->file_cap = (size_t)st.st_size;
        }
    }
    size_t got = 0;
    while (!rc && got < (size_t)st.st_size) {
        ssize_t n = read(fd, c->file_buf + got, (size_t)st.st_size - got);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0)
            rc = n < 0 ? -errno : -EIO; /* the file shrank under us */
        else
            got += (size_t)n;
    }
    close(fd);
    c->file_size = got;
    return rc ? fail(c, rc, "%s: read failed: %s", path, sp_strerror(rc)) : 0;
}

static int ensure_rgb(import_ctx *c, uint32_t w, uint32_t h)
{
    size_t need = (size_t)w * h * 3;
    if (need <= c->rgb_cap)
        return 0;
    uint8_t *p = realloc(c->rgb, need);
    if (!p)
        return -ENOMEM;
    c->rgb = p;
    c->rgb_cap = need;
    return 0;
}

/* Fills f with the RGB24 image in c->rgb, or its JPEG re-encoding. */
static int frame_from_rgb(import_ctx *c, const char *what, uint32_t w, uint32_t h, sp_frame *f)
{
    f->width = w;
    f->height = h;
    if (c->s->store == SP_IMPORT_STORE_RGB) {
        f->format = SP_PIXFMT_RGB24;
        f->stride = w * 3;
        f->data = c->rgb;
        f->bytes_used = (size_t)w * h * 3;
        return 0;
    }
    int rc = sp_jpeg_encode_rgb24(c->rgb, w, h, w * 3, c->s->quality, &c->jpeg);
    if (rc == SP_EDISABLED)
        return fail(c, rc, "%s: storing as JPEG needs libjpeg; rebuild with -Djpeg=enabled or use --store rgb", what);
    if (rc)
        return fail(c, rc, "%s: JPEG encoding failed: %s", what, sp_strerror(rc));
    f->format = SP_PIXFMT_MJPEG;
    f->stride = 0;
    f->data = c->jpeg.data;
    f->bytes_used = c->jpeg.size;
    return 0;
}

static int frame_from_jpeg_file(import_ctx *c, const char *path, sp_frame *f)
{
    sp_jpeg_header hdr;
    int rc = sp_jpeg_parse_header(c->file_buf, c->file_size, &hdr);
    if (rc)
        return fail(c, SP_EFORMAT, "%s: not a valid JPEG (%s)", path, sp_strerror(rc));
    if (hdr.components == 4)
        return fail(c, SP_EUNSUPPORTED, "%s: CMYK JPEG is not supported", path);
    if (c->s->store == SP_IMPORT_STORE_JPEG) { /* byte-for-byte: no generation loss */
        *f = (sp_frame){ .format = SP_PIXFMT_MJPEG, .width = hdr.width, .height = hdr.height,
                         .data = c->file_buf, .bytes_used = c->file_size };
        c->rep->frames_copied++;
        return 0;
    }
    if ((rc = ensure_rgb(c, hdr.width, hdr.height)) != 0)
        return fail(c, rc, "%s: %s", path, sp_strerror(rc));
    rc = sp_jpeg_decode(c->file_buf, c->file_size, SP_PIXFMT_RGB24, hdr.width, hdr.height, c->rgb, c->rgb_cap,
                        hdr.width * 3);
    if (rc == SP_EDISABLED)
        return fail(c, rc, "%s: decoding JPEG for --store rgb needs libjpeg; rebuild with -Djpeg=enabled", path);
    if (rc)
        return fail(c, SP_EFORMAT, "%s: cannot decode JPEG: %s", path, sp_strerror(rc));
    return frame_from_rgb(c, path, hdr.width, hdr.height, f);
}

static int frame_from_png_file(import_ctx *c, const char *path, sp_frame *f)
{
#if HAVE_OPENCV
    uint32_t w = 0, h = 0;
    int rc = sp_cv_image_decode(c->file_buf, c->file_size, &c->rgb, &c->rgb_cap, &w, &h);
    if (rc)
        return fail(c, rc, "%s: cannot decode image: %s", path, sp_strerror(rc));
    return frame_from_rgb(c, path, w, h, f);
#else
    (void)f;
    return fail(c, SP_EDISABLED, "%s: decoding PNG needs OpenCV; rebuild with -Dopencv=enabled (JPEG sequences "
                "import without it)", path);
#endif
}

static int next_image(import_ctx *c, sp_frame *f)
{
    if (c->index >= c->images.count)
        return SP_EOS;
    const char *path = c->images.items[c->index];
    int rc = read_file(c, path);
    if (rc)
        return rc;
    static const uint8_t png_magic[8] = { 0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n' };
    if (c->file_size >= 2 && c->file_buf[0] == 0xFF && c->file_buf[1] == 0xD8)
        return frame_from_jpeg_file(c, path, f);
    if (c->file_size >= 8 && memcmp(c->file_buf, png_magic, 8) == 0)
        return frame_from_png_file(c, path, f);
    return fail(c, SP_EFORMAT, "%s: neither a JPEG nor a PNG file", path);
}

/* ---- video ---- */

static int open_video(import_ctx *c, const char *path)
{
#if HAVE_OPENCV
    sp_cv_video_info info;
    int rc = sp_cv_video_open(&c->video, path, &info);
    if (rc == SP_EFORMAT)
        return fail(c, rc, "%s: OpenCV cannot open or decode this as a video", path);
    if (rc)
        return fail(c, rc, "%s: %s", path, sp_strerror(rc));
    if ((rc = ensure_rgb(c, info.width, info.height)) != 0)
        return rc;
    c->video_w = info.width;
    c->video_h = info.height;
    c->total = info.frame_count > 0 ? (uint64_t)info.frame_count : 0;
    if (isfinite(info.fps) && info.fps > 0 && info.fps <= 1000)
        c->video_fps = info.fps;
    if (c->s->store == SP_IMPORT_STORE_JPEG && !sp_jpeg_available())
        return fail(c, SP_EDISABLED, "%s: storing video frames as JPEG needs libjpeg; rebuild with "
                    "-Djpeg=enabled or use --store rgb", path);
    return 0;
#else
    return fail(c, SP_EDISABLED, "%s: importing video needs OpenCV; rebuild with -Dopencv=enabled", path);
#endif
}

static int next_video_frame(import_ctx *c, sp_frame *f)
{
#if HAVE_OPENCV
    int rc = sp_cv_video_read(c->video, c->rgb, c->rgb_cap, c->video_w * 3);
    if (rc == SP_EOS)
        return rc;
    if (rc)
        return fail(c, rc == SP_ECORRUPT ? SP_EFORMAT : rc, "%s: frame %llu: %s", c->s->input,
                    (unsigned long long)c->index, rc == SP_ECORRUPT ? "frame size changed" : sp_strerror(rc));
    return frame_from_rgb(c, c->s->input, c->video_w, c->video_h, f);
#else
    (void)f;
    return fail(c, SP_EDISABLED, "%s: importing video needs OpenCV; rebuild with -Dopencv=enabled", c->s->input);
#endif
}

/* ---- frame times ---- */

static int time_columns(sp_csv *csv, int *col_t, int *col_tns)
{
    *col_t = sp_csv_column(csv, "t");
    *col_tns = sp_csv_column(csv, "t_ns");
    if (*col_t >= 0 && *col_tns >= 0)
        return sp_csv_fail(csv, SP_ECORRUPT, "has both 't' and 't_ns' columns; keep one");
    if (*col_t < 0 && *col_tns < 0)
        return sp_csv_fail(csv, SP_ECORRUPT, "needs a 't' (seconds) or 't_ns' (nanoseconds) column");
    return 0;
}

static int push_time(import_ctx *c, size_t *cap, int64_t t)
{
    if (c->ntimes == *cap) {
        size_t n = *cap ? *cap * 2 : 1024;
        int64_t *p = realloc(c->times, n * sizeof(*p));
        if (!p)
            return -ENOMEM;
        c->times = p;
        *cap = n;
    }
    c->times[c->ntimes++] = t;
    return 0;
}

static int load_frame_times(import_ctx *c, const char *path)
{
    sp_csv csv;
    int rc = sp_csv_open(&csv, path, c->rep->message, sizeof(c->rep->message));
    if (rc)
        return rc;
    int col_t, col_tns;
    size_t cap = 0;
    rc = time_columns(&csv, &col_t, &col_tns);
    while (!rc && (rc = sp_csv_next(&csv)) == 0) {
        int64_t t;
        rc = sp_csv_time_ns(&csv, col_t, col_tns, &t);
        if (!rc && c->ntimes && t <= c->times[c->ntimes - 1])
            rc = sp_csv_fail(&csv, SP_ECORRUPT, "frame time is not after the previous row's (times must increase)");
        if (!rc)
            rc = push_time(c, &cap, t);
    }
    if (rc == SP_EOS)
        rc = c->ntimes ? 0 : sp_csv_fail(&csv, SP_ENODATA, "no frame times after the header");
    sp_csv_close(&csv);
    return rc;
}

static int frame_time(import_ctx *c, uint64_t i, int64_t *out)
{
    if (c->times) {
        if (i >= c->ntimes)
            return fail(c, SP_ECORRUPT, "%s: has %zu frame times, but the input has more frames",
                        c->s->frame_times_csv, c->ntimes);
        *out = c->times[i] - c->times[0];
        return 0;
    }
    *out = llround((double)i * 1e9 / c->fps);
    return 0;
}

/* ---- IMU CSV ---- */

static int imu_open(import_ctx *c, imu_reader *r, const char *path)
{
    memset(r, 0, sizeof(*r));
    int rc = sp_csv_open(&r->csv, path, c->rep->message, sizeof(c->rep->message));
    if (rc)
        return rc;
    r->open = 1;
    if ((rc = time_columns(&r->csv, &r->col_t, &r->col_tns)) != 0)
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
        return sp_csv_fail(&r->csv, SP_ECORRUPT, "no sensor columns: expected gx,gy,gz and/or ax,ay,az and/or mx,my,mz");
    /* IMU times share the clock of the frame times (or start at the first frame); then the offset */
    int64_t t0 = c->times ? c->times[0] : 0;
    r->shift_ns = llround(c->s->imu_offset_s * 1e9) - t0;
    return 0;
}

/* One sensor's three cells of the current row: 1 sample, 0 all empty, or an error. */
static int imu_cells(imu_reader *r, int k, int64_t t, sp_imu_sample *out)
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

static int imu_read_row(imu_reader *r)
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

/* The next sample without taking it: 0, SP_EOS, or an error (message already set). */
static int imu_peek(imu_reader *r, const sp_imu_sample **out)
{
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

static int write_batch(import_ctx *c)
{
    if (c->nbatch == 0)
        return 0;
    int rc = sp_capture_write_imu(c->writer, c->batch, c->nbatch);
    if (rc)
        return fail(c, rc, "%s: writing IMU samples: %s", c->partial, sp_strerror(rc));
    c->rep->imu_samples += c->nbatch;
    c->rep->imu_chunks++;
    c->nbatch = 0;
    return 0;
}

/* Writes every IMU sample up to limit_ns, so a frame follows the samples that precede it in file order. */
static int flush_imu(import_ctx *c, int64_t limit_ns)
{
    if (!c->imu.open)
        return 0;
    const sp_imu_sample *smp;
    int rc;
    while ((rc = imu_peek(&c->imu, &smp)) == 0 && smp->timestamp_ns <= limit_ns) {
        c->batch[c->nbatch++] = *smp;
        c->imu.irow++;
        if (c->nbatch == c->s->imu_batch && (rc = write_batch(c)) != 0)
            return rc;
    }
    if (rc && rc != SP_EOS)
        return rc;
    return write_batch(c);
}

/* ---- metadata ---- */

static int read_text(import_ctx *c, const char *path, char **out, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        int rc = -errno;
        return fail(c, rc, "%s: cannot open: %s", path, sp_strerror(rc));
    }
    char *buf = malloc(MAX_META_FILE + 1);
    size_t n = buf ? fread(buf, 1, MAX_META_FILE + 1, f) : 0;
    int rc = !buf ? -ENOMEM : ferror(f) ? -EIO : n > MAX_META_FILE ? -EFBIG : 0;
    fclose(f);
    if (rc) {
        free(buf);
        return fail(c, rc, "%s: %s", path, rc == -EFBIG ? "larger than 1 MiB" : sp_strerror(rc));
    }
    buf[n] = 0;
    *out = buf;
    *len = n;
    return 0;
}

typedef struct key_type {
    const char *key;
    sp_json_type type;
    size_t count; /* arrays: exact length, else 0 */
} key_type;

static const key_type top_keys[] = {
    { "kind", SP_JSON_STRING, 0 },    { "source", SP_JSON_STRING, 0 }, { "utc_start", SP_JSON_STRING, 0 },
    { "ground_truth", SP_JSON_STRING, 0 }, { "camera", SP_JSON_OBJECT, 0 }, { "imu", SP_JSON_OBJECT, 0 },
    { "location", SP_JSON_OBJECT, 0 }, { NULL, SP_JSON_NULL, 0 },
};
static const key_type camera_keys[] = {
    { "name", SP_JSON_STRING, 0 },  { "driver", SP_JSON_STRING, 0 }, { "width", SP_JSON_NUMBER, 0 },
    { "height", SP_JSON_NUMBER, 0 }, { "fps", SP_JSON_NUMBER, 0 },    { "fx", SP_JSON_NUMBER, 0 },
    { "fy", SP_JSON_NUMBER, 0 },    { "cx", SP_JSON_NUMBER, 0 },     { "cy", SP_JSON_NUMBER, 0 },
    { "focal_length_mm", SP_JSON_NUMBER, 0 }, { "sensor_width_mm", SP_JSON_NUMBER, 0 }, { NULL, SP_JSON_NULL, 0 },
};
static const key_type imu_keys[] = {
    { "name", SP_JSON_STRING, 0 },         { "rate_hz", SP_JSON_NUMBER, 0 },   { "time_offset_s", SP_JSON_NUMBER, 0 },
    { "to_camera", SP_JSON_ARRAY, 4 },     { "gyro_bias", SP_JSON_ARRAY, 3 },  { "accel_bias", SP_JSON_ARRAY, 3 },
    { NULL, SP_JSON_NULL, 0 },
};
static const key_type location_keys[] = {
    { "latitude", SP_JSON_NUMBER, 0 }, { "longitude", SP_JSON_NUMBER, 0 }, { "altitude_m", SP_JSON_NUMBER, 0 },
    { NULL, SP_JSON_NULL, 0 },
};

static const char *type_name(sp_json_type t)
{
    static const char *const names[] = { "null", "a boolean", "a number", "a string", "an array", "an object" };
    return (unsigned)t < 6 ? names[t] : "?";
}

/* Known keys must have their schema type (null means "unknown" and is allowed); unknown keys pass through. */
static int check_keys(import_ctx *c, const char *path, const char *prefix, const sp_json *obj, const key_type *keys)
{
    for (const key_type *k = keys; k->key; k++) {
        const sp_json *v = sp_json_get(obj, k->key);
        if (!v || v->type == SP_JSON_NULL)
            continue;
        if (v->type != k->type)
            return fail(c, SP_ECORRUPT, "%s: %s%s must be %s, not %s", path, prefix, k->key, type_name(k->type),
                        type_name(v->type));
        if (k->count && (v->count != k->count || sp_json_numbers(v, (double[4]){ 0 }, k->count) != k->count))
            return fail(c, SP_ECORRUPT, "%s: %s%s must be an array of %zu numbers", path, prefix, k->key, k->count);
    }
    return 0;
}

static int load_meta(import_ctx *c, const char *path)
{
    char *text = NULL, err[160];
    size_t len = 0;
    int rc = read_text(c, path, &text, &len);
    if (rc)
        return rc;
    rc = sp_json_parse(text, len, &c->meta_root, err, sizeof(err));
    if (rc)
        rc = fail(c, SP_ECORRUPT, "%s: %s", path, err);
    else if (c->meta_root->type != SP_JSON_OBJECT)
        rc = fail(c, SP_ECORRUPT, "%s: must hold one JSON object", path);
    if (!rc)
        rc = check_keys(c, path, "", c->meta_root, top_keys);
    if (!rc)
        rc = check_keys(c, path, "camera.", sp_json_get(c->meta_root, "camera"), camera_keys);
    if (!rc)
        rc = check_keys(c, path, "imu.", sp_json_get(c->meta_root, "imu"), imu_keys);
    if (!rc)
        rc = check_keys(c, path, "location.", sp_json_get(c->meta_root, "location"), location_keys);
    /* ranges and the rest, exactly as readers will judge the chunk */
    if (!rc && sp_capture_meta_merge(&c->meta, text, len) != 0)
        rc = fail(c, SP_ECORRUPT, "%s: a value is out of range or invalid for the META schema (capture/FORMAT.md)",
                  path);
    free(text);
    return rc;
}

static void put_value(sp_strbuf *b, const sp_json *v);

static void put_member(sp_strbuf *b, int *first, const char *key)
{
    if (!*first)
        sp_strbuf_append(b, ",", 1);
    *first = 0;
    sp_strbuf_json_string(b, key);
    sp_strbuf_append(b, ":", 1);
}

static int in_list(const char *key, const char *const *list)
{
    for (; list && *list; list++)
        if (strcmp(key, *list) == 0)
            return 1;
    return 0;
}

static void put_members(sp_strbuf *b, const sp_json *obj, const char *const *skip, int *first)
{
    for (size_t i = 0; obj && obj->type == SP_JSON_OBJECT && i < obj->count; i++) {
        if (in_list(obj->keys[i], skip))
            continue;
        put_member(b, first, obj->keys[i]);
        put_value(b, &obj->items[i]);
    }
}

static void put_value(sp_strbuf *b, const sp_json *v)
{
    int first = 1;
    switch (v->type) {
    case SP_JSON_NULL:
        sp_strbuf_append(b, "null", 4);
        break;
    case SP_JSON_BOOL:
        sp_strbuf_printf(b, "%s", v->number != 0 ? "true" : "false");
        break;
    case SP_JSON_NUMBER:
        sp_strbuf_json_number(b, v->number);
        break;
    case SP_JSON_STRING:
        sp_strbuf_json_string(b, v->string);
        break;
    case SP_JSON_ARRAY:
        sp_strbuf_append(b, "[", 1);
        for (size_t i = 0; i < v->count; i++) {
            if (i)
                sp_strbuf_append(b, ",", 1);
            put_value(b, &v->items[i]);
        }
        sp_strbuf_append(b, "]", 1);
        break;
    case SP_JSON_OBJECT:
        sp_strbuf_append(b, "{", 1);
        put_members(b, v, NULL, &first);
        sp_strbuf_append(b, "}", 1);
        break;
    }
}

/* The user's JSON with the facts the import knows put over it: kind, source, camera size and rate. */
static int build_meta(import_ctx *c, uint32_t w, uint32_t h, sp_strbuf *b)
{
    const sp_json *root = c->meta_root;
    const char *kind = c->s->kind ? c->s->kind : sp_json_string(sp_json_get(root, "kind"), NULL);
    const char *source = sp_json_string(sp_json_get(root, "source"), NULL);
    static const char *const top_skip[] = { "kind", "source", "camera", NULL };
    static const char *const cam_skip[] = { "width", "height", "fps", NULL };
    int first = 1, cam_first = 1;
    sp_strbuf_append(b, "{", 1);
    put_members(b, root, top_skip, &first);
    if (kind) {
        put_member(b, &first, "kind");
        sp_strbuf_json_string(b, kind);
    }
    put_member(b, &first, "source");
    if (source) {
        sp_strbuf_json_string(b, source);
    } else {
        sp_strbuf tmp = { 0 };
        sp_strbuf_printf(&tmp, "import:%s", c->s->input); /* FORMAT.md: the imported file name */
        sp_strbuf_json_string(b, tmp.failed ? "import" : tmp.data);
        sp_strbuf_free(&tmp);
    }
    put_member(b, &first, "camera");
    sp_strbuf_append(b, "{", 1);
    put_members(b, sp_json_get(root, "camera"), cam_skip, &cam_first);
    put_member(b, &cam_first, "width");
    sp_strbuf_printf(b, "%u", w);
    put_member(b, &cam_first, "height");
    sp_strbuf_printf(b, "%u", h);
    if (c->fps > 0) {
        put_member(b, &cam_first, "fps");
        sp_strbuf_json_number(b, c->fps);
    }
    sp_strbuf_append(b, "}}", 2);
    return b->failed ? -ENOMEM : 0;
}

static int write_meta(import_ctx *c, uint32_t w, uint32_t h)
{
    if (c->meta.width && (c->meta.width != w || c->meta.height != h))
        return fail(c, SP_ECORRUPT, "%s: camera is %ux%u, but the frames are %ux%u", c->s->meta_json,
                    c->meta.width, c->meta.height, w, h);
    if (isfinite(c->meta.fps) && c->fps > 0 && fabs(c->meta.fps - c->fps) > 1e-3 * c->fps)
        sp_log(SP_LOG_WARN, "import", "%s: camera.fps %g replaced by %g, the rate of the timestamps",
               c->s->meta_json, c->meta.fps, c->fps);
    sp_strbuf b = { 0 };
    int rc = build_meta(c, w, h, &b);
    if (!rc)
        rc = sp_capture_write_meta(c->writer, 0, b.data, b.len);
    sp_strbuf_free(&b);
    return rc ? fail(c, rc, "%s: writing metadata: %s", c->partial, sp_strerror(rc)) : 0;
}

/* ---- the run ---- */

static int check_settings(import_ctx *c)
{
    const sp_import_settings *s = c->s;
    if (!s->input || !*s->input || !s->output || !*s->output)
        return fail(c, -EINVAL, "an input and an output path are required");
    if (s->quality < 1 || s->quality > 100)
        return fail(c, -EINVAL, "JPEG quality %d is not in 1..100", s->quality);
    if (!isfinite(s->fps) || s->fps < 0 || s->fps > 1e4)
        return fail(c, -EINVAL, "frame rate %g is not in (0, 10000]", s->fps);
    if (!isfinite(s->imu_offset_s) || fabs(s->imu_offset_s) > MAX_IMU_OFFSET_S)
        return fail(c, -EINVAL, "IMU offset %g s is not a finite number of at most 1e6 s", s->imu_offset_s);
    if (s->store != SP_IMPORT_STORE_JPEG && s->store != SP_IMPORT_STORE_RGB)
        return fail(c, -EINVAL, "unknown storage mode %d", (int)s->store);
    if (s->kind && strcmp(s->kind, "selfie") != 0 && strcmp(s->kind, "static") != 0)
        return fail(c, -EINVAL, "kind '%s' is neither 'selfie' nor 'static'", s->kind);
    if (s->imu_batch == 0 || s->imu_batch > (1u << 20))
        return fail(c, -EINVAL, "IMU batch size %u is not in 1..1048576", s->imu_batch);
    if (!s->overwrite && access(s->output, F_OK) == 0)
        return fail(c, -EEXIST, "%s: already exists (use --force to replace it)", s->output);
    c->batch = malloc(s->imu_batch * sizeof(*c->batch));
    return c->batch ? 0 : -ENOMEM;
}

static int open_input(import_ctx *c)
{
    const char *in = c->s->input;
    struct stat st;
    int rc;
    if (stat(in, &st) == 0) {
        if (S_ISDIR(st.st_mode))
            rc = list_directory(c, in);
        else if (is_image_name(in))
            rc = list_add(&c->images, NULL, in);
        else
            rc = open_video(c, in);
    } else if (strchr(in, '%')) {
        rc = list_pattern(c, in);
    } else {
        rc = -errno;
        return fail(c, rc, "%s: %s", in, sp_strerror(rc));
    }
    if (!rc && !c->video)
        c->total = c->images.count;
    return rc;
}

/* --fps, else the rate of the frame-times CSV, else the video's, else camera.fps of the metadata. */
static int choose_fps(import_ctx *c)
{
    if (c->s->fps > 0) {
        c->fps = c->s->fps;
    } else if (c->times && c->ntimes >= 2) {
        double span = (double)(c->times[c->ntimes - 1] - c->times[0]);
        c->fps = span > 0 ? (double)(c->ntimes - 1) * 1e9 / span : 0;
    } else if (c->video_fps > 0) {
        c->fps = c->video_fps;
    } else if (isfinite(c->meta.fps) && c->meta.fps > 0) {
        c->fps = c->meta.fps;
    }
    if (!(c->fps > 0) && !c->times)
        return fail(c, -EINVAL, "%s: no frame rate known: give --fps, a frame-times CSV, or camera.fps in the "
                    "metadata", c->s->input);
    c->rep->fps = c->fps;
    return 0;
}

static int open_output(import_ctx *c)
{
    size_t n = strlen(c->s->output) + sizeof(".partial");
    c->partial = malloc(n);
    if (!c->partial)
        return -ENOMEM;
    snprintf(c->partial, n, "%s.partial", c->s->output);
    sp_capture_writer_settings ws;
    sp_capture_writer_default_settings(&ws);
    ws.sync = SP_SYNC_NONE; /* a conversion: one sync at the end is enough */
    ws.overwrite = 1;       /* a .partial left by an interrupted run is garbage */
    int rc = sp_capture_writer_open(&c->writer, c->partial, &ws);
    if (rc) {
        rc = fail(c, rc, "%s: cannot create: %s", c->partial, sp_strerror(rc));
        free(c->partial); /* nothing of ours to remove */
        c->partial = NULL;
    }
    return rc;
}

static int next_frame(import_ctx *c, sp_frame *f)
{
    memset(f, 0, sizeof(*f));
    int rc = c->video ? next_video_frame(c, f) : next_image(c, f);
    if (rc)
        return rc;
    f->sequence = c->index;
    f->exposure_us = NAN;
    f->gain = NAN;
    return 0;
}

static int check_size(import_ctx *c, const sp_frame *f)
{
    if (c->index == 0) {
        c->rep->width = f->width;
        c->rep->height = f->height;
        return write_meta(c, f->width, f->height);
    }
    if (f->width == c->rep->width && f->height == c->rep->height)
        return 0;
    return fail(c, SP_EFORMAT, "%s: %ux%u, but the first frame is %ux%u",
                c->video ? c->s->input : c->images.items[c->index], f->width, f->height, c->rep->width,
                c->rep->height);
}

static void report_progress(import_ctx *c)
{
    if (!c->s->progress)
        return;
    uint64_t total = c->total;
    if (c->s->max_frames && (total == 0 || total > c->s->max_frames))
        total = c->s->max_frames;
    c->s->progress(c->s->progress_user, c->index, total);
}

static int import_frames(import_ctx *c)
{
    int rc = 0;
    while (!c->s->max_frames || c->index < c->s->max_frames) {
        if (c->s->cancel && *c->s->cancel)
            return fail(c, -ECANCELED, "interrupted after %llu frames", (unsigned long long)c->index);
        sp_frame f;
        if ((rc = next_frame(c, &f)) == SP_EOS)
            break;
        if (!rc)
            rc = check_size(c, &f);
        if (!rc)
            rc = frame_time(c, c->index, &f.timestamp_ns);
        if (!rc)
            rc = flush_imu(c, f.timestamp_ns);
        if (rc)
            return rc;
        if ((rc = sp_capture_write_frame(c->writer, &f)) != 0)
            return fail(c, rc, "%s: writing frame %llu: %s", c->partial, (unsigned long long)c->index,
                        sp_strerror(rc));
        c->rep->last_frame_ns = f.timestamp_ns;
        c->rep->frames = ++c->index;
        report_progress(c);
    }
    if (c->index == 0)
        return fail(c, SP_ENODATA, "%s: no frames", c->s->input);
    if (c->times && c->ntimes > c->index && !c->s->max_frames)
        sp_log(SP_LOG_WARN, "import", "%s: %zu frame times for %llu frames; the rest are ignored",
               c->s->frame_times_csv, c->ntimes, (unsigned long long)c->index);
    return flush_imu(c, INT64_MAX); /* IMU samples after the last frame are kept too */
}

static int rename_into_place(import_ctx *c)
{
    const char *out = c->s->output;
    if (!c->s->overwrite) {
        if (renameat2(AT_FDCWD, c->partial, AT_FDCWD, out, RENAME_NOREPLACE) == 0)
            return 0;
        if (errno != EINVAL && errno != ENOSYS) /* file systems without RENAME_NOREPLACE: check, then rename */
            return -errno;
        if (access(out, F_OK) == 0)
            return -EEXIST;
    }
    return rename(c->partial, out) == 0 ? 0 : -errno;
}

static int finish_output(import_ctx *c)
{
    int rc = sp_capture_writer_close(&c->writer);
    if (rc)
        return fail(c, rc, "%s: finishing the capture: %s", c->partial, sp_strerror(rc));
    rc = rename_into_place(c);
    if (rc)
        return fail(c, rc, "%s: cannot rename to %s: %s", c->partial, c->s->output, sp_strerror(rc));
    free(c->partial);
    c->partial = NULL;
    rc = spc_sync_parent_dir(c->s->output);
    if (rc) /* the capture is complete; only the durability of its name is in doubt */
        sp_log(SP_LOG_WARN, "import", "%s: syncing its directory: %s", c->s->output, sp_strerror(rc));
    return 0;
}

static void cleanup(import_ctx *c)
{
    if (c->writer)
        sp_capture_writer_close(&c->writer);
    if (c->partial && unlink(c->partial) != 0 && errno != ENOENT)
        sp_log(SP_LOG_WARN, "import", "%s: could not remove: %s", c->partial, strerror(errno));
    free(c->partial);
#if HAVE_OPENCV
    sp_cv_video_close(&c->video);
#endif
    if (c->imu.open)
        sp_csv_close(&c->imu.csv);
    list_free(&c->images);
    sp_json_free(c->meta_root);
    sp_jpeg_buffer_free(&c->jpeg);
    free(c->times);
    free(c->batch);
    free(c->file_buf);
    free(c->rgb);
}

int sp_import_run(const sp_import_settings *s, sp_import_report *report)
{
    sp_import_report local;
    if (!report)
        report = &local;
    memset(report, 0, sizeof(*report));
    if (!s) {
        snprintf(report->message, sizeof(report->message), "no settings");
        return -EINVAL;
    }
    import_ctx c = { .s = s, .rep = report };
    sp_capture_meta_init(&c.meta);
    int rc = check_settings(&c);
    if (!rc)
        rc = open_input(&c);
    if (!rc && s->frame_times_csv)
        rc = load_frame_times(&c, s->frame_times_csv);
    if (!rc && s->meta_json)
        rc = load_meta(&c, s->meta_json);
    if (!rc)
        rc = choose_fps(&c);
    if (!rc && s->imu_csv)
        rc = imu_open(&c, &c.imu, s->imu_csv);
    if (!rc)
        rc = open_output(&c);
    if (!rc)
        rc = import_frames(&c);
    if (!rc)
        rc = finish_output(&c);
    if (rc && !report->message[0])
        snprintf(report->message, sizeof(report->message), "%s", sp_strerror(rc));
    cleanup(&c);
    return rc;
}
