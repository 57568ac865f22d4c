// SPDX-License-Identifier: MIT
/*
 * Open every bus of rmdd's configuration with its transport: SocketCAN with
 * a kernel filter for the bus's motors and the plan's burst (the most
 * requests of one cycle, which the interface's txqueuelen must hold), an
 * RS485 line at the configured baud, or an in-process simulated bus with
 * the configuration's simulated motors, wire model and faults.  Each
 * transport's message already names the command that fixes it; this file
 * adds where in the configuration the bus comes from.  Non-rt.
 */
#include <errno.h>
#include <string.h>

#include "rmd/bus_rs485.h"
#include "rmd/bus_sim.h"
#include "rmd/bus_socketcan.h"
#include "rmdd.h"

static int open_socketcan(struct rmd_bus *bus, const struct rmd_config *cfg, unsigned b,
			  const struct rmd_plan *plan, char *err, size_t errlen)
{
	const struct rmd_config_bus *cb = &cfg->buses[b];
	struct rmd_socketcan_motor motors[RMD_MAX_MOTORS];
	struct rmd_socketcan_opts o = { .motors = motors };

	for (unsigned i = 0; i < cfg->n_motors; i++) {
		if (cfg->motors[i].bus != b || o.n_motors >= RMD_MAX_MOTORS)
			continue;
		motors[o.n_motors].id = cfg->motors[i].id;
		motors[o.n_motors].proto = cfg->motors[i].proto;
		o.n_motors++;
	}
	o.burst = plan->bus[b].max_requests;
	return rmd_socketcan_open(bus, cb->interface[0] ? cb->interface : cb->name, &o, err,
				  errlen);
}

static int open_rs485(struct rmd_bus *bus, const struct rmd_config *cfg, unsigned b, char *err,
		      size_t errlen)
{
	const struct rmd_config_bus *cb = &cfg->buses[b];
	struct rmd_rs485_opts o = { .baud = cb->baud };

	/* the transport's default reply timeout: the motor's answer plus an adapter's delay */
	for (unsigned i = 0; i < cfg->n_motors; i++)
		if (cfg->motors[i].bus == b)
			o.broadcast_replies++;
	return rmd_rs485_open(bus, cb->device, &o, err, errlen);
}

int rmdd_buses_open(const struct rmd_config *cfg, const struct rmd_plan *plan,
		    struct rmd_bus buses[RMD_MAX_BUSES])
{
	char err[512];
	unsigned b;
	int r = 0;

	for (b = 0; b < cfg->n_buses; b++) {
		const struct rmd_config_bus *cb = &cfg->buses[b];

		memset(&buses[b], 0, sizeof(buses[b]));
		err[0] = '\0';
		switch (cb->kind) {
		case RMD_BUS_KIND_SOCKETCAN:
			r = open_socketcan(&buses[b], cfg, b, plan, err, sizeof(err));
			break;
		case RMD_BUS_KIND_RS485:
			r = open_rs485(&buses[b], cfg, b, err, sizeof(err));
			break;
		case RMD_BUS_KIND_SIM:
			r = rmd_config_open_sim_bus(cfg, b, &buses[b], err, sizeof(err));
			break;
		}
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
		if (err[0]) /* a notice, e.g. an RS485 port without kernel RS485 mode */
			tool_log(5, "bus %s: %s", cb->name, err);
		tool_log(7, "bus %s: open (%s)", cb->name, buses[b].ops->kind);
	}
	return 0;

err_close_opened:
	rmdd_buses_close(buses, b);
	return r;
}

void rmdd_buses_close(struct rmd_bus *buses, unsigned n)
{
	for (unsigned b = n; b-- > 0;)
		rmd_bus_close(&buses[b]);
}
