// SPDX-License-Identifier: MIT
/*
 * rmdctl stop --robot: one rmd.robot_stop_t on RMD_ROBOT_STOP, which every
 * rmdd of the robot (those with a robot.instance) takes as a robot-wide
 * safe action (docs/robot.md).  Fire and forget: LCM has no delivery
 * receipt, so it is sent three times 10 ms apart (each stop after the
 * first finds the motors SAFE already and changes nothing); each daemon's
 * health_t robot_stops says it was taken.  Then it listens to the robot's
 * heartbeats for --wait-ms and names every daemon it heard: tripped (it
 * took the stop, or was stopped already) or still running; a daemon that
 * kept running, or none heard, is exit 1: nothing confirmed the stop there.
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
#include "rmd/rmd_heartbeat_t.h"
#include "rmd/rmd_robot_stop_t.h"
#include "rmd/time.h"
#include "rmdctl.h"

#define SENDS 3
#define HEARD_MAX 64	    /* daemons listed; a robot has at most 17 that know each other */
#define WAIT_MS_DEFAULT 300 /* 30 heartbeats at the default 10 ms */
#define WAIT_MS_MAX 60000

enum { OPT_ROBOT, OPT_URL, OPT_REASON, OPT_WAIT, OPT_HELP };

/* A daemon heard on RMD_ROBOT_HEARTBEAT after the stop went out. */
struct heard {
	char instance[64], host[64], prefix[64], reason[160];
	int32_t pid;
	int8_t state; /* its newest heartbeat's */
};

/* The newest heartbeat of each daemon is judged (by arrival: their clocks are their own). */
struct listen {
	struct heard d[HEARD_MAX];
	unsigned n, dropped;
};

const struct tool_opt rmdctl_robot_stop_opts[] = {
	{ .name = "robot",
	  .help = "stop every rmdd of the robot (robot_stop_t on " RMD_CHANNEL_ROBOT_STOP ")" },
	{ .name = "lcm-url",
	  .has_arg = required_argument,
	  .arg = "URL",
	  .help = "the robot's LCM URL (default $LCM_DEFAULT_URL, else\n" RMD_CONFIG_DEFAULT_LCM_URL
		  ")" },
	TOOL_OPT_ARG("reason", "TEXT", "why, for every daemon's journal (default \"operator\")"),
	TOOL_OPT_ARG("wait-ms", "MS",
		     "listen this long for the daemons' heartbeats, to say which took\n"
		     "the stop (default 300; 0: send and exit)"),
	TOOL_OPT_HELP,
};
const size_t rmdctl_n_robot_stop_opts =
	sizeof(rmdctl_robot_stop_opts) / sizeof(rmdctl_robot_stop_opts[0]);

void rmdctl_robot_stop_usage(FILE *f)
{
	fprintf(f, "usage: rmdctl stop --robot [--lcm-url URL] [--reason TEXT] [--wait-ms MS]\n"
		   "\n"
		   "Stops the whole robot: publishes rmd.robot_stop_t on " RMD_CHANNEL_ROBOT_STOP
		   ", and every\n"
		   "rmdd with a robot.instance gives each driven motor its safe action, as its\n"
		   "command watchdog does, and says why in its journal and health_t.  Enabling\n"
		   "again is each controller's enable (enable = 0, then 1).  docs/robot.md.\n"
		   "Then it names each daemon whose heartbeat it heard: tripped, or still\n"
		   "running (an rmdd without a robot: section sends none and ignores the stop).\n"
		   "\n");
	tool_opts_help(f, rmdctl_robot_stop_opts, rmdctl_n_robot_stop_opts);
	fprintf(f, "\nexit status: 0 sent, and every daemon heard says tripped; 1 LCM failed, a\n"
		   "daemon heard still runs, or none was heard (--wait-ms 0: 0 once sent);\n"
		   "2 usage error.\n");
}

bool rmdctl_is_robot_stop(int argc, char **argv)
{
	for (int i = 1; i < argc; i++)
		if (!strcmp(argv[i], "--robot"))
			return true;
	return false;
}

static void on_heartbeat(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_heartbeat_t *h,
			 void *user)
{
	struct listen *l = user;
	struct heard *d = NULL;

	(void)rbuf;
	(void)channel;
	for (unsigned i = 0; i < l->n && !d; i++)
		if (!strcmp(l->d[i].instance, h->instance) && !strcmp(l->d[i].host, h->host) &&
		    l->d[i].pid == h->pid)
			d = &l->d[i];
	if (!d) {
		if (l->n == HEARD_MAX) {
			l->dropped++;
			return;
		}
		d = &l->d[l->n++];
		snprintf(d->instance, sizeof(d->instance), "%s", h->instance);
		snprintf(d->host, sizeof(d->host), "%s", h->host);
		snprintf(d->prefix, sizeof(d->prefix), "%s", h->prefix);
		d->pid = h->pid;
	}
	d->state = h->state;
	snprintf(d->reason, sizeof(d->reason), "%s", h->reason);
}

/* Listen to the heartbeats until wait_ms after now; the daemons heard, and whether all stopped. */
static int listen_report(lcm_t *lcm, struct listen *l, int wait_ms)
{
	int64_t end = rmd_now_ns() + (int64_t)wait_ms * RMD_NS_PER_MS;
	unsigned running = 0;

	for (int64_t left; (left = end - rmd_now_ns()) > 0;)
		lcm_handle_timeout(lcm, (int)(left / RMD_NS_PER_MS) + 1);
	for (unsigned i = 0; i < l->n; i++) {
		const struct heard *d = &l->d[i];
		bool stopped = d->state == RMD_HEARTBEAT_T_HB_TRIPPED;

		running += !stopped;
		printf("  %s (host %s, pid %d, prefix %s): %s%s%s\n", d->instance, d->host,
		       (int)d->pid, d->prefix,
		       stopped ? "tripped" :
		       d->state == RMD_HEARTBEAT_T_HB_STOPPING ?
				 "shutting down, not stopped by this" :
				 "STILL RUNNING: it did not take the stop",
		       stopped && d->reason[0] ? ": " : "", stopped ? d->reason : "");
	}
	if (l->dropped)
		printf("  (and %u more daemons, not listed)\n", l->dropped);
	if (!l->n) {
		tool_log(
			TOOL_LOG_ERR,
			"no rmdd of a robot heard within %d ms: nothing confirmed the stop (an rmdd "
			"without a robot: section ignores it: stop its motors with enable = 0, or "
			"SIGINT; docs/robot.md)",
			wait_ms);
		return RMDCTL_EXIT_DATA;
	}
	if (running) {
		tool_log(TOOL_LOG_ERR, "%u of %u daemons heard did not say tripped within %d ms",
			 running, l->n, wait_ms);
		return RMDCTL_EXIT_DATA;
	}
	return RMDCTL_EXIT_OK;
}

int rmdctl_robot_stop_run(int argc, char **argv)
{
	struct option
		longopts[sizeof(rmdctl_robot_stop_opts) / sizeof(rmdctl_robot_stop_opts[0]) + 1];
	const char *env = getenv("LCM_DEFAULT_URL");
	const char *url = env && *env ? env : RMD_CONFIG_DEFAULT_LCM_URL, *reason = "operator";
	char shorts[16], msg[160], host[64] = "?", who[96], *end;
	static struct listen heard;
	rmd_heartbeat_t_subscription_t *sub = NULL;
	struct timespec ts;
	rmd_robot_stop_t s;
	long wait_ms = WAIT_MS_DEFAULT;
	lcm_t *lcm;
	int c, failed = 0, rc;

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
		case TOOL_OPT_BASE + OPT_WAIT:
			wait_ms = strtol(optarg, &end, 10);
			if (end == optarg || *end || wait_ms < 0 || wait_ms > WAIT_MS_MAX) {
				tool_log(TOOL_LOG_ERR, "--wait-ms: \"%s\" is not 0..%d ms", optarg,
					 WAIT_MS_MAX);
				return RMDCTL_EXIT_USAGE;
			}
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
	/* listening before the first stop goes out: a daemon's next heartbeat may be 1 ms away */
	if (wait_ms > 0)
		sub = rmd_heartbeat_t_subscribe(lcm, RMD_CHANNEL_ROBOT_HEARTBEAT, on_heartbeat,
						&heard);
	for (int k = 0; k < SENDS; k++) {
		struct timespec gap = { .tv_nsec = 10 * RMD_NS_PER_MS };

		clock_gettime(CLOCK_REALTIME, &ts);
		s.t_ns = rmd_timespec_ns(&ts);
		failed += rmd_robot_stop_t_publish(lcm, RMD_CHANNEL_ROBOT_STOP, &s) != 0;
		if (k + 1 < SENDS)
			nanosleep(&gap, NULL);
	}
	if (failed == SENDS) {
		if (sub)
			rmd_heartbeat_t_unsubscribe(lcm, sub);
		lcm_destroy(lcm);
		tool_log(TOOL_LOG_ERR, "LCM %s: could not publish on %s", url,
			 RMD_CHANNEL_ROBOT_STOP);
		return RMDCTL_EXIT_DATA;
	}
	printf("robot stop sent on %s (%s): %s\n", RMD_CHANNEL_ROBOT_STOP, url, reason);
	fflush(stdout);
	rc = wait_ms > 0 ? listen_report(lcm, &heard, (int)wait_ms) : RMDCTL_EXIT_OK;
	if (sub) /* lcm-gen's subscriptions are the caller's to free */
		rmd_heartbeat_t_unsubscribe(lcm, sub);
	lcm_destroy(lcm);
	return rc;
}
