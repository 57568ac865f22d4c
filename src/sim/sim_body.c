// SPDX-License-Identifier: MIT
/*
 * A body for the simulated motors (rmd/sim_body.h): the physics module
 * found and loaded with dlopen(), its world, and the lockstep of the
 * world with the motors that drive its joints.
 *
 * Load, attach and free are non-rt (dlopen, the engine's allocations);
 * the steps are rt-safe: the engine's mj_step() allocates nothing, and
 * everything here is a fixed array.
 */
#define _GNU_SOURCE /* program_invocation_short_name */
#include <dlfcn.h>
#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "rmd/err.h"
#include "rmd/physics.h"
#include "rmd/sim_body.h"
#include "sim_physics.h"

/* One attached motor. */
struct slot {
	struct rmd_sim_motor *m;
	int joint;
	unsigned sub;	   /* motor steps done in the current exchange */
	double torque_sum; /* of those steps, N·m (a slide: N) */
	/*
	 * The motor's count minus the joint's angle: 0 at attach; a start
	 * that wraps the motor's multi-turn count (a power cycle) moves it,
	 * not the joint.
	 */
	double offset_rad;
	double last_pos_rad; /* what the world last wrote to m->pos_rad */
};

struct rmd_sim_body {
	void *dl;
	const struct rmd_physics_ops *ops;
	void *w;
	unsigned k;	   /* motor steps per exchange */
	unsigned substeps; /* integration steps per exchange */
	int64_t period_ns;
	int joint_of[RMD_MAX_MOTORS]; /* by configuration motor; -1: none */
	struct slot slots[RMD_MAX_MOTORS];
	unsigned n_slots;
	uint64_t steps;
	unsigned diverged;
	char model[RMD_SIM_MODEL_PATH_LEN];
};

/* The module file to load into *path; false: none of the places has one (path: the last). */
static bool find_module(char *path, size_t len)
{
	const char *env = getenv(RMD_PHYSICS_MODULE_ENV);
	char exe[PATH_MAX - 32]; /* room for the module's name after it */
	ssize_t n;

	if (env && env[0]) {
		snprintf(path, len, "%s", env);
		return access(path, R_OK) == 0;
	}
	/* a build tree: build/rmdd beside build/lib/rmd-physics.so */
	n = readlink("/proc/self/exe", exe, sizeof(exe) - 1);
	if (n > 0) {
		char *slash;

		exe[n] = '\0';
		slash = strrchr(exe, '/');
		if (slash) {
			*slash = '\0';
			snprintf(path, len, "%.*s/lib/rmd-physics.so", (int)(sizeof(exe) - 1), exe);
			if (access(path, R_OK) == 0)
				return true;
		}
	}
	snprintf(path, len, "%s", RMD_PHYSICS_MODULE_PATH);
	return access(path, R_OK) == 0;
}

static int open_module(struct rmd_sim_body *b, const struct rmd_sim_physics_setup *ps, char *err,
		       size_t errlen)
{
	const struct rmd_physics_ops *(*entry)(void);
	char path[PATH_MAX];
	bool found = find_module(path, sizeof(path));
	const char *why;

	b->dl = found ? dlopen(path, RTLD_NOW | RTLD_LOCAL) : NULL;
	if (!b->dl) {
		why = found ? dlerror() : "not found";
		return rmd_errf(err, errlen, -ENOENT,
				"%s:%u: sim.physics: this %s has no physics module (%s: %s): "
				"install the rmdd-physics package, or build with libmujoco-dev "
				"(docs/physics.md)",
				ps->source, ps->model_line, program_invocation_short_name, path,
				why ? why : "?");
	}
	*(void **)&entry = dlsym(b->dl, RMD_PHYSICS_ENTRY);
	b->ops = entry ? entry() : NULL;
	if (!b->ops || b->ops->abi != RMD_PHYSICS_ABI)
		return rmd_errf(
			err, errlen, -ENOEXEC,
			"%s:%u: sim.physics: %s is not a physics module of this rmdd (ABI "
			"%u, want %u): install the rmdd-physics package of the same version",
			ps->source, ps->model_line, path, b->ops ? b->ops->abi : 0,
			RMD_PHYSICS_ABI);
	return 0;
}

/* The model's joint names, for "its joints: ..." (at most len bytes). */
static void joint_list(const struct rmd_sim_body *b, char *out, size_t len)
{
	size_t used = 0;
	int n = b->ops->n_joints(b->w);

	out[0] = '\0';
	for (int j = 0; j < n && used + 1 < len; j++) {
		int r = snprintf(out + used, len - used, "%s%s", j ? ", " : "",
				 b->ops->joint_name(b->w, j)[0] ? b->ops->joint_name(b->w, j) :
								  "(unnamed)");

		if (r < 0)
			break;
		used += (size_t)r;
	}
	if (!n)
		snprintf(out, len, "none");
}

static int check_joints(struct rmd_sim_body *b, const struct rmd_sim_physics_setup *ps, char *err,
			size_t errlen)
{
	for (unsigned i = 0; i < ps->n_joints; i++) {
		const struct rmd_sim_physics_joint *pj = &ps->joints[i];
		enum rmd_physics_joint kind = RMD_PHYSICS_OTHER;
		int j = b->ops->joint(b->w, pj->joint, &kind);
		char names[256];

		if (j < 0) {
			joint_list(b, names, sizeof(names));
			return rmd_errf(
				err, errlen, -ENOENT,
				"%s:%u: sim.physics.joints: the model %s has no joint \"%s\" "
				"(its joints: %s)",
				ps->source, pj->line, ps->model, pj->joint, names);
		}
		if (kind != RMD_PHYSICS_HINGE && kind != RMD_PHYSICS_SLIDE)
			return rmd_errf(
				err, errlen, -EINVAL,
				"%s:%u: sim.physics.joints: joint \"%s\" of %s is neither a "
				"hinge nor a slide: a motor drives one degree of freedom",
				ps->source, pj->line, pj->joint, ps->model);
		for (unsigned o = 0; o < i; o++)
			if (b->joint_of[ps->joints[o].motor] == j)
				return rmd_errf(err, errlen, -EINVAL,
						"%s:%u: sim.physics.joints: joint \"%s\" is mapped "
						"twice (line %u too): one motor per joint",
						ps->source, pj->line, pj->joint,
						ps->joints[o].line);
		if (pj->motor >= RMD_MAX_MOTORS)
			return rmd_errf(err, errlen, -EINVAL,
					"%s:%u: sim.physics.joints: bad motor", ps->source,
					pj->line);
		if (b->joint_of[pj->motor] >= 0)
			return rmd_errf(err, errlen, -EINVAL,
					"%s:%u: sim.physics.joints: the motor is mapped twice",
					ps->source, pj->line);
		b->joint_of[pj->motor] = j;
	}
	return 0;
}

int rmd_sim_body_load(struct rmd_sim_body **out, const struct rmd_sim_physics_setup *ps, char *err,
		      size_t errlen)
{
	struct rmd_sim_body *b;
	unsigned rate = ps->rate_hz ? ps->rate_hz : RMD_SIM_PHYSICS_RATE_HZ;
	unsigned substeps = ps->substeps ? ps->substeps : 1;
	char why[768];
	int r;

	*out = NULL;
	if (!ps->model[0])
		return rmd_errf(err, errlen, -EINVAL, "%s: sim.physics: no model", ps->source);
	if ((int64_t)1000000000 % RMD_SIM_STEP_NS || (1000000000 / RMD_SIM_STEP_NS) % rate)
		return rmd_errf(err, errlen, -EINVAL,
				"%s:%u: sim.physics.rate_hz: %u does not divide the motors' step "
				"rate (%d Hz)",
				ps->source, ps->rate_line, rate, 1000000000 / RMD_SIM_STEP_NS);
	b = calloc(1, sizeof(*b));
	if (!b)
		return rmd_errf(err, errlen, -ENOMEM, "out of memory");
	for (unsigned i = 0; i < RMD_MAX_MOTORS; i++)
		b->joint_of[i] = -1;
	b->period_ns = 1000000000 / rate;
	b->k = (unsigned)(b->period_ns / RMD_SIM_STEP_NS);
	b->substeps = substeps;
	snprintf(b->model, sizeof(b->model), "%s", ps->model);
	r = open_module(b, ps, err, errlen);
	if (r < 0)
		goto err_free;
	b->w = b->ops->load(ps->model, why, sizeof(why));
	if (!b->w) {
		r = rmd_errf(err, errlen, -EINVAL, "%s:%u: sim.physics.model: %s: %s", ps->source,
			     ps->model_line, ps->model, why);
		goto err_free;
	}
	r = check_joints(b, ps, err, errlen);
	if (r < 0)
		goto err_free;
	/* the configuration's rate is the world's: the model's own timestep yields to it */
	b->ops->set_timestep_s(b->w, (double)b->period_ns * 1e-9 / substeps);
	*out = b;
	return 0;

err_free:
	rmd_sim_body_free(b);
	return r;
}

void rmd_sim_body_free(struct rmd_sim_body *b)
{
	if (!b)
		return;
	if (b->ops && b->w)
		b->ops->free(b->w);
	if (b->dl)
		dlclose(b->dl);
	free(b);
}

int rmd_sim_body_attach(struct rmd_sim_body *b, unsigned motor, struct rmd_sim_motor *m)
{
	struct slot *s;
	int j = motor < RMD_MAX_MOTORS ? b->joint_of[motor] : -1;

	if (j < 0)
		return 0;
	for (unsigned i = 0; i < b->n_slots; i++)
		if (b->slots[i].joint == j)
			return -EEXIST;
	s = &b->slots[b->n_slots];
	*s = (struct slot){ .m = m, .joint = j, .last_pos_rad = m->pos_rad };
	/*
	 * The motor's own mechanics go into its joint, where the engine
	 * integrates them with the rest: its inertia at the output (rotor
	 * reflected) as armature, its friction as damping and frictionloss.
	 */
	b->ops->add_drive(b->w, j, m->p.inertia_kgm2, m->p.viscous_nm_s_rad, m->p.coulomb_nm);
	b->ops->set(b->w, j, m->pos_rad, 0.0);
	m->vel_rad_s = 0.0;
	m->body = b;
	m->body_slot = b->n_slots++;
	return 1;
}

void rmd_sim_body_describe(const struct rmd_sim_body *b, char *out, size_t len)
{
	snprintf(out, len,
		 "%s, model %s: %u motor%s on its joints, %g Hz (%u integration step%s of %g us "
		 "each, %s)",
		 b->ops->engine, b->model, b->n_slots, b->n_slots == 1 ? "" : "s",
		 1e9 / (double)b->period_ns, b->substeps, b->substeps == 1 ? "" : "s",
		 b->ops->timestep_s(b->w) * 1e6, b->ops->integrator(b->w));
}

int64_t rmd_sim_body_period_ns(const struct rmd_sim_body *b)
{
	return b->period_ns;
}

uint64_t rmd_sim_body_steps(const struct rmd_sim_body *b)
{
	return b->steps;
}

unsigned rmd_sim_body_diverged(const struct rmd_sim_body *b)
{
	return b->diverged;
}

bool rmd_sim_body_room(const struct rmd_sim_body *b, unsigned slot)
{
	return b->slots[slot].sub < b->k;
}

bool rmd_sim_body_push(struct rmd_sim_body *b, unsigned slot, double torque_nm)
{
	struct slot *s = &b->slots[slot];

	s->torque_sum += isfinite(torque_nm) ? torque_nm : 0.0;
	s->sub++;
	return s->sub >= b->k;
}

/*
 * One exchange: every motor has stepped through it (those behind are
 * brought up now, in slot order); each joint gets its motor's mean torque
 * over it, or is held where it is while its brake is locked; the world
 * steps; the motors' shafts become their joints'.
 */
void rmd_sim_body_advance(struct rmd_sim_body *b)
{
	const struct rmd_physics_ops *ops = b->ops;
	double hold[RMD_MAX_MOTORS];
	bool held[RMD_MAX_MOTORS];

	for (unsigned i = 0; i < b->n_slots; i++)
		while (b->slots[i].sub < b->k)
			rmd_sim_motor_substep(b->slots[i].m);
	for (unsigned i = 0; i < b->n_slots; i++) {
		struct slot *s = &b->slots[i];
		double v;

		s->offset_rad += s->m->pos_rad - s->last_pos_rad;
		held[i] = rmd_sim_motor_held(s->m);
		ops->force(b->w, s->joint, held[i] ? 0.0 : s->torque_sum / b->k);
		ops->get(b->w, s->joint, &hold[i], &v);
		s->torque_sum = 0.0;
		s->sub = 0;
	}
	for (unsigned n = 0; n < b->substeps; n++) {
		for (unsigned i = 0; i < b->n_slots; i++)
			if (held[i])
				ops->set(b->w, b->slots[i].joint, hold[i], 0.0);
		b->diverged = ops->step(b->w, 1);
	}
	for (unsigned i = 0; i < b->n_slots; i++) {
		struct slot *s = &b->slots[i];
		double pos, vel;

		if (held[i])
			ops->set(b->w, s->joint, hold[i], 0.0);
		ops->get(b->w, s->joint, &pos, &vel);
		s->m->pos_rad = pos + s->offset_rad;
		s->m->vel_rad_s = vel;
		s->last_pos_rad = s->m->pos_rad;
	}
	b->steps++;
}
