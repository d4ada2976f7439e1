/* SPDX-License-Identifier: MIT */
/* Finding the objects to remove and filling their holes (depop_job.h), for depopulate and repopulate. */
#include "depop_job.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd.h"
#include "common/module.h"
#include "export/png_read.h"
#include "pipeline/probe/opencv_probe_shim.h"
#include "sp_config.h"

void depop_input_default(depop_input *in)
{
    memset(in, 0, sizeof(*in));
    in->detector = HAVE_OPENCV ? 1 : 0;
    sp_depop_default_settings(&in->ds);
}

static int bad(const char *cmd, const char *opt, const char *v)
{
    fprintf(stderr, "sunprobe %s: bad %s: '%s'\n", cmd, opt, v);
    return SP_EXIT_USAGE;
}

int depop_input_option(const char *cmd, const char *opt, const char *arg, depop_input *a)
{
    double v[4];
    if (!strcmp(opt, "probe")) {
        a->probe = arg;
    } else if (!strcmp(opt, "box")) {
        if (a->n_boxes == DEPOP_MAX_BOXES || sp_opt_numbers(arg, v, 4) || v[2] < 1 || v[3] < 1 || v[0] < 0 ||
            v[1] < 0 || v[0] + v[2] > 1e5 || v[1] + v[3] > 1e5)
            return bad(cmd, "--box (X,Y,W,H, W and H at least 1, at most 64 boxes)", arg);
        int *b = a->boxes[a->n_boxes++];
        b[0] = (int)v[0], b[1] = (int)v[1], b[2] = (int)(v[0] + v[2]) - 1, b[3] = (int)(v[1] + v[3]) - 1;
    } else if (!strcmp(opt, "keep")) {
        if (a->n_keep == DEPOP_MAX_KEEP || sp_opt_numbers(arg, a->keep + 2 * a->n_keep, 2))
            return bad(cmd, "--keep (X,Y, at most 64)", arg);
        a->n_keep++;
    } else if (!strcmp(opt, "detector")) {
        static const char *const names[] = { "none", "hog" };
        return sp_opt_choice(cmd, "detector", arg, names, 2, &a->detector) ? SP_EXIT_USAGE : 0;
    } else if (!strcmp(opt, "sun-dir")) {
        if (sp_opt_numbers(arg, v, 2) || hypot(v[0], v[1]) < 1e-9)
            return bad(cmd, "--sun-dir (DX,DY, not both 0)", arg);
        a->ds.sun_dx = v[0], a->ds.sun_dy = v[1];
    } else if (!strcmp(opt, "whole-boxes")) {
        a->whole_boxes = 1;
    } else if (!strcmp(opt, "no-shadows")) {
        a->ds.shadows = 0;
    } else {
        return 1;
    }
    return 0;
}

int depop_camera_option(const char *cmd, const char *arg, sp_depop_camera *cam)
{
    double v[4];
    if (sp_opt_numbers(arg, v, 4) || !(v[0] > 0 && v[0] < 1e6) || !(v[3] >= 0 && v[3] < 89))
        return bad(cmd, "--camera (F,CX,CY,PITCH: F > 0, pitch 0..89 degrees)", arg);
    *cam = (sp_depop_camera){ v[0], v[1], v[2], v[3] };
    return 0;
}

int depop_person_shaped(const sp_depop_object *o)
{
    int w = o->x1 - o->x0 + 1, h = o->y1 - o->y0 + 1;
    return h >= 1.5 * w && h <= 5.0 * w;
}

sp_depop_camera depop_assumed_camera(uint32_t w, uint32_t h)
{
    return (sp_depop_camera){ 0.5 * w / tan(30 * M_PI / 180), 0.5 * w, 0.5 * h, 15 };
}

static int add_object(depop_job *j, int x0, int y0, int x1, int y1, const char *origin)
{
    if (j->n == DEPOP_MAX_OBJECTS)
        return 0; /* the report says how many were found */
    j->obj[j->n] = (sp_depop_object){ .x0 = x0, .y0 = y0, .x1 = x1, .y1 = y1 };
    j->origin[j->n++] = origin;
    return 1;
}

/* Whether box b is mostly inside an object already listed (a HOG hit on a user's box). */
static int covered(const depop_job *j, const int *b)
{
    for (size_t i = 0; i < j->n; i++) {
        const sp_depop_object *o = &j->obj[i];
        int w = (b[2] < o->x1 ? b[2] : o->x1) - (b[0] > o->x0 ? b[0] : o->x0) + 1;
        int h = (b[3] < o->y1 ? b[3] : o->y1) - (b[1] > o->y0 ? b[1] : o->y0) + 1;
        if (w > 0 && h > 0 && 2.0 * w * h > (double)(b[2] - b[0] + 1) * (b[3] - b[1] + 1))
            return 1;
    }
    return 0;
}

static int user_boxes(const depop_input *a, depop_job *j)
{
    for (unsigned i = 0; i < a->n_boxes; i++) {
        const int *b = a->boxes[i];
        if (b[2] >= (int)j->w || b[3] >= (int)j->h) {
            fprintf(stderr, "sunprobe %s: --box %d,%d,%d,%d reaches outside the %ux%u image %s\n", j->cmd, b[0], b[1],
                    b[2] - b[0] + 1, b[3] - b[1] + 1, j->w, j->h, a->in);
            return SP_EXIT_USAGE;
        }
        if (sp_depop_keeps(a->keep, a->n_keep, b[0], b[1], b[2], b[3]))
            j->kept++;
        else
            add_object(j, b[0], b[1], b[2], b[3], "box");
    }
    return 0;
}

static int hog_people(const depop_input *a, depop_job *j)
{
    int boxes[4 * DEPOP_MAX_OBJECTS];
    unsigned n = 0;
#if HAVE_OPENCV
    sp_cv_hog *hog = NULL;
    double up = j->h < 480 ? 2.0 : 1.0; /* people under the 128-px window */
    int ret = sp_cv_hog_open(&hog);
    if (!ret)
        ret = sp_cv_hog_detect(hog, j->rgb, j->w, j->h, j->w * 3, up, boxes, DEPOP_MAX_OBJECTS, &n);
    sp_cv_hog_close(&hog);
    if (ret)
        return sp_cmd_fail(j->cmd, ret, "HOG people detector");
#else
    (void)boxes;
    fprintf(stderr, "sunprobe %s: --detector hog needs OpenCV (-Dopencv=enabled); give --box and "
                    "--detector none\n", j->cmd);
    return SP_EXIT_DISABLED;
#endif
    j->hog_found = n;
    for (unsigned i = 0; i < n && i < DEPOP_MAX_OBJECTS; i++) {
        const int *b = boxes + 4 * i;
        if (sp_depop_keeps(a->keep, a->n_keep, b[0], b[1], b[2], b[3]))
            j->kept++;
        else if (!covered(j, b))
            add_object(j, b[0], b[1], b[2], b[3], "hog");
    }
    return 0;
}

static int from_plate(const depop_input *a, depop_job *j)
{
    size_t first = j->n, n = 0, kept = 0;
    int ret = sp_depop_from_plate(j->rgb, j->pd.clean_plate, j->w, j->h, &j->pd.plane, a->keep, a->n_keep,
                                  j->obj + first, DEPOP_MAX_OBJECTS - first, &n, &kept, j->mask);
    if (ret)
        return sp_cmd_fail(j->cmd, ret, "segmenting against the clean plate");
    for (size_t i = first; i < first + n && i < DEPOP_MAX_OBJECTS; i++)
        j->origin[i] = "probe";
    j->n = first + n < DEPOP_MAX_OBJECTS ? first + n : DEPOP_MAX_OBJECTS;
    j->kept += kept;
    for (size_t i = 0; i < first; i++) /* user boxes: the whole box, its shadow is in the plate's segmentation */
        for (int y = j->obj[i].y0; y <= j->obj[i].y1; y++)
            memset(j->mask + (size_t)y * j->w + j->obj[i].x0, 1, (size_t)(j->obj[i].x1 - j->obj[i].x0 + 1));
    j->source = a->n_boxes ? "the probe's segmentation against its clean plate, and --box"
                           : "the probe's segmentation against its clean plate";
    return 0;
}

static int find_objects(const depop_input *a, depop_job *j)
{
    int code = user_boxes(a, j);
    if (code)
        return code;
    if (j->have_probe)
        return from_plate(a, j);
    if (a->detector == 1 && (code = hog_people(a, j)))
        return code;
    j->source = a->detector == 1 ? (a->n_boxes ? "--box and the HOG people detector" : "the HOG people detector")
                                 : "--box";
    int ret = 0;
    if (!a->whole_boxes && j->n) {
        if (!(j->silhouettes = malloc((size_t)j->w * j->h)))
            return sp_cmd_fail(j->cmd, -ENOMEM, "silhouettes");
        ret = sp_depop_segment(j->rgb, j->w, j->h, j->w * 3, j->obj, j->n, j->silhouettes, &j->segmented);
        if (ret == SP_EMODULE) { /* no OpenCV here: the boxes go whole, and the report says so */
            fprintf(stderr, "sunprobe %s: no OpenCV GrabCut in this build; each box is removed whole\n", j->cmd);
            ret = 0;
        } else if (ret) {
            return sp_cmd_fail(j->cmd, ret, "silhouettes");
        }
    }
    sp_depop_settings ds = a->ds;
    ds.camera = &j->cam;
    ret = sp_depop_mask(j->rgb, j->w, j->h, j->w * 3, j->obj, j->n, &ds, j->mask);
    return ret ? sp_cmd_fail(j->cmd, ret, "removal masks") : 0;
}

static int load_probe(const depop_input *a, depop_job *j)
{
    int ret = sp_probe_dir_load(a->probe, &j->pd);
    if (ret)
        return sp_cmd_fail(j->cmd, ret, a->probe);
    j->have_probe = 1;
    if (j->pd.width != j->w || j->pd.height != j->h) {
        fprintf(stderr, "sunprobe %s: %s is %ux%u, the probe %s %ux%u\n", j->cmd, a->in, j->w, j->h, a->probe,
                j->pd.width, j->pd.height);
        return SP_EXIT_BAD_INPUT;
    }
    return 0;
}

int depop_job_run(const char *cmd, const depop_input *a, depop_job *j)
{
    memset(j, 0, sizeof(*j));
    j->cmd = cmd;
    int ret = sp_image_read_rgb8(a->in, &j->rgb, &j->w, &j->h);
    if (ret)
        return sp_cmd_fail(cmd, ret, a->in);
    j->cam = a->ds.camera ? *a->ds.camera : depop_assumed_camera(j->w, j->h);
    size_t np = (size_t)j->w * j->h;
    j->mask = calloc(np, 1), j->result = malloc(np * 3);
    if (!j->mask || !j->result)
        return sp_cmd_fail(cmd, -ENOMEM, "image buffers");
    int code = a->probe ? load_probe(a, j) : 0;
    return code ? code : find_objects(a, j);
}

int depop_job_fill(depop_job *j)
{
    size_t np = (size_t)j->w * j->h;
    memcpy(j->result, j->rgb, np * 3);
    if (j->have_probe) {
        for (size_t i = 0; i < np; i++)
            if (j->mask[i])
                memcpy(j->result + 3 * i, j->pd.clean_plate + 3 * i, 3);
        j->fill = "the probe's clean plate";
        return 0;
    }
    j->fill = "exemplar inpainting";
    int ret = sp_inpaint_exemplar(j->result, j->w, j->h, j->w * 3, j->mask, NULL, &j->ir);
    if (ret == SP_ENODATA)
        fprintf(stderr, "sunprobe %s: the objects cover the whole image: nothing is left to fill from\n", j->cmd);
    return ret ? sp_cmd_fail(j->cmd, ret, "inpainting") : 0;
}

void depop_job_free(depop_job *j)
{
    free(j->rgb), free(j->mask), free(j->result), free(j->silhouettes);
    if (j->have_probe)
        sp_probe_dir_free(&j->pd);
    memset(j, 0, sizeof(*j));
}

char *depop_derived_name(const char *out, const char *suffix)
{
    size_t n = strlen(out);
    if (n > 4 && !strcmp(out + n - 4, ".png"))
        n -= 4;
    char *p = malloc(n + strlen(suffix) + 1);
    if (p)
        memcpy(p, out, n), strcpy(p + n, suffix);
    return p;
}
