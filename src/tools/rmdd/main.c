// SPDX-License-Identifier: MIT
/*
 * rmdd: the real-time daemon for RMD motors (docs/design.md, layer tools).
 *
 *   rmdd --check-config FILE   load FILE, plan every bus, print the plan;
 *                              exit 0 when it fits, 1 with the errors
 *   rmdd [--config FILE]       run the daemon (FILE defaults to
 *                              RMDD_DEFAULT_CONFIG)
 *   rmdd --sim [N]             run on N built-in simulated motors
 *   rmdd --schema              print the configuration's JSON Schema
 *
 * The lifecycle (chrony style): main() builds everything, then starts the
 * threads, and tears down in reverse order; only main() exits.
 *
 *   load the configuration -> plan every bus (refuse an infeasible one)
 *   -> open every bus -> hand-over buffers and the event ring
 *   -> rmd_loop_new() -> bring-up (probe, 0xB3; report; refuse per config)
 *   -> LCM bridge init -> bridge thread -> rt loop thread (SCHED_FIFO, or
 *   one warning and normal priority unless --require-rt) -> monitor thread
 *   -> READY=1 -> the main thread serves signals (signalfd) and systemd:
 *      SIGUSR1     print the statistics, keep running
 *      SIGHUP      ignored (a new configuration needs a restart)
 *      SIGTERM/INT stop the loop (it stops every motor, 0xB3 stays), join
 *                  it, print the statistics, stop the bridge, close the
 *                  buses, exit 0
 *      every second: STATUS=; every WATCHDOG_USEC/2: WATCHDOG=1, only
 *      when the loop completed cycles since the last ping.
 *
 * Threads: the rt loop (SCHED_FIFO, loop.rt_priority), the LCM bridge and
 * the monitor (SCHED_OTHER), and the main thread (SCHED_OTHER; it leaves
 * a SCHED_FIFO it was started with, e.g. by CPUSchedulingPolicy=, after
 * bring-up).  Every signal is blocked in every thread and read from the
 * main thread's signalfd.
 *
 * Test hook, only in build/rmdd-test (compiled with -DRMDD_TEST_HOOKS; the
 * installed rmdd has none): RMDD_TEST_STALL_AFTER_MS=N (1..86400000) in the
 * environment makes the main thread stop the rt loop N ms after it started,
 * without joining it or telling anyone: the loop thread exits (stopping the
 * motors), its heartbeat freezes, and the real watchdog logic must stop the
 * pings.
 *
 * Exit statuses: 0 ok, 1 failure, 2 usage.  Non-rt.
 */
#define _GNU_SOURCE /* signalfd, sched_* */
#include <errno.h>
#include <getopt.h>
#include <inttypes.h>
#include <math.h>
#include <poll.h>
#include <sched.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <sys/eventfd.h>
#include <sys/signalfd.h>

#include "rmd/bringup.h"
#include "rmd/bus_open.h"
#include "rmd/codec.h"
#include "rmd/dialect.h"
#include "rmd/motor.h"
#include "rmd/multiturn.h"
#include "rmd/time.h"
#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/plan.h"
#include "tools/common/cli.h"
#include "rmdd.h"

#ifndef RMDD_DEFAULT_CONFIG
#define RMDD_DEFAULT_CONFIG "/etc/rmdd/rmdd.yaml"
#endif

#define RMDD_SIM_DEFAULT_MOTORS 6 /* rmdd --sim: two 1 Mbit/s sim buses of three motors */

#define STATUS_PERIOD_NS RMD_NS_PER_S
/* The main thread looks at the loop's heartbeat this often ... */
#define LOOK_PERIOD_NS (100 * RMD_NS_PER_MS)
/* ... and calls it stalled after this many periods without a cycle, and at least: */
#define STALL_PERIODS 5
#define STALL_MIN_NS (500 * RMD_NS_PER_MS)
/* READY=1 waits this long at most for the loop's first cycle. */
#define FIRST_CYCLE_WAIT_NS (2 * RMD_NS_PER_S)

enum rmdd_mode {
	MODE_RUN = 0, /* the daemon, from a config file */
	MODE_SIM,     /* the daemon, on rmd_config_sim_default() */
	MODE_CHECK,   /* --check-config */
	MODE_HELP,
	MODE_VERSION,
	MODE_COMPLETION, /* --completion bash: the script the build installs */
	MODE_SCHEMA,	 /* --schema: the configuration's JSON Schema */
};

struct rmdd_opts {
	enum rmdd_mode mode;
	const char *config;	/* --config or --check-config FILE */
	bool config_given;	/* --config: no fallback message for a missing default */
	unsigned sim_motors;	/* --sim [N] */
	const char *lcm_url;	/* --lcm-url: replaces the configuration's lcm.url */
	bool require_rt;	/* refuse to run without SCHED_FIFO and mlockall */
	bool force;		/* start beside another daemon on the same URL and prefix */
	int64_t stall_after_ns; /* RMDD_TEST_STALL_AFTER_MS */
};

/* Everything the daemon builds, in the order it builds it. */
struct rmdd {
	struct rmd_config cfg;
	struct rmd_sim_setup sim; /* the sim buses' simulator */
	struct rmd_plan plan;
	int sfd;	 /* signalfd: SIGTERM, SIGINT, SIGUSR1, SIGHUP */
	int snapshot_fd; /* eventfd: the loop pokes the bridge after each snapshot */
	struct rmd_bus buses[RMD_MAX_BUSES];
	/* hand-overs: bridge -> loop, loop -> bridge, loop -> monitor -> bridge */
	struct rmd_latest commands, snapshots, health, homes;
	struct rmd_ring events;
	void *buf_commands, *buf_snapshots, *buf_health, *buf_events, *buf_homes;
	struct rmd_loop *loop;
	struct rmdd_monitor mon;
	struct rmdd_incidents inc; /* the incident recorder: ring and writer */
	struct rmd_bridge *bridge;
	struct rmdd_notify notify;
	struct rmdd_stats_src stats;
};

#define STR_(x) #x
#define STR(x) STR_(x)

/* The options: getopt, --help and the bash completion. */
static const struct tool_opt opts[] = {
	{ .name = "config",
	  .shortc = 'c',
	  .has_arg = required_argument,
	  .arg = "FILE",
	  .help = "configuration (default " RMDD_DEFAULT_CONFIG ")",
	  .value = TOOL_VAL_FILE },
	{ .name = "check-config",
	  .shortc = 'C',
	  .has_arg = required_argument,
	  .arg = "FILE",
	  .help = "check FILE and print each bus's plan and budget;\n"
		  "exit 0 when every bus fits, 1 otherwise",
	  .value = TOOL_VAL_FILE },
	{ .name = "sim",
	  .shortc = 's',
	  .has_arg = optional_argument,
	  .arg = "N",
	  .help = "run on N (1.." STR(RMD_MAX_MOTORS) ", default " STR(
		  RMDD_SIM_DEFAULT_MOTORS) ") built-in simulated\n"
					   "motors, three per simulated 1 Mbit/s bus, at 1 kHz" },
	{ .name = "lcm-url",
	  .shortc = 'l',
	  .has_arg = required_argument,
	  .arg = "URL",
	  .help = "LCM provider instead of the configuration's lcm.url\n"
		  "(memq:// keeps all traffic inside rmdd)" },
	{ .name = "force",
	  .shortc = 'f',
	  .help = "start even when another rmdd publishes on the same LCM URL\n"
		  "and channel prefix (both then log the conflict)" },
	{ .name = "require-rt",
	  .shortc = 'r',
	  .help = "exit unless SCHED_FIFO and mlockall are granted" },
	TOOL_OPT_VERBOSE("also debug messages"),
	TOOL_OPT_QUIET("only warnings and errors"),
	TOOL_OPT_HELP,
	TOOL_OPT_VERSION("print \"rmdd VERSION\" and exit"),
	{ .name = "schema",
	  .shortc = 'S',
	  .help = "print the configuration file's JSON Schema (for YAML editors)\n"
		  "and exit" },
	TOOL_OPT_COMPLETION,
};
#define NOPTS (sizeof(opts) / sizeof(opts[0]))
#define OPT_COMPLETION (TOOL_OPT_BASE + (int)NOPTS - 1)

#define USAGE_LINE "rmdd [--config FILE | --sim [N] | --check-config FILE] [OPTIONS]"

static void usage(FILE *out)
{
	fprintf(out, "usage: rmdd [--config FILE] [--require-rt] [--lcm-url URL] [-f] [-v|-q]\n"
		     "       rmdd --sim [N] [--require-rt] [--lcm-url URL] [-f] [-v|-q]\n"
		     "       rmdd --check-config FILE\n"
		     "\n"
		     "Drives MyActuator RMD motors on CAN buses and RS485 lines at up to 1 kHz\n"
		     "and serves them over LCM.\n"
		     "\n");
	tool_opts_help(out, opts, NOPTS);
	fprintf(out, "\n"
		     "Log lines carry journald's <N> priority prefixes when journald reads them\n"
		     "(JOURNAL_STREAM), and are plain text elsewhere.\n"
		     "Signals: SIGTERM or SIGINT stop every motor and exit 0 after printing the\n"
		     "statistics; SIGUSR1 prints them and keeps running; SIGHUP is ignored.\n"
		     "Exit status: 0 ok, 1 failure (configuration, plan, bus, bring-up, LCM,\n"
		     "--require-rt), 2 bad command line.\n");
}

/* "6" -> 6 when it is a motor count 1..RMD_MAX_MOTORS. */
static int parse_count(const char *s, unsigned *out)
{
	char *end;
	unsigned long v;

	if (!s || !*s || *s < '0' || *s > '9')
		return -EINVAL;
	errno = 0;
	v = strtoul(s, &end, 10);
	if (errno || *end || v < 1 || v > RMD_MAX_MOTORS)
		return -EINVAL;
	*out = (unsigned)v;
	return 0;
}

static bool all_digits(const char *s)
{
	if (!s || !*s)
		return false;
	for (; *s; s++)
		if (*s < '0' || *s > '9')
			return false;
	return true;
}

/* Fill o from the command line.  Returns 0, or -EINVAL after a message. */
static int parse_args(int argc, char **argv, struct rmdd_opts *o)
{
	struct option longopts[NOPTS + 1];
	char shorts[64], msg[160];
	bool sim = false, check = false;
	int c;

	memset(o, 0, sizeof(*o));
	o->config = RMDD_DEFAULT_CONFIG;
	o->sim_motors = RMDD_SIM_DEFAULT_MOTORS;
	tool_opts_getopt(opts, NOPTS, longopts, shorts, sizeof(shorts));
	opterr = 0;
	while ((c = getopt_long(argc, argv, shorts, longopts, NULL)) != -1) {
		switch (c) {
		case 'c':
			o->config = optarg;
			o->config_given = true;
			break;
		case 'C':
			o->config = optarg;
			check = true;
			break;
		case 's':
			sim = true;
			/* "--sim 12" as well as "--sim=12" */
			if (!optarg && optind < argc && all_digits(argv[optind]))
				optarg = argv[optind++];
			if (optarg && parse_count(optarg, &o->sim_motors)) {
				fprintf(stderr, "rmdd: --sim %s: the motor count is 1..%d\n",
					optarg, RMD_MAX_MOTORS);
				return -EINVAL;
			}
			break;
		case 'l':
			o->lcm_url = optarg;
			break;
		case 'r':
			o->require_rt = true;
			break;
		case 'f':
			o->force = true;
			break;
		case 'v':
			tool_log_set_level(TOOL_LOG_DEBUG);
			break;
		case 'q':
			tool_log_set_level(TOOL_LOG_WARNING);
			break;
		case 'h':
			o->mode = MODE_HELP;
			return 0;
		case 'V':
			o->mode = MODE_VERSION;
			return 0;
		case 'S':
			o->mode = MODE_SCHEMA;
			return 0;
		case OPT_COMPLETION:
			if (!tool_completion_shell("rmdd", optarg))
				return -EINVAL;
			o->mode = MODE_COMPLETION;
			return 0;
		default:
			fprintf(stderr, "rmdd: %s\n",
				tool_getopt_error(msg, sizeof(msg), c, argv, opts, NOPTS));
			return -EINVAL;
		}
	}
	if (optind < argc) {
		fprintf(stderr, "rmdd: unexpected argument \"%s\"\n", argv[optind]);
		return -EINVAL;
	}
	if (sim && check) {
		fprintf(stderr, "rmdd: --sim and --check-config exclude each other\n");
		return -EINVAL;
	}
	if (sim && o->config_given) {
		fprintf(stderr, "rmdd: --sim and --config exclude each other\n");
		return -EINVAL;
	}
	if (o->lcm_url && (!o->lcm_url[0] || strlen(o->lcm_url) >= RMD_CONFIG_URL_LEN)) {
		fprintf(stderr, "rmdd: --lcm-url: empty, or longer than %d characters\n",
			RMD_CONFIG_URL_LEN - 1);
		return -EINVAL;
	}
#ifdef RMDD_TEST_HOOKS
	{
		const char *env = getenv("RMDD_TEST_STALL_AFTER_MS");
		long long ms;
		char *end;

		if (env && *env) {
			errno = 0;
			ms = strtoll(env, &end, 10);
			if (errno || *end || ms < 1 || ms > 86400000) {
				fprintf(stderr,
					"rmdd: RMDD_TEST_STALL_AFTER_MS=\"%s\": expected 1..86400000 "
					"(ms)\n",
					env);
				return -EINVAL;
			}
			o->stall_after_ns = ms * RMD_NS_PER_MS;
		}
	}
#endif
	o->mode = check ? MODE_CHECK : sim ? MODE_SIM : MODE_RUN;
	return 0;
}

/* "0-1,4" of the CPUs in set. */
static void cpu_list(const cpu_set_t *set, char *out, size_t len)
{
	size_t k = 0;

	out[0] = '\0';
	for (int c = 0; c < CPU_SETSIZE && k < len; c++) {
		int last = c;

		if (!CPU_ISSET(c, set))
			continue;
		while (last + 1 < CPU_SETSIZE && CPU_ISSET(last + 1, set))
			last++;
		if (last > c)
			k += (size_t)snprintf(out + k, len - k, "%s%d-%d", k ? "," : "", c, last);
		else
			k += (size_t)snprintf(out + k, len - k, "%s%d", k ? "," : "", c);
		c = last;
	}
}

/*
 * Every CPU of loop.cpu_affinity exists and this process may use it (its
 * affinity, e.g. systemd's CPUAffinity=).  Returns 0, or -EINVAL with a
 * message naming the first one that does not.
 */
static int check_cpus(const struct rmd_config *cfg, char *msg, size_t len)
{
	cpu_set_t set;
	char cpus[256];

	if (!cfg->loop.n_cpus || sched_getaffinity(0, sizeof(set), &set) < 0)
		return 0; /* none asked for, or cannot tell: the thread's start says */
	for (unsigned k = 0; k < cfg->loop.n_cpus; k++) {
		unsigned cpu = cfg->loop.cpus[k];

		if (cpu < CPU_SETSIZE && CPU_ISSET(cpu, &set))
			continue;
		cpu_list(&set, cpus, sizeof(cpus));
		snprintf(
			msg, len,
			"%s: loop.cpu_affinity: CPU %u does not exist on this machine, or rmdd may "
			"not use it (it may use CPUs %s)",
			cfg->source, cpu, cpus);
		return -EINVAL;
	}
	return 0;
}

/*
 * The note for a socketcan or rs485 bus with `sim:` sections, which are
 * rmd-sim's: "" for another bus.  Non-rt.
 */
static const char *sim_note(const struct rmd_config *cfg, unsigned b, char *buf, size_t len)
{
	const struct rmd_config_bus *cb = &cfg->buses[b];
	bool serial;
	const char *wire = rmd_config_bus_wire(cb, &serial);

	if (!cb->sim_section || !wire)
		return "";
	snprintf(buf, len,
		 "bus %s: its sim: sections are rmd-sim's (rmd-sim --config %s --bus %s); rmdd "
		 "simulates nothing on it and talks to the motors on %s",
		 cb->name, cfg->source, cb->name, wire);
	return buf;
}

/*
 * Position limits (and travel_rad) above this many rad, in a motor that
 * does not keep its multi-turn count, look like degrees: two output turns
 * either way of zero.  A joint's travel in rad is a few rad; 15 "rad" and
 * more is 15 deg and more written for rad.  Conservative: a joint that
 * really turns further keeps its count, or is told otherwise in its own
 * words (docs/faults.md "Position uncertain after power-off").
 */
#define DEGREES_LOOK_RAD (4.0 * M_PI)

/* One limit of motor i that looks like degrees: a warning line on stderr. */
static unsigned degrees_warning(const struct rmd_config *cfg, unsigned i, const char *key,
				unsigned line, double v)
{
	if (!line || !isfinite(v) || fabs(v) <= DEGREES_LOOK_RAD)
		return 0;
	fprintf(stderr,
		"%s:%u: motors[%u].%s: warning: %s: %g rad is %.1f output turns from zero: if "
		"degrees were meant, write %.4f; rmdd's positions are rad at the output shaft "
		"(whatever units says)\n",
		cfg->source, line, i, key, cfg->motors[i].name, v, fabs(v) / (2.0 * M_PI),
		v * M_PI / 180.0);
	return 1;
}

/*
 * What --check-config warns of, motor by motor, on stderr (FILE:LINE:
 * key: warning: ...; the exit status stays the plan's):
 *   - a geared motor in mode position or mit that will be position
 *     uncertain after every power cycle: it keeps no multi-turn count and
 *     its travel band is not narrower than one rotor turn at the output,
 *     decided by the rule the loop applies (rmd_multiturn_band_unique() on
 *     the motor record rmd_motor_init() builds, the reading's step
 *     included);
 *   - position limits or travel_rad that look like degrees
 *     (DEGREES_LOOK_RAD), for a motor that keeps no count.
 * Returns the number of warnings.  Non-rt.
 */
static unsigned position_warnings(const struct rmd_config *cfg)
{
	static struct rmd_motor rec; /* large: off the stack */
	unsigned n = 0;

	for (unsigned i = 0; i < cfg->n_motors; i++) {
		const struct rmd_config_motor *c = &cfg->motors[i];
		bool drives_position = c->mode == RMD_MODE_POSITION || rmd_config_mit_mode(c);
		double turn_deg = 360.0 / c->gear_ratio;

		if (c->multi_turn_saved)
			continue;
		n += degrees_warning(cfg, i, "limits.position_min_rad", c->pos_min_line,
				     c->limits.position_min_rad);
		n += degrees_warning(cfg, i, "limits.position_max_rad", c->pos_max_line,
				     c->limits.position_max_rad);
		if (c->n_travel == 2) {
			n += degrees_warning(cfg, i, "travel_rad", c->travel_line,
					     c->travel_rad[0]);
			n += degrees_warning(cfg, i, "travel_rad", c->travel_line,
					     c->travel_rad[1]);
		}
		if (!drives_position || !(c->gear_ratio > 1.0) || rmd_motor_init(&rec, c) < 0 ||
		    rmd_multiturn_band_unique(&rec.mt))
			continue;
		fprintf(stderr,
			"%s:%u: motors[%u]: warning: %s (mode %s, gear_ratio %g) will be position "
			"uncertain after every power cycle: one rotor turn is %g deg at the output, "
			"and its travel band (%s) is not narrower, nor does it keep its count; rmdd "
			"refuses position mode and MIT with kp > 0 for it after each power-on until "
			"it is homed. Fix: travel_rad: [min, max] narrower than %g deg (360 / "
			"gear_ratio, less the reading's step), or multi_turn_saved: true if its "
			"firmware saves the count (0x20 index 4, V3 §2.33.4), or home it at each "
			"start (rmd.home_t, the Python client's home(); docs/faults.md \"Position "
			"uncertain after power-off\")\n",
			cfg->source, c->line, i, c->name, rmd_mode_name(c->mode), c->gear_ratio,
			turn_deg,
			c->n_travel == 2 ? "travel_rad" :
			isfinite(c->limits.position_min_rad) &&
					isfinite(c->limits.position_max_rad) ?
					   "its position limits" :
					   "no travel_rad, no position limits",
			turn_deg);
		n++;
	}
	return n;
}

/* --check-config: exit status 0 when every bus fits. */
static int check_config(const char *path)
{
	static struct rmd_config cfg; /* large: off the stack */
	static struct rmd_plan plan;
	char err[RMDD_ERR_LEN], note[RMD_CONFIG_SOURCE_LEN + RMD_CONFIG_PATH_LEN + 256];
	int r;

	r = rmd_config_load(path, &cfg, NULL, err, sizeof(err));
	if (!r)
		r = check_cpus(&cfg, err, sizeof(err));
	if (r) {
		fprintf(stderr, "%s\n", err);
		return RMDD_EXIT_FAIL;
	}
	r = rmd_plan_build(&cfg, &plan, err, sizeof(err));
	rmd_plan_print(&plan, &cfg, stdout);
	for (unsigned b = 0; b < cfg.n_buses; b++)
		if (*sim_note(&cfg, b, note, sizeof(note)))
			printf("\n%s\n", note);
	/* the firmware decides the MIT scaling: only bring-up can read it */
	for (unsigned i = 0, first = 1; i < cfg.n_motors; i++) {
		char mit[1024];

		if (!rmd_config_mit_mode(&cfg.motors[i]))
			continue;
		if (first)
			printf("\nMIT scaling, decided at bring-up from each motor's firmware date "
			       "(0xB2) and model (0xB5) (docs/protocol-v4.md \"MIT scaling\"):\n");
		first = 0;
		rmdd_mit_config_note(&cfg, i, mit, sizeof(mit));
		printf("  %s\n", mit);
	}
	rmdd_robot_note(&cfg, note, sizeof(note));
	if (note[0])
		printf("\n%s\n", note);
	fflush(stdout);
	position_warnings(&cfg);
	if (r) {
		fprintf(stderr, "%s\n", err);
		return RMDD_EXIT_FAIL;
	}
	return RMDD_EXIT_OK;
}

/* Print a multi-line message, one log line per line. */
static void log_lines(int level, const char *text)
{
	const char *p = text;

	while (*p) {
		const char *nl = strchr(p, '\n');
		int n = nl ? (int)(nl - p) : (int)strlen(p);

		tool_log(level, "%.*s", n, p);
		p += n + (nl ? 1 : 0);
	}
}

/* ---- building ------------------------------------------------------------- */

/* Configuration and plan.  Returns an exit status. */
static int load(struct rmdd *d, const struct rmdd_opts *o)
{
	static char err[RMDD_ERR_LEN];
	int r;

	if (o->mode == MODE_SIM) {
		r = rmd_config_sim_default(&d->cfg, &d->sim, o->sim_motors);
		if (r) {
			tool_log(3, "--sim %u: cannot build the simulated configuration",
				 o->sim_motors);
			return RMDD_EXIT_FAIL;
		}
	} else {
		if (!o->config_given && access(o->config, F_OK) < 0 && errno == ENOENT) {
			tool_log(3,
				 "no configuration: %s does not exist; pass --config FILE (see "
				 "examples/rmdd.yaml), or --sim to run on simulated motors",
				 o->config);
			return RMDD_EXIT_USAGE;
		}
		r = rmd_config_load(o->config, &d->cfg, &d->sim, err, sizeof(err));
		if (r) {
			log_lines(3, err);
			return RMDD_EXIT_FAIL;
		}
		for (unsigned b = 0; b < d->cfg.n_buses; b++)
			if (*sim_note(&d->cfg, b, err, sizeof(err)))
				tool_log(6, "%s", err);
	}
	/* --lcm-url, else the file's lcm.url, else $LCM_DEFAULT_URL, else the default */
	if (o->lcm_url) {
		snprintf(d->cfg.lcm.url, sizeof(d->cfg.lcm.url), "%s", o->lcm_url);
	} else if (!d->cfg.lcm.url_given) {
		const char *env = getenv("LCM_DEFAULT_URL");

		if (env && env[0] && strlen(env) < sizeof(d->cfg.lcm.url))
			snprintf(d->cfg.lcm.url, sizeof(d->cfg.lcm.url), "%s", env);
		else if (env && env[0])
			tool_log(4, "LCM_DEFAULT_URL: longer than %zu characters: ignored",
				 sizeof(d->cfg.lcm.url) - 1);
	}
	if (check_cpus(&d->cfg, err, sizeof(err)) < 0) {
		log_lines(3, err);
		return RMDD_EXIT_FAIL;
	}
	r = rmd_plan_build(&d->cfg, &d->plan, err, sizeof(err));
	if (r) {
		log_lines(3, err);
		tool_log(3, "%s: the plan does not fit; `rmdd --check-config %s` prints it",
			 d->cfg.source, d->cfg.source);
		return RMDD_EXIT_FAIL;
	}
	return RMDD_EXIT_OK;
}

/* Block the signals main serves (every thread inherits the mask) and open the signalfd. */
static int signals_open(struct rmdd *d)
{
	sigset_t set;

	sigemptyset(&set);
	sigaddset(&set, SIGTERM);
	sigaddset(&set, SIGINT);
	sigaddset(&set, SIGUSR1);
	sigaddset(&set, SIGHUP);
	if (sigprocmask(SIG_BLOCK, &set, NULL) < 0)
		return -errno;
	/* a closed stderr reader or LCM socket must not kill the daemon */
	signal(SIGPIPE, SIG_IGN);
	d->sfd = signalfd(-1, &set, SFD_NONBLOCK | SFD_CLOEXEC);
	return d->sfd < 0 ? -errno : 0;
}

static void *zalloc3(size_t size)
{
	return calloc(3, size);
}

/* Triple buffers and the event ring.  Returns 0 or -ENOMEM. */
static int handovers_init(struct rmdd *d)
{
	d->buf_commands = zalloc3(sizeof(struct rmd_command));
	d->buf_snapshots = zalloc3(sizeof(struct rmd_snapshot));
	d->buf_health = zalloc3(sizeof(struct rmd_health));
	d->buf_events = calloc(RMDD_EVENT_SLOTS, sizeof(struct rmd_event));
	d->buf_homes = zalloc3(sizeof(struct rmd_home));
	if (!d->buf_commands || !d->buf_snapshots || !d->buf_health || !d->buf_events ||
	    !d->buf_homes)
		return -ENOMEM;
	rmd_latest_init(&d->homes, d->buf_homes, sizeof(struct rmd_home));
	rmd_latest_init(&d->commands, d->buf_commands, sizeof(struct rmd_command));
	rmd_latest_init(&d->snapshots, d->buf_snapshots, sizeof(struct rmd_snapshot));
	rmd_latest_init(&d->health, d->buf_health, sizeof(struct rmd_health));
	d->snapshot_fd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
	if (d->snapshot_fd < 0)
		return -errno;
	return rmd_ring_init(&d->events, d->buf_events, RMDD_EVENT_SLOTS, sizeof(struct rmd_event));
}

static void handovers_free(struct rmdd *d)
{
	if (d->snapshot_fd >= 0)
		close(d->snapshot_fd);
	free(d->buf_homes);
	free(d->buf_events);
	free(d->buf_health);
	free(d->buf_snapshots);
	free(d->buf_commands);
}

/* One line of the bring-up report, built in pieces. */
struct line {
	char s[4096];
	size_t n;
};

__attribute__((format(printf, 2, 3))) static void line_add(struct line *ln, const char *fmt, ...)
{
	va_list ap;
	int k;

	if (ln->n + 1 >= sizeof(ln->s))
		return;
	va_start(ap, fmt);
	k = vsnprintf(ln->s + ln->n, sizeof(ln->s) - ln->n, fmt, ap);
	va_end(ap);
	if (k > 0)
		ln->n += (size_t)k;
	if (ln->n >= sizeof(ln->s))
		ln->n = sizeof(ln->s) - 1;
}

/* "bus: motor 2 (knee): X8S2V10, firmware 20220206, 48.5 V, 25 °C".  Returns its log level. */
static int motor_line(const struct rmd_config *cfg, unsigned i, const struct rmd_bringup_motor *bm,
		      struct line *ln)
{
	const struct rmd_config_motor *c = &cfg->motors[i];
	const struct rmd_dialect *d = rmd_dialect(bm->proto);
	int level = 6;

	line_add(ln, "%s: motor %u (%s): ", cfg->buses[c->bus].name, c->id, c->name);
	if (bm->state == RMD_BRINGUP_MISSING) {
		line_add(ln, "missing (no answer to 0x%02X in %u tries of %lld ms)", bm->probe_cmd,
			 bm->tries, (long long)(bm->timeout_ns / RMD_NS_PER_MS));
		return 4;
	}
	if (!rmd_dialect_has(d, RMD_DIALECT_MODEL_B5 | RMD_DIALECT_VERSION_B2)) {
		line_add(ln, "%s (no model or version query)", d->name);
	} else {
		line_add(ln, "%s", bm->model[0] ? bm->model : "(no model)");
		if (!bm->version) {
			line_add(ln, ", no answer to 0xB2");
			level = 4;
		} else if (rmd_version_date_valid(bm->version)) {
			line_add(ln, ", firmware %u", (unsigned)bm->version);
		} else {
			line_add(ln, ", firmware date %u implausible", (unsigned)bm->version);
		}
		/* issue 32 point 17: the date decides its dialect and MIT scaling */
		if (bm->version_again)
			line_add(ln,
				 bm->version ?
					 " (its 0xB2 answered only when asked again, waiting "
					 "up to %u ms: probe.reply_timeout_ms)" :
					 " (asked again, waiting %u ms: probe.reply_timeout_ms)",
				 cfg->probe.reply_timeout_ms);
	}
	if (bm->status) {
		line_add(ln, ", %.1f V, %.0f °C", bm->voltage_v, bm->temp_c);
		if (bm->error_code) {
			const char *names[4];
			size_t n = rmd_error_names(bm->proto, bm->error_code, names, 4);

			line_add(ln, ", errors 0x%04X (", bm->error_code);
			for (size_t k = 0; k < n && k < 4; k++)
				line_add(ln, "%s%s", k ? ", " : "", names[k]);
			line_add(ln, "%s)", n > 4 ? ", ..." : "");
		}
	} else {
		line_add(ln, ", no answer to 0x9A");
		level = 4;
	}
	if (bm->pushed) {
		line_add(ln, ", it pushed");
		for (unsigned k = 0; k < d->n_report_cmds; k++)
			if (bm->pushed & (1u << k))
				line_add(ln, " 0x%02X", d->report_cmds[k]);
		line_add(ln, " unasked (0xB6 active reply, left on by another tool)%s",
			 bm->reports_off ? ": turned off" : "");
	}
	if (rmd_dialect_has(d, RMD_DIALECT_ACTIVE_REPLY) && !bm->reports_off &&
	    bm->state != RMD_BRINGUP_MISSING) {
		line_add(ln, ", 0xB6 active reply not turned off: its pushed replies are taken "
			     "as reports");
		level = 4;
	}
	if (bm->proto_auto)
		line_add(ln,
			 bm->auto_certain ? ", protocol auto: %s" :
					    ", protocol auto: %s (its firmware date does not tell "
					    "the generation: the conservative one taken)",
			 d->key);
	if (rmd_dialect_has(d, RMD_DIALECT_ENCODER_UNWRAP) && !bm->v2_angle)
		line_add(ln, ", no 0x92 angle: no position until it answers one");
	if (!rmd_dialect_has(d, RMD_DIALECT_COMM_LOSS_B3))
		line_add(ln, ", no 0xB3 in %s (no comm-loss protection)", d->name);
	/* the scaling chosen for its MIT frames, and why (docs/protocol-v4.md "MIT scaling") */
	if (bm->mit_mode && bm->mismatch == RMD_BRINGUP_MISMATCH_NONE) {
		char mit[512];

		rmdd_mit_text(d, &bm->mit, bm->version, bm->model, mit, sizeof(mit));
		line_add(ln, ", %s", mit);
	}
	if (bm->state == RMD_BRINGUP_MISMATCH) {
		line_add(ln, "; refused: ");
		switch (bm->mismatch) {
		case RMD_BRINGUP_MISMATCH_FIRMWARE: {
			bool certain;
			const char *fw = rmd_dialect_for_firmware(bm->version, &certain)->key;

			line_add(ln,
				 "its firmware %u is %s, but its protocol is %s (set protocol: %s, "
				 "or auto",
				 (unsigned)bm->version, fw, rmd_proto_key(c->proto), fw);
			/* `mit` names V3 firmware driven in MIT: the mode stays */
			if (!rmd_dialect_is_firmware(rmd_dialect(c->proto)))
				line_add(ln, ", and keep mode: mit");
			line_add(ln, ")");
			break;
		}
		case RMD_BRINGUP_MISMATCH_NO_MIT:
			line_add(
				ln,
				"it answers as %s, which has no MIT mode (V2 has no 0x400 frames), "
				"and its mode is mit (set protocol: %s and another mode, as for a "
				"%s motor)",
				d->name, d->key, d->name);
			break;
		case RMD_BRINGUP_MISMATCH_MIT_SCALING: {
			char mit[512];

			rmdd_mit_text(d, &bm->mit, bm->version, bm->model, mit, sizeof(mit));
			line_add(ln, "%s", mit);
			break;
		}
		case RMD_BRINGUP_MISMATCH_NO_COMM_LOSS:
			line_add(
				ln,
				"it answers as %s, which has no comm-loss protection (0xB3), and its "
				"comm_loss_ms is %u (set protocol: %s and comm_loss_ms: 0, as for a "
				"%s motor)",
				d->name, (unsigned)rmd_config_comm_loss_ms(cfg, i), d->key,
				d->name);
			break;
		case RMD_BRINGUP_MISMATCH_NO_FINE_ANGLE:
			line_add(ln,
				 "it answers as %s, whose 0x92 is not the fine position: "
				 "feedback.position multi_turn is for v3 and mit motors",
				 d->name);
			break;
		case RMD_BRINGUP_MISMATCH_NONE:
			break;
		}
		return 3;
	}
	return level;
}

/*
 * "bus: comm-loss protection (0xB3) 100 ms: 1 2 3 (3 set, echo verified)",
 * or level 0 when no motor of bus b had 0xB3 written.  Returns its log level.
 */
static int b3_line(const struct rmd_config *cfg, unsigned b, const struct rmd_bringup *bu,
		   struct line *ln)
{
	unsigned set = 0;
	int level = 0;

	for (unsigned i = 0; i < bu->n_motors; i++) {
		const struct rmd_config_motor *c = &cfg->motors[i];
		enum rmd_bringup_b3 b3 = bu->motor[i].b3;
		uint32_t ms = bu->motor[i].comm_loss_ms;

		if (c->bus != b || b3 == RMD_B3_NOT_APPLICABLE)
			continue;
		if (!level) {
			level = 6;
			line_add(ln, "%s: comm-loss protection (0xB3) %s", cfg->buses[b].name,
				 bu->comm_loss_ms ? "" :
						    "off (disabled by safety.comm_loss_ms: 0)");
			if (bu->comm_loss_ms)
				line_add(ln, "%u ms:", (unsigned)bu->comm_loss_ms);
		}
		if (ms != bu->comm_loss_ms && !ms) {
			/* its own key turns it off: whatever the answer, it may move */
			line_add(ln, " motor %u (%s) off (its comm_loss_ms: 0);", c->id, c->name);
			continue;
		}
		switch (b3) {
		case RMD_B3_SET:
			line_add(ln, " %u", c->id);
			if (ms != bu->comm_loss_ms)
				line_add(ln, " (%u ms)", (unsigned)ms);
			set++;
			break;
		case RMD_B3_ZEROS:
			line_add(ln, " motor %u (%s) answered zeros, not verified (V3 §2.30);",
				 c->id, c->name);
			if (level > 5)
				level = 5;
			break;
		case RMD_B3_NO_ANSWER:
		case RMD_B3_DIFFERS: {
			bool none = b3 == RMD_B3_NO_ANSWER;

			line_add(ln, " motor %u (%s) %s: it cannot be enabled until %s;", c->id,
				 c->name,
				 none ? "did not answer 0xB3" : "NOT confirmed (the echo differs)",
				 none ? "it does" : "it is");
			level = ms ? 4 : level;
			break;
		}
		case RMD_B3_NOT_APPLICABLE:
			break;
		}
	}
	if (level)
		line_add(ln, " (%u set, echo verified)", set);
	return level;
}

/* What a motor's protection is, for the exit line. */
static const char *comm_loss_why(uint8_t cl)
{
	switch (cl) {
	case RMD_CL_NO_ANSWER:
		return "did not answer 0xB3";
	case RMD_CL_DIFFERS:
		return "answered 0xB3 with another time";
	case RMD_CL_OFF:
		return "off by config";
	case RMD_CL_UNSUPPORTED:
		return "V2 has no 0xB3";
	default:
		/* RMD_CL_PENDING: missing at bring-up, or lost and not answered since */
		return "not armed: missing or lost, not re-armed since";
	}
}

/* What rmd_loop_stop_motors() sent, for the exit line (safety.shutdown_action).  Non-rt. */
static const char *shutdown_said(const struct rmd_config_safety *s)
{
	switch (s->shutdown_action) {
	case RMD_SHUTDOWN_STOP:
		return "every motor was sent stop (0x80)";
	case RMD_SHUTDOWN_HOLD:
		return "the driven motors were sent hold (0x81), the others stop (0x80)";
	case RMD_SHUTDOWN_DAMP:
		return "the driven motors were damped, then every motor was sent stop (0x80) and "
		       "brake (0x78)";
	case RMD_SHUTDOWN_BRAKE:
		return "every motor was sent stop (0x80) and brake (0x78)";
	case RMD_SHUTDOWN_DEFAULT:
		break;
	}
	return s->safe_action == RMD_SAFE_BRAKE ?
		       "every motor was sent stop (0x80) and brake (0x78)" :
		       "every motor was sent stop (0x80)";
}

/*
 * The last line: what the motors were sent and whose comm-loss protection
 * stays set, naming exactly the motors it is set on (after the loop's
 * thread is joined, so the loop's state is final).
 */
static void exit_line(const struct rmdd *d)
{
	const struct rmd_config *cfg = &d->cfg;
	const char *said = shutdown_said(&cfg->safety);
	unsigned set = 0, k = 0, unreached = 0;
	struct line ln = { .n = 0 }, sl = { .n = 0 };
	const char *sent;

	/* issue 20.9: the motors whose final frames no bus took or no answer confirmed */
	for (unsigned i = 0; i < cfg->n_motors; i++)
		if (!rmd_loop_stop_reached(d->loop, i))
			line_add(&sl, "%s%s", unreached++ ? ", " : "", cfg->motors[i].name);
	if (unreached) {
		struct line w = { .n = 0 };

		line_add(&w, "%s, but %s not reached (its bus took no frame, or %s not answer)",
			 said, sl.s, unreached == 1 ? "it did" : "they did");
		snprintf(sl.s, sizeof(sl.s), "%s", w.s);
		sent = sl.s;
	} else {
		sent = said;
	}
	for (unsigned i = 0; i < cfg->n_motors; i++)
		set += rmd_comm_loss_set(rmd_loop_comm_loss(d->loop, i));
	if (set == cfg->n_motors) {
		tool_log(5, "%s; their comm-loss protection (0xB3) stays set", sent);
		return;
	}
	for (unsigned i = 0; i < cfg->n_motors; i++)
		if (rmd_comm_loss_set(rmd_loop_comm_loss(d->loop, i)))
			line_add(&ln, "%s%s", k++ ? ", " : "", cfg->motors[i].name);
	line_add(&ln, "%snot set on ", set ? "; " : "none; ");
	k = 0;
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		uint8_t cl = rmd_loop_comm_loss(d->loop, i);

		if (!rmd_comm_loss_set(cl))
			line_add(&ln, "%s%s (%s)", k++ ? ", " : "", cfg->motors[i].name,
				 comm_loss_why(cl));
	}
	tool_log(5, "%s; comm-loss protection (0xB3) stays set on %s", sent, ln.s);
}

/*
 * "bus: round trip 0.52 .. 0.61 ms (12 answers)": what bring-up measured,
 * and a warning when the longest takes the whole period the plan gives a
 * reply (docs/troubleshooting.md "Slow answers").
 */
static void rtt_line(const struct rmd_config *cfg, unsigned b, const struct rmd_bringup_bus *bb,
		     int64_t period_ns)
{
	if (!bb->n)
		return;
	if (!bb->exceeds_period) {
		tool_log(6, "  %s: round trip %.2f .. %.2f ms (%u answers at their first try)",
			 cfg->buses[b].name, (double)bb->rtt_min_ns / 1e6,
			 (double)bb->rtt_max_ns / 1e6, bb->n);
		return;
	}
	tool_log(4,
		 "  %s: round trip %.2f .. %.2f ms (%u answers at their first try): longer than "
		 "a cycle (%.2f ms at %u Hz), so replies will come after their deadline and "
		 "count as missed; lower loop.rate_hz to at most %u Hz, or find what delays them "
		 "(a USB adapter or converter: docs/troubleshooting.md)",
		 cfg->buses[b].name, (double)bb->rtt_min_ns / 1e6, (double)bb->rtt_max_ns / 1e6,
		 bb->n, (double)period_ns / 1e6, cfg->loop.rate_hz,
		 (unsigned)(1e9 / ((double)bb->rtt_max_ns * 1.25)));
}

/*
 * A half-duplex line writes the next request when the answer or the
 * line's reply timeout comes: answers later than that timeout cross
 * requests on the wire.  Warn with what to set (the line's timeout
 * follows the bus's turnaround_us: rmd_bus_open()).
 */
static void line_timeout_line(const struct rmd_config *cfg, unsigned b,
			      const struct rmd_bringup_bus *bb, const struct rmd_bus *bus)
{
	const struct rmd_bus_caps *caps = rmd_bus_caps(bus);

	if (!bb->n || !caps->half_duplex || !caps->reply_timeout_ns ||
	    bb->rtt_max_ns <= caps->reply_timeout_ns)
		return;
	tool_log(4,
		 "  %s: round trip up to %.2f ms, longer than the line's reply timeout %.2f ms: "
		 "requests will go out while motors answer; set the bus's turnaround_us to at "
		 "least %lld (`rmdctl rtt` measures it; docs/troubleshooting.md \"Slow answers\")",
		 cfg->buses[b].name, (double)bb->rtt_max_ns / 1e6,
		 (double)caps->reply_timeout_ns / 1e6, (long long)(bb->rtt_max_ns / 1000));
}

/*
 * Bus b's motors that the file does not list and a 0x280 frame would
 * command (issue 33 point 2): no 0x280 frame on that bus, and a refusal
 * when its batched motors' own frames cannot all go every cycle.
 */
static void stray_line(const struct rmdd *d, unsigned b, const struct rmd_bringup *bu)
{
	const struct rmd_config *cfg = &d->cfg;
	const struct rmd_plan_bus *pb = &d->plan.bus[b];
	const char *bus = cfg->buses[b].name;
	unsigned n = (unsigned)__builtin_popcount(pb->batched);

	if (!bu->stray_ids[b])
		return;
	for (unsigned id = 1; id <= RMD_MAX_MOTORS; id++)
		if (bu->stray_ids[b] & (1u << (id - 1)))
			tool_log(
				bu->bus[b].stray_refused ? 3 : 4,
				"  %s: motor %u answers as firmware that takes the bus's 0x280 frame "
				"for its own command (first on 0x%03X), and %s does not list it",
				bus, id, (unsigned)bu->bus[b].stray_id, cfg->source);
	if (bu->bus[b].stray_refused)
		tool_log(
			3,
			"  %s: no 0x280 frame then, and without it %u of its %u V2 motors get their "
			"own frames a cycle at %u Hz: refused.  Add the motor to the file (as the "
			"motor it is), take it off the bus, or turn its CAN-ID filter on (0x20 "
			"index 2 = 1, V3 §2.33.4) and set can_id_filter: true for bus %s",
			bus, pb->batch_own, n, d->plan.rate_hz, bus);
	else
		tool_log(
			4,
			"  %s: no 0x280 frame: its %u V2 motors get frames of their own every cycle "
			"(add the motor to the file, or turn its CAN-ID filter on and set "
			"can_id_filter: true for bus %s, to batch them again)",
			bus, n, bus);
}

/* Bring-up with its report.  Returns an exit status. */
static int bringup(struct rmdd *d)
{
	static struct rmd_bringup bu;
	const struct rmd_config *cfg = &d->cfg;
	struct line ln;
	int r, level;

	r = rmd_loop_bringup(d->loop, &bu);
	tool_log(6, "bring-up of %u motor(s) on %u bus(es):", cfg->n_motors, cfg->n_buses);
	if (r != -EBUSY) {
		for (unsigned i = 0; i < bu.n_motors; i++) {
			ln.n = 0;
			if (bu.motor[i].state != RMD_BRINGUP_MISSING)
				rmdd_dialect_found(i, bu.motor[i].proto);
			level = motor_line(cfg, i, &bu.motor[i], &ln);
			tool_log(level, "  %s", ln.s);
		}
		for (unsigned b = 0; b < bu.n_buses; b++)
			for (unsigned id = 1; id <= RMD_MAX_MOTORS; id++)
				if (bu.unexpected_ids[b] & (1u << (id - 1)))
					tool_log(4,
						 "  %s: motor %u: unexpected (answers, but is not "
						 "configured)",
						 cfg->buses[b].name, id);
		for (unsigned b = 0; b < bu.n_buses; b++)
			stray_line(d, b, &bu);
		for (unsigned b = 0; b < bu.n_buses; b++) {
			ln.n = 0;
			level = b3_line(cfg, b, &bu, &ln);
			if (level)
				tool_log(level, "  %s", ln.s);
		}
		for (unsigned b = 0; b < bu.n_buses; b++) {
			rtt_line(cfg, b, &bu.bus[b], d->plan.period_ns);
			line_timeout_line(cfg, b, &bu.bus[b], &d->buses[b]);
		}
	}
	/* what bring-up reported through the ring goes out now */
	rmdd_monitor_drain(&d->mon);
	if (r == -EPROTO && bu.mismatched)
		tool_log(3,
			 "%u motor(s) answered as another dialect than %s says, or one that cannot "
			 "do what it asks (above)",
			 bu.mismatched, cfg->source);
	if (r == -EPROTO && bu.strays_refused)
		tool_log(
			3,
			"%u bus(es) of %s refused: a motor the file does not list would take their "
			"0x280 frame for its own command (above)",
			bu.strays_refused, cfg->source);
	if (r == -EPROTO)
		return RMDD_EXIT_FAIL;
	if (r == -ENODEV && !bu.unarmed) {
		tool_log(
			3,
			"%u motor(s) missing and probe.on_missing is refuse in %s (set it to start "
			"to run without them)",
			bu.missing, cfg->source);
		return RMDD_EXIT_FAIL;
	}
	if (r == -ENODEV) {
		tool_log(3,
			 "%u motor(s) missing, %u without comm-loss protection (0xB3 not set), and "
			 "probe.on_missing is refuse in %s (set it to start to run and keep them "
			 "from moving until they answer and are armed)",
			 bu.missing, bu.unarmed, cfg->source);
		return RMDD_EXIT_FAIL;
	}
	if (r < 0) {
		tool_log(3, "bring-up failed: %s", strerror(-r));
		return RMDD_EXIT_FAIL;
	}
	return RMDD_EXIT_OK;
}

/*
 * A main thread started at SCHED_FIFO (CPUSchedulingPolicy=) would compete
 * with the rt loop: it goes back to SCHED_OTHER once bring-up is done.
 */
static void main_thread_normal(const struct rmdd *d)
{
	struct sched_param sp = { .sched_priority = 0 };
	int pol = sched_getscheduler(0);

	if (pol != SCHED_FIFO && pol != SCHED_RR)
		return;
	if (sched_setscheduler(0, SCHED_OTHER, &sp) == 0)
		tool_log(7,
			 "main thread: SCHED_OTHER (started real-time; the rt loop takes "
			 "loop.rt_priority %u)",
			 d->cfg.loop.rt_priority);
	else
		tool_log(4, "main thread: cannot leave SCHED_%s: %s",
			 pol == SCHED_FIFO ? "FIFO" : "RR", strerror(errno));
}

/*
 * READY=1 means the loop runs: wait (up to FIRST_CYCLE_WAIT_NS) until it
 * completed a cycle, so the first STATUS= shows the motors as bring-up
 * left them.  A loop that does not start is reported, and the watchdog
 * gets no ping from it.
 */
static void wait_first_cycle(struct rmdd *d)
{
	const struct timespec step = { 0, RMD_NS_PER_MS };
	int64_t end = rmd_now_ns() + FIRST_CYCLE_WAIT_NS;

	while (rmd_loop_heartbeat(d->loop) == 0) {
		if (rmd_now_ns() >= end) {
			tool_log(3, "rt loop: no cycle completed %.1f s after its start",
				 (double)FIRST_CYCLE_WAIT_NS / 1e9);
			return;
		}
		nanosleep(&step, NULL);
	}
}

/* ---- serving --------------------------------------------------------------- */

/* The rt loop's liveness, as the main thread sees its heartbeat. */
struct liveness {
	uint64_t hb;	  /* heartbeat at the last look */
	int64_t advanced; /* when a look last saw it move */
	int64_t stall_ns; /* no move for this long: stalled */
	bool stalled;
};

/* Look at the heartbeat; log when the loop stalls or runs again. */
static void look(struct liveness *lv, struct rmdd *d, int64_t now)
{
	uint64_t hb = rmd_loop_heartbeat(d->loop);

	if (hb != lv->hb) {
		lv->hb = hb;
		lv->advanced = now;
		if (lv->stalled)
			tool_log(5, "rt loop: cycles complete again");
		lv->stalled = false;
	} else if (!lv->stalled && now - lv->advanced >= lv->stall_ns) {
		lv->stalled = true;
		tool_log(3, "rt loop: no cycle completed in the last %.1f s%s",
			 (double)(now - lv->advanced) / 1e9,
			 d->notify.watchdog_ns ? "; the systemd watchdog is no longer fed" : "");
	}
}

static void handle_signal(struct rmdd *d, int sig)
{
	switch (sig) {
	case SIGUSR1:
		rmdd_stats_print(&d->stats, "SIGUSR1");
		break;
	case SIGHUP:
		tool_log(5, "SIGHUP ignored: a new configuration takes a restart "
			    "(systemctl restart rmdd)");
		break;
	default:
		break;
	}
}

/*
 * Wait for signals; feed systemd.  Returns the signal that ends the daemon
 * (SIGTERM or SIGINT), or -errno.
 *
 * The main thread wakes at least every LOOK_PERIOD_NS to look at the
 * loop's heartbeat.  WATCHDOG=1 goes out every WATCHDOG_USEC/2, and only
 * when the heartbeat moved since the previous ping: a stuck loop stops the
 * pings and systemd restarts the service.  STATUS= every second.
 */
static int serve(struct rmdd *d, const struct rmdd_opts *o)
{
	const int64_t ping_every = d->notify.ping_every_ns;
	int64_t now = rmd_now_ns(), t_status = now;
	int64_t next_status = now + STATUS_PERIOD_NS, next_ping = now + ping_every;
	int64_t next_look = now + LOOK_PERIOD_NS;
	int64_t stall_at = o->stall_after_ns > 0 ? now + o->stall_after_ns : 0;
	struct liveness lv = {
		.hb = rmd_loop_heartbeat(d->loop),
		.advanced = now,
		.stall_ns = STALL_PERIODS * d->plan.period_ns > STALL_MIN_NS ?
				    STALL_PERIODS * d->plan.period_ns :
				    STALL_MIN_NS,
	};
	uint64_t hb_ping = lv.hb, hb_status = lv.hb;

	for (;;) {
		struct pollfd pfd = { .fd = d->sfd, .events = POLLIN };
		struct signalfd_siginfo si;
		int64_t next = next_status < next_look ? next_status : next_look;
		int r;

		if (ping_every && next_ping < next)
			next = next_ping;
		if (stall_at && stall_at < next)
			next = stall_at;
		r = poll(&pfd, 1,
			 next > now ? (int)((next - now + RMD_NS_PER_MS - 1) / RMD_NS_PER_MS) : 0);
		if (r < 0 && errno != EINTR)
			return -errno;
		while (read(d->sfd, &si, sizeof(si)) == (ssize_t)sizeof(si)) {
			if (si.ssi_signo == SIGTERM || si.ssi_signo == SIGINT)
				return (int)si.ssi_signo;
			handle_signal(d, (int)si.ssi_signo);
		}
		now = rmd_now_ns();
#ifdef RMDD_TEST_HOOKS
		if (stall_at && now >= stall_at) {
			tool_log(4, "test hook RMDD_TEST_STALL_AFTER_MS: the rt loop stops now and "
				    "nobody is told");
			rmd_loop_request_stop(d->loop);
			stall_at = 0;
		}
#endif
		if (now >= next_look) {
			look(&lv, d, now);
			next_look = now + LOOK_PERIOD_NS;
		}
		if (ping_every && now >= next_ping) {
			uint64_t hb = rmd_loop_heartbeat(d->loop);

			/* a stuck loop is not kept alive by this timer */
			if (hb != hb_ping)
				rmdd_notify_watchdog(&d->notify);
			hb_ping = hb;
			next_ping += ping_every;
			if (next_ping <= now)
				next_ping = now + ping_every;
		}
		if (now >= next_status) {
			uint64_t hb = rmd_loop_heartbeat(d->loop);
			double secs = (double)(now - t_status) / 1e9;
			char status[256];

			look(&lv, d, now);
			rmdd_stats_status(&d->stats, secs > 0 ? (double)(hb - hb_status) / secs : 0,
					  lv.stalled, status, sizeof(status));
			rmdd_notify_status(&d->notify, status);
			tool_log(7, "status: %s", status);
			hb_status = hb;
			t_status = now;
			next_status += STATUS_PERIOD_NS;
			if (next_status <= now)
				next_status = now + STATUS_PERIOD_NS;
		}
	}
}

/* ---- the daemon ---------------------------------------------------------------- */

static int run(const struct rmdd_opts *o)
{
	struct rmdd *d = calloc(1, sizeof(*d));
	struct rmd_bridge_opts bo;
	struct rmd_loop_opts lo;
	char err[512], status[256], note[512];
	int r, ret = RMDD_EXIT_FAIL;

	if (!d) {
		tool_log(3, "out of memory");
		return RMDD_EXIT_FAIL;
	}
	d->sfd = -1;
	d->snapshot_fd = -1;
	ret = load(d, o);
	if (ret != RMDD_EXIT_OK)
		goto err_free;
	ret = RMDD_EXIT_FAIL;
	r = signals_open(d);
	if (r < 0) {
		tool_log(3, "signalfd: %s", strerror(-r));
		goto err_free;
	}
	rmdd_notify_init(&d->notify);
	if (rmdd_buses_open(&d->cfg, &d->sim, &d->plan, d->buses) < 0)
		goto err_close_signals;
	r = handovers_init(d);
	if (r < 0) {
		tool_log(3, "hand-over buffers: %s", strerror(-r));
		goto err_free_handovers;
	}

	r = rmdd_incidents_init(&d->inc, &d->cfg, &d->plan, err, sizeof(err));
	if (r < 0) {
		tool_log(3, "%s", err);
		goto err_free_handovers;
	}
	lo = (struct rmd_loop_opts){
		.cfg = &d->cfg,
		.plan = &d->plan,
		.buses = d->buses,
		.commands = &d->commands,
		.homes = &d->homes,
		.snapshots = &d->snapshots,
		.health = &d->health,
		.events = &d->events,
		.incidents = d->inc.ring,
		.snapshot_fd = d->snapshot_fd,
		.require_rt = o->require_rt,
	};
	d->loop = rmd_loop_new(&lo, err, sizeof(err));
	if (!d->loop) {
		tool_log(3, "%s", err);
		goto err_free_handovers;
	}
	r = rmdd_monitor_init(&d->mon, &d->cfg, d->loop, &d->events);
	if (r < 0) {
		tool_log(3, "monitor: %s", strerror(-r));
		goto err_free_loop;
	}
	if (d->inc.ring)
		d->mon.incidents = &d->inc;
	d->stats = (struct rmdd_stats_src){
		.cfg = &d->cfg,
		.plan = &d->plan,
		.loop = d->loop,
		.mon = &d->mon,
		.events = &d->events,
	};
	/*
	 * Everything slow comes before bring-up, which ends with the 0xB3
	 * writes: from then on every motor counts its comm-loss time, and the
	 * first cycle must follow at once.
	 */
	r = rmd_loop_lock_memory(d->loop);
	if (r < 0) {
		tool_log(3,
			 "--require-rt: mlockall refused (%s): run as root, as a user with "
			 "memlock unlimited in /etc/security/limits.d/ (docs/troubleshooting.md "
			 "\"Real-time limits\"), or with LimitMEMLOCK=infinity "
			 "(systemd/rmdd.service)",
			 strerror(-r));
		goto err_fini_monitor;
	}
	/* before LCM: a thread it may create must not inherit a real-time policy */
	main_thread_normal(d);
	rmdd_lcm_opts(&bo, &d->cfg, &d->plan, d->loop, &d->commands, &d->snapshots, &d->health);
	bo.homes = &d->homes;
	bo.notify_fd = d->snapshot_fd;
	rmdd_lcm_incidents(&bo, d->inc.ring ? &d->inc : NULL);
	r = rmd_bridge_new(&d->bridge, &bo, err, sizeof(err));
	if (r < 0) {
		tool_log(3, "LCM: %s; --lcm-url memq:// runs without LCM traffic", err);
		goto err_fini_monitor;
	}
	d->stats.bridge = d->bridge;
	/* before bring-up: another daemon here would answer our controllers too */
	if (rmdd_lcm_alone(d->bridge, o->force) < 0)
		goto err_free_bridge;
	r = rmd_bridge_start(d->bridge);
	if (r < 0) {
		tool_log(3, "LCM bridge thread: %s", strerror(-r));
		goto err_free_bridge;
	}
	rmdd_lcm_started(d->bridge);
	if (bringup(d) != RMDD_EXIT_OK)
		goto err_stop_bridge;

	d->stats.start_ns = rmd_now_ns();
	r = rmd_loop_start(d->loop);
	if (r == -EPERM && o->require_rt) {
		tool_log(3,
			 "--require-rt: SCHED_FIFO priority %u or mlockall refused (%s): run as "
			 "root, as a user with rtprio 49 and memlock unlimited in "
			 "/etc/security/limits.d/ (docs/troubleshooting.md \"Real-time "
			 "limits\"), or with LimitRTPRIO=49 and LimitMEMLOCK=infinity "
			 "(systemd/rmdd.service)",
			 d->cfg.loop.rt_priority, strerror(-r));
		goto err_stop_bridge;
	}
	if (r < 0) {
		tool_log(3, "rt loop thread: %s", strerror(-r));
		goto err_stop_bridge;
	}
	r = rmdd_monitor_start(&d->mon);
	if (r < 0) {
		tool_log(3, "monitor thread: %s", strerror(-r));
		goto err_stop_loop;
	}
	d->inc.bridge = d->bridge; /* each recording's LCM log starts with its config_t */
	r = rmdd_incidents_start(&d->inc);
	if (r < 0) {
		tool_log(3, "incident writer thread: %s", strerror(-r));
		goto err_stop_loop;
	}
	if (d->inc.ring)
		tool_log(6, "incidents: recorded to %s (%.1f s before, %.1f s after; %.1f MB held)",
			 d->inc.dir, d->cfg.incidents.seconds_before,
			 d->cfg.incidents.seconds_after,
			 (double)rmd_incident_ring_bytes(d->inc.ring) / 1e6);

	wait_first_cycle(d);
	/* A sim bus's fault windows count from its time 0 (fixed at bring-up): bench/soak.sh */
	for (unsigned b = 0; b < d->cfg.n_buses; b++) {
		int64_t zero_ns = rmd_bus_open_time_zero_ns(&d->buses[b], rmd_now_ns());

		if (zero_ns)
			tool_log(6, "bus %s: sim time 0 at %.6f s of CLOCK_MONOTONIC",
				 d->cfg.buses[b].name, (double)zero_ns / 1e9);
	}
	tool_log(5,
		 "running: %u motor(s) on %u bus(es) at %u Hz from %s; LCM %s, channels %s*; "
		 "SIGUSR1 prints statistics",
		 d->cfg.n_motors, d->cfg.n_buses, d->cfg.loop.rate_hz, d->cfg.source,
		 d->cfg.lcm.url, d->cfg.lcm.channel_prefix);
	rmdd_robot_note(&d->cfg, note, sizeof(note));
	if (note[0])
		tool_log(5, "%s", note);
	rmdd_stats_status(&d->stats, (double)d->plan.rate_hz, false, status, sizeof(status));
	rmdd_notify_ready(&d->notify, status);

	r = serve(d, o);
	if (r < 0)
		tool_log(3, "signalfd: %s; stopping", strerror(-r));
	else
		tool_log(5, "%s: stopping every motor", strsignal(r));
	rmdd_notify_stopping(&d->notify, "stopping every motor");
	ret = r < 0 ? RMDD_EXIT_FAIL : RMDD_EXIT_OK;

err_stop_loop:
	rmd_loop_request_stop(d->loop);
	r = rmd_loop_join(d->loop);
	if (r < 0)
		tool_log(3, "rt loop thread: join: %s", strerror(-r));
	if (ret == RMDD_EXIT_OK) {
		/* -q: only warnings and errors, so no statistics (SIGUSR1 still asks for them) */
		if (tool_log_enabled(TOOL_LOG_INFO))
			rmdd_stats_print(&d->stats, "exit");
		exit_line(d);
	}
err_stop_bridge:
	rmd_bridge_stop(d->bridge);
	rmdd_monitor_stop(&d->mon);
	/* after the monitor's last drain: its triggers are written now */
	rmdd_incidents_stop(&d->inc);
err_free_bridge:
	rmd_bridge_free(d->bridge);
err_fini_monitor:
	rmdd_monitor_fini(&d->mon);
err_free_loop:
	rmd_loop_free(d->loop);
err_free_handovers:
	rmdd_incidents_fini(&d->inc);
	handovers_free(d);
	rmdd_buses_close(d->buses, d->cfg.n_buses);
err_close_signals:
	if (d->sfd >= 0)
		close(d->sfd);
err_free:
	free(d);
	return ret;
}

int main(int argc, char **argv)
{
	struct rmdd_opts o;

	tool_log_init("rmdd", TOOL_LOG_INFO, 0);
	if (parse_args(argc, argv, &o)) {
		tool_usage_hint(USAGE_LINE, "rmdd --help");
		return RMDD_EXIT_USAGE;
	}
	switch (o.mode) {
	case MODE_HELP:
		usage(stdout);
		return RMDD_EXIT_OK;
	case MODE_VERSION:
		tool_print_version("rmdd");
		return RMDD_EXIT_OK;
	case MODE_COMPLETION:
		tool_completion_bash(stdout, "rmdd", opts, NOPTS, NULL, 0);
		return RMDD_EXIT_OK;
	case MODE_SCHEMA:
		if (rmd_config_schema_json(stdout)) {
			tool_log(3, "--schema: writing to standard output failed");
			return RMDD_EXIT_FAIL;
		}
		return RMDD_EXIT_OK;
	case MODE_CHECK:
		return check_config(o.config);
	case MODE_RUN:
	case MODE_SIM:
		break;
	}
	return run(&o);
}
