/* SPDX-License-Identifier: MIT */
/*
 * The rig of the rt loop suites (tests/unit/test_loop_*.c, one subject
 * each): rmd_loop_cycle() driven with an injected clock (harness/clock.h)
 * over in-process simulated buses (the sim's time follows the now_ns each
 * call passes), through the sim rig (harness/rig.h).  A tap on every sim
 * bus records the frames the host put on the wire, so a test checks what
 * actually went out.
 *
 * The names are the suites' own (they were one file): one rig R, one
 * trace, run(), snap(), sent_to() and the rest, with no prefix.
 */
#ifndef RMD_TESTS_LOOP_RIG_H
#define RMD_TESTS_LOOP_RIG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "harness/clock.h"
#include "harness/loop_io.h"
#include "harness/rig.h"
#include "rmd/bringup.h"
#include "rmd/bus_sim.h"
#include "rmd/config.h"
#include "rmd/loop.h"
#include "rmd/plan.h"
#include "rmd/sim.h"
#include "rmd/sim_wire.h"
#include "rmd/spsc.h"
#include "rmd/state.h"

#define MS INT64_C(1000000)
#define US INT64_C(1000)
#define TRACE_MAX 65536

/* ---- frames the host put on the wire --------------------------------------- */

struct sent {
	unsigned bus;
	struct rmd_frame f;
	int64_t t_ns; /* caller's clock, start of frame */
};

extern struct sent trace[TRACE_MAX];
extern unsigned trace_n;

/*
 * When set, the tap hands it every frame on bus b first, host's and
 * motors' (start_ns: sim time); it may rewrite a motor's reply in place.
 */
extern void (*rig_tap_hook)(unsigned b, const struct rmd_sim_pending *p, int64_t start_ns);

/* ---- the rig ---------------------------------------------------------------- */

/* R.cmd: the command the test builds; R.report: of the last bring-up; R.ev: its events */
extern struct rig R;
/* when set, rig_up() hands it the simulated motors' setup before it opens the buses */
extern void (*rig_sim_tweak)(struct rmd_sim_setup *sim);

typedef void tweak_fn(struct rmd_config *cfg);

/* The loop's events taken into R.ev. */
void events_pump(void);

/* How many events of kind for motor (< 0: any). */
unsigned count_ev(unsigned kind, int motor);

/*
 * n V3 motors three to a sim bus (rmd_config_sim_default()), tweaked, and a
 * loop on them, on the injected clock or (real) on CLOCK_MONOTONIC.
 */
void rig_up_clock(unsigned n, tweak_fn *tweak, bool real);
void rig_up(unsigned n, tweak_fn *tweak);
void rig_down(void);

/* R's buses opened again from R.io.cfg and R.io.sim, with the tap (after a rig_down()). */
void open_buses(void);

/* Bring-up, then the clock on a whole millisecond; the epochs for the tap. */
void bring_up(void);

int64_t period(void);

/* n cycles, one period apart; with_cmd: publish R.cmd before each. */
void run(unsigned n, bool with_cmd);

/* How many commands the loop ignored for `why` over n cycles run with R.cmd. */
uint64_t ignored_over(unsigned n, enum rmd_ignore why);

void cmd_clear(void);
struct rmd_setpoint *cmd_motor(unsigned i, bool enable, enum rmd_mode mode);
struct rmd_snapshot snap(void);
struct rmd_sim_motor *sim_motor(unsigned i);
unsigned lifecycle(unsigned i);

/* Host frames to motor i (its 0x140 + ID or 0x400 + ID) with command byte cmd since trace[from]. */
unsigned sent_to(unsigned i, int cmd, unsigned from);

/* A frame that makes a motor move: control commands, 0x77, 0x88, MIT, 0x280. */
bool moves_frame(const struct rmd_frame *f);

/* n 0 clears the table (f then points at a dummy: rmd_sim_wire_set_faults() memcpy()s it) */
void set_faults(unsigned bus, const struct rmd_sim_fault *f, size_t n);

int64_t sim_time(unsigned bus);

/*
 * Fault f on bus 0 from the sim's time now, for for_ns (0: until cleared);
 * returns trace_n, where its effects begin.
 */
unsigned fault_now(struct rmd_sim_fault *f, int64_t for_ns);

/* `motors` brought up (rig_up()), the first n running in speed mode at vel_rad_s for `cycles`. */
void motors_at_speed(unsigned motors, tweak_fn *tweak, unsigned n, double vel_rad_s,
		     unsigned cycles);

/* Three motors brought up, the first n running in speed mode at vel_rad_s for `cycles`. */
void up_at_speed(tweak_fn *tweak, unsigned n, double vel_rad_s, unsigned cycles);

/* Three motors on one bus, enabled in speed mode at 1 rad/s for 200 cycles. */
void three_at_speed(void);

/*
 * Motor 2 alone got the safe action: one event, its stop (0x80) on the wire
 * since trace[from] and its output off; motors 1 and 3 still ENABLED.
 * Runs 5 cycles.
 */
void assert_motor2_alone_stopped(unsigned from);

/* What a controller does for motor i back from LOST: enable = 0, then 1 (1 rad/s); 22 cycles. */
void cl_reenable(unsigned i);

/* A tweak: probe.on_missing start. */
void missing_start(struct rmd_config *cfg);

#endif /* RMD_TESTS_LOOP_RIG_H */
