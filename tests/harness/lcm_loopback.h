/* SPDX-License-Identifier: MIT */
/*
 * Test helper shared by the LCM suites: make sure LCM's UDP multicast works
 * on loopback (README "A robot PC without a network"), routing it when the
 * suite runs as root, or say loudly why every test will skip.
 */
#ifndef RMD_TESTS_LCM_LOOPBACK_H
#define RMD_TESTS_LCM_LOOPBACK_H

#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include <lcm/lcm.h>

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
static bool lcm_loopback_ready(const char *suite)
{
	if (lcm_loopback_works())
		return true;
	if (geteuid() == 0) {
		fprintf(stderr,
			"%s: routing multicast on loopback: "
			"ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo\n",
			suite);
		if (system("ip link set lo up multicast on && "
			   "(ip route add 224.0.0.0/4 dev lo 2>/dev/null || true)") != 0)
			fprintf(stderr, "%s: ip failed\n", suite);
		if (lcm_loopback_works())
			return true;
	}
	fprintf(stderr,
		"\n*** %s: SKIPPING every test: LCM multicast on loopback is not routable%s.\n"
		"*** As root: ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo\n\n",
		suite, geteuid() ? " and this is not root" : " even after routing it");
	return false;
}

#endif /* RMD_TESTS_LCM_LOOPBACK_H */
