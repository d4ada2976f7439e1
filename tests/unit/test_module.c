/* SPDX-License-Identifier: MIT */
/*
 * Lazily loaded modules (common/module.h): OpenCV is not in the process until
 * a shim function is called; the call then works; a missing module gives
 * SP_EMODULE and a message instead of a crash.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "capture/opencv_shim.h"
#include "check.h"
#include "common/module.h"
#include "sp_config.h"

#if SP_LAZY_MODULES
/* 1 when a mapping of this process names a file containing lib. */
static int mapped(const char *lib)
{
    FILE *f = fopen("/proc/self/maps", "r");
    char line[1024];
    int found = 0;
    while (f && !found && fgets(line, sizeof(line), f))
        found = strstr(line, lib) != NULL;
    if (f)
        fclose(f);
    return found;
}

/* In a child (the parent's module table stays untouched): the module directory is empty. */
static void missing_module(void)
{
    char dir[] = "/tmp/sp_module_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    pid_t pid = fork();
    if (pid == 0) {
        setenv("SP_MODULE_DIR", dir, 1);
        static const uint8_t junk[16] = { 1, 2, 3 };
        uint8_t *buf = NULL;
        size_t cap = 0;
        uint32_t w, h;
        int rc = sp_cv_image_decode(junk, sizeof(junk), &buf, &cap, &w, &h);
        free(buf);
        _exit(rc == SP_EMODULE && !mapped("libopencv_core") ? 0 : 1);
    }
    int status = 0;
    CHECK(pid > 0 && waitpid(pid, &status, 0) == pid);
    CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) == 0, "a missing module did not give SP_EMODULE");
    rmdir(dir);
}
#endif

int main(void)
{
#if !SP_LAZY_MODULES
    SKIP("built without lazily loaded modules (-Dlazy_modules=false, or no OpenCV/OpenImageIO)");
#else
    CHECK_MSG(!mapped("libopencv_core"), "OpenCV is loaded before any shim call");
    missing_module();
    /* a call into the module: bytes that are no image are refused by OpenCV itself, not by the loader */
    static const uint8_t junk[16] = { 1, 2, 3 };
    uint8_t *buf = NULL;
    size_t cap = 0;
    uint32_t w = 0, h = 0;
    int rc = sp_cv_image_decode(junk, sizeof(junk), &buf, &cap, &w, &h);
    CHECK_MSG(rc != 0 && rc != SP_EMODULE, "decoding junk: %d", rc);
    CHECK_MSG(mapped("libopencv_core"), "OpenCV is not loaded after a shim call");
    free(buf);
    /* and a real image: a 1x1 PGM decodes to one grey RGB pixel */
    static const uint8_t pgm[] = { 'P', '5', '\n', '1', ' ', '1', '\n', '2', '5', '5', '\n', 200 };
    buf = NULL, cap = 0;
    rc = sp_cv_image_decode(pgm, sizeof(pgm), &buf, &cap, &w, &h);
    CHECK_EQ_INT(rc, 0);
    CHECK(w == 1 && h == 1 && buf && buf[0] == 200 && buf[1] == 200 && buf[2] == 200);
    free(buf);
    return check_exit();
#endif
}
