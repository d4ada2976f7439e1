/* SPDX-License-Identifier: MIT */
/* The importers' metadata: a META JSON file checked against the schema, then merged with what the import knows. */
#include "import_internal.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/file_util.h"

#define MAX_META_FILE (1u << 20)

static int read_text(const char *path, char **out, size_t *len, char *msg, size_t msg_size)
{
    void *buf = NULL;
    int rc = sp_read_whole_file(path, MAX_META_FILE, &buf, len);
    if (rc == -EFBIG)
        return sp_import_fail(msg, msg_size, SP_EUNSUPPORTED, "%s: larger than 1 MiB (metadata, not data)", path);
    if (rc == -ENOMEM || rc == -EIO)
        return sp_import_fail(msg, msg_size, rc, "%s: %s", path, sp_strerror(rc));
    if (rc)
        return sp_import_fail(msg, msg_size, rc, "%s: cannot open: %s", path, sp_strerror(rc));
    *out = buf; /* NUL-terminated */
    return 0;
}

typedef struct key_type {
    const char *key;
    sp_json_type type;
    size_t count; /* arrays: exact length, else 0 */
} key_type;

static const key_type top_keys[] = {
    { "kind", SP_JSON_STRING, 0 },    { "source", SP_JSON_STRING, 0 }, { "utc_start", SP_JSON_STRING, 0 },
    { "ground_truth", SP_JSON_STRING, 0 }, { "camera", SP_JSON_OBJECT, 0 }, { "imu", SP_JSON_OBJECT, 0 },
    { "location", SP_JSON_OBJECT, 0 }, { NULL, SP_JSON_NULL, 0 },
};
static const key_type camera_keys[] = {
    { "name", SP_JSON_STRING, 0 },  { "driver", SP_JSON_STRING, 0 }, { "width", SP_JSON_NUMBER, 0 },
    { "height", SP_JSON_NUMBER, 0 }, { "fps", SP_JSON_NUMBER, 0 },    { "fx", SP_JSON_NUMBER, 0 },
    { "fy", SP_JSON_NUMBER, 0 },    { "cx", SP_JSON_NUMBER, 0 },     { "cy", SP_JSON_NUMBER, 0 },
    { "focal_length_mm", SP_JSON_NUMBER, 0 }, { "sensor_width_mm", SP_JSON_NUMBER, 0 }, { NULL, SP_JSON_NULL, 0 },
};
static const key_type imu_keys[] = {
    { "name", SP_JSON_STRING, 0 },         { "rate_hz", SP_JSON_NUMBER, 0 },   { "time_offset_s", SP_JSON_NUMBER, 0 },
    { "to_camera", SP_JSON_ARRAY, 4 },     { "gyro_bias", SP_JSON_ARRAY, 3 },  { "accel_bias", SP_JSON_ARRAY, 3 },
    { NULL, SP_JSON_NULL, 0 },
};
static const key_type location_keys[] = {
    { "latitude", SP_JSON_NUMBER, 0 }, { "longitude", SP_JSON_NUMBER, 0 }, { "altitude_m", SP_JSON_NUMBER, 0 },
    { "magnetic_declination_deg", SP_JSON_NUMBER, 0 }, { "heading_deg", SP_JSON_NUMBER, 0 }, { NULL, SP_JSON_NULL, 0 },
};

static const char *type_name(sp_json_type t)
{
    static const char *const names[] = { "null", "a boolean", "a number", "a string", "an array", "an object" };
    return (unsigned)t < 6 ? names[t] : "?";
}

/* Known keys must have their schema type (null means "unknown" and is allowed); unknown keys pass through. */
static int check_keys(char *msg, size_t msg_size, const char *path, const char *prefix, const sp_json *obj,
                      const key_type *keys)
{
    for (const key_type *k = keys; k->key; k++) {
        const sp_json *v = sp_json_get(obj, k->key);
        if (!v || v->type == SP_JSON_NULL)
            continue;
        if (v->type != k->type)
            return sp_import_fail(msg, msg_size, SP_ECORRUPT, "%s: %s%s must be %s, not %s", path, prefix, k->key,
                                  type_name(k->type), type_name(v->type));
        if (k->count && (v->count != k->count || sp_json_numbers(v, (double[4]){ 0 }, k->count) != k->count))
            return sp_import_fail(msg, msg_size, SP_ECORRUPT, "%s: %s%s must be an array of %zu numbers", path,
                                  prefix, k->key, k->count);
    }
    return 0;
}

int sp_import_meta_load(const char *path, sp_json **root, sp_capture_meta *meta, char *msg, size_t msg_size)
{
    char *text = NULL, err[160];
    size_t len = 0;
    int rc = read_text(path, &text, &len, msg, msg_size);
    if (rc)
        return rc;
    rc = sp_json_parse(text, len, root, err, sizeof(err));
    if (rc)
        rc = sp_import_fail(msg, msg_size, SP_ECORRUPT, "%s: %s", path, err);
    else if ((*root)->type != SP_JSON_OBJECT)
        rc = sp_import_fail(msg, msg_size, SP_ECORRUPT, "%s: must hold one JSON object", path);
    if (!rc)
        rc = check_keys(msg, msg_size, path, "", *root, top_keys);
    if (!rc)
        rc = check_keys(msg, msg_size, path, "camera.", sp_json_get(*root, "camera"), camera_keys);
    if (!rc)
        rc = check_keys(msg, msg_size, path, "imu.", sp_json_get(*root, "imu"), imu_keys);
    if (!rc)
        rc = check_keys(msg, msg_size, path, "location.", sp_json_get(*root, "location"), location_keys);
    /* ranges and the rest, exactly as readers will judge the chunk */
    if (!rc && sp_capture_meta_merge(meta, text, len) != 0)
        rc = sp_import_fail(msg, msg_size, SP_ECORRUPT,
                            "%s: a value is out of range or invalid for the META schema (capture/FORMAT.md)", path);
    free(text);
    return rc;
}

static void put_value(sp_strbuf *b, const sp_json *v);

static void put_member(sp_strbuf *b, int *first, const char *key)
{
    if (!*first)
        sp_strbuf_append(b, ",", 1);
    *first = 0;
    sp_strbuf_json_string(b, key);
    sp_strbuf_append(b, ":", 1);
}

static int in_list(const char *key, const char *const *list)
{
    for (; list && *list; list++)
        if (strcmp(key, *list) == 0)
            return 1;
    return 0;
}

static void put_members(sp_strbuf *b, const sp_json *obj, const char *const *skip, int *first)
{
    for (size_t i = 0; obj && obj->type == SP_JSON_OBJECT && i < obj->count; i++) {
        if (in_list(obj->keys[i], skip))
            continue;
        put_member(b, first, obj->keys[i]);
        put_value(b, &obj->items[i]);
    }
}

static void put_value(sp_strbuf *b, const sp_json *v)
{
    int first = 1;
    switch (v->type) {
    case SP_JSON_NULL:
        sp_strbuf_append(b, "null", 4);
        break;
    case SP_JSON_BOOL:
        sp_strbuf_printf(b, "%s", v->number != 0 ? "true" : "false");
        break;
    case SP_JSON_NUMBER:
        sp_strbuf_json_number(b, v->number);
        break;
    case SP_JSON_STRING:
        sp_strbuf_json_string(b, v->string);
        break;
    case SP_JSON_ARRAY:
        sp_strbuf_append(b, "[", 1);
        for (size_t i = 0; i < v->count; i++) {
            if (i)
                sp_strbuf_append(b, ",", 1);
            put_value(b, &v->items[i]);
        }
        sp_strbuf_append(b, "]", 1);
        break;
    case SP_JSON_OBJECT:
        sp_strbuf_append(b, "{", 1);
        put_members(b, v, NULL, &first);
        sp_strbuf_append(b, "}", 1);
        break;
    }
}

/* The JSON's imu object with to_camera replaced. */
static void put_imu(sp_strbuf *b, const sp_json *root, const double *q, int *first)
{
    static const char *const skip[] = { "to_camera", NULL };
    int imu_first = 1;
    put_member(b, first, "imu");
    sp_strbuf_append(b, "{", 1);
    put_members(b, sp_json_get(root, "imu"), skip, &imu_first);
    put_member(b, &imu_first, "to_camera");
    sp_strbuf_append(b, "[", 1);
    for (int i = 0; i < 4; i++) {
        if (i)
            sp_strbuf_append(b, ",", 1);
        sp_strbuf_json_number(b, q[i]);
    }
    sp_strbuf_append(b, "]}", 2);
}

/* The log's start time and place, where the user's metadata gives none. */
static void put_extra(sp_strbuf *b, const sp_json *root, const sp_import_meta_extra *x, int *first)
{
    if (x->utc_start && !sp_json_get(root, "utc_start")) {
        put_member(b, first, "utc_start");
        sp_strbuf_json_string(b, x->utc_start);
    }
    if (x->has_location && !sp_json_get(root, "location")) {
        put_member(b, first, "location");
        sp_strbuf_printf(b, "{\"latitude\":");
        sp_strbuf_json_number(b, x->location[0]);
        sp_strbuf_printf(b, ",\"longitude\":");
        sp_strbuf_json_number(b, x->location[1]);
        if (isfinite(x->location[2])) {
            sp_strbuf_printf(b, ",\"altitude_m\":");
            sp_strbuf_json_number(b, x->location[2]);
        }
        sp_strbuf_append(b, "}", 1);
    }
}

int sp_import_meta_build(const sp_json *root, const char *kind, const char *input, uint32_t w, uint32_t h,
                         double fps, const double *to_camera, const sp_import_meta_extra *extra, sp_strbuf *b)
{
    if (!kind)
        kind = sp_json_string(sp_json_get(root, "kind"), NULL);
    const char *source = sp_json_string(sp_json_get(root, "source"), NULL);
    static const char *const top_skip[] = { "kind", "source", "camera", NULL };
    static const char *const top_skip_imu[] = { "kind", "source", "camera", "imu", NULL };
    static const char *const cam_skip[] = { "width", "height", "fps", NULL };
    int first = 1, cam_first = 1;
    sp_strbuf_append(b, "{", 1);
    put_members(b, root, to_camera ? top_skip_imu : top_skip, &first);
    if (to_camera)
        put_imu(b, root, to_camera, &first);
    if (extra)
        put_extra(b, root, extra, &first);
    if (kind) {
        put_member(b, &first, "kind");
        sp_strbuf_json_string(b, kind);
    }
    put_member(b, &first, "source");
    if (source) {
        sp_strbuf_json_string(b, source);
    } else {
        sp_strbuf tmp = { 0 };
        sp_strbuf_printf(&tmp, "import:%s", input); /* FORMAT.md: the imported file name */
        sp_strbuf_json_string(b, tmp.failed ? "import" : tmp.data);
        sp_strbuf_free(&tmp);
    }
    put_member(b, &first, "camera");
    sp_strbuf_append(b, "{", 1);
    put_members(b, sp_json_get(root, "camera"), cam_skip, &cam_first);
    put_member(b, &cam_first, "width");
    sp_strbuf_printf(b, "%u", w);
    put_member(b, &cam_first, "height");
    sp_strbuf_printf(b, "%u", h);
    if (fps > 0) {
        put_member(b, &cam_first, "fps");
        sp_strbuf_json_number(b, fps);
    }
    sp_strbuf_append(b, "}}", 2);
    return b->failed ? -ENOMEM : 0;
}
