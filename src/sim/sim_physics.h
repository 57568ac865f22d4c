/* SPDX-License-Identifier: MIT */
/*
 * The simulated motor's physics (sim_physics.c) as its protocol side
 * (sim_motor.c) calls it, and what both use: unit helpers and the factory
 * PI gains the control loops scale by.  Private to src/sim/; every
 * function rt-safe.
 */
#ifndef RMD_SIM_PHYSICS_H
#define RMD_SIM_PHYSICS_H

#include <math.h>
#include <stdint.h>

#include "rmd/sim.h"

/* V3 §2.1.4: the example's gains 0x55/0x19, taken as the factory values. */
#define V3_PID_DEFAULT_KP 85
#define V3_PID_DEFAULT_KI 25
/* V2 §3.1: Q24 gains; the manual's example value 0.25 taken as factory value. */
#define V2_PID_DEFAULT (INT64_C(1) << 22)

/* V4.2 §2.1.5: the example's gain 1.0 (0x3F800000), taken as every index's factory value. */
#define V4_GAIN_DEFAULT 1.0f

/* The factory value of PI gain i (RMD_FLD_CURR_KP order) of a protocol. */
static inline int64_t rmd_sim_pid_default(enum rmd_proto proto, unsigned i)
{
	if (rmd_dialect(proto)->pid == RMD_PID_V2_PER_GAIN)
		return V2_PID_DEFAULT;
	return i % 2 ? V3_PID_DEFAULT_KI : V3_PID_DEFAULT_KP;
}

static inline double deg(double radians)
{
	return radians * (180.0 / M_PI);
}

static inline double rad(double degrees)
{
	return degrees * (M_PI / 180.0);
}

static inline double clamp(double x, double lo, double hi)
{
	return x < lo ? lo : x > hi ? hi : x;
}

/* The multi-turn encoder value without offset (V3 §2.7, 0x61). */
int64_t rmd_sim_raw_counts(const struct rmd_sim_motor *m);

/* The zero offset in use (V3 §2.8), as an output angle. */
double rmd_sim_offset_rad(const struct rmd_sim_motor *m);

/* The output shaft angle the motor reports: from its zero (V3 §2.11). */
double rmd_sim_angle_rad(const struct rmd_sim_motor *m);

/* 0x43 index (V3 §2.5.4) in rad/s^2; 0 is taken as "no limit" (INFINITY). */
double rmd_sim_accel_rad(const struct rmd_sim_motor *m, unsigned index);

/* Electrical power drawn: copper loss plus shaft power, >= 0 (V3 §2.24). */
double rmd_sim_power_w(const struct rmd_sim_motor *m);

/* Output off and the running state cleared (V3 §2.15.1). */
void rmd_sim_off_state(struct rmd_sim_motor *m);

/*
 * Combine the error sources; a level-1 fault also clears the mode, and the
 * first error of a run schedules an error report at once.
 */
void rmd_sim_update_errors(struct rmd_sim_motor *m);

/* Fault detection after a step of dt seconds (V3 §2.12 table 1, §8.2). */
void rmd_sim_detect_faults(struct rmd_sim_motor *m, double dt);

/* The firmware's control loops over dt seconds (0: settle): the iq to apply, A. */
double rmd_sim_control(struct rmd_sim_motor *m, double dt);

/* The shaft is held by the brake (V3 §2.27.1). */
bool rmd_sim_motor_held(const struct rmd_sim_motor *m);

/*
 * One motor step of a motor on a world (rmd/sim_body.h): its firmware
 * over RMD_SIM_STEP_NS with the shaft the world last gave it, its output
 * torque pushed to the world.  sim_body.c calls it for the motors it
 * brings up to an exchange.
 */
void rmd_sim_motor_substep(struct rmd_sim_motor *m);

#endif /* RMD_SIM_PHYSICS_H */
