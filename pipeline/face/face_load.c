/* SPDX-License-Identifier: MIT */
/*
 * Picks the face model a run uses: the ICT model when its data folder exists
 * (imported once, then read from a cache file keyed by the settings and the
 * neutral mesh's size and time), else the built-in generic head.
 */
#include "sunprobe/sp_face_model.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/file_util.h"
#include "face_internal.h"

void sp_face_load_default_settings(sp_face_load_settings *settings)
{
    if (!settings)
        return;
    memset(settings, 0, sizeof(*settings));
    settings->target_triangles = 10000;
    settings->use_cache = 1;
}

static int neutral_stat(const char *dir, struct stat *st)
{
    char path[4096];
    return sp_path_join(path, sizeof(path), dir, "generic_neutral_mesh.obj") == 0 && stat(path, st) == 0 &&
           S_ISREG(st->st_mode);
}

/* $XDG_CACHE_HOME/sunprobe or ~/.cache/sunprobe, created if needed; 0 and the file path, or an error. */
static int default_cache_path(char *buf, size_t n, uint32_t target)
{
    const char *xdg = getenv("XDG_CACHE_HOME"), *home = getenv("HOME");
    char dir[4096], name[64];
    int err;
    if (xdg && xdg[0] == '/')
        err = sp_path_join(dir, sizeof(dir), xdg, "sunprobe");
    else if (home && home[0])
        err = sp_path_join(dir, sizeof(dir), home, ".cache/sunprobe");
    else
        return -ENOENT;
    if (!err)
        err = sp_mkdir_p(dir, 0755);
    snprintf(name, sizeof(name), "face-ict-%u.spface", target);
    return err ? err : sp_path_join(buf, n, dir, name);
}

static int load_ict(sp_face_model *model, const sp_face_load_settings *s, const char *dir, const struct stat *st)
{
    char key[sizeof(model->source)], cache[4096];
    snprintf(key, sizeof(key), "ict-facekit v2 eyes target=%u neutral=%lld-%lld", s->target_triangles,
             (long long)st->st_size, (long long)st->st_mtime);
    int have_cache = 0;
    if (s->use_cache) {
        int n = s->cache_path ? snprintf(cache, sizeof(cache), "%s", s->cache_path) : 0;
        have_cache = s->cache_path ? n > 0 && (size_t)n < sizeof(cache)
                                   : default_cache_path(cache, sizeof(cache), s->target_triangles) == 0;
    }
    if (have_cache && sp_face_model_read(model, cache) == 0) {
        if (strcmp(model->source, key) == 0) {
            sp_log(SP_LOG_INFO, FACE_LOG, "face model: ICT (cached %s)", cache);
            return 0;
        }
        sp_face_model_free(model); /* stale: other settings or a changed data folder */
    }
    sp_face_ict_settings is;
    sp_face_ict_default_settings(&is);
    is.dir = dir;
    is.target_triangles = s->target_triangles;
    int err = sp_face_model_import_ict(model, &is);
    if (err)
        return err;
    memcpy(model->source, key, sizeof(key));
    sp_log(SP_LOG_INFO, FACE_LOG, "face model: ICT from %s (%u triangles)", dir, model->mesh.n_triangles);
    if (have_cache) {
        int werr = sp_face_model_write(model, cache);
        if (werr)
            sp_log(SP_LOG_WARN, FACE_LOG, "could not cache the face model in %s: %s", cache, sp_strerror(werr));
    }
    return 0;
}

int sp_face_model_load(sp_face_model *model, const sp_face_load_settings *settings)
{
    sp_face_load_settings s;
    if (!model)
        return -EINVAL;
    memset(model, 0, sizeof(*model));
    if (settings)
        s = *settings;
    else
        sp_face_load_default_settings(&s);
    const char *dir = s.ict_dir ? s.ict_dir : sp_face_ict_dir();
    struct stat st;
    if (neutral_stat(dir, &st))
        return load_ict(model, &s, dir, &st);
    sp_log(SP_LOG_INFO, FACE_LOG,
           "face model: built-in generic head (no ICT data in %s; tools/fetch-ict-facekit.sh downloads it)", dir);
    return sp_face_model_generic(model);
}

int sp_face_model_load_default(sp_face_model *model)
{
    return sp_face_model_load(model, NULL);
}
