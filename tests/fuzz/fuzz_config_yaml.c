// SPDX-License-Identifier: MIT
/*
 * rmdd's YAML loader (rmd_config_load()): any bytes as the file, with the
 * simulator settings asked for.  It returns 0 or -EINVAL, with an error
 * text that fits its buffer.  What it accepts then goes where
 * `rmdd --check-config` takes it: the bus plans (rmd_plan_build(), printed
 * to /dev/null), and a few cycles of each bus.
 * Inputs are bounded by the runner (-max_len, tests/fuzz/run): the loader's
 * own size bound is issue 10's defect 2.
 *
 * Input: the file.
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/plan.h"
#include "rmd/sim_setup.h"

#include "fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static struct rmd_config cfg;
	static struct rmd_sim_setup sim;
	static struct rmd_plan plan;
	static struct rmd_plan_slot slots[RMD_PLAN_MAX_SLOTS];
	static char err[4096];
	static FILE *null;
	const char *path = fuzz_file(data, size);
	int r;

	if (!null)
		null = fopen("/dev/null", "w");

	err[sizeof(err) - 1] = 'x';
	r = rmd_config_load(path, &cfg, &sim, err, sizeof(err) - 1);
	/* -EILSEQ: a NUL byte; -EFBIG: over RMD_CONFIG_FILE_MAX (rmd_config_file_read()) */
	FUZZ_CHECK(r == 0 || r == -EINVAL || r == -EILSEQ || r == -EFBIG);
	FUZZ_CHECK(err[sizeof(err) - 1] == 'x');
	if (r < 0)
		FUZZ_CHECK(memchr(err, 0, sizeof(err) - 1) != NULL && err[0] != '\0');
	if (r < 0)
		return 0;

	r = rmd_plan_build(&cfg, &plan, err, sizeof(err) - 1);
	FUZZ_CHECK(r == 0 || r == -ENOSPC || r == -EINVAL);
	FUZZ_CHECK(err[sizeof(err) - 1] == 'x');
	rmd_plan_print(&plan, &cfg, null);
	if (r < 0)
		return 0;
	for (unsigned b = 0; b < RMD_MAX_BUSES; b++)
		for (uint64_t n = 0; n < 4; n++)
			FUZZ_CHECK(rmd_plan_cycle(&plan, b, n * 997, slots) <= RMD_PLAN_MAX_SLOTS);
	return 0;
}
