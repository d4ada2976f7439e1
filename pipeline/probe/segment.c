/* SPDX-License-Identifier: MIT */
/*
 * Per-frame segmentation against the clean plate. Each pixel is background,
 * object (refined mask M': colour differs from the plate by more than the
 * threshold) or shadow (darker than the plate by a bounded ratio with its
 * chromaticity kept). Changed pixels are counted on a coarse grid, closed
 * (dilate, erode) and labelled in 8-connected components; a component with
 * object pixels is an object, and its shadow pixels are its shadow, except
 * those inside the object's upper body, which are dark clothing and rejoin M'.
 * A body too short for its head row gets back legs that differ weakly from the plate.
 */
#include "probe_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#if defined(__SSE2__)
#include <emmintrin.h>
#elif defined(__aarch64__)
#include <arm_neon.h>
#endif

#define NOISE_LEVELS 2 /* sensor noise assumed by the shadow test, in 8-bit levels */
#define NOISY_LEVELS 1.5 /* measured noise from which a frame is grainy (classify) */

int segment_open(probe_segment *sg, uint32_t width, uint32_t height, const sp_probe_settings *s)
{
    memset(sg, 0, sizeof(*sg));
    sg->width = width;
    sg->height = height;
    sg->block = s->block;
    sg->gw = (width + s->block - 1) / s->block;
    sg->gh = (height + s->block - 1) / s->block;
    sg->fg_threshold = s->fg_threshold;
    sg->min_object_px = s->min_object_px;
    sg->shadow_lo = (int32_t)lround(s->shadow_min_ratio * 1024.0);
    sg->shadow_hi = (int32_t)lround(s->shadow_max_ratio * 1024.0);
    sg->chroma_tol = (int32_t)lround(s->shadow_chroma_tol * 1024.0);
    size_t cells = (size_t)sg->gw * sg->gh;
    sg->cls = malloc((size_t)width * height);
    sg->cell_obj = malloc(cells);
    sg->cell_sh = malloc(cells);
    sg->grid = malloc(cells);
    sg->tmp = malloc(cells);
    sg->morph_rows = malloc((size_t)sg->gw * 3);
    sg->lab_obj = malloc(cells * sizeof(int32_t));
    sg->parent = malloc((cells + 1) * sizeof(int32_t));
    sg->comp = malloc((cells + 1) * 5 * sizeof(int32_t));
    sg->objbox = malloc((cells + 1) * 5 * sizeof(int32_t));
    sg->order = malloc((cells + 1) * sizeof(int32_t));
    sg->row_span = malloc((size_t)height * sizeof(int32_t));
    sg->row_first = malloc((size_t)height * sizeof(int32_t));
    sg->col_first = malloc((size_t)width * sizeof(int32_t));
    sg->col_last = malloc((size_t)width * sizeof(int32_t));
    sg->denoised = malloc((size_t)width * height * 3);
    sg->colsum = malloc((size_t)width * 3 * sizeof(int32_t));
    if (!sg->cls || !sg->cell_obj || !sg->cell_sh || !sg->grid || !sg->tmp || !sg->morph_rows || !sg->lab_obj ||
        !sg->parent || !sg->comp || !sg->objbox || !sg->order || !sg->row_span || !sg->row_first || !sg->col_first ||
        !sg->col_last || !sg->denoised || !sg->colsum) {
        segment_close(sg);
        return -ENOMEM;
    }
    memset(sg->cls, PROBE_CLS_BG, (size_t)width * height);
    memset(sg->lab_obj, 0, cells * sizeof(int32_t));
    return 0;
}

void segment_close(probe_segment *sg)
{
    free(sg->cls);
    free(sg->cell_obj);
    free(sg->cell_sh);
    free(sg->grid);
    free(sg->tmp);
    free(sg->morph_rows);
    free(sg->lab_obj);
    free(sg->parent);
    free(sg->comp);
    free(sg->objbox);
    free(sg->order);
    free(sg->row_span);
    free(sg->row_first);
    free(sg->col_first);
    free(sg->col_last);
    free(sg->denoised);
    free(sg->colsum);
    memset(sg, 0, sizeof(*sg));
}

/*
 * One pixel against the plate: the refined-mask test, then the shadow test on what changed. p is the
 * frame's pixel, sp the same pixel of the denoised frame (NULL on clean footage, see classify). On
 * grainy footage a pixel has changed when both it and its 3x3 neighbourhood differ from the plate, one
 * by the threshold and the other by half of it: a lone noisy pixel is not an object, a quiet pixel
 * beside a changed body stays background (edges do not move), and a body pixel noise brought near the
 * plate's colour is object.
 */
static inline uint8_t classify_pixel(const probe_segment *sg, const uint8_t *p, const uint8_t *sp, const uint8_t *q)
{
    int32_t R = q[0], G = q[1], B = q[2], t = (int32_t)sg->fg_threshold;
    int32_t d = abs(p[0] - R) + abs(p[1] - G) + abs(p[2] - B);
    if (sp) {
        int32_t ds = abs(sp[0] - R) + abs(sp[1] - G) + abs(sp[2] - B);
        if (!((d > t && 2 * ds > t) || (ds > t && 2 * d > t)))
            return PROBE_CLS_BG;
    } else if (d <= t) {
        return PROBE_CLS_BG;
    }
    return probe_shadow_of(p, q, sg->shadow_lo, sg->shadow_hi, sg->chroma_tol, sg->noise_allow) ? PROBE_CLS_SHADOW
                                                                                                  : PROBE_CLS_OBJECT;
}

/*
 * Sensor noise of the frame against the plate, in 8-bit levels: 1.4826 x the median absolute green
 * difference over every 7th pixel (most pixels are background, so the median is the noise's).
 */
static double frame_noise(const probe_segment *sg, const uint8_t *rgb, const uint8_t *plate)
{
    unsigned hist[256] = { 0 }, n = 0;
    size_t px = (size_t)sg->width * sg->height;
    for (size_t i = 1; i < px; i += 7, n++)
        hist[abs(rgb[3 * i + 1] - plate[3 * i + 1])]++;
    unsigned acc = 0, k = 0;
    while (k < 255 && (acc += hist[k]) * 2 < n)
        k++;
    return 1.4826 * k;
}

/*
 * The frame as the plate plus the 3x3 mean of its difference to the plate: noise cut to a third,
 * while the plate's own edges stay sharp (a static edge's difference is noise only).
 */
static void denoise(probe_segment *sg, const uint8_t *rgb, const uint8_t *plate)
{
    uint32_t w = sg->width, h = sg->height;
    int32_t *col = sg->colsum; /* 3 * w: the vertical 3-sums of the difference on this row */
    for (uint32_t y = 0; y < h; y++) {
        size_t r0 = (size_t)(y ? y - 1 : 0) * w, r1 = (size_t)y * w, r2 = (size_t)(y + 1 < h ? y + 1 : y) * w;
        for (uint32_t i = 0; i < 3 * w; i++)
            col[i] = rgb[3 * r0 + i] - plate[3 * r0 + i] + rgb[3 * r1 + i] - plate[3 * r1 + i] + rgb[3 * r2 + i] -
                     plate[3 * r2 + i];
        uint8_t *out = sg->denoised + 3 * r1;
        const uint8_t *q = plate + 3 * r1;
        for (uint32_t x = 0; x < w; x++) {
            uint32_t xl = x ? x - 1 : 0, xr = x + 1 < w ? x + 1 : x;
            for (int c = 0; c < 3; c++) {
                int32_t sum = col[3 * xl + c] + col[3 * x + c] + col[3 * xr + c];
                int32_t v = q[3 * x + c] + (sum >= 0 ? (sum + 4) / 9 : -((-sum + 4) / 9));
                out[3 * x + c] = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
            }
        }
    }
}

#define CHUNK_PX 16 /* pixels per fast background test */

/* Every |a[i] - b[i]| <= lim over n bytes (n a multiple of 16 for the vector paths). */
static int bytes_near(const uint8_t *a, const uint8_t *b, size_t n, uint8_t lim)
{
    size_t i = 0;
#if defined(__SSE2__)
    __m128i l = _mm_set1_epi8((char)lim), m = _mm_setzero_si128();
    for (; i + 16 <= n; i += 16) {
        __m128i x = _mm_loadu_si128((const __m128i *)(a + i)), y = _mm_loadu_si128((const __m128i *)(b + i));
        m = _mm_max_epu8(m, _mm_or_si128(_mm_subs_epu8(x, y), _mm_subs_epu8(y, x)));
    }
    if (_mm_movemask_epi8(_mm_cmpeq_epi8(_mm_max_epu8(m, l), l)) != 0xFFFF)
        return 0;
#elif defined(__aarch64__)
    uint8x16_t m = vdupq_n_u8(0);
    for (; i + 16 <= n; i += 16)
        m = vmaxq_u8(m, vabdq_u8(vld1q_u8(a + i), vld1q_u8(b + i)));
    if (vmaxvq_u8(m) > lim)
        return 0;
#endif
    for (; i < n; i++)
        if ((a[i] > b[i] ? a[i] - b[i] : b[i] - a[i]) > lim)
            return 0;
    return 1;
}

#define SPECK_MARK 0x80
#define SPECK_SHARE_MIN 0.02 /* of a frame's object pixels (clean: under 0.01; JPEG quality 70: 0.04-0.09) */

/* Pixels of class `cls` among the 8 neighbours of pixel (x, y), marked specks counted as objects. */
static int class_neighbours(const probe_segment *sg, uint32_t x, uint32_t y, uint8_t cls)
{
    int n = 0;
    for (int dy = -1; dy <= 1; dy++)
        for (int dx = -1; dx <= 1; dx++) {
            int64_t xx = (int64_t)x + dx, yy = (int64_t)y + dy;
            if ((dx || dy) && xx >= 0 && yy >= 0 && xx < sg->width && yy < sg->height)
                n += (sg->cls[(size_t)yy * sg->width + (size_t)xx] & ~SPECK_MARK) == cls;
        }
    return n;
}

/* Pixel ranges of cell (gx, gy). */
static void cell_span(const probe_segment *sg, uint32_t gx, uint32_t gy, uint32_t *x0, uint32_t *x1, uint32_t *y0,
                      uint32_t *y1)
{
    *x0 = gx * sg->block, *y0 = gy * sg->block;
    *x1 = *x0 + sg->block < sg->width ? *x0 + sg->block : sg->width;
    *y1 = *y0 + sg->block < sg->height ? *y0 + sg->block : sg->height;
}

/* A marked speck becomes shadow beside shadow, else background; the counts follow. */
static void settle_speck(probe_segment *sg, uint32_t x, uint32_t y, uint64_t *fg, uint64_t *sh)
{
    int beside_shadow = class_neighbours(sg, x, y, PROBE_CLS_SHADOW) > 0;
    size_t cell = (size_t)(y / sg->block) * sg->gw + x / sg->block;
    sg->cell_obj[cell]--, (*fg)--;
    sg->cls[(size_t)y * sg->width + x] = beside_shadow ? PROBE_CLS_SHADOW : PROBE_CLS_BG;
    if (beside_shadow)
        sg->cell_sh[cell]++, (*sh)++;
}

/*
 * Object pixels with fewer than two object pixels among their 8 neighbours are specks, not parts of a
 * body (a leg 2 px wide leaves each of its pixels 5): a compressed frame's ringing around a figure and
 * its blocks inside a cast shadow. Only where they are SPECK_SHARE_MIN of the object pixels or more:
 * a clean frame's few lone pixels are the ends of thin limbs (taking them cost synth street seed 4 0.07
 * of its recall). Visits the cells that hold object pixels only.
 */
static void drop_specks(probe_segment *sg, uint64_t *fg, uint64_t *sh)
{
    size_t specks = 0, objects = 0;
    int drop = 0;
    for (int pass = 0; pass < 2 && (pass == 0 || specks); pass++) { /* no specks marked: nothing to undo */
        if (pass == 1)
            drop = specks >= SPECK_SHARE_MIN * (double)objects;
        for (uint32_t gy = 0; gy < sg->gh; gy++)
            for (uint32_t gx = 0; gx < sg->gw; gx++) {
                if (!sg->cell_obj[(size_t)gy * sg->gw + gx])
                    continue;
                uint32_t x0, x1, y0, y1;
                cell_span(sg, gx, gy, &x0, &x1, &y0, &y1);
                for (uint32_t y = y0; y < y1; y++)
                    for (uint32_t x = x0; x < x1; x++) {
                        uint8_t *c = sg->cls + (size_t)y * sg->width + x;
                        if (pass == 0 && *c == PROBE_CLS_OBJECT) {
                            objects++;
                            if (class_neighbours(sg, x, y, PROBE_CLS_OBJECT) < 2)
                                *c |= SPECK_MARK, specks++;
                        } else if (pass == 1 && (*c & SPECK_MARK)) {
                            if (drop)
                                settle_speck(sg, x, y, fg, sh);
                            else
                                *c &= (uint8_t)~SPECK_MARK;
                        }
                    }
            }
    }
}

static void classify(probe_segment *sg, const uint8_t *rgb, const uint8_t *plate)
{
    /* clean footage (a renderer's, a good sensor in daylight) is classified as it is: denoising would only
     * blur thin legs and poles; grainy footage on its denoised copy */
    sg->noise = frame_noise(sg, rgb, plate);
    int grainy = sg->noise >= NOISY_LEVELS;
    /* the shadow tests read the pixel itself (its denoised copy lost the street's recall) with room for
     * 1.5 sigma of the measured noise */
    sg->noise_allow = grainy && 1.5 * sg->noise > NOISE_LEVELS ? (int32_t)lrint(1.5 * sg->noise) : NOISE_LEVELS;
    if (grainy)
        denoise(sg, rgb, plate);
    size_t cells = (size_t)sg->gw * sg->gh;
    memset(sg->cell_obj, 0, cells);
    memset(sg->cell_sh, 0, cells);
    uint64_t fg = 0, sh = 0;
    /* every channel within t/3 of the plate: |dR|+|dG|+|dB| <= t for the pixel and its denoised copy */
    uint8_t near = (uint8_t)(sg->fg_threshold / 3 > 255 ? 255 : sg->fg_threshold / 3);
    for (uint32_t y = 0; y < sg->height; y++) {
        size_t row = (size_t)y * sg->width;
        int changed = 0;
        for (uint32_t x = 0; x < sg->width;) {
            size_t i = row + x;
            if (x + CHUNK_PX <= sg->width && bytes_near(rgb + 3 * i, plate + 3 * i, 3 * CHUNK_PX, near) &&
                (!grainy || bytes_near(sg->denoised + 3 * i, plate + 3 * i, 3 * CHUNK_PX, near))) {
                memset(sg->cls + i, PROBE_CLS_BG, CHUNK_PX); /* background for certain: the common case */
                x += CHUNK_PX;
                continue;
            }
            uint8_t c = classify_pixel(sg, rgb + 3 * i, grainy ? sg->denoised + 3 * i : NULL, plate + 3 * i);
            sg->cls[i] = c;
            changed |= c != PROBE_CLS_BG;
            x++;
        }
        if (!changed)
            continue;
        uint8_t *co = sg->cell_obj + (size_t)(y / sg->block) * sg->gw;
        uint8_t *cs = sg->cell_sh + (size_t)(y / sg->block) * sg->gw;
        for (uint32_t gx = 0, x = 0; gx < sg->gw; gx++) {
            uint32_t xe = x + sg->block < sg->width ? x + sg->block : sg->width;
            unsigned no = 0, ns = 0;
            for (; x < xe; x++) {
                no += sg->cls[row + x] == PROBE_CLS_OBJECT;
                ns += sg->cls[row + x] == PROBE_CLS_SHADOW;
            }
            co[gx] = (uint8_t)(co[gx] + no); /* block <= 15: at most 225 per cell */
            cs[gx] = (uint8_t)(cs[gx] + ns);
            fg += no;
            sh += ns;
        }
    }
    if (!grainy) /* grainy frames are classified on their denoised copy, and their shadows judged whole */
        drop_specks(sg, &fg, &sh);
    sg->fg_pixels = fg;
    sg->shadow_pixels = sh;
}

/* One row of three 0/1 rows combined: OR (grow) or AND; separate loops so each vectorises. */
static void morph_combine(uint8_t *out, const uint8_t *a, const uint8_t *b, const uint8_t *c, uint32_t n, int grow)
{
    if (grow)
        for (uint32_t x = 0; x < n; x++)
            out[x] = (uint8_t)(a[x] | b[x] | c[x]);
    else
        for (uint32_t x = 0; x < n; x++)
            out[x] = (uint8_t)(a[x] & b[x] & c[x]);
}

/*
 * 3x3 dilation (grow = 1) or erosion (grow = 0) of a 0/1 grid, as a row pass then a column pass
 * (the square is separable); outside the grid counts as "off" for dilation and "on" for erosion.
 * rows: 3 * gw bytes of scratch.
 */
static void morph(const uint8_t *in, uint8_t *out, uint8_t *rows, uint32_t gw, uint32_t gh, int grow)
{
    uint8_t edge = (uint8_t)!grow, *prev = rows, *cur = rows + gw, *pad = rows + 2 * (size_t)gw;
    memset(pad, edge, gw);
    for (uint32_t y = 0; y < gh; y++) {
        const uint8_t *r = in + (size_t)y * gw;
        uint8_t *o = out + (size_t)y * gw;
        if (gw == 1) {
            o[0] = r[0];
            continue;
        }
        morph_combine(o + 1, r, r + 1, r + 2, gw - 2, grow);
        o[0] = (uint8_t)(grow ? r[0] | r[1] : r[0] & r[1]);
        o[gw - 1] = (uint8_t)(grow ? r[gw - 2] | r[gw - 1] : r[gw - 2] & r[gw - 1]);
    }
    memset(prev, edge, gw);
    for (uint32_t y = 0; y < gh; y++) {
        uint8_t *o = out + (size_t)y * gw, *t;
        memcpy(cur, o, gw);
        morph_combine(o, prev, cur, y + 1 < gh ? o + gw : pad, gw, grow);
        t = prev, prev = cur, cur = t;
    }
}

static int32_t uf_find(int32_t *parent, int32_t a)
{
    while (parent[a] != a) {
        parent[a] = parent[parent[a]];
        a = parent[a];
    }
    return a;
}

static void uf_union(int32_t *parent, int32_t a, int32_t b)
{
    a = uf_find(parent, a);
    b = uf_find(parent, b);
    if (a != b)
        parent[a > b ? a : b] = a < b ? a : b;
}

/* Two-pass 8-connected labelling of grid into lab; returns the number of labels (1..n). */
static int32_t label_components(probe_segment *sg, const uint8_t *grid)
{
    uint32_t gw = sg->gw, gh = sg->gh;
    int32_t next = 1;
    sg->parent[0] = 0;
    for (uint32_t y = 0; y < gh; y++)
        for (uint32_t x = 0; x < gw; x++) {
            size_t i = (size_t)y * gw + x;
            sg->lab_obj[i] = 0;
            if (!grid[i])
                continue;
            int32_t nb[4] = { x > 0 ? sg->lab_obj[i - 1] : 0, y > 0 && x > 0 ? sg->lab_obj[i - gw - 1] : 0,
                              y > 0 ? sg->lab_obj[i - gw] : 0, y > 0 && x + 1 < gw ? sg->lab_obj[i - gw + 1] : 0 };
            int32_t l = 0;
            for (int k = 0; k < 4; k++)
                if (nb[k] && (!l || nb[k] < l))
                    l = nb[k];
            if (!l) {
                l = next++;
                sg->parent[l] = l;
            }
            for (int k = 0; k < 4; k++)
                if (nb[k])
                    uf_union(sg->parent, l, nb[k]);
            sg->lab_obj[i] = l;
        }
    /* flatten to consecutive labels */
    int32_t n = 0;
    for (int32_t l = 1; l < next; l++)
        sg->order[l] = sg->parent[l] == l ? ++n : 0;
    for (size_t i = 0; i < (size_t)gw * gh; i++)
        if (sg->lab_obj[i])
            sg->lab_obj[i] = sg->order[uf_find(sg->parent, sg->lab_obj[i])];
    return n;
}

/*
 * Cell bounding box and cell count per component: box[5 l + 0..4] = x0, y0,
 * x1, y1, cells; over all its cells, or (objects_only) over the cells that
 * hold object pixels.
 */
static void component_boxes(probe_segment *sg, int32_t n, int32_t *box, int objects_only)
{
    for (int32_t l = 1; l <= n; l++) {
        int32_t *c = box + 5 * l;
        c[0] = INT32_MAX, c[1] = INT32_MAX, c[2] = -1, c[3] = -1, c[4] = 0;
    }
    for (uint32_t y = 0; y < sg->gh; y++)
        for (uint32_t x = 0; x < sg->gw; x++) {
            size_t i = (size_t)y * sg->gw + x;
            int32_t l = sg->lab_obj[i];
            if (!l || (objects_only && !sg->cell_obj[i]))
                continue;
            int32_t *c = box + 5 * l;
            c[0] = (int32_t)x < c[0] ? (int32_t)x : c[0];
            c[1] = (int32_t)y < c[1] ? (int32_t)y : c[1];
            c[2] = (int32_t)x > c[2] ? (int32_t)x : c[2];
            c[3] = (int32_t)y > c[3] ? (int32_t)y : c[3];
            c[4]++;
        }
}

static int32_t max_i32(int32_t a, int32_t b) { return a > b ? a : b; }
static int32_t min_i32(int32_t a, int32_t b) { return a < b ? a : b; }

/*
 * Two components that look like the parts of one person an occluder cut
 * apart (cell boxes of their object cells): side by side with the same top and
 * bottom (a pole or pillar in front), or one above the other (a sign across the
 * body) when the scale model says the lower part alone is too short for a
 * person standing there and the two together are about right.
 */
static int parts_of_one(const probe_segment *sg, const int32_t *a, const int32_t *b, const sp_probe_plane *plane)
{
    int32_t wa = a[2] - a[0] + 1, wb = b[2] - b[0] + 1, ha = a[3] - a[1] + 1, hb = b[3] - b[1] + 1;
    int32_t ovx = min_i32(a[2], b[2]) - max_i32(a[0], b[0]) + 1, ovy = min_i32(a[3], b[3]) - max_i32(a[1], b[1]) + 1;
    int32_t h = max_i32(a[3], b[3]) - min_i32(a[1], b[1]) + 1, w = max_i32(a[2], b[2]) - min_i32(a[0], b[0]) + 1;
    if (5 * ovy >= 3 * min_i32(ha, hb) && ovx <= 0) { /* side by side */
        int32_t gap = -ovx, tall = max_i32(ha, hb);
        return 2 * gap <= tall && 4 * abs(a[3] - b[3]) <= tall + 4 && 4 * abs(a[1] - b[1]) <= tall + 4 && 5 * w <= 4 * h;
    }
    if (2 * ovx < min_i32(wa, wb) || ovy > 0 || !plane || plane->status != SP_PROBE_PLANE_OK)
        return 0;
    const int32_t *low = a[3] > b[3] ? a : b;
    double bs = sg->block, foot = (low[3] + 1) * bs - 1, x = 0.5 * (low[0] + low[2] + 1) * bs;
    double expect = sp_probe_plane_height(plane, x, foot), own = (low[3] - low[1] + 1) * bs, both = h * bs;
    return isfinite(expect) && own < 0.8 * expect && fabs(both - expect) <= 0.25 * expect;
}

/* Joins the parts of occluded people (union-find over labels), then renumbers the cells. */
static void merge_parts(probe_segment *sg, int32_t n, const sp_probe_plane *plane)
{
    component_boxes(sg, n, sg->objbox, 1);
    for (int32_t l = 0; l <= n; l++)
        sg->parent[l] = l;
    for (int32_t a = 1; a <= n; a++) {
        const int32_t *ba = sg->objbox + 5 * a;
        if (ba[4] < 2)
            continue;
        for (int32_t b = a + 1; b <= n; b++) {
            const int32_t *bb = sg->objbox + 5 * b;
            if (bb[4] >= 2 && parts_of_one(sg, ba, bb, plane))
                uf_union(sg->parent, a, b);
        }
    }
    for (size_t i = 0; i < (size_t)sg->gw * sg->gh; i++)
        if (sg->lab_obj[i])
            sg->lab_obj[i] = uf_find(sg->parent, sg->lab_obj[i]);
}

typedef struct rect {
    uint32_t x0, y0, x1, y1; /* pixels, half-open */
} rect;

static rect component_rect(const probe_segment *sg, int32_t label)
{
    const int32_t *c = sg->comp + 5 * label;
    rect r = { (uint32_t)c[0] * sg->block, (uint32_t)c[1] * sg->block, (uint32_t)(c[2] + 1) * sg->block,
               (uint32_t)(c[3] + 1) * sg->block };
    r.x1 = r.x1 < sg->width ? r.x1 : sg->width;
    r.y1 = r.y1 < sg->height ? r.y1 : sg->height;
    return r;
}

static inline int in_component(const probe_segment *sg, int32_t label, uint32_t x, uint32_t y)
{
    return sg->lab_obj[(y / sg->block) * sg->gw + x / sg->block] == label;
}

/*
 * Rows holding object pixels of the component, and their x range. The top is
 * the first row with at least 2 pixels; the foot is the last row of the last
 * run of at least 3 such rows, so stray object pixels inside a shadow below
 * the feet do not lower it, while a gap (an occluder across the body) may.
 */
static int object_extent(probe_segment *sg, int32_t label, rect r, int *top, int *foot, int *xa, int *xb)
{
    *top = *foot = *xa = *xb = -1;
    int run = 0;
    for (uint32_t y = r.y0; y < r.y1; y++) {
        int32_t n = 0;
        const uint8_t *c = sg->cls + (size_t)y * sg->width;
        for (uint32_t x = r.x0; x < r.x1; x++)
            if (c[x] == PROBE_CLS_OBJECT && in_component(sg, label, x, y)) {
                n++;
                *xa = *xa < 0 || (int)x < *xa ? (int)x : *xa;
                *xb = (int)x > *xb ? (int)x : *xb;
            }
        run = n >= 2 ? run + 1 : 0;
        if (n >= 2 && *top < 0)
            *top = (int)y;
        if (run >= 3)
            *foot = (int)y;
    }
    return *top >= 0 && *foot > *top;
}

/*
 * A cast shadow the pixel test missed: on grainy footage (only there: on clean footage the trim took
 * light trousers in the wall's shadow off synth street seed 4, recall 0.923 -> 0.885) a shadow pixel's
 * chromaticity often leaves the test's bounds, and a walker with a long shadow beside the feet becomes a box too wide for a person
 * (on the path-traced street, 71 of the ~190 views of people partly hidden by an occluder). The
 * component's changed pixels beside a narrow upper body (head and torso, at most half the height wide)
 * and below it are judged on each side together: their mean colour against the plate's mean averages
 * the grain away. A side whose mean is a shadow of the ground has its pixels darker than the plate
 * reclassified as shadow. Legs striding out stay within the margin of 0.15 of the height.
 */
static void trim_cast_shadow(probe_segment *sg, const uint8_t *rgb, const uint8_t *plate, int32_t label, rect r,
                             int top, int foot)
{
    int h = foot - top + 1, torso_end = top + h / 2, ua = INT32_MAX, ub = -1;
    for (int y = top; y <= torso_end; y++) {
        const uint8_t *c = sg->cls + (size_t)y * sg->width;
        for (uint32_t x = r.x0; x < r.x1; x++)
            if (c[x] == PROBE_CLS_OBJECT && in_component(sg, label, x, (uint32_t)y))
                ua = min_i32(ua, (int32_t)x), ub = max_i32(ub, (int32_t)x);
    }
    if (ub < 0 || 2 * (ub - ua + 1) > h)
        return; /* no narrow upright body above: a car, a group */
    int margin = (int)ceil(0.15 * h);
    for (int side = 0; side < 2; side++) {
        int x0 = side ? ub + margin + 1 : (int)r.x0, x1 = side ? (int)r.x1 : ua - margin; /* [x0, x1) */
        int64_t sum_p[3] = { 0 }, sum_q[3] = { 0 }, n = 0;
        for (int y = torso_end + 1; y < (int)r.y1; y++)
            for (int x = x0 < 0 ? 0 : x0; x < x1; x++) {
                size_t i = (size_t)y * sg->width + (size_t)x;
                if (sg->cls[i] == PROBE_CLS_BG || !in_component(sg, label, (uint32_t)x, (uint32_t)y))
                    continue;
                for (int c = 0; c < 3; c++)
                    sum_p[c] += rgb[3 * i + c], sum_q[c] += plate[3 * i + c];
                n++;
            }
        if (n < h / 2)
            continue; /* too few pixels to average the grain away */
        uint8_t mp[3], mq[3];
        for (int c = 0; c < 3; c++)
            mp[c] = (uint8_t)((sum_p[c] + n / 2) / n), mq[c] = (uint8_t)((sum_q[c] + n / 2) / n);
        if (!probe_shadow_of(mp, mq, sg->shadow_lo, sg->shadow_hi, sg->chroma_tol, NOISE_LEVELS))
            continue;
        for (int y = torso_end + 1; y < (int)r.y1; y++)
            for (int x = x0 < 0 ? 0 : x0; x < x1; x++) {
                size_t i = (size_t)y * sg->width + (size_t)x;
                const uint8_t *p = rgb + 3 * i, *q = plate + 3 * i;
                if (sg->cls[i] != PROBE_CLS_SHADOW && in_component(sg, label, (uint32_t)x, (uint32_t)y) &&
                    p[0] + p[1] + p[2] < q[0] + q[1] + q[2])
                    sg->cls[i] = PROBE_CLS_SHADOW;
            }
    }
}

/*
 * Shadow-classified pixels inside the body's box (its x range, top to foot)
 * are dark clothing or the shadow right under the feet: back into M'. A cast
 * shadow is what lies outside; one falling straight away from the camera hides
 * behind the body and is not learned (PROBE.md).
 */
static void reclaim_clothing(probe_segment *sg, int32_t label, int top, int foot, int xa, int xb)
{
    for (int y = top; y <= foot; y++) {
        uint8_t *c = sg->cls + (size_t)y * sg->width;
        for (int x = xa; x <= xb; x++)
            if (c[x] == PROBE_CLS_SHADOW && in_component(sg, label, (uint32_t)x, (uint32_t)y))
                c[x] = PROBE_CLS_OBJECT;
    }
}

/*
 * Where a person stands: the foot row whose plane height reaches up to the
 * head row (h(x, foot) = foot - top + 1, solved by fixed-point iteration; the
 * plane's slope in y is small). NaN without a usable model.
 */
static double predicted_foot(const sp_probe_plane *plane, double x, int top, int foot)
{
    if (!plane || plane->status != SP_PROBE_PLANE_OK)
        return (double)NAN;
    double y = foot;
    for (int k = 0; k < 6 && isfinite(y); k++)
        y = top - 1 + sp_probe_plane_height(plane, x, y);
    return isfinite(y) && y > top ? y : (double)NAN;
}

/* Background-classified pixels that still differ from the plate: more than a third of the threshold. */
static inline int weak_change(const probe_segment *sg, const uint8_t *p, const uint8_t *q)
{
    int32_t d = abs(p[0] - q[0]) + abs(p[1] - q[1]) + abs(p[2] - q[2]);
    return 3 * d > (int32_t)sg->fg_threshold;
}

/*
 * Legs whose colour is close to the plate's (light trousers on a pale road)
 * fall under the threshold and the foot row comes out too high, which puts
 * every occlusion event of the body at a wrong depth. When the scale model
 * says the body is too short for its head row (under 0.88 of it), the rows
 * below the foot, down to the predicted foot + 8%, where at least a fifth of
 * the body's width still differs weakly from the plate (or is its M'), are its
 * legs (two misses end them): those pixels join M', their free cells the
 * component, and the foot moves to the last such row. Measured, not predicted:
 * without weak change below (legs behind something, or matching the plate
 * exactly) the foot stays; PROBE.md says why trusting the prediction was dropped.
 */
static void extend_legs(probe_segment *sg, const uint8_t *rgb, const uint8_t *plate, const sp_probe_plane *plane,
                        int32_t label, int top, int *foot, int xa, int xb)
{
    double pred = predicted_foot(plane, 0.5 * (xa + xb), top, *foot);
    double expect = pred - top + 1;
    if (!isfinite(pred) || *foot - top + 1 >= 0.88 * expect)
        return;
    int last = (int)fmin(pred + 0.08 * expect, (double)sg->height - 1), width = xb - xa + 1, found = *foot, miss = 0;
    int need = width / 5 > 2 ? width / 5 : 2;
    for (int y = *foot + 1; y <= last && miss < 2; y++) {
        const uint8_t *c = sg->cls + (size_t)y * sg->width;
        int n = 0;
        for (int x = xa; x <= xb; x++) {
            size_t i = (size_t)y * sg->width + (size_t)x;
            int32_t l = sg->lab_obj[(y / (int)sg->block) * sg->gw + x / (int)sg->block];
            n += (c[x] == PROBE_CLS_OBJECT && l == label) ||
                 (c[x] == PROBE_CLS_BG && (l == 0 || l == label) && weak_change(sg, rgb + 3 * i, plate + 3 * i));
        }
        miss = n >= need ? 0 : miss + 1;
        found = n >= need ? y : found;
    }
    for (int y = *foot + 1; y <= found; y++)
        for (int x = xa; x <= xb; x++) {
            size_t i = (size_t)y * sg->width + (size_t)x;
            size_t cell = (size_t)(y / (int)sg->block) * sg->gw + (size_t)x / sg->block;
            if (sg->cls[i] != PROBE_CLS_BG || (sg->lab_obj[cell] && sg->lab_obj[cell] != label) ||
                !weak_change(sg, rgb + 3 * i, plate + 3 * i))
                continue;
            sg->cls[i] = PROBE_CLS_OBJECT;
            sg->lab_obj[cell] = label;
            int32_t *b = sg->comp + 5 * label, cx = (int32_t)(x / (int)sg->block), cy = y / (int)sg->block;
            b[0] = min_i32(b[0], cx), b[2] = max_i32(b[2], cx), b[3] = max_i32(b[3], cy);
        }
    *foot = found;
}

/*
 * Column x of the plate has a horizontal edge within 3 rows of `row`: the plate changes across two rows by
 * `level` (|dR|+|dG|+|dB|), and the darker side fails the shadow test against the brighter one (a shadow's
 * edge on the ground is no occluder's), unless people here cast no hard shadows (no_cast_shadows).
 */
int segment_plate_edge_at(const probe_segment *sg, const uint8_t *plate, int row, int x, int level)
{
    int best = 0, y0 = row - 3 < 1 ? 1 : row - 3, y1 = row + 3 < (int)sg->height - 2 ? row + 3 : (int)sg->height - 2;
    for (int y = y0; y <= y1; y++) {
        const uint8_t *a = plate + ((size_t)(y - 1) * sg->width + (size_t)x) * 3;
        const uint8_t *b = plate + ((size_t)(y + 1) * sg->width + (size_t)x) * 3;
        int g = abs(a[0] - b[0]) + abs(a[1] - b[1]) + abs(a[2] - b[2]);
        int dark_a = a[0] + a[1] + a[2] < b[0] + b[1] + b[2];
        if (g > best &&
            (sg->no_cast_shadows || classify_pixel(sg, dark_a ? a : b, NULL, dark_a ? b : a) != PROBE_CLS_SHADOW))
            best = g;
    }
    return best >= level;
}

/*
 * Row `row` of the body (its top or foot) lies on a horizontal edge of the plate, half the object threshold
 * strong, across 3/5 of the columns xa..xb. There the body meets something static in front of it: a sign's
 * lower edge, a planter.
 */
static int on_plate_edge(const probe_segment *sg, const uint8_t *plate, int row, int xa, int xb)
{
    int edge = 0;
    for (int x = xa; x <= xb; x++)
        edge += segment_plate_edge_at(sg, plate, row, x, ((int)sg->fg_threshold + 1) / 2);
    return 5 * edge >= 3 * (xb - xa + 1);
}

/*
 * A body still too short for its head row (under 0.75 of it, legs found or not) whose foot lies on an
 * edge of the plate stands behind that edge: the top of a planter, a bench, a low wall. Its lower body
 * is hidden, and its foot is where the scale model puts it; legs lost on open ground end on no edge.
 * NaN when not so.
 */
static double cut_foot(const probe_segment *sg, const uint8_t *plate, const sp_probe_plane *plane, int top, int foot,
                       int xa, int xb)
{
    double pred = predicted_foot(plane, 0.5 * (xa + xb), top, foot);
    if (!isfinite(pred) || foot - top + 1 >= 0.75 * (pred - top + 1) || pred > (double)sg->height - 1)
        return (double)NAN;
    return on_plate_edge(sg, plate, foot, xa, xb) ? pred : (double)NAN;
}

typedef struct sums {
    double n, x, rgb[3], t, foot_n, foot_x;
    double sh_n, sh_x, sh_y, sh_ratio;
    int x0, x1;
} sums;

static void accumulate(const probe_segment *sg, const uint8_t *rgb, const uint8_t *plate, int32_t label, rect r,
                       int top, int foot, sums *s)
{
    double h = foot - top + 1;
    int foot_rows = (int)ceil(0.1 * h);
    memset(s, 0, sizeof(*s));
    s->x0 = INT32_MAX, s->x1 = -1;
    for (uint32_t y = r.y0; y < r.y1; y++) {
        const uint8_t *c = sg->cls + (size_t)y * sg->width;
        for (uint32_t x = r.x0; x < r.x1; x++) {
            if (c[x] == PROBE_CLS_BG || !in_component(sg, label, x, y))
                continue;
            const uint8_t *p = rgb + ((size_t)y * sg->width + x) * 3;
            if (c[x] == PROBE_CLS_SHADOW) {
                const uint8_t *q = plate + ((size_t)y * sg->width + x) * 3;
                int lit = q[0] + q[1] + q[2];
                s->sh_n++, s->sh_x += x, s->sh_y += y;
                s->sh_ratio += lit > 0 ? (double)(p[0] + p[1] + p[2]) / lit : 1.0;
                continue;
            }
            s->n++, s->x += x;
            s->rgb[0] += p[0], s->rgb[1] += p[1], s->rgb[2] += p[2];
            s->t += (foot - (double)y) / h;
            s->x0 = (int)x < s->x0 ? (int)x : s->x0;
            s->x1 = (int)x > s->x1 ? (int)x : s->x1;
            if ((int)y > foot - foot_rows && (int)y <= foot)
                s->foot_n++, s->foot_x += x;
        }
    }
}

static int touches(const probe_segment *sg, int x0, int y0, int x1, int y1)
{
    return (y0 <= 1 ? PROBE_TOUCH_TOP : 0) | (y1 >= (int)sg->height - 2 ? PROBE_TOUCH_BOTTOM : 0) |
           (x0 <= 1 ? PROBE_TOUCH_LEFT : 0) | (x1 >= (int)sg->width - 2 ? PROBE_TOUCH_RIGHT : 0);
}

/* Upright and compact like one walking person: a group or a car is too wide, a pole too thin. */
static int person_shaped(const probe_object *o)
{
    double w = o->x1 - o->x0 + 1, aspect = o->height / w, fill = o->area / (w * o->height);
    return !o->touches && o->height >= 16 && aspect >= 1.4 && aspect <= 5.5 && fill >= 0.25 && fill <= 0.95;
}

static inline int object_px(const probe_segment *sg, int32_t label, int x, int y)
{
    return sg->cls[(size_t)y * sg->width + (size_t)x] == PROBE_CLS_OBJECT &&
        in_component(sg, label, (uint32_t)x, (uint32_t)y);
}

/* Each row's span, its first to last object pixel, into row_span and row_first (searched from both ends). */
static int32_t row_spans(probe_segment *sg, const probe_object *o, int top, int foot)
{
    int32_t widest = 0;
    for (int y = top; y <= foot; y++) {
        int xa = o->x0, xb = o->x1;
        while (xa <= o->x1 && !object_px(sg, o->label, xa, y))
            xa++;
        while (xb > xa && !object_px(sg, o->label, xb, y))
            xb--;
        sg->row_span[y] = xa <= o->x1 ? xb - xa + 1 : 0;
        sg->row_first[y] = xa;
        widest = max_i32(widest, sg->row_span[y]);
    }
    return widest;
}

/*
 * The core's pixels with its holes closed: a pixel counts when object pixels lie on both sides of it in its
 * row and above and below it in its column (within the core). The gap between two walkers side by side has
 * none above or below and stays open.
 */
static uint32_t closed_core_area(probe_segment *sg, const probe_object *o)
{
    int32_t *first = sg->col_first, *last = sg->col_last;
    for (int x = o->x0; x <= o->x1; x++) {
        int ya = o->core_y0, yb = o->core_y1;
        while (ya <= o->core_y1 && !object_px(sg, o->label, x, ya))
            ya++;
        while (yb > ya && !object_px(sg, o->label, x, yb))
            yb--;
        first[x] = ya, last[x] = ya <= o->core_y1 ? yb : -1;
    }
    uint32_t area = 0;
    for (int y = o->core_y0; y <= o->core_y1; y++)
        for (int x = sg->row_first[y]; x < sg->row_first[y] + sg->row_span[y]; x++)
            area += (uint32_t)(first[x] <= y && y <= last[x]);
    return area;
}

/*
 * The object's solid rows, judged on each row's span (a car body the colour of the road behind it is a
 * mask full of holes, yet as wide as the car): from the first to the last row at least half as wide as the
 * widest. A car merged with a person standing behind it is the car's wide rows under a narrow column; its
 * core is the car. Its roof is the first row a quarter as wide as the widest: a car's cabin is 0.4-0.6 of
 * its length, a walker's head and shoulders behind it much less.
 */
static void core_rows(probe_segment *sg, probe_object *o, int top, int foot)
{
    int32_t widest = row_spans(sg, o, top, foot);
    o->core_y0 = o->core_y1 = o->roof_y = -1;
    o->core_area = 0;
    for (int y = top; y <= foot && o->roof_y < 0; y++)
        if (4 * sg->row_span[y] >= widest)
            o->roof_y = y;
    for (int y = top; y <= foot; y++)
        if (2 * sg->row_span[y] >= widest)
            o->core_y0 = o->core_y0 < 0 ? y : o->core_y0, o->core_y1 = y;
    if (o->core_y0 >= 0)
        o->core_area = closed_core_area(sg, o);
}

static int extract_object(probe_segment *sg, const uint8_t *rgb, const uint8_t *plate, const sp_probe_plane *plane,
                          int32_t label, probe_object *o)
{
    rect r = component_rect(sg, label);
    int top, foot, xa, xb;
    if (!object_extent(sg, label, r, &top, &foot, &xa, &xb))
        return 0; /* a shadow without an object, or a speck */
    if (sg->noise >= NOISY_LEVELS) /* clean footage: the pixel test found its shadows */
        trim_cast_shadow(sg, rgb, plate, label, r, top, foot);
    if (!object_extent(sg, label, r, &top, &foot, &xa, &xb))
        return 0;
    /* a head hidden by a sign's edge makes the body look short too: its legs are where they were found */
    int top_cut = top > 0 && on_plate_edge(sg, plate, top, xa, xb), foot0 = foot;
    if (!top_cut)
        extend_legs(sg, rgb, plate, plane, label, top, &foot, xa, xb);
    r = component_rect(sg, label);
    reclaim_clothing(sg, label, top, foot, xa, xb);
    sums s;
    accumulate(sg, rgb, plate, label, r, top, foot, &s);
    if (s.n < sg->min_object_px || s.foot_n <= 0)
        return 0;
    memset(o, 0, sizeof(*o));
    o->label = label;
    o->x0 = s.x0, o->x1 = s.x1, o->y0 = top, o->y1 = foot;
    o->area = (uint32_t)s.n;
    o->touches = touches(sg, o->x0, o->y0, o->x1, o->y1);
    o->foot_x = s.foot_x / s.foot_n;
    o->foot_y = foot;
    o->height = foot - top + 1;
    for (int c = 0; c < 3; c++)
        o->mean_rgb[c] = s.rgb[c] / s.n;
    o->cx = s.x / s.n;
    o->tbar = s.t / s.n;
    o->person = person_shaped(o);
    core_rows(sg, o, top, foot0);
    o->cut_foot = o->touches ? (double)NAN : cut_foot(sg, plate, plane, top, foot, xa, xb);
    if (s.sh_n > 0) {
        o->shadow_area = (uint32_t)s.sh_n;
        o->shadow_cx = s.sh_x / s.sh_n;
        o->shadow_cy = s.sh_y / s.sh_n;
        o->shadow_ratio = s.sh_ratio / s.sh_n;
    }
    return 1;
}

static int by_cells_desc(const void *a, const void *b, void *comp)
{
    const int32_t *c = comp;
    int32_t na = c[5 * *(const int32_t *)a + 4], nb = c[5 * *(const int32_t *)b + 4];
    return (na < nb) - (na > nb);
}

/* Insertion sort of candidate labels by size (few candidates per frame). */
static void sort_candidates(int32_t *v, int32_t n, int32_t *comp)
{
    for (int32_t i = 1; i < n; i++) {
        int32_t key = v[i], j = i - 1;
        while (j >= 0 && by_cells_desc(&v[j], &key, comp) > 0) {
            v[j + 1] = v[j];
            j--;
        }
        v[j + 1] = key;
    }
}

void segment_frame(probe_segment *sg, const uint8_t *rgb, const uint8_t *plate, const sp_probe_plane *plane)
{
    classify(sg, rgb, plate);
    size_t cells = (size_t)sg->gw * sg->gh;
    unsigned quarter = (sg->block * sg->block + 3) / 4;
    for (size_t i = 0; i < cells; i++)
        sg->grid[i] = (uint8_t)(sg->cell_obj[i] + sg->cell_sh[i] >= quarter);
    morph(sg->grid, sg->tmp, sg->morph_rows, sg->gw, sg->gh, 1); /* closing joins the parts of one person */
    morph(sg->tmp, sg->grid, sg->morph_rows, sg->gw, sg->gh, 0);
    int32_t n = label_components(sg, sg->grid);
    merge_parts(sg, n, plane);
    component_boxes(sg, n, sg->comp, 0);
    int32_t cand = 0;
    unsigned min_cells = sg->min_object_px / (sg->block * sg->block);
    for (int32_t l = 1; l <= n; l++)
        if ((unsigned)sg->comp[5 * l + 4] >= (min_cells ? min_cells : 1))
            sg->order[cand++] = l;
    sort_candidates(sg->order, cand, sg->comp);
    sg->n_obj = 0;
    for (int32_t i = 0; i < cand && sg->n_obj < PROBE_MAX_OBJECTS; i++)
        sg->n_obj += (unsigned)extract_object(sg, rgb, plate, plane, sg->order[i], &sg->obj[sg->n_obj]);
}
