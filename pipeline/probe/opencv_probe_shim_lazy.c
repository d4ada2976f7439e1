/* SPDX-License-Identifier: MIT */
/* opencv_probe_shim.h's functions forwarded to the sunprobe-opencv-probe module, loaded on first use (common/module.h). */
#include "opencv_probe_shim.h"

#include <errno.h>

#include "common/module.h"

typedef int (*hog_open_fn)(sp_cv_hog **);
typedef int (*hog_score_fn)(sp_cv_hog *, const uint8_t *, uint32_t, uint32_t, uint32_t, int, int, int, int, double *);
typedef void (*hog_close_fn)(sp_cv_hog **);
typedef int (*hog_detect_fn)(sp_cv_hog *, const uint8_t *, uint32_t, uint32_t, uint32_t, double, int *, unsigned,
                             unsigned *);
typedef int (*grabcut_fn)(const uint8_t *, uint32_t, uint32_t, uint32_t, int, int, int, int, int, int, uint8_t *);
typedef int (*telea_fn)(uint8_t *, uint32_t, uint32_t, uint32_t, const uint8_t *, double);
typedef int (*mog2_open_fn)(sp_cv_mog2 **, int, double, int);
typedef int (*mog2_apply_fn)(sp_cv_mog2 *, const uint8_t *, uint32_t, uint32_t, uint32_t, uint8_t *, uint32_t);
typedef void (*mog2_close_fn)(sp_cv_mog2 **);
typedef void (*set_threads_fn)(int);

/* name's function from the module, looked up once (each forwarder has its slot, name##_slot) */
#define SYMBOL(type, name) ((type)sp_module_symbol_cached(&sp_module_opencv_probe, #name, &name##_slot))

static sp_module_slot sp_cv_hog_open_slot;
int sp_cv_hog_open(sp_cv_hog **out)
{
    hog_open_fn fn = SYMBOL(hog_open_fn, sp_cv_hog_open);
    return fn ? fn(out) : SP_EMODULE;
}

static sp_module_slot sp_cv_hog_score_slot;
int sp_cv_hog_score(sp_cv_hog *hog, const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, int x0,
                    int y0, int x1, int y1, double *score)
{
    hog_score_fn fn = SYMBOL(hog_score_fn, sp_cv_hog_score);
    return fn ? fn(hog, rgb, width, height, stride, x0, y0, x1, y1, score) : SP_EMODULE;
}

static sp_module_slot sp_cv_hog_close_slot;
void sp_cv_hog_close(sp_cv_hog **hog)
{
    hog_close_fn fn = hog && *hog ? SYMBOL(hog_close_fn, sp_cv_hog_close) : NULL; /* nothing open: no load */
    if (fn)
        fn(hog);
}

static sp_module_slot sp_cv_hog_detect_slot;
int sp_cv_hog_detect(sp_cv_hog *hog, const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride,
                     double upscale, int *boxes, unsigned cap, unsigned *n)
{
    hog_detect_fn fn = SYMBOL(hog_detect_fn, sp_cv_hog_detect);
    return fn ? fn(hog, rgb, width, height, stride, upscale, boxes, cap, n) : SP_EMODULE;
}

static sp_module_slot sp_cv_inpaint_telea_slot;
int sp_cv_inpaint_telea(uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, const uint8_t *mask,
                        double radius)
{
    telea_fn fn = SYMBOL(telea_fn, sp_cv_inpaint_telea);
    return fn ? fn(rgb, width, height, stride, mask, radius) : SP_EMODULE;
}

static sp_module_slot sp_cv_grabcut_box_slot;
int sp_cv_grabcut_box(const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, int x0, int y0, int x1,
                      int y1, int iterations, int min_height, uint8_t *mask)
{
    grabcut_fn fn = SYMBOL(grabcut_fn, sp_cv_grabcut_box);
    return fn ? fn(rgb, width, height, stride, x0, y0, x1, y1, iterations, min_height, mask) : SP_EMODULE;
}

static sp_module_slot sp_cv_mog2_open_slot;
int sp_cv_mog2_open(sp_cv_mog2 **out, int history, double var_threshold, int detect_shadows)
{
    mog2_open_fn fn = SYMBOL(mog2_open_fn, sp_cv_mog2_open);
    return fn ? fn(out, history, var_threshold, detect_shadows) : SP_EMODULE;
}

static sp_module_slot sp_cv_mog2_apply_slot;
int sp_cv_mog2_apply(sp_cv_mog2 *m, const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride,
                     uint8_t *mask, uint32_t mask_stride)
{
    mog2_apply_fn fn = SYMBOL(mog2_apply_fn, sp_cv_mog2_apply);
    return fn ? fn(m, rgb, width, height, stride, mask, mask_stride) : SP_EMODULE;
}

static sp_module_slot sp_cv_mog2_close_slot;
void sp_cv_mog2_close(sp_cv_mog2 **m)
{
    mog2_close_fn fn = m && *m ? SYMBOL(mog2_close_fn, sp_cv_mog2_close) : NULL;
    if (fn)
        fn(m);
}

static sp_module_slot sp_cv_set_threads_slot;
void sp_cv_set_threads(int n)
{
    set_threads_fn fn = SYMBOL(set_threads_fn, sp_cv_set_threads);
    if (fn)
        fn(n);
}
