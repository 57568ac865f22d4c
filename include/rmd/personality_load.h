/* SPDX-License-Identifier: MIT */
/*
 * Personality files from disk (rmd/sim_personality.h): read as rmdd reads
 * its configuration (rmd_config_file_read(): a regular file only, no NUL),
 * at most RMD_PERSONALITY_FILE_MAX bytes, parsed by
 * rmd_personality_parse().  Part of the config loader (it fills the
 * simulator's parameters from files), for rmdd.yaml's `sim:` sections,
 * rmd-sim and rmdctl's sim buses.  Non-rt.
 */
#ifndef RMD_PERSONALITY_LOAD_H
#define RMD_PERSONALITY_LOAD_H

#include <stddef.h>

#include "rmd/sim.h"
#include "rmd/sim_params.h"
#include "rmd/sim_personality.h"

/*
 * Read the personality file `path` into *out.  Returns 0 or -errno with
 * err = "PATH: why" or "PATH:LINE: key: message".
 */
int rmd_personality_load(const char *path, struct rmd_personality *out, char *err, size_t errsize);

/*
 * rmd_sim_param_parse(), and for the `personality` row a value that names
 * no built-in personality read as a personality file's path (allowed then
 * says what is wrong with the file, or that there is neither).
 */
int rmd_sim_param_parse_file(struct rmd_sim_motor_params *p, const struct rmd_sim_param *spec,
			     const char *value, char *allowed, size_t size);

#endif /* RMD_PERSONALITY_LOAD_H */
