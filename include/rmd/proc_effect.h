/* SPDX-License-Identifier: MIT */
/*
 * Whether a motor's position commands have an effect (issue 32 point 4):
 * a procedure record that decides and never acts.
 *
 * Firmware may take a position command (0xA4) and not run it: X6-P20
 * 2025070202 ignores it after an MIT frame until it is reset (a field
 * report; rmd_firmware_quirks() refuses the switch for the firmware rmdd
 * knows).  Its answers say so -- where it is, and that it does not move
 * -- so that is judged, for any firmware: a motor driven to a position at
 * least RMD_EFFECT_FAR_RAD away that moves less than RMD_EFFECT_MOVE_RAD
 * in RMD_EFFECT_HOLD_NS, where its commanded speed limit would have taken
 * it several times that far, is told once (until it moves, or comes
 * within RMD_EFFECT_FAR_RAD of its target, or is no longer driven to a
 * position).  A joint blocked by something is told alike: the report says
 * both.  rmdd reports where the motor is, never the target as reached.
 *
 * The rt loop feeds it the motor's position at each status poll (cold).
 * Pure: no clock, no I/O, no allocation; rt-safe.
 */
#ifndef RMD_PROC_EFFECT_H
#define RMD_PROC_EFFECT_H

#include <stdbool.h>
#include <stdint.h>

/* How far from its target a motor is judged (5 deg). */
#define RMD_EFFECT_FAR_RAD 0.0872664626
/* Less than this in RMD_EFFECT_HOLD_NS is no motion (0.5 deg). */
#define RMD_EFFECT_MOVE_RAD 0.00872664626
#define RMD_EFFECT_HOLD_NS INT64_C(500000000)

struct rmd_effect {
	int64_t since_ns; /* it has been at pos_rad since then (0: not watched) */
	double pos_rad;
	bool told; /* told this episode */
};

/*
 * A reading of the motor at now_ns: driven (ENABLED in position mode) to
 * target_rad with speed limit max_vel_rad_s (<= 0: none), at pos_rad.
 * True once an episode, when its commands show no effect (above).
 * rt-safe.
 */
bool rmd_effect_watch(struct rmd_effect *e, bool driven, double target_rad, double max_vel_rad_s,
		      double pos_rad, int64_t now_ns);

#endif /* RMD_PROC_EFFECT_H */
