// SPDX-License-Identifier: MIT
/* What all transports share: names for messages, the trivial ops, decorators. */
#include <stdio.h>
#include <string.h>

#include "rmd/bus.h"

const char *rmd_bus_state_name(enum rmd_bus_state state)
{
	switch (state) {
	case RMD_BUS_ACTIVE:
		return "error-active";
	case RMD_BUS_WARNING:
		return "error-warning";
	case RMD_BUS_PASSIVE:
		return "error-passive";
	case RMD_BUS_OFF:
		return "bus-off";
	case RMD_BUS_NO_ACK:
		return "no-ack";
	}
	return "unknown";
}

int64_t rmd_bus_never_due_ns(const struct rmd_bus *bus)
{
	(void)bus;
	return INT64_MAX;
}

/* ---- decorators (struct rmd_bus_wrap) ----------------------------------------------- */

void rmd_bus_wrap_init(struct rmd_bus *bus, const struct rmd_bus_ops *ops, struct rmd_bus_wrap *w)
{
	*bus = (struct rmd_bus){ .ops = ops, .caps = w->inner->caps, .priv = w };
	snprintf(bus->name, sizeof(bus->name), "%s", w->inner->name);
}

int rmd_bus_wrap_send(struct rmd_bus *bus, const struct rmd_frame *frames, unsigned n,
		      int64_t now_ns)
{
	const struct rmd_bus_wrap *w = bus->priv;

	return rmd_bus_send(w->inner, frames, n, now_ns);
}

int rmd_bus_wrap_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, int64_t now_ns)
{
	const struct rmd_bus_wrap *w = bus->priv;

	return rmd_bus_recv(w->inner, out, max, now_ns);
}

int rmd_bus_wrap_fd(const struct rmd_bus *bus)
{
	const struct rmd_bus_wrap *w = bus->priv;

	return rmd_bus_fd(w->inner);
}

int64_t rmd_bus_wrap_next_due_ns(const struct rmd_bus *bus)
{
	const struct rmd_bus_wrap *w = bus->priv;

	return rmd_bus_next_due_ns(w->inner);
}

enum rmd_bus_state rmd_bus_wrap_state(const struct rmd_bus *bus)
{
	const struct rmd_bus_wrap *w = bus->priv;

	return rmd_bus_state(w->inner);
}

const struct rmd_bus_stats *rmd_bus_wrap_stats(const struct rmd_bus *bus)
{
	const struct rmd_bus_wrap *w = bus->priv;

	return rmd_bus_stats(w->inner);
}

int rmd_bus_wrap_flush(struct rmd_bus *bus)
{
	const struct rmd_bus_wrap *w = bus->priv;

	return rmd_bus_flush(w->inner);
}

void rmd_bus_wrap_close(struct rmd_bus *bus)
{
	memset(bus, 0, sizeof(*bus));
}
