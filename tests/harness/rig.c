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

void rig_assert_default_motor(const struct rmd_bringup_motor *m)
{
	assert_int_equal(m->state, RMD_BRINGUP_FOUND);
	assert_string_equal(m->model, "X8S2V10");
	assert_int_equal(m->version, 20220206);
	assert_true(m->status);
	assert_float_equal(m->voltage_v, 48.0, 0.05);
	assert_float_equal(m->temp_c, 25.0, 0.5);
	assert_int_equal(m->error_code, 0);
	assert_int_equal(m->b3, RMD_B3_SET);
}
