/* SPDX-License-Identifier: MIT */
/*
 * The event loop of the system suites (harness/vsys.c, test_vcan_batch):
 * a suite that runs programs (harness/proc.h) and is their controller over
 * LCM waits for either in one poll() and publishes its commands on a
 * period of its own, whatever else it waits for.
 */
#ifndef RMD_TESTS_EVLOOP_H
#define RMD_TESTS_EVLOOP_H

#include <stdbool.h>
#include <stdint.h>

#include <lcm/lcm.h>

/* A controller's commands: publishing or not, every period_ns, next at next_ns. */
struct ctl_clock {
	bool on;
	int64_t next_ns; /* CLOCK_MONOTONIC */
	int64_t period_ns;
	void (*publish)(void);
};

/*
 * One turn: wait at most max_ms -- less when c is on and due first, or
 * other_due_ns (CLOCK_MONOTONIC; INT64_MAX: none) comes first -- for LCM
 * (lcm; NULL: none) or a child's output, and handle what came; then, when
 * c is due, c->publish() and its next time a period on (late: skipped
 * ahead, no burst).
 */
void evloop_turn(lcm_t *lcm, struct ctl_clock *c, int64_t other_due_ns, int max_ms);

/* service(ms) until ms milliseconds have passed (a measurement window, not a wait for a result). */
void evloop_run_for(void (*service)(int max_ms), int ms);

#endif /* RMD_TESTS_EVLOOP_H */
