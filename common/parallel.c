/* SPDX-License-Identifier: MIT */
/* Worker pool (parallel.h): workers sleep on a condition variable between loops and claim tasks by an atomic counter. */
#include "common/parallel.h"

#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <unistd.h>

#define MAX_THREADS 64

struct sp_pool {
    int n;            /* threads including the caller */
    pthread_t tid[MAX_THREADS];
    pthread_mutex_t lock;
    pthread_cond_t start, done;
    unsigned long generation; /* bumped per loop: wakes the workers */
    int busy;                 /* workers still in the current loop */
    int stop;
    void (*fn)(void *, int);
    void *ctx;
    int n_tasks;
    atomic_int next;
};

int sp_cpu_count(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1 : (n > MAX_THREADS ? MAX_THREADS : (int)n);
}

static void run_tasks(sp_pool *p)
{
    for (int t; (t = atomic_fetch_add(&p->next, 1)) < p->n_tasks;)
        p->fn(p->ctx, t);
}

static void *worker(void *arg)
{
    sp_pool *p = arg;
    unsigned long seen = 0;
    pthread_mutex_lock(&p->lock);
    for (;;) {
        while (!p->stop && p->generation == seen)
            pthread_cond_wait(&p->start, &p->lock);
        if (p->stop)
            break;
        seen = p->generation;
        pthread_mutex_unlock(&p->lock);
        run_tasks(p);
        pthread_mutex_lock(&p->lock);
        if (--p->busy == 0)
            pthread_cond_signal(&p->done);
    }
    pthread_mutex_unlock(&p->lock);
    return NULL;
}

int sp_pool_open(sp_pool **pool, int threads)
{
    if (!pool)
        return -EINVAL;
    *pool = NULL;
    if (threads <= 0)
        threads = sp_cpu_count();
    if (threads > MAX_THREADS)
        return -EINVAL;
    sp_pool *p = calloc(1, sizeof(*p));
    if (!p)
        return -ENOMEM;
    p->n = 1;
    if (pthread_mutex_init(&p->lock, NULL) || pthread_cond_init(&p->start, NULL) || pthread_cond_init(&p->done, NULL)) {
        free(p);
        return -ENOMEM;
    }
    for (int i = 1; i < threads; i++) {
        int err = pthread_create(&p->tid[i], NULL, worker, p);
        if (err) {
            sp_pool_close(&p);
            return -err;
        }
        p->n++;
    }
    *pool = p;
    return 0;
}

void sp_pool_close(sp_pool **pool)
{
    if (!pool || !*pool)
        return;
    sp_pool *p = *pool;
    pthread_mutex_lock(&p->lock);
    p->stop = 1;
    pthread_cond_broadcast(&p->start);
    pthread_mutex_unlock(&p->lock);
    for (int i = 1; i < p->n; i++)
        pthread_join(p->tid[i], NULL);
    pthread_cond_destroy(&p->start);
    pthread_cond_destroy(&p->done);
    pthread_mutex_destroy(&p->lock);
    free(p);
    *pool = NULL;
}

int sp_pool_threads(const sp_pool *pool)
{
    return pool ? pool->n : 1;
}

void sp_pool_for(sp_pool *pool, int n_tasks, void (*fn)(void *ctx, int task), void *ctx)
{
    if (!pool || pool->n == 1 || n_tasks <= 1) {
        for (int t = 0; t < n_tasks; t++)
            fn(ctx, t);
        return;
    }
    pthread_mutex_lock(&pool->lock);
    pool->fn = fn, pool->ctx = ctx, pool->n_tasks = n_tasks;
    atomic_store(&pool->next, 0);
    pool->busy = pool->n - 1;
    pool->generation++;
    pthread_cond_broadcast(&pool->start);
    pthread_mutex_unlock(&pool->lock);
    run_tasks(pool);
    pthread_mutex_lock(&pool->lock);
    while (pool->busy > 0)
        pthread_cond_wait(&pool->done, &pool->lock);
    pthread_mutex_unlock(&pool->lock);
}
