/* SPDX-License-Identifier: MIT */
/*
 * The live capture check: a thread follows the growing capture file with the ordinary reader (it
 * re-reads the file size when it reaches the end; a chunk half written is read again later), feeds
 * each chunk to the same measurements `sunprobe check` makes and keeps a status line for the
 * terminal. Reading the file rather than tapping the recorder keeps the check off the capture path:
 * when it falls behind (the landmark tracker is the slow part) it lags, the recording does not.
 */
#include "live_check.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "check_capture.h"
#include "common/clock.h"
#include "sunprobe/sp_capture.h"

#define STATUS_PERIOD_NS 500000000  /* the status is refreshed at most twice a second */
#define IDLE_SLEEP_NS 50000000      /* at the end of what is written: wait for more */

struct sp_live_check {
    char path[4096];
    int find_faces;
    double face_interval_s;
    int64_t max_lag_ns;
    sp_check_scan *scan;           /* opened in the thread: loading the landmark model takes a while */
    sp_capture_reader *reader;
    pthread_t thread;
    pthread_mutex_t lock;
    char status[160];          /* under lock */
    atomic_int closing;        /* the recorder has closed the file: read to its end, then stop */
    int error;                 /* the thread's, read after join */
};

static void format_status(const sp_check_report *r, char *buf, size_t size)
{
    char face[32] = "face not looked for";
    if (isfinite(r->face_share))
        snprintf(face, sizeof(face), "face %.0f %%", 100 * r->face_share);
    if (r->gyro_samples)
        snprintf(buf, size, "turn %.0f deg of %d | %s | clipped %.0f %% | gyro %.0f Hz", r->turn_range_deg,
                 SP_CHECK_GOOD_TURN_DEG, face, 100 * r->clipped_share, r->gyro_hz);
    else
        snprintf(buf, size, "no gyro yet | %s | clipped %.0f %%", face, 100 * r->clipped_share);
}

static void refresh_status(sp_live_check *lc)
{
    sp_check_report r;
    if (sp_check_scan_report(lc->scan, &r) != 0 || r.frames == 0)
        return;
    char line[sizeof(lc->status)];
    format_status(&r, line, sizeof(line));
    pthread_mutex_lock(&lc->lock);
    memcpy(lc->status, line, sizeof(line));
    pthread_mutex_unlock(&lc->lock);
}

static void idle(void)
{
    nanosleep(&(struct timespec){ 0, IDLE_SLEEP_NS }, NULL);
}

/* Reads until the END chunk (or, once closing, the end of what was written); 0 or a read error. */
static int follow(sp_live_check *lc)
{
    int64_t next_status = 0;
    for (;;) {
        int closing = atomic_load(&lc->closing);
        if (!lc->reader) {
            int rc = sp_capture_reader_open(&lc->reader, lc->path, NULL);
            if (rc == 0)
                continue;
            if (closing) /* the recorder never wrote a header */
                return rc;
            idle(); /* not created, or its header not written yet */
            continue;
        }
        sp_chunk ch;
        int rc = sp_capture_reader_next(lc->reader, &ch);
        if (rc == 0) {
            if (ch.type == SP_CHUNK_FRAME) /* frames carry the camera's monotonic time */
                sp_check_scan_pause_faces(lc->scan, sp_clock_monotonic_ns() - ch.timestamp_ns > lc->max_lag_ns);
            if ((rc = sp_check_scan_chunk(lc->scan, &ch)) != 0)
                return rc;
        } else if (rc == SP_EOS && sp_capture_reader_saw_end(lc->reader)) {
            return 0;
        } else if (rc != SP_EOS && rc != SP_ETRUNCATED) {
            return rc;
        } else if (closing) { /* closed without an END (device lost, disk full): what is there is all */
            return 0;
        } else {
            idle();
        }
        int64_t now = sp_clock_monotonic_ns();
        if (now >= next_status) {
            refresh_status(lc);
            next_status = now + STATUS_PERIOD_NS;
        }
    }
}

static void *run(void *arg)
{
    sp_live_check *lc = arg;
    lc->error = sp_check_scan_open(&lc->scan, lc->find_faces, lc->face_interval_s);
    if (lc->error == 0)
        lc->error = follow(lc);
    return NULL;
}

int sp_live_check_start(sp_live_check **out, const char *path, int find_faces, double face_interval_s,
                        double max_lag_s)
{
    sp_live_check *lc = calloc(1, sizeof(*lc));
    if (!lc)
        return -ENOMEM;
    if (strlen(path) >= sizeof(lc->path)) {
        free(lc);
        return -ENAMETOOLONG;
    }
    strcpy(lc->path, path);
    lc->find_faces = find_faces;
    lc->face_interval_s = face_interval_s;
    lc->max_lag_ns = (int64_t)(max_lag_s * 1e9);
    pthread_mutex_init(&lc->lock, NULL);
    int rc = -pthread_create(&lc->thread, NULL, run, lc);
    if (rc) {
        pthread_mutex_destroy(&lc->lock);
        free(lc);
        return rc;
    }
    *out = lc;
    return 0;
}

void sp_live_check_status(sp_live_check *lc, char *buf, size_t size)
{
    pthread_mutex_lock(&lc->lock);
    snprintf(buf, size, "%s", lc->status);
    pthread_mutex_unlock(&lc->lock);
}

int sp_live_check_finish(sp_live_check **lcp, FILE *out)
{
    sp_live_check *lc = lcp ? *lcp : NULL;
    if (!lc)
        return 0;
    atomic_store(&lc->closing, 1);
    pthread_join(lc->thread, NULL);
    int rc = lc->error;
    sp_check_report r;
    if (rc == 0 && (rc = sp_check_scan_report(lc->scan, &r)) == 0) {
        sp_check_verdicts v = { 0 };
        fprintf(out, "capture check (as `sunprobe check` would say):\n");
        sp_check_judge(&r, out, &v);
        fprintf(out, "%s\n", v.fails   ? "this capture cannot work: re-shoot as said above"
                             : v.warns ? "usable, with the warnings above"
                                       : "good to fit");
    }
    sp_capture_reader_close(&lc->reader);
    sp_check_scan_close(&lc->scan);
    pthread_mutex_destroy(&lc->lock);
    free(lc);
    *lcp = NULL;
    return rc;
}
