/* SPDX-License-Identifier: MIT */
/* Threads that are not the rt loop. */
#ifndef RMD_THREAD_H
#define RMD_THREAD_H

#include <pthread.h>

/*
 * Start fn(arg) as a SCHED_OTHER thread whatever the caller runs at (the
 * daemon's main thread may be SCHED_FIFO during bring-up), with every
 * signal blocked: signals belong to the main thread's signalfd.
 * Returns 0 or -errno.  Non-rt.
 */
int rmd_thread_start_normal(pthread_t *thread, void *(*fn)(void *), void *arg);

#endif /* RMD_THREAD_H */
