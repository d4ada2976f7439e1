/* SPDX-License-Identifier: MIT */
/*
 * The selfie generator's write driver (sp_synth_selfie_write): the capture (synth_capture.c) and the truth
 * directory (synth_truth.c) under temporary names, committed together. Kept apart from the generator's core
 * (synth.c) so the calls run one way: driver -> writers -> core.
 */
#include "sunprobe/sp_synth.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "pipeline/synth/synth_internal.h"

/* Length of the leading path components a and b share (at a '/' or the end of both). */
static size_t common_components(const char *a, const char *b)
{
    size_t last = 0;
    for (size_t i = 0;; i++) {
        int ea = a[i] == '/' || !a[i], eb = b[i] == '/' || !b[i];
        if (ea && eb) {
            last = i;
            if (!a[i] || !b[i])
                return last;
        } else if (a[i] != b[i]) {
            return last;
        }
    }
}

/* Relative path from the directory of `from_file` to the existing path `to`; `to` itself if either fails to resolve. */
static char *relative_path(const char *from_file, const char *to)
{
    char *dir = strdup(from_file), *a = realpath(to, NULL), *b = NULL, *out = NULL;
    if (dir) {
        char *slash = strrchr(dir, '/');
        if (slash)
            slash[slash == dir ? 1 : 0] = '\0';
        b = realpath(slash ? dir : ".", NULL);
    }
    if (a && b) {
        size_t common = common_components(a, b), ups = 0;
        for (const char *q = b + common; *q; q++) /* components of b below the common part */
            ups += *q != '/' && (q == b || q[-1] == '/');
        const char *rest = a + common;
        rest += *rest == '/';
        size_t need = ups * 3 + strlen(rest) + 2;
        if ((out = malloc(need))) {
            out[0] = '\0';
            for (size_t k = 0; k < ups; k++)
                strcat(out, "../");
            if (*rest)
                strcat(out, rest);
            else if (ups)
                out[strlen(out) - 1] = '\0';
            else
                strcat(out, ".");
        }
    }
    free(a);
    free(b);
    free(dir);
    return out ? out : strdup(to);
}

/*
 * The truth directory exists afterwards (*made: this call created it). An existing one is replaced as a
 * whole at the end, so it must be empty or hold an earlier truth.json: never someone else's directory.
 */
static int make_dir(const char *dir, int *made)
{
    *made = mkdir(dir, 0777) == 0;
    if (*made)
        return 0;
    struct stat st;
    if (errno != EEXIST)
        return -errno;
    if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode))
        return -ENOTDIR;
    char *manifest = sp_path_join_alloc(dir, "truth.json");
    if (!manifest)
        return -ENOMEM;
    /* rmdir succeeds on an empty directory only: put it back as it was */
    int ours = sp_is_regular_file(manifest) || (rmdir(dir) == 0 && mkdir(dir, 0777) == 0);
    free(manifest);
    return ours ? 0 : -EEXIST;
}

int sp_synth_selfie_write(sp_synth_selfie *g, const char *capture_path, const char *truth_dir,
                          sp_synth_selfie_report *report)
{
    if (!g || !capture_path || !*capture_path || (truth_dir && !*truth_dir))
        return -EINVAL;
    sp_synth_selfie_report rep = { 0 };
    sp_partial cap = { 0 }, truth = { 0 };
    char *rel = NULL;
    int made = 0, ret = truth_dir ? make_dir(truth_dir, &made) : 0;
    if (!ret && truth_dir && !(rel = relative_path(capture_path, truth_dir)))
        ret = -ENOMEM;
    if (!ret && truth_dir)
        ret = sp_partial_dir_open(&truth, truth_dir);
    if (!ret)
        ret = synth_write_capture(g, capture_path, rel, &rep, &cap);
    if (!ret && truth_dir) {
        const char *slash = strrchr(capture_path, '/');
        ret = synth_write_truth(g, truth.path, slash ? slash + 1 : capture_path, &rep);
    }
    /* both complete: the truth first, so a capture never names a truth directory that is not there */
    if (!ret && truth_dir)
        ret = sp_partial_dir_commit(&truth, SP_PARTIAL_REPLACE);
    if (!ret)
        ret = sp_partial_file_commit(&cap, SP_PARTIAL_REPLACE);
    sp_partial_file_abort(&cap); /* after a failure; no-ops after the commits */
    sp_partial_dir_abort(&truth);
    if (ret && made)
        rmdir(truth_dir);
    free(rel);
    if (!ret && report)
        *report = rep;
    return ret;
}
