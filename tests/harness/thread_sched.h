/* SPDX-License-Identifier: MIT */
/*
 * How long the machine held one thread off (issue 10: tests that hold on a
 * busy machine): the kernel's own account of a thread, in
 * /proc/PID/task/TID/schedstat -- the time it ran on a CPU and the time it
 * was runnable but waited for one.  A reference sleeper (sleeper.h)
 * measures what the machine does to a thread of a class; this measures
 * what it did to the very thread a test judges (rmdd's bridge, say), so
 * that a count that depends on that thread getting a CPU is judged against
 * the CPU it got.
 */
#ifndef RMD_TESTS_THREAD_SCHED_H
#define RMD_TESTS_THREAD_SCHED_H

#include <stdint.h>
#include <sys/types.h>

struct thread_sched {
	int64_t run_ns;	 /* on a CPU */
	int64_t wait_ns; /* runnable, waiting for a CPU */
	uint64_t slices; /* times it got a CPU */
};

/*
 * The id of process pid's thread named comm (/proc/PID/task/TID/comm, as
 * pthread_setname_np() set it), or -errno (-ENOENT: no such thread).
 */
pid_t thread_find(pid_t pid, const char *comm);

/* *s = thread tid of process pid's counters so far; 0 or -errno. */
int thread_sched_read(pid_t pid, pid_t tid, struct thread_sched *s);

/*
 * The time thread tid of pid waited for a CPU since *since (read then by
 * thread_sched_read()), ns; 0 when it cannot be read.
 */
int64_t thread_wait_since(pid_t pid, pid_t tid, const struct thread_sched *since);

#endif /* RMD_TESTS_THREAD_SCHED_H */
