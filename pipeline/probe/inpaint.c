/* SPDX-License-Identifier: MIT */
/*
 * Exemplar-based inpainting (Criminisi, Perez and Toyama 2004). The hole is
 * filled one patch at a time from its front inward, highest priority first:
 * confidence (how much of the patch is known, and how reliably) times the
 * data term (how strongly an isophote flows into the hole), so kerbs, road
 * lines and wall edges are continued before texture fills the rest. A
 * target patch takes its unknown pixels from the source patch (wholly outside
 * the original hole) whose pixels match its known ones best, searched on a
 * strided grid in a window around it and refined around the best cell.
 */
#include "depopulate.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sunprobe/sp_common.h"

void sp_inpaint_default_settings(sp_inpaint_settings *s)
{
    if (!s)
        return;
    s->patch_radius = 4;
    s->search_radius = 0;
    s->max_candidates = 1500;
    s->blend = 4;
}

typedef struct inpaint {
    uint8_t *rgb;
    uint32_t stride;
    int w, h, r, R, blend;
    unsigned budget;   /* coarse candidates per search */
    uint8_t *hole;     /* 1 while unknown */
    uint8_t *guide;    /* RGB24, the hole's smooth push-pull fill (make_guide) */
    uint8_t *onfront;  /* 1 while listed in front */
    float *conf;       /* Criminisi's C: 1 known, the patch's confidence once filled */
    float *prio;
    float *luma;
    uint32_t *integral; /* (w+1) x (h+1) sums of the original hole, for "source patch wholly known" */
    int32_t *front;
    size_t n_front, cap_front;
} inpaint;

static int source_ok(const inpaint *ip, int x, int y)
{
    int r = ip->r;
    if (x < r || y < r || x >= ip->w - r || y >= ip->h - r)
        return 0;
    size_t W = (size_t)ip->w + 1;
    const uint32_t *I = ip->integral;
    uint32_t s = I[(size_t)(y + r + 1) * W + x + r + 1] - I[(size_t)(y - r) * W + x + r + 1] -
                 I[(size_t)(y + r + 1) * W + x - r] + I[(size_t)(y - r) * W + x - r];
    return s == 0;
}

static int is_front(const inpaint *ip, int x, int y)
{
    size_t i = (size_t)y * ip->w + x;
    if (!ip->hole[i])
        return 0;
    return (x > 0 && !ip->hole[i - 1]) || (x + 1 < ip->w && !ip->hole[i + 1]) ||
           (y > 0 && !ip->hole[i - ip->w]) || (y + 1 < ip->h && !ip->hole[i + ip->w]);
}

static int known(const inpaint *ip, int x, int y)
{
    return x >= 0 && y >= 0 && x < ip->w && y < ip->h && !ip->hole[(size_t)y * ip->w + x];
}

/* The luma gradient at a known pixel from known neighbours (one-sided where needed), 0 where none. */
static void gradient(const inpaint *ip, int x, int y, double *gx, double *gy)
{
    const float *L = ip->luma;
    size_t i = (size_t)y * ip->w + x;
    int l = known(ip, x - 1, y), rt = known(ip, x + 1, y), u = known(ip, x, y - 1), d = known(ip, x, y + 1);
    double c = L[i], xl = l ? (double)L[i - 1] : c, xr = rt ? (double)L[i + 1] : c;
    double yu = u ? (double)L[i - ip->w] : c, yd = d ? (double)L[i + ip->w] : c;
    *gx = (xr - xl) / (l && rt ? 2.0 : 1.0);
    *gy = (yd - yu) / (u && d ? 2.0 : 1.0);
}

/* Criminisi's C(p): the known share of the patch, weighted by how reliably each pixel was filled. */
static float confidence(const inpaint *ip, int x, int y)
{
    int r = ip->r;
    double c = 0;
    for (int v = y - r; v <= y + r; v++)
        for (int u = x - r; u <= x + r; u++)
            if (known(ip, u, v))
                c += (double)ip->conf[(size_t)v * ip->w + u];
    return (float)(c / (double)((2 * r + 1) * (2 * r + 1)));
}

/* Priority of a front pixel: confidence times the isophote's flow across the front's normal. */
static float priority(const inpaint *ip, int x, int y)
{
    int r = ip->r;
    double best = 0, ix = 0, iy = 0, nx = 0, ny = 0;
    for (int v = y - r; v <= y + r; v++)
        for (int u = x - r; u <= x + r; u++) {
            if (u < 0 || v < 0 || u >= ip->w || v >= ip->h)
                continue;
            size_t i = (size_t)v * ip->w + u;
            if (ip->hole[i]) {
                nx += u - x, ny += v - y; /* the normal points into the hole */
                continue;
            }
            double gx, gy;
            gradient(ip, u, v, &gx, &gy);
            if (gx * gx + gy * gy > best)
                best = gx * gx + gy * gy, ix = -gy, iy = gx;
        }
    double c = confidence(ip, x, y), nn = hypot(nx, ny);
    double data = nn > 0 ? fabs(ix * nx + iy * ny) / (nn * 255.0) : 0.0;
    return (float)(c * (data + 1e-3)); /* the floor keeps flat regions in confidence order */
}

static int front_push(inpaint *ip, int x, int y)
{
    size_t i = (size_t)y * ip->w + x;
    if (ip->onfront[i])
        return 0;
    if (ip->n_front == ip->cap_front) {
        size_t cap = ip->cap_front ? 2 * ip->cap_front : 1024;
        int32_t *p = realloc(ip->front, cap * sizeof(*p));
        if (!p)
            return -ENOMEM;
        ip->front = p, ip->cap_front = cap;
    }
    ip->front[ip->n_front++] = (int32_t)i;
    ip->onfront[i] = 1;
    return 0;
}

/*
 * Matching cost: mean squared difference over the target's `norm` pixels, its known ones as they are
 * and its unknown ones as the smooth guide has them; abandoned once it must pass `bound`. The guide
 * keeps the low frequencies (where a static shadow's band goes), so a source with the right texture
 * but the wrong light loses. (Synth street seeds 1-3, 21 frames: the guide at a quarter of the known
 * pixels' weight 21.96 dB, half 22.19, equal 22.36, double 21.98.)
 */
static double patch_cost(const inpaint *ip, int tx, int ty, int sx, int sy, double bound, uint64_t norm)
{
    double limit = bound * (double)norm;
    int r = ip->r;
    uint64_t sum = 0;
    for (int dv = -r; dv <= r; dv++) {
        int v = ty + dv;
        if (v < 0 || v >= ip->h)
            continue;
        const uint8_t *srow = ip->rgb + (size_t)(sy + dv) * ip->stride + 3 * (size_t)(sx - r);
        const uint8_t *trow = ip->rgb + (size_t)v * ip->stride, *grow = ip->guide + (size_t)v * ip->w * 3;
        const uint8_t *hrow = ip->hole + (size_t)v * ip->w;
        for (int du = -r; du <= r; du++) {
            int u = tx + du;
            if (u < 0 || u >= ip->w)
                continue;
            const uint8_t *a = hrow[u] ? grow + 3 * (size_t)u : trow + 3 * (size_t)u, *b = srow + 3 * (size_t)(du + r);
            int d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
            sum += (uint64_t)(d0 * d0 + d1 * d1 + d2 * d2);
        }
        if ((double)sum > limit)
            return (double)INFINITY; /* over the best even if the rest matched exactly */
    }
    return norm ? (double)sum / (double)norm : (double)INFINITY;
}

/* One push-pull level down: premultiplied sums of each 2x2 block, the weight clamped to 1. */
static void push(const float *f, int fw, int fh, float *c, int cw, int ch)
{
    for (int y = 0; y < ch; y++)
        for (int x = 0; x < cw; x++) {
            float acc[4] = { 0, 0, 0, 0 };
            for (int j = 0; j < 2; j++)
                for (int i = 0; i < 2; i++) {
                    int u = 2 * x + i, v = 2 * y + j;
                    if (u < fw && v < fh)
                        for (int k = 0; k < 4; k++)
                            acc[k] += f[4 * ((size_t)v * fw + u) + k];
                }
            float n = acc[3] > 1.0f ? acc[3] : 1.0f;
            float *o = c + 4 * ((size_t)y * cw + x);
            for (int k = 0; k < 3; k++)
                o[k] = acc[3] > 0 ? acc[k] / acc[3] * (n > 1.0f ? 1.0f : acc[3]) : 0.0f;
            o[3] = acc[3] > 1.0f ? 1.0f : acc[3];
        }
}

/* One level up: each pixel keeps its own share (its weight) and takes the rest from the bilinear coarse value. */
static void pull(const float *c, int cw, int ch, float *f, int fw, int fh)
{
    for (int y = 0; y < fh; y++)
        for (int x = 0; x < fw; x++) {
            float *o = f + 4 * ((size_t)y * fw + x);
            if (o[3] >= 1.0f) {
                continue;
            }
            float cx = (x + 0.5f) * 0.5f - 0.5f, cy = (y + 0.5f) * 0.5f - 0.5f;
            int x0 = (int)floorf(cx), y0 = (int)floorf(cy);
            float ax = cx - x0, ay = cy - y0, up[4] = { 0, 0, 0, 0 };
            for (int j = 0; j < 2; j++)
                for (int i = 0; i < 2; i++) {
                    int u = x0 + i < 0 ? 0 : x0 + i >= cw ? cw - 1 : x0 + i;
                    int v = y0 + j < 0 ? 0 : y0 + j >= ch ? ch - 1 : y0 + j;
                    float wgt = (i ? ax : 1 - ax) * (j ? ay : 1 - ay);
                    for (int k = 0; k < 4; k++)
                        up[k] += wgt * c[4 * ((size_t)v * cw + u) + k];
                }
            float a = o[3];
            for (int k = 0; k < 3; k++) {
                float own = a > 0 ? o[k] / a : 0.0f, coarse = up[3] > 0 ? up[k] / up[3] : 0.0f;
                o[k] = a * own + (1 - a) * coarse;
            }
            o[3] = 1.0f;
        }
}

/*
 * The guide: a push-pull fill of the hole (each coarser level the mean of the known pixels below it,
 * then every unknown pixel the bilinear value of the level above), the smooth surface the exemplars
 * are matched against inside the hole.
 */
static int make_guide(inpaint *ip)
{
    int levels = 0, w = ip->w, h = ip->h;
    float *v[24] = { 0 };
    int lw[24], lh[24];
    int ret = 0;
    for (; levels < 24; levels++) {
        lw[levels] = w, lh[levels] = h;
        if (!(v[levels] = malloc((size_t)w * h * 4 * sizeof(float)))) {
            ret = -ENOMEM;
            break;
        }
        if (w == 1 && h == 1)
            break;
        w = (w + 1) / 2, h = (h + 1) / 2;
    }
    if (!ret) {
        levels++;
        for (int y = 0; y < ip->h; y++)
            for (int x = 0; x < ip->w; x++) {
                const uint8_t *p = ip->rgb + (size_t)y * ip->stride + 3 * (size_t)x;
                float *q = v[0] + 4 * ((size_t)y * ip->w + x), k = ip->hole[(size_t)y * ip->w + x] ? 0.0f : 1.0f;
                q[0] = p[0] * k, q[1] = p[1] * k, q[2] = p[2] * k, q[3] = k;
            }
        for (int l = 1; l < levels; l++)
            push(v[l - 1], lw[l - 1], lh[l - 1], v[l], lw[l], lh[l]);
        for (int l = levels - 2; l >= 0; l--)
            pull(v[l + 1], lw[l + 1], lh[l + 1], v[l], lw[l], lh[l]);
        for (size_t i = 0; i < (size_t)ip->w * ip->h; i++)
            for (int c = 0; c < 3; c++)
                ip->guide[3 * i + c] = (uint8_t)lrintf(fminf(255.0f, fmaxf(0.0f, v[0][4 * i + c])));
    }
    for (int l = 0; l < 24; l++)
        free(v[l]);
    return ret;
}

#define MAX_BLEND 8

/* The best few source patches found so far, best first. */
typedef struct match {
    int n, k;                  /* found, wanted */
    int x[MAX_BLEND], y[MAX_BLEND];
    double cost[MAX_BLEND];
    uint64_t norm;             /* the target patch's pixels inside the image */
} match;

static double worst(const match *m)
{
    return m->n < m->k ? (double)INFINITY : m->cost[m->n - 1];
}

static void try_source(const inpaint *ip, int tx, int ty, int sx, int sy, match *m)
{
    if (!source_ok(ip, sx, sy))
        return;
    for (int j = 0; j < m->n; j++)
        if (m->x[j] == sx && m->y[j] == sy)
            return; /* the refinement revisits the coarse grid's cells */
    double c = patch_cost(ip, tx, ty, sx, sy, worst(m), m->norm);
    if (!(c < worst(m)))
        return;
    int j = m->n < m->k ? m->n++ : m->n - 1;
    /* equal costs: the nearer source first, the likelier the same depth and light */
    for (; j > 0 && (m->cost[j - 1] > c || (m->cost[j - 1] == c && abs(m->x[j - 1] - tx) + abs(m->y[j - 1] - ty) >
                                                                       abs(sx - tx) + abs(sy - ty)));
         j--)
        m->x[j] = m->x[j - 1], m->y[j] = m->y[j - 1], m->cost[j] = m->cost[j - 1];
    m->x[j] = sx, m->y[j] = sy, m->cost[j] = c;
}

/* The coarse grid's stride that keeps a window of radius R within the candidate budget. */
static int stride_for(int R, unsigned budget)
{
    double cells = (2.0 * R + 1) * (2.0 * R + 1) / (double)(budget ? budget : 1);
    return cells > 1 ? (int)ceil(sqrt(cells)) : 1;
}

static match search(const inpaint *ip, int tx, int ty, int R)
{
    match m = { .k = ip->blend };
    for (int v = ty - ip->r; v <= ty + ip->r; v++)
        for (int u = tx - ip->r; u <= tx + ip->r; u++)
            if (u >= 0 && v >= 0 && u < ip->w && v < ip->h)
                m.norm++;
    int s = stride_for(R, ip->budget);
    for (int y = ty - R; y <= ty + R; y += s)
        for (int x = tx - R; x <= tx + R; x += s)
            try_source(ip, tx, ty, x, y, &m);
    if (!m.n && s > 1) /* the grid missed the few sources there are: every cell */
        for (int y = ty - R; y <= ty + R; y++)
            for (int x = tx - R; x <= tx + R; x++)
                try_source(ip, tx, ty, x, y, &m);
    if (m.n && s > 1) {
        int cx = m.x[0], cy = m.y[0];
        for (int y = cy - s + 1; y < cy + s; y++)
            for (int x = cx - s + 1; x < cx + s; x++)
                try_source(ip, tx, ty, x, y, &m);
    }
    return m;
}

/*
 * Copies the unknown pixels: the mean of the sources whose cost is within twice the best's (one when
 * blend is 1): averaging a few near-equal matches keeps structure and loses the copy's own noise.
 */
static void fill_patch(inpaint *ip, int tx, int ty, const match *m, float c, uint64_t *filled)
{
    int r = ip->r, n = 1;
    while (n < m->n && m->cost[n] <= 2.0 * m->cost[0] + 1.0)
        n++;
    for (int dv = -r; dv <= r; dv++)
        for (int du = -r; du <= r; du++) {
            int u = tx + du, v = ty + dv;
            if (u < 0 || v < 0 || u >= ip->w || v >= ip->h)
                continue;
            size_t i = (size_t)v * ip->w + u;
            if (!ip->hole[i])
                continue;
            uint8_t *d = ip->rgb + (size_t)v * ip->stride + 3 * (size_t)u;
            int sum[3] = { 0, 0, 0 };
            for (int j = 0; j < n; j++) {
                const uint8_t *src = ip->rgb + (size_t)(m->y[j] + dv) * ip->stride + 3 * (size_t)(m->x[j] + du);
                sum[0] += src[0], sum[1] += src[1], sum[2] += src[2];
            }
            for (int ch = 0; ch < 3; ch++)
                d[ch] = (uint8_t)((sum[ch] + n / 2) / n);
            ip->luma[i] = 0.299f * d[0] + 0.587f * d[1] + 0.114f * d[2];
            ip->hole[i] = 0;
            ip->conf[i] = c;
            (*filled)++;
        }
}

/* After a fill: new front pixels and fresh priorities within reach of the patch. */
static int refresh(inpaint *ip, int tx, int ty)
{
    int k = 2 * ip->r + 1;
    for (int v = ty - k; v <= ty + k; v++)
        for (int u = tx - k; u <= tx + k; u++) {
            if (u < 0 || v < 0 || u >= ip->w || v >= ip->h || !is_front(ip, u, v))
                continue;
            ip->prio[(size_t)v * ip->w + u] = priority(ip, u, v);
            if (front_push(ip, u, v))
                return -ENOMEM;
        }
    return 0;
}

/* Takes the highest-priority front pixel out of the list (dropping filled ones); -1 when none is left. */
static int32_t front_best(inpaint *ip)
{
    size_t best = SIZE_MAX, k = 0;
    for (size_t j = 0; j < ip->n_front; j++) {
        int32_t i = ip->front[j];
        if (!ip->hole[i]) {
            ip->onfront[i] = 0;
            continue;
        }
        ip->front[k] = i;
        if (best == SIZE_MAX || ip->prio[i] > ip->prio[ip->front[best]])
            best = k;
        k++;
    }
    ip->n_front = k;
    return best == SIZE_MAX ? -1 : ip->front[best];
}

static int setup(inpaint *ip, const uint8_t *mask, const sp_inpaint_settings *s, uint64_t *holes)
{
    size_t n = (size_t)ip->w * ip->h, W = (size_t)ip->w + 1;
    ip->hole = calloc(n, 1), ip->onfront = calloc(n, 1);
    ip->guide = malloc(3 * n);
    ip->conf = malloc(n * sizeof(float)), ip->prio = calloc(n, sizeof(float)), ip->luma = malloc(n * sizeof(float));
    ip->integral = calloc(W * ((size_t)ip->h + 1), sizeof(uint32_t));
    if (!ip->hole || !ip->guide || !ip->onfront || !ip->conf || !ip->prio || !ip->luma || !ip->integral)
        return -ENOMEM;
    for (int y = 0; y < ip->h; y++) {
        uint32_t row = 0;
        for (int x = 0; x < ip->w; x++) {
            size_t i = (size_t)y * ip->w + x;
            const uint8_t *p = ip->rgb + (size_t)y * ip->stride + 3 * (size_t)x;
            ip->hole[i] = mask[i] != 0;
            *holes += ip->hole[i];
            ip->conf[i] = ip->hole[i] ? 0.0f : 1.0f;
            ip->luma[i] = 0.299f * p[0] + 0.587f * p[1] + 0.114f * p[2];
            row += ip->hole[i];
            ip->integral[(size_t)(y + 1) * W + x + 1] = ip->integral[(size_t)y * W + x + 1] + row;
        }
    }
    if (*holes && make_guide(ip))
        return -ENOMEM;
    int side = ip->w < ip->h ? ip->w : ip->h;
    ip->R = s->search_radius > 0 ? s->search_radius : (side / 6 > 24 ? side / 6 : 24);
    ip->budget = s->max_candidates;
    return 0;
}

static void teardown(inpaint *ip)
{
    free(ip->hole), free(ip->guide), free(ip->onfront), free(ip->conf), free(ip->prio), free(ip->luma), free(ip->integral);
    free(ip->front);
}

/* No whole source patch anywhere: nothing to copy from. */
static int any_source(const inpaint *ip)
{
    for (int y = ip->r; y < ip->h - ip->r; y++)
        for (int x = ip->r; x < ip->w - ip->r; x++)
            if (source_ok(ip, x, y))
                return 1;
    return 0;
}

/* A target no window reaches: search the whole image (slow, but only where the local window is all hole). */
static match search_anywhere(const inpaint *ip, int tx, int ty)
{
    int R = ip->w > ip->h ? ip->w : ip->h;
    return search(ip, tx, ty, R);
}

static int run(inpaint *ip, uint64_t *filled, uint64_t *patches)
{
    for (int y = 0; y < ip->h; y++)
        for (int x = 0; x < ip->w; x++)
            if (is_front(ip, x, y)) {
                ip->prio[(size_t)y * ip->w + x] = priority(ip, x, y);
                if (front_push(ip, x, y))
                    return -ENOMEM;
            }
    int32_t i;
    while ((i = front_best(ip)) >= 0) {
        int tx = i % ip->w, ty = i / ip->w;
        match m = search(ip, tx, ty, ip->R);
        if (!m.n)
            m = search_anywhere(ip, tx, ty);
        if (!m.n)
            return SP_ENODATA; /* not reached: any_source said a source exists */
        fill_patch(ip, tx, ty, &m, confidence(ip, tx, ty), filled);
        (*patches)++;
        if (refresh(ip, tx, ty))
            return -ENOMEM;
    }
    return 0;
}

int sp_inpaint_exemplar(uint8_t *rgb, uint32_t width, uint32_t height, uint32_t stride, const uint8_t *mask,
                        const sp_inpaint_settings *s, sp_inpaint_report *report)
{
    sp_inpaint_settings def;
    sp_inpaint_default_settings(&def);
    s = s ? s : &def;
    if (!rgb || !mask || width == 0 || height == 0 || width > 32768 || height > 32768 || stride < 3 * width ||
        s->patch_radius < 1 || s->patch_radius > 8 || s->search_radius < 0 || s->blend < 1 || s->blend > MAX_BLEND)
        return -EINVAL;
    inpaint ip = { .rgb = rgb, .stride = stride, .w = (int)width, .h = (int)height, .r = s->patch_radius,
                   .blend = s->blend };
    uint64_t holes = 0, filled = 0, patches = 0;
    int ret = setup(&ip, mask, s, &holes);
    if (!ret && holes && !any_source(&ip))
        ret = SP_ENODATA;
    if (!ret && holes)
        ret = run(&ip, &filled, &patches);
    teardown(&ip);
    if (!ret && report)
        *report = (sp_inpaint_report){ filled, patches };
    return ret;
}
