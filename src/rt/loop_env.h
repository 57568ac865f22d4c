/* SPDX-License-Identifier: MIT */
/*
 * loop_env.c: what every file of the loop stands on -- its clock, sleeps
 * and waits, and its events.  rt-safe unless said.
 */
#ifndef RMD_LOOP_ENV_H
#define RMD_LOOP_ENV_H

#include <stdint.h>
#include <time.h>

#include "rmd/bus.h"
#include "rmd/state.h"
#include "loop_state.h"

int64_t loop_now(const struct rmd_loop *l);
struct timespec loop_ts(int64_t ns);
/* Sleep ns: the injected sleep, or clock_nanosleep.  Bounded. */
void loop_sleep(const struct rmd_loop *l, int64_t ns);
/* Wait up to ns for frames on bus (ppoll on its fd when it has one).  Non-rt. */
void loop_wait_bus(const struct rmd_loop *l, struct rmd_bus *bus, int64_t ns);
/* Into the event ring (the daemon words it) and the incident recorder. */
void loop_event(struct rmd_loop *l, int64_t t, unsigned kind, unsigned motor, unsigned bus,
		int64_t a, int64_t b);

/* RMD_EV_BUS_STATE when bus b's state changed since the last look. */
static inline void loop_bus_state(struct rmd_loop *l, unsigned b, int64_t now)
{
	struct lbus *lb = &l->bus[b];
	enum rmd_bus_state st = rmd_bus_state(lb->bus);

	if (st != lb->state_seen) {
		lb->state_seen = (uint8_t)st;
		loop_event(l, now, RMD_EV_BUS_STATE, 0xFF, b, lb->state_seen, 0);
	}
}

#endif /* RMD_LOOP_ENV_H */
