// SPDX-License-Identifier: MIT
/*
 * What every file of the loop stands on: its clock, its sleeps and waits,
 * and its events (the ring the daemon words them from, and the incident
 * recorder).  Below lifecycle.c, loop_rx.c and loop_tx.c, which call it;
 * it calls none of them.
 *
 * Execution context: rt-safe, except loop_wait_bus() (non-rt).
 */
#define _GNU_SOURCE /* ppoll */
#include <poll.h>
#include <stdint.h>
#include <time.h>

#include "rmd/bus.h"
#include "rmd/incident.h"
#include "rmd/spsc.h"
#include "rmd/time.h"
#include "loop_state.h"
#include "loop_env.h"

/* rt-safe. */
int64_t loop_now(const struct rmd_loop *l)
{
	return l->o.now_ns ? l->o.now_ns(l->o.now_ctx) : rmd_now_ns();
}

/* rt-safe. */
struct timespec loop_ts(int64_t ns)
{
	struct timespec ts = { .tv_sec = ns / RMD_NS_PER_S, .tv_nsec = ns % RMD_NS_PER_S };

	return ts;
}

/* Sleep ns: the injected sleep, or clock_nanosleep.  Bounded.  rt-safe. */
void loop_sleep(const struct rmd_loop *l, int64_t ns)
{
	struct timespec ts;

	if (ns <= 0)
		return;
	if (l->o.sleep_ns) {
		l->o.sleep_ns(l->o.now_ctx, ns);
		return;
	}
	ts = loop_ts(ns);
	clock_nanosleep(CLOCK_MONOTONIC, 0, &ts, NULL);
}

/* Wait up to ns for frames on bus (poll(2) on its fd when it has one).  Non-rt. */
void loop_wait_bus(const struct rmd_loop *l, struct rmd_bus *bus, int64_t ns)
{
	int fd;

	if (ns <= 0)
		return;
	fd = rmd_bus_fd(bus);
	if (l->o.sleep_ns || fd < 0) {
		loop_sleep(l, ns);
	} else {
		struct pollfd pfd = { .fd = fd, .events = POLLIN };
		struct timespec ts = loop_ts(ns);

		ppoll(&pfd, 1, &ts, NULL);
	}
}

/* rt-safe. */
void loop_event(struct rmd_loop *l, int64_t t, unsigned kind, unsigned motor, unsigned bus,
		int64_t a, int64_t b)
{
	struct rmd_event e = {
		.t_ns = t,
		.kind = (uint16_t)kind,
		.motor = (uint8_t)motor,
		.bus = (uint8_t)bus,
		.a = a,
		.b = b,
	};

	if (l->o.events) {
		rmd_ring_push(l->o.events, &e);
		l->ev_pushed = true;
	}
	/* incident recorder: the events beside the frames */
	if (l->o.incidents)
		rmd_incident_event(l->o.incidents, &e);
}
