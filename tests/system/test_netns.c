// SPDX-License-Identifier: MIT
/*
 * The harness that stands in for separate machines (tests/harness/netns.h,
 * issue 30): robot PCs A and B and a controller C, each a network
 * namespace on one bridge, proved as the suites that use them need:
 *   bridge    an LCM publisher in A (udpm, ttl=1) is heard in B and C, and
 *             not in this process's own namespace (the host's network is
 *             not part of it);
 *   child     a program started in B runs there: B's address, B's eth0;
 *   loss      netns_loss(B, 50): B hears about half of what A publishes,
 *             judged against the binomial spread, while C still hears all;
 *             netns_loss(B, 0) gives everything back;
 *   teardown  netns_net_down() leaves nothing in `ip netns list`, nor does
 *             a test process that exits without it (at exit) or is killed
 *             (SIGKILL: the next netns_net_up() sweeps its namespaces).
 * Needs root, ip and nft, and no CAN: without them every test skips saying
 * why.  RMD_TEST_FILTER=test_loss runs one test.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <math.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <sys/wait.h>

#include <lcm/lcm.h>

#include "rmd/time.h"
#include "harness/lcm_loopback.h"
#include "harness/netns.h"
#include "harness/proc.h"
#include "harness/suite.h"

#define BASE_PORT 60000 /* + (pid % 100) * 40 + test: 60000..64039 */
#define PIDS 100
#define HOST_A 0
#define HOST_B 1
#define HOST_C 2
#define LOSS_N 2000 /* datagrams sent for the loss test */
#define LOSS_PCT 50
#define QUIET_MS 200 /* after the last datagram: nothing more is on its way */
#define LIMIT_MS 60000
#define WINDOW 16	 /* datagrams in flight at most */
#define CATCH_UP_MS 1000 /* for C to hear a window */

static const char *skip_why;
static unsigned test_no;

struct ear {
	lcm_t *lcm;
	unsigned got;
};

struct fixture {
	struct netns_net net;
	char url[96];
	lcm_t *pub;	   /* in A */
	struct ear ear[3]; /* B, C, and this process's own namespace */
};

static void on_msg(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	(void)rbuf;
	(void)channel;
	((struct ear *)user)->got++;
}

/* An lcm_t on f->url opened in host i (or here: i < 0), and subscribed there when ear is given. */
static lcm_t *open_in(struct fixture *f, int i, struct ear *ear)
{
	lcm_t *l;

	if (i >= 0) {
		int r = netns_enter(&f->net, (unsigned)i);

		if (r < 0)
			fail_msg("into %s: %s", f->net.name[i], strerror(-r));
	}
	l = lcm_create(f->url);
	if (l && ear) {
		ear->lcm = l;
		lcm_subscription_t *sub = lcm_subscribe(l, "NETNS_PROBE", on_msg, ear);

		/* the receive socket is made here, in this namespace */
		assert_non_null(sub);
		/* no queue limit: a datagram lost is the link's, never the queue's (LCM's 30) */
		lcm_subscription_set_queue_capacity(sub, 0);
		assert_true(lcm_get_fileno(l) >= 0);
	}
	if (i >= 0)
		assert_int_equal(netns_leave(), 0);
	if (!l)
		fail_msg("lcm_create(%s) in %s failed", f->url, i >= 0 ? f->net.name[i] : "here");
	return l;
}

static int setup(void **state)
{
	static const char *const hosts[] = { "a", "b", "c" };
	struct fixture *f;

	*state = NULL;
	if (skip_why)
		return 0;
	f = calloc(1, sizeof(*f));
	assert_non_null(f);
	lcm_test_url_ttl(f->url, sizeof(f->url), BASE_PORT, PIDS, test_no++, 1);
	if (netns_net_up(&f->net, hosts, 3) < 0) {
		free(f);
		return -1;
	}
	*state = f;
	f->pub = open_in(f, HOST_A, NULL);
	f->ear[0].lcm = open_in(f, HOST_B, &f->ear[0]);
	f->ear[1].lcm = open_in(f, HOST_C, &f->ear[1]);
	f->ear[2].lcm = open_in(f, -1, &f->ear[2]);
	return 0;
}

static int teardown(void **state)
{
	struct fixture *f = *state;

	kid_kill_all();
	if (!f)
		return 0;
	for (unsigned i = 0; i < 3; i++)
		if (f->ear[i].lcm)
			lcm_destroy(f->ear[i].lcm);
	if (f->pub)
		lcm_destroy(f->pub);
	netns_net_down(&f->net);
	free(f);
	return 0;
}

static struct fixture *fixture(void **state)
{
	if (skip_why) {
		fprintf(stderr, "SKIP: %s\n", skip_why);
		skip();
	}
	assert_non_null(*state);
	return *state;
}

/* Take what every ear has until none hears anything for QUIET_MS. */
static void drain(struct fixture *f, int quiet_ms)
{
	int64_t quiet_until = rmd_now_ns() + (int64_t)quiet_ms * 1000000;

	while (rmd_now_ns() < quiet_until) {
		bool any = false;

		for (unsigned i = 0; i < 3; i++)
			while (lcm_handle_timeout(f->ear[i].lcm, 0) > 0)
				any = true;
		if (any)
			quiet_until = rmd_now_ns() + (int64_t)quiet_ms * 1000000;
		else
			usleep(1000);
	}
}

/*
 * A publishes n datagrams, WINDOW at a time: the next ones go out when C,
 * whose link loses nothing, has heard these (or after CATCH_UP_MS), so no
 * socket's buffer overflows however the machine schedules LCM's reader
 * threads: what an ear misses, its link lost.
 */
static void publish(struct fixture *f, unsigned n)
{
	const int64_t limit = rmd_now_ns() + (int64_t)LIMIT_MS * 1000000;
	char payload[64] = "probe";
	unsigned c0 = f->ear[1].got;

	for (unsigned i = 0; i < n; i++) {
		assert_int_equal(lcm_publish(f->pub, "NETNS_PROBE", payload, sizeof(payload)), 0);
		if (i % WINDOW == WINDOW - 1 || i == n - 1) {
			int64_t until = rmd_now_ns() + (int64_t)CATCH_UP_MS * 1000000;

			while (f->ear[1].got - c0 < i + 1 && rmd_now_ns() < until)
				drain(f, 1);
		}
		if (rmd_now_ns() > limit)
			fail_msg("publishing %u datagrams took over %d ms", n, LIMIT_MS);
	}
	drain(f, QUIET_MS);
}

static void test_bridge(void **state)
{
	struct fixture *f = fixture(state);

	publish(f, 100);
	print_message("A -> B %u, A -> C %u, A -> this namespace %u of 100\n", f->ear[0].got,
		      f->ear[1].got, f->ear[2].got);
	/* Nothing loses datagrams on a veth and a bridge at this pace. */
	assert_int_equal(f->ear[0].got, 100);
	assert_int_equal(f->ear[1].got, 100);
	assert_int_equal(f->ear[2].got, 0);
}

static void test_child(void **state)
{
	struct fixture *f = fixture(state);
	const char *argv[] = { "ip", "-o", "-4", "addr", "show", NULL };
	struct kid *k = netns_kid_spawn(&f->net, HOST_B, "ip", argv, NULL);
	char want[48];

	assert_non_null(k);
	assert_int_equal(kid_wait_exit(k, LIMIT_MS, NULL), 0);
	snprintf(want, sizeof(want), "eth0    inet %s/24", f->net.addr[HOST_B]);
	assert_has(k->out, want, "ip addr in B");
	assert_has(k->out, "lo    inet 127.0.0.1/8", "ip addr in B");
	assert_int_equal(count_lines(k->out), 2); /* nothing of the host's interfaces */
}

static void test_loss(void **state)
{
	struct fixture *f = fixture(state);
	const double p = LOSS_PCT / 100.0, mean = LOSS_N * (1 - p), sd = sqrt(LOSS_N * p * (1 - p));

	assert_int_equal(netns_loss(&f->net, HOST_B, LOSS_PCT), 0);
	publish(f, LOSS_N);
	print_message("%d %% loss into B: B heard %u of %d (expected %.0f +- %.0f), C %u\n",
		      LOSS_PCT, f->ear[0].got, LOSS_N, mean, 5 * sd, f->ear[1].got);
	/* 5 standard deviations: a false failure once in ~2 million runs. */
	if (fabs(f->ear[0].got - mean) > 5 * sd)
		fail_msg("B heard %u of %d with %d %% loss: not within %.0f +- %.0f", f->ear[0].got,
			 LOSS_N, LOSS_PCT, mean, 5 * sd);
	assert_int_equal(f->ear[1].got, LOSS_N); /* the loss is B's link alone */

	assert_int_equal(netns_loss(&f->net, HOST_B, 0), 0);
	f->ear[0].got = 0;
	publish(f, 100);
	assert_int_equal(f->ear[0].got, 100);
}

static void assert_none_left(const char *prefix, const char *what)
{
	char listed[1024];

	if (netns_listed(prefix, listed, sizeof(listed)))
		fail_msg("%s: still in `ip netns list`:\n%s", what, listed);
}

static void test_teardown(void **state)
{
	struct fixture *f = fixture(state);
	const char *argv[] = { "sleep", "60", NULL };
	char prefix[32], listed[1024];
	pid_t pid;
	int ws;

	/* a child still running in a namespace does not keep it listed */
	assert_non_null(netns_kid_spawn(&f->net, HOST_C, "sleep", argv, NULL));
	snprintf(prefix, sizeof(prefix), "rmdt-%ld-", (long)getpid());
	assert_int_equal(netns_listed(prefix, listed, sizeof(listed)), 4);
	for (unsigned i = 0; i < 3; i++)
		lcm_destroy(f->ear[i].lcm);
	lcm_destroy(f->pub);
	memset(f->ear, 0, sizeof(f->ear));
	f->pub = NULL;
	netns_net_down(&f->net);
	assert_none_left(prefix, "after netns_net_down()");
	kid_kill_all(); /* before the forks below, which must not inherit it */

	/* a test process that exits without taking its network down (a failed test) */
	for (int how = 0; how < 2; how++) {
		static const char *const hosts[] = { "a", "b" };

		pid = fork();
		assert_true(pid >= 0);
		if (pid == 0) {
			struct netns_net net;

			if (netns_net_up(&net, hosts, 2) < 0)
				_exit(3);
			if (how == 1)
				raise(SIGKILL);
			exit(1); /* atexit: netns_net_down() */
		}
		assert_int_equal(waitpid(pid, &ws, 0), pid);
		snprintf(prefix, sizeof(prefix), "rmdt-%ld-", (long)pid);
		if (how == 0) {
			assert_true(WIFEXITED(ws) && WEXITSTATUS(ws) == 1);
			assert_none_left(prefix, "after exit()");
		} else {
			assert_true(WIFSIGNALED(ws));
			assert_int_equal(netns_listed(prefix, listed, sizeof(listed)), 3);
			assert_true(netns_sweep() >= 3); /* and any other dead suite's */
			assert_none_left(prefix, "after SIGKILL and netns_sweep()");
		}
	}
}

static int group_setup(void **state)
{
	(void)state;
	unsetenv("LCM_DEFAULT_URL");
	skip_why = netns_unavailable();
	if (skip_why)
		fprintf(stderr, "\n*** test_netns: SKIPPING every test: %s\n\n", skip_why);
	return 0;
}

SUITE_MAIN_FIXTURE("netns", setup, teardown, group_setup, NULL,
		   {
			   cmocka_unit_test(test_bridge),
			   cmocka_unit_test(test_child),
			   cmocka_unit_test(test_loss),
			   cmocka_unit_test(test_teardown),
		   })
