/* SPDX-License-Identifier: MIT */
/*
 * A reference pseudo-terminal (issue 10: tests that hold on a busy
 * machine).  Bytes written to a pty reach its other side through the
 * kernel's tty flip-buffer worker, a normal-priority kernel thread: on a
 * busy machine it is held off, and a byte then takes 100 ms or more to
 * cross, while every user thread is awake and waiting (a reference
 * sleeper does not see it).  The RS485 suites run rmd-sim and rmdctl over
 * ptys, so an answer that "did not come" may be stuck there.
 *
 * The probe is a thread that sends one byte every period through a spare
 * pty pair and records how long each took to arrive: the worst hop since
 * a mark, as sleeper.h does for wake-ups.  A test judges a missing answer
 * against it: the line was stalled at least that long in that window.
 */
#ifndef RMD_TESTS_PTY_PROBE_H
#define RMD_TESTS_PTY_PROBE_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdint.h>

struct pty_probe {
	int64_t period_ns;
	int master, slave;
	pthread_t thread;
	bool started;
	atomic_bool stop;
	atomic_llong worst_ns;	     /* the slowest hop since pty_probe_mark() */
	atomic_llong hops;	     /* hops since pty_probe_mark() */
	atomic_llong total_worst_ns; /* the slowest since the start */
	atomic_llong inflight_ns;    /* when the byte on its way was sent, 0: none */
};

/* Open a pty pair (raw) and start the thread: a byte every period_ns.  0 or -errno. */
int pty_probe_start(struct pty_probe *p, int64_t period_ns);

/* Begin a window: forget the slowest hop so far. */
void pty_probe_mark(struct pty_probe *p);

/*
 * The slowest hop since the last pty_probe_mark(), ns, a hop still on its
 * way counted for as long as it has been (0 before any).
 */
int64_t pty_probe_worst_ns(struct pty_probe *p);

/* Stop the thread and close the pty (nothing when not started). */
void pty_probe_stop(struct pty_probe *p);

#endif /* RMD_TESTS_PTY_PROBE_H */
