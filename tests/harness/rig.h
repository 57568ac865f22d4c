/* SPDX-License-Identifier: MIT */
/*
 * The sim rig of the loop suites (test_loop, test_loop_alloc,
 * test_latency): a configuration whose buses are all simulated, opened in
 * one place, so that how a test opens a bus from its configuration entry
 * changes here alone.
 */
#ifndef RMD_TESTS_RIG_H
#define RMD_TESTS_RIG_H

#include "rmd/bus.h"
#include "rmd/config.h"
#include "rmd/sim_setup.h"

/*
 * Open every bus of cfg (all sim buses, with sim's settings and models;
 * NULL: the simulator's defaults) into buses[0..n_buses-1] through the bus
 * factory; fails the test naming the bus, after closing those it opened.
 */
void rig_open_buses(const struct rmd_config *cfg, const struct rmd_sim_setup *sim,
		    struct rmd_bus *buses);

#endif /* RMD_TESTS_RIG_H */
