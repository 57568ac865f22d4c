/* SPDX-License-Identifier: MIT */
/*
 * A reference sleeper (issue 10: tests that hold on a busy machine): a
 * thread that sleeps to every period with clock_nanosleep(TIMER_ABSTIME)
 * and records how late it wakes.  Its lateness is the scheduling delay the
 * machine imposed in that run on a thread of its class (SCHED_FIFO at a
 * given priority, or normal), so that a test can judge a time bound of the
 * programs it watches against what the machine actually delivered, instead
 * of against a guess.  The worst lateness is kept per window: a test marks
 * the start of the interval it judges and reads the worst since then.
 */
#ifndef RMD_TESTS_SLEEPER_H
#define RMD_TESTS_SLEEPER_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

struct sleeper {
	int64_t period_ns;
	int fifo;     /* SCHED_FIFO priority, or 0: normal */
	bool is_fifo; /* the priority was granted */
	pthread_t thread;
	bool started;
	atomic_bool stop;
	atomic_llong worst_ns;	     /* the worst lateness since sleeper_mark() */
	atomic_llong wakes;	     /* wake-ups since sleeper_mark() */
	atomic_llong total_worst_ns; /* the worst since the start */
	atomic_llong late_sum_ns;    /* all its lateness since sleeper_mark() */
};

/*
 * A watcher thread, the sleeper's and canlog.h's canwatch: pthread_create()
 * of main(arg) into *thread at SCHED_FIFO priority fifo when granted (root),
 * else at normal priority (and for fifo 0); *is_fifo says which.  0, or
 * pthread_create()'s error.
 */
int watcher_start(pthread_t *thread, void *(*main)(void *), void *arg, int fifo, bool *is_fifo);

/* Set *stop and join thread, when *started; *started is false after.  Whether it was. */
bool watcher_stop(pthread_t thread, atomic_bool *stop, bool *started);

/*
 * Start s: wake every period_ns at SCHED_FIFO priority fifo (when granted:
 * root; else at normal priority, said in is_fifo), or at normal priority
 * for fifo 0.  Returns 0 or -errno.
 */
int sleeper_start(struct sleeper *s, int64_t period_ns, int fifo);

/* Begin a window: forget the worst lateness so far. */
void sleeper_mark(struct sleeper *s);

/* The worst lateness since the last sleeper_mark(), ns (0 before a wake-up). */
int64_t sleeper_worst_ns(struct sleeper *s);

/*
 * The worst scheduling delay s saw since its mark, ms: its latest wake-up
 * plus its period (a stall that began just after a wake-up shows only as
 * far as it outlasted the period); 0 before a late wake-up.
 */
double sleeper_stall_ms(struct sleeper *s);

/*
 * How long the machine held the sleeper off since the last sleeper_mark(),
 * ns: the sum of its wake-ups' lateness -- the time a thread of its class
 * could not run when it wanted to.
 */
int64_t sleeper_held_off_ns(struct sleeper *s);

/* Stop and join the thread (nothing when not started). */
void sleeper_stop(struct sleeper *s);

/*
 * A deadline counted in the time the machine let threads of s's class run:
 * ms of CLOCK_MONOTONIC after held_deadline_start(), plus all the time s
 * was held off since then, so that a busy machine stretches it and an idle
 * one keeps it.  s NULL: a plain deadline.
 */
struct held_deadline {
	struct sleeper *s;
	int64_t t0_ns, held0_ns, ms;
};

void held_deadline_start(struct held_deadline *d, struct sleeper *s, int64_t ms);

/* How long the machine held s off since held_deadline_start(), ns (0 without s). */
int64_t held_deadline_held_ns(const struct held_deadline *d);

/* The deadline has passed: more than ms since the start, less the time held off. */
bool held_deadline_passed(const struct held_deadline *d);

#endif /* RMD_TESTS_SLEEPER_H */
