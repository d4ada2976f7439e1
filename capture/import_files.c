/* SPDX-License-Identifier: MIT */
/* Input file lists for the importers: a directory in natural name order, or a printf-style pattern. */
#include "import_internal.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

int sp_import_paths_add(sp_import_paths *l, const char *dir, const char *name)
{
    if (l->count == l->cap) {
        size_t cap = l->cap ? l->cap * 2 : 64;
        char **p = realloc(l->items, cap * sizeof(*p));
        if (!p)
            return -ENOMEM;
        l->items = p;
        l->cap = cap;
    }
    size_t n = (dir ? strlen(dir) + 1 : 0) + strlen(name) + 1;
    char *path = malloc(n);
    if (!path)
        return -ENOMEM;
    if (dir)
        snprintf(path, n, "%s/%s", dir, name);
    else
        snprintf(path, n, "%s", name);
    l->items[l->count++] = path;
    return 0;
}

void sp_import_paths_free(sp_import_paths *l)
{
    for (size_t i = 0; i < l->count; i++)
        free(l->items[i]);
    free(l->items);
    memset(l, 0, sizeof(*l));
}

static int has_ext(const char *name, const char *ext)
{
    size_t n = strlen(name), e = strlen(ext);
    return n > e && strcasecmp(name + n - e, ext) == 0;
}

int sp_import_is_image_name(const char *name)
{
    return has_ext(name, ".jpg") || has_ext(name, ".jpeg") || has_ext(name, ".png");
}

/* Name order in which digit runs compare as numbers: img_2 before img_10. */
int sp_import_natural_cmp(const char *a, const char *b)
{
    const char *a0 = a, *b0 = b;
    while (*a && *b) {
        if (isdigit((unsigned char)*a) && isdigit((unsigned char)*b)) {
            while (*a == '0')
                a++;
            while (*b == '0')
                b++;
            size_t na = 0, nb = 0;
            while (isdigit((unsigned char)a[na]))
                na++;
            while (isdigit((unsigned char)b[nb]))
                nb++;
            if (na != nb)
                return na < nb ? -1 : 1;
            int d = memcmp(a, b, na);
            if (d)
                return d;
            a += na;
            b += nb;
        } else if (*a != *b) {
            return (unsigned char)*a - (unsigned char)*b;
        } else {
            a++;
            b++;
        }
    }
    if (*a || *b)
        return (unsigned char)*a - (unsigned char)*b;
    return strcmp(a0, b0); /* equal numbers with different zero padding: still a total order */
}

static int path_cmp(const void *pa, const void *pb)
{
    return sp_import_natural_cmp(*(char *const *)pa, *(char *const *)pb);
}

static int is_regular(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0 && S_ISREG(st.st_mode);
}

int sp_import_list_directory(const char *dir, sp_import_paths *out, char *msg, size_t msg_size)
{
    DIR *d = opendir(dir);
    if (!d) {
        int rc = -errno;
        return sp_import_fail(msg, msg_size, rc, "%s: cannot open directory: %s", dir, sp_strerror(rc));
    }
    int rc = 0;
    struct dirent *e;
    while (!rc && (e = readdir(d)) != NULL) {
        if (e->d_name[0] == '.' || !sp_import_is_image_name(e->d_name))
            continue;
        rc = sp_import_paths_add(out, dir, e->d_name);
        if (!rc && !is_regular(out->items[out->count - 1]))
            free(out->items[--out->count]); /* a directory called x.png */
    }
    closedir(d);
    if (rc)
        return sp_import_fail(msg, msg_size, rc, "%s: listing: %s", dir, sp_strerror(rc));
    if (out->count == 0)
        return sp_import_fail(msg, msg_size, SP_ENODATA, "%s: no .jpg, .jpeg or .png files in this directory", dir);
    qsort(out->items, out->count, sizeof(char *), path_cmp);
    return 0;
}

/* A printf pattern with exactly one %d, %0Nd or %Nd; "%%" is a literal percent sign. */
typedef struct pattern {
    char prefix[4096], suffix[4096];
    int width, zero;
} pattern;

static int parse_pattern(const char *in, pattern *p)
{
    memset(p, 0, sizeof(*p));
    char *out = p->prefix;
    size_t n = 0, cap = sizeof(p->prefix);
    int convs = 0;
    for (const char *s = in; *s; s++) {
        if (*s == '%' && s[1] == '%') {
            s++;
        } else if (*s == '%') {
            s++;
            p->zero = *s == '0';
            while (isdigit((unsigned char)*s))
                p->width = p->width * 10 + (*s++ - '0');
            if (*s != 'd' || p->width > 12 || ++convs > 1)
                return -EINVAL;
            out[n] = 0;
            out = p->suffix;
            n = 0;
            cap = sizeof(p->suffix);
            continue;
        }
        if (n + 1 >= cap)
            return -ENAMETOOLONG;
        out[n++] = *s;
    }
    out[n] = 0;
    return convs == 1 ? 0 : -EINVAL;
}

static void expand_pattern(const pattern *p, long i, char *out, size_t size)
{
    if (p->zero)
        snprintf(out, size, "%s%0*ld%s", p->prefix, p->width, i, p->suffix);
    else
        snprintf(out, size, "%s%*ld%s", p->prefix, p->width, i, p->suffix);
}

int sp_import_list_pattern(const char *in, sp_import_paths *out, char *msg, size_t msg_size)
{
    pattern *p = malloc(sizeof(*p));
    char *path = malloc(8300);
    if (!p || !path) {
        free(p);
        free(path);
        return -ENOMEM;
    }
    int rc = parse_pattern(in, p);
    if (rc) {
        rc = sp_import_fail(msg, msg_size, -EINVAL, "%s: not a file, and not a pattern with one %%d, %%0Nd or %%Nd",
                            in);
        goto out;
    }
    long first = 0; /* like other tools, the sequence may start at any index from 0 to 4 */
    for (; first <= 4; first++) {
        expand_pattern(p, first, path, 8300);
        if (is_regular(path))
            break;
    }
    for (long i = first; !rc && first <= 4; i++) {
        expand_pattern(p, i, path, 8300);
        if (!is_regular(path))
            break;
        rc = sp_import_paths_add(out, NULL, path);
    }
    if (!rc && out->count == 0)
        rc = sp_import_fail(msg, msg_size, SP_ENODATA, "%s: no file matches this pattern (first index tried 0 to 4)",
                            in);
out:
    free(p);
    free(path);
    return rc;
}
