// SPDX-License-Identifier: MIT
/*
 * rmd-sim: simulated RMD motors on a real wire (docs/design.md, layer tools, the
 * `rmd-sim` tool of layer 3's simulator).
 *
 *   rmd-sim [options] --can IFACE
 *   rmd-sim [options] --serial DEVICE [--baud B]
 *   rmd-sim [options] --config rmdd.yaml [--bus NAME]
 *
 * The motors are struct rmd_sim_motor (src/sim/sim_motor.c); this program
 * feeds them the frames that arrive on a SocketCAN interface or an RS485
 * line and writes their replies after their turnaround.  The command line
 * (here), the config files (config.c: an rmdd.yaml through rmdd's loader,
 * or rmd-sim's KEY = VALUE format) and the event loop (wire.c) are
 * described in docs/rmd-sim.md; -v describes frames with rmd/describe.h and
 * every line goes through the programs' one logger (tools/common/log.h).
 *
 * Exit statuses: 0 stopped by SIGINT/SIGTERM, 1 the wire failed, 2 a bad
 * argument or configuration value.  Non-rt.
 */
#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "tools/common/cli.h"
#include "rmd-sim.h"

/* The program's own options: rows 0..NPROG-1 of the option table. */
static const struct tool_opt prog_opts[] = {
	{ .name = "config",
	  .has_arg = required_argument,
	  .arg = "FILE",
	  .help = "an rmdd.yaml (FILE.yaml, .yml): simulate the motors\n"
		  "of one of its socketcan or rs485 buses, as its sim:\n"
		  "sections say; every other option overrides it.\n"
		  "Other FILE: KEY = VALUE lines, [motor N] sections,\n"
		  "read here; later options override its global values",
	  .value = TOOL_VAL_FILE },
	TOOL_OPT_ARG("bus", "NAME",
		     "the rmdd.yaml's bus to simulate (default: the one on\n"
		     "the wire of --can or --serial, else its only one)"),
	TOOL_OPT_ARG("set", "[ID:]KEY=VALUE", "a motor parameter, for motor ID or every motor"),
	TOOL_OPT_VERBOSE("also log every frame, decoded"),
	TOOL_OPT_QUIET("log errors and warnings only"),
	TOOL_OPT_HELP,
	TOOL_OPT_VERSION("print \"rmd-sim VERSION\" and exit (the simulated\n"
			 "firmware date is --version-date)"),
	TOOL_OPT_COMPLETION,
};
#define NPROG (sizeof(prog_opts) / sizeof(prog_opts[0]))

static void usage(void)
{
	printf("Usage: rmd-sim [options] --can IFACE\n"
	       "       rmd-sim [options] --serial DEVICE [--baud B]\n"
	       "       rmd-sim [options] --config rmdd.yaml [--bus NAME]\n"
	       "\n"
	       "Simulated MyActuator RMD motors (V3, V2 or MIT protocol) answering on a\n"
	       "SocketCAN interface or an RS485 line.  Stops on SIGINT or SIGTERM, once the\n"
	       "requests that came before it are answered (replies due within 250 ms).\n"
	       "\n"
	       "One file describes a bus for rmdd and rmd-sim: given rmdd's configuration,\n"
	       "rmd-sim answers on the interface or device of one of its socketcan or rs485\n"
	       "buses as that bus's motors (ids and protocols from motors[]), with the models\n"
	       "of the bus's sim: section and the motors' own (motors[].sim), its sim.seed\n"
	       "and sim.faults.  rmdd does not simulate such a bus: it talks to the wire.\n"
	       "\n");
	tool_opts_help(stdout, prog_opts, NPROG);
	printf("\n");
	sim_config_help();
	printf("\n"
	       "FAULTS (--fault, repeatable; ID 1..32 or * for every motor; P 0..1):\n"
	       "  drop:ID:P                 the motor's frames are lost\n"
	       "  delay:ID:US:P             ... sent US microseconds late\n"
	       "  bad_dlc:ID:DLC:P          ... sent with DLC 0..7 (RS485: that length byte)\n"
	       "  garbage:ID:P              ... with random data bytes\n"
	       "  wrong_id:ID:OTHER:P       ... on motor OTHER's identifier\n"
	       "    each of these takes an optional window @START_S-END_S\n"
	       "  disappear:ID:START_S:END_S[:reboot]  deaf and mute (END_S empty: for good);\n"
	       "                            reboot: it lost power and boots at END_S\n"
	       "  error_flag:ID:BITS:AT_S[:END_S]  error flags (0x0004, or low_voltage+over_temp...)\n"
	       "  flood:CANID:PERIOD_US:START_S[:END_S]  a foreign node's frames (CAN only)\n"
	       "  bus_power:START_S:END_S   every motor loses power (an e-stop) and boots at END_S\n"
	       "Times count from rmd-sim's start.  The kinds are those of rmdd.yaml's sim faults\n"
	       "(US, PERIOD_US there: delay_us, period_us); older spellings stay aliases: error,\n"
	       "bad-dlc, wrong-id, any case.\n"
	       "\n"
	       "Exit status: 0 stopped by a signal, 1 the wire failed, 2 bad arguments.\n"
	       "See docs/rmd-sim.md.\n");
}

enum { OPT_CONFIG = TOOL_OPT_BASE, OPT_BUS, OPT_SET, OPT_COMPLETION = TOOL_OPT_BASE + NPROG - 1 };

#define MAX_OPTS 160
#define USAGE_LINE "rmd-sim [options] --can IFACE | --serial DEVICE [--baud B] | --config rmdd.yaml"

/* What completion offers for the value of setting key. */
static void key_value(struct tool_opt *o, const char *key)
{
	static const struct {
		const char *key;
		enum tool_value value;
		const char *words;
	} kinds[] = {
		{ "can", TOOL_VAL_CAN, NULL },
		{ "serial", TOOL_VAL_SERIAL, NULL },
		{ "baud", TOOL_VAL_WORDS, "115200 500000 1000000 1500000 2000000" },
		{ "verbosity", TOOL_VAL_WORDS, "quiet normal frames" },
		{ "protocol", TOOL_VAL_PROTO, NULL },
	};

	for (size_t k = 0; k < sizeof(kinds) / sizeof(kinds[0]); k++)
		if (!strcmp(kinds[k].key, key)) {
			o->value = kinds[k].value;
			o->words = kinds[k].words;
		}
}

/*
 * The option table: the program's options, then every setting by each of
 * its names (config.c), except a name the program's options take
 * ("version", the old spelling of version_date).  keyidx[] maps a row to
 * its setting.  Returns the row count.
 */
static size_t build_opts(struct tool_opt *o, unsigned *keyidx)
{
	size_t n = NPROG;
	const char *key;
	bool flag;

	memcpy(o, prog_opts, sizeof(prog_opts));
	for (unsigned i = 0; (key = sim_config_key(i, &flag)) && n < MAX_OPTS; i++) {
		bool taken = false;

		for (size_t k = 0; k < NPROG; k++)
			taken |= !strcmp(prog_opts[k].name, key);
		if (!*key || taken)
			continue;
		keyidx[n] = i;
		o[n] = (struct tool_opt){
			.name = key,
			.has_arg = flag ? no_argument : required_argument,
			.help = sim_config_key_listed(i) ? "" : NULL,
		};
		key_value(&o[n], key);
		n++;
	}
	return n;
}

/*
 * An rmdd.yaml given with --config is read before the other options, so
 * that every one of them overrides it wherever it stands: a first pass
 * finds it, --bus, and the wire named by the last --can or --serial (the
 * bus to pick).  The second pass reports what is wrong.  Returns 0 or an
 * exit status.
 */
static int read_yaml(struct sim_config *cfg, int argc, char **argv, const char *shorts,
		     const struct option *opts, const unsigned *keyidx, size_t n)
{
	const char *yaml = NULL, *bus = NULL, *wire = NULL, *key;
	bool flag, now = true;

	for (;;) {
		int c = getopt_long(argc, argv, shorts, opts, NULL);

		if (c == -1)
			break;
		if (c == 'h' || c == 'V' || c == OPT_COMPLETION)
			now = false; /* the second pass answers them */
		else if (c == OPT_CONFIG && sim_config_is_yaml(optarg) && yaml &&
			 strcmp(yaml, optarg)) {
			tool_log(TOOL_LOG_ERR,
				 "rmd-sim: --config %s: one rmdd.yaml only (already %s); "
				 "choose its bus with --bus",
				 optarg, yaml);
			return SIM_EXIT_USAGE;
		} else if (c == OPT_CONFIG && sim_config_is_yaml(optarg))
			yaml = optarg;
		else if (c == OPT_BUS)
			bus = optarg;
		else if (c >= TOOL_OPT_BASE + (int)NPROG && c < TOOL_OPT_BASE + (int)n &&
			 (key = sim_config_key(keyidx[c - TOOL_OPT_BASE], &flag)) &&
			 (!strcmp(key, "can") || !strcmp(key, "serial")))
			wire = optarg;
	}
	optind = 0; /* glibc: start the second pass afresh */
	if (bus && !yaml) {
		tool_log(TOOL_LOG_ERR,
			 "rmd-sim: --bus %s: names a bus of an rmdd.yaml given with --config "
			 "FILE.yaml",
			 bus);
		return SIM_EXIT_USAGE;
	}
	if (yaml && now && sim_config_yaml(cfg, yaml, bus, wire) < 0)
		return SIM_EXIT_USAGE;
	return 0;
}

int main(int argc, char **argv)
{
	static struct sim_config cfg;
	static struct tool_opt table[MAX_OPTS];
	static struct option opts[MAX_OPTS + 1];
	static unsigned keyidx[MAX_OPTS];
	char shorts[32], msg[200];
	size_t n;
	bool flag;
	const char *key;
	int r;

	tool_log_init(NULL, SIM_NORMAL, 0);
	sim_config_init(&cfg);
	n = build_opts(table, keyidx);
	tool_opts_getopt(table, n, opts, shorts, sizeof(shorts));

	opterr = 0;
	r = read_yaml(&cfg, argc, argv, shorts, opts, keyidx, n);
	if (r)
		return r;
	for (;;) {
		int c = getopt_long(argc, argv, shorts, opts, NULL);
		char where[64];

		if (c == -1)
			break;
		switch (c) {
		case 'v':
			cfg.verbosity = SIM_FRAMES;
			tool_log_set_level((int)cfg.verbosity);
			break;
		case 'q':
			cfg.verbosity = SIM_QUIET;
			tool_log_set_level((int)cfg.verbosity);
			break;
		case 'h':
			usage();
			return SIM_EXIT_OK;
		case 'V':
			tool_print_version("rmd-sim");
			return SIM_EXIT_OK;
		case OPT_COMPLETION:
			if (strcmp(optarg, "bash")) {
				tool_log(TOOL_LOG_ERR, "rmd-sim: --completion %s: only bash",
					 optarg);
				return SIM_EXIT_USAGE;
			}
			tool_completion_bash(stdout, "rmd-sim", table, n, NULL, 0);
			return SIM_EXIT_OK;
		case OPT_CONFIG:
			/* an rmdd.yaml is read already (read_yaml()) */
			if (!sim_config_is_yaml(optarg) && sim_config_file(&cfg, optarg) < 0)
				return SIM_EXIT_USAGE;
			break;
		case OPT_BUS:
			break;
		case OPT_SET:
			if (sim_config_set_arg(&cfg, optarg, "--set") < 0)
				return SIM_EXIT_USAGE;
			break;
		case ':':
		case '?':
			tool_log(TOOL_LOG_ERR, "rmd-sim: %s (rmd-sim --help lists the options)",
				 tool_getopt_error(msg, sizeof(msg), c, argv, table, n));
			tool_usage_hint(USAGE_LINE, "rmd-sim --help");
			return SIM_EXIT_USAGE;
		default:
			if (c < TOOL_OPT_BASE + (int)NPROG || c >= TOOL_OPT_BASE + (int)n ||
			    !(key = sim_config_key(keyidx[c - TOOL_OPT_BASE], &flag)))
				return SIM_EXIT_USAGE;
			snprintf(where, sizeof(where), "--%s", key);
			if (sim_config_set(&cfg, 0, key, flag ? "yes" : optarg, where) < 0)
				return SIM_EXIT_USAGE;
			break;
		}
	}
	if (optind < argc) {
		tool_log(TOOL_LOG_ERR,
			 "rmd-sim: unexpected argument \"%s\" (options take the form "
			 "--name VALUE; rmd-sim --help)",
			 argv[optind]);
		tool_usage_hint(USAGE_LINE, "rmd-sim --help");
		return SIM_EXIT_USAGE;
	}
	if (sim_config_finish(&cfg) < 0)
		return SIM_EXIT_USAGE;
	return sim_run(&cfg);
}
