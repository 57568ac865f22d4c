/* SPDX-License-Identifier: MIT */
/*
 * The position after a power cycle, and homing (docs/faults.md "Position
 * uncertain after power-off"): a procedure record that decides and never
 * acts, over the rule of rmd/multiturn.h.
 *
 * A motor that appears (bring-up) or returns from LOST may have been
 * powered off, and its multi-turn count with it.  Its position is then
 * trusted when the configuration says it keeps its count, or decided on
 * the first two positions received after the settle began that come to
 * the same decision (rmd_settle_reading()): one frame that decodes but is
 * not the motor's (garbled, or another node on its identifier) must not
 * move the frame its commands go in by whole turns.  A controller may say
 * where the motor is instead (rmd_settle_home(): rmd.home_t), within the
 * joint's travel only.
 *
 * The rt loop drives it with the positions its replies carry
 * (src/rt/loop_rx.c); src/rt/lifecycle.c applies the decisions (the
 * state's trust, the frame's shift, the events).
 *
 * Pure: no clock, no I/O, no allocation; rt-safe.
 */
#ifndef RMD_PROC_SETTLE_H
#define RMD_PROC_SETTLE_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/multiturn.h"
#include "rmd/state.h"

struct rmd_settle {
	bool on;	    /* the next position received from due_ns on decides */
	bool warned;	    /* this episode's refusal of a position setpoint was reported */
	uint8_t cand_trust; /* the earlier reading's decision (enum rmd_pos_trust; UNKNOWN: none) */
	int64_t due_ns;
	double cand_shift; /* ... and its shift */
};

/* Lost: nothing is known of the position any more, no settle runs.  rt-safe. */
void rmd_settle_forget(struct rmd_settle *s);

/*
 * The motor appeared or is back at now: RMD_POS_SAVED when it keeps its
 * count (decided at once), else RMD_POS_UNKNOWN: the settle runs.  rt-safe.
 */
enum rmd_pos_trust rmd_settle_begin(struct rmd_settle *s, const struct rmd_multiturn *mt,
				    int64_t now_ns);

/* Whether a position received at pos_rx_ns is one the settle decides on.  rt-safe. */
static inline bool rmd_settle_due(const struct rmd_settle *s, int64_t pos_rx_ns)
{
	return s->on && pos_rx_ns >= s->due_ns;
}

/*
 * A position the motor reported (pos_rad, received at pos_rx_ns; due):
 * RMD_POS_UNKNOWN while it is the first of two, or the second disagrees
 * (it becomes the first); else the decision (rmd_multiturn_settle()), in
 * *shift_rad what to add to the reported frame.  rt-safe.
 */
enum rmd_pos_trust rmd_settle_reading(struct rmd_settle *s, const struct rmd_multiturn *mt,
				      double pos_rad, int64_t pos_rx_ns, double *shift_rad);

/*
 * The decision t was applied: no settle runs; a trusted position ends the
 * episode of refusals (rmd_settle_warn_once()).  rt-safe.
 */
void rmd_settle_decided(struct rmd_settle *s, enum rmd_pos_trust t);

/* True the first time in an episode that a position setpoint is refused: report it.  rt-safe. */
bool rmd_settle_warn_once(struct rmd_settle *s);

/* What the loop knows of the motor a homing request is for. */
struct rmd_settle_home_facts {
	bool enabled;	 /* ENABLED: its position must not jump under a running loop */
	bool reachable;	 /* not LOST, nor PROBE */
	bool have_pos;	 /* it reported a position since it (re)appeared */
	double reported; /* that position, in the reported frame */
};

/*
 * A controller says the motor is at pos_rad now (or where it reports,
 * as_reported).  0 with *shift_rad, what to add to the reported frame
 * (the motor does not move); else why it is refused (enum
 * rmd_home_refusal), *at_rad the position it would have been homed at.
 * Refused while enabled, before a position came or while the settle
 * runs, and at a position outside the travel band (rmd_multiturn_in_band():
 * the frame would move so that setpoints within the limits drive the
 * joint past them).  rt-safe.
 */
int rmd_settle_home(const struct rmd_settle *s, const struct rmd_multiturn *mt,
		    const struct rmd_settle_home_facts *f, bool as_reported, double pos_rad,
		    double *shift_rad, double *at_rad);

#endif /* RMD_PROC_SETTLE_H */
