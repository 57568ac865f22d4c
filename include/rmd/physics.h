/* SPDX-License-Identifier: MIT */
/*
 * The physics module's face (docs/physics.md): what the simulator
 * (src/sim/sim_body.c) asks of a rigid-body world, as a table of
 * functions that the module, a shared object loaded with dlopen() only
 * when a configuration asks for physics (rmd-physics.so, built from
 * src/physics/ against MuJoCo), hands out.  rmdd and rmd-sim do not link
 * the engine: a machine without it runs everything else.
 *
 * Units are the world's: a hinge joint's position in rad and its force in
 * N·m, a slide joint's in m and N.  Joints are named by their index in
 * the model (the module's joint()).  One world is one model and its state;
 * the module keeps no other state, so several worlds may coexist.
 */
#ifndef RMD_PHYSICS_H
#define RMD_PHYSICS_H

#include <stddef.h>

/* Bumped when the table changes: a module of another version is refused. */
#define RMD_PHYSICS_ABI 1

/* The symbol a module exports: a function returning its table. */
#define RMD_PHYSICS_ENTRY "rmd_physics_module"

/* What kind of joint a name is (struct rmd_physics_ops.joint()). */
enum rmd_physics_joint {
	RMD_PHYSICS_HINGE = 1, /* one rotational dof: rad, N·m */
	RMD_PHYSICS_SLIDE,     /* one translational dof: m, N */
	RMD_PHYSICS_OTHER,     /* free or ball: not a motor's joint */
};

struct rmd_physics_ops {
	unsigned abi;	    /* RMD_PHYSICS_ABI */
	const char *engine; /* e.g. "MuJoCo 2.2.2" */
	/*
	 * Load the model file at path and make its world (state at the
	 * model's reference pose, at rest).  NULL on failure, the engine's
	 * message (with the model's line where it gives one) in err.
	 * Non-rt: allocates everything the steps use.
	 */
	void *(*load)(const char *path, char *err, size_t errlen);
	void (*free)(void *world); /* NULL: no-op.  Non-rt. */
	/* The model's own integration step, s (its <option timestep>). */
	double (*timestep_s)(const void *world);
	/*
	 * Set the integration step (s > 0) for the steps from now on.
	 * Non-rt.
	 */
	void (*set_timestep_s)(void *world, double s);
	/* The model's integrator, as the model file spells it ("Euler", "RK4", ...). */
	const char *(*integrator)(const void *world);
	/* Joint `name`'s index (>= 0) and kind, or -ENOENT.  Non-rt. */
	int (*joint)(const void *world, const char *name, enum rmd_physics_joint *kind);
	int (*n_joints)(const void *world);
	const char *(*joint_name)(const void *world, int joint); /* "" for an unnamed one */
	/*
	 * Add to a joint's dof its actuator's own reflected inertia (armature,
	 * kg·m²), viscous friction (N·m·s/rad) and dry friction (N·m), which
	 * the engine then integrates implicitly.  Non-rt.
	 */
	void (*add_drive)(void *world, int joint, double armature, double damping,
			  double frictionloss);
	/* A joint's position and velocity, now.  Rt-safe. */
	void (*get)(const void *world, int joint, double *pos, double *vel);
	/* Put a joint at pos with velocity vel (the world's derived state follows).  Rt-safe. */
	void (*set)(void *world, int joint, double pos, double vel);
	/* The generalized force on a joint for the steps from now on (replaces).  Rt-safe. */
	void (*force)(void *world, int joint, double f);
	/*
	 * n integration steps.  Returns how many times the engine found its
	 * state diverged and reset it since the load (0 in a sane model).
	 * Rt-safe: no allocation, no I/O.
	 */
	unsigned (*step)(void *world, unsigned n);
	/* Simulated time of the world, s. */
	double (*time_s)(const void *world);
};

/* The module's entry (RMD_PHYSICS_ENTRY). */
const struct rmd_physics_ops *rmd_physics_module(void);

#endif /* RMD_PHYSICS_H */
