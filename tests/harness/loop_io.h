/* SPDX-License-Identifier: MIT */
/*
 * The configuration, plan, buses and channels of a loop of the rigs
 * (harness/rig.h's struct rig, test_loop_alloc, test_latency,
 * bench/insn_rig.c): commands in, snapshots and health out, events to the
 * logger, and the loop's options on them with the injected clock
 * (harness/clock.h).  No cmocka: bench/insn_rig.c links it, also against
 * the baseline library of bench/insn-per-cycle.sh.
 */
#ifndef RMD_TESTS_LOOP_IO_H
#define RMD_TESTS_LOOP_IO_H

#include "rmd/bus.h"
#include "rmd/config.h"
#include "rmd/loop.h"
#include "rmd/plan.h"
#include "rmd/sim_setup.h"
#include "rmd/spsc.h"
#include "rmd/state.h"

struct rig_loop {
	struct rmd_config cfg;
	struct rmd_sim_setup sim;
	struct rmd_plan plan;
	struct rmd_bus buses[RMD_MAX_BUSES];
	struct rmd_latest cmds, snaps, health, homes;
	struct rmd_command cmd_buf[3];
	struct rmd_home home_buf[3];
	struct rmd_snapshot snap_buf[3];
	struct rmd_health health_buf[3];
	struct rmd_ring events;
	struct rmd_event ev_buf[4096];
};

/*
 * r's channels made, and *o: the options of a loop over r's cfg, plan and
 * buses (the caller builds and opens them) on them, with the injected
 * clock and no snapshot file.  Returns 0, or rmd_ring_init()'s error.
 */
int rig_loop_opts(struct rig_loop *r, struct rmd_loop_opts *o);

/*
 * One cycle for the tick at now as the rt thread runs it
 * (src/rt/rt_thread.c), on the injected clock: the tick; when the loop
 * waits for the cycle's replies, a receive when they are expected (still
 * missing: a second at 9/10 of the period, before the publish deadline)
 * and the publish; otherwise the next tick publishes.
 */
void rig_loop_cycle(struct rmd_loop *l, int64_t now, int64_t period_ns);

#endif /* RMD_TESTS_LOOP_IO_H */
