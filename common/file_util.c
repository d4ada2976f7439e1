/* SPDX-License-Identifier: MIT */
#include "file_util.h"

#include <errno.h>
#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <ftw.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "atomic_file.h"
#include "sunprobe/sp_common.h"

#define LOG_MODULE "file"
#define FIRST_CHUNK 65536 /* first buffer for streams whose size fstat does not tell */
#define MAX_OPEN_FDS 16   /* directory descriptors nftw may hold */

/* ---- whole files ---- */

/* Reads fd to EOF into a buffer that grows up to limit bytes (+1 for the NUL). */
static int read_all(int fd, size_t cap, size_t limit, char **out, size_t *len_out)
{
    char *buf = malloc(cap + 1);
    if (!buf)
        return -ENOMEM;
    size_t len = 0;
    for (;;) {
        if (len == cap) {
            if (cap >= limit)
                break; /* limit bytes read: the caller reports it as too big */
            size_t ncap = cap > limit / 2 ? limit : cap * 2;
            char *nb = realloc(buf, ncap + 1);
            if (!nb) {
                free(buf);
                return -ENOMEM;
            }
            buf = nb;
            cap = ncap;
        }
        ssize_t r = read(fd, buf + len, cap - len);
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0) {
            int err = -errno;
            free(buf);
            return err;
        }
        if (r == 0)
            break;
        len += (size_t)r;
    }
    buf[len] = '\0';
    *out = buf;
    *len_out = len;
    return 0;
}

int sp_read_whole_file(const char *path, size_t max_size, void **data, size_t *size)
{
    if (!path || !data || !size)
        return -EINVAL;
    if (max_size > SIZE_MAX - 2) /* room for the probe byte and the NUL */
        max_size = SIZE_MAX - 2;
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0)
        return -errno;
    struct stat st;
    int err = fstat(fd, &st) != 0 ? -errno : 0;
    size_t limit = max_size + 1, cap = limit < FIRST_CHUNK ? limit : FIRST_CHUNK;
    if (!err && S_ISREG(st.st_mode)) {
        if (st.st_size < 0 || (uint64_t)st.st_size > (uint64_t)max_size)
            err = -EFBIG;
        else
            cap = (size_t)st.st_size + 1; /* one more so EOF is seen without growing */
    }
    char *buf = NULL;
    size_t len = 0;
    if (!err)
        err = read_all(fd, cap, limit, &buf, &len);
    close(fd);
    if (!err && len > max_size) { /* a stream, or a file that grew while we read it */
        free(buf);
        err = -EFBIG;
    }
    if (err)
        return err;
    *data = buf;
    *size = len;
    return 0;
}

int sp_write_whole_file_atomic(const char *path, const void *data, size_t size)
{
    if (!path || (!data && size))
        return -EINVAL;
    sp_atomic_file af;
    int err = sp_atomic_file_open(&af, path);
    if (err)
        return err;
    int st = size == 0 || fwrite(data, 1, size, af.file) == size ? 0 : sp_write_error();
    return sp_atomic_file_finish(&af, st);
}

/* ---- paths ---- */

int sp_path_join(char *buf, size_t n, const char *dir, const char *name)
{
    if (!buf || !dir || !name)
        return -EINVAL;
    int w = snprintf(buf, n, "%s/%s", dir, name);
    return w < 0 || (size_t)w >= n ? -ENAMETOOLONG : 0;
}

char *sp_path_join_alloc(const char *dir, const char *name)
{
    if (!dir || !name)
        return NULL;
    size_t n = strlen(dir) + strlen(name) + 2;
    char *p = malloc(n);
    if (p)
        snprintf(p, n, "%s/%s", dir, name);
    return p;
}

int sp_is_regular_file(const char *path)
{
    struct stat st;
    return path && stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

static int mkdir_one(const char *dir, mode_t mode)
{
    if (mkdir(dir, mode) == 0)
        return 0;
    if (errno != EEXIST)
        return -errno;
    struct stat st;
    return stat(dir, &st) == 0 && S_ISDIR(st.st_mode) ? 0 : -ENOTDIR;
}

int sp_mkdir_p(const char *dir, mode_t mode)
{
    if (!dir || !*dir)
        return -EINVAL;
    char *tmp = strdup(dir);
    if (!tmp)
        return -ENOMEM;
    int err = 0;
    for (char *p = tmp + 1; *p && !err; p++)
        if (*p == '/' && p[-1] != '/') {
            *p = '\0';
            err = mkdir_one(tmp, mode);
            *p = '/';
        }
    if (!err)
        err = mkdir_one(tmp, mode);
    free(tmp);
    return err;
}

static int remove_entry(const char *path, const struct stat *st, int type, struct FTW *ftw)
{
    (void)st, (void)type, (void)ftw;
    return remove(path) == 0 || errno == ENOENT ? 0 : -errno;
}

/* nftw returns -1 for its own failures (errno set) and else what the callback returned. */
static int walk_result(int r)
{
    return r == -1 ? -errno : r;
}

int sp_remove_tree(const char *path)
{
    if (!path || !*path)
        return -EINVAL;
    return walk_result(nftw(path, remove_entry, MAX_OPEN_FDS, FTW_DEPTH | FTW_PHYS));
}

static int sync_path(const char *path, int flags)
{
    int fd = open(path, O_RDONLY | O_CLOEXEC | flags);
    if (fd < 0)
        return -errno;
    int err = fsync(fd) < 0 ? -errno : 0;
    close(fd);
    return err;
}

int sp_sync_parent_dir(const char *path)
{
    if (!path)
        return -EINVAL;
    const char *slash = strrchr(path, '/');
    char *dir = !slash ? strdup(".") : slash == path ? strdup("/") : strndup(path, (size_t)(slash - path));
    if (!dir)
        return -ENOMEM;
    int err = sync_path(dir, O_DIRECTORY);
    free(dir);
    /* some file systems cannot fsync a directory; the data itself is synced already */
    return err == -EINVAL ? 0 : err;
}

static int sync_entry(const char *path, const struct stat *st, int type, struct FTW *ftw)
{
    (void)st, (void)ftw;
    if (type == FTW_DNR || type == FTW_NS)
        return -EACCES;
    if (type != FTW_F && type != FTW_DP && type != FTW_D)
        return 0; /* symlinks: nothing of ours to sync */
    int err = sync_path(path, type == FTW_F ? 0 : O_DIRECTORY);
    return err == -EINVAL ? 0 : err;
}

/* ---- partial outputs ---- */

static void partial_reset(sp_partial *p)
{
    free(p->path);
    free(p->final_path);
    memset(p, 0, sizeof(*p));
}

static int partial_names(sp_partial *p, const char *final_path, int with_pid)
{
    memset(p, 0, sizeof(*p));
    if (!final_path || !*final_path)
        return -EINVAL;
    size_t n = strlen(final_path) + 40;
    p->final_path = strdup(final_path);
    p->path = malloc(n);
    if (!p->final_path || !p->path) {
        partial_reset(p);
        return -ENOMEM;
    }
    if (with_pid)
        snprintf(p->path, n, "%s.partial.%ld", final_path, (long)getpid());
    else
        snprintf(p->path, n, "%s.partial", final_path);
    return 0;
}

void sp_partial_forget(sp_partial *p)
{
    if (p)
        partial_reset(p);
}

/* 1 when name is "<base>.partial.<pid>" for a pid other than ours that no longer runs; the pid in *pid. */
static int is_stale_partial(const char *name, const char *base, long *pid)
{
    static const char tag[] = ".partial.";
    size_t nb = strlen(base);
    if (strncmp(name, base, nb) != 0 || strncmp(name + nb, tag, sizeof(tag) - 1) != 0)
        return 0;
    const char *digits = name + nb + sizeof(tag) - 1;
    char *end;
    errno = 0;
    long v = strtol(digits, &end, 10);
    if (!*digits || *end || errno || v <= 0 || v > INT32_MAX || v == (long)getpid())
        return 0;
    *pid = v;
    /* EPERM: a process of another user has that pid now; only ESRCH says nobody does */
    return kill((pid_t)v, 0) != 0 && errno == ESRCH;
}

/*
 * Removes "<final_dir>.partial.<pid>" directories of ours whose process is
 * gone (killed, crashed): they were never committed, so nothing of value is
 * lost, and without this they pile up beside the outputs. Failures are logged.
 */
static void remove_stale_partials(const char *final_dir)
{
    char *copy = strdup(final_dir);
    if (!copy)
        return;
    char *slash = strrchr(copy, '/');
    const char *parent = slash ? (slash == copy ? "/" : copy) : ".";
    const char *base = slash ? slash + 1 : copy;
    if (slash)
        *slash = '\0';
    DIR *d = *base ? opendir(parent) : NULL;
    struct dirent *e;
    while (d && (e = readdir(d))) {
        long pid;
        char *path;
        struct stat st;
        if (!is_stale_partial(e->d_name, base, &pid) || !(path = sp_path_join_alloc(parent, e->d_name)))
            continue;
        if (lstat(path, &st) == 0 && S_ISDIR(st.st_mode) && st.st_uid == getuid()) {
            int err = sp_remove_tree(path);
            if (err)
                sp_log(SP_LOG_WARN, LOG_MODULE, "%s: could not remove: %s", path, sp_strerror(err));
            else
                sp_log(SP_LOG_INFO, LOG_MODULE, "removed %s, left by process %ld, which no longer runs", path, pid);
        }
        free(path);
    }
    if (d)
        closedir(d);
    free(copy);
}

int sp_partial_dir_open(sp_partial *pd, const char *final_dir)
{
    if (!pd)
        return -EINVAL;
    int err = partial_names(pd, final_dir, 1);
    if (err)
        return err;
    remove_stale_partials(final_dir);
    if (mkdir(pd->path, 0755) != 0) {
        err = -errno;
        partial_reset(pd); /* not ours: never remove it */
        return err;
    }
    pd->is_dir = 1;
    return 0;
}

/* Moves the existing output aside, puts the new one in place, then deletes the old one. */
static int replace_existing(const sp_partial *p)
{
    size_t n = strlen(p->final_path) + 40;
    char *old = malloc(n);
    if (!old)
        return -ENOMEM;
    snprintf(old, n, "%s.old.%ld", p->final_path, (long)getpid());
    int err = rename(p->final_path, old) == 0 ? 0 : -errno;
    if (!err && rename(p->path, p->final_path) != 0) {
        err = -errno;
        if (rename(old, p->final_path) != 0)
            sp_log(SP_LOG_ERROR, LOG_MODULE, "%s: could not restore the old output from %s: %s", p->final_path, old,
                   strerror(errno));
    }
    int rm = err ? 0 : sp_remove_tree(old);
    if (rm)
        sp_log(SP_LOG_WARN, LOG_MODULE, "%s: could not remove the replaced output: %s", old, sp_strerror(rm));
    free(old);
    return err;
}

static void sync_parent_or_warn(const char *path)
{
    int err = sp_sync_parent_dir(path);
    if (err) /* the output is complete; only the durability of its name is in doubt */
        sp_log(SP_LOG_WARN, LOG_MODULE, "%s: syncing its directory: %s", path, sp_strerror(err));
}

int sp_partial_dir_commit(sp_partial *pd, int flags)
{
    if (!pd || !pd->path || !pd->is_dir)
        return -EINVAL;
    int err = walk_result(nftw(pd->path, sync_entry, MAX_OPEN_FDS, FTW_DEPTH | FTW_PHYS));
    if (!err && rename(pd->path, pd->final_path) != 0) {
        err = -errno;
        struct stat st;
        int exists = lstat(pd->final_path, &st) == 0;
        /* rename replaces an empty directory itself; anything else in the way is refused or moved aside */
        if (exists && (err == -ENOTEMPTY || err == -EEXIST || err == -ENOTDIR || err == -EISDIR))
            err = flags & SP_PARTIAL_REPLACE ? replace_existing(pd) : -EEXIST;
    }
    if (err)
        return err;
    sync_parent_or_warn(pd->final_path);
    partial_reset(pd);
    return 0;
}

void sp_partial_dir_abort(sp_partial *pd)
{
    if (!pd)
        return;
    if (pd->path && pd->is_dir) {
        int err = sp_remove_tree(pd->path);
        if (err && err != -ENOENT)
            sp_log(SP_LOG_WARN, LOG_MODULE, "%s: could not remove: %s", pd->path, sp_strerror(err));
    }
    partial_reset(pd);
}

int sp_partial_file_open(sp_partial *pf, const char *final_path)
{
    return pf ? partial_names(pf, final_path, 0) : -EINVAL;
}

static int rename_file(const sp_partial *p, int flags)
{
    if (!(flags & SP_PARTIAL_REPLACE)) {
        if (renameat2(AT_FDCWD, p->path, AT_FDCWD, p->final_path, RENAME_NOREPLACE) == 0)
            return 0;
        if (errno != EINVAL && errno != ENOSYS) /* file systems without RENAME_NOREPLACE: check, then rename */
            return -errno;
        if (access(p->final_path, F_OK) == 0)
            return -EEXIST;
    }
    return rename(p->path, p->final_path) == 0 ? 0 : -errno;
}

int sp_partial_file_commit(sp_partial *pf, int flags)
{
    if (!pf || !pf->path || pf->is_dir)
        return -EINVAL;
    int err = rename_file(pf, flags);
    if (err)
        return err;
    sync_parent_or_warn(pf->final_path);
    partial_reset(pf);
    return 0;
}

void sp_partial_file_abort(sp_partial *pf)
{
    if (!pf)
        return;
    if (pf->path && !pf->is_dir && unlink(pf->path) != 0 && errno != ENOENT)
        sp_log(SP_LOG_WARN, LOG_MODULE, "%s: could not remove: %s", pf->path, strerror(errno));
    partial_reset(pf);
}
