/* SPDX-License-Identifier: MIT */
/*
 * The sim rig of the loop suites (test_loop, test_loop_alloc,
 * test_latency): a configuration whose buses are all simulated, opened in
 * one place, so that how a test opens a bus from its configuration entry
 * changes here alone.
 */
#ifndef RMD_TESTS_RIG_H
#define RMD_TESTS_RIG_H

#include "rmd/bringup.h"
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

/*
 * m, as bring-up reports a simulator default motor: found, X8S2V10,
 * firmware 20220206, 48.0 V, 25 °C, no errors, 0xB3 written.
 */
void rig_assert_default_motor(const struct rmd_bringup_motor *m);

#endif /* RMD_TESTS_RIG_H */
