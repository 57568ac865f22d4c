/* SPDX-License-Identifier: MIT */
/*
 * Two rmdd as one robot (docs/robot.md), as the robot suites drive them:
 * daemon 0 instance "left" (prefix LEFT_), daemon 1 instance "right"
 * (RIGHT_), each the other's peer, on sim buses; the test is their
 * controller on one LCM URL and keeps what they publish (state_t, health_t,
 * heartbeats).  On one host (test_robot_system) or each in a network
 * namespace of its own (test_robot_netns: rp.net set, the controller's
 * sockets in host rp.ctl_host, daemon i in host rp.host[i]).  One pair at a
 * time: rp.  Non-rt.
 */
#ifndef RMD_TESTS_ROBOT_PAIR_H
#define RMD_TESTS_ROBOT_PAIR_H

#include <limits.h>
#include <stdbool.h>
#include <stdint.h>

#include <lcm/lcm.h>

#include "rmd/rmd_health_t.h"
#include "rmd/rmd_heartbeat_t.h"
#include "rmd/rmd_state_t.h"

#define RP_NMOT 2
#define RP_HEARTBEAT_MS 10
#define RP_PEER_TIMEOUT_MS 100

struct kid;
struct netns_net;
struct sleeper;

/* One daemon of the robot, as the test sees and drives it. */
struct robot_side {
	const char *inst, *prefix;
	struct kid *kid;
	int64_t controller, seq;
	rmd_state_t_subscription_t *ssub;
	rmd_health_t_subscription_t *hsub;
	int8_t lc[RP_NMOT]; /* the newest state_t's lifecycles */
	int64_t host_utime; /* and its host clock */
	unsigned n_states;
	int64_t safe_rx_ns;   /* when a state_t first showed every motor SAFE (0: not yet) */
	bool left_enabled;    /* a state_t showed a motor not ENABLED after arm() */
	bool armed;	      /* watch for that */
	rmd_health_t *health; /* the newest (a copy) */
	char ch_cmd[64];
	char tap[PATH_MAX + 64]; /* its sim bus's wire tap ("" none), set before it starts */
};

struct robot_pair {
	/* set by the suite, kept by robot_pair_url() */
	const char *rmdd, *dir;	     /* the daemon's path, where configs go */
	struct sleeper *ref;	     /* how long the machine held a thread off */
	const struct netns_net *net; /* NULL: all on this host */
	unsigned ctl_host, host[2];  /* with net: the controller's host, each daemon's */
	const char *safe_action;     /* NULL: damp */
	int peer_timeout_ms;	     /* 0: RP_PEER_TIMEOUT_MS */
	/* robot_pair_url() on */
	char url[128];
	lcm_t *lcm;
	struct robot_side s[2];
	rmd_heartbeat_t_subscription_t *hbsub;
	unsigned heartbeats; /* on RMD_ROBOT_HEARTBEAT */
};

extern struct robot_pair rp;

/*
 * A robot suite's group set-up (lcm_tools_setup(): rmdd and rmdctl found,
 * a temporary folder, *multicast): rp.rmdd, rp.dir, rp.ref set and the
 * reference sleeper started.  0, or -1.
 */
int robot_pair_group_setup(const char *suite, char *rmdctl, bool *multicast);

/* Its group teardown: the sleeper stopped, then lcm_tools_teardown(). */
int robot_pair_group_teardown(void **state);

/*
 * rp's LCM on url (its live fields cleared, the suite's kept): in
 * rp.ctl_host with rp.net.
 */
void robot_pair_url(const char *url);

/* Start daemon i: instance inst on prefix with robot: section robot ("" none), motors names_hip/_knee. */
void robot_side_start_named(unsigned i, const char *inst, const char *prefix, const char *robot,
			    const char *names);
void robot_side_start(unsigned i, const char *inst, const char *prefix, const char *robot);

/* left and right, each the other's peer; motors named after names[i]. */
void robot_pair_start_named(const char *const names[2]);
void robot_pair_start(void);

/* Both up, each seeing the other, every motor ENABLED (fails the test otherwise). */
void robot_pair_enabled(void);

/* Every daemon killed, every subscription and rp.lcm gone. */
void robot_pair_teardown(void);

/* Every motor of s: enable as given, torque 0 (torque mode needs no certain position). */
void robot_send_cmd(struct robot_side *s, bool enable);

/* A heartbeat_t on l as another process would send it: instance inst from host, ahead_ns ahead. */
void robot_send_heartbeat(lcm_t *l, const char *inst, const char *host, int64_t boot, int64_t seq,
			  int64_t ahead_ns);

/* Handle LCM and read the children for ms; a daemon that exits unasked fails the test. */
void robot_pump(int ms);

/* Stream enable to the running sides (20 ms apart) until done(), at most ms of held time. */
bool robot_drive_until(bool enable, int ms, bool (*done)(void));

/* Every motor of s in lifecycle lc in its newest state_t. */
bool robot_all_in(const struct robot_side *s, int lc);

/* Predicates for robot_drive_until(). */
bool robot_both_enabled(void);
bool robot_right_enabled(void);
bool robot_both_safe(void);
bool robot_right_safe(void);
bool robot_peers_ok(void);
bool robot_never(void);

/* Occurrences of needle in hay. */
unsigned robot_count_of(const char *hay, const char *needle);

#endif /* RMD_TESTS_ROBOT_PAIR_H */
