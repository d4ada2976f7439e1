/* SPDX-License-Identifier: MIT */
/* common/: CRC-32C vectors, JSON round trips and malformed input, frame pools, quaternion extremes. */
#include <errno.h>
#include <math.h>
#include <string.h>

#include "check.h"
#include "common/crc32c.h"
#include "common/json.h"
#include "common/report.h"
#include "common/stats.h"
#include "device/node_scan.h"
#include "sunprobe/sp_frame.h"
#include "sunprobe/sp_math.h"

static void test_crc32c(void)
{
    CHECK_EQ_INT(sp_crc32c(0, "123456789", 9), 0xE3069283u);
    CHECK_EQ_INT(sp_crc32c_sw(0, "123456789", 9), 0xE3069283u);
    uint8_t buf[1027];
    for (size_t i = 0; i < sizeof(buf); i++)
        buf[i] = (uint8_t)(i * 131 + 7);
    for (size_t n = 0; n < sizeof(buf); n += 37) {
        CHECK_EQ_INT(sp_crc32c(0, buf + 1, n), sp_crc32c_sw(0, buf + 1, n));
        /* incremental equals one-shot */
        uint32_t a = sp_crc32c(sp_crc32c(0, buf, n / 2), buf + n / 2, n - n / 2);
        CHECK_EQ_INT(a, sp_crc32c(0, buf, n));
    }
}

static void test_json(void)
{
    const char *text = "{\"a\": [1, 2.5, -3e2], \"s\": \"x\\n\\u00e9\\ud83d\\ude00\", \"t\": true, \"n\": null, "
                       "\"o\": {\"k\": \"v\"}}";
    sp_json *j = NULL;
    char err[128];
    CHECK_EQ_INT(sp_json_parse(text, strlen(text), &j, err, sizeof(err)), 0);
    double v[3] = { 0 };
    CHECK_EQ_INT(sp_json_numbers(sp_json_get(j, "a"), v, 3), 3);
    CHECK_NEAR(v[2], -300.0, 0);
    CHECK(strcmp(sp_json_string(sp_json_get(j, "s"), ""), "x\n\xc3\xa9\xf0\x9f\x98\x80") == 0);
    CHECK_NEAR(sp_json_number(sp_json_get(j, "t"), 0), 1, 0);
    CHECK(sp_json_get(j, "n")->type == SP_JSON_NULL);
    CHECK(strcmp(sp_json_string(sp_json_get(sp_json_get(j, "o"), "k"), ""), "v") == 0);
    CHECK(sp_json_get(j, "missing") == NULL);
    sp_json_free(j);

    /* raw UTF-8 of 2, 3 and 4 bytes passes as it is; the edges of the valid ranges too */
    const char *utf = "[\"\xc3\xa9\xe2\x82\xac\xf0\x9f\x98\x80\xed\x9f\xbf\xf4\x8f\xbf\xbf\"]";
    CHECK_EQ_INT(sp_json_parse(utf, strlen(utf), &j, err, sizeof(err)), 0);
    CHECK(j && strcmp(sp_json_string(sp_json_at(j, 0), ""), "\xc3\xa9\xe2\x82\xac\xf0\x9f\x98\x80\xed\x9f\xbf\xf4\x8f\xbf\xbf") == 0);
    sp_json_free(j);
    /* not UTF-8 (a stray continuation, a truncated sequence, overlong, CESU-8 surrogate, above U+10FFFF, Latin-1),
       and escapes a C string cannot hold (NUL) or UTF-8 cannot (a lone surrogate) */
    static const char *bad[] = { "", "{", "[1,]", "{\"a\" 1}", "\"abc", "tru", "1 2", "{\"a\":1,}", "\"\\x\"",
                                 "[\"\x01\"]", "[\"\x80\"]", "[\"\xc3\"]", "[\"\xc0\xaf\"]", "[\"\xe0\x80\xaf\"]",
                                 "[\"\xed\xa0\x80\"]", "[\"\xf4\x90\x80\x80\"]", "[\"caf\xe9\"]", "[\"a\\u0000b\"]",
                                 "[\"\\ud800\"]", "[\"\\udc00x\"]", "[\"\\ud800\\u0041\"]" };
    for (size_t i = 0; i < sizeof(bad) / sizeof(bad[0]); i++) {
        j = NULL;
        CHECK_MSG(sp_json_parse(bad[i], strlen(bad[i]), &j, err, sizeof(err)) == SP_ECORRUPT, "input %zu", i);
        CHECK(j == NULL);
    }
    /* deep nesting is refused, not a stack overflow */
    char deep[4001];
    memset(deep, '[', 4000);
    deep[4000] = 0;
    CHECK(sp_json_parse(deep, 4000, &j, err, sizeof(err)) == SP_ECORRUPT);

    sp_strbuf b = { 0 };
    sp_strbuf_json_string(&b, "q\"\\\x01");
    sp_strbuf_append(&b, ",", 1);
    sp_strbuf_json_number(&b, NAN);
    CHECK(strcmp(b.data, "\"q\\\"\\\\\\u0001\",null") == 0);
    sp_strbuf_free(&b);
}

static void test_frame_pool(void)
{
    sp_frame_pool *pool = NULL;
    CHECK_EQ_INT(sp_frame_pool_open(&pool, 0, 10), -EINVAL);
    CHECK_EQ_INT(sp_frame_pool_open(&pool, 2, 64), 0);
    sp_frame *a = NULL, *b = NULL, *c = NULL;
    CHECK_EQ_INT(sp_frame_pool_get(pool, &a), 0);
    CHECK_EQ_INT(sp_frame_pool_get(pool, &b), 0);
    CHECK_EQ_INT(sp_frame_pool_get(pool, &c), -EAGAIN);
    CHECK(isnan(a->exposure_us));
    sp_frame *a2 = sp_frame_ref(a);
    sp_frame_unref(&a);
    CHECK(a == NULL);
    CHECK_EQ_INT(sp_frame_pool_free_count(pool), 0);
    sp_frame_unref(&a2);
    CHECK_EQ_INT(sp_frame_pool_free_count(pool), 1);
    sp_frame_pool_close(&pool); /* b still out: pool stays alive until it returns */
    b->data[63] = 1;
    sp_frame_unref(&b);

    CHECK_EQ_INT(sp_pixfmt_image_size(SP_PIXFMT_NV12, 4, 3, 4), 4 * 5);
    CHECK_EQ_INT(sp_pixfmt_min_stride(SP_PIXFMT_NV12, 5), 6); /* odd width: a whole last UV pair */
    CHECK_EQ_INT(sp_pixfmt_image_size(SP_PIXFMT_YUYV, 3, 2, 6), 0); /* stride below 2*4 */
    CHECK_EQ_INT(sp_pixfmt_image_size(SP_PIXFMT_MJPEG, 3, 2, 6), 0);
    CHECK(sp_pixfmt_from_name("yuyv") == SP_PIXFMT_YUYV);
}

static void test_quat(void)
{
    sp_quat q = sp_quat_from_rotvec((sp_vec3){ 0, 0, 0 });
    CHECK_NEAR(q.w, 1, 0);
    q = sp_quat_from_rotvec((sp_vec3){ 1e-300, 0, 0 });
    CHECK(isfinite(q.x) && isfinite(q.w));
    q = sp_quat_from_rotvec((sp_vec3){ NAN, 0, 0 });
    CHECK_NEAR(q.w, 1, 0);
    sp_quat a = sp_quat_from_axis_angle((sp_vec3){ 0, 0, 1 }, 0.3);
    sp_quat b = sp_quat_from_axis_angle((sp_vec3){ 0, 0, 1 }, 0.3 + 1e-9);
    CHECK_NEAR(sp_quat_angle_between(a, b), 1e-9, 1e-12);
    sp_quat m = sp_quat_slerp(a, b, 0.5);
    CHECK(isfinite(m.w) && isfinite(m.z));
    sp_quat c = sp_quat_from_axis_angle((sp_vec3){ 1, 2, 3 }, 3.1);
    double mat[9];
    sp_quat_to_matrix(c, mat);
    CHECK_NEAR(sp_quat_angle_between(c, sp_quat_from_matrix(mat)), 0, 1e-9);
    sp_vec3 rv = sp_quat_to_rotvec(c);
    CHECK_NEAR(sp_vec3_norm(rv), 3.1, 1e-9);
    sp_quat half = sp_quat_slerp(sp_quat_identity(), c, 0.5);
    CHECK_NEAR(sp_quat_angle_between(sp_quat_identity(), half), 1.55, 1e-9);
    CHECK_NEAR(sp_vec3_norm((sp_vec3){ 1e300, 1e300, 1e300 }), sqrt(3.0) * 1e300, 1e288);
    /* the mean of rotations 0.2 rad either side of c, given with both signs, is c */
    sp_quat_mean mean;
    sp_quat_mean_init(&mean);
    CHECK_NEAR(sp_quat_angle_between(sp_quat_mean_get(&mean), sp_quat_identity()), 0, 0);
    sp_quat lo = sp_quat_mul(c, sp_quat_from_axis_angle((sp_vec3){ 0, 1, 0 }, -0.2));
    sp_quat hi = sp_quat_mul(c, sp_quat_from_axis_angle((sp_vec3){ 0, 1, 0 }, 0.2));
    sp_quat_mean_add(&mean, lo);
    sp_quat_mean_add(&mean, (sp_quat){ -hi.w, -hi.x, -hi.y, -hi.z });
    CHECK_NEAR(sp_quat_angle_between(sp_quat_mean_get(&mean), c), 0, 1e-12);
}

static void test_report(void)
{
    char dir[] = "/tmp/sp-report-XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char prefix[64], path[80];
    snprintf(prefix, sizeof(prefix), "%s/loss", dir);
    const char *names[] = { "loss", "psnr <dB>" };
    sp_report *r = NULL;
    CHECK_EQ_INT(sp_report_open(&r, prefix, "fit & test", names, 2, 1), 0);
    for (int i = 0; i < 5; i++) {
        double v[2] = { 1.0 / (i + 1), i == 2 ? (double)NAN : 20.0 + i };
        CHECK_EQ_INT(sp_report_add(r, 0.5 * i, v), 0);
    }
    double bad[2] = { -1.0, INFINITY }; /* not plottable on a log axis: skipped, not a crash */
    CHECK_EQ_INT(sp_report_add(r, 3.0, bad), 0);
    CHECK_EQ_INT(sp_report_close(&r), 0);
    CHECK(r == NULL);
    snprintf(path, sizeof(path), "%s.csv", prefix);
    FILE *f = fopen(path, "r");
    char line[256] = "";
    int rows = 0, empty_cell = 0;
    while (f && fgets(line, sizeof(line), f)) {
        rows++;
        if (rows == 4)
            empty_cell = strcmp(line, "1.0000,0.333333333,\n") == 0;
    }
    if (f)
        fclose(f);
    CHECK_EQ_INT(rows, 7);
    CHECK(empty_cell);
    snprintf(path, sizeof(path), "%s.svg", prefix);
    f = fopen(path, "r");
    size_t n = f ? fread(line, 1, sizeof(line) - 1, f) : 0;
    line[n] = 0;
    if (f)
        fclose(f);
    CHECK(strstr(line, "<svg") != NULL && strstr(line, "fit &amp; test") != NULL);
    /* a failed run's report is dropped: the previous one stays whole, no temporary is left */
    CHECK_EQ_INT(sp_report_open(&r, prefix, "again", names, 2, 1), 0);
    double row[2] = { 9.0, 9.0 };
    CHECK_EQ_INT(sp_report_add(r, 1.0, row), 0);
    sp_report_abort(&r);
    CHECK(r == NULL);
    snprintf(path, sizeof(path), "%s.csv", prefix);
    f = fopen(path, "r");
    rows = 0;
    while (f && fgets(line, sizeof(line), f))
        rows += strncmp(line, "1.0000,9", 8) != 0;
    if (f)
        fclose(f);
    CHECK_EQ_INT(rows, 7);
    snprintf(path, sizeof(path), "ls -a %s | grep -q '\\.new\\.'", dir);
    CHECK_MSG(system(path) != 0, "a report temporary was left in %s", dir);
    snprintf(path, sizeof(path), "rm -rf %s", dir);
    CHECK(system(path) == 0);
    /* bad arguments are refused */
    CHECK_EQ_INT(sp_report_open(&r, prefix, "x", names, 0, 0), -EINVAL);
}

static void test_node_scan(void)
{
    char dir[] = "/tmp/sp-nodes-XXXXXX", path[80];
    CHECK(mkdtemp(dir) != NULL);
    static const char *names[] = { "video12", "video0", "video", "videoX", "video3a", "iio:device2", "video-1" };
    for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++) {
        snprintf(path, sizeof(path), "%s/%s", dir, names[i]);
        FILE *f = fopen(path, "w");
        CHECK(f != NULL);
        if (f)
            fclose(f);
    }
    int nums[4] = { -9, -9, -9, -9 };
    CHECK_EQ_INT(sp_scan_numbered_entries(dir, "video", nums, 4), 2);
    CHECK_EQ_INT(nums[0], 0);
    CHECK_EQ_INT(nums[1], 12);
    CHECK_EQ_INT(sp_scan_numbered_entries(dir, "iio:device", nums, 4), 1);
    CHECK_EQ_INT(nums[0], 2);
    CHECK_EQ_INT(sp_scan_numbered_entries("/nonexistent-sp-dir", "video", nums, 4), 0);
    snprintf(path, sizeof(path), "rm -rf %s", dir);
    CHECK(system(path) == 0);

    sp_strbuf b = { 0 };
    double v[3] = { 1.5, NAN, -2 };
    sp_strbuf_json_numbers(&b, v, 3);
    CHECK(b.data && strcmp(b.data, "[1.5,null,-2]") == 0);
    sp_strbuf_free(&b);
}

/* The median: none, one, odd and even counts, unsorted with negatives and repeats, sorted in place. */
static void test_median(void)
{
    double none[1] = { 7 };
    CHECK(isnan(sp_median_inplace(none, 0)));
    CHECK(isnan(sp_median_inplace(NULL, 3)));
    double one[1] = { -2.5 };
    CHECK(sp_median_inplace(one, 1) == -2.5);
    double odd[5] = { 3, -1, 1e300, 3, -1e-300 };
    CHECK(sp_median_inplace(odd, 5) == 3);
    CHECK(odd[0] == -1 && odd[4] == 1e300);
    double even[4] = { 4, -4, 2, 1 };
    CHECK(sp_median_inplace(even, 4) == 1.5);
}

int main(void)
{
    test_crc32c();
    test_median();
    test_json();
    test_frame_pool();
    test_quat();
    test_report();
    test_node_scan();
    return check_exit();
}
