/* SPDX-License-Identifier: MIT */
/*
 * Firmware personalities of the simulated motor (docs/rmd-sim.md
 * "Personalities"): what a motor of a given model and firmware date does
 * that its manual does not say, as seen in the field (issue 32), or as
 * `rmdctl characterize` recorded it from a real motor.
 *
 * A personality is a record of simulator parameters (rmd/sim_params.h
 * rows: model, version_date, the firmware's dialect, boot_ms, mit_ranges,
 * and the behaviour flags such as answers_79_as_b2) plus what only a
 * recording gives: a turnaround distribution per command and the commands
 * the firmware never answers.  A motor's parameters carry one (struct
 * rmd_sim_motor_params.personality, the `personality` row); at power-on
 * (rmd_sim_motor_init()) rmd_personality_apply() resolves it:
 * - auto (the default): the built-in personality whose model, firmware
 *   date and dialect are the motor's, if any (the simulator's default
 *   X8S2V10 matches none, so a motor without one behaves as the manuals);
 * - none: no personality, the parameters as given;
 * - a built-in one by name (rmd_personality_builtin()), or a file's
 *   (rmd_personality_parse(), rmd/personality_load.h): what it gives
 *   replaces the parameters of the same name.
 *
 * The file format (docs/rmd-sim.md "Personality files"): text, one
 * `key = value` a line, `#` starts a comment; at most
 * RMD_PERSONALITY_FILE_MAX bytes and RMD_PERSONALITY_LINES_MAX lines.
 *
 *     format = rmd-personality 1
 *     name = my-x4-64
 *     model = X4-64
 *     version_date = 2025070202
 *     dialect = v4
 *     boot_ms = 1120
 *     answers_79_as_b2 = yes            # any behaviour row of rmd/sim_params.h
 *     ignores = 0x92 0xB6
 *     turnaround 0x9C = 410 450 520 610 700 950    # p0 p10 p50 p90 p99 p100, µs
 *     turnaround mit = ...
 *     turnaround * = ...                # every command without its own line
 *
 * The parser and the writer are non-rt (no allocation: the record is
 * fixed-size); rmd_personality_turnaround_ns() is rt-safe.
 */
#ifndef RMD_SIM_PERSONALITY_H
#define RMD_SIM_PERSONALITY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "rmd/codec.h"
#include "rmd/mit.h"

#define RMD_PERSONALITY_NAME_MAX 32
/* The quantiles of a turnaround line: p0 p10 p50 p90 p99 p100 (rmd_personality_quantiles). */
#define RMD_PERSONALITY_NQ 6
/* Turnaround lines a record holds: every command of a dialect's table, MIT and `*`. */
#define RMD_PERSONALITY_CMDS_MAX 64
#define RMD_PERSONALITY_FILE_MAX (64 * 1024)
#define RMD_PERSONALITY_FILE_MAX_TEXT "64 KiB"
#define RMD_PERSONALITY_LINES_MAX 1024
/* A turnaround line's key beside the command bytes 0x00..0xFF: MIT frames, every other. */
#define RMD_PERSONALITY_CMD_MIT 0x100u
#define RMD_PERSONALITY_CMD_ANY 0x101u
/* A quantile's ceiling, µs: 10 s (a ROM write's answer is slow, not this slow). */
#define RMD_PERSONALITY_TURNAROUND_MAX_US 10000000u

/* The probabilities of a turnaround line's quantiles, 0 .. 1 in order. */
extern const double rmd_personality_quantiles[RMD_PERSONALITY_NQ];

enum rmd_personality_source {
	RMD_PERSONALITY_AUTO = 0, /* the built-in one of the motor's model, date and dialect */
	RMD_PERSONALITY_NONE,	  /* none: the parameters as given */
	RMD_PERSONALITY_BUILTIN,  /* a built-in one, by name */
	RMD_PERSONALITY_FILE,	  /* read from a file (name: the file's `name`, or its path) */
};

/* What a record gives (struct rmd_personality.set); the rest stays as the parameters say. */
enum {
	RMD_PERSONALITY_HAS_MODEL = 1u << 0,
	RMD_PERSONALITY_HAS_VERSION = 1u << 1,
	RMD_PERSONALITY_HAS_PROTO = 1u << 2,
	RMD_PERSONALITY_HAS_BOOT = 1u << 3,
	RMD_PERSONALITY_HAS_MIT = 1u << 4,
	RMD_PERSONALITY_HAS_F1 = 1u << 5,
};

/*
 * The firmware's behaviour flags, each a bool row of rmd/sim_params.h
 * (rmd_personality_flag_key() names it), in struct rmd_personality.flags.
 */
enum rmd_personality_flag {
	RMD_PERSONALITY_ANSWERS_79_AS_B2 = 0,
	RMD_PERSONALITY_SET_ID_REPLIES_NEW,
	RMD_PERSONALITY_COMM_LOSS_SILENT,
	RMD_PERSONALITY_COMM_LOSS_EXECUTES_FIRST,
	RMD_PERSONALITY_A4_IGNORED_AFTER_MIT,
	RMD_PERSONALITY_STATUS1_EXECUTING,
	RMD_PERSONALITY_V2_ANGLE_MAGNITUDE,
	RMD_PERSONALITY_B3_ANSWER_ZEROS,
	RMD_PERSONALITY_N_FLAGS
};

/* One command's measured turnaround: request end to reply start. */
struct rmd_personality_turnaround {
	uint16_t cmd;			   /* 0x00..0xFF, RMD_PERSONALITY_CMD_MIT or _ANY */
	uint32_t samples;		   /* how many it was measured from; 0: not said */
	uint32_t q_us[RMD_PERSONALITY_NQ]; /* at rmd_personality_quantiles, non-decreasing */
};

struct rmd_personality {
	enum rmd_personality_source source;
	char name[RMD_PERSONALITY_NAME_MAX]; /* "x4-64-2025070202", a file's name; "" */
	uint32_t set;			     /* RMD_PERSONALITY_HAS_* */
	char model[8];			     /* 0xB5 */
	uint32_t version_date;		     /* 0xB2 */
	enum rmd_proto proto;		     /* the firmware's dialect */
	unsigned boot_ms;		     /* boot after power or 0x76 (boot_ms row) */
	struct rmd_mit_ranges mit;	     /* the ranges MIT frames are scaled by (mit_ranges) */
	unsigned comm_loss_f1_ms;	     /* 0xF1 period after a trip (comm_loss_f1_ms) */
	uint32_t flags_set;		     /* 1 << enum rmd_personality_flag: flags it gives */
	uint32_t flags;			     /* ... and their values */
	uint8_t ignores[32];		     /* bit c: command byte c is never answered */
	unsigned n_turnaround;
	struct rmd_personality_turnaround turnaround[RMD_PERSONALITY_CMDS_MAX];
};

/* The bool row of rmd/sim_params.h that flag f is ("answers_79_as_b2"), or NULL.  Non-rt. */
const char *rmd_personality_flag_key(enum rmd_personality_flag f);

/* Where flag f's bool lives in struct rmd_sim_motor_params (its row's offset).  Non-rt. */
size_t rmd_personality_flag_offset(enum rmd_personality_flag f);

/* Whether the record gives flag f (its value: bit f of flags). */
static inline bool rmd_personality_gives(const struct rmd_personality *p,
					 enum rmd_personality_flag f)
{
	return p->flags_set & (UINT32_C(1) << f);
}

/* Give flag f the value on. */
void rmd_personality_set_flag(struct rmd_personality *p, enum rmd_personality_flag f, bool on);

/* The built-in personalities: count and the i-th (NULL past the end).  Non-rt. */
size_t rmd_personality_builtin_count(void);
const struct rmd_personality *rmd_personality_builtin_at(size_t i);

/* The built-in personality called `name` (any case), or NULL.  Non-rt. */
const struct rmd_personality *rmd_personality_builtin(const char *name);

/*
 * The built-in personality of a motor of this model (0xB5, any case),
 * firmware date (0xB2) and dialect, or NULL.  rt-safe.
 */
const struct rmd_personality *rmd_personality_match(const char *model, uint32_t version_date,
						    enum rmd_proto proto);

/* "x4-64-2025070202, x4-36-2025070202, ..." into buf; returns buf.  Non-rt. */
const char *rmd_personality_names(char *buf, size_t size);

/*
 * Parse a personality file's text (len bytes, need not be NUL-terminated)
 * into *out (source RMD_PERSONALITY_FILE; name its `name` line, else
 * `file`).  Returns 0, or -EINVAL with err = "FILE:LINE: key: message"
 * (the first error; FILE is `file`), -EFBIG for more than
 * RMD_PERSONALITY_FILE_MAX bytes or RMD_PERSONALITY_LINES_MAX lines.
 * Time linear in len.  Non-rt, no allocation.
 */
int rmd_personality_parse(const char *text, size_t len, const char *file,
			  struct rmd_personality *out, char *err, size_t errsize);

/*
 * Write *p in the file format, a comment line per `comment` line first
 * (NULL: none); what rmd_personality_parse() reads back equal.  Returns 0
 * or -EIO when f reports a write error.  Non-rt.
 */
int rmd_personality_write(FILE *f, const struct rmd_personality *p, const char *comment);

/*
 * The turnaround line for a request (cmd its command byte, or
 * RMD_PERSONALITY_CMD_MIT): its own, else `*`, else NULL.  rt-safe.
 */
const struct rmd_personality_turnaround *
rmd_personality_turnaround_for(const struct rmd_personality *p, unsigned cmd);

/*
 * A turnaround drawn from line t at u in [0, 1): the quantiles joined by
 * straight lines (the inverse of a piecewise-linear distribution), ns.
 * rt-safe.
 */
int64_t rmd_personality_turnaround_ns(const struct rmd_personality_turnaround *t, double u);

/* Whether the record says command byte cmd is never answered.  rt-safe. */
static inline bool rmd_personality_ignores(const struct rmd_personality *p, uint8_t cmd)
{
	return p->ignores[cmd >> 3] & (1u << (cmd & 7));
}

#endif /* RMD_SIM_PERSONALITY_H */
