/* SPDX-License-Identifier: MIT */
/* Loading a cut-out collection (cutout_collection.h), every problem named with its file. */
#include "cutout_collection.h"

#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd.h"
#include "common/file_util.h"
#include "export/png_read.h"

#define MAX_CUTOUTS 4096
#define MAX_SIDECAR (64 * 1024)

static int by_name(const void *a, const void *b) { return strcmp(*(char *const *)a, *(char *const *)b); }

/* The sidecar names in dir, sorted; -errno, or the count. */
static int list_sidecars(const char *dir, char ***names)
{
    DIR *d = opendir(dir);
    if (!d)
        return -errno;
    int n = 0;
    *names = calloc(MAX_CUTOUTS, sizeof(char *));
    for (struct dirent *e; *names && n < MAX_CUTOUTS && (e = readdir(d));) {
        size_t len = strlen(e->d_name);
        if (len > 5 && len < 256 && !strcmp(e->d_name + len - 5, ".json") && e->d_name[0] != '.')
            (*names)[n++] = strdup(e->d_name);
    }
    closedir(d);
    if (!*names)
        return -ENOMEM;
    qsort(*names, (size_t)n, sizeof(char *), by_name);
    return n;
}

/* Alpha must cut the person out: some pixels fully transparent, some opaque. */
static int check_alpha(const char *cmd, const char *path, const uint8_t *data, size_t size, const cutout *c)
{
    if (sp_png_has_alpha(data, size) != 1) {
        fprintf(stderr, "sunprobe %s: %s has no alpha channel: a cut-out needs one (transparent around the person)\n",
                cmd, path);
        return SP_EXIT_BAD_INPUT;
    }
    size_t clear = 0, solid = 0, np = (size_t)c->w * c->h;
    for (size_t i = 0; i < np; i++)
        clear += c->rgba[4 * i + 3] == 0, solid += c->rgba[4 * i + 3] == 255;
    if (!clear || !solid) {
        fprintf(stderr, "sunprobe %s: %s: its alpha is %s: nothing is cut out\n", cmd, path,
                clear ? "transparent everywhere" : "opaque everywhere");
        return SP_EXIT_BAD_INPUT;
    }
    return 0;
}

static int load_one(const char *cmd, const char *dir, const char *name, cutout *c)
{
    char *path = sp_path_join_alloc(dir, name), err[256] = "";
    void *data = NULL;
    size_t size = 0;
    int code = 0, ret = path ? sp_read_whole_file(path, MAX_SIDECAR, &data, &size) : -ENOMEM;
    snprintf(c->name, sizeof(c->name), "%s", name);
    if (ret)
        code = sp_cmd_fail(cmd, ret, path ? path : name);
    else if (sp_cutout_meta_parse(data, size, &c->m, err, sizeof(err))) {
        fprintf(stderr, "sunprobe %s: %s: %s\n", cmd, path, err);
        code = SP_EXIT_BAD_INPUT;
    }
    free(data), free(path);
    data = NULL;
    path = code ? NULL : sp_path_join_alloc(dir, c->m.image);
    if (!code && !path)
        code = sp_cmd_fail(cmd, -ENOMEM, name);
    if (!code && (ret = sp_read_whole_file(path, (size_t)1 << 30, &data, &size)))
        code = sp_cmd_fail(cmd, ret, path);
    if (!code && (ret = sp_png_decode_rgba(data, size, &c->rgba, &c->w, &c->h)))
        code = sp_cmd_failf(cmd, ret == -ENOMEM ? ret : SP_ECORRUPT, "%s (named by %s)", path, name);
    if (!code)
        code = check_alpha(cmd, path, data, size, c);
    free(data), free(path);
    return code;
}

int cutouts_load(const char *cmd, const char *dir, cutout **out, size_t *n)
{
    char **names = NULL;
    int count = list_sidecars(dir, &names), code = 0;
    *out = NULL, *n = 0;
    if (count < 0)
        code = sp_cmd_fail(cmd, count, dir);
    else if (count == 0) {
        fprintf(stderr, "sunprobe %s: %s holds no cut-out (no *.json sidecar; `sunprobe cutouts` makes them)\n", cmd,
                dir);
        code = SP_EXIT_BAD_INPUT;
    }
    cutout *c = code || count <= 0 ? NULL : calloc((size_t)count, sizeof(*c));
    if (!code && !c)
        code = sp_cmd_fail(cmd, -ENOMEM, dir);
    for (int i = 0; !code && i < count; i++)
        code = load_one(cmd, dir, names[i], &c[i]);
    for (int i = 0; names && i < count; i++)
        free(names[i]);
    free(names);
    if (code) {
        cutouts_free(c, c ? (size_t)count : 0);
        return code;
    }
    *out = c, *n = (size_t)count;
    return 0;
}

void cutouts_free(cutout *c, size_t n)
{
    for (size_t i = 0; c && i < n; i++)
        free(c[i].rgba);
    free(c);
}
