/* SPDX-License-Identifier: MIT */
/*
 * A body for the simulated motors (docs/physics.md): one rigid-body world
 * (an MJCF model, stepped by the physics module rmd/physics.h) whose
 * joints the configuration's motors drive (sim.physics, struct
 * rmd_sim_physics_setup).  Each attached motor's output torque (kt iq,
 * less its constant load) acts on its joint, and the joint's angle and
 * velocity are the motor's shaft (pos_rad, vel_rad_s), which its encoder
 * and replies report.  The motor's own inertia, viscous and dry friction
 * become the joint's armature, damping and frictionloss, so the engine
 * integrates them with the model.
 *
 * Time is the motors' (rmd_sim_motor_step()): an attached motor steps its
 * firmware (control loops, heat, faults) at RMD_SIM_STEP_NS as before,
 * with the shaft it read at the start of the exchange; the world
 * advances one exchange (1 / rate_hz) only when every attached motor has
 * stepped through it, and the motor that needs the next exchange first
 * steps the others up to it.  So all motors of one world, across the
 * buses of one process, move in lockstep, and the same frames give the
 * same result whatever the order the buses are stepped in.  Every motor
 * of a world must be stepped by one thread (rmdd's rt thread, rmd-sim's
 * one thread).
 */
#ifndef RMD_SIM_BODY_H
#define RMD_SIM_BODY_H

#include <stddef.h>
#include <stdint.h>

#include "rmd/sim.h"
#include "rmd/sim_setup.h"

/* Where the module is installed (RMD_PHYSICS_MODULE_PATH at build time). */
#ifndef RMD_PHYSICS_MODULE_PATH
#define RMD_PHYSICS_MODULE_PATH "/usr/lib/rmdd/rmd-physics.so"
#endif
/* The environment variable that names another module file (tests, a build tree). */
#define RMD_PHYSICS_MODULE_ENV "RMD_PHYSICS_MODULE"

struct rmd_sim_body;

/*
 * Load the physics of ps: the module (RMD_PHYSICS_MODULE_ENV, else
 * ../lib/rmd-physics.so beside the running program, as in a build tree,
 * else RMD_PHYSICS_MODULE_PATH), the model, each mapped joint (a hinge
 * or a slide, each joint of one motor).  Returns 0 and *out, or -errno
 * with one line in err naming ps->source:line and the key:
 *   -ENOENT  no module (what to install), or a joint the model lacks
 *   -EINVAL  the model does not load (MuJoCo's message, its line), a
 *            joint of another kind, one joint for two motors, a bad rate
 *   -ENOEXEC a module of another ABI
 *   -ENOMEM  out of memory
 * ps->model "" is -EINVAL (nothing to load).  Non-rt.
 */
int rmd_sim_body_load(struct rmd_sim_body **out, const struct rmd_sim_physics_setup *ps, char *err,
		      size_t errlen);

/*
 * Free a world (NULL: no-op), after its motors (their buses closed: it
 * does not touch them); a motor still on it must not step again.  Non-rt.
 */
void rmd_sim_body_free(struct rmd_sim_body *b);

/*
 * Put motor m (powered on: rmd_sim_motor_init()) on the joint that ps
 * maps configuration motor `motor` to: the joint starts at m's shaft
 * angle (p.start_angle_deg) at rest, with m's inertia and friction added
 * to it.  Returns 1 when attached, 0 when ps maps no joint to it, -EEXIST
 * when that joint has a motor already.  Non-rt.
 */
int rmd_sim_body_attach(struct rmd_sim_body *b, unsigned motor, struct rmd_sim_motor *m);

/* One line on the world: engine, model, joints, rate, integrator. */
void rmd_sim_body_describe(const struct rmd_sim_body *b, char *out, size_t len);

/* The exchange period, ns (1e9 / rate_hz).  Rt-safe. */
int64_t rmd_sim_body_period_ns(const struct rmd_sim_body *b);

/* Exchanges stepped so far, and the engine's resets of a diverged state.  Rt-safe. */
uint64_t rmd_sim_body_steps(const struct rmd_sim_body *b);
unsigned rmd_sim_body_diverged(const struct rmd_sim_body *b);

/*
 * The motors' side (src/sim/sim_physics.c): attached motor m has stepped
 * its firmware through the current exchange; step the other motors up to
 * it and the world through it.  Rt-safe.
 */
void rmd_sim_body_advance(struct rmd_sim_body *b);

/*
 * Motor m (attached as slot) drove its joint with torque_nm for one
 * motor step; returns true when it has stepped through the exchange.
 * Rt-safe.
 */
bool rmd_sim_body_push(struct rmd_sim_body *b, unsigned slot, double torque_nm);

/* True when m's slot has room for another motor step in this exchange.  Rt-safe. */
bool rmd_sim_body_room(const struct rmd_sim_body *b, unsigned slot);

#endif /* RMD_SIM_BODY_H */
