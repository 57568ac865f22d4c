/* SPDX-License-Identifier: MIT */
/*
 * The simulated motor's parameters as text (docs/design.md, layer sim): one table
 * of every field of struct rmd_sim_motor_params a user may set, with its
 * name, range, unit and help, and one parser from text to the field.
 * rmdd.yaml's `sim:` sections (src/config/config_yaml.c) and rmd-sim's
 * options, config file and --help (src/tools/rmd-sim/config.c) are both
 * built from it, so both spell every parameter, its unit and its range the
 * same way.
 *
 * Names: the canonical name is snake_case with the unit in it where the
 * value has one (inertia_kgm2, turnaround_us), as rmdd.yaml spells it;
 * rmd-sim also takes it with '-' for '_'.  A row may carry rmd-sim's
 * older name as an alias with the same meaning (inertia, jitter-us, ...).
 */
#ifndef RMD_SIM_PARAMS_H
#define RMD_SIM_PARAMS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/sim.h"

enum rmd_sim_param_type {
	RMD_SIM_PARAM_REAL,    /* double, in the unit of the name */
	RMD_SIM_PARAM_US,      /* double ns field, given in µs */
	RMD_SIM_PARAM_UINT,    /* unsigned */
	RMD_SIM_PARAM_BOOL,    /* bool: yes/no, true/false, on/off, 1/0 */
	RMD_SIM_PARAM_PROTO,   /* enum rmd_proto: a protocol key (rmd_proto_parse()) */
	RMD_SIM_PARAM_MODEL,   /* char[8]: 1..7 printable ASCII characters (0xB5) */
	RMD_SIM_PARAM_VERSION, /* uint32_t yyyymmdd (0xB2) */
	RMD_SIM_PARAM_MIT,     /* struct rmd_mit_ranges from "P,V,T,KP,KD" */
	/*
	 * struct rmd_personality: auto, none or a built-in name
	 * (rmd/sim_personality.h); a file where a reader of files parses it
	 * (rmd_sim_param_parse_file(), rmd/personality_load.h)
	 */
	RMD_SIM_PARAM_PERSONALITY,
};

/* Row flags */
enum {
	/*
	 * In rmdd.yaml the motor entry's own key sets it (protocol, mit), not
	 * its `sim:` section: rmd-sim only.
	 */
	RMD_SIM_PARAM_MOTOR_KEY = 1u << 0,
	/* help follows the protocol keys, "v3, v2, mit or v4 " (rmd_proto_keys_text()) */
	RMD_SIM_PARAM_KEYS_FIRST = 1u << 1,
};

struct rmd_sim_param {
	const char *key;   /* canonical name */
	const char *alias; /* rmd-sim's older name, same meaning; NULL: none */
	enum rmd_sim_param_type type;
	size_t off;	  /* in struct rmd_sim_motor_params */
	double min, max;  /* REAL, US (in µs), UINT */
	bool min_excl;	  /* value > min rather than >= min */
	const char *unit; /* "kg·m²", "µs", ...; "" for none */
	const char *help;
	unsigned flags; /* RMD_SIM_PARAM_* */
};

extern const struct rmd_sim_param rmd_sim_params[];
extern const size_t rmd_sim_n_params;

/*
 * The row called `key`: its canonical name or its alias, any case, '-'
 * and '_' alike; NULL for none.  Non-rt.
 */
const struct rmd_sim_param *rmd_sim_param_find(const char *key);

/*
 * Store `value` (text) in p's field of row `spec`.  Returns 0, or -EINVAL
 * with what is allowed in `allowed` (e.g. "a number >= 0 and <= 100, in
 * Ω"), p unchanged.  Non-rt.
 */
int rmd_sim_param_parse(struct rmd_sim_motor_params *p, const struct rmd_sim_param *spec,
			const char *value, char *allowed, size_t size);

/* The field's size in struct rmd_sim_motor_params, for copying or comparing it.  Non-rt. */
size_t rmd_sim_param_size(const struct rmd_sim_param *spec);

/*
 * Whole-string parsers in the C locale, as rmd_sim_param_parse() reads:
 * a finite number; an unsigned integer (decimal, or hex with 0x; never
 * octal); yes/no, true/false, on/off, 1/0 (any case).  0 or -EINVAL.
 */
int rmd_sim_parse_real(const char *s, double *v);
int rmd_sim_parse_u64(const char *s, uint64_t *v);
int rmd_sim_parse_bool(const char *s, bool *b);

#endif /* RMD_SIM_PARAMS_H */
