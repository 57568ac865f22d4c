// SPDX-License-Identifier: MIT
/* The simulator's settings for a configuration (rmd/sim_setup.h).  rt-safe. */
#include <string.h>

#include "rmd/sim_setup.h"

void rmd_sim_bus_setup_default(struct rmd_sim_bus_setup *b, uint64_t seed)
{
	memset(b, 0, sizeof(*b));
	b->seed = seed;
	b->txqueuelen = RMD_SIM_DEFAULT_TXQUEUELEN;
	b->host_fifo = true;
	rmd_sim_motor_params_default(&b->motor, 1, RMD_PROTO_V3);
}
