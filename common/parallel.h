/* SPDX-License-Identifier: MIT */
/*
 * A fixed pool of worker threads for data-parallel loops (parallel.c). Work is
 * cut into tasks the caller numbers; each task writes its own partial result,
 * and the caller combines them in task order, so results do not depend on the
 * thread count or on which thread ran which task.
 */
#ifndef SUNPROBE_COMMON_PARALLEL_H
#define SUNPROBE_COMMON_PARALLEL_H

typedef struct sp_pool sp_pool;

/* The online CPUs (at least 1). */
int sp_cpu_count(void);
/* threads <= 0: sp_cpu_count(); 1 runs everything on the caller. 0, -EINVAL or -errno (*pool NULL on error). */
int sp_pool_open(sp_pool **pool, int threads);
/* Stops and joins the workers; accepts NULL and *pool == NULL. */
void sp_pool_close(sp_pool **pool);
/* Threads that run tasks, the caller included. A NULL pool counts 1. */
int sp_pool_threads(const sp_pool *pool);
/*
 * fn(ctx, task) for every task in [0, n_tasks), spread over the threads (the
 * caller works too), returning when all have run. A NULL pool runs them in order
 * on the caller. Not reentrant: fn must not call sp_pool_for on the same pool.
 */
void sp_pool_for(sp_pool *pool, int n_tasks, void (*fn)(void *ctx, int task), void *ctx);

#endif
