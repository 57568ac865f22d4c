// SPDX-License-Identifier: MIT
/* The sim rig (rig.h). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "harness/rig.h"
#include "rmd/bus_open.h"

void rig_open_buses(const struct rmd_config *cfg, const struct rmd_sim_setup *sim,
		    struct rmd_bus *buses)
{
	char err[256];

	for (unsigned b = 0; b < cfg->n_buses; b++) {
		struct rmd_bus_open_motor motors[RMD_MAX_MOTORS];
		struct rmd_bus_open_ctx ctx;

		rmd_bus_open_ctx_of(cfg, sim, b, motors, &ctx);
		if (rmd_bus_open(&buses[b], &cfg->buses[b], &ctx, err, sizeof(err)) == 0)
			continue;
		for (unsigned k = 0; k < b; k++)
			rmd_bus_close(&buses[k]);
		fail_msg("sim bus %s: %s", cfg->buses[b].name, err);
	}
}
