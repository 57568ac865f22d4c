/* SPDX-License-Identifier: MIT */
/*
 * Can the position a motor reports be trusted after it was powered off or
 * reset?  (docs/faults.md "Position uncertain after power-off".)
 *
 * An RMD motor keeps its multi-turn count in RAM (docs/design.md
 * "Multi-turn position"): after a power cycle or a 0x76 reset (V3 §2.25)
 * it knows where its rotor is within one turn, not how many turns it has
 * made.  Its encoder sits on the rotor (V3 §2.13.4), so the output position
 * it then reports is right only up to a whole number of rotor turns: the
 * ambiguity period at the output shaft is 2 pi / gear_ratio rad (360 deg on
 * a direct-drive motor, 40 deg behind a 1:9 gearbox).  This holds for every
 * dialect: V3's 0x92 and 0x9C report output degrees counted from the
 * rotor, and V2's control replies carry the rotor's single-turn encoder
 * (V2 §3.32), which rmdd unwraps from the 0x92 angle read at bring-up.
 * Firmware that wraps the output angle to +-180 deg instead (as the
 * simulator does, include/rmd/sim.h) loses a whole number of these
 * periods when the gear ratio is a whole number, so the same rule holds.
 *
 * rmdd trusts the reported position when
 *   (a) the motor keeps its count across power-off (V3.5+ firmware: 0x20
 *       index 4, V3 §2.33.4; the config says so: multi_turn_saved), or
 *   (b) the joint's travel band (travel_rad, else its position limits) is
 *       narrower than one period, so exactly one position in the band is
 *       the reported one plus a whole number of periods: rmdd shifts the
 *       reported position there (and its zero offset with it), or
 *   (c) the controller homed it (command over LCM, docs/lcm.md "Homing").
 * Otherwise the position is uncertain, and rmdd refuses the modes that
 * drive to a position (position, MIT with kp > 0).
 *
 * Pure: no state, no allocation, rt-safe.
 */
#ifndef RMD_MULTITURN_H
#define RMD_MULTITURN_H

#include <stdbool.h>

/* What decided a motor's position (rmd_multiturn_settle(); struct rmd_motor_state.pos_trust). */
enum rmd_pos_trust {
	RMD_POS_UNKNOWN = 0, /* not decided yet: no position since the motor (re)appeared */
	RMD_POS_AMBIGUOUS,   /* no band narrower than a period: several positions fit */
	RMD_POS_OUTSIDE,     /* no position in the band fits what the motor reports */
	RMD_POS_SAVED,	     /* the motor keeps its count (multi_turn_saved) */
	RMD_POS_IN_BAND,     /* one position in the travel band fits: shifted there */
	RMD_POS_HOMED,	     /* the controller said where the motor is */
	RMD_POS_TRUST_COUNT
};

/* The position may drive a position loop.  rt-safe. */
static inline bool rmd_pos_trusted(unsigned trust)
{
	return trust == RMD_POS_SAVED || trust == RMD_POS_IN_BAND || trust == RMD_POS_HOMED;
}

/* One motor's facts for the decision, in its reported frame (rad at the output shaft). */
struct rmd_multiturn {
	bool saved;	   /* the motor keeps its multi-turn count across power-off */
	double period_rad; /* rmd_multiturn_period_rad(gear_ratio) */
	/* the travel band: where the joint can physically be; +-INFINITY: none */
	double lo_rad, hi_rad;
	/* the reading's step (rmd_motor_pos_resolution_rad()): widens the band both ways */
	double tol_rad;
};

/* 2 pi / gear_ratio: one rotor turn at the output shaft.  rt-safe. */
double rmd_multiturn_period_rad(double gear_ratio);

/*
 * Whether band [lo, hi] widened by tol both ways is narrower than one
 * period, so that it holds at most one position of each class.  rt-safe.
 */
bool rmd_multiturn_band_unique(const struct rmd_multiturn *mt);

/*
 * Whether position pos_rad (finite) lies in the travel band widened by
 * the reading's step; a band that is infinite on a side admits anything
 * on that side.  rt-safe.
 */
bool rmd_multiturn_in_band(const struct rmd_multiturn *mt, double pos_rad);

/*
 * Decide on position pos_rad as the motor reports it now.  *shift_rad gets
 * what to add to the reported position (a whole number of periods; 0
 * unless RMD_POS_IN_BAND).  Returns RMD_POS_SAVED, RMD_POS_IN_BAND,
 * RMD_POS_AMBIGUOUS (no finite band narrower than a period) or
 * RMD_POS_OUTSIDE (no whole number of periods brings it into the band: the
 * joint is outside its travel, or the band is wrong).  A non-finite
 * pos_rad is ambiguous.  rt-safe.
 */
enum rmd_pos_trust rmd_multiturn_settle(const struct rmd_multiturn *mt, double pos_rad,
					double *shift_rad);

#endif /* RMD_MULTITURN_H */
