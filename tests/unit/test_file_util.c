/* SPDX-License-Identifier: MIT */
/*
 * common/file_util: whole-file read/write (limits, missing files, streams,
 * unwritable places), path helpers, and partial outputs (commit, refusal to
 * replace, replace on request, abort removes everything).
 */
#include <errno.h>
#include <signal.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "check.h"
#include "common/file_set.h"
#include "common/file_util.h"

static char root[256];

static const char *at(const char *name)
{
    static char buf[4][512];
    static int k;
    k = (k + 1) % 4;
    snprintf(buf[k], sizeof(buf[k]), "%s/%s", root, name);
    return buf[k];
}

static int exists(const char *path)
{
    struct stat st;
    return lstat(path, &st) == 0;
}

static void put(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

/* Returns the file's text (caller frees) or NULL. */
static char *get(const char *path)
{
    void *d = NULL;
    size_t n = 0;
    return sp_read_whole_file(path, 1 << 20, &d, &n) == 0 ? d : NULL;
}

static int text_is(const char *path, const char *want)
{
    char *t = get(path);
    int ok = t && strcmp(t, want) == 0;
    free(t);
    return ok;
}

/* A child writes `bytes` into a FIFO; returns what sp_read_whole_file says about it. */
static int stream_read(size_t bytes, size_t max, size_t *n)
{
    char fifo[512];
    snprintf(fifo, sizeof(fifo), "%s", at("fifo"));
    unlink(fifo);
    if (mkfifo(fifo, 0600) != 0)
        return -errno;
    pid_t pid = fork();
    if (pid == 0) {
        signal(SIGPIPE, SIG_DFL); /* the reader may stop early: dying of SIGPIPE is expected */
        int fd = open(fifo, O_WRONLY);
        char block[4096];
        memset(block, 'x', sizeof(block));
        for (size_t done = 0; fd >= 0 && done < bytes;) {
            size_t k = bytes - done < sizeof(block) ? bytes - done : sizeof(block);
            ssize_t w = write(fd, block, k);
            if (w <= 0)
                break;
            done += (size_t)w;
        }
        _exit(0);
    }
    if (pid < 0)
        return -errno;
    void *d = NULL;
    int rc = sp_read_whole_file(fifo, max, &d, n);
    if (rc == 0) {
        size_t i = 0;
        while (i < *n && ((char *)d)[i] == 'x')
            i++;
        CHECK(i == *n && ((char *)d)[i] == '\0');
        free(d);
    }
    int status = 0;
    waitpid(pid, &status, 0);
    return rc;
}

static void test_read(void)
{
    void *d = (void *)&d;
    size_t n = 12345;
    CHECK_EQ_INT(sp_read_whole_file(at("missing"), 100, &d, &n), -ENOENT);
    CHECK(d == (void *)&d && n == 12345); /* untouched on error */
    CHECK_EQ_INT(sp_read_whole_file(root, 100, &d, &n), -EISDIR);
    CHECK_EQ_INT(sp_read_whole_file(NULL, 100, &d, &n), -EINVAL);

    put(at("ten"), "0123456789");
    CHECK_EQ_INT(sp_read_whole_file(at("ten"), 9, &d, &n), -EFBIG);
    CHECK_EQ_INT(sp_read_whole_file(at("ten"), 10, &d, &n), 0);
    CHECK_EQ_INT(n, 10);
    CHECK(memcmp(d, "0123456789", 11) == 0); /* NUL after the content */
    free(d);

    put(at("empty"), "");
    CHECK_EQ_INT(sp_read_whole_file(at("empty"), 0, &d, &n), 0);
    CHECK(n == 0 && ((char *)d)[0] == '\0');
    free(d);

    /* a stream (fstat says nothing about its size): the limit still holds, and a small one reads whole */
    CHECK_EQ_INT(stream_read(65 * 4096, 100000, &n), -EFBIG);
    CHECK_EQ_INT(stream_read(3 * 4096 + 7, 100000, &n), 0);
    CHECK_EQ_INT(n, 3 * 4096 + 7);
}

static void test_write(void)
{
    const char *p = at("w.bin");
    CHECK_EQ_INT(sp_write_whole_file_atomic(p, "abc", 3), 0);
    CHECK(text_is(p, "abc"));
    CHECK_EQ_INT(sp_write_whole_file_atomic(p, "xy", 2), 0); /* replaces */
    CHECK(text_is(p, "xy"));
    CHECK_EQ_INT(sp_write_whole_file_atomic(p, NULL, 0), 0);
    CHECK(text_is(p, ""));
    CHECK_EQ_INT(sp_write_whole_file_atomic(at("no/such/dir/f"), "a", 1), -ENOENT);
    CHECK_EQ_INT(sp_write_whole_file_atomic(at("w.bin/f"), "a", 1), -ENOTDIR); /* parent is a file */
    if (geteuid() != 0) { /* root writes anywhere */
        CHECK_EQ_INT(mkdir(at("ro"), 0500), 0);
        CHECK_EQ_INT(sp_write_whole_file_atomic(at("ro/f"), "a", 1), -EACCES);
        CHECK(!exists(at("ro/f")));
    } else {
        printf("note: running as root, the read-only directory case is not tested\n");
    }
    CHECK_EQ_INT(sp_write_whole_file_atomic(NULL, "a", 1), -EINVAL);
    /* devices are written in place (a rename would replace the node); reached through links here, so a
       regression replaces only the link, never /dev/null itself */
    struct stat st;
    CHECK_EQ_INT(symlink("/dev/null", at("null")), 0);
    CHECK_EQ_INT(sp_write_whole_file_atomic(at("null"), "a", 1), 0);
    CHECK(lstat(at("null"), &st) == 0 && S_ISLNK(st.st_mode));
    if (stat("/dev/full", &st) == 0 && S_ISCHR(st.st_mode) && symlink("/dev/full", at("full")) == 0) {
        CHECK_EQ_INT(sp_write_whole_file_atomic(at("full"), "a", 1), -ENOSPC);
        CHECK(lstat(at("full"), &st) == 0 && S_ISLNK(st.st_mode));
    }
}

static void test_paths(void)
{
    char buf[8];
    CHECK_EQ_INT(sp_path_join(buf, sizeof(buf), "ab", "cd"), 0);
    CHECK(strcmp(buf, "ab/cd") == 0);
    CHECK_EQ_INT(sp_path_join(buf, sizeof(buf), "abc", "defg"), -ENAMETOOLONG); /* 8 bytes + NUL */
    char *j = sp_path_join_alloc("x", "y.z");
    CHECK(j && strcmp(j, "x/y.z") == 0);
    free(j);
    CHECK(sp_is_regular_file(at("ten")));
    CHECK(!sp_is_regular_file(root));
    CHECK(!sp_is_regular_file(at("missing")));
    CHECK_EQ_INT(sp_mkdir_p(at("m/n//o/"), 0755), 0);
    CHECK_EQ_INT(sp_mkdir_p(at("m/n/o"), 0755), 0); /* existing is fine */
    struct stat st;
    CHECK(stat(at("m/n/o"), &st) == 0 && S_ISDIR(st.st_mode));
    CHECK_EQ_INT(sp_mkdir_p(at("ten/sub"), 0755), -ENOTDIR);
    CHECK_EQ_INT(sp_mkdir_p(at("ten"), 0755), -ENOTDIR);
    CHECK_EQ_INT(sp_remove_tree(at("m")), 0);
    CHECK(!exists(at("m")));
    CHECK_EQ_INT(sp_remove_tree(at("m")), -ENOENT);
    CHECK_EQ_INT(sp_sync_parent_dir(at("ten")), 0);
}

/* Fills a partial directory with a file, a subdirectory and a symlink pointing outside. */
static void fill(const char *dir, const char *text)
{
    char p[600];
    snprintf(p, sizeof(p), "%s/a.txt", dir);
    put(p, text);
    snprintf(p, sizeof(p), "%s/sub", dir);
    CHECK_EQ_INT(mkdir(p, 0755), 0);
    snprintf(p, sizeof(p), "%s/sub/b.txt", dir);
    put(p, "b");
    snprintf(p, sizeof(p), "%s/link", dir);
    CHECK_EQ_INT(symlink(at("keep"), p), 0);
}

static void test_partial_dir(void)
{
    put(at("keep"), "outside");
    const char *out = at("out");
    sp_partial pd;
    CHECK_EQ_INT(sp_partial_dir_open(&pd, out), 0);
    char want[600];
    snprintf(want, sizeof(want), "%s.partial.%ld", out, (long)getpid());
    CHECK(pd.path && strcmp(pd.path, want) == 0);
    fill(pd.path, "one");
    CHECK_EQ_INT(sp_partial_dir_commit(&pd, 0), 0);
    CHECK(pd.path == NULL && !exists(want));
    CHECK(text_is(at("out/a.txt"), "one") && text_is(at("out/sub/b.txt"), "b"));

    /* an existing non-empty output is refused, and both stay as they were */
    CHECK_EQ_INT(sp_partial_dir_open(&pd, out), 0);
    fill(pd.path, "two");
    CHECK_EQ_INT(sp_partial_dir_commit(&pd, 0), -EEXIST);
    CHECK(exists(want) && text_is(at("out/a.txt"), "one"));
    /* ... unless asked: then it is replaced and the old one is gone */
    CHECK_EQ_INT(sp_partial_dir_commit(&pd, SP_PARTIAL_REPLACE), 0);
    CHECK(text_is(at("out/a.txt"), "two") && !exists(want));
    char old[600];
    snprintf(old, sizeof(old), "%s.old.%ld", out, (long)getpid());
    CHECK(!exists(old));

    /* an empty directory in the way is replaced without asking */
    CHECK_EQ_INT(mkdir(at("empty_out"), 0755), 0);
    CHECK_EQ_INT(sp_partial_dir_open(&pd, at("empty_out")), 0);
    put(at("empty_out.partial.x"), "not ours"); /* a neighbour with a similar name survives */
    fill(pd.path, "three");
    CHECK_EQ_INT(sp_partial_dir_commit(&pd, 0), 0);
    CHECK(text_is(at("empty_out/a.txt"), "three"));

    /* a file in the way is refused too */
    put(at("file_out"), "file");
    CHECK_EQ_INT(sp_partial_dir_open(&pd, at("file_out")), 0);
    CHECK_EQ_INT(sp_partial_dir_commit(&pd, 0), -EEXIST);
    CHECK(text_is(at("file_out"), "file"));
    sp_partial_dir_abort(&pd);

    /* abort removes the whole tree but not what a symlink in it points to */
    CHECK_EQ_INT(sp_partial_dir_open(&pd, at("aborted")), 0);
    char path[600];
    snprintf(path, sizeof(path), "%s", pd.path);
    fill(pd.path, "four");
    sp_partial_dir_abort(&pd);
    CHECK(pd.path == NULL && !exists(path) && !exists(at("aborted")));
    CHECK(text_is(at("keep"), "outside") && text_is(at("empty_out.partial.x"), "not ours"));
    sp_partial_dir_abort(&pd); /* twice is harmless */

    /* a partial that cannot be created: nothing to clean, nothing removed */
    CHECK_EQ_INT(sp_partial_dir_open(&pd, at("no/such/parent")), -ENOENT);
    CHECK(pd.path == NULL);
    CHECK_EQ_INT(sp_partial_dir_commit(&pd, 0), -EINVAL);
    CHECK_EQ_INT(sp_partial_dir_open(&pd, ""), -EINVAL);
}

static void test_partial_file(void)
{
    const char *out = at("cap.bin");
    sp_partial pf;
    CHECK_EQ_INT(sp_partial_file_open(&pf, out), 0);
    CHECK(strcmp(pf.path, at("cap.bin.partial")) == 0);
    CHECK(!exists(pf.path)); /* the caller creates it */
    put(pf.path, "v1");
    CHECK_EQ_INT(sp_partial_file_commit(&pf, 0), 0);
    CHECK(text_is(out, "v1") && !exists(at("cap.bin.partial")));

    CHECK_EQ_INT(sp_partial_file_open(&pf, out), 0);
    put(pf.path, "v2");
    CHECK_EQ_INT(sp_partial_file_commit(&pf, 0), -EEXIST);
    CHECK(text_is(out, "v1") && exists(pf.path));
    CHECK_EQ_INT(sp_partial_file_commit(&pf, SP_PARTIAL_REPLACE), 0);
    CHECK(text_is(out, "v2"));

    CHECK_EQ_INT(sp_partial_file_open(&pf, out), 0);
    put(pf.path, "v3");
    sp_partial_file_abort(&pf);
    CHECK(!exists(at("cap.bin.partial")) && text_is(out, "v2") && pf.path == NULL);
    CHECK_EQ_INT(sp_partial_file_open(&pf, out), 0);
    sp_partial_file_abort(&pf); /* nothing was created: fine */
    CHECK_EQ_INT(sp_partial_file_commit(&pf, 0), -EINVAL);
}

/* A pid that no longer runs: a child that has exited and been reaped. */
static pid_t dead_pid(void)
{
    pid_t pid = fork();
    if (pid == 0)
        _exit(0);
    CHECK(pid > 0);
    int status;
    CHECK(waitpid(pid, &status, 0) == pid);
    return pid;
}

/* Partials left by crashed runs are removed on the next open; live or foreign-looking ones are not. */
static void test_stale_partials(void)
{
    char out[520]; /* at()'s buffers rotate, and fill() uses them */
    snprintf(out, sizeof(out), "%s", at("crashy"));
    char stale[600], alive[600], odd[600], plain[600];
    snprintf(stale, sizeof(stale), "%s.partial.%ld", out, (long)dead_pid());
    snprintf(alive, sizeof(alive), "%s.partial.%ld", out, (long)getppid()); /* our parent still runs */
    snprintf(odd, sizeof(odd), "%s.partial.12x", out);
    snprintf(plain, sizeof(plain), "%s.partial.%ld", at("crashy2"), (long)dead_pid()); /* another output's */
    const char *dirs[] = { stale, alive, odd, plain };
    for (int i = 0; i < 4; i++) {
        CHECK_EQ_INT(mkdir(dirs[i], 0755), 0);
        fill(dirs[i], "left");
    }
    sp_partial pd;
    CHECK_EQ_INT(sp_partial_dir_open(&pd, out), 0);
    CHECK(!exists(stale));
    CHECK(exists(alive) && exists(odd) && exists(plain));
    sp_partial_dir_abort(&pd);
    /* a relative name sweeps the current directory */
    char cwd[512];
    CHECK(getcwd(cwd, sizeof(cwd)) != NULL);
    CHECK_EQ_INT(chdir(root), 0);
    CHECK_EQ_INT(sp_partial_dir_open(&pd, "crashy2"), 0);
    CHECK(!exists(plain) && exists(alive));
    sp_partial_dir_abort(&pd);
    CHECK_EQ_INT(chdir(cwd), 0);
    for (int i = 1; i < 3; i++)
        CHECK_EQ_INT(sp_remove_tree(dirs[i]), 0);
}

/* Counts the entries of root whose name contains tag (temporaries and kept old files). */
static int count_tagged(const char *tag)
{
    char cmd[700];
    snprintf(cmd, sizeof(cmd), "ls -a '%s' | grep -c -- '%s' >/dev/null", root, tag);
    return system(cmd) == 0;
}

/* Adds final to fs and writes text under its temporary name. */
static void stage(sp_file_set *fs, const char *final_path, const char *text)
{
    const char *tmp = NULL;
    CHECK_EQ_INT(sp_file_set_add(fs, final_path, &tmp), 0);
    if (tmp)
        put(tmp, text);
}

static void test_file_set(void)
{
    sp_file_set fs = { 0 };
    stage(&fs, at("set.glb"), "glb1");
    stage(&fs, at("set.env.hdr"), "env1");
    CHECK(!exists(at("set.glb")) && !exists(at("set.env.hdr"))); /* nothing final before the commit */
    CHECK_EQ_INT(sp_file_set_commit(&fs), 0);
    CHECK(text_is(at("set.glb"), "glb1") && text_is(at("set.env.hdr"), "env1"));
    CHECK(fs.count == 0 && !count_tagged(".new.") && !count_tagged(".old."));

    /* abort: the old set stays, no temporary is left */
    stage(&fs, at("set.glb"), "glb2");
    stage(&fs, at("set.env.hdr"), "env2");
    sp_file_set_abort(&fs);
    CHECK(text_is(at("set.glb"), "glb1") && text_is(at("set.env.hdr"), "env1") && !count_tagged(".new."));

    /* a rename fails half-way (the third temporary was never written): the first two are put back */
    const char *tmp = NULL;
    stage(&fs, at("set.env.hdr"), "env3");
    stage(&fs, at("set.extra.txt"), "new3");
    CHECK_EQ_INT(sp_file_set_add(&fs, at("set.png"), &tmp), 0);
    stage(&fs, at("set.glb"), "glb3");
    CHECK_EQ_INT(sp_file_set_commit(&fs), -ENOENT);
    CHECK(text_is(at("set.glb"), "glb1") && text_is(at("set.env.hdr"), "env1"));
    CHECK(!exists(at("set.extra.txt")) && !exists(at("set.png")));
    CHECK(fs.count == 0 && !count_tagged(".new.") && !count_tagged(".old."));

    /* a directory in the way of a final name is refused, not moved aside */
    CHECK_EQ_INT(mkdir(at("set.png"), 0755), 0);
    put(at("set.png/x"), "x");
    stage(&fs, at("set.glb"), "glb4");
    stage(&fs, at("set.png"), "png4");
    CHECK_EQ_INT(sp_file_set_commit(&fs), -EISDIR);
    CHECK(text_is(at("set.glb"), "glb1") && text_is(at("set.png/x"), "x"));
    CHECK(!count_tagged(".new.") && !count_tagged(".old."));

    /* a device in the set (a link to /dev/null here) is written in place and survives the commit */
    struct stat st;
    CHECK_EQ_INT(symlink("/dev/null", at("set-null")), 0);
    stage(&fs, at("set-null"), "dev");
    stage(&fs, at("set.glb"), "glb5");
    CHECK_EQ_INT(sp_file_set_commit(&fs), 0);
    CHECK(lstat(at("set-null"), &st) == 0 && S_ISLNK(st.st_mode) && text_is(at("set.glb"), "glb5"));

    CHECK_EQ_INT(sp_file_set_add(&fs, "", &(const char *){ NULL }), -EINVAL);
    CHECK_EQ_INT(sp_file_set_commit(&fs), 0); /* an empty set */
    sp_file_set_abort(&fs);
    sp_file_set_abort(NULL);
}

int main(void)
{
    const char *tmp = getenv("TMPDIR");
    snprintf(root, sizeof(root), "%s/sp_file_util_XXXXXX", tmp && *tmp ? tmp : "/tmp");
    if (!mkdtemp(root))
        SKIP("cannot create a temporary directory: %s", strerror(errno));
    test_read();
    test_write();
    test_paths();
    test_partial_dir();
    test_stale_partials();
    test_partial_file();
    test_file_set();
    if (!check_failures)
        CHECK_EQ_INT(sp_remove_tree(root), 0);
    else
        fprintf(stderr, "left %s for inspection\n", root);
    return check_exit();
}
