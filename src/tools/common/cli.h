/* SPDX-License-Identifier: MIT */
/*
 * The command lines of rmdd, rmdctl and rmd-sim: each program describes
 * its options once, in a table of struct tool_opt, and that table feeds
 * getopt_long, --help, the "did you mean" of usage errors and the bash
 * completion the build writes (PROG --completion bash).
 *
 * Usage errors read the same in the three programs: one line that says
 * what is wrong (with a suggestion when a name is close to a known one),
 * then one usage line and "see `PROG --help`"; the exit status is 2.
 * Non-rt.
 */
#ifndef RMD_TOOL_CLI_H
#define RMD_TOOL_CLI_H

#include <getopt.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>

/* What an option's value is: what bash completion offers for it. */
enum tool_value {
	TOOL_VAL_NONE = 0, /* a switch (no value), or a value nothing can suggest */
	TOOL_VAL_FILE,	   /* a path */
	TOOL_VAL_BUS,	   /* a CAN interface, a serial device, or sim */
	TOOL_VAL_CAN,	   /* a CAN interface (/sys/class/net, type 280) */
	TOOL_VAL_SERIAL,   /* a serial device (/dev/ttyUSB*, /dev/ttyACM*, /dev/serial/by-id/) */
	TOOL_VAL_WORDS,	   /* one of tool_opt.words */
	TOOL_VAL_PROTO,	   /* a dialect's key (rmd_proto_keys, rmd/codec.h) */
	TOOL_VAL_FIRMWARE, /* a firmware dialect's key, not mit's (rmd_firmware_keys_text()) */
};

/* One option of a program. */
struct tool_opt {
	const char *name; /* the long name, without "--" */
	char shortc;	  /* its short letter, or 0 */
	int has_arg;	  /* getopt_long's no_argument, required_argument, optional_argument */
	const char *arg;  /* the value's name in --help ("FILE"); NULL: none */
	const char *help; /* --help text, '\n' between its lines; NULL: not listed */
	enum tool_value value;
	const char *words; /* TOOL_VAL_WORDS: "v3 v2" */
	unsigned flag;	   /* the program's own use (rmdctl: which commands have it) */
};

/*
 * The hidden option of every program: `PROG --completion bash` prints the
 * script the build installs (not in --help, not offered by completion).
 */
#define TOOL_OPT_COMPLETION                                                         \
	{                                                                           \
		.name = "completion", .has_arg = required_argument, .arg = "SHELL", \
		.value = TOOL_VAL_WORDS, .words = "bash"                            \
	}

/* The options every tool spells alike: their names and letters, once. */
#define TOOL_OPT_HELP                                              \
	{                                                          \
		.name = "help", .shortc = 'h', .help = "this text" \
	}
#define TOOL_OPT_VERBOSE(text)                                 \
	{                                                      \
		.name = "verbose", .shortc = 'v', .help = text \
	}
#define TOOL_OPT_QUIET(text)                                 \
	{                                                    \
		.name = "quiet", .shortc = 'q', .help = text \
	}
#define TOOL_OPT_VERSION(text)                                 \
	{                                                      \
		.name = "version", .shortc = 'V', .help = text \
	}
/* A long option that takes a value named arg (and one the program flags, flag_). */
#define TOOL_OPT_ARG_FLAG(name_, arg_, text, flag_)                                     \
	{                                                                               \
		.name = name_, .has_arg = required_argument, .arg = arg_, .help = text, \
		.flag = flag_                                                           \
	}
/* A long option that takes a value named arg. */
#define TOOL_OPT_ARG(name_, arg_, text)                                                \
	{                                                                              \
		.name = name_, .has_arg = required_argument, .arg = arg_, .help = text \
	}

/* getopt_long returns shortc, or TOOL_OPT_BASE + the row's index for a row without one. */
#define TOOL_OPT_BASE 0x100

/*
 * getopt_long's tables from o[0..n): lo (n + 1 entries, the last zero) and
 * the short option string (":" first, so a missing value returns ':').
 */
void tool_opts_getopt(const struct tool_opt *o, size_t n, struct option *lo, char *shorts,
		      size_t size);

/* The --help lines of the rows of o that have help, aligned in two columns. */
void tool_opts_help(FILE *f, const struct tool_opt *o, size_t n);

/* The closest of the names offered to tool_near_try(), for "did you mean". */
struct tool_near {
	const char *word;
	const char *best; /* NULL: none close enough */
	unsigned dist;
};

void tool_near_init(struct tool_near *n, const char *word);
/* Offer a candidate: kept when within 2 edits of the word, and closer than the others. */
void tool_near_try(struct tool_near *n, const char *cand);

/*
 * The usage error of a getopt_long return c ('?' or ':') on argv, for the
 * options o[0..n): "unknown option "--chek" (did you mean --check-config?)"
 * or "option "--bus" needs a value", into buf.  Returns buf.
 */
const char *tool_getopt_error(char *buf, size_t size, int c, char **argv, const struct tool_opt *o,
			      size_t n);

/* The long option of o[0..n) closest to arg ("--verbos", "--quiet=1"), or NULL. */
const char *tool_nearest_opt(const char *arg, const struct tool_opt *o, size_t n);

/* The two lines after a usage error on stderr: "usage: LINE" and "see `HELP`". */
void tool_usage_hint(const char *line, const char *help);

/* "PROG VERSION" on stdout: the build's RMD_VERSION (tools/version). */
void tool_print_version(const char *prog);

/* ---- bash completion ---------------------------------------------------------------------- */

/* A command of a program with commands (rmdctl COMMAND ...). */
struct tool_compl_cmd {
	const char *name;
	const struct tool_opt *opts; /* its options: the rows of opts[0..n) ... */
	size_t n;
	unsigned flags;		     /* ... whose flag is 0 or shares a bit with flags */
	const struct tool_opt *more; /* and every row of more[0..n_more) */
	size_t n_more;
	bool files; /* its arguments are files */
};

/*
 * The bash completion script of prog: the options opts[0..n) (after
 * PROG, or before the command), and when cmds is given the commands
 * cmds[0..ncmds) with their own options, and `help COMMAND`.
 */
void tool_completion_bash(FILE *f, const char *prog, const struct tool_opt *opts, size_t n,
			  const struct tool_compl_cmd *cmds, size_t ncmds);

/* --completion SHELL: true for bash, else false after "PROG: --completion SHELL: only bash". */
bool tool_completion_shell(const char *prog, const char *shell);

#endif /* RMD_TOOL_CLI_H */
