// SPDX-License-Identifier: MIT
/*
 * The SCHED_FIFO thread that runs the cycle at every tick (rmd_loop_tick(),
 * then the wait for its replies and rmd_loop_publish()): memory locking, the
 * prefaulted stack, CPU affinity and priority, collecting replies between
 * ticks, start, stop and join.  The thread body is rt-safe;
 * its set-up and tear-down are non-rt.
 */
#define _GNU_SOURCE /* ppoll, pthread_setaffinity_np */
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <stdio.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "rmd/time.h"
#include "loop_state.h"
#include "loop_env.h"

/* rt thread, before its first cycle. */
static void __attribute__((noinline)) prefault_stack(void)
{
	volatile unsigned char buf[RMD_LOOP_PREFAULT_STACK];

	for (size_t i = 0; i < sizeof(buf); i += 4096)
		buf[i] = 0;
}

/* rt-safe. */
static bool stopping(const struct rmd_loop *l)
{
	return atomic_load_explicit(&l->stop, memory_order_acquire);
}

/*
 * Whether bus b is served between ticks whatever the cycle awaits: a
 * transport that queues its own requests (RS485, half duplex) writes the
 * next one only when it is read, so it is waited on and read as its frames
 * come.  A full-duplex bus (SocketCAN, sim) is read when the cycle's
 * replies on it are due (between_ticks()).  rt-safe.
 */
static bool queues_requests(const struct rmd_bus *bus)
{
	const struct rmd_bus_caps *caps = rmd_bus_caps(bus);

	return caps->half_duplex || caps->queue_len > 0;
}

static int64_t min64(int64_t a, int64_t b)
{
	return a < b ? a : b;
}

/* Whether one of the buses in mask has no descriptor to wait on (the sim bus).  rt-safe. */
static bool blind(const struct rmd_loop *l, unsigned mask)
{
	for (unsigned b = 0; b < l->n_buses; b++)
		if ((mask & (1u << b)) && rmd_bus_fd(l->bus[b].bus) < 0)
			return true;
	return false;
}

/*
 * Between ticks (rmd/loop.h step 5, docs/design.md "The cycle"): the
 * cycle's state is published as soon as the replies to its requests are
 * in, so that a controller answering it makes the next tick.  The thread
 * sleeps until the last reply is expected (the motors' mean round trips),
 * reads the buses that owe replies, and waits for what is still missing
 * on their descriptors (a bus without one, the sim bus, is looked at every
 * COLLECT_SIM_STEP_NS), up to PUBLISH_LEAD_NS before the next tick.  What
 * is not in by then, or not expected by then, is left to the next tick,
 * which publishes after its receive (rmd_loop_tick()): no wake-up near the
 * tick for a state no controller could answer in time.  Meanwhile and
 * after, the buses that queue their own requests (RS485) are served as
 * their frames come, until COLLECT_GUARD_NS before the tick; and a send a
 * healthy bus refused is tried again every RETRY_STEP_NS (loop_tx.c
 * loop_retry_sends()).  rt-safe.
 */
static void between_ticks(struct rmd_loop *l)
{
	int64_t deadline = loop_publish_deadline(l);
	bool waiting = true, looked = false; /* looked: the owing buses were read when due */
	unsigned deaf = 0; /* buses whose descriptor said more than "readable": not waited on */

	for (;;) {
		struct pollfd pfd[RMD_MAX_BUSES];
		unsigned which[RMD_MAX_BUSES], n = 0, owing = 0;
		int64_t now = rmd_now_ns(), until = l->next_tick_ns - COLLECT_GUARD_NS;
		int64_t due = 0, wake = until;
		bool queues = false;
		struct timespec ts;
		int r;

		if (waiting) {
			due = stopping(l) ? -1 : loop_reply_due(l, now, &owing);
			if (due < 0)
				owing = 0;
			if (!due)
				rmd_loop_publish(l, now);
			if (due <= 0)
				waiting = false; /* published, or the next tick publishes */
			else if (now >= due && !looked) {
				looked = true;
				for (unsigned b = 0; b < l->n_buses; b++)
					if (owing & (1u << b))
						loop_drain(l, b, now);
				continue;
			}
		}
		/* a send refused on a healthy bus, tried again (loop_tx.c loop_retry_sends()) */
		if (__builtin_expect(l->retry_buses != 0, 0) && now >= l->retry_next_ns)
			loop_retry_sends(l, now, false);
		if (now >= until || stopping(l))
			return;
		if (owing && due > now)
			wake = due;
		else if (owing) /* readiness on a descriptor, steps for a bus without one */
			wake = blind(l, owing) ? min64(deadline, now + COLLECT_SIM_STEP_NS) :
						 deadline;
		for (unsigned b = 0; b < l->n_buses; b++) {
			struct rmd_bus *bus = l->bus[b].bus;
			int fd = rmd_bus_fd(bus);
			bool queue = queues_requests(bus);
			/* readiness: what is missing */
			bool ready = looked && (owing & ~deaf & (1u << b));

			if (queue) {
				int64_t d = rmd_bus_next_due_ns(bus);

				/* at least a short step: a past deadline must not spin */
				wake = min64(wake, d < now + COLLECT_MIN_STEP_NS ?
							   now + COLLECT_MIN_STEP_NS :
							   d);
				queues = true;
			}
			if (fd >= 0 && (queue || ready)) {
				pfd[n] = (struct pollfd){ .fd = fd, .events = POLLIN };
				which[n++] = b;
			}
		}
		if (l->retry_buses)
			wake = min64(wake, l->retry_next_ns);
		if (!waiting && !queues && !l->retry_buses)
			return;
		ts = loop_ts(wake - now);
		r = ppoll(pfd, n, &ts, NULL);
		if (r < 0 && errno != EINTR)
			return;
		now = rmd_now_ns();
		/* the buses that have frames, whose queue is due, or (no descriptor) that owe */
		for (unsigned k = 0; k < n; k++) {
			struct rmd_bus *bus = l->bus[which[k]].bus;

			/* an error or hang-up would wake every wait: read at the tick, as before */
			if (r > 0 && (pfd[k].revents & ~POLLIN) && !queues_requests(bus))
				deaf |= 1u << which[k];
			if ((r > 0 && pfd[k].revents) ||
			    (queues_requests(bus) && rmd_bus_next_due_ns(bus) <= now))
				loop_drain(l, which[k], now);
		}
		for (unsigned b = 0; looked && b < l->n_buses; b++)
			if ((owing & (1u << b)) && rmd_bus_fd(l->bus[b].bus) < 0)
				loop_drain(l, b, now);
	}
}

/* The rt thread. */
static void *thread_main(void *arg)
{
	struct rmd_loop *l = arg;
	int64_t now;

	/* one name to find it by (/proc/PID/task/TID/comm; bench/ scripts) */
	pthread_setname_np(pthread_self(), "rmd-loop");
	prefault_stack();
	now = rmd_now_ns();
	while (!stopping(l)) {
		struct timespec ts;

		rmd_loop_tick(l, now);
		now = rmd_now_ns();
		/* the work ran past the next tick: skip it (its lateness recorded) */
		if (now > l->next_tick_ns)
			loop_reached_tick(l, now, false);
		between_ticks(l);
		ts = loop_ts(l->next_tick_ns);
		while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR &&
		       !stopping(l))
			;
		now = rmd_now_ns();
	}
	rmd_loop_publish(l, rmd_now_ns()); /* the last cycle's state, if still owed */
	rmd_loop_stop_motors(l, rmd_now_ns());
	return NULL;
}

/* Create the thread with SCHED_FIFO (fifo) and the configured CPUs (cpus).  Non-rt. */
static int create_thread(struct rmd_loop *l, bool fifo, bool cpus)
{
	const struct rmd_config_loop *cl = &l->cfg->loop;
	struct sched_param sp = { .sched_priority = (int)cl->rt_priority };
	pthread_attr_t attr;
	int r;

	r = -pthread_attr_init(&attr);
	if (r)
		return r;
	r = -pthread_attr_setstacksize(&attr, RMD_LOOP_STACK_SIZE);
	if (!r && fifo) {
		r = -pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
		if (!r)
			r = -pthread_attr_setschedpolicy(&attr, SCHED_FIFO);
		if (!r)
			r = -pthread_attr_setschedparam(&attr, &sp);
	}
	if (!r && cpus) {
		cpu_set_t set;

		CPU_ZERO(&set);
		for (unsigned k = 0; k < cl->n_cpus && k < RMD_CONFIG_MAX_CPUS; k++)
			if (cl->cpus[k] < CPU_SETSIZE)
				CPU_SET(cl->cpus[k], &set);
		r = -pthread_attr_setaffinity_np(&attr, sizeof(set), &set);
	}
	if (!r)
		r = -pthread_create(&l->thread, &attr, thread_main, l);
	pthread_attr_destroy(&attr);
	return r;
}

/*
 * loop.keep_cpus_awake: a PM QoS request of 0 us CPU wake-up latency,
 * held as long as its descriptor is open (the kernel's
 * Documentation/power/pm_qos_interface.rst; cyclictest does the same).
 * Returns 0 or -errno.  Non-rt.
 */
static int hold_cpus_awake(struct rmd_loop *l)
{
	int32_t zero = 0;
	int fd = open("/dev/cpu_dma_latency", O_WRONLY | O_CLOEXEC);

	if (fd < 0)
		return -errno;
	if (write(fd, &zero, sizeof(zero)) != (ssize_t)sizeof(zero)) {
		int r = -errno;

		close(fd);
		return r ? r : -EIO;
	}
	l->qos_fd = fd;
	return 0;
}

/* The PM QoS request ends with its descriptor.  Non-rt. */
void loop_release_cpus(struct rmd_loop *l)
{
	if (l->qos_fd >= 0)
		close(l->qos_fd);
	l->qos_fd = -1;
}

/* Non-rt. */
int rmd_loop_lock_memory(struct rmd_loop *l)
{
	if (l->locked)
		return 0;
	if (mlockall(MCL_CURRENT | MCL_FUTURE) < 0) {
		if (l->o.require_rt)
			return -EPERM;
		/* said by rmd_loop_start(), with the other real-time refusals */
		l->mlock_err = -errno;
	}
	l->locked = true;
	return 0;
}

int rmd_loop_start(struct rmd_loop *l)
{
	bool fifo = true, cpus = l->cfg->loop.n_cpus > 0;
	int64_t now = rmd_now_ns();
	int r;

	if (l->running)
		return -EBUSY;
	if (l->o.now_ns)
		return -EINVAL;
	atomic_store(&l->stop, false);
	r = rmd_loop_lock_memory(l);
	if (r < 0)
		return r;
	if (l->mlock_err)
		loop_event(l, now, RMD_EV_RT, 0xFF, 0xFF, l->mlock_err, RMD_LOOP_RT_MLOCK);
	if (l->cfg->loop.keep_cpus_awake && l->qos_fd < 0) {
		r = hold_cpus_awake(l);
		if (r < 0)
			loop_event(l, now, RMD_EV_RT, 0xFF, 0xFF, r, RMD_LOOP_RT_CPU_AWAKE);
	}
	/*
	 * Every fallback is decided, and said through the event ring, before
	 * the thread exists: the ring has one producer at a time.
	 */
	for (;;) {
		r = create_thread(l, fifo, cpus);
		if (r == -EPERM && fifo && !l->o.require_rt) {
			loop_event(l, now, RMD_EV_RT, 0xFF, 0xFF, r, RMD_LOOP_RT_FIFO);
			fifo = false;
			continue;
		}
		if (r == -EINVAL && cpus && !l->o.require_rt) {
			loop_event(l, now, RMD_EV_RT, 0xFF, 0xFF, r, RMD_LOOP_RT_AFFINITY);
			cpus = false;
			continue;
		}
		break;
	}
	if (r)
		return r;
	l->running = true;
	return 0;
}

/* rt-safe and async-signal-safe. */
void rmd_loop_request_stop(struct rmd_loop *l)
{
	atomic_store_explicit(&l->stop, true, memory_order_release);
}

/* Non-rt. */
int rmd_loop_join(struct rmd_loop *l)
{
	int r;

	if (!l->running)
		return 0;
	r = -pthread_join(l->thread, NULL);
	if (!r) {
		l->running = false;
		loop_release_cpus(l);
	}
	return r;
}
