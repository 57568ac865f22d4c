// SPDX-License-Identifier: MIT
/*
 * The physics module on MuJoCo (rmd/physics.h): rmd-physics.so, the one
 * part of rmdd that links libmujoco (Debian 12: libmujoco-dev 2.2.2, C
 * API).  The simulator loads it with dlopen() when a configuration asks
 * for physics (src/sim/sim_body.c); rmdd and rmd-sim never link it.
 *
 * A world is an mjModel and its mjData, both made at load: the steps only
 * write qfrc_applied, qpos and qvel and call mj_step(), which allocates
 * nothing (MuJoCo's stack is inside mjData).
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "rmd/physics.h"

struct world {
	mjModel *m;
	mjData *d;
};

/*
 * MuJoCo prints its warnings (a diverged state it resets, a full stack)
 * to stdout by default: not from the rt thread.  They are counted in
 * mjData.warning[], which step() reports.
 */
static void quiet_warning(const char *msg)
{
	(void)msg;
}

/* Non-rt. */
static void *load(const char *path, char *err, size_t errlen)
{
	char why[1024] = "";
	struct world *w;

	mju_user_warning = quiet_warning;
	w = calloc(1, sizeof(*w));
	if (!w) {
		snprintf(err, errlen, "out of memory");
		return NULL;
	}
	w->m = mj_loadXML(path, NULL, why, sizeof(why));
	if (!w->m) {
		/* MuJoCo's message is one or more lines; keep them on one */
		for (char *c = why; *c; c++)
			if (*c == '\n')
				*c = ' ';
		for (size_t n = strlen(why); n && why[n - 1] == ' ';)
			why[--n] = '\0';
		snprintf(err, errlen, "%s", why[0] ? why : "MuJoCo could not load it");
		free(w);
		return NULL;
	}
	w->d = mj_makeData(w->m);
	if (!w->d) {
		snprintf(err, errlen, "out of memory (mj_makeData)");
		mj_deleteModel(w->m);
		free(w);
		return NULL;
	}
	mj_forward(w->m, w->d);
	return w;
}

static void world_free(void *world)
{
	struct world *w = world;

	if (!w)
		return;
	mj_deleteData(w->d);
	mj_deleteModel(w->m);
	free(w);
}

static double timestep_s(const void *world)
{
	const struct world *w = world;

	return w->m->opt.timestep;
}

static void set_timestep_s(void *world, double s)
{
	struct world *w = world;

	w->m->opt.timestep = s;
}

static const char *integrator(const void *world)
{
	const struct world *w = world;

	switch (w->m->opt.integrator) {
	case mjINT_EULER:
		return "Euler";
	case mjINT_RK4:
		return "RK4";
	case mjINT_IMPLICIT:
		return "implicit";
	}
	return "?";
}

static int joint(const void *world, const char *name, enum rmd_physics_joint *kind)
{
	const struct world *w = world;
	int j = mj_name2id(w->m, mjOBJ_JOINT, name);

	if (j < 0)
		return -ENOENT;
	switch (w->m->jnt_type[j]) {
	case mjJNT_HINGE:
		*kind = RMD_PHYSICS_HINGE;
		break;
	case mjJNT_SLIDE:
		*kind = RMD_PHYSICS_SLIDE;
		break;
	default:
		*kind = RMD_PHYSICS_OTHER;
		break;
	}
	return j;
}

static int n_joints(const void *world)
{
	const struct world *w = world;

	return w->m->njnt;
}

static const char *joint_name(const void *world, int j)
{
	const struct world *w = world;
	const char *n = mj_id2name(w->m, mjOBJ_JOINT, j);

	return n ? n : "";
}

static void add_drive(void *world, int j, double armature, double damping, double frictionloss)
{
	struct world *w = world;
	int dof = w->m->jnt_dofadr[j];

	w->m->dof_armature[dof] += armature;
	w->m->dof_damping[dof] += damping;
	w->m->dof_frictionloss[dof] += frictionloss;
	/* the mass matrix and friction constraints follow the new values */
	mj_setConst(w->m, w->d);
	mj_forward(w->m, w->d);
}

static void get(const void *world, int j, double *pos, double *vel)
{
	const struct world *w = world;

	*pos = w->d->qpos[w->m->jnt_qposadr[j]];
	*vel = w->d->qvel[w->m->jnt_dofadr[j]];
}

static void set(void *world, int j, double pos, double vel)
{
	struct world *w = world;

	w->d->qpos[w->m->jnt_qposadr[j]] = pos;
	w->d->qvel[w->m->jnt_dofadr[j]] = vel;
}

static void force(void *world, int j, double f)
{
	struct world *w = world;

	w->d->qfrc_applied[w->m->jnt_dofadr[j]] = f;
}

static unsigned step(void *world, unsigned n)
{
	struct world *w = world;

	for (unsigned i = 0; i < n; i++)
		mj_step(w->m, w->d);
	return (unsigned)w->d->warning[mjWARN_BADQACC].number;
}

static double time_s(const void *world)
{
	const struct world *w = world;

	return w->d->time;
}

const struct rmd_physics_ops *rmd_physics_module(void)
{
	static char engine[32];
	static struct rmd_physics_ops ops = {
		.abi = RMD_PHYSICS_ABI,
		.engine = engine,
		.load = load,
		.free = world_free,
		.timestep_s = timestep_s,
		.set_timestep_s = set_timestep_s,
		.integrator = integrator,
		.joint = joint,
		.n_joints = n_joints,
		.joint_name = joint_name,
		.add_drive = add_drive,
		.get = get,
		.set = set,
		.force = force,
		.step = step,
		.time_s = time_s,
	};
	int v = mj_version();

	snprintf(engine, sizeof(engine), "MuJoCo %d.%d.%d", v / 100, v / 10 % 10, v % 10);
	return &ops;
}
