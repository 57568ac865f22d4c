// SPDX-License-Identifier: MIT
/* A reference sleeper: see sleeper.h. */
#define _GNU_SOURCE
#include "harness/sleeper.h"

#include <errno.h>
#include <sched.h>
#include <time.h>

#define NS_PER_S INT64_C(1000000000)

static int64_t mono(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t)ts.tv_sec * NS_PER_S + ts.tv_nsec;
}

int watcher_start(pthread_t *thread, void *(*main)(void *), void *arg, int fifo, bool *is_fifo)
{
	pthread_attr_t attr;
	int rc = -1;

	*is_fifo = false;
	if (fifo > 0) {
		struct sched_param sp = { .sched_priority = fifo };

		pthread_attr_init(&attr);
		pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
		pthread_attr_setschedpolicy(&attr, SCHED_FIFO);
		pthread_attr_setschedparam(&attr, &sp);
		rc = pthread_create(thread, &attr, main, arg);
		pthread_attr_destroy(&attr);
		*is_fifo = rc == 0;
	}
	if (rc != 0) /* fifo 0, or not granted: at normal priority, said in is_fifo */
		rc = pthread_create(thread, NULL, main, arg);
	return rc;
}

bool watcher_stop(pthread_t thread, atomic_bool *stop, bool *started)
{
	if (!*started)
		return false;
	atomic_store(stop, true);
	pthread_join(thread, NULL);
	*started = false;
	return true;
}

static void *sleeper_main(void *arg)
{
	struct sleeper *s = arg;
	int64_t next = mono();

	while (!atomic_load(&s->stop)) {
		struct timespec ts;
		int64_t late, now;

		next += s->period_ns;
		ts.tv_sec = next / NS_PER_S;
		ts.tv_nsec = next % NS_PER_S;
		while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR)
			;
		now = mono();
		late = now - next;
		if (late > atomic_load(&s->worst_ns))
			atomic_store(&s->worst_ns, late);
		if (late > atomic_load(&s->total_worst_ns))
			atomic_store(&s->total_worst_ns, late);
		atomic_fetch_add(&s->late_sum_ns, late);
		atomic_fetch_add(&s->wakes, 1);
		/* a wake-up later than a period: start again from now, no burst */
		if (now - next > s->period_ns)
			next = now;
	}
	return NULL;
}

int sleeper_start(struct sleeper *s, int64_t period_ns, int fifo)
{
	int rc;

	s->period_ns = period_ns;
	s->fifo = fifo;
	atomic_store(&s->stop, false);
	atomic_store(&s->worst_ns, 0);
	atomic_store(&s->total_worst_ns, 0);
	atomic_store(&s->wakes, 0);
	atomic_store(&s->late_sum_ns, 0);
	rc = watcher_start(&s->thread, sleeper_main, s, fifo, &s->is_fifo);
	s->started = rc == 0;
	return -rc;
}

void sleeper_mark(struct sleeper *s)
{
	atomic_store(&s->worst_ns, 0);
	atomic_store(&s->wakes, 0);
	atomic_store(&s->late_sum_ns, 0);
}

int64_t sleeper_worst_ns(struct sleeper *s)
{
	return atomic_load(&s->worst_ns);
}

double sleeper_stall_ms(struct sleeper *s)
{
	int64_t w = sleeper_worst_ns(s);

	return w > 0 ? (double)(w + s->period_ns) / 1e6 : 0;
}

int64_t sleeper_held_off_ns(struct sleeper *s)
{
	return atomic_load(&s->late_sum_ns);
}

void sleeper_stop(struct sleeper *s)
{
	watcher_stop(s->thread, &s->stop, &s->started);
}

void held_deadline_start(struct held_deadline *d, struct sleeper *s, int64_t ms)
{
	d->s = s;
	d->ms = ms;
	d->t0_ns = mono();
	d->held0_ns = s ? sleeper_held_off_ns(s) : 0;
}

int64_t held_deadline_held_ns(const struct held_deadline *d)
{
	return d->s ? sleeper_held_off_ns(d->s) - d->held0_ns : 0;
}

bool held_deadline_passed(const struct held_deadline *d)
{
	return mono() - d->t0_ns - held_deadline_held_ns(d) > d->ms * 1000000;
}
