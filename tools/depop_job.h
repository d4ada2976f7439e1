/* SPDX-License-Identifier: MIT */
/*
 * The object finding and hole filling of `sunprobe depopulate`, shared with
 * `sunprobe repopulate` (which empties the street first with --private and
 * takes its scale and sun from the people it finds): the image, the objects
 * from --box, HOG or a probe's segmentation, their masks with shadows, and
 * the filled image.
 */
#ifndef SUNPROBE_TOOLS_DEPOP_JOB_H
#define SUNPROBE_TOOLS_DEPOP_JOB_H

#include <stddef.h>
#include <stdint.h>

#include "export/probe_dir.h"
#include "pipeline/probe/depopulate.h"

#define DEPOP_MAX_BOXES 64
#define DEPOP_MAX_OBJECTS 128
#define DEPOP_MAX_KEEP 64

/* What the command line says about the objects. */
typedef struct depop_input {
    const char *in, *probe;
    int boxes[DEPOP_MAX_BOXES][4]; /* x0, y0, x1, y1 */
    unsigned n_boxes;
    double keep[2 * DEPOP_MAX_KEEP];
    unsigned n_keep;
    int detector;    /* 0 none, 1 hog */
    int whole_boxes; /* --whole-boxes: remove boxes whole, no silhouettes */
    sp_depop_settings ds;
} depop_input;

typedef struct depop_job {
    const char *cmd; /* for messages: "depopulate", "repopulate" */
    uint8_t *rgb;    /* the input, RGB24 */
    uint32_t w, h;
    sp_depop_camera cam; /* in.ds.camera, else the assumed one: the masks', the sun's and the scale's */
    sp_probe_dir pd;
    int have_probe;
    uint8_t *mask, *result; /* 1 object, 2 shadow; the filled image */
    uint8_t *silhouettes;   /* the box objects' own masks (sp_depop_segment), or NULL */
    size_t segmented;       /* box objects cut to their silhouettes */
    sp_depop_object obj[DEPOP_MAX_OBJECTS];
    const char *origin[DEPOP_MAX_OBJECTS]; /* "box", "hog", "probe" */
    size_t n, kept, hog_found;
    const char *source, *fill;
    sp_inpaint_report ir;
} depop_job;

/* Sets the defaults (HOG where OpenCV is built). */
void depop_input_default(depop_input *in);
/*
 * --probe, --box, --keep, --detector, --whole-boxes, --sun-dir, --no-shadows (the long option's name without its dashes
 * in opt, its value in arg): 0 taken, 1 not one of these, else the exit code after a message.
 */
int depop_input_option(const char *cmd, const char *opt, const char *arg, depop_input *in);
/* Reads the input and the probe directory, finds the objects and their masks; 0 or the exit code. */
int depop_job_run(const char *cmd, const depop_input *in, depop_job *j);
/* Fills the masks into j->result (the plate with a probe, else exemplar inpainting); 0 or the exit code. */
int depop_job_fill(depop_job *j);
void depop_job_free(depop_job *j);
/* --camera F,CX,CY,PITCH into *cam: 0, or the usage exit code after a message. */
int depop_camera_option(const char *cmd, const char *arg, sp_depop_camera *cam);
/* Shaped like a standing person: 1.5 to 5 times as tall as wide (a car, a group or a pole is not). */
int depop_person_shaped(const sp_depop_object *o);
/* The camera assumed without --camera: 60 degrees wide, centred, 15 degrees down. */
sp_depop_camera depop_assumed_camera(uint32_t w, uint32_t h);
/* OUT without ".png" + suffix, malloc'd (NULL when out of memory). */
char *depop_derived_name(const char *out, const char *suffix);

#endif
