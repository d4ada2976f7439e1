/* SPDX-License-Identifier: MIT */
/*
 * The module side of common/module.h, linked into every module: the shims
 * call sp_log and sp_log_get_level as they would in the program, and these
 * forward to the program's logger (its level, its stderr line format).
 */
#include "module.h"

#include <errno.h>
#include <stdarg.h>

static const sp_module_host *host;

SP_API int sp_module_attach(const sp_module_host *h);

int sp_module_attach(const sp_module_host *h)
{
    if (!h || h->abi != SP_MODULE_ABI)
        return -EPROTO;
    host = h;
    return 0;
}

enum sp_log_level sp_log_get_level(void)
{
    return host ? host->log_level() : SP_LOG_WARN;
}

void sp_log(enum sp_log_level level, const char *module, const char *fmt, ...)
{
    if (!host)
        return;
    va_list ap;
    va_start(ap, fmt);
    host->logv(level, module, fmt, ap);
    va_end(ap);
}
