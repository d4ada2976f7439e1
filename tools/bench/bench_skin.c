/* SPDX-License-Identifier: MIT */
/*
 * bench_skin FACE_DIR CAPTURE_DIR [--png OUT.png]: the fit's unseen skin against
 * the capture's true UV albedo (gt/albedo_face.png for u in [0, 1], gt/albedo_head.png
 * for u in [1, 2], sRGB). Over the texels no keyframe saw in skin clusters: the
 * mean colour and the local contrast (3x3 luminance standard deviation within
 * the set) relative to the truth's, and the seam (mean squared step between
 * an unseen and an observed neighbour) relative to the steps inside either set.
 * Push-pull alone (the face directory's map when it has no synthesised texels)
 * and push-pull + synthesis (skin_fill.c) side by side. The fit's albedo is
 * scaled per channel to the truth over the observed skin (albedo and light
 * trade a factor), by least squares, and the mean colour again with the scale
 * that matches the observed skin's mean. Then the observed skin the synthesis copies, against the truth there.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/file_util.h"
#include "export/png.h"
#include "export/png_read.h"
#include "pipeline/sunstage/sunstage_internal.h"

typedef struct truth_tile {
    uint8_t *rgba;
    uint32_t w, h;
} truth_tile;

static double srgb_to_linear(double v)
{
    return v <= 0.04045 ? v / 12.92 : pow((v + 0.055) / 1.055, 2.4);
}

/* The truth averaged over texel (x, y) of a w x h map whose halves are the two tiles. */
static void truth_texel(const truth_tile t[2], int x, int y, int w, int h, double out[3])
{
    int half = w / 2, k = x >= half;
    const truth_tile *tt = &t[k];
    int x0 = (int)((double)(x - k * half) * tt->w / half), x1 = (int)((double)(x - k * half + 1) * tt->w / half);
    int y0 = (int)((double)y * tt->h / h), y1 = (int)((double)(y + 1) * tt->h / h);
    double s[3] = { 0, 0, 0 };
    int n = 0;
    for (int v = y0; v < y1; v++)
        for (int u = x0; u < x1; u++, n++)
            for (int c = 0; c < 3; c++)
                s[c] += srgb_to_linear(tt->rgba[4 * ((size_t)v * tt->w + u) + c] / 255.0);
    for (int c = 0; c < 3; c++)
        out[c] = n ? s[c] / n : 0;
}

static double lum(const float *p)
{
    return 0.2126 * (double)p[0] + 0.7152 * (double)p[1] + 0.0722 * (double)p[2];
}

typedef struct measure {
    double mean_err, contrast_fit, contrast_true, seam, inner;
    double inner_seen, inner_filled; /* the steps inside each set alone */
    double sum_fit[3], sum_true[3];  /* over the filled texels, per channel */
} measure;

/* 3x3 luminance standard deviation over the texels of the set, averaged over the set. */
static double local_contrast(const float *im, const uint8_t *set, int w, int h)
{
    double acc = 0;
    int n = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            if (!set[y * w + x])
                continue;
            double s = 0, q = 0;
            int k = 0;
            for (int dy = -1; dy <= 1; dy++)
                for (int dx = -1; dx <= 1; dx++) {
                    int u = x + dx, v = y + dy;
                    if (u < 0 || v < 0 || u >= w || v >= h || !set[v * w + u])
                        continue;
                    double l = lum(im + 3 * ((size_t)v * w + u));
                    s += l, q += l * l, k++;
                }
            if (k >= 4) {
                acc += sqrt(fmax(0, q / k - (s / k) * (s / k)));
                n++;
            }
        }
    return n ? acc / n : 0;
}

static measure evaluate(const float *fit, const float *truth, const uint8_t *filled, const uint8_t *seen, int w, int h)
{
    measure m = { 0 };
    double sf[3] = { 0 }, st[3] = { 0 };
    int n = 0;
    for (int i = 0; i < w * h; i++)
        if (filled[i]) {
            for (int c = 0; c < 3; c++)
                sf[c] += (double)fit[3 * i + c], st[c] += (double)truth[3 * i + c];
            n++;
        }
    for (int c = 0; c < 3; c++) {
        m.mean_err = fmax(m.mean_err, fabs(sf[c] - st[c]) / fmax(st[c], 1e-9));
        m.sum_fit[c] = sf[c], m.sum_true[c] = st[c];
    }
    m.contrast_fit = local_contrast(fit, filled, w, h);
    m.contrast_true = local_contrast(truth, filled, w, h);
    double sb = 0, si = 0, s_seen = 0, s_filled = 0;
    int nb = 0, ni = 0, n_seen = 0, n_filled = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int d = 0; d < 2; d++) {
                int u = x + (d == 0), v = y + (d == 1);
                if (u >= w || v >= h)
                    continue;
                int a = y * w + x, b = v * w + u;
                int ina = filled[a] || seen[a], inb = filled[b] || seen[b];
                if (!ina || !inb)
                    continue;
                double q = 0;
                for (int c = 0; c < 3; c++)
                    q += (double)((fit[3 * a + c] - fit[3 * b + c]) * (fit[3 * a + c] - fit[3 * b + c]));
                if (filled[a] != filled[b])
                    sb += q, nb++;
                else {
                    si += q, ni++;
                    if (filled[a])
                        s_filled += q, n_filled++;
                    else
                        s_seen += q, n_seen++;
                }
            }
    m.seam = nb ? sb / nb : 0;
    m.inner = ni ? si / ni : 1e-12;
    m.inner_seen = n_seen ? s_seen / n_seen : 1e-12;
    m.inner_filled = n_filled ? s_filled / n_filled : 1e-12;
    (void)n;
    return m;
}

static void print_measure(const char *who, const measure *m)
{
    printf("  %-22s mean colour off by %5.1f %%  local contrast %.4f vs true %.4f (%+5.1f %%)  seam / interior %.2f\n",
           who, 100 * m->mean_err, m->contrast_fit, m->contrast_true,
           100 * (m->contrast_fit / fmax(m->contrast_true, 1e-12) - 1), m->seam / fmax(m->inner, 1e-12));
    /* a step across the boundary between two textures of different roughness sits between their own */
    printf("  %-22s seam against each side's own steps: seen %.2f, filled %.2f\n", "",
           m->seam / fmax(m->inner_seen, 1e-12), m->seam / fmax(m->inner_filled, 1e-12));
}

static void put_block(uint8_t *img, int iw, int x0, int y0, const float *rgb, int w, int h, int z)
{
    for (int y = 0; y < h * z; y++)
        for (int x = 0; x < w * z; x++)
            for (int c = 0; c < 3; c++) {
                double v = (double)rgb[3 * ((size_t)(y / z) * w + x / z) + c];
                v = v <= 0.0031308 ? 12.92 * v : 1.055 * pow(fmax(v, 0), 1 / 2.4) - 0.055;
                img[3 * ((size_t)(y0 + y) * iw + x0 + x) + c] = (uint8_t)fmin(255, fmax(0, v * 255 + 0.5));
            }
}

static int read_maps(const char *dir, float **albedo, uint8_t **obs, uint8_t **clusters, int *w, int *h, int *cw)
{
    char p[1024];
    void *a = NULL, *o = NULL, *c = NULL;
    size_t na, no, nc;
    snprintf(p, sizeof(p), "%s/albedo.f32", dir);
    int ret = sp_read_whole_file(p, 1u << 28, &a, &na);
    snprintf(p, sizeof(p), "%s/albedo_observed.u8", dir);
    ret = ret ? ret : sp_read_whole_file(p, 1u << 26, &o, &no);
    snprintf(p, sizeof(p), "%s/clusters.u8", dir);
    ret = ret ? ret : sp_read_whole_file(p, 1u << 26, &c, &nc);
    if (ret || na != no * 12)
        return fprintf(stderr, "bench_skin: %s: no albedo / albedo_observed / clusters maps\n", dir), 1;
    *h = (int)lrint(sqrt((double)no / 2)), *w = 2 * *h; /* ICT: two tiles side by side */
    *cw = (int)lrint(sqrt((double)nc * 2));
    *albedo = a, *obs = o, *clusters = c;
    return *w * *h == (int)no ? 0 : 1;
}

int main(int argc, char **argv)
{
    if (argc < 3)
        return fprintf(stderr, "usage: bench_skin FACE_DIR CAPTURE_DIR [--png OUT.png]\n"), 1;
    float *albedo;
    uint8_t *obs, *clusters;
    int w, h, cw;
    if (read_maps(argv[1], &albedo, &obs, &clusters, &w, &h, &cw))
        return 1;
    truth_tile t[2];
    char p[1024];
    for (int k = 0; k < 2; k++) {
        snprintf(p, sizeof(p), "%s/gt/albedo_%s.png", argv[2], k ? "head" : "face");
        if (sp_png_read_rgba(p, &t[k].rgba, &t[k].w, &t[k].h))
            return printf("SKIP: no true albedo %s\n", p), 77;
    }
    size_t n = (size_t)w * h;
    float *truth = malloc(sizeof(float) * 3 * n), *synth = malloc(sizeof(float) * 3 * n);
    uint8_t *filled = calloc(n, 1), *seen = calloc(n, 1), *obs2 = malloc(n);
    int already = 0;
    for (size_t i = 0; i < n; i++)
        already |= obs[i] == SS_TEXEL_SYNTHESISED;
    memcpy(synth, albedo, sizeof(float) * 3 * n);
    memcpy(obs2, obs, n);
    if (!already && ss_skin_synthesise(synth, w, h, obs2, clusters, cw, cw / 2, 0))
        return fprintf(stderr, "bench_skin: synthesis failed\n"), 1;
    double k[3], num[3] = { 0 }, den[3] = { 0 }, sum_t[3] = { 0 }, sum_a[3] = { 0 };
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            size_t i = (size_t)y * w + x;
            double tv[3];
            truth_texel(t, x, y, w, h, tv);
            for (int c = 0; c < 3; c++)
                truth[3 * i + c] = (float)tv[c];
            filled[i] = obs2[i] == SS_TEXEL_SYNTHESISED;
            int cl = clusters[(size_t)((y + 0.5) * (cw / 2) / h) * cw + (size_t)((x + 0.5) * cw / w)];
            seen[i] = obs[i] == 1 && cl < SP_RENDER_CLUSTERS && cl != 6 && cl != 7;
            for (int c = 0; seen[i] && c < 3; c++)
                num[c] += tv[c] * (double)albedo[3 * i + c],
                    den[c] += (double)albedo[3 * i + c] * (double)albedo[3 * i + c], sum_t[c] += tv[c],
                    sum_a[c] += (double)albedo[3 * i + c];
        }
    for (int c = 0; c < 3; c++)
        k[c] = den[c] > 0 ? num[c] / den[c] : 1;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            albedo[3 * i + c] *= (float)k[c], synth[3 * i + c] *= (float)k[c];
    size_t nf = 0, ns = 0;
    for (size_t i = 0; i < n; i++)
        nf += filled[i], ns += seen[i];
    printf("%s: %dx%d map, %zu observed skin texels, %zu unseen skin texels%s; albedo scaled by %.3f %.3f %.3f\n",
           argv[1], w, h, ns, nf, already ? " (synthesised by the fit)" : "", k[0], k[1], k[2]);
    measure pp = evaluate(albedo, truth, filled, seen, w, h), sy = evaluate(synth, truth, filled, seen, w, h);
    if (!already)
        print_measure("push-pull alone", &pp);
    print_measure("push-pull + synthesis", &sy);
    /* Least squares weighs the observed skin's errors by its brightness (an over-bright forehead pulls the
       scale down); matching the observed skin's mean instead leaves the fill's own error in the unseen mean */
    double err = 0;
    int scalable = 1;
    for (int c = 0; c < 3; c++) {
        scalable &= sum_a[c] > 0 && k[c] > 0;
        double ratio = scalable ? sum_t[c] / sum_a[c] / k[c] : 1;
        err = fmax(err, fabs(sy.sum_fit[c] * ratio - sy.sum_true[c]) / fmax(sy.sum_true[c], 1e-9));
    }
    if (scalable)
        printf("  %-22s mean colour off by %5.1f %% with the scale that matches the observed skin's mean instead\n",
               "push-pull + synthesis", 100 * err);
    else
        printf("  %-22s no mean-matching scale: the observed skin's albedo sums to 0 in a channel\n",
               "push-pull + synthesis");
    /* the exemplar the synthesis copies: the fit's observed skin against the truth there */
    double co_fit = local_contrast(albedo, seen, w, h), co_true = local_contrast(truth, seen, w, h);
    printf("  %-22s local contrast %.4f vs true %.4f (%+5.1f %%)\n", "observed skin (source)", co_fit, co_true,
           100 * (co_fit / fmax(co_true, 1e-12) - 1));
    if (argc >= 5 && !strcmp(argv[3], "--png")) { /* truth, push-pull, synthesis, each 4x */
        int z = 4, iw = w * z, ih = 3 * h * z;
        uint8_t *img = malloc((size_t)iw * ih * 3);
        put_block(img, iw, 0, 0, truth, w, h, z);
        put_block(img, iw, 0, h * z, albedo, w, h, z);
        put_block(img, iw, 0, 2 * h * z, synth, w, h, z);
        sp_png_write(argv[4], img, (uint32_t)iw, (uint32_t)ih, (uint32_t)iw * 3, 3);
        free(img);
    }
    return 0;
}
