/* SPDX-License-Identifier: MIT */
/*
 * rmdd's configuration from a YAML file (docs/design.md, layer tools): the file ->
 * struct rmd_config (rmd/config.h) and, for its sim buses, struct
 * rmd_sim_setup (rmd/sim_setup.h).
 *
 * The file is read into a small tree that remembers the line of every key
 * and value, and walked against schema tables (src/config/config_yaml.c):
 * every key is checked for its type and range, every unknown key is
 * refused with the list of allowed ones, and every error names the file,
 * the line and the key path and says what is allowed:
 *
 *   sim-12.yaml:14: motors[3].id: 40 is out of range (1..32)
 *   x.yaml:7: buses[0].type: "canbus" is not one of socketcan, rs485, sim
 *
 * The simulated motor's keys (`sim.motor:`, `motors[].sim:`) are the rows
 * of the simulator's parameter table, as rmd-sim reads them.  A socketcan
 * or rs485 bus may have them too: they are rmd-sim's, which simulates that
 * bus's motors on the real wire from the same file (`rmd-sim --config
 * rmdd.yaml`); rmdd talks to the wire (struct rmd_config_bus.sim_section).
 */
#ifndef RMD_CONFIG_YAML_H
#define RMD_CONFIG_YAML_H

#include <stddef.h>
#include <stdio.h>

#include "rmd/config.h"
#include "rmd/sim_setup.h"

/*
 * Load and validate the YAML file at `path` into *cfg, and the buses'
 * simulator settings into *sim (may be NULL: checked, then dropped),
 * defaults for what it leaves out.  Returns 0, -errno when the
 * file cannot be read or is refused as a whole (rmd_config_file_read():
 * -EISDIR, -EFBIG, -EILSEQ for a NUL byte, ...), or -EINVAL for a file
 * with errors; err then holds
 * one line per error (up to a few dozen, joined with '\n', no trailing
 * newline), each naming the file, the line and the key.  *cfg and *sim are
 * unspecified after a failure.  Non-rt: allocates while parsing, frees
 * before it returns.
 */
int rmd_config_load(const char *path, struct rmd_config *cfg, struct rmd_sim_setup *sim, char *err,
		    size_t errlen);

/*
 * The configuration `rmdd --sim` runs: `nmotors` (1..RMD_MAX_MOTORS) V3
 * torque-mode motors with the simulator's default model, three per 1 Mbit/s
 * sim bus (the most that fit at 1 kHz, docs/design.md), at 1 kHz, and their
 * simulator settings in *sim (may be NULL).  The motors keep their
 * multi-turn count across power-off (multi_turn_saved, and the simulated
 * motors with it).  Returns 0 or -EINVAL.  Non-rt.
 */
int rmd_config_sim_default(struct rmd_config *cfg, struct rmd_sim_setup *sim, unsigned nmotors);

/*
 * The file's JSON Schema (draft-07), from the tables rmd_config_load()
 * checks with (`rmdd --schema`; the package installs it as
 * /usr/share/rmdd/rmdd.schema.json): every key, its type, range and
 * names, unknown keys refused, so YAML editors validate and complete while
 * typing.  Checks across keys (a motor's bus exists, unique IDs, the bus
 * budget) are rmdd --check-config's.  Returns 0, or -EIO when writing to
 * out failed.  Non-rt.
 */
int rmd_config_schema_json(FILE *out);

#endif /* RMD_CONFIG_YAML_H */
