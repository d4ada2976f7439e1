/* SPDX-License-Identifier: MIT */
/*
 * The worker pool (common/parallel.h): every task runs exactly once per loop,
 * on 1, 2 and 8 threads, over many back-to-back loops (the start/finish
 * handshake), with 0 and 1 tasks and a NULL pool; partial sums combined in task
 * order give bit-identical results whatever the thread count.
 */
#include <math.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>

#include "check.h"
#include "common/parallel.h"

#define TASKS 97

typedef struct loop_ctx {
    atomic_int runs[TASKS];
    double part[TASKS];
    int loop;
} loop_ctx;

static void task(void *arg, int t)
{
    loop_ctx *c = arg;
    atomic_fetch_add(&c->runs[t], 1);
    double s = 0.0; /* a sum whose value depends on the order of its terms */
    for (int i = 1; i <= 1000; i++)
        s += 1.0 / ((double)i * (t + 1) + c->loop);
    c->part[t] = s;
}

static double run_loops(sp_pool *pool, int loops, int *all_once)
{
    static loop_ctx c;
    double total = 0.0;
    *all_once = 1;
    for (int l = 0; l < loops; l++) {
        memset(&c, 0, sizeof(c));
        c.loop = l;
        sp_pool_for(pool, TASKS, task, &c);
        for (int t = 0; t < TASKS; t++) {
            *all_once &= atomic_load(&c.runs[t]) == 1;
            total += c.part[t];
        }
    }
    return total;
}

static void count_task(void *arg, int t)
{
    (void)t;
    atomic_fetch_add((atomic_int *)arg, 1);
}

int main(void)
{
    CHECK(sp_cpu_count() >= 1);
    int once;
    double reference = run_loops(NULL, 200, &once);
    CHECK_MSG(once, "NULL pool: a task ran more or less than once");
    static const int threads[] = { 1, 2, 8 };
    for (size_t i = 0; i < sizeof(threads) / sizeof(threads[0]); i++) {
        sp_pool *pool = NULL;
        CHECK_EQ_INT(sp_pool_open(&pool, threads[i]), 0);
        CHECK_EQ_INT(sp_pool_threads(pool), threads[i]);
        double total = run_loops(pool, 2000, &once);
        CHECK_MSG(once, "%d threads: a task ran more or less than once", threads[i]);
        double ref2000 = run_loops(NULL, 2000, &once);
        CHECK_MSG(total == ref2000, "%d threads: %.17g against %.17g on the caller alone", threads[i], total, ref2000);
        atomic_int n = 0;
        sp_pool_for(pool, 0, count_task, &n);
        CHECK_EQ_INT(atomic_load(&n), 0);
        sp_pool_for(pool, 1, count_task, &n);
        CHECK_EQ_INT(atomic_load(&n), 1);
        sp_pool_close(&pool);
        CHECK(pool == NULL);
    }
    sp_pool *pool = NULL;
    CHECK_EQ_INT(sp_pool_open(&pool, 0), 0); /* the online CPUs */
    CHECK_EQ_INT(sp_pool_threads(pool), sp_cpu_count());
    sp_pool_close(&pool);
    CHECK(sp_pool_open(&pool, 65) < 0 && pool == NULL);
    CHECK(sp_pool_open(NULL, 2) < 0);
    sp_pool_close(NULL);
    printf("parallel: %d CPUs; 2000 loops of %d tasks on 1, 2 and 8 threads agree to the bit (%.6f)\n",
           sp_cpu_count(), TASKS, reference);
    return check_exit();
}
