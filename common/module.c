/* SPDX-License-Identifier: MIT */
#include "module.h"

#include <dlfcn.h>
#include <errno.h>
#include <limits.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "sp_config.h"

#define LOG_MODULE "module"
#define MAX_MODULES 8

typedef struct loaded {
    const sp_module *m;
    void *handle; /* NULL after a failed load: not retried, so the reason is logged once */
} loaded;

static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static loaded table[MAX_MODULES];
static int n_loaded;

/* 1 when the running program is inside the build tree (tests, uninstalled runs). */
static int running_from_build_tree(void)
{
    char exe[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
    if (n <= 0)
        return 0;
    exe[n] = '\0';
    size_t root = strlen(SP_BUILD_ROOT);
    return (size_t)n > root && strncmp(exe, SP_BUILD_ROOT, root) == 0 && exe[root] == '/';
}

static void module_path(const sp_module *m, char *path, size_t size)
{
    const char *dir = getenv("SP_MODULE_DIR");
    if (dir && *dir)
        snprintf(path, size, "%s/%s.so", dir, m->name);
    else if (running_from_build_tree())
        snprintf(path, size, "%s/%s/%s.so", SP_BUILD_ROOT, m->build_subdir, m->name);
    else
        snprintf(path, size, "%s/%s.so", SP_MODULE_INSTALL_DIR, m->name);
}

const sp_module sp_module_opencv_import = { "sunprobe-opencv-import", "capture", "OpenCV" };
const sp_module sp_module_opencv_probe = { "sunprobe-opencv-probe", "pipeline", "OpenCV" };
const sp_module sp_module_oiio = { "sunprobe-oiio", "export", "OpenImageIO" };

int sp_module_locate(const sp_module *m, char *path, size_t size)
{
    module_path(m, path, size);
    return access(path, R_OK) == 0;
}

static const sp_module_host host = { SP_MODULE_ABI, sp_logv, sp_log_get_level };

/* dlopen + attach; NULL with the reason logged. */
static void *load(const sp_module *m)
{
    char path[PATH_MAX];
    module_path(m, path, sizeof(path));
    void *h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (!h) {
        sp_log(SP_LOG_ERROR, LOG_MODULE,
               "cannot load the %s module: %s (install it beside sunprobe, set SP_MODULE_DIR, or build with "
               "-Dlazy_modules=false)",
               m->library, dlerror());
        return NULL;
    }
    sp_module_attach_fn attach;
    void *sym = dlsym(h, SP_MODULE_ATTACH_SYMBOL);
    memcpy(&attach, &sym, sizeof(attach)); /* POSIX: object and function pointers share a representation */
    int err = attach ? attach(&host) : -EPROTO;
    if (err) {
        sp_log(SP_LOG_ERROR, LOG_MODULE, "%s: not a sunprobe module of this version (ABI %d)", path, SP_MODULE_ABI);
        dlclose(h);
        return NULL;
    }
    sp_log(SP_LOG_DEBUG, LOG_MODULE, "loaded %s", path);
    return h;
}

static void *handle_of(const sp_module *m)
{
    for (int i = 0; i < n_loaded; i++)
        if (table[i].m == m || strcmp(table[i].m->name, m->name) == 0)
            return table[i].handle;
    void *h = load(m);
    if (n_loaded < MAX_MODULES)
        table[n_loaded++] = (loaded){ m, h };
    return h;
}

sp_module_fn sp_module_symbol(const sp_module *m, const char *symbol)
{
    sp_module_fn fn = NULL;
    pthread_mutex_lock(&lock);
    void *h = handle_of(m);
    void *sym = h ? dlsym(h, symbol) : NULL;
    pthread_mutex_unlock(&lock);
    if (h && !sym)
        sp_log(SP_LOG_ERROR, LOG_MODULE, "%s: no symbol %s", m->name, symbol);
    memcpy(&fn, &sym, sizeof(fn));
    return fn;
}

sp_module_fn sp_module_symbol_cached(const sp_module *m, const char *symbol, sp_module_slot *slot)
{
    sp_module_fn fn = atomic_load_explicit(slot, memory_order_acquire);
    if (fn)
        return fn;
    fn = sp_module_symbol(m, symbol);
    if (fn)
        atomic_store_explicit(slot, fn, memory_order_release);
    return fn;
}
