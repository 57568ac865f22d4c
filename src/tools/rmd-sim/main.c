// SPDX-License-Identifier: MIT
/*
 * rmd-sim: simulated RMD motors on a real wire (docs/design.md, layer tools, the
 * `rmd-sim` tool of layer 3's simulator).
 *
 *   rmd-sim [options] --can IFACE
 *   rmd-sim [options] --serial DEVICE [--baud B]
 *
 * The motors are struct rmd_sim_motor (src/sim/sim_motor.c); this program
 * feeds them the frames that arrive on a SocketCAN interface or an RS485
 * line and writes their replies after their turnaround.  The command line
 * (here), the config file (config.c) and the event loop (wire.c) are
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

#include "rmd-sim.h"

static void usage(void)
{
	printf("Usage: rmd-sim [options] --can IFACE\n"
	       "       rmd-sim [options] --serial DEVICE [--baud B]\n"
	       "\n"
	       "Simulated MyActuator RMD motors (V3, V2 or MIT protocol) answering on a\n"
	       "SocketCAN interface or an RS485 line.  Stops on SIGINT or SIGTERM.\n"
	       "\n"
	       "  --config FILE       read settings from FILE (KEY = VALUE lines, [motor N]\n"
	       "                      sections); later options override its global values\n"
	       "  --set [ID:]KEY=VALUE  a motor parameter, for motor ID or every motor\n"
	       "  -v, --verbose       also log every frame, decoded\n"
	       "  -q, --quiet         log errors and warnings only\n"
	       "  -h, --help          this text\n"
	       "\n");
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
	       "Times count from rmd-sim's start.  The kinds are those of rmdd.yaml's sim faults\n"
	       "(US, PERIOD_US there: delay_us, period_us); older spellings stay aliases: error,\n"
	       "bad-dlc, wrong-id, any case.\n"
	       "\n"
	       "Exit status: 0 stopped by a signal, 1 the wire failed, 2 bad arguments.\n"
	       "See docs/rmd-sim.md.\n");
}

enum {
	OPT_CONFIG = 0x100,
	OPT_SET,
	OPT_KEY = 0x200, /* + index of sim_config_key() */
};

#define MAX_OPTS 128

int main(int argc, char **argv)
{
	static struct sim_config cfg;
	static struct option opts[MAX_OPTS];
	unsigned n = 0;
	bool flag;
	const char *key;

	tool_log_init(NULL, SIM_NORMAL, 0);
	sim_config_init(&cfg);
	opts[n++] = (struct option){ "config", required_argument, NULL, OPT_CONFIG };
	opts[n++] = (struct option){ "set", required_argument, NULL, OPT_SET };
	opts[n++] = (struct option){ "verbose", no_argument, NULL, 'v' };
	opts[n++] = (struct option){ "quiet", no_argument, NULL, 'q' };
	opts[n++] = (struct option){ "help", no_argument, NULL, 'h' };
	for (unsigned i = 0; (key = sim_config_key(i, &flag)) && n < MAX_OPTS - 1; i++)
		if (*key)
			opts[n++] = (struct option){ key, flag ? no_argument : required_argument,
						     NULL, OPT_KEY + (int)i };
	opts[n] = (struct option){ NULL, 0, NULL, 0 };

	opterr = 0;
	for (;;) {
		int longidx = -1, c = getopt_long(argc, argv, ":vqh", opts, &longidx);
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
		case OPT_CONFIG:
			if (sim_config_file(&cfg, optarg) < 0)
				return SIM_EXIT_USAGE;
			break;
		case OPT_SET:
			if (sim_config_set_arg(&cfg, optarg, "--set") < 0)
				return SIM_EXIT_USAGE;
			break;
		case ':':
			tool_log(TOOL_LOG_ERR, "rmd-sim: %s needs a value (rmd-sim --help)",
				 argv[optind - 1]);
			return SIM_EXIT_USAGE;
		case '?':
			if (optopt)
				tool_log(TOOL_LOG_ERR,
					 "rmd-sim: unknown option \"-%c\" (rmd-sim --help "
					 "lists the options)",
					 optopt);
			else
				tool_log(TOOL_LOG_ERR,
					 "rmd-sim: unknown option \"%s\" (rmd-sim --help "
					 "lists the options)",
					 argv[optind - 1]);
			return SIM_EXIT_USAGE;
		default:
			if (c < OPT_KEY || !(key = sim_config_key((unsigned)(c - OPT_KEY), &flag)))
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
		return SIM_EXIT_USAGE;
	}
	if (sim_config_finish(&cfg) < 0)
		return SIM_EXIT_USAGE;
	return sim_run(&cfg);
}
