// SPDX-License-Identifier: MIT
/*
 * rmdctl: command-line tool for RMD motors (layer 7 of DESIGN.md).
 *
 *   rmdctl decode ...   candump text -> decoded quantities (rmdctl_decode.c)
 *   rmdctl encode ...   one command -> a frame in cansend syntax (rmdctl_encode.c)
 *
 * Subcommands are rows of `cmds` below: adding one is a new row and a
 * rmdctl_<name>.c file.  Exit statuses: 0 ok, 1 data or device errors, 2 usage.
 * Everything here is non-rt.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmdctl.h"

static const struct rmdctl_cmd cmds[] = {
	{ "decode", "print candump output as decoded quantities (text or JSON)", rmdctl_decode_run,
	  rmdctl_decode_usage },
	{ "encode", "print one command as a frame in cansend syntax", rmdctl_encode_run,
	  rmdctl_encode_usage },
	{ "scan", "list the motors that answer on a bus", rmdctl_dev_run, rmdctl_scan_usage },
	{ "info", "model, firmware, runtime, acceleration, gains, mode of a motor", rmdctl_dev_run,
	  rmdctl_info_usage },
	{ "status", "temperature, voltage, errors, angle, speed, current of a motor",
	  rmdctl_dev_run, rmdctl_status_usage },
	{ "monitor", "live status table of the motors on a bus", rmdctl_dev_run,
	  rmdctl_monitor_usage },
	{ "set-id", "renumber a motor (ROM)", rmdctl_dev_run, rmdctl_set_id_usage },
	{ "set-zero", "make the current position the zero (ROM)", rmdctl_dev_run,
	  rmdctl_set_zero_usage },
	{ "set-timeout", "set the comm-loss protection time (ROM)", rmdctl_dev_run,
	  rmdctl_set_timeout_usage },
	{ "accel", "read or write acceleration", rmdctl_dev_run, rmdctl_accel_usage },
	{ "pid", "read or write PI gains", rmdctl_dev_run, rmdctl_pid_usage },
	{ "brake", "lock or release the brake", rmdctl_dev_run, rmdctl_brake_usage },
	{ "stop", "stop and hold position", rmdctl_dev_run, rmdctl_stop_usage },
	{ "off", "turn the output off", rmdctl_dev_run, rmdctl_off_usage },
	{ "reset", "reset a motor and wait for it", rmdctl_dev_run, rmdctl_reset_usage },
	{ "move", "small, slow absolute move, waiting for arrival", rmdctl_dev_run,
	  rmdctl_move_usage },
};
#define NCMDS (sizeof(cmds) / sizeof(cmds[0]))

int rmdctl_parse_double(const char *s, double *v)
{
	char *end;

	errno = 0;
	*v = strtod(s, &end);
	if (end == s || *end != '\0' || errno == ERANGE || !isfinite(*v))
		return -EINVAL;
	return 0;
}

static void usage(FILE *f)
{
	fprintf(f, "usage: rmdctl COMMAND [ARGS...]\n"
		   "       rmdctl help [COMMAND]\n"
		   "\n"
		   "Tool for MyActuator RMD servo motors (protocols V2, V3 and MIT mode).\n"
		   "\n"
		   "commands:\n");
	for (size_t i = 0; i < NCMDS; i++)
		fprintf(f, "  %-12s %s\n", cmds[i].name, cmds[i].summary);
	fprintf(f, "\n"
		   "`rmdctl COMMAND --help` describes one command.\n"
		   "\n"
		   "exit status: 0 ok; 1 data or device errors (bad input lines, I/O, values\n"
		   "the codec refuses, a motor or bus that failed); 2 usage errors, and\n"
		   "refused confirmations or safety limits.\n");
}

static char log_name[32];

static const struct rmdctl_cmd *find_cmd(const char *name)
{
	for (size_t i = 0; i < NCMDS; i++)
		if (!strcmp(cmds[i].name, name))
			return &cmds[i];
	return NULL;
}

static bool is_help(const char *s)
{
	return !strcmp(s, "-h") || !strcmp(s, "--help") || !strcmp(s, "help");
}

int main(int argc, char **argv)
{
	const struct rmdctl_cmd *cmd;

	if (argc < 2) {
		usage(stderr);
		return RMDCTL_EXIT_USAGE;
	}
	if (is_help(argv[1])) {
		if (argc == 2) {
			usage(stdout);
			return RMDCTL_EXIT_OK;
		}
		cmd = find_cmd(argv[2]);
		if (!cmd || argc > 3) {
			fprintf(stderr, "rmdctl: no help for \"%s\"\n", argv[2]);
			usage(stderr);
			return RMDCTL_EXIT_USAGE;
		}
		cmd->usage(stdout);
		return RMDCTL_EXIT_OK;
	}
	cmd = find_cmd(argv[1]);
	if (!cmd) {
		fprintf(stderr, "rmdctl: unknown command \"%s\"\n", argv[1]);
		usage(stderr);
		return RMDCTL_EXIT_USAGE;
	}
	/* Messages read "rmdctl scan: ...". */
	snprintf(log_name, sizeof(log_name), "rmdctl %s", cmd->name);
	tool_log_init(log_name, TOOL_LOG_DEBUG, TOOL_LOG_NO_LEVEL);
	return cmd->run(argc - 1, argv + 1);
}
