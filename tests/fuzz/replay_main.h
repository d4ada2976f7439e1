/* SPDX-License-Identifier: MIT */
/*
 * The plain main of the fuzz harnesses (include last, after LLVMFuzzerTestOneInput): without
 * libFuzzer (-DSP_LIBFUZZER) it replays every file named, or found directly inside a directory
 * named, on the command line, so the normal suite runs the seed corpus.
 */
#ifndef SUNPROBE_TESTS_FUZZ_REPLAY_MAIN_H
#define SUNPROBE_TESTS_FUZZ_REPLAY_MAIN_H

#include <dirent.h>
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#ifndef SP_LIBFUZZER
static int replay_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return -1;
    size_t cap = 1 << 16, len = 0;
    uint8_t *buf = malloc(cap);
    size_t n;
    while (buf && (n = fread(buf + len, 1, cap - len, f)) > 0) {
        len += n;
        if (len == cap) {
            uint8_t *bigger = realloc(buf, cap * 2);
            if (!bigger) {
                free(buf);
                buf = NULL;
                break;
            }
            buf = bigger;
            cap *= 2;
        }
    }
    fclose(f);
    if (!buf)
        return -1;
    LLVMFuzzerTestOneInput(buf, len);
    free(buf);
    return 0;
}

/* Replays every regular file named, or found directly inside a directory named, on the command line. */
int main(int argc, char **argv)
{
    int files = 0, failed = 0;
    for (int i = 1; i < argc; i++) {
        struct stat st;
        if (stat(argv[i], &st) < 0) {
            fprintf(stderr, "%s: %s\n", argv[i], strerror(errno));
            failed++;
            continue;
        }
        if (!S_ISDIR(st.st_mode)) {
            failed += replay_file(argv[i]) < 0;
            files++;
            continue;
        }
        DIR *d = opendir(argv[i]);
        struct dirent *e;
        char p[4096];
        while (d && (e = readdir(d))) {
            snprintf(p, sizeof(p), "%s/%s", argv[i], e->d_name);
            if (e->d_name[0] == '.' || stat(p, &st) < 0 || !S_ISREG(st.st_mode))
                continue;
            failed += replay_file(p) < 0;
            files++;
        }
        if (d)
            closedir(d);
    }
    fprintf(stderr, "replayed %d inputs, %d unreadable\n", files, failed);
    return files > 0 && failed == 0 ? 0 : 1;
}
#endif
#endif
