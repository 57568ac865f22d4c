// SPDX-License-Identifier: MIT
/* Normal-priority helper threads: the LCM bridge, the daemon's monitor. */
#include <errno.h>
#include <sched.h>
#include <signal.h>

#include "rmd/thread.h"

int rmd_thread_start_normal(pthread_t *thread, void *(*fn)(void *), void *arg)
{
	struct sched_param sp = { .sched_priority = 0 };
	pthread_attr_t attr;
	sigset_t all, old;
	int r;

	r = -pthread_attr_init(&attr);
	if (r)
		return r;
	r = -pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
	if (!r)
		r = -pthread_attr_setschedpolicy(&attr, SCHED_OTHER);
	if (!r)
		r = -pthread_attr_setschedparam(&attr, &sp);
	if (!r) {
		sigfillset(&all);
		pthread_sigmask(SIG_SETMASK, &all, &old);
		r = -pthread_create(thread, &attr, fn, arg);
		pthread_sigmask(SIG_SETMASK, &old, NULL);
	}
	pthread_attr_destroy(&attr);
	return r;
}
