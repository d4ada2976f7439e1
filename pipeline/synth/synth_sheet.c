/* SPDX-License-Identifier: MIT */
/*
 * Contact sheet: frames decoded back from a written capture (what a consumer
 * sees, JPEG and noise included), then the renderer's decomposition of one
 * frame: final, diffuse, specular, ambient, visibility, normals, albedo, mask.
 */
#include "pipeline/synth/synth_internal.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "common/pixconv.h"
#include "sunprobe/sp_capture.h"

#define SHEET_GAP 2
#define SHEET_BG 32
#define N_COMPONENTS 8

typedef struct sheet {
    uint8_t *px;
    uint32_t w, h;
    uint32_t tile_w, tile_h, scale;
    int columns;
} sheet;

/* Box-downscales an RGB image by s into tile slot `slot`. */
static void put_tile(sheet *sh, int slot, const uint8_t *rgb, uint32_t w, uint32_t h)
{
    uint32_t x0 = SHEET_GAP + (uint32_t)(slot % sh->columns) * (sh->tile_w + SHEET_GAP);
    uint32_t y0 = SHEET_GAP + (uint32_t)(slot / sh->columns) * (sh->tile_h + SHEET_GAP);
    uint32_t s = sh->scale;
    for (uint32_t y = 0; y < sh->tile_h && y * s < h; y++)
        for (uint32_t x = 0; x < sh->tile_w && x * s < w; x++)
            for (int c = 0; c < 3; c++) {
                uint32_t sum = 0, n = 0;
                for (uint32_t dy = 0; dy < s && y * s + dy < h; dy++)
                    for (uint32_t dx = 0; dx < s && x * s + dx < w; dx++, n++)
                        sum += rgb[((size_t)(y * s + dy) * w + x * s + dx) * 3 + (size_t)c];
                sh->px[((size_t)(y0 + y) * sh->w + x0 + x) * 3 + (size_t)c] = (uint8_t)((sum + n / 2) / (n ? n : 1));
            }
}

/* Decodes the wanted frames of the capture into slots 0..n-1. */
static int decode_frames(sheet *sh, const char *path, const uint64_t *want, int n, uint8_t *rgb, uint32_t w,
                         uint32_t h)
{
    sp_capture_reader *r = NULL;
    int ret = sp_capture_reader_open(&r, path, NULL), found = 0;
    while (!ret && found < n) {
        sp_chunk ch;
        ret = sp_capture_reader_next(r, &ch);
        if (ret)
            break;
        sp_frame_chunk fc;
        if (ch.type != SP_CHUNK_FRAME || sp_chunk_parse_frame(&ch, &fc) || fc.sequence != want[found])
            continue;
        if (fc.width != w || fc.height != h) {
            ret = SP_ECORRUPT;
            break;
        }
        sp_pixconv_src src = { fc.format, fc.width, fc.height, fc.stride, fc.data, fc.data_size };
        ret = sp_pixconv_to_rgb24(&src, rgb, (size_t)w * h * 3, w * 3);
        while (!ret && found < n && want[found] == fc.sequence) /* repeats when fewer frames than slots */
            put_tile(sh, found++, rgb, w, h);
    }
    sp_capture_reader_close(&r);
    if (ret == SP_EOS)
        ret = found == n ? 0 : SP_ENODATA;
    return ret;
}

static double clamp01(double v) { return v < 0 ? 0 : v > 1 ? 1 : v; }

/* Component c of the renderer's outputs as display bytes. */
static void component(const sp_synth_selfie *g, const sp_render_outputs *o, const synth_pose *p, double exposure,
                      int c, uint8_t *rgb)
{
    size_t n = (size_t)o->width * (size_t)o->height;
    const float *lin = c == 1 ? o->diffuse : c == 2 ? o->specular : o->ambient;
    for (size_t i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
            double v;
            switch (c) {
            case 0: v = o->image[3 * i + (size_t)k]; break;
            case 1:
            case 2:
            case 3: v = synth_display(exposure * (double)lin[3 * i + (size_t)k]); break;
            case 4: v = o->visibility[i]; break;
            case 5: { /* camera-frame normal: x right, y up, z towards the viewer */
                const float *nw = o->normal + 3 * i;
                double nc = p->cam.R[k * 3] * (double)nw[0] + p->cam.R[k * 3 + 1] * (double)nw[1] +
                            p->cam.R[k * 3 + 2] * (double)nw[2];
                v = o->coverage[i] > 0 ? 0.5 + 0.5 * (k ? -nc : nc) : 0.0;
                break;
            }
            case 6: v = pow(clamp01(o->albedo[3 * i + (size_t)k]), 1.0 / 2.2); break;
            default: v = o->coverage[i]; break;
            }
            rgb[3 * i + (size_t)k] = synth_to_byte(clamp01(v));
        }
    (void)g;
}

static int render_components(sp_synth_selfie *g, sheet *sh, int first_slot, uint64_t frame, uint8_t *rgb)
{
    sp_synth_frame_truth ft;
    synth_pose p;
    sp_render_outputs o;
    int ret = sp_synth_selfie_frame_truth(g, frame, &ft);
    if (!ret)
        ret = synth_pose_at(g, ft.pose_ns, &p);
    double e = isfinite(ft.exposure) ? ft.exposure : g->initial_exposure;
    if (!ret)
        ret = synth_render_pose(g, &p, NULL, 0, NULL, e, &o);
    for (int c = 0; !ret && c < N_COMPONENTS; c++) {
        component(g, &o, &p, e, c, rgb);
        put_tile(sh, first_slot + c, rgb, g->s.width, g->s.height);
    }
    return ret;
}

int sp_synth_selfie_contact_sheet(sp_synth_selfie *g, const char *capture_path, int n_frames,
                                  uint64_t component_frame, int columns, uint8_t **rgb_out, uint32_t *width,
                                  uint32_t *height)
{
    if (!g || !capture_path || !rgb_out || !width || !height || n_frames < 0 || n_frames > 256 || columns < 1 ||
        columns > 64 || component_frame >= g->n_frames)
        return -EINVAL;
    *rgb_out = NULL;
    uint32_t w = g->s.width, h = g->s.height;
    sheet sh = { .columns = columns };
    sh.scale = (w + 319) / 320; /* tiles at most 320 pixels wide */
    sh.tile_w = (w + sh.scale - 1) / sh.scale;
    sh.tile_h = (h + sh.scale - 1) / sh.scale;
    int frame_rows = (n_frames + columns - 1) / columns, slots = frame_rows * columns + N_COMPONENTS;
    int rows = (slots + columns - 1) / columns;
    sh.w = SHEET_GAP + (uint32_t)columns * (sh.tile_w + SHEET_GAP);
    sh.h = SHEET_GAP + (uint32_t)rows * (sh.tile_h + SHEET_GAP);
    sh.px = malloc((size_t)sh.w * sh.h * 3);
    uint8_t *rgb = malloc((size_t)w * h * 3);
    uint64_t *want = malloc(((size_t)n_frames + 1) * sizeof(*want));
    int ret = sh.px && rgb && want ? 0 : -ENOMEM;
    if (!ret) {
        memset(sh.px, SHEET_BG, (size_t)sh.w * sh.h * 3);
        for (int k = 0; k < n_frames; k++)
            want[k] = n_frames > 1 ? (uint64_t)llround((double)k * (double)(g->n_frames - 1) / (n_frames - 1)) : 0;
        ret = decode_frames(&sh, capture_path, want, n_frames, rgb, w, h);
    }
    if (!ret)
        ret = render_components(g, &sh, frame_rows * columns, component_frame, rgb);
    free(rgb);
    free(want);
    if (ret) {
        free(sh.px);
        return ret;
    }
    *rgb_out = sh.px;
    *width = sh.w;
    *height = sh.h;
    return 0;
}
