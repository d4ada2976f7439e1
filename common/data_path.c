/* SPDX-License-Identifier: MIT */
/* Run-time data discovery (data_path.h). */
#include "common/data_path.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "sp_config.h"

static int exists(const char *dir, const char *probe)
{
    struct stat st;
    if (!probe)
        return stat(dir, &st) == 0 && S_ISREG(st.st_mode);
    char p[4200];
    if ((size_t)snprintf(p, sizeof(p), "%s/%s", dir, probe) >= sizeof(p))
        return 0;
    return stat(p, &st) == 0 && S_ISREG(st.st_mode);
}

/* Takes the candidate when it exists; 1 when taken. */
static int try(sp_data_location *out, const char *source, const char *base, const char *rel, const char *probe)
{
    char p[sizeof(out->path)];
    int n = rel ? snprintf(p, sizeof(p), "%s/sunprobe/%s", base, rel) : snprintf(p, sizeof(p), "%s", base);
    if (n < 0 || (size_t)n >= sizeof(p) || !exists(p, probe))
        return 0;
    memcpy(out->path, p, (size_t)n + 1);
    snprintf(out->source, sizeof(out->source), "%s", source);
    out->found = 1;
    return 1;
}

void sp_data_locate(const char *env, const char *rel, const char *probe, const char *fallback,
                    sp_data_location *out)
{
    memset(out, 0, sizeof(*out));
    const char *v = env ? getenv(env) : NULL;
    if (v && v[0]) { /* an explicit choice is never second-guessed */
        snprintf(out->path, sizeof(out->path), "%s", v);
        snprintf(out->source, sizeof(out->source), "%s", env);
        out->found = exists(v, probe);
        return;
    }
    const char *home = getenv("XDG_DATA_HOME"), *user = getenv("HOME");
    char buf[4200];
    if (home && home[0] == '/') {
        if (try(out, "XDG_DATA_HOME", home, rel, probe))
            return;
    } else if (user && user[0] == '/') {
        snprintf(buf, sizeof(buf), "%s/.local/share", user);
        if (try(out, "XDG_DATA_HOME", buf, rel, probe))
            return;
    }
    const char *dirs = getenv("XDG_DATA_DIRS");
    if (!dirs || !dirs[0])
        dirs = "/usr/local/share:/usr/share";
    for (const char *d = dirs; *d;) { /* colon-separated, relative entries ignored (the spec) */
        size_t n = strcspn(d, ":");
        if (n && n < sizeof(buf) && d[0] == '/') {
            memcpy(buf, d, n);
            buf[n] = '\0';
            if (try(out, "XDG_DATA_DIRS", buf, rel, probe))
                return;
        }
        d += n + (d[n] == ':');
    }
    if (try(out, "install prefix", SP_DATA_INSTALL_DIR, rel, probe))
        return;
    if (fallback && try(out, "build default", fallback, NULL, probe))
        return;
    snprintf(out->path, sizeof(out->path), "%s", fallback ? fallback : "");
    snprintf(out->source, sizeof(out->source), "%s", fallback ? "build default" : "none");
}
