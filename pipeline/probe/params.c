/* SPDX-License-Identifier: MIT */
/* The plane and shadow models as JSON (written into a probe directory, read back for compositing). */
#include "probe_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/json.h"

static const char *const plane_status_names[] = { "ok", "none", "one_point", "line" };

static void numbers(sp_strbuf *b, const char *key, const double *v, size_t n)
{
    sp_strbuf_printf(b, ",");
    sp_strbuf_json_string(b, key);
    sp_strbuf_printf(b, ":[");
    for (size_t i = 0; i < n; i++) {
        if (i)
            sp_strbuf_printf(b, ",");
        sp_strbuf_json_number(b, v[i]);
    }
    sp_strbuf_printf(b, "]");
}

static void number(sp_strbuf *b, const char *key, double v)
{
    sp_strbuf_printf(b, ",");
    sp_strbuf_json_string(b, key);
    sp_strbuf_printf(b, ":");
    sp_strbuf_json_number(b, v);
}

static void plane_json(sp_strbuf *b, const sp_probe_plane *pl)
{
    unsigned st = (unsigned)pl->status < 4 ? (unsigned)pl->status : 1;
    sp_strbuf_printf(b, "\"plane\":{\"status\":\"%s\",\"model\":\"h = a*x + b*y + c (pixels)\"",
                     plane_status_names[st]);
    number(b, "a", pl->a);
    number(b, "b", pl->b);
    number(b, "c", pl->c);
    double line[4] = { pl->line_x, pl->line_y, pl->line_dx, pl->line_dy };
    numbers(b, "line", line, 4);
    number(b, "line_tol", pl->line_tol);
    number(b, "observations", pl->n_observations);
    number(b, "inliers", pl->n_inliers);
    number(b, "residual_rel", pl->residual_rel);
    number(b, "holdout_n", pl->holdout_n);
    number(b, "holdout_error_rel", pl->holdout_error_rel);
    sp_strbuf_printf(b, ",\"note\":");
    sp_strbuf_json_string(b, pl->note);
    sp_strbuf_printf(b, "}");
}

static void shadow_json(sp_strbuf *b, const sp_probe_shadow *sh)
{
    sp_strbuf_printf(b, "\"shadow\":{\"present\":%s,\"model\":\"tip = foot + h*(dx,dy); dx = ox0 + ox1*u + "
                        "ox2*v, dy = oy0 + oy1*u + oy2*v; u = x/width, v = y/height\"",
                     sh->present ? "true" : "false");
    numbers(b, "ox", sh->ox, 3);
    numbers(b, "oy", sh->oy, 3);
    numbers(b, "ratio", sh->ratio, 3);
    number(b, "shadows", sh->n_shadows);
    number(b, "candidates", sh->n_candidates);
    number(b, "direction_spread_deg", sh->direction_spread_deg);
    sp_strbuf_printf(b, ",\"note\":");
    sp_strbuf_json_string(b, sh->note);
    sp_strbuf_printf(b,
                     ",\"contact\":{\"present\":%s,\"model\":\"ground/plate luminance around the feet over "
                     "that at 1.5-2, across the foot row; ring k at (k + 0.5) / 4 x 0.25 h from the foot\"",
                     sh->contact_present ? "true" : "false");
    numbers(b, "rings", sh->contact, SP_PROBE_CONTACT_BINS);
    number(b, "observations", sh->n_contact);
    sp_strbuf_printf(b, ",\"note\":");
    sp_strbuf_json_string(b, sh->contact_note);
    sp_strbuf_printf(b, "}}");
}

int sp_probe_params_to_json(const sp_probe_plane *plane, const sp_probe_shadow *shadow,
                            const sp_probe_stats *stats, uint32_t width, uint32_t height, char **out)
{
    if (!plane || !shadow || !out || !width || !height)
        return -EINVAL;
    sp_strbuf b = { 0 };
    sp_strbuf_printf(&b, "{\"format\":\"sunprobe-probe\",\"version\":1,\"width\":%u,\"height\":%u,\n", width,
                     height);
    plane_json(&b, plane);
    sp_strbuf_printf(&b, ",\n");
    shadow_json(&b, shadow);
    if (stats) /* observations per class (PROBE.md, "Object classes") */
        sp_strbuf_printf(&b,
                         ",\n\"objects\":{\"observations\":%llu,\"person\":%llu,\"car\":%llu,\"other\":%llu,"
                         "\"repeated_still\":%llu}",
                         (unsigned long long)stats->objects, (unsigned long long)stats->people,
                         (unsigned long long)stats->cars,
                         (unsigned long long)(stats->objects - stats->people - stats->cars - stats->repeats),
                         (unsigned long long)stats->repeats);
    sp_strbuf_printf(&b, "}\n");
    if (b.failed) {
        sp_strbuf_free(&b);
        return -ENOMEM;
    }
    *out = b.data;
    return 0;
}

/* Array of exactly n finite-or-null numbers into v (null reads as NaN). */
static int read_numbers(const sp_json *obj, const char *key, double *v, size_t n)
{
    const sp_json *a = sp_json_get(obj, key);
    if (!a || a->type != SP_JSON_ARRAY || a->count != n)
        return SP_ECORRUPT;
    for (size_t i = 0; i < n; i++)
        v[i] = sp_json_number(sp_json_at(a, i), (double)NAN);
    return 0;
}

static void read_note(const sp_json *obj, char *dst, size_t size)
{
    const char *s = sp_json_string(sp_json_get(obj, "note"), "");
    strncpy(dst, s, size - 1);
    dst[size - 1] = '\0';
}

static unsigned read_count(const sp_json *obj, const char *key)
{
    double v = sp_json_number(sp_json_get(obj, key), 0);
    return v >= 0 && v < 4e9 ? (unsigned)v : 0;
}

static int parse_plane(const sp_json *o, sp_probe_plane *pl)
{
    memset(pl, 0, sizeof(*pl));
    const char *st = sp_json_string(sp_json_get(o, "status"), "");
    int found = -1;
    for (int i = 0; i < 4; i++)
        if (!strcmp(st, plane_status_names[i]))
            found = i;
    double line[4];
    if (found < 0 || read_numbers(o, "line", line, 4))
        return SP_ECORRUPT;
    pl->status = (enum sp_probe_plane_status)found;
    pl->a = sp_json_number(sp_json_get(o, "a"), (double)NAN);
    pl->b = sp_json_number(sp_json_get(o, "b"), (double)NAN);
    pl->c = sp_json_number(sp_json_get(o, "c"), (double)NAN);
    pl->line_x = line[0], pl->line_y = line[1], pl->line_dx = line[2], pl->line_dy = line[3];
    pl->line_tol = sp_json_number(sp_json_get(o, "line_tol"), 0);
    pl->n_observations = read_count(o, "observations");
    pl->n_inliers = read_count(o, "inliers");
    pl->residual_rel = sp_json_number(sp_json_get(o, "residual_rel"), (double)NAN);
    pl->holdout_n = read_count(o, "holdout_n");
    pl->holdout_error_rel = sp_json_number(sp_json_get(o, "holdout_error_rel"), (double)NAN);
    read_note(o, pl->note, sizeof(pl->note));
    if (pl->status != SP_PROBE_PLANE_NONE && !(isfinite(pl->a) && isfinite(pl->b) && isfinite(pl->c)))
        return SP_ECORRUPT;
    return 0;
}

static int parse_shadow(const sp_json *o, sp_probe_shadow *sh)
{
    memset(sh, 0, sizeof(*sh));
    const sp_json *present = sp_json_get(o, "present");
    if (!present || present->type != SP_JSON_BOOL)
        return SP_ECORRUPT;
    sh->present = present->number != 0;
    if (read_numbers(o, "ox", sh->ox, 3) || read_numbers(o, "oy", sh->oy, 3) || read_numbers(o, "ratio", sh->ratio, 3))
        return SP_ECORRUPT;
    sh->n_shadows = read_count(o, "shadows");
    sh->n_candidates = read_count(o, "candidates");
    sh->direction_spread_deg = sp_json_number(sp_json_get(o, "direction_spread_deg"), (double)NAN);
    read_note(o, sh->note, sizeof(sh->note));
    for (int i = 0; sh->present && i < 3; i++)
        if (!isfinite(sh->ox[i]) || !isfinite(sh->oy[i]) || !(sh->ratio[i] >= 0 && sh->ratio[i] <= 2))
            return SP_ECORRUPT;
    const sp_json *c = sp_json_get(o, "contact"); /* optional: probe directories before it lack it */
    if (!c)
        return 0;
    const sp_json *cp = sp_json_get(c, "present");
    if (c->type != SP_JSON_OBJECT || !cp || cp->type != SP_JSON_BOOL ||
        read_numbers(c, "rings", sh->contact, SP_PROBE_CONTACT_BINS))
        return SP_ECORRUPT;
    sh->contact_present = cp->number != 0;
    sh->n_contact = read_count(c, "observations");
    read_note(c, sh->contact_note, sizeof(sh->contact_note));
    for (int i = 0; sh->contact_present && i < SP_PROBE_CONTACT_BINS; i++)
        if (!(sh->contact[i] >= 0 && sh->contact[i] <= 2))
            return SP_ECORRUPT;
    return 0;
}

int sp_probe_params_from_json(const char *json, size_t len, sp_probe_plane *plane, sp_probe_shadow *shadow,
                              uint32_t *width, uint32_t *height)
{
    if (!json || !plane || !shadow || !width || !height)
        return -EINVAL;
    sp_json *root = NULL;
    char err[128];
    int ret = sp_json_parse(json, len, &root, err, sizeof(err));
    if (ret)
        return SP_ECORRUPT;
    double w = sp_json_number(sp_json_get(root, "width"), 0), h = sp_json_number(sp_json_get(root, "height"), 0);
    const char *fmt = sp_json_string(sp_json_get(root, "format"), "");
    ret = strcmp(fmt, "sunprobe-probe") || !(w >= 1 && w <= 16384) || !(h >= 1 && h <= 16384) ? SP_ECORRUPT : 0;
    const sp_json *pl = sp_json_get(root, "plane"), *sh = sp_json_get(root, "shadow");
    if (!ret && (!pl || !sh))
        ret = SP_ECORRUPT;
    if (!ret)
        ret = parse_plane(pl, plane);
    if (!ret)
        ret = parse_shadow(sh, shadow);
    if (!ret) {
        *width = (uint32_t)w;
        *height = (uint32_t)h;
    }
    sp_json_free(root);
    return ret;
}
