/* SPDX-License-Identifier: MIT */
/*
 * A sensor-log export as one thing to look into: a directory, or a .zip read with libzip (never
 * unpacked as a whole). Files are found by base name, at the top or one directory down (Sensor
 * Logger keeps its video in Camera/). Internal; layout in IMPORT.md.
 */
#include "import_internal.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

#include "sp_config.h"
#if HAVE_LIBZIP
#include <zip.h>
#endif

int sp_import_is_zip(const char *path)
{
    unsigned char magic[4] = { 0 };
    FILE *f = fopen(path, "rb");
    if (!f)
        return 0;
    size_t n = fread(magic, 1, 4, f);
    fclose(f);
    return n == 4 && memcmp(magic, "PK\x03\x04", 4) == 0;
}

#if HAVE_LIBZIP /* zip members are named by path */
static const char *base_name(const char *p)
{
    const char *s = strrchr(p, '/');
    return s ? s + 1 : p;
}
#endif

int sp_import_bundle_open(sp_import_bundle *b, const char *path, char *msg, size_t msg_size)
{
    memset(b, 0, sizeof(*b));
    b->path = path;
    struct stat st;
    if (stat(path, &st) != 0) {
        int rc = -errno;
        return sp_import_fail(msg, msg_size, rc, "%s: %s", path, sp_strerror(rc));
    }
    if (S_ISDIR(st.st_mode))
        return 0;
#if HAVE_LIBZIP
    int err = 0;
    b->zip = zip_open(path, ZIP_RDONLY, &err);
    if (!b->zip)
        return sp_import_fail(msg, msg_size, SP_ECORRUPT, "%s: not a readable zip archive (libzip error %d)", path,
                              err);
    return 0;
#else
    return sp_import_fail(msg, msg_size, SP_EDISABLED,
                          "%s: reading a .zip export needs libzip; rebuild with -Dlibzip=enabled, or unzip it and "
                          "import the directory", path);
#endif
}

void sp_import_bundle_close(sp_import_bundle *b)
{
#if HAVE_LIBZIP
    if (b->zip)
        zip_discard(b->zip);
#endif
    b->zip = NULL;
}

/* A directory's file whose name passes match, at the top or one level down; 1 found, 0 not. */
static int dir_find(const char *dir, int depth, int (*match)(const char *, const void *), const void *arg,
                    char *out, size_t out_size)
{
    DIR *d = opendir(dir);
    if (!d)
        return 0;
    struct dirent *e;
    int found = 0;
    while (!found && (e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.')
            continue;
        char p[4096];
        if ((size_t)snprintf(p, sizeof(p), "%s/%s", dir, e->d_name) >= sizeof(p))
            continue;
        struct stat st;
        if (stat(p, &st) != 0)
            continue;
        if (S_ISDIR(st.st_mode))
            found = depth > 0 && dir_find(p, depth - 1, match, arg, out, out_size);
        else if (S_ISREG(st.st_mode) && match(e->d_name, arg))
            found = (size_t)snprintf(out, out_size, "%s", p) < out_size;
    }
    closedir(d);
    return found;
}

int sp_import_bundle_find(sp_import_bundle *b, int (*match)(const char *, const void *), const void *arg, char *out,
                          size_t out_size)
{
#if HAVE_LIBZIP
    if (b->zip) {
        zip_int64_t n = zip_get_num_entries(b->zip, 0);
        for (zip_int64_t i = 0; i < n; i++) {
            const char *name = zip_get_name(b->zip, (zip_uint64_t)i, 0);
            if (name && name[strlen(name) - 1] != '/' && base_name(name)[0] != '.' && match(base_name(name), arg))
                return (size_t)snprintf(out, out_size, "%s", name) < out_size;
        }
        return 0;
    }
#endif
    return dir_find(b->path, 1, match, arg, out, out_size);
}

int sp_import_match_name(const char *name, const void *want)
{
    return strcasecmp(name, (const char *)want) == 0;
}

int sp_import_match_video(const char *name, const void *unused)
{
    (void)unused;
    size_t n = strlen(name);
    return n > 4 && (strcasecmp(name + n - 4, ".mp4") == 0 || strcasecmp(name + n - 4, ".mov") == 0);
}

#if HAVE_LIBZIP
/* Copies a zip entry into fd. */
static int zip_copy(sp_import_bundle *b, const char *name, int fd, char *msg, size_t msg_size)
{
    zip_file_t *zf = zip_fopen(b->zip, name, 0);
    if (!zf)
        return sp_import_fail(msg, msg_size, SP_ECORRUPT, "%s: cannot open %s in the archive: %s", b->path, name,
                              zip_strerror(b->zip));
    char buf[65536];
    zip_int64_t n;
    int rc = 0;
    while (!rc && (n = zip_fread(zf, buf, sizeof(buf))) > 0)
        for (zip_int64_t done = 0; !rc && done < n;) {
            ssize_t w = write(fd, buf + done, (size_t)(n - done));
            if (w < 0 && errno != EINTR)
                rc = sp_import_fail(msg, msg_size, -errno, "%s: unpacking %s: %s", b->path, name, strerror(errno));
            done += w > 0 ? w : 0;
        }
    if (!rc && n < 0)
        rc = sp_import_fail(msg, msg_size, SP_ECORRUPT, "%s: %s is damaged in the archive: %s", b->path, name,
                            zip_file_strerror(zf));
    zip_fclose(zf);
    return rc;
}
#endif

int sp_import_bundle_fopen(sp_import_bundle *b, const char *name, FILE **out, char *msg, size_t msg_size)
{
    *out = NULL;
#if HAVE_LIBZIP
    if (b->zip) { /* an anonymous temporary file: gone when closed, whatever happens */
        FILE *f = tmpfile();
        if (!f)
            return sp_import_fail(msg, msg_size, -errno, "temporary file for %s: %s", name, strerror(errno));
        int rc = zip_copy(b, name, fileno(f), msg, msg_size);
        if (rc || fseek(f, 0, SEEK_SET) != 0) {
            fclose(f);
            return rc ? rc : -EIO;
        }
        *out = f;
        return 0;
    }
#endif
    *out = fopen(name, "r");
    if (!*out)
        return sp_import_fail(msg, msg_size, -errno, "%s: cannot open: %s", name, strerror(errno));
    return 0;
}

int sp_import_bundle_extract(sp_import_bundle *b, const char *name, const char *near, char *out, size_t out_size,
                             char *msg, size_t msg_size)
{
#if HAVE_LIBZIP
    /* beside the output, so the copy lands on the disk the user gave room on */
    const char *slash = strrchr(near, '/');
    int dl = slash ? (int)(slash - near) : 1;
    if ((size_t)snprintf(out, out_size, "%.*s/.sp-import-video-XXXXXX", dl, slash ? near : ".") >= out_size)
        return sp_import_fail(msg, msg_size, -ENAMETOOLONG, "%s: path too long", near);
    int fd = mkstemp(out);
    if (fd < 0) {
        int rc = -errno;
        out[0] = 0;
        return sp_import_fail(msg, msg_size, rc, "%s: cannot create a temporary copy of the video: %s", near,
                              sp_strerror(rc));
    }
    int rc = zip_copy(b, name, fd, msg, msg_size);
    close(fd);
    return rc;
#else
    (void)b, (void)name, (void)near, (void)out, (void)out_size;
    return sp_import_fail(msg, msg_size, SP_EDISABLED, "reading a .zip export needs libzip; rebuild with "
                          "-Dlibzip=enabled");
#endif
}
