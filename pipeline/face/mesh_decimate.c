/* SPDX-License-Identifier: MIT */
/*
 * Half-edge collapse u -> v (u disappears, v keeps its position) in order of
 * cost = importance * (quadric error of v for the planes around u and v + a
 * small edge-length term that keeps flat regions evenly sampled). A binary
 * heap holds candidates with the vertex versions they were computed for;
 * stale or no longer valid entries are dropped when popped.
 */
#include "mesh_decimate.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define EDGE_TERM 0.02       /* weight of |u - v|^2 against squared plane distances */
#define BORDER_WEIGHT 10.0   /* quadric weight of the planes that keep mesh borders in place */
#define MIN_NORMAL_COS 0.3   /* refuse collapses that turn a triangle by more than ~73 degrees */
#define MAX_WEDGES 16

typedef struct adj_list {
    uint32_t *t;
    uint32_t n, cap;
} adj_list;

typedef struct heap_item {
    double cost;
    uint32_t u, v, ver_u, ver_v;
} heap_item;

typedef struct dctx {
    uint32_t nv, nt, alive_tris;
    const float *pos, *uvs;
    uint32_t *tv, *tuv;
    uint8_t *tri_alive, *v_alive;
    uint32_t *ver, *mark_u, stamp;
    adj_list *adj;
    double *Q;
    const uint8_t *locked;
    const float *imp;
    heap_item *heap;
    size_t hn, hcap;
} dctx;

/* ---- small helpers ---- */

static void vsub(const float *a, const float *b, double o[3])
{
    for (int k = 0; k < 3; k++)
        o[k] = (double)a[k] - (double)b[k];
}

static void cross(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

static double dot3(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static void normal_of(const float *a, const float *b, const float *c, double n[3])
{
    double e1[3], e2[3];
    vsub(b, a, e1);
    vsub(c, a, e2);
    cross(e1, e2, n);
}

static double uv_area(const float *a, const float *b, const float *c)
{
    return ((double)b[0] - (double)a[0]) * ((double)c[1] - (double)a[1]) -
           ((double)c[0] - (double)a[0]) * ((double)b[1] - (double)a[1]);
}

static int corner_of(const dctx *d, uint32_t t, uint32_t v)
{
    for (int k = 0; k < 3; k++)
        if (d->tv[t * 3 + k] == v)
            return k;
    return -1;
}

static const float *P(const dctx *d, uint32_t v) { return d->pos + (size_t)v * 3; }
static const float *UV(const dctx *d, uint32_t uv) { return d->uvs + (size_t)uv * 2; }

/* ---- quadrics: symmetric 4x4 as 10 doubles ---- */

static void quadric_add_plane(double *q, const double n[3], double dist, double w)
{
    double p[4] = { n[0], n[1], n[2], dist };
    int k = 0;
    for (int i = 0; i < 4; i++)
        for (int j = i; j < 4; j++)
            q[k++] += w * p[i] * p[j];
}

static double quadric_eval(const double *q, const float *pf)
{
    double p[4] = { (double)pf[0], (double)pf[1], (double)pf[2], 1.0 }, s = 0;
    int k = 0;
    for (int i = 0; i < 4; i++)
        for (int j = i; j < 4; j++)
            s += (i == j ? 1.0 : 2.0) * q[k++] * p[i] * p[j];
    return s;
}

/* ---- adjacency ---- */

static int adj_push(adj_list *a, uint32_t t)
{
    if (a->n == a->cap) {
        uint32_t cap = a->cap ? a->cap * 2 : 8;
        uint32_t *n = realloc(a->t, sizeof(uint32_t) * cap);
        if (!n)
            return -ENOMEM;
        a->t = n;
        a->cap = cap;
    }
    a->t[a->n++] = t;
    return 0;
}

static void adj_compact(dctx *d, uint32_t v)
{
    adj_list *a = &d->adj[v];
    uint32_t n = 0;
    for (uint32_t i = 0; i < a->n; i++)
        if (d->tri_alive[a->t[i]])
            a->t[n++] = a->t[i];
    a->n = n;
}

static uint32_t edge_count(const dctx *d, uint32_t u, uint32_t v)
{
    uint32_t c = 0;
    const adj_list *a = &d->adj[u];
    for (uint32_t i = 0; i < a->n; i++)
        if (d->tri_alive[a->t[i]] && corner_of(d, a->t[i], v) >= 0)
            c++;
    return c;
}

static int is_border_vertex(const dctx *d, uint32_t u)
{
    const adj_list *a = &d->adj[u];
    for (uint32_t i = 0; i < a->n; i++) {
        uint32_t t = a->t[i];
        if (!d->tri_alive[t])
            continue;
        for (int k = 0; k < 3; k++) {
            uint32_t w = d->tv[t * 3 + k];
            if (w != u && edge_count(d, u, w) == 1)
                return 1;
        }
    }
    return 0;
}

/* Sets mark[w] = stamp for u and every vertex sharing a triangle with u. */
static void mark_neighbours(dctx *d, uint32_t u, uint32_t *mark)
{
    const adj_list *a = &d->adj[u];
    for (uint32_t i = 0; i < a->n; i++)
        if (d->tri_alive[a->t[i]])
            for (int k = 0; k < 3; k++)
                mark[d->tv[a->t[i] * 3 + k]] = d->stamp;
}

/* Link condition: u and v share exactly the vertices opposite their common edge. */
static int link_ok(dctx *d, uint32_t u, uint32_t v, uint32_t shared_tris)
{
    d->stamp++;
    mark_neighbours(d, u, d->mark_u);
    uint32_t common = 0;
    const adj_list *a = &d->adj[v];
    for (uint32_t i = 0; i < a->n; i++) {
        uint32_t t = a->t[i];
        if (!d->tri_alive[t])
            continue;
        for (int k = 0; k < 3; k++) {
            uint32_t w = d->tv[t * 3 + k];
            if (w != u && w != v && d->mark_u[w] == d->stamp) {
                common++;
                d->mark_u[w] = 0; /* count each shared vertex once */
            }
        }
    }
    return common == shared_tris;
}

/* ---- collapse validity ---- */

typedef struct wedge_map {
    uint32_t n, from[MAX_WEDGES], to[MAX_WEDGES];
} wedge_map;

/* Each UV of u must continue as the UV that v has on the same side of any seam. */
static int build_wedges(const dctx *d, uint32_t u, uint32_t v, wedge_map *w)
{
    w->n = 0;
    const adj_list *a = &d->adj[u];
    for (uint32_t i = 0; i < a->n; i++) {
        uint32_t t = a->t[i];
        int ku = corner_of(d, t, u), kv = corner_of(d, t, v);
        if (!d->tri_alive[t] || kv < 0)
            continue;
        uint32_t from = d->tuv[t * 3 + (uint32_t)ku], to = d->tuv[t * 3 + (uint32_t)kv], j;
        for (j = 0; j < w->n && w->from[j] != from; j++)
            ;
        if (j < w->n) {
            if (w->to[j] != to)
                return 0;
            continue;
        }
        if (w->n == MAX_WEDGES)
            return 0;
        w->from[w->n] = from;
        w->to[w->n++] = to;
    }
    return 1;
}

static int wedge_lookup(const wedge_map *w, uint32_t from, uint32_t *to)
{
    for (uint32_t j = 0; j < w->n; j++)
        if (w->from[j] == from) {
            *to = w->to[j];
            return 1;
        }
    return 0;
}

/* The triangles that keep u (now v) must not fold in 3-D or in UV space. */
static int fan_ok(const dctx *d, uint32_t u, uint32_t v, const wedge_map *w)
{
    const adj_list *a = &d->adj[u];
    for (uint32_t i = 0; i < a->n; i++) {
        uint32_t t = a->t[i];
        if (!d->tri_alive[t] || corner_of(d, t, v) >= 0)
            continue;
        int ku = corner_of(d, t, u);
        const float *p[3], *q[3], *uvp[3], *uvq[3];
        uint32_t mapped;
        if (!wedge_lookup(w, d->tuv[t * 3 + (uint32_t)ku], &mapped))
            return 0;
        for (int k = 0; k < 3; k++) {
            p[k] = q[k] = P(d, d->tv[t * 3 + k]);
            uvp[k] = uvq[k] = UV(d, d->tuv[t * 3 + k]);
        }
        q[ku] = P(d, v);
        uvq[ku] = UV(d, mapped);
        double n0[3], n1[3];
        normal_of(p[0], p[1], p[2], n0);
        normal_of(q[0], q[1], q[2], n1);
        double l0 = sqrt(dot3(n0, n0)), l1 = sqrt(dot3(n1, n1));
        if (!(l1 > 1e-14) || dot3(n0, n1) < MIN_NORMAL_COS * l0 * l1)
            return 0;
        double a0 = uv_area(uvp[0], uvp[1], uvp[2]), a1 = uv_area(uvq[0], uvq[1], uvq[2]);
        if (!(fabs(a1) > 1e-12) || (a0 > 0) != (a1 > 0))
            return 0;
    }
    return 1;
}

static int collapse_ok(dctx *d, uint32_t u, uint32_t v, wedge_map *w)
{
    if (!d->v_alive[u] || !d->v_alive[v] || (d->locked && d->locked[u]))
        return 0;
    uint32_t shared = edge_count(d, u, v);
    if (shared == 0 || shared > 2)
        return 0;
    if (is_border_vertex(d, u) && shared != 1)
        return 0; /* a border vertex may only slide along its border */
    return link_ok(d, u, v, shared) && build_wedges(d, u, v, w) && fan_ok(d, u, v, w);
}

/* ---- heap ---- */

static int heap_push(dctx *d, heap_item it)
{
    if (d->hn == d->hcap) {
        size_t cap = d->hcap ? d->hcap * 2 : 4096;
        heap_item *n = realloc(d->heap, sizeof(*n) * cap);
        if (!n)
            return -ENOMEM;
        d->heap = n;
        d->hcap = cap;
    }
    size_t i = d->hn++;
    while (i > 0 && d->heap[(i - 1) / 2].cost > it.cost) {
        d->heap[i] = d->heap[(i - 1) / 2];
        i = (i - 1) / 2;
    }
    d->heap[i] = it;
    return 0;
}

static heap_item heap_pop(dctx *d)
{
    heap_item top = d->heap[0], last = d->heap[--d->hn];
    size_t i = 0;
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= d->hn)
            break;
        if (c + 1 < d->hn && d->heap[c + 1].cost < d->heap[c].cost)
            c++;
        if (d->heap[c].cost >= last.cost)
            break;
        d->heap[i] = d->heap[c];
        i = c;
    }
    if (d->hn)
        d->heap[i] = last;
    return top;
}

static int push_candidate(dctx *d, uint32_t u, uint32_t v)
{
    if (d->locked && d->locked[u])
        return 0;
    double q[10];
    for (int k = 0; k < 10; k++)
        q[k] = d->Q[(size_t)u * 10 + k] + d->Q[(size_t)v * 10 + k];
    double e[3];
    vsub(P(d, u), P(d, v), e);
    double imp = d->imp ? fmax((double)d->imp[u], (double)d->imp[v]) : 1.0;
    double cost = imp * (fmax(0.0, quadric_eval(q, P(d, v))) + EDGE_TERM * dot3(e, e));
    return heap_push(d, (heap_item){ cost, u, v, d->ver[u], d->ver[v] });
}

/* ---- collapse ---- */

static int push_around(dctx *d, uint32_t v)
{
    const adj_list *a = &d->adj[v];
    for (uint32_t i = 0; i < a->n; i++)
        for (int k = 0; k < 3; k++) {
            uint32_t w = d->tv[a->t[i] * 3 + k];
            if (w == v)
                continue;
            int err = push_candidate(d, w, v);
            if (!err)
                err = push_candidate(d, v, w);
            if (err)
                return err;
        }
    return 0;
}

static int collapse(dctx *d, uint32_t u, uint32_t v, const wedge_map *w)
{
    adj_list *a = &d->adj[u];
    for (uint32_t i = 0; i < a->n; i++) {
        uint32_t t = a->t[i];
        if (!d->tri_alive[t])
            continue;
        if (corner_of(d, t, v) >= 0) {
            d->tri_alive[t] = 0;
            d->alive_tris--;
            continue;
        }
        int ku = corner_of(d, t, u);
        uint32_t mapped = 0;
        wedge_lookup(w, d->tuv[t * 3 + (uint32_t)ku], &mapped);
        d->tv[t * 3 + (uint32_t)ku] = v;
        d->tuv[t * 3 + (uint32_t)ku] = mapped;
        int err = adj_push(&d->adj[v], t);
        if (err)
            return err;
    }
    a->n = 0;
    d->v_alive[u] = 0;
    d->ver[u]++;
    d->ver[v]++;
    for (int k = 0; k < 10; k++)
        d->Q[(size_t)v * 10 + k] += d->Q[(size_t)u * 10 + k];
    adj_compact(d, v);
    return push_around(d, v);
}

/* ---- setup and output ---- */

static int setup(dctx *d, const sp_mesh *in)
{
    d->nv = in->n_vertices;
    d->nt = d->alive_tris = in->n_triangles;
    d->pos = in->positions;
    d->uvs = in->uvs;
    size_t n3 = (size_t)d->nt * 3;
    d->tv = malloc(sizeof(uint32_t) * n3 + 1);
    d->tuv = malloc(sizeof(uint32_t) * n3 + 1);
    d->tri_alive = malloc((size_t)d->nt + 1);
    d->v_alive = malloc((size_t)d->nv + 1);
    d->ver = calloc((size_t)d->nv + 1, sizeof(uint32_t));
    d->mark_u = calloc((size_t)d->nv + 1, sizeof(uint32_t));
    d->adj = calloc((size_t)d->nv + 1, sizeof(adj_list));
    d->Q = calloc((size_t)d->nv * 10 + 1, sizeof(double));
    if (!d->tv || !d->tuv || !d->tri_alive || !d->v_alive || !d->ver || !d->mark_u || !d->adj ||
        !d->Q)
        return -ENOMEM;
    memcpy(d->tv, in->tri_vertices, sizeof(uint32_t) * n3);
    memcpy(d->tuv, in->tri_uvs, sizeof(uint32_t) * n3);
    memset(d->tri_alive, 1, d->nt);
    memset(d->v_alive, 1, d->nv);
    for (uint32_t t = 0; t < d->nt; t++)
        for (int k = 0; k < 3; k++)
            if (adj_push(&d->adj[d->tv[t * 3 + k]], t))
                return -ENOMEM;
    return 0;
}

static void init_quadrics(dctx *d)
{
    for (uint32_t t = 0; t < d->nt; t++) {
        const float *p[3];
        for (int k = 0; k < 3; k++)
            p[k] = P(d, d->tv[t * 3 + k]);
        double n[3];
        normal_of(p[0], p[1], p[2], n);
        double len = sqrt(dot3(n, n));
        if (!(len > 0))
            continue;
        for (int k = 0; k < 3; k++)
            n[k] /= len;
        double p0[3] = { (double)p[0][0], (double)p[0][1], (double)p[0][2] };
        for (int k = 0; k < 3; k++)
            quadric_add_plane(d->Q + (size_t)d->tv[t * 3 + k] * 10, n, -dot3(n, p0), 1.0);
        for (int k = 0; k < 3; k++) { /* border edges get a perpendicular plane */
            uint32_t a = d->tv[t * 3 + k], b = d->tv[t * 3 + (k + 1) % 3];
            if (edge_count(d, a, b) != 1)
                continue;
            double e[3], m[3];
            vsub(P(d, b), P(d, a), e);
            cross(e, n, m);
            double ml = sqrt(dot3(m, m));
            if (!(ml > 0))
                continue;
            for (int c = 0; c < 3; c++)
                m[c] /= ml;
            double pa[3] = { (double)P(d, a)[0], (double)P(d, a)[1], (double)P(d, a)[2] };
            quadric_add_plane(d->Q + (size_t)a * 10, m, -dot3(m, pa), BORDER_WEIGHT);
            quadric_add_plane(d->Q + (size_t)b * 10, m, -dot3(m, pa), BORDER_WEIGHT);
        }
    }
}

static uint32_t max_uv_index(const dctx *d)
{
    uint32_t n = 0;
    for (size_t i = 0; i < (size_t)d->nt * 3; i++)
        if (d->tuv[i] + 1 > n)
            n = d->tuv[i] + 1;
    return n;
}

static void fill_output(const dctx *d, const uint32_t *vmap, const uint32_t *uvmap, uint32_t n_uv_in,
                        sp_mesh *out, uint32_t *origin)
{
    for (uint32_t v = 0; v < d->nv; v++)
        if (vmap[v] != UINT32_MAX) {
            memcpy(out->positions + (size_t)vmap[v] * 3, P(d, v), sizeof(float) * 3);
            origin[vmap[v]] = v;
        }
    for (uint32_t uv = 0; uv < n_uv_in; uv++)
        if (uvmap[uv] != UINT32_MAX)
            memcpy(out->uvs + (size_t)uvmap[uv] * 2, UV(d, uv), sizeof(float) * 2);
    size_t o = 0;
    for (uint32_t t = 0; t < d->nt; t++) {
        if (!d->tri_alive[t])
            continue;
        for (int k = 0; k < 3; k++, o++) {
            out->tri_vertices[o] = vmap[d->tv[t * 3 + k]];
            out->tri_uvs[o] = uvmap[d->tuv[t * 3 + k]];
        }
    }
}

/* Compacts the surviving vertices, UVs and triangles into a new mesh. */
static int emit(const dctx *d, sp_mesh *out, uint32_t **origin)
{
    uint32_t n_uv_in = max_uv_index(d);
    uint32_t *vmap = malloc(sizeof(uint32_t) * ((size_t)d->nv + 1));
    uint32_t *uvmap = malloc(sizeof(uint32_t) * ((size_t)n_uv_in + 1));
    int err = vmap && uvmap ? 0 : -ENOMEM;
    uint32_t nv = 0, nuv = 0;
    if (!err) {
        memset(vmap, 0xff, sizeof(uint32_t) * d->nv);
        memset(uvmap, 0xff, sizeof(uint32_t) * n_uv_in);
        for (uint32_t t = 0; t < d->nt; t++)
            for (int k = 0; d->tri_alive[t] && k < 3; k++) {
                uint32_t v = d->tv[t * 3 + k], uv = d->tuv[t * 3 + k];
                if (vmap[v] == UINT32_MAX)
                    vmap[v] = nv++;
                if (uvmap[uv] == UINT32_MAX)
                    uvmap[uv] = nuv++;
            }
        err = sp_mesh_alloc(out, nv, nuv, d->alive_tris);
    }
    if (!err) {
        *origin = malloc(sizeof(uint32_t) * ((size_t)nv + 1));
        if (*origin)
            fill_output(d, vmap, uvmap, n_uv_in, out, *origin);
        else {
            sp_mesh_free(out);
            err = -ENOMEM;
        }
    }
    free(vmap);
    free(uvmap);
    return err;
}

static void dctx_free(dctx *d)
{
    free(d->tv);
    free(d->tuv);
    free(d->tri_alive);
    free(d->v_alive);
    free(d->ver);
    free(d->mark_u);
    for (uint32_t v = 0; d->adj && v < d->nv; v++)
        free(d->adj[v].t);
    free(d->adj);
    free(d->Q);
    free(d->heap);
}

int mesh_decimate(const sp_mesh *in, const uint8_t *locked, const float *importance, uint32_t target_triangles,
                  sp_mesh *out, uint32_t **origin)
{
    if (!in || !out || !origin || sp_mesh_validate(in) != 0)
        return -EINVAL;
    memset(out, 0, sizeof(*out));
    *origin = NULL;
    dctx d = { .locked = locked, .imp = importance };
    int err = setup(&d, in);
    if (!err) {
        init_quadrics(&d);
        for (uint32_t t = 0; !err && t < d.nt; t++)
            for (int k = 0; !err && k < 3; k++) {
                uint32_t a = d.tv[t * 3 + k], b = d.tv[t * 3 + (k + 1) % 3];
                err = push_candidate(&d, a, b);
                if (!err)
                    err = push_candidate(&d, b, a);
            }
    }
    while (!err && d.alive_tris > target_triangles && d.hn > 0) {
        heap_item it = heap_pop(&d);
        wedge_map w;
        if (it.ver_u != d.ver[it.u] || it.ver_v != d.ver[it.v] || !collapse_ok(&d, it.u, it.v, &w))
            continue;
        err = collapse(&d, it.u, it.v, &w);
    }
    if (!err)
        err = emit(&d, out, origin);
    dctx_free(&d);
    return err;
}
