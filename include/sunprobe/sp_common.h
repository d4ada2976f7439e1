/* SPDX-License-Identifier: MIT */
/* Error codes, export macro, logging and version shared by every sunprobe module. */
#ifndef SUNPROBE_SP_COMMON_H
#define SUNPROBE_SP_COMMON_H

#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#if defined(SP_BUILDING_LIBRARY) && defined(__GNUC__)
#define SP_API __attribute__((visibility("default")))
#else
#define SP_API
#endif

#if defined(__GNUC__)
#define SP_PRINTF(fmt, args) __attribute__((format(printf, fmt, args)))
#else
#define SP_PRINTF(fmt, args)
#endif

/*
 * Functions return 0 on success or a negative code: either a negated errno
 * (-EINVAL, -ENOMEM, -EIO, -ENODEV, -EAGAIN = "not ready, drain output first")
 * or one of the project codes below, all far outside errno's range.
 */
enum sp_error {
    SP_EOS = -10000,        /* end of stream: no more frames or chunks */
    SP_ECORRUPT = -10001,   /* data failed a checksum or a structural check */
    SP_EVERSION = -10002,   /* written by a newer, incompatible format version */
    SP_EFORMAT = -10003,    /* not a file of the expected kind (wrong magic) */
    SP_ETRUNCATED = -10004, /* file ends inside a header or chunk */
    SP_EUNSUPPORTED = -10005, /* valid but not handled (pixel format, chunk kind) */
    SP_EDISABLED = -10006,  /* needs an optional feature this build left out */
    SP_ENODATA = -10007,    /* input holds nothing usable for the request */
};

/* Message for any code returned by sunprobe; never NULL, static storage. */
SP_API const char *sp_strerror(int err);

enum sp_log_level {
    SP_LOG_ERROR = 0,
    SP_LOG_WARN = 1,
    SP_LOG_INFO = 2,
    SP_LOG_DEBUG = 3,
};

/* Messages above this level are dropped; default SP_LOG_WARN, SP_LOG env overrides. */
SP_API void sp_log_set_level(enum sp_log_level level);
SP_API enum sp_log_level sp_log_get_level(void);
SP_API void sp_log(enum sp_log_level level, const char *module, const char *fmt, ...) SP_PRINTF(3, 4);
/* sp_log with the arguments as a va_list (for wrappers); ap is consumed. */
SP_API void sp_logv(enum sp_log_level level, const char *module, const char *fmt, va_list ap) SP_PRINTF(3, 0);

SP_API const char *sp_version(void);

#ifdef __cplusplus
}
#endif
#endif
