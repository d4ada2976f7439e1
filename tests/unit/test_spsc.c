/* SPDX-License-Identifier: MIT */
/* The recorder's SPSC ring: FIFO order, full/empty edges, wrap-around, and a two-thread run losing nothing. */
#include "capture/spsc_queue.h"

#include <errno.h>
#include <pthread.h>
#include <stdint.h>
#include <string.h>

#include "check.h"

#define N_ITEMS 200000

static void test_edges(void)
{
    sp_spsc q;
    CHECK_EQ_INT(sp_spsc_init(&q, 0, 8), -EINVAL);
    CHECK_EQ_INT(sp_spsc_init(&q, 4, 0), -EINVAL);
    CHECK_EQ_INT(sp_spsc_init(&q, 3, sizeof(uint64_t)), 0);
    CHECK(sp_spsc_peek(&q) == NULL);
    for (uint64_t round = 0; round < 5; round++) { /* several laps so the counters wrap the ring */
        for (uint64_t i = 0; i < 3; i++) {
            uint64_t *slot = sp_spsc_reserve(&q);
            CHECK(slot != NULL);
            if (slot)
                *slot = round * 10 + i;
            sp_spsc_push(&q);
        }
        CHECK(sp_spsc_reserve(&q) == NULL); /* full */
        CHECK_EQ_INT(sp_spsc_count(&q), 3);
        for (uint64_t i = 0; i < 3; i++) {
            uint64_t *slot = sp_spsc_peek(&q);
            CHECK(slot && *slot == round * 10 + i);
            sp_spsc_pop(&q);
        }
        CHECK(sp_spsc_peek(&q) == NULL); /* empty */
    }
    sp_spsc_free(&q);
}

static void *producer(void *arg)
{
    sp_spsc *q = arg;
    for (uint64_t i = 0; i < N_ITEMS;) {
        uint64_t *slot = sp_spsc_reserve(q);
        if (!slot)
            continue; /* a real producer would drop; here we retry to check nothing is lost */
        slot[0] = i;
        slot[1] = ~i;
        sp_spsc_push(q);
        i++;
    }
    return NULL;
}

static void test_threads(void)
{
    sp_spsc q;
    CHECK_EQ_INT(sp_spsc_init(&q, 16, 2 * sizeof(uint64_t)), 0);
    pthread_t t;
    CHECK_EQ_INT(pthread_create(&t, NULL, producer, &q), 0);
    uint64_t expect = 0, torn = 0;
    while (expect < N_ITEMS) {
        uint64_t *slot = sp_spsc_peek(&q);
        if (!slot)
            continue;
        if (slot[0] != expect || slot[1] != ~expect)
            torn++;
        sp_spsc_pop(&q);
        expect++;
    }
    pthread_join(t, NULL);
    CHECK_EQ_INT(torn, 0);
    CHECK(sp_spsc_peek(&q) == NULL);
    sp_spsc_free(&q);
}

int main(void)
{
    test_edges();
    test_threads();
    return check_exit();
}
