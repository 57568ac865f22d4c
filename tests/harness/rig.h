/* SPDX-License-Identifier: MIT */
/*
 * The sim rig of the loop suites (test_loop_*, test_lifecycle, test_estop,
 * test_power_glitch, test_mit_mode, test_bringup, test_loop_alloc,
 * test_latency): a configuration whose buses are all simulated, opened in
 * one place, so that how a test opens a bus from its configuration entry
 * changes here alone; and a loop on them driven on the injected clock
 * (harness/clock.h), so that how a test brings one up and runs its cycles
 * is written once.
 */
#ifndef RMD_TESTS_RIG_H
#define RMD_TESTS_RIG_H

#include <stdbool.h>
#include <stdint.h>

#include "harness/loop_io.h"
#include "rmd/bringup.h"
#include "rmd/bus.h"
#include "rmd/config.h"
#include "rmd/loop.h"
#include "rmd/sim_setup.h"
#include "rmd/sim_wire.h"
#include "rmd/state.h"

/*
 * Open every bus of cfg (all sim buses, with sim's settings and models;
 * NULL: the simulator's defaults) into buses[0..n_buses-1] through the bus
 * factory; fails the test naming the bus, after closing those it opened.
 */
void rig_open_buses(const struct rmd_config *cfg, const struct rmd_sim_setup *sim,
		    struct rmd_bus *buses);

/*
 * m, as bring-up reports a simulator default motor: found, X8S2V10,
 * firmware 20220206, 48.0 V, 25 °C, no errors, 0xB3 written.
 */
void rig_assert_default_motor(const struct rmd_bringup_motor *m);

#define RIG_EVENTS_MAX 8192

/*
 * A loop on sim buses and what a test drives it with.  A test calls
 * rig_reset(), fills in io.cfg and io.sim (rmd_config_sim_default() or a
 * file), sets the options below, then rig_start(), rig_bring_up(),
 * rig_run() as it needs, and rig_stop().
 */
struct rig {
	struct rig_loop io;	      /* configuration, plan, buses, channels */
	struct rmd_loop *l;	      /* rig_start()'s */
	struct rmd_command cmd;	      /* the controller's, published by rig_run() */
	struct rmd_bringup report;    /* of the last rig_bring_up() */
	int64_t epoch[RMD_MAX_BUSES]; /* caller time at sim time 0, per bus (rig_bring_up()) */
	/* options, after rig_reset() */
	bool real_clock;     /* rig_start(): the loop on CLOCK_MONOTONIC, not the injected clock */
	bool rt;	     /* rig_run(): each cycle as the rt thread runs it (rig_loop_cycle()) */
	void (*each)(void);  /* rig_run(): called after each cycle, when set */
	bool events_in_ring; /* rig_run(): leave the events in io.events for the test to pop */
	/* the loop's events so far (rig_events()); a test may set nev to 0 to forget them */
	struct rmd_event ev[RIG_EVENTS_MAX];
	unsigned nev;
};

/* r zeroed, the wire log (rig_wire_tap()) emptied and the injected clock at 1 s. */
void rig_reset(struct rig *r);

#define RIG_WIRE_MAX 65536

/* The frames the host put on the sim buses, and the motors', in order (rig_wire_tap()). */
extern struct rmd_frame rig_host[RIG_WIRE_MAX], rig_motor[RIG_WIRE_MAX];
extern unsigned rig_host_n, rig_motor_n;

/* A tap for rig_start() that logs every frame into rig_host[] or rig_motor[] while there is room. */
void rig_wire_tap(void *ctx, const struct rmd_sim_pending *p, int64_t start_ns, int64_t eof_ns);

/*
 * r's plan built from r->io.cfg, its buses opened (rig_open()) and the loop
 * made on them (rig_loop_opts()); fails the test saying what failed.
 */
void rig_start(struct rig *r, rmd_sim_wire_tap_fn *tap);

/* r's buses opened (rig_open_buses()) with tap on each (NULL: none; ctx: the bus's index). */
void rig_open(struct rig *r, rmd_sim_wire_tap_fn *tap);

/*
 * The loop's bring-up (fails the test unless it returns 0), then the clock
 * on the next whole millisecond and each bus's epoch for it.
 */
void rig_bring_up(struct rig *r);

/* The loop freed, every bus closed. */
void rig_stop(struct rig *r);

/*
 * n cycles, one period apart on the injected clock: r->cmd published before
 * each when with_cmd (its rx_ns now, seq one more), r->each after each;
 * then the events taken in (rig_events()) unless r->events_in_ring.
 */
void rig_run(struct rig *r, unsigned n, bool with_cmd);

/* The loop's events so far appended to r->ev (while there is room). */
void rig_events(struct rig *r);

/* How many of r's events are of kind, for motor (< 0: any) with a (< 0: any); takes them in first. */
unsigned rig_count_events(struct rig *r, unsigned kind, int motor, int64_t a);

#endif /* RMD_TESTS_RIG_H */
