/* SPDX-License-Identifier: MIT */
/*
 * Scene-probe numerics: the median sorting network against a sort, the
 * clean plate in bounded memory, the robust scale-model fit (outliers,
 * degenerate inputs that must say what cannot be estimated, extremes), the
 * reservoir, the plane/shadow JSON round trip with its error cases, and the
 * occlusion map settled as objects (specks dropped, one depth per occluder).
 */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "pipeline/probe/probe_internal.h"

static uint64_t rng = 12345;

static unsigned rnd(unsigned n)
{
    return (unsigned)(probe_rand(&rng) % n);
}

static int cmp_u8(const void *a, const void *b)
{
    return *(const uint8_t *)a - *(const uint8_t *)b;
}

/* Every width 1..32 on random, constant and extreme data, including a tail shorter than a block. */
static void test_median_network(void)
{
    enum { N = 1000 };
    static uint8_t data[32][N], out[N];
    const uint8_t *in[32];
    for (unsigned k = 1; k <= 32; k++) {
        for (unsigned mode = 0; mode < 3; mode++) {
            for (unsigned j = 0; j < k; j++) {
                for (unsigned i = 0; i < N; i++)
                    data[j][i] = mode == 0 ? (uint8_t)rnd(256) : mode == 1 ? 77 : (rnd(2) ? 255 : 0);
                in[j] = data[j];
            }
            CHECK(probe_median_bytes(in, k, N, out) == 0);
            int bad = 0;
            for (unsigned i = 0; i < N; i++) {
                uint8_t v[32];
                for (unsigned j = 0; j < k; j++)
                    v[j] = data[j][i];
                qsort(v, k, 1, cmp_u8);
                bad += out[i] != v[k / 2];
            }
            CHECK_MSG(bad == 0, "k=%u mode=%u: %d wrong medians", k, mode, bad);
        }
    }
    CHECK(probe_median_bytes(in, 0, N, out) == -EINVAL);
    CHECK(probe_median_bytes(in, 33, N, out) == -EINVAL);
}

/* A square crosses a static background: once the ring is full the plate is the background exactly. */
static void test_plate(void)
{
    enum { W = 40, H = 30 };
    probe_plate pl;
    CHECK(plate_open(&pl, W, H, 5, 1000000000, 0) == 0);
    static uint8_t bg[W * H * 3], frame[W * H * 3];
    for (unsigned i = 0; i < sizeof(bg); i++)
        bg[i] = (uint8_t)(i * 7 % 251);
    int updates = 0;
    for (int f = 0; f < 30; f++) {
        memcpy(frame, bg, sizeof(frame));
        for (int y = 10; y < 20; y++)
            for (int x = 4 * f - 20; x < 4 * f - 14; x++) /* over any pixel for less than a sample */
                if (x >= 0 && x < W)
                    memset(frame + (y * W + x) * 3, 255, 3);
        updates += plate_offer(&pl, frame, (int64_t)f * 100000000, NULL); /* 10 fps, sample every 200 ms */
    }
    CHECK(plate_ready(&pl));
    CHECK_MSG(updates >= 8 && updates <= 12, "%d plate updates", updates);
    CHECK(memcmp(pl.median, bg, sizeof(bg)) == 0);
    plate_close(&pl);
    CHECK(plate_open(&pl, W, H, 2, 1000, 0) == -EINVAL);
    CHECK(plate_open(&pl, W, H, 5, 0, 0) == -EINVAL);
}

/* h = a x + b y + c on a grid, a share of wild outliers; n records of {x, y, h}. */
static unsigned make_plane_obs(float *rec, unsigned n, double a, double b, double c, double outliers)
{
    for (unsigned i = 0; i < n; i++) {
        double x = 20 + rnd(600), y = 150 + rnd(400), h = a * x + b * y + c;
        if (rnd(1000) < outliers * 1000)
            h *= 0.3 + 1.5 * rnd(1000) / 1000.0; /* groups, bags, half-hidden people */
        else
            h *= 1.0 + 0.06 * ((double)rnd(1000) / 1000.0 - 0.5); /* people differ a little */
        rec[3 * i] = (float)x, rec[3 * i + 1] = (float)y, rec[3 * i + 2] = (float)h;
    }
    return n;
}

static void test_plane_robust(void)
{
    static float rec[3 * 2000];
    sp_probe_plane pl = { 0 };
    uint64_t r = 7;
    unsigned n = make_plane_obs(rec, 2000, 0.01, 0.3, -20, 0.3);
    plane_fit(rec, n, 3, 768, 576, &r, &pl);
    CHECK_EQ_INT(pl.status, SP_PROBE_PLANE_OK);
    double err = 0;
    for (int x = 100; x <= 700; x += 200)
        for (int y = 200; y <= 550; y += 50) {
            double truth = 0.01 * x + 0.3 * y - 20, h = sp_probe_plane_height(&pl, x, y);
            err = fmax(err, fabs(h - truth) / truth);
        }
    CHECK_MSG(err < 0.02, "max relative error %.4f with 30%% outliers", err);
    CHECK(pl.n_inliers > 1200 && pl.n_inliers < 1700);
    CHECK(pl.residual_rel > 0 && pl.residual_rel < 0.03);
    CHECK(plane_median_error(&pl, rec, n, 3) < 0.03);
}

static void test_plane_degenerate(void)
{
    static float rec[3 * 100];
    sp_probe_plane pl = { 0 };
    uint64_t r = 9;
    plane_fit(rec, 0, 3, 640, 480, &r, &pl);
    CHECK_EQ_INT(pl.status, SP_PROBE_PLANE_NONE);
    CHECK(strstr(pl.note, "cannot be estimated") != NULL);
    CHECK(isnan(sp_probe_plane_height(&pl, 100, 100)));

    /* one person, seen many times at (nearly) one spot */
    for (int i = 0; i < 50; i++)
        rec[3 * i] = 300.0f + (float)(i % 3), rec[3 * i + 1] = 400.0f, rec[3 * i + 2] = 120.0f + (float)(i % 2);
    plane_fit(rec, 50, 3, 640, 480, &r, &pl);
    CHECK_EQ_INT(pl.status, SP_PROBE_PLANE_ONE_POINT);
    CHECK_NEAR(sp_probe_plane_height(&pl, 301, 400), 120.5, 1.0);
    CHECK(isnan(sp_probe_plane_height(&pl, 100, 100))); /* far from where anyone stood */
    CHECK(strstr(pl.note, "cannot be estimated") != NULL);

    /* everyone on one image row: the height along it is known, across it not */
    for (int i = 0; i < 60; i++) {
        double x = 50 + 9 * i;
        rec[3 * i] = (float)x, rec[3 * i + 1] = 300.0f, rec[3 * i + 2] = (float)(80 + 0.05 * x);
    }
    plane_fit(rec, 60, 3, 640, 480, &r, &pl);
    CHECK_EQ_INT(pl.status, SP_PROBE_PLANE_LINE);
    CHECK_NEAR(sp_probe_plane_height(&pl, 400, 300), 100.0, 0.5);
    CHECK(isnan(sp_probe_plane_height(&pl, 400, 100)));
    CHECK(fabs(pl.line_dy) < 1e-6 && fabs(fabs(pl.line_dx) - 1) < 1e-6);

    /* two observations only */
    plane_fit(rec, 2, 3, 640, 480, &r, &pl);
    CHECK_EQ_INT(pl.status, SP_PROBE_PLANE_ONE_POINT);
}

/* Extremes: zero and negative heights, the largest image, huge coordinates: never NaN, never garbage. */
static void test_plane_extremes(void)
{
    static float rec[3 * 64];
    sp_probe_plane pl = { 0 };
    uint64_t r = 3;
    for (int i = 0; i < 64; i++)
        rec[3 * i] = (float)(i * 200), rec[3 * i + 1] = (float)(i * 150 % 16000), rec[3 * i + 2] = 0.0f;
    plane_fit(rec, 64, 3, 16384, 16384, &r, &pl);
    CHECK(pl.status == SP_PROBE_PLANE_NONE || isfinite(pl.a + pl.b + pl.c));
    for (int i = 0; i < 64; i++)
        rec[3 * i + 2] = -5.0f;
    plane_fit(rec, 64, 3, 16384, 16384, &r, &pl);
    CHECK(pl.status == SP_PROBE_PLANE_NONE || isfinite(pl.a + pl.b + pl.c));
    CHECK(isnan(sp_probe_plane_height(&pl, NAN, 3)));
    CHECK(isnan(sp_probe_plane_height(NULL, 3, 3)));
    double A[9] = { 1, 2, 3, 2, 4, 6, 1, 1, 1 }, b[3] = { 1, 2, 3 }, x[3];
    CHECK(probe_solve3(A, b, x) == -1); /* singular */
    double I[9] = { 1e-300, 0, 0, 0, 1e-300, 0, 0, 0, 1e-300 };
    CHECK(probe_solve3(I, b, x) == 0 && isfinite(x[0]));
}

static void test_reservoir(void)
{
    probe_reservoir res;
    CHECK(reservoir_open(&res, 100, 2, 5) == 0);
    unsigned late = 0;
    for (int i = 0; i < 10000; i++) {
        float rec[2] = { (float)i, 1.0f };
        reservoir_add(&res, rec);
    }
    CHECK_EQ_INT(res.n, 100);
    CHECK(res.seen == 10000);
    for (unsigned i = 0; i < res.n; i++)
        late += res.v[2 * i] >= 5000.0f;
    CHECK_MSG(late > 30 && late < 70, "%u of 100 kept from the second half", late); /* uniform: about 50 */
    reservoir_close(&res);
    CHECK(reservoir_open(&res, 0, 2, 5) == -EINVAL);
}

static void test_params_json(void)
{
    sp_probe_plane pl = { .status = SP_PROBE_PLANE_OK, .a = 0.0123, .b = 0.3456, .c = -7.5, .n_observations = 321,
                          .n_inliers = 300, .residual_rel = 0.041, .holdout_n = 17, .holdout_error_rel = NAN };
    snprintf(pl.note, sizeof(pl.note), "a \"quoted\" note\nwith a newline");
    sp_probe_shadow sh = { .present = 1,
                           .ox = { 0.5, 0.1, -0.2 },
                           .oy = { 0.8, 0, -0.7 },
                           .ratio = { 0.4, 0.42, 0.5 },
                           .n_shadows = 40,
                           .n_candidates = 50,
                           .direction_spread_deg = 12,
                           .contact_present = 1,
                           .contact = { 0.81, 0.87, 0.93, 0.97, 0.99, 1 },
                           .n_contact = 77 };
    snprintf(sh.contact_note, sizeof(sh.contact_note), "learned \"here\"");
    char *json = NULL;
    CHECK(sp_probe_params_to_json(&pl, &sh, NULL, 320, 240, &json) == 0);
    sp_probe_plane p2;
    sp_probe_shadow s2;
    uint32_t w = 0, h = 0;
    CHECK(json && sp_probe_params_from_json(json, strlen(json), &p2, &s2, &w, &h) == 0);
    CHECK(w == 320 && h == 240);
    CHECK(p2.status == SP_PROBE_PLANE_OK && p2.a == pl.a && p2.b == pl.b && p2.c == pl.c);
    CHECK(p2.n_inliers == 300 && isnan(p2.holdout_error_rel) && !strcmp(p2.note, pl.note));
    CHECK(s2.present && s2.ox[2] == -0.2 && s2.oy[0] == 0.8 && s2.ratio[1] == 0.42);
    CHECK(s2.contact_present && s2.contact[0] == 0.81 && s2.contact[5] == 1 && s2.n_contact == 77 &&
          !strcmp(s2.contact_note, sh.contact_note));
    free(json);
    /* a probe directory from before the contact shadow: loads, without one */
    static const char old_dir[] =
        "{\"format\":\"sunprobe-probe\",\"width\":3,\"height\":3,\"plane\":{\"status\":\"none\",\"line\":[0,0,0,0]},"
        "\"shadow\":{\"present\":false,\"ox\":[0,0,0],\"oy\":[0,0,0],\"ratio\":[0,0,0]}}";
    CHECK(sp_probe_params_from_json(old_dir, strlen(old_dir), &p2, &s2, &w, &h) == 0 && !s2.contact_present);

    static const char *const bad[] = {
        "{}",
        "{\"format\":\"other\",\"width\":3,\"height\":3}",
        "{\"format\":\"sunprobe-probe\",\"width\":0,\"height\":3,\"plane\":{},\"shadow\":{}}",
        "{\"format\":\"sunprobe-probe\",\"width\":3,\"height\":3,\"plane\":{\"status\":\"weird\",\"line\":[0,0,0,0]},"
        "\"shadow\":{\"present\":false,\"ox\":[0,0,0],\"oy\":[0,0,0],\"ratio\":[0,0,0]}}",
        "{\"format\":\"sunprobe-probe\",\"width\":3,\"height\":3,\"plane\":{\"status\":\"ok\",\"a\":null,\"b\":1,\"c\":"
        "1,"
        "\"line\":[0,0,0,0]},\"shadow\":{\"present\":false,\"ox\":[0,0,0],\"oy\":[0,0,0],\"ratio\":[0,0,0]}}",
        "{\"format\":\"sunprobe-probe\",\"width\":3,\"height\":3,\"plane\":{\"status\":\"none\",\"line\":[0,0,0,0]},"
        "\"shadow\":{\"present\":true,\"ox\":[0,0,0],\"oy\":[0,0,0],\"ratio\":[null,0,0]}}",
        "not json",
        /* the contact shadow: not an object, no "present", a short ring list, a ring missing or out of range */
        "{\"format\":\"sunprobe-probe\",\"width\":3,\"height\":3,\"plane\":{\"status\":\"none\",\"line\":[0,0,0,0]},"
        "\"shadow\":{\"present\":false,\"ox\":[0,0,0],\"oy\":[0,0,0],\"ratio\":[0,0,0],\"contact\":1}}",
        "{\"format\":\"sunprobe-probe\",\"width\":3,\"height\":3,\"plane\":{\"status\":\"none\",\"line\":[0,0,0,0]},"
        "\"shadow\":{\"present\":false,\"ox\":[0,0,0],\"oy\":[0,0,0],\"ratio\":[0,0,0],\"contact\":{\"rings\":[1,1,1,1,"
        "1,1]}}}",
        "{\"format\":\"sunprobe-probe\",\"width\":3,\"height\":3,\"plane\":{\"status\":\"none\",\"line\":[0,0,0,0]},"
        "\"shadow\":{\"present\":false,\"ox\":[0,0,0],\"oy\":[0,0,0],\"ratio\":[0,0,0],"
        "\"contact\":{\"present\":true,\"rings\":[1,1,1,1,1]}}}",
        "{\"format\":\"sunprobe-probe\",\"width\":3,\"height\":3,\"plane\":{\"status\":\"none\",\"line\":[0,0,0,0]},"
        "\"shadow\":{\"present\":false,\"ox\":[0,0,0],\"oy\":[0,0,0],\"ratio\":[0,0,0],"
        "\"contact\":{\"present\":true,\"rings\":[null,1,1,1,1,1]}}}",
        "{\"format\":\"sunprobe-probe\",\"width\":3,\"height\":3,\"plane\":{\"status\":\"none\",\"line\":[0,0,0,0]},"
        "\"shadow\":{\"present\":false,\"ox\":[0,0,0],\"oy\":[0,0,0],\"ratio\":[0,0,0],"
        "\"contact\":{\"present\":true,\"rings\":[1,1,1,1,1,2.5]}}}",
    };
    for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++)
        CHECK_MSG(sp_probe_params_from_json(bad[i], strlen(bad[i]), &p2, &s2, &w, &h) == SP_ECORRUPT, "bad[%zu]", i);
    CHECK(sp_probe_params_to_json(NULL, &sh, NULL, 1, 1, &json) == -EINVAL);
}

/*
 * A post (one column, rows 20-90, people passed behind it with their feet at row 90) carries a sign (rows 20-30,
 * passed behind at row 50 only): one object, one depth. One sign pixel saw a body standing at row 60 in front
 * of it: it keeps its own value. A 3x3 speck at row 70 (a person there is 35 px tall) is dropped; a kerb four
 * rows thick and 20 px long is kept, a line one row thick and as long (inferences strung along a stride) is
 * dropped as torn. A column grouped after the post (17 pixels at row 55, 3 at 95) takes 95, its own 85th
 * percentile: the post's depths must not linger in the histogram. These stand out of the clean plate; a 15 x 15
 * block on plain plate is dropped as plain, while a strip of wrong inferences on plain plate attached to the
 * post stays with it (raised to its depth): the post's outline is long on edges. Without a scale model nothing is
 * dropped.
 */
static void test_occluders(void)
{
    enum { W = 80, H = 100 };
    probe_maps m;
    CHECK(maps_open(&m, W, H, 1) == 0);
    sp_probe_plane pl = { .status = SP_PROBE_PLANE_OK, .a = 0, .b = 0.5, .c = 0 };
    for (int pass = 0; pass < 2; pass++) {
        for (size_t i = 0; i < (size_t)W * H; i++)
            m.occlusion[i] = -1;
        for (int y = 20; y <= 90; y++)
            m.occlusion[y * W + 40] = 90;
        for (int y = 20; y <= 30; y++)
            for (int x = 30; x <= 50; x++)
                m.occlusion[y * W + x] = x == 40 ? 90 : 50;
        size_t seen_px = 25 * W + 33;
        m.vis[seen_px * PROBE_EVIDENCE] = 60;
        m.vis_n[seen_px * PROBE_EVIDENCE] = 1;
        for (int y = 69; y <= 71; y++)
            for (int x = 9; x <= 11; x++)
                m.occlusion[y * W + x] = 70;
        for (int y = 59; y <= 62; y++) /* a person at row 60 is 30 px tall: the kerb's runs are over 0.1 of it */
            for (int x = 55; x < 75; x++)
                m.occlusion[y * W + x] = 60;
        for (int x = 55; x < 75; x++)
            m.occlusion[80 * W + x] = 80;
        for (int y = 30; y < 50; y++)
            m.occlusion[y * W + 77] = y < 47 ? 55 : 95;
        for (size_t i = 0; i < (size_t)W * H; i++) /* the things above stand out of the plate */
            memset(m.clean + 3 * i, m.occlusion[i] >= 0 ? 200 : 100, 3);
        for (int y = 75; y < 90; y++)
            for (int x = 3; x < 18; x++)
                m.occlusion[y * W + x] = 90;
        for (int y = 40; y <= 41; y++)
            for (int x = 41; x <= 52; x++)
                m.occlusion[y * W + x] = 60;
        probe_occluder_stats st;
        sp_probe_plane none = { .status = SP_PROBE_PLANE_NONE };
        occluders_settle(&m, pass == 0 ? &pl : &none, &st);
        CHECK_MSG(st.groups == 6, "%zu groups", st.groups);
        CHECK_MSG(m.occlusion[40 * W + 52] == 90, "the strip on the post: %g", (double)m.occlusion[40 * W + 52]);
        CHECK_MSG(m.occlusion[30 * W + 77] == 95, "the column after the post: %g", (double)m.occlusion[30 * W + 77]);
        CHECK(m.occlusion[25 * W + 45] == 90 && m.occlusion[20 * W + 30] == 90 && m.occlusion[50 * W + 40] == 90);
        CHECK_MSG(m.occlusion[seen_px] == 50, "the pixel a body at row 60 was seen over: %g",
                  (double)m.occlusion[seen_px]);
        CHECK(m.occlusion[60 * W + 55] == 60 && m.occlusion[60 * W + 74] == 60);
        if (pass == 0) {
            CHECK(st.specks == 1 && st.torn == 1 && st.plain == 1 && st.dropped_pixels == 9 + 20 + 225 &&
                  m.occlusion[70 * W + 10] == -1 && m.occlusion[80 * W + 10] == -1);
            CHECK(m.occlusion[80 * W + 55] == -1 && m.occlusion[80 * W + 74] == -1);
            CHECK_MSG(st.raised == 21 * 11 - 11 - 1 + 17 + 24, "%zu raised", st.raised);
        } else {
            CHECK(st.specks == 0 && st.torn == 0 && st.plain == 0 && m.occlusion[70 * W + 10] == 70 &&
                  m.occlusion[80 * W + 60] == 80 && m.occlusion[80 * W + 10] == 90);
        }
    }
    /* extremes: nothing occluding; everything occluding at one depth, and at the last row */
    probe_occluder_stats st;
    for (size_t i = 0; i < (size_t)W * H; i++)
        m.occlusion[i] = -1;
    occluders_settle(&m, &pl, &st);
    CHECK(st.groups == 0 && st.raised == 0);
    for (size_t i = 0; i < (size_t)W * H; i++)
        m.occlusion[i] = i % 2 ? 99 : 5000;
    occluders_settle(&m, &pl, &st);
    CHECK(st.groups == 1 && st.specks == 0 && m.occlusion[1] == 99 && m.occlusion[0] == 5000);
    maps_close(&m);
    probe_maps one;
    CHECK(maps_open(&one, 1, 1, 1) == 0);
    one.occlusion[0] = 0;
    occluders_settle(&one, &pl, &st);
    CHECK(st.groups == 1 && st.specks == 0 && one.occlusion[0] == 0); /* a person at row 0 is 0 px tall */
    maps_close(&one);
}

/*
 * The plain rule's two clauses (occluders.c), a person at row 90 being 45 px tall: a box 4 x 50 that stands out
 * of the plate, joined by a strip 140 x 5 of wrong inferences on plain plate, has 0.27 of its outline on plate
 * edges but 104 edge pixels, over half a person: kept. The same strip joined to a box 2 x 7 (17 edge pixels, 0.06):
 * dropped.
 */
static void test_occluders_plain(void)
{
    enum { W = 200, H = 100 };
    probe_maps m;
    CHECK(maps_open(&m, W, H, 1) == 0);
    sp_probe_plane pl = { .status = SP_PROBE_PLANE_OK, .a = 0, .b = 0.5, .c = 0 };
    for (size_t i = 0; i < (size_t)W * H; i++)
        m.occlusion[i] = -1, memset(m.clean + 3 * i, 100, 3);
    static const int parts[4][4] = { /* x0, x1, y0, y1: the tall box and its strip, the small box and its strip */
                                     { 150, 153, 40, 89 },
                                     { 10, 149, 85, 89 },
                                     { 150, 151, 20, 26 },
                                     { 10, 149, 27, 31 }
    };
    for (int k = 0; k < 4; k++)
        for (int y = parts[k][2]; y <= parts[k][3]; y++)
            for (int x = parts[k][0]; x <= parts[k][1]; x++) {
                m.occlusion[y * W + x] = 90;
                if (k % 2 == 0) /* the boxes stand out of the plate */
                    memset(m.clean + 3 * ((size_t)y * W + x), 200, 3);
            }
    probe_occluder_stats st;
    occluders_settle(&m, &pl, &st);
    CHECK_MSG(st.groups == 2 && st.plain == 1 && st.torn == 0 && st.specks == 0, "%zu groups, %zu plain", st.groups,
              st.plain);
    CHECK(m.occlusion[45 * W + 151] == 90 && m.occlusion[87 * W + 60] == 90);
    CHECK(m.occlusion[22 * W + 150] == -1 && m.occlusion[29 * W + 60] == -1);
    maps_close(&m);
}

/* The confidence of a value from a pixel's own events (maps.c): agreeing over all, one contrary event as prior. */
static void test_confidence(void)
{
    probe_maps m;
    CHECK(maps_open(&m, 4, 1, 1) == 0);
    /* pixel 0: nothing seen; 1: one hidden event at row 50; 2: three at 50 and a body seen at row 60 (nearer);
       3: a hidden event at 50 refuted by a body seen at row 40 (farther) */
    m.hid[1 * PROBE_EVIDENCE] = 50, m.hid_n[1 * PROBE_EVIDENCE] = 1;
    m.hid[2 * PROBE_EVIDENCE] = 50, m.hid_n[2 * PROBE_EVIDENCE] = 3;
    m.vis[2 * PROBE_EVIDENCE] = 60, m.vis_n[2 * PROBE_EVIDENCE] = 1;
    m.hid[3 * PROBE_EVIDENCE] = 50, m.hid_n[3 * PROBE_EVIDENCE] = 1;
    m.vis[3 * PROBE_EVIDENCE] = 40, m.vis_n[3 * PROBE_EVIDENCE] = 1;
    CHECK(maps_confidence_at(&m, 0, -1) == 0 && maps_confidence_at(&m, 0, 30) == 0);
    CHECK(maps_occlusion_at(&m, 1) == 50 && fabsf(maps_confidence_at(&m, 1, 50) - 0.5f) < 1e-6f);
    CHECK(fabsf(maps_confidence_at(&m, 1, -1) - 0.0f) < 1e-6f); /* never occluding: nothing agrees */
    CHECK(maps_occlusion_at(&m, 2) == 50 && fabsf(maps_confidence_at(&m, 2, 50) - 3.0f / 4.0f) < 1e-6f);
    /* raising pixel 2 to row 60 would hide the body seen there: 3 agree, 4 against */
    CHECK(fabsf(maps_confidence_at(&m, 2, 60) - 3.0f / 8.0f) < 1e-6f);
    CHECK(maps_occlusion_at(&m, 3) == -1 && fabsf(maps_confidence_at(&m, 3, -1) - 4.0f / 5.0f) < 1e-6f);
    maps_close(&m);
}

int main(void)
{
    test_median_network();
    test_plate();
    test_plane_robust();
    test_plane_degenerate();
    test_plane_extremes();
    test_reservoir();
    test_params_json();
    test_occluders();
    test_occluders_plain();
    test_confidence();
    return check_exit();
}
