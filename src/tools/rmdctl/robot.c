// SPDX-License-Identifier: MIT
/*
 * rmdctl stop --robot: one rmd.robot_stop_t on RMD_ROBOT_STOP, which every
 * rmdd of the robot (those with a robot.instance) takes as a robot-wide
 * safe action (docs/robot.md).  Fire and forget: LCM has no delivery
 * receipt, so it is sent three times 10 ms apart (each stop after the
 * first finds the motors SAFE already and changes nothing); each daemon's
 * health_t robot_stops says it was taken.
 */
#include <getopt.h>
#include <lcm/lcm.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "rmd/channels.h"
#include "rmd/config.h"
#include "rmd/rmd_robot_stop_t.h"
#include "rmd/time.h"
#include "rmdctl.h"

#define SENDS 3

enum { OPT_ROBOT, OPT_URL, OPT_REASON, OPT_HELP };

const struct tool_opt rmdctl_robot_stop_opts[] = {
	{ .name = "robot",
	  .help = "stop every rmdd of the robot (robot_stop_t on " RMD_CHANNEL_ROBOT_STOP ")" },
	{ .name = "lcm-url",
	  .has_arg = required_argument,
	  .arg = "URL",
	  .help = "the robot's LCM URL (default $LCM_DEFAULT_URL, else\n" RMD_CONFIG_DEFAULT_LCM_URL
		  ")" },
	TOOL_OPT_ARG("reason", "TEXT", "why, for every daemon's journal (default \"operator\")"),
	TOOL_OPT_HELP,
};
const size_t rmdctl_n_robot_stop_opts =
	sizeof(rmdctl_robot_stop_opts) / sizeof(rmdctl_robot_stop_opts[0]);

void rmdctl_robot_stop_usage(FILE *f)
{
	fprintf(f, "usage: rmdctl stop --robot [--lcm-url URL] [--reason TEXT]\n"
		   "\n"
		   "Stops the whole robot: publishes rmd.robot_stop_t on " RMD_CHANNEL_ROBOT_STOP
		   ", and every\n"
		   "rmdd with a robot.instance gives each driven motor its safe action, as its\n"
		   "command watchdog does, and says why in its journal and health_t.  Enabling\n"
		   "again is each controller's enable (enable = 0, then 1).  docs/robot.md.\n"
		   "\n");
	tool_opts_help(f, rmdctl_robot_stop_opts, rmdctl_n_robot_stop_opts);
	fprintf(f, "\nexit status: 0 sent; 1 LCM failed; 2 usage error.\n");
}

bool rmdctl_is_robot_stop(int argc, char **argv)
{
	for (int i = 1; i < argc; i++)
		if (!strcmp(argv[i], "--robot"))
			return true;
	return false;
}

int rmdctl_robot_stop_run(int argc, char **argv)
{
	struct option
		longopts[sizeof(rmdctl_robot_stop_opts) / sizeof(rmdctl_robot_stop_opts[0]) + 1];
	const char *env = getenv("LCM_DEFAULT_URL");
	const char *url = env && *env ? env : RMD_CONFIG_DEFAULT_LCM_URL, *reason = "operator";
	char shorts[16], msg[160], host[64] = "?", who[96];
	struct timespec ts;
	rmd_robot_stop_t s;
	lcm_t *lcm;
	int c, failed = 0;

	tool_opts_getopt(rmdctl_robot_stop_opts, rmdctl_n_robot_stop_opts, longopts, shorts,
			 sizeof(shorts));
	optind = 0;
	opterr = 0;
	while ((c = getopt_long(argc, argv, shorts, longopts, NULL)) != -1) {
		switch (c) {
		case TOOL_OPT_BASE + OPT_ROBOT:
			break;
		case TOOL_OPT_BASE + OPT_URL:
			url = optarg;
			break;
		case TOOL_OPT_BASE + OPT_REASON:
			reason = optarg;
			break;
		case 'h':
			rmdctl_robot_stop_usage(stdout);
			return RMDCTL_EXIT_OK;
		default:
			tool_log(TOOL_LOG_ERR, "%s",
				 tool_getopt_error(msg, sizeof(msg), c, argv,
						   rmdctl_robot_stop_opts,
						   rmdctl_n_robot_stop_opts));
			rmdctl_usage_hint_name("stop");
			return RMDCTL_EXIT_USAGE;
		}
	}
	if (optind < argc) {
		tool_log(TOOL_LOG_ERR, "stop --robot takes no motor id (\"%s\"): it stops them all",
			 argv[optind]);
		return RMDCTL_EXIT_USAGE;
	}
	lcm = lcm_create(url);
	if (!lcm) {
		tool_log(TOOL_LOG_ERR,
			 "LCM: cannot open %s (docs/lcm.md: a robot PC without a network)", url);
		return RMDCTL_EXIT_DATA;
	}
	if (gethostname(host, sizeof(host)) < 0)
		snprintf(host, sizeof(host), "?");
	host[sizeof(host) - 1] = '\0';
	snprintf(who, sizeof(who), "rmdctl@%s pid %d", host, (int)getpid());
	s = (rmd_robot_stop_t){ .who = who, .reason = (char *)reason };
	for (int k = 0; k < SENDS; k++) {
		struct timespec gap = { .tv_nsec = 10 * RMD_NS_PER_MS };

		clock_gettime(CLOCK_REALTIME, &ts);
		s.t_ns = rmd_timespec_ns(&ts);
		failed += rmd_robot_stop_t_publish(lcm, RMD_CHANNEL_ROBOT_STOP, &s) != 0;
		if (k + 1 < SENDS)
			nanosleep(&gap, NULL);
	}
	lcm_destroy(lcm);
	if (failed == SENDS) {
		tool_log(TOOL_LOG_ERR, "LCM %s: could not publish on %s", url,
			 RMD_CHANNEL_ROBOT_STOP);
		return RMDCTL_EXIT_DATA;
	}
	printf("robot stop sent on %s (%s): %s\n", RMD_CHANNEL_ROBOT_STOP, url, reason);
	return RMDCTL_EXIT_OK;
}
