// SPDX-License-Identifier: MIT
/* LCM on loopback and the test controller's listener (lcm_loopback.h). */
#include <setjmp.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <limits.h>

#include <cmocka.h>
#include <lcm/lcm.h>

#include "rmd/channels.h"
#include "rmd/time.h"
#include "harness/lcm_loopback.h"
#include "harness/proc.h"

static int lcm_loopback_got;

static void lcm_loopback_on_probe(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	(void)rbuf;
	(void)channel;
	(void)user;
	lcm_loopback_got = 1;
}

/* One message to ourselves over udpm on a per-process port: does it come back? */
static bool lcm_loopback_works(void)
{
	char url[80];
	lcm_t *l;

	snprintf(url, sizeof(url), "udpm://239.255.76.67:%d?ttl=0", 7600 + getpid() % 97);
	l = lcm_create(url);
	if (!l)
		return false;
	lcm_loopback_got = 0;
	if (lcm_subscribe(l, "PROBE", lcm_loopback_on_probe, NULL)) {
		for (int i = 0; i < 5 && !lcm_loopback_got; i++) {
			lcm_publish(l, "PROBE", "x", 1);
			lcm_handle_timeout(l, 100);
		}
	}
	lcm_destroy(l);
	return lcm_loopback_got;
}

/*
 * True when multicast on loopback works, routing it first as root ("up"
 * too: a fresh network namespace starts with lo down).  Otherwise prints
 * one loud line naming `suite` and the commands that fix it.
 */
bool lcm_loopback_ready(const char *suite)
{
	if (lcm_loopback_works())
		return true;
	if (geteuid() == 0) {
		fprintf(stderr,
			"%s: routing multicast on loopback: "
			"ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo src 127.0.0.1\n",
			suite);
		if (system("ip link set lo up multicast on && "
			   "(ip route add 224.0.0.0/4 dev lo src 127.0.0.1 2>/dev/null || true)") !=
		    0)
			fprintf(stderr, "%s: ip failed\n", suite);
		if (lcm_loopback_works())
			return true;
	}
	fprintf(stderr,
		"\n*** %s: SKIPPING every test: LCM multicast on loopback is not routable%s.\n"
		"*** As root: ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo src 127.0.0.1\n\n",
		suite, geteuid() ? " and this is not root" : " even after routing it");
	return false;
}

static const char *tools_dir;

int lcm_tools_setup(const char *suite, char *rmdd, char *rmdctl, char *dir, bool *multicast)
{
	if (find_prog(rmdd, PATH_MAX, "RMDD", "rmdd") < 0 ||
	    find_prog(rmdctl, PATH_MAX, "RMDCTL", "rmdctl") < 0 || !mkdtemp(dir))
		return -1;
	tools_dir = dir;
	unsetenv("LCM_DEFAULT_URL");
	unsetenv("NOTIFY_SOCKET");
	*multicast = lcm_loopback_ready(suite);
	return 0;
}

int lcm_tools_teardown(void **state)
{
	(void)state;
	kid_kill_all();
	return tools_dir ? rm_tree(tools_dir) : 0;
}

void lcm_test_url(char *url, size_t len, int base_port, unsigned pids, unsigned test_no)
{
	lcm_test_url_ttl(url, len, base_port, pids, test_no, 0);
}

void lcm_test_url_ttl(char *url, size_t len, int base_port, unsigned pids, unsigned test_no,
		      unsigned ttl)
{
	int port;

	/* judged on the range, not this pid's port: a range past 65535 fails every run, not 1 in N */
	if (pids == 0 || base_port < 1024 || base_port + (long)pids * 40 > 65536)
		fail_msg(
			"lcm_test_url: ports %d..%ld are not all UDP ports (base %d, %u pids of 40)",
			base_port, base_port + (long)pids * 40 - 1, base_port, pids);
	port = base_port + (int)((unsigned)getpid() % pids) * 40 + (int)(test_no % 40);
	snprintf(url, len, "udpm://239.255.76.67:%d?ttl=%u", port, ttl);
}

void *lcm_fixture_new(void **state, size_t size, bool multicast)
{
	void *f = NULL;

	*state = NULL; /* the set-up stores f once it is complete */
	if (multicast) {
		f = calloc(1, size);
		assert_non_null(f);
	}
	return f;
}

void *fixture_or_skip(void **state)
{
	if (!*state)
		skip();
	return *state;
}

/* ---- the listener ---------------------------------------------------------- */

static void on_state(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_state_t *msg,
		     void *user)
{
	struct lcm_rx *rx = user;

	(void)rbuf;
	(void)channel;
	rx->state = *msg; /* motor[] is variable-length: copied into rx */
	memset(rx->state_motor, 0, sizeof(rx->state_motor));
	if (msg->count > 0 && msg->count <= RMD_STATE_T_MAX_MOTORS)
		memcpy(rx->state_motor, msg->motor, (size_t)msg->count * sizeof(*msg->motor));
	rx->state.motor = rx->state_motor;
	if (rx->n_states < LCM_RX_STATES)
		rx->state_cycle[rx->n_states] = msg->cycle;
	rx->n_states++;
}

static void on_health(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_health_t *msg,
		      void *user)
{
	struct lcm_rx *rx = user;

	(void)rbuf;
	(void)channel;
	if (rx->health)
		rmd_health_t_destroy(rx->health);
	rx->health = rmd_health_t_copy(msg);
	if (rx->n_health < LCM_RX_HEALTH)
		rx->health_rx_ns[rx->n_health] = rmd_now_ns();
	rx->n_health++;
}

static void on_config(const lcm_recv_buf_t *rbuf, const char *channel, const rmd_config_t *msg,
		      void *user)
{
	struct lcm_rx *rx = user;
	rmd_config_t *old = rx->config;

	(void)rbuf;
	(void)channel;
	rx->config = rmd_config_t_copy(msg);
	rx->n_config++;
	if (old)
		rmd_config_t_destroy(old);
}

void lcm_rx_listen(struct lcm_rx *rx, lcm_t *lcm, const char *prefix)
{
	char ch[96];

	rx->lcm = lcm;
	snprintf(ch, sizeof(ch), "%s" RMD_CHANNEL_STATE, prefix);
	rx->state_sub = rmd_state_t_subscribe(lcm, ch, on_state, rx);
	assert_non_null(rx->state_sub);
	rmd_state_t_subscription_set_queue_capacity(rx->state_sub, LCM_RX_STATES);
	snprintf(ch, sizeof(ch), "%s" RMD_CHANNEL_HEALTH, prefix);
	rx->health_sub = rmd_health_t_subscribe(lcm, ch, on_health, rx);
	assert_non_null(rx->health_sub);
	snprintf(ch, sizeof(ch), "%s" RMD_CHANNEL_CONFIG, prefix);
	rx->config_sub = rmd_config_t_subscribe(lcm, ch, on_config, rx);
	assert_non_null(rx->config_sub);
}

void lcm_rx_stop(struct lcm_rx *rx)
{
	if (rx->lcm) {
		rmd_state_t_unsubscribe(rx->lcm, rx->state_sub);
		rmd_health_t_unsubscribe(rx->lcm, rx->health_sub);
		rmd_config_t_unsubscribe(rx->lcm, rx->config_sub);
		rx->lcm = NULL;
	}
}

void lcm_rx_free(struct lcm_rx *rx)
{
	lcm_rx_stop(rx);
	if (rx->health)
		rmd_health_t_destroy(rx->health);
	if (rx->config)
		rmd_config_t_destroy(rx->config);
	rx->health = NULL;
	rx->config = NULL;
}

static void on_first(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	int64_t *first_ns = user;

	(void)rbuf;
	(void)channel;
	if (!*first_ns)
		*first_ns = rmd_now_ns();
}

lcm_subscription_t *lcm_first_listen(lcm_t *lcm, const char *channel, int64_t *first_ns)
{
	*first_ns = 0;
	return lcm_subscribe(lcm, channel, on_first, first_ns);
}
