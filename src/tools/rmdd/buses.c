// SPDX-License-Identifier: MIT
/*
 * Open every bus of rmdd's configuration with the bus layer's factory
 * (rmd_bus_open()): the bus's motors (and, for a sim bus, the simulator's
 * settings), and the plan's burst (the most
 * requests of one cycle, which a CAN interface's txqueuelen must hold).
 * Each transport's message already names the command that fixes it; this
 * file adds where in the configuration the bus comes from.  Non-rt.
 */
#include <errno.h>
#include <string.h>

#include "rmd/bus_open.h"
#include "rmd/sim_body.h"
#include "rmdd.h"
#include "tools/common/buslock.h"

/*
 * A sim bus is rmdd's own and judges it in rmdd's time (rmd/bus_sim.h
 * "Host gaps"): the loop calls it at least once a period (every tick
 * drains it, sending or not), so a call later than two periods after the
 * one before ends a gap the host held the loop away for.  Each such gap
 * counts two periods on the motors' comm-loss timers, never the seconds
 * of a stopped process; and a loop that runs but sends nothing trips them
 * as on a wire.
 */
#define SIM_HOLD_AFTER_PERIODS 2

/* The world of sim.physics (rmd/sim_body.h) its sim buses' motors drive; NULL: none. */
static struct rmd_sim_body *body;

/*
 * Load sim.physics when a motor of a sim bus drives a joint (a socketcan
 * or rs485 bus's motors are rmd-sim's, which loads it itself).
 */
static int body_open(const struct rmd_config *cfg, const struct rmd_sim_setup *sim)
{
	const struct rmd_sim_physics_setup *ps = sim ? &sim->physics : NULL;
	char err[1024];
	bool used = false;
	int r;

	for (unsigned k = 0; ps && ps->model[0] && k < ps->n_joints; k++)
		if (rmd_bus_config_motor_in_process(cfg, ps->joints[k].motor))
			used = true;
	if (!used)
		return 0;
	r = rmd_sim_body_load(&body, ps, err, sizeof(err));
	if (r < 0) {
		tool_log(3, "%s", err);
		return r;
	}
	return 0;
}

static int lock_fd[RMD_MAX_BUSES] = { [0 ... RMD_MAX_BUSES - 1] = -1 };

/*
 * Take the lock of bus b (open), so that rmdctl does not talk on it behind
 * rmdd's back and a second rmdd does not start on it.  A bus without a
 * descriptor (sim: inside this process) has none.
 */
static int lock_bus(const struct rmd_config_bus *cb, struct rmd_bus *bus, unsigned b)
{
	const char *dev = cb->device[0] ? cb->device : cb->interface[0] ? cb->interface : cb->name;
	char key[256], path[TOOL_BUSLOCK_PATH_LEN] = "";
	pid_t owner;
	int r;

	if (rmd_bus_fd(bus) < 0)
		return 0;
	r = tool_buslock_key(key, sizeof(key), dev);
	if (r == 0)
		r = tool_buslock_take(key, &lock_fd[b], path, sizeof(path), &owner);
	if (r == -EBUSY)
		tool_log(3, "bus %s: %s is in use by another rmdd (pid %ld, lock %s)", cb->name,
			 dev, (long)owner, path);
	else if (r < 0) /* no place for a lock file: run, but rmdctl cannot see rmdd */
		tool_log(4, "bus %s: no lock file (%s: %s): rmdctl will not know rmdd drives it",
			 cb->name, path, strerror(-r));
	return r == -EBUSY ? r : 0;
}

int rmdd_buses_open(const struct rmd_config *cfg, const struct rmd_sim_setup *sim,
		    const struct rmd_plan *plan, struct rmd_bus buses[RMD_MAX_BUSES])
{
	struct rmd_bus_open_motor motors[RMD_MAX_MOTORS];
	struct rmd_bus_open_ctx ctx;
	char err[512];
	unsigned b = 0;
	int r = body_open(cfg, sim);

	if (r < 0)
		return r;
	for (b = 0; b < cfg->n_buses; b++) {
		const struct rmd_config_bus *cb = &cfg->buses[b];

		rmd_bus_open_ctx_of(cfg, sim, b, motors, &ctx);
		ctx.burst = plan->bus[b].max_requests;
		ctx.watch_strays = plan->bus[b].batched && !cb->can_id_filter;
		ctx.body = body;
		ctx.sim_hold_after_ns = SIM_HOLD_AFTER_PERIODS * plan->period_ns;
		r = rmd_bus_open(&buses[b], cb, &ctx, err, sizeof(err));
		if (r < 0) {
			if (cb->line)
				tool_log(3, "%s:%u: bus %s (%s): %s", cfg->source, cb->line,
					 cb->name, rmd_bus_kind_name(cb->kind),
					 err[0] ? err : strerror(-r));
			else
				tool_log(3, "bus %s (%s): %s", cb->name,
					 rmd_bus_kind_name(cb->kind), err[0] ? err : strerror(-r));
			goto err_close_opened;
		}
		r = lock_bus(cb, &buses[b], b);
		if (r < 0) {
			rmd_bus_close(&buses[b]);
			goto err_close_opened;
		}
		if (err[0]) /* a notice, e.g. an RS485 port without kernel RS485 mode */
			tool_log(5, "bus %s: %s", cb->name, err);
		tool_log(7, "bus %s: open (%s)", cb->name, buses[b].ops->kind);
	}
	if (body) {
		char what[512];

		rmd_sim_body_describe(body, what, sizeof(what));
		tool_log(6, "physics: %s", what);
	}
	return 0;

err_close_opened:
	rmdd_buses_close(buses, b);
	return r;
}

void rmdd_buses_close(struct rmd_bus *buses, unsigned n)
{
	for (unsigned b = n; b-- > 0;) {
		rmd_bus_close(&buses[b]);
		tool_buslock_release(&lock_fd[b]);
	}
	rmd_sim_body_free(body);
	body = NULL;
}
