/* SPDX-License-Identifier: MIT */
/*
 * Test helpers shared by the LCM suites: make sure LCM's UDP multicast works
 * on loopback (README "A robot PC without a network"), routing it when the
 * suite runs as root, or say loudly why every test will skip; and the test
 * controller's listener, which keeps what rmdd's bridge publishes.
 */
#ifndef RMD_TESTS_LCM_LOOPBACK_H
#define RMD_TESTS_LCM_LOOPBACK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <lcm/lcm.h>

#include "rmd/rmd_config_t.h"
#include "rmd/rmd_health_t.h"
#include "rmd/rmd_state_t.h"

/*
 * True when multicast on loopback works, routing it first as root ("up"
 * too: a fresh network namespace starts with lo down).  Otherwise prints
 * one loud line naming `suite` and the commands that fix it.
 */
bool lcm_loopback_ready(const char *suite);

/*
 * The group set-up of a suite that runs rmdd and rmdctl over LCM (suite: its
 * name, for lcm_loopback_ready()): both found (find_prog() into rmdd and
 * rmdctl, PATH_MAX each), dir (a mkdtemp() template) made, and what a
 * user's shell may have set that would steer them (LCM_DEFAULT_URL,
 * NOTIFY_SOCKET) unset; *multicast: whether multicast on loopback works.
 * 0, or -1.
 */
int lcm_tools_setup(const char *suite, char *rmdd, char *rmdctl, char *dir, bool *multicast);

/* Its group teardown: every child killed (kid_kill_all()), then its dir removed. */
int lcm_tools_teardown(void **state);

/*
 * url = a udpm URL (TTL 0) on a port of this process and test: base_port +
 * (pid % pids) * 40 + test_no % 40, so that suites running in parallel do
 * not hear each other. The whole range must be UDP ports (a test fails
 * otherwise, whatever its pid).
 */
void lcm_test_url(char *url, size_t len, int base_port, unsigned pids, unsigned test_no);

/* lcm_test_url() with ttl=ttl: 1 for LCM between network namespaces (netns.h). */
void lcm_test_url_ttl(char *url, size_t len, int base_port, unsigned pids, unsigned test_no,
		      unsigned ttl);

/*
 * A zeroed fixture of size bytes for a set-up to fill and store in *state
 * (NULL until then); NULL when multicast does not work (the tests then skip:
 * fixture_or_skip()).
 */
void *lcm_fixture_new(void **state, size_t size, bool multicast);

/* *state, the suite's fixture; skips the test when set-up left none (no multicast). */
void *fixture_or_skip(void **state);

#define LCM_RX_STATES 4096 /* state_t cycles kept, and the subscription's queue */
#define LCM_RX_HEALTH 64   /* health_t arrival times kept */

/* What the controller received on <prefix>STATE, HEALTH and CONFIG. */
struct lcm_rx {
	lcm_t *lcm; /* NULL: not listening */
	rmd_state_t_subscription_t *state_sub;
	rmd_health_t_subscription_t *health_sub;
	rmd_config_t_subscription_t *config_sub;

	rmd_state_t state; /* the last one; its motor[] is state_motor[] */
	rmd_motor_state_t state_motor[RMD_STATE_T_MAX_MOTORS];
	unsigned n_states;
	int64_t state_cycle[LCM_RX_STATES]; /* the first ones' cycle numbers */
	rmd_health_t *health;		    /* the last one (a copy), or NULL */
	unsigned n_health;
	int64_t health_rx_ns[LCM_RX_HEALTH]; /* CLOCK_MONOTONIC at arrival */
	rmd_config_t *config;		     /* the last one (a copy), or NULL */
	unsigned n_config;
};

/* Subscribe rx to prefix's channels on lcm (rx zeroed by the caller). */
void lcm_rx_listen(struct lcm_rx *rx, lcm_t *lcm, const char *prefix);

/* Unsubscribe (the messages kept stay). */
void lcm_rx_stop(struct lcm_rx *rx);

/* Unsubscribe and free the messages kept. */
void lcm_rx_free(struct lcm_rx *rx);

/*
 * Zero *first_ns, then stamp it (rmd_now_ns()) with the arrival of the first
 * message on channel: when a controller's first command came.  The
 * subscription, for lcm_unsubscribe(); NULL on failure.
 */
lcm_subscription_t *lcm_first_listen(lcm_t *lcm, const char *channel, int64_t *first_ns);

#endif /* RMD_TESTS_LCM_LOOPBACK_H */
