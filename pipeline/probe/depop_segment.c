/* SPDX-License-Identifier: MIT */
/*
 * An object's own silhouette inside its box (DEPOPULATE.md, "Silhouettes"). A box from a user or a
 * detector holds background around the object; filling that background throws away pixels the image
 * had right. GrabCut (OpenCV) tells the object from the box's background by colour models learnt around
 * the box. Its answer is closed over holes (a person's inside is theirs) and over rows it left empty (a
 * standing object is one piece from head to foot), grown by a few pixels for edges it missed, and taken only
 * when it covers a twentieth to 95% of the box; otherwise the whole box goes.
 * The box's lowest fifth always goes whole: there the object meets the ground and its contact shadow.
 */
#include "depopulate.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/module.h"
#include "opencv_probe_shim.h"
#include "sp_config.h"

enum { GRABCUT_ITERATIONS = 4 };
/* boxes shorter than this are cut enlarged: on a 13 x 48 px walker GrabCut kept under a fifth of the box
 * (DEPOPULATE.md, "Silhouettes") */
enum { GRABCUT_MIN_HEIGHT = 150 };
/* the box's lowest fifth stays whole: dark legs on a dark road and the contact shadow fool the colour models */
#define LOWER_WHOLE 0.2

/* Background pixels of the box not 4-connected to its border through background become object. */
static int fill_holes(uint8_t *m, int w, int h)
{
    int32_t *queue = malloc((size_t)w * h * sizeof(int32_t));
    if (!queue)
        return -ENOMEM;
    size_t n = 0, head = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            if ((x == 0 || y == 0 || x == w - 1 || y == h - 1) && m[(size_t)y * w + x] == 0)
                m[(size_t)y * w + x] = 2, queue[n++] = y * w + x;
    while (head < n) {
        int32_t i = queue[head++];
        int x = i % w, y = i / w;
        const int nx[4] = { x - 1, x + 1, x, x }, ny[4] = { y, y, y - 1, y + 1 };
        for (int k = 0; k < 4; k++)
            if (nx[k] >= 0 && ny[k] >= 0 && nx[k] < w && ny[k] < h && m[(size_t)ny[k] * w + nx[k]] == 0)
                m[(size_t)ny[k] * w + nx[k]] = 2, queue[n++] = ny[k] * w + nx[k];
    }
    for (size_t i = 0; i < (size_t)w * h; i++)
        m[i] = m[i] != 2; /* reached from the border: background; the rest, holes included: object */
    free(queue);
    return 0;
}

/*
 * A standing object is one piece from head to foot: every row of its box holds some of it. A row the cut
 * left empty (dark trousers on dark paving between a torso and the legs, a head against dark windows) takes
 * the columns of the cut's nearest non-empty rows above and below it, both where both exist. lo and hi
 * are scratch of h ints each.
 */
static void close_rows(uint8_t *m, int w, int h, int *lo, int *hi)
{
    for (int y = 0; y < h; y++) {
        lo[y] = w, hi[y] = -1;
        for (int x = 0; x < w; x++)
            if (m[(size_t)y * w + x])
                lo[y] = x < lo[y] ? x : lo[y], hi[y] = x;
    }
    for (int y = 0; y < h; y++) {
        if (hi[y] >= 0)
            continue;
        int a = y, b = y;
        while (a >= 0 && hi[a] < 0)
            a--;
        while (b < h && hi[b] < 0)
            b++;
        int x0 = w, x1 = -1;
        if (a >= 0)
            x0 = lo[a], x1 = hi[a];
        if (b < h)
            x0 = lo[b] < x0 ? lo[b] : x0, x1 = hi[b] > x1 ? hi[b] : x1;
        for (int x = x0; x <= x1; x++)
            m[(size_t)y * w + x] = 1;
    }
}

/* Square dilation by r inside the box, separable (rows, then columns), into out. */
static void dilate(const uint8_t *m, uint8_t *tmp, uint8_t *out, int w, int h, int r)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            uint8_t v = 0;
            for (int u = x - r < 0 ? 0 : x - r; u <= x + r && u < w && !v; u++)
                v = m[(size_t)y * w + u];
            tmp[(size_t)y * w + x] = v;
        }
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            uint8_t v = 0;
            for (int t = y - r < 0 ? 0 : y - r; t <= y + r && t < h && !v; t++)
                v = tmp[(size_t)t * w + x];
            out[(size_t)y * w + x] = v;
        }
}

int sp_depop_segment(const uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, sp_depop_object *objs,
                     size_t n, uint8_t *masks, size_t *segmented)
{
    if (!rgb || !masks || (!objs && n) || !segmented || width == 0 || height == 0 || width > 32768 || height > 32768 ||
        stride < 3 * width)
        return -EINVAL;
    *segmented = 0;
    for (size_t i = 0; i < n; i++)
        if (objs[i].x0 < 0 || objs[i].y0 < 0 || objs[i].x1 < objs[i].x0 || objs[i].y1 < objs[i].y0 ||
            objs[i].x1 >= (int)width || objs[i].y1 >= (int)height)
            return -EINVAL;
    if (!HAVE_OPENCV)
        return SP_EMODULE; /* every box stays a box */
    size_t np = (size_t)width * height;
    uint8_t *cut = calloc(np, 1), *box = malloc(np), *tmp = malloc(np), *grown = malloc(np);
    int *spans = malloc(sizeof(int) * 2 * (size_t)height);
    int ret = cut && box && tmp && grown && spans ? 0 : -ENOMEM;
    memset(masks, 0, ret ? 0 : np);
    for (size_t i = 0; i < n && !ret; i++) {
        sp_depop_object *o = &objs[i];
        if (o->mask)
            continue; /* its own mask came with it */
        int bw = o->x1 - o->x0 + 1, bh = o->y1 - o->y0 + 1;
        size_t area = (size_t)bw * bh, fg = 0;
#if HAVE_OPENCV
        int rc = sp_cv_grabcut_box(rgb, width, height, stride, o->x0, o->y0, o->x1, o->y1, GRABCUT_ITERATIONS,
                                   GRABCUT_MIN_HEIGHT, cut);
#else
        int rc = SP_EMODULE;
#endif
        for (int y = 0; y < bh; y++)
            for (int x = 0; x < bw; x++) {
                uint8_t *c = &cut[(size_t)(o->y0 + y) * width + o->x0 + x];
                box[(size_t)y * bw + x] = rc == 0 && *c, *c = 0;
            }
        if (rc == SP_EMODULE || rc == -ENOMEM) {
            ret = rc;
            break;
        }
        if (rc == 0 && (ret = fill_holes(box, bw, bh)) == 0)
            for (size_t k = 0; k < area; k++)
                fg += box[k];
        /* GrabCut errs by missing parts, rarely by taking paving: a small answer still beats the whole box */
        int usable = rc == 0 && fg * 20 >= area && fg * 20 <= area * 19;
        if (usable) /* from the cut's own rows, before the lowest fifth goes whole */
            close_rows(box, bw, bh, spans, spans + bh);
        for (int y = bh - (int)lround(LOWER_WHOLE * bh); y < bh && usable; y++)
            memset(box + (size_t)y * bw, 1, (size_t)bw);
        int r = (int)lround(0.03 * bh);
        dilate(box, tmp, grown, bw, bh, r < 1 ? 1 : r);
        for (int y = 0; y < bh; y++)
            for (int x = 0; x < bw; x++)
                masks[(size_t)(o->y0 + y) * width + o->x0 + x] |= usable ? grown[(size_t)y * bw + x] : 1;
        o->mask = masks;
        *segmented += (size_t)usable;
    }
    for (size_t i = 0; i < n && ret; i++)
        if (objs[i].mask == masks)
            objs[i].mask = NULL; /* nothing half done: every box stays a box */
    free(cut), free(box), free(tmp), free(grown), free(spans);
    return ret;
}
