// SPDX-License-Identifier: MIT
/* What all transports share: names for messages, the trivial ops. */
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
	}
	return "unknown";
}

int64_t rmd_bus_never_due_ns(const struct rmd_bus *bus)
{
	(void)bus;
	return INT64_MAX;
}
