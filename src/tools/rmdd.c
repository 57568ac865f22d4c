// SPDX-License-Identifier: MIT
/*
 * rmdd: the real-time daemon for RMD motors (DESIGN.md layer 7).
 *
 *   rmdd --check-config FILE   load FILE, plan every bus, print the plan;
 *                              exit 0 when it fits, 1 with the errors
 *   rmdd [--config FILE] [--require-rt]   run the daemon (FILE defaults
 *                              to RMDD_DEFAULT_CONFIG)
 *   rmdd --sim [--require-rt]  run on built-in simulated motors
 *
 * main() parses the options into struct rmdd_opts and runs one mode.
 * Exit statuses: 0 ok, 1 failure, 2 usage.  Non-rt.
 */
#include <errno.h>
#include <getopt.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/config.h"
#include "rmd/plan.h"

#ifndef RMD_VERSION
#define RMD_VERSION "0.1.0"
#endif
#ifndef RMDD_DEFAULT_CONFIG
#define RMDD_DEFAULT_CONFIG "/etc/rmdd/rmdd.yaml"
#endif

#define ERR_LEN 8192 /* config and plan messages */

enum rmdd_mode {
	MODE_RUN = 0, /* the daemon, from a config file */
	MODE_SIM,     /* the daemon, on rmd_config_sim_default() */
	MODE_CHECK,   /* --check-config */
	MODE_HELP,
	MODE_VERSION,
};

struct rmdd_opts {
	enum rmdd_mode mode;
	const char *config; /* --config or --check-config FILE */
	bool require_rt;    /* refuse to run without SCHED_FIFO and mlockall */
};

static void usage(FILE *out)
{
	fprintf(out,
		"usage: rmdd [--config FILE] [--require-rt]\n"
		"       rmdd --sim [--require-rt]\n"
		"       rmdd --check-config FILE\n"
		"\n"
		"Drives MyActuator RMD motors on CAN buses and RS485 lines at up to 1 kHz\n"
		"and serves them over LCM.\n"
		"\n"
		"  -c, --config FILE        configuration (default %s)\n"
		"  -C, --check-config FILE  check FILE and print each bus's plan and budget;\n"
		"                           exit 0 when every bus fits, 1 otherwise\n"
		"  -s, --sim                run on built-in simulated motors\n"
		"  -r, --require-rt         exit unless SCHED_FIFO and mlockall are granted\n"
		"  -h, --help               this text\n"
		"  -V, --version            version\n",
		RMDD_DEFAULT_CONFIG);
}

/* Fill o from the command line.  Returns 0, or -EINVAL after a message. */
static int parse_args(int argc, char **argv, struct rmdd_opts *o)
{
	static const struct option longopts[] = {
		{ "config", required_argument, NULL, 'c' },
		{ "check-config", required_argument, NULL, 'C' },
		{ "sim", no_argument, NULL, 's' },
		{ "require-rt", no_argument, NULL, 'r' },
		{ "help", no_argument, NULL, 'h' },
		{ "version", no_argument, NULL, 'V' },
		{ NULL, 0, NULL, 0 },
	};
	bool sim = false, check = false;
	int c;

	memset(o, 0, sizeof(*o));
	o->config = RMDD_DEFAULT_CONFIG;
	while ((c = getopt_long(argc, argv, "c:C:srhV", longopts, NULL)) != -1) {
		switch (c) {
		case 'c':
			o->config = optarg;
			break;
		case 'C':
			o->config = optarg;
			check = true;
			break;
		case 's':
			sim = true;
			break;
		case 'r':
			o->require_rt = true;
			break;
		case 'h':
			o->mode = MODE_HELP;
			return 0;
		case 'V':
			o->mode = MODE_VERSION;
			return 0;
		default:
			usage(stderr);
			return -EINVAL;
		}
	}
	if (optind < argc) {
		fprintf(stderr, "rmdd: unexpected argument \"%s\"\n", argv[optind]);
		usage(stderr);
		return -EINVAL;
	}
	if (sim && check) {
		fprintf(stderr, "rmdd: --sim and --check-config exclude each other\n");
		return -EINVAL;
	}
	o->mode = check ? MODE_CHECK : sim ? MODE_SIM : MODE_RUN;
	return 0;
}

/* --check-config: exit status 0 when every bus fits. */
static int check_config(const char *path)
{
	static struct rmd_config cfg; /* large: off the stack */
	static struct rmd_plan plan;
	char err[ERR_LEN];
	int r;

	r = rmd_config_load(path, &cfg, err, sizeof(err));
	if (r) {
		fprintf(stderr, "%s\n", err);
		return 1;
	}
	r = rmd_plan_build(&cfg, &plan, err, sizeof(err));
	rmd_plan_print(&plan, &cfg, stdout);
	fflush(stdout);
	if (r) {
		fprintf(stderr, "%s\n", err);
		return 1;
	}
	return 0;
}

int main(int argc, char **argv)
{
	struct rmdd_opts o;

	if (parse_args(argc, argv, &o))
		return 2;
	switch (o.mode) {
	case MODE_HELP:
		usage(stdout);
		return 0;
	case MODE_VERSION:
		printf("rmdd %s\n", RMD_VERSION);
		return 0;
	case MODE_CHECK:
		return check_config(o.config);
	case MODE_RUN:
	case MODE_SIM:
		break;
	}
	fprintf(stderr, "rmdd: the real-time loop is not built yet\n");
	return 1;
}
