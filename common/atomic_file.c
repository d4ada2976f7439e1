/* SPDX-License-Identifier: MIT */
#include "atomic_file.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* /dev/stdout, a FIFO, /dev/null: written in place; a rename would replace the device node itself. */
static int open_special(sp_atomic_file *af, const char *path)
{
    if (!(af->file = fopen(path, "wb")))
        return -errno;
    return 0;
}

int sp_atomic_file_open(sp_atomic_file *af, const char *path)
{
    memset(af, 0, sizeof(*af));
    struct stat st;
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode))
        return open_special(af, path);
    size_t n = strlen(path) + 32;
    af->final_path = strdup(path);
    af->temp_path = malloc(n);
    if (!af->final_path || !af->temp_path) {
        free(af->final_path);
        free(af->temp_path);
        return -ENOMEM;
    }
    snprintf(af->temp_path, n, "%s.tmp.%ld", path, (long)getpid());
    af->file = fopen(af->temp_path, "wbx");
    if (!af->file) {
        int err = -errno;
        free(af->final_path);
        free(af->temp_path);
        memset(af, 0, sizeof(*af));
        return err;
    }
    return 0;
}

int sp_atomic_file_finish(sp_atomic_file *af, int status)
{
    if (!af->file)
        return status ? status : -EINVAL;
    if (!af->temp_path) { /* a special file (open_special): nothing to rename or remove */
        if (fflush(af->file) != 0 && status == 0)
            status = -errno;
        if (status == 0 && ferror(af->file))
            status = -EIO;
        if (fclose(af->file) != 0 && status == 0)
            status = errno ? -errno : -EIO;
        memset(af, 0, sizeof(*af));
        return status;
    }
    if (status == 0 && (fflush(af->file) != 0 || fsync(fileno(af->file)) != 0))
        status = -errno;
    if (status == 0 && ferror(af->file)) /* a write the caller did not check failed */
        status = -EIO;
    if (fclose(af->file) != 0 && status == 0)
        status = errno ? -errno : -EIO;
    if (status == 0 && rename(af->temp_path, af->final_path) != 0)
        status = -errno;
    if (status != 0)
        unlink(af->temp_path);
    free(af->final_path);
    free(af->temp_path);
    memset(af, 0, sizeof(*af));
    return status;
}
