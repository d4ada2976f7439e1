/* SPDX-License-Identifier: MIT */
/*
 * The error -> exit code list (tools/cmd_exit.c): each row maps as listed, to a documented code; the
 * cases users meet (full disk, read-only, exists, corrupt, feature, Ctrl-C) give what README.md promises;
 * every errno maps to a documented code; and README.md's list is the code's list, row for row.
 */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "tools/cmd.h"

static int documented(int code)
{
    return code == 0 || code == 1 || code == 2 || code == 3 || code == 4 || code == 70;
}

static void rows_map_as_listed(void)
{
    size_t n;
    const sp_exit_rule *r = sp_exit_rules(&n);
    CHECK(n >= 20);
    for (size_t i = 0; i < n; i++) {
        CHECK(documented(r[i].code));
        CHECK(sp_exit_for_error(r[i].err) == r[i].code);
        CHECK(r[i].name && r[i].name[0] && r[i].what && r[i].what[0]);
        for (size_t j = 0; j < i; j++)
            CHECK(r[j].err != r[i].err); /* one row per error */
    }
}

static void what_users_meet(void)
{
    CHECK(sp_exit_for_error(0) == 0);
    CHECK(sp_exit_for_error(-ENOSPC) == 3);
    CHECK(sp_exit_for_error(-EDQUOT) == 3);
    CHECK(sp_exit_for_error(-EROFS) == 3);
    CHECK(sp_exit_for_error(-EACCES) == 3);
    CHECK(sp_exit_for_error(-EFBIG) == 3);
    CHECK(sp_exit_for_error(-EEXIST) == 1);
    CHECK(sp_exit_for_error(-EINVAL) == 1);
    CHECK(sp_exit_for_error(SP_ECORRUPT) == 2);
    CHECK(sp_exit_for_error(SP_ETRUNCATED) == 2);
    CHECK(sp_exit_for_error(SP_EDISABLED) == 4);
    /* outside the list: another errno is the system's refusal, anything else a bug */
    CHECK(sp_exit_for_error(-EHOSTDOWN) == 3);
    CHECK(sp_exit_for_error(-5000) == 70);
    CHECK(sp_exit_for_error(-20000) == 70);
    CHECK(sp_exit_for_error(7) == 70);
    /* every errno the C library knows gives a documented failure code, never 0 */
    for (int e = 1; e < 4096; e++)
        CHECK(documented(sp_exit_for_error(-e)) && sp_exit_for_error(-e) != 0);
}

static void stop_signals(void)
{
    CHECK(sp_exit_for_error(-EINTR) == 70); /* interrupted with no signal asking: a bug */
    CHECK(sp_exit_for_error(-ECANCELED) == 70);
    sp_cmd_stop_signal = SIGINT;
    CHECK(sp_exit_for_error(-EINTR) == 130);
    CHECK(sp_exit_for_error(-ECANCELED) == 130);
    CHECK(sp_exit_for_error(-ENOSPC) == 3); /* a real failure stays itself */
    CHECK(sp_cmd_fail("test", -ECANCELED, "stopping") == 130);
    sp_cmd_stop_signal = SIGTERM;
    CHECK(sp_exit_for_error(-ECANCELED) == 143);
    sp_cmd_stop_signal = 0;
    CHECK(sp_cmd_fail("test", 0, "no error") == 70); /* failing with "success" is a bug */
}

/* README.md lists every row as "| `NAME` | CODE | ..." and nothing more */
static void readme_lists_the_rows(const char *readme)
{
    FILE *f = fopen(readme, "rb");
    CHECK(f != NULL);
    if (!f)
        return;
    static char text[1 << 20];
    size_t len = fread(text, 1, sizeof(text) - 1, f);
    fclose(f);
    text[len] = 0;
    size_t n, listed = 0;
    const sp_exit_rule *r = sp_exit_rules(&n);
    for (size_t i = 0; i < n; i++) {
        char row[128];
        snprintf(row, sizeof(row), "| `%s` | %d |", r[i].name, r[i].code);
        if (!strstr(text, row))
            fprintf(stderr, "README.md does not list \"%s\"\n", row);
        CHECK(strstr(text, row) != NULL);
    }
    for (const char *p = text; (p = strstr(p, "\n| `")); p++) {
        char name[64];
        int code;
        if (sscanf(p, "\n| `%63[A-Z_0-9]` | %d |", name, &code) == 2)
            listed++;
    }
    if (listed != n)
        fprintf(stderr, "README.md lists %zu error rows, the code %zu\n", listed, n);
    CHECK(listed == n);
}

int main(int argc, char **argv)
{
    if (argc < 2) {
        fprintf(stderr, "usage: test_exit_codes README.md\n");
        return 1;
    }
    rows_map_as_listed();
    what_users_meet();
    stop_signals();
    readme_lists_the_rows(argv[1]);
    return check_exit();
}
