// SPDX-License-Identifier: MIT
/* The sim rig (rig.h). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "harness/rig.h"

void rig_open_buses(const struct rmd_config *cfg, struct rmd_bus *buses)
{
	char err[256];

	for (unsigned b = 0; b < cfg->n_buses; b++) {
		if (rmd_config_open_sim_bus(cfg, b, &buses[b], err, sizeof(err)) == 0)
			continue;
		for (unsigned k = 0; k < b; k++)
			rmd_bus_close(&buses[k]);
		fail_msg("sim bus %s: %s", cfg->buses[b].name, err);
	}
}
