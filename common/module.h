/* SPDX-License-Identifier: MIT */
/*
 * Loadable modules for the C++ shims whose libraries are costly to load.
 * OpenCV and OpenImageIO pull in ~200 shared libraries: linked into the
 * binary they cost every `sunprobe` start ~0.5 s of CPU and ~130 MB of
 * resident memory, even `sunprobe info`. With -Dlazy_modules=true (the
 * default) each such shim is built as a module (NAME.so) and small C
 * forwarders (*_lazy.c) load it on the first call of one of its functions.
 *
 * Where a module is looked for: $SP_MODULE_DIR when set; else the build
 * tree's BUILD_SUBDIR when the running program lives in the build tree
 * (tests, uninstalled runs); else the installed module directory.
 */
#ifndef SUNPROBE_COMMON_MODULE_H
#define SUNPROBE_COMMON_MODULE_H

#include "sunprobe/sp_common.h"
#include "common/private_api.h"

/* raised with every change to a shim function's signature: a module built before it is refused, not called wrongly
   (2: sp_cv_grabcut_box's min_height) */
#define SP_MODULE_ABI 2

/* What the program hands a module when it is loaded: the module logs through the program's logger. */
typedef struct sp_module_host {
    int abi; /* SP_MODULE_ABI */
    void (*logv)(enum sp_log_level level, const char *module, const char *fmt, va_list ap) SP_PRINTF(3, 0);
    enum sp_log_level (*log_level)(void);
} sp_module_host;

/* Every module exports this; it returns 0, or -EPROTO when the host's ABI differs. */
typedef int (*sp_module_attach_fn)(const sp_module_host *host);
#define SP_MODULE_ATTACH_SYMBOL "sp_module_attach"

/* A module as the forwarders name it (static storage). */
typedef struct sp_module {
    const char *name;         /* file name without ".so", e.g. "sunprobe-opencv-import" */
    const char *build_subdir; /* where the build tree puts it, relative to the build root */
    const char *library;      /* what it wraps, for messages: "OpenCV" */
} sp_module;

/* The modules this program can load (one per shim; `sunprobe --version --verbose` lists them). */
extern SP_PRIVATE const sp_module sp_module_opencv_import, sp_module_opencv_probe, sp_module_oiio;

/* Where m is looked for (the order above) into path; 1 when a file is there. */
SP_PRIVATE int sp_module_locate(const sp_module *m, char *path, size_t size);

/* Any function pointer; forwarders cast it back to the function's real type. */
typedef void (*sp_module_fn)(void);

/*
 * The function symbol from module m, loading the module on first use
 * (thread-safe; a module is never unloaded). NULL when the module or the
 * symbol cannot be found: the reason is logged once per module, and
 * callers return SP_EMODULE.
 */
sp_module_fn sp_module_symbol(const sp_module *m, const char *symbol);

/*
 * A forwarder's remembered function (one static per forwarder, zero-initialised):
 * after the first successful lookup a call costs one atomic load, not a lock
 * and a dlsym (forwarders run per frame: video reads, MOG2, HOG).
 */
typedef _Atomic(sp_module_fn) sp_module_slot;
/* sp_module_symbol, remembered in *slot once found (a failed lookup is retried: its reason is logged by it). */
sp_module_fn sp_module_symbol_cached(const sp_module *m, const char *symbol, sp_module_slot *slot);

/* What forwarders return when their module cannot be loaded. */
#define SP_EMODULE (-ELIBACC)

#endif
