/* SPDX-License-Identifier: MIT */
/*
 * The leg of examples/physics/ judged through rmdd's state_t, for the
 * suites that stand it: on rmdd's sim bus (tests/system/test_physics_leg.c)
 * and against rmd-sim on vcan0 (tests/system/test_vcan_leg.c).  The hip's
 * height comes from the joint angles in state_t and the model's kinematics
 * (examples/physics/leg.h): the foot is on the floor, and the sim puts
 * nothing on the wire that a real leg would not.
 */
#ifndef RMD_TESTS_LEG_H
#define RMD_TESTS_LEG_H

#include "harness/proc.h"

#include <stdbool.h>

/*
 * Whether rmdd (its path) finds the physics module beside it
 * (build/lib/rmd-physics.so, as rmdd looks for it) or $RMD_PHYSICS_MODULE
 * names one; when not, one line on stderr naming suite and the file: the
 * suite skips (a build without MuJoCo).
 */
bool physics_module_found(const char *rmdd, const char *suite);

#define LEG_STAND_TOL_M 0.015 /* standing: the hip's height within this of leg.h's */
#define LEG_FALL_M 0.08	      /* fallen: at least this far below it */

/*
 * With rmdd running on the leg's configuration at url (rmdd: its kid, to
 * notice an exit): starts leg_stand (its path) and judges, from state_t:
 *   - it stands: once leg_stand says so, the hip's height stays within
 *     LEG_STAND_TOL_M of LEG_STAND_M over `stand_states` states, both
 *     motors ENABLED, the knee carrying the weight (its current);
 *   - it falls when the controller dies: leg_stand killed (SIGKILL), both
 *     motors go SAFE (the watchdog's safe action, stop: their replies show
 *     no current), and the hip then drops LEG_FALL_M with the knee folding.
 * wait_ms: the longest wait for each step (the guest is slow).
 *
 * A judgement that fails asks leg_busy first, when set: a machine too busy
 * to judge (it says why into why) makes the test skip, "busy machine: ...
 * not judged", instead of failing.
 */
extern bool (*leg_busy)(char *why, size_t size);

void leg_stand_and_fall(const char *url, const char *leg_stand, struct kid *rmdd,
			unsigned stand_states, int wait_ms);

#endif /* RMD_TESTS_LEG_H */
