// SPDX-License-Identifier: MIT
/*
 * Personality files from disk (rmd/personality_load.h).  Non-rt.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/config.h"
#include "rmd/personality_load.h"

int rmd_personality_load(const char *path, struct rmd_personality *out, char *err, size_t errsize)
{
	char why[256], *text;
	unsigned line;
	size_t len;
	int r;

	r = rmd_config_file_read(path, &text, &len, &line, why, sizeof(why));
	if (r < 0) {
		if (line)
			snprintf(err, errsize, "%s:%u: %s", path, line, why);
		else
			snprintf(err, errsize, "%s: %s", path, why);
		return r;
	}
	r = rmd_personality_parse(text, len, path, out, err, errsize);
	free(text);
	return r;
}

int rmd_sim_param_parse_file(struct rmd_sim_motor_params *p, const struct rmd_sim_param *spec,
			     const char *value, char *allowed, size_t size)
{
	struct rmd_personality rec;
	char err[320];
	int r;

	r = rmd_sim_param_parse(p, spec, value, allowed, size);
	if (r == 0 || spec->type != RMD_SIM_PARAM_PERSONALITY)
		return r;
	r = rmd_personality_load(value, &rec, err, sizeof(err));
	if (r == -ENOENT) {
		size_t n = strlen(allowed);

		snprintf(allowed + n, size - n, " (no such file)");
		return -EINVAL;
	}
	if (r < 0) {
		snprintf(allowed, size, "a personality file: %s", err);
		return -EINVAL;
	}
	p->personality = rec;
	return 0;
}
