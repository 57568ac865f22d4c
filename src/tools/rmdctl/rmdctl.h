/* SPDX-License-Identifier: MIT */
/*
 * rmdctl internals: the command table's rows and what the commands share.
 * Everything here is non-rt (a command-line tool).
 */
#ifndef RMDCTL_H
#define RMDCTL_H

#include <signal.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <getopt.h>

#include "rmd/bus.h"
#include "rmd/codec.h"
#include "rmd/dialect.h"
#include "rmd/mit.h"
#include "rmd/txn.h"
#include "tools/common/cli.h"
#include "tools/common/log.h"

/* Exit statuses of every command (printed by `rmdctl --help`). */
enum {
	RMDCTL_EXIT_OK = 0,    /* everything worked */
	RMDCTL_EXIT_DATA = 1,  /* bad input data, I/O error, or a codec refusal */
	RMDCTL_EXIT_USAGE = 2, /* bad command line */
};

/* Options of a device command beyond the bus options (struct rmdctl_cmd.opts). */
enum {
	O_JSON = 1u << 0,
	O_YES = 1u << 1,
	O_ROM = 1u << 2,
	O_SPEED = 1u << 3,
	O_FORCE = 1u << 4,
	O_NOWAIT = 1u << 5,
	O_ONCE = 1u << 6,
	O_INTERVAL = 1u << 7,
	O_COUNT = 1u << 8,
	O_OUT = 1u << 9,
	O_MOVE = 1u << 10,
	O_POWER = 1u << 11,
};

struct dev;

/*
 * One command: `rmdctl NAME ARGS...`.  Device commands have args, arity,
 * opts, help and run (called with the options parsed and min_args..max_args
 * positional arguments); decode and encode have main (argv[0] == NAME) and
 * usage instead, as they parse their own command line.
 */
struct rmdctl_cmd {
	const char *name;
	const char *summary; /* one line for `rmdctl help` */
	const char *args;    /* positional arguments, for usage */
	unsigned min_args, max_args;
	unsigned opts; /* O_* */
	const char *help;
	int (*run)(struct dev *d, int argc, char **argv);
	int (*main)(int argc, char **argv);
	void (*usage)(FILE *f);
};

int rmdctl_decode_run(int argc, char **argv);
void rmdctl_decode_usage(FILE *f);
int rmdctl_encode_run(int argc, char **argv);
void rmdctl_encode_usage(FILE *f);
/* top.c: a running rmdd over LCM */
int rmdctl_top_run(int argc, char **argv);
void rmdctl_top_usage(FILE *f);
/* robot.c: `rmdctl stop --robot`, a robot-wide stop over LCM (docs/robot.md) */
bool rmdctl_is_robot_stop(int argc, char **argv);
int rmdctl_robot_stop_run(int argc, char **argv);
void rmdctl_robot_stop_usage(FILE *f);
extern const struct tool_opt rmdctl_robot_stop_opts[];
extern const size_t rmdctl_n_robot_stop_opts;
/* top's options (its --help and the bash completion). */
extern const struct tool_opt rmdctl_top_opts[];
extern const size_t rmdctl_n_top_opts;

/* The options rmdctl_codec_getopt() handles: first in decode's and encode's tables. */
/* clang-format off */
#define RMDCTL_CODEC_OPTS \
	{ .name = "protocol", .shortc = 'p', .has_arg = required_argument, .arg = "P", \
	  .help = "", .value = TOOL_VAL_PROTO }, \
	{ .name = "mit-ranges", .shortc = 'm', .has_arg = required_argument, \
	  .arg = "P,V,T,KP,KD", .help = "" }, \
	{ .name = "help", .shortc = 'h', .help = "" }, \
	{ .name = "yes", .shortc = 'y', .help = "" }
/* clang-format on */

/* decode's and encode's options (their --help texts describe them). */
extern const struct tool_opt rmdctl_decode_opts[], rmdctl_encode_opts[];
extern const size_t rmdctl_n_decode_opts, rmdctl_n_encode_opts;

/* ---- command lines (parse.c) ------------------------------------------------------------ */

/* decode's and encode's operands (their usage lines and main.c's table). */
#define RMDCTL_DECODE_ARGS "[FILE]"
#define RMDCTL_ENCODE_ARGS "COMMAND [ARGS...]"

/* The protocol of every command that is not told one (--protocol). */
#define RMDCTL_PROTO_DEFAULT RMD_PROTO_V3

/* decode's and encode's command lines (rmdctl_codec_getopt()). */
struct rmdctl_codec_cmd {
	const char *name;	     /* "encode" */
	const char *args;	     /* its operands, for the usage hint: RMDCTL_ENCODE_ARGS */
	const struct tool_opt *opts; /* its option table, RMDCTL_CODEC_OPTS first */
	size_t n_opts;
	bool stop_at_operand; /* options end at the first operand (encode's values may be negative) */
	void (*usage)(FILE *f); /* --help */
};

/*
 * The command line of decode or encode, up to its operands: the options
 * both have (-p/--protocol into *proto, -m/--mit-ranges into *ranges,
 * -h/--help, and -y/--yes, which every rmdctl command accepts and these
 * ignore) here, each other option's short letter through own(c, ctx),
 * which returns 0 or -1 (reported).  Returns -1 to go on (optind at the
 * first operand), or the exit status: RMDCTL_EXIT_OK after --help, or
 * RMDCTL_EXIT_USAGE after a bad option (reported, with the usage line).
 */
int rmdctl_codec_getopt(int argc, char **argv, const struct rmdctl_codec_cmd *c,
			enum rmd_proto *proto, struct rmd_mit_ranges *ranges,
			int (*own)(int c, void *ctx), void *ctx);

/*
 * After a usage error of command `name` with operands `args` (NULL: none;
 * name NULL: no command): the usage line and "see --help".
 */
void rmdctl_usage_hint_args(const char *name, const char *args);
/* The same for command c (NULL: no command). */
void rmdctl_usage_hint(const struct rmdctl_cmd *c);
/* The same for the command named name (main.c's table: top). */
void rmdctl_usage_hint_name(const char *name);

/* A whole-string finite number (C locale).  Returns 0 or -EINVAL. */
int rmdctl_parse_double(const char *s, double *v);

/*
 * The protocol keys as help texts list them, from the dialect list: "v3
 * (default), v2, mit (= v3 tables plus `mit`), or v4"; firmware_only: the
 * firmware dialects, "v3 (default), v2 or v4".  In buf, which it returns.
 */
const char *rmdctl_proto_help(char *buf, size_t size, bool firmware_only);

/* ---- device commands (bench.c) ---------------------------------------------------------- */

/* Requests in one batch: three reads for each of 32 motors. */
#define MAX_REQS (3 * RMD_MAX_MOTORS)
/* rtt --count: default and most */
#define RMDCTL_RTT_COUNT 200
#define RMDCTL_RTT_MAX_COUNT 10000
/* --sim KEY=VALUE settings one command line may give. */
#define MAX_SIM_SETTINGS 16
/* Defaults of --interval (monitor) and --speed (move). */
#define MONITOR_INTERVAL_MS 200.0
#define MOVE_SPEED_DPS 30.0
/*
 * Without --timeout the wait per try is measured (rmdctl_open_bus()): the
 * first exchange of a run is preceded by one 0x9A to its motors that waits
 * up to RMDCTL_WAIT_PROBE_MS; the wait per try is then RMDCTL_WAIT_RTTS
 * times the slowest round trip heard plus RMDCTL_WAIT_SLACK_MS, within
 * the default (RMD_TXN_TIMEOUT_NS) and RMDCTL_WAIT_PROBE_MS.  A motor behind
 * a slow adapter (a USB latency timer of 16 ms, answers 8-48 ms late) is
 * found; a silent one costs RMDCTL_WAIT_PROBE_MS more.
 */
#define RMDCTL_WAIT_PROBE_MS 100
#define RMDCTL_WAIT_RTTS 2
#define RMDCTL_WAIT_SLACK_MS 1

/* Everything one run of a device command holds. */
struct dev {
	const struct rmdctl_cmd *cmd;
	uint8_t id; /* commands whose first argument is ID: that motor */
	/* options */
	const char *bus_spec;
	uint32_t baud;
	enum rmd_proto proto; /* its record: rmdctl_dialect() */
	double timeout_ms;
	bool timeout_set; /* --timeout given */
	/*
	 * The wait follows the turnaround measured (RMDCTL_WAIT_PROBE_MS):
	 * no --timeout, a command without a wait of its own (rtt has one), a
	 * bus without a reply timeout of its own (RS485 has one)
	 */
	bool wait_auto;
	bool wait_known;     /* ... and it was measured */
	int64_t wait_rtt_ns; /* the slowest round trip that measurement heard; 0: none */
	uint8_t wait_rtt_id; /* ... of this motor */
	bool line_timeout;   /* rtt: --timeout is RS485's own reply timeout too */
	unsigned tries;
	unsigned count; /* rtt --count */
	/* --sim KEY=VALUE: the simulated motors' model, applied at open in order */
	const char *sim_kv[MAX_SIM_SETTINGS];
	unsigned n_sim;
	bool json, yes, rom, force, no_wait, once, trace;
	double speed_dps;
	bool speed_set; /* --speed given */
	double interval_ms;
	/* characterize: --out, --move (0: none), --power-cycle, its candump log (NULL: none) */
	const char *out;
	double move_deg;
	bool power_cycle;
	FILE *log;
	/* the bus */
	struct rmd_bus bus;	   /* the transport */
	struct rmd_bus tbus;	   /* --trace: prints every frame, then calls bus */
	struct rmd_bus_wrap twrap; /* tbus's priv */
	struct rmd_bus *b;	   /* what the commands use: &bus or &tbus */
	char name[sizeof(((struct rmd_bus *)0)->name)]; /* the bus's, kept after close */
	struct rmd_txn_opts txn;
	int64_t t0_ns;	    /* start, for --trace and monitor times */
	int64_t t0_wall_ns; /* the same instant in CLOCK_REALTIME, for --trace */
};

/* One request to one motor and what came of it. */
struct req {
	uint8_t id;
	struct rmd_msg msg; /* request */
	struct rmd_txn t;
	bool probed;	    /* its first try was the 0x9A that measured the wait */
	bool answered;	    /* a frame matched */
	bool ok;	    /* ... and decoded (echo rows: equal to the request) */
	struct rmd_msg rep; /* decoded answer */
};

/* Fields gathered from several answers of one motor, in native units. */
struct rec {
	uint64_t present;
	uint64_t is_float; /* bit f: raw[f] holds binary32 bits (V4.2 §2.1 gains) */
	int64_t raw[RMD_FLD_COUNT];
	double scale[RMD_FLD_COUNT];
};

/*
 * The requests that read every gain of --protocol's dialect from motor id
 * (rmd_pid_requests()) into q[] (RMD_PID_SLOTS_MAX); their count, 0 when
 * it has no PID commands.
 */
unsigned rmdctl_pid_read_reqs(const struct dev *d, uint8_t id, struct req *q);

/*
 * The gains the answers to q[0..n) carry, into *got (its slots those
 * found); requests that are no PID read are passed over.  An answer that
 * lacks a gain its request named (V4.2 §2.1.3: another index) is reported;
 * returns how many did.
 */
unsigned rmdctl_pid_gather(struct dev *d, const struct req *q, unsigned n, struct rmd_pid_set *got);

/* Field f of r is `raw` as fs reads it (its scale; is_float: binary32 bits). */
void rmdctl_rec_set(struct rec *r, enum rmd_field f, const struct rmd_field_spec *fs, int64_t raw);

/* The gains of g (the dialect's slots), into r under their fields. */
void rmdctl_rec_add_gains(struct rec *r, const struct dev *d, const struct rmd_pid_set *g);

/* Set by SIGINT/SIGTERM: waits end early, move stops the motor, monitor exits. */
extern volatile sig_atomic_t rmdctl_interrupted;

/* Parse the command line of `cmd` (argv[0] is its name), run it, report write errors. */
int rmdctl_dev_run(const struct rmdctl_cmd *cmd, int argc, char **argv);
/* `rmdctl CMD --help` of a device command. */
void rmdctl_dev_usage(FILE *f, const struct rmdctl_cmd *c);
/* The options of the device commands (bench.c): struct tool_opt.flag is O_*, 0 for every one. */
extern const struct tool_opt rmdctl_dev_opts[];
extern const size_t rmdctl_n_dev_opts;

const struct rmd_cmd_spec *rmdctl_spec(const struct dev *d, uint8_t cmd);
/* "5", "0.5": a number of ms for messages. */
const char *rmdctl_ms_str(char *buf, size_t size, double ms);
/* A whole-string unsigned integer in [lo, hi].  Returns 0 or -EINVAL. */
int rmdctl_parse_uint(const char *s, uint64_t lo, uint64_t hi, uint64_t *v);
/* A motor id 1..32 (reported when bad).  Returns 0 or -EINVAL. */
int rmdctl_parse_id(const char *s, const char *what, uint8_t *id);
void rmdctl_sleep_until(int64_t t_ns);
/* ids[] = 1..32; returns 32. */
unsigned rmdctl_all_ids(uint8_t *ids);

/* "QUESTION? [y/N]" unless --yes: 0, RMDCTL_EXIT_USAGE (no terminal) or RMDCTL_EXIT_DATA. */
int rmdctl_confirm(struct dev *d, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Open --bus (with --trace, behind the tracing bus).  0 or RMDCTL_EXIT_DATA (reported). */
int rmdctl_open_bus(struct dev *d);
/*
 * The same for a command that will ask (confirm: ROM writes, moves): without
 * --yes and a terminal it refuses to "fmt..." first.  0 or an exit status.
 */
int rmdctl_open_bus_for(struct dev *d, bool confirm, const char *fmt, ...)
	__attribute__((format(printf, 3, 4)));
void rmdctl_close_bus(struct dev *d);

void rmdctl_req_init(struct req *q, uint8_t id, uint8_t cmd);
/* rmd_txn_prepare() of m to motor id in d's dialect; failure reported.  0 or RMDCTL_EXIT_DATA. */
int rmdctl_txn_prepare(struct rmd_txn *t, const struct dev *d, uint8_t id, const struct rmd_msg *m);
/* rmd_txn_run() on d's bus; Ctrl-C or a bus error reported.  0 or RMDCTL_EXIT_DATA. */
int rmdctl_txn_run(struct dev *d, struct rmd_txn *t, unsigned n, const struct rmd_txn_opts *o);
/* q[0..n) as one pipelined batch: 0 (each q[i].ok says), RMDCTL_EXIT_DATA on a bus error. */
int rmdctl_run_reqs(struct dev *d, struct req *q, unsigned n);
/* Open the bus, rmdctl_run_reqs(), close it: 0 or an exit status. */
int rmdctl_exchange(struct dev *d, struct req *q, unsigned n);
/* The answer rmdctl_run_reqs() got for one request; reports failure.  0 or RMDCTL_EXIT_DATA. */
int rmdctl_ask_check(struct dev *d, struct req *q);
/* One request; failure reported.  0 or RMDCTL_EXIT_DATA. */
int rmdctl_ask(struct dev *d, struct req *q);
/* "motor 3 did not answer 0x9A within 5 ms (3 tries)" + more; or "motor 3 only echoed 0x30 ...". */
void rmdctl_report_missing(struct dev *d, const struct req *q, const char *more);
/* Every failed request of a batch reported; returns how many failed. */
unsigned rmdctl_report_failed(struct dev *d, const struct req *q, unsigned n);
/*
 * The optional IDS argument (argc 0 or 1: ids 1..32 when none), then the
 * bus opened.  Returns the id count, or minus the exit status (reported).
 */
int rmdctl_ids_open(struct dev *d, int argc, char **argv, uint8_t *ids);
/* Probe ids[0..n) with 0x9A; found[] gets those that answered (one that only echoed is reported).  The count or -exit. */
int rmdctl_probe(struct dev *d, const uint8_t *ids, unsigned n, uint8_t *found, struct req *st);
/*
 * rmdctl_ids_open(), then rmdctl_probe() of those ids, where some motor must
 * answer: none is reported as "BUS: no motor answered 0x9A" and `none` after
 * it.  Returns the count in found[] (1 or more), or minus the exit status
 * with the bus closed.
 */
int rmdctl_ids_probe(struct dev *d, int argc, char **argv, uint8_t *found, struct req *st,
		     const char *none);

/* ---- output (output.c) ------------------------------------------------------------------ */

bool rmdctl_rec_has(const struct rec *r, enum rmd_field f);
/* Field f in native units. */
double rmdctl_rec_val(const struct rec *r, enum rmd_field f);
/* Fold the fields of an answer into r; keep what r has unless overwrite. */
void rmdctl_rec_add(struct rec *r, const struct rmd_cmd_spec *spec, const struct rmd_msg *m,
		    bool overwrite);
void rmdctl_rec_add_req(struct rec *r, const struct dev *d, const struct req *q, bool overwrite);

/* "0x0004 low_voltage" or "none". */
const char *rmdctl_errors_text(const struct dev *d, int64_t raw, char *buf, size_t size);
/* A field's value as text (no unit) for tables and "key: value" lines; "-" when missing. */
const char *rmdctl_field_text(const struct dev *d, const struct rec *r, enum rmd_field f, char *buf,
			      size_t size);
/* ,"key":value for one field; null when it is missing. */
void rmdctl_json_field(const struct dev *d, const struct rec *r, enum rmd_field f);
/* A JSON string (quoted, escaped) on stdout. */
void rmdctl_json_str(const char *s);
/* {"bus":...,"motor_id":N,"protocol":"V3" */
void rmdctl_json_begin(const struct dev *d, uint8_t id);
/* One motor: a JSON line, or a header and one line per field. */
void rmdctl_print_rec(const struct dev *d, uint8_t id, const struct rec *r,
		      const enum rmd_field *order, size_t n);

/* ---- the commands (read.c, settings.c, motion.c) ---------------------------------------- */

int rmdctl_run_scan(struct dev *d, int argc, char **argv);
int rmdctl_run_info(struct dev *d, int argc, char **argv);
int rmdctl_run_status(struct dev *d, int argc, char **argv);
int rmdctl_run_monitor(struct dev *d, int argc, char **argv);
int rmdctl_run_set_id(struct dev *d, int argc, char **argv);
int rmdctl_run_set_zero(struct dev *d, int argc, char **argv);
int rmdctl_run_multiturn_save(struct dev *d, int argc, char **argv);
int rmdctl_run_angle_limit(struct dev *d, int argc, char **argv);
int rmdctl_run_set_timeout(struct dev *d, int argc, char **argv);
int rmdctl_run_accel(struct dev *d, int argc, char **argv);
int rmdctl_run_pid(struct dev *d, int argc, char **argv);
int rmdctl_run_brake(struct dev *d, int argc, char **argv);
int rmdctl_run_stop(struct dev *d, int argc, char **argv);
int rmdctl_run_off(struct dev *d, int argc, char **argv);
int rmdctl_run_reset(struct dev *d, int argc, char **argv);
int rmdctl_run_move(struct dev *d, int argc, char **argv);
/* rtt.c */
int rmdctl_run_rtt(struct dev *d, int argc, char **argv);
/* characterize.c */
int rmdctl_run_characterize(struct dev *d, int argc, char **argv);
/* motion.c, for characterize's move: 0x81 (reported), and the wait for arrival */
void rmdctl_stop_motor(struct dev *d, uint8_t id);
int rmdctl_move_wait(struct dev *d, uint8_t id, double from, double target, double *final,
		     const char **why);
/* dump.c */
int rmdctl_run_dump(struct dev *d, int argc, char **argv);
int rmdctl_run_restore(struct dev *d, int argc, char **argv);

struct rec;
/*
 * The dialect the firmware date in r says (rmd_dialect_for_firmware()),
 * when r has one and --protocol's dialect has 0xB2; else NULL.
 */
const struct rmd_dialect *rmdctl_rec_dialect(const struct dev *d, const struct rec *r,
					     bool *certain);

/* The dialect the motors on the device speak (--protocol), rmd/dialect.h. */
static inline const struct rmd_dialect *rmdctl_dialect(const struct dev *d)
{
	return rmd_dialect(d->proto);
}

#endif /* RMDCTL_H */
