// SPDX-License-Identifier: MIT
/*
 * rmd-sim's config file reader (src/tools/rmd-sim/config.c, linked in as
 * test_sim_params links it): any bytes as the file given to --config, then
 * the final checks rmd-sim makes before it starts (with a serial wire, as
 * when the file names none).  Every motor it accepts has parameters the
 * simulator takes; every message it logs is formatted (into a buffer).
 *
 * Input: the file.
 */
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rmd/sim.h"
#include "tools/rmd-sim/rmd-sim.h"

#include "fuzz.h"

/* The programs' logger (src/tools/common/log.c) is not linked: here each message is only formatted. */
void tool_log(int level, const char *fmt, ...)
{
	char line[2048];
	va_list ap;

	FUZZ_CHECK(level >= TOOL_LOG_ERR && level <= TOOL_LOG_DEBUG);
	va_start(ap, fmt);
	FUZZ_CHECK(vsnprintf(line, sizeof(line), fmt, ap) >= 0);
	va_end(ap);
}

void tool_log_set_level(int max_level)
{
	(void)max_level;
}

bool tool_log_enabled(int level)
{
	return level <= TOOL_LOG_WARNING;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static struct sim_config c;
	const char *path = fuzz_file(data, size);
	int r;

	sim_config_init(&c);
	r = sim_config_file(&c, path);
	FUZZ_CHECK(r == 0 || r == -EINVAL || r == -EIO || r == -EILSEQ || r == -EFBIG);
	if (r < 0)
		return 0;
	if (c.wire == SIM_WIRE_NONE)
		FUZZ_CHECK(sim_config_set(&c, 0, "serial", "/dev/null", "fuzz") == 0);
	if (sim_config_finish(&c) < 0)
		return 0;
	for (unsigned i = 0; i < RMD_MAX_MOTORS; i++) {
		struct rmd_sim_motor m;

		if (!(c.motors & (UINT32_C(1) << i)))
			continue;
		FUZZ_CHECK(c.params[i].id == i + 1);
		rmd_sim_motor_init(&m, &c.params[i], 0);
		rmd_sim_motor_step(&m, 10 * RMD_SIM_STEP_NS);
	}
	return 0;
}
