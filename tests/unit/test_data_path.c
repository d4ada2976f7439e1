/* SPDX-License-Identifier: MIT */
/* Run-time data discovery: the variable wins even when wrong, then XDG_DATA_HOME, XDG_DATA_DIRS in order
 * (relative entries skipped), then the build default; a directory counts only with its probe file. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "check.h"
#include "common/data_path.h"
#include "sunprobe/sp_face_model.h"

static char root[256];

static void touch(const char *rel)
{
    char p[400], cmd[1000];
    snprintf(p, sizeof(p), "%s/%s", root, rel);
    snprintf(cmd, sizeof(cmd), "mkdir -p \"$(dirname '%s')\" && : > '%s'", p, p);
    CHECK(system(cmd) == 0);
}

int main(void)
{
    snprintf(root, sizeof(root), "%s/sp-data.XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    if (!mkdtemp(root))
        SKIP("cannot create a temporary directory");
    char home[300], d1[300], d2[300], dirs[700];
    snprintf(home, sizeof(home), "%s/home", root);
    snprintf(d1, sizeof(d1), "%s/d1", root);
    snprintf(d2, sizeof(d2), "%s/d2", root);
    unsetenv("SP_ICT_FACEKIT_DIR");
    setenv("XDG_DATA_HOME", home, 1);
    snprintf(dirs, sizeof(dirs), "relative/dir:%s:%s", d1, d2);
    setenv("XDG_DATA_DIRS", dirs, 1);
    sp_data_location l;

    /* a directory without its probe file does not count: d2 holds the model, d1 only an empty folder */
    touch("d1/sunprobe/ict-facekit/README.md");
    touch("d2/sunprobe/ict-facekit/generic_neutral_mesh.obj");
    sp_data_locate("SP_ICT_FACEKIT_DIR", "ict-facekit", "generic_neutral_mesh.obj", "/nonexistent", &l);
    CHECK(l.found && !strcmp(l.source, "XDG_DATA_DIRS") && strstr(l.path, "/d2/sunprobe/ict-facekit"));
    /* the user's own copy comes first */
    touch("home/sunprobe/ict-facekit/generic_neutral_mesh.obj");
    CHECK(strstr(sp_face_ict_dir(), "/home/sunprobe/ict-facekit") != NULL);
    /* the variable is used as given, found or not */
    setenv("SP_ICT_FACEKIT_DIR", "/nonexistent/ict", 1);
    sp_face_ict_locate(&l);
    CHECK(!l.found && !strcmp(l.path, "/nonexistent/ict") && !strcmp(l.source, "SP_ICT_FACEKIT_DIR"));
    unsetenv("SP_ICT_FACEKIT_DIR");
    /* a file (the dlib model): rel names the file itself; nothing anywhere gives the fallback, not found */
    sp_data_locate("SP_TEST_NO_SUCH_VAR", "model.dat", NULL, "/nonexistent/model.dat", &l);
    CHECK(!l.found && !strcmp(l.path, "/nonexistent/model.dat") && !strcmp(l.source, "build default"));
    touch("d1/sunprobe/model.dat");
    sp_data_locate("SP_TEST_NO_SUCH_VAR", "model.dat", NULL, "/nonexistent/model.dat", &l);
    CHECK(l.found && strstr(l.path, "/d1/sunprobe/model.dat"));
    /* a relative XDG_DATA_HOME is ignored (the spec): ~/.local/share stands in for it */
    setenv("XDG_DATA_HOME", "relative", 1);
    char user[300];
    snprintf(user, sizeof(user), "%s/user", root);
    setenv("HOME", user, 1);
    sp_data_locate("SP_TEST_NO_SUCH_VAR", "ict-facekit", "generic_neutral_mesh.obj", NULL, &l);
    CHECK(l.found && !strcmp(l.source, "XDG_DATA_DIRS"));
    touch("user/.local/share/sunprobe/ict-facekit/generic_neutral_mesh.obj");
    sp_data_locate("SP_TEST_NO_SUCH_VAR", "ict-facekit", "generic_neutral_mesh.obj", NULL, &l);
    CHECK(l.found && !strcmp(l.source, "XDG_DATA_HOME") && strstr(l.path, "/user/.local/share/sunprobe/"));

    char cmd[300];
    snprintf(cmd, sizeof(cmd), "rm -rf '%s'", root);
    if (system(cmd) != 0)
        fprintf(stderr, "cannot remove %s\n", root);
    return check_exit();
}
