/* SPDX-License-Identifier: MIT */
#include "file_set.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "file_util.h"
#include "sunprobe/sp_common.h"

#define LOG_MODULE "file"

/* "<path>.<tag>.<pid>" in a new string, or NULL. */
static char *tagged(const char *path, const char *tag)
{
    size_t n = strlen(path) + strlen(tag) + 32;
    char *s = malloc(n);
    if (s)
        snprintf(s, n, "%s.%s.%ld", path, tag, (long)getpid());
    return s;
}

int sp_file_set_add(sp_file_set *fs, const char *final_path, const char **temp_path)
{
    if (!fs || !final_path || !*final_path || !temp_path)
        return -EINVAL;
    if (fs->count == fs->cap) {
        size_t cap = fs->cap ? fs->cap * 2 : 8;
        sp_file_set_entry *f = realloc(fs->files, cap * sizeof(*f));
        if (!f)
            return -ENOMEM;
        fs->files = f;
        fs->cap = cap;
    }
    sp_file_set_entry *e = &fs->files[fs->count];
    struct stat st;
    /* a device or FIFO (-o /dev/stdout) is written in place: renaming over it would replace the node */
    e->in_place = stat(final_path, &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode);
    e->final_path = strdup(final_path);
    e->temp_path = e->in_place ? strdup(final_path) : tagged(final_path, "new");
    if (!e->final_path || !e->temp_path) {
        free(e->final_path);
        free(e->temp_path);
        return -ENOMEM;
    }
    fs->count++;
    *temp_path = e->temp_path;
    return 0;
}

static void reset(sp_file_set *fs)
{
    for (size_t i = 0; i < fs->count; i++) {
        free(fs->files[i].final_path);
        free(fs->files[i].temp_path);
    }
    free(fs->files);
    memset(fs, 0, sizeof(*fs));
}

void sp_file_set_abort(sp_file_set *fs)
{
    if (!fs)
        return;
    for (size_t i = 0; i < fs->count; i++)
        if (!fs->files[i].in_place && unlink(fs->files[i].temp_path) != 0 && errno != ENOENT)
            sp_log(SP_LOG_WARN, LOG_MODULE, "%s: could not remove: %s", fs->files[i].temp_path, strerror(errno));
    reset(fs);
}

/*
 * Keeps the current final file (if any) under *old: a hard link, or, where
 * the file system has none, the file itself moved aside. *old stays NULL
 * when there is no final file.
 */
static int keep_old(const char *final_path, char **old)
{
    struct stat st;
    if (lstat(final_path, &st) != 0)
        return errno == ENOENT ? 0 : -errno;
    if (S_ISDIR(st.st_mode))
        return -EISDIR; /* never move a directory aside for a file */
    char *b = tagged(final_path, "old");
    if (!b)
        return -ENOMEM;
    if (link(final_path, b) == 0 ||
        ((errno == EPERM || errno == ENOTSUP || errno == EMLINK) && rename(final_path, b) == 0)) {
        *old = b;
        return 0;
    }
    int err = -errno;
    free(b);
    return err;
}

int sp_file_set_commit(sp_file_set *fs)
{
    if (!fs)
        return -EINVAL;
    size_t n = fs->count, done = 0;
    char **old = calloc(n ? n : 1, sizeof(*old));
    int err = old ? 0 : -ENOMEM;
    for (size_t i = 0; !err && i < n; i++)
        if (!fs->files[i].in_place)
            err = keep_old(fs->files[i].final_path, &old[i]);
    while (!err && done < n) {
        if (!fs->files[done].in_place && rename(fs->files[done].temp_path, fs->files[done].final_path) != 0)
            err = -errno;
        else
            done++;
    }
    for (size_t i = 0; err && old && i < n; i++) { /* put the old set back */
        const char *final_path = fs->files[i].final_path;
        if (fs->files[i].in_place)
            continue;
        if (old[i] ? rename(old[i], final_path) != 0 : i < done && unlink(final_path) != 0)
            sp_log(SP_LOG_ERROR, LOG_MODULE, "%s: could not restore the previous file: %s", final_path,
                   strerror(errno));
    }
    for (size_t i = 0; old && i < n; i++) {
        if (old[i] && unlink(old[i]) != 0 && errno != ENOENT)
            sp_log(SP_LOG_WARN, LOG_MODULE, "%s: could not remove: %s", old[i], strerror(errno));
        free(old[i]);
    }
    free(old);
    for (size_t i = 0; !err && i < n; i++) {
        if (fs->files[i].in_place)
            continue;
        int serr = sp_sync_parent_dir(fs->files[i].final_path);
        if (serr) /* the files are complete; only the durability of their names is in doubt */
            sp_log(SP_LOG_WARN, LOG_MODULE, "%s: syncing its directory: %s", fs->files[i].final_path,
                   sp_strerror(serr));
    }
    sp_file_set_abort(fs); /* the temporaries not renamed */
    return err;
}
