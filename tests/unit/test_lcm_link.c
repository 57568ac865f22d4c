// SPDX-License-Identifier: MIT
/*
 * The LCM link (rmd/lcm_link.h) against the two LCMs rmdd meets: Debian's
 * liblcm 1.3.1 (what rmdd links; a C peer in this process, its own
 * sockets) and PyPI's lcm 1.5.x (tests/unit/lcm_peer.py, a Python process
 * with its own bundled liblcm), over udpm on loopback.  Each sends to the
 * link and receives from it a short message (one datagram) and messages
 * longer than one datagram (LCM's fragments), byte for byte; the link
 * never reads back its own datagrams (the socket filter) while every other
 * member of the group hears them; a message too long to keep is said to
 * be, with its channel and size; memq:// goes through LCM's own path;
 * receive and publish allocate nothing.
 *
 * The Python is $RMD_PYTHON, else the python3 on PATH when it imports lcm
 * (make test puts the venv's first), else build/venv/bin/python3.  Without
 * one, or without multicast on loopback, the tests skip, loudly.
 */
#define _GNU_SOURCE

#include <errno.h>
#include <limits.h>
#include <poll.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <cmocka.h>
#include <lcm/lcm.h>

#include "harness/alloc_count.h"
#include "harness/lcm_loopback.h"
#include "rmd/lcm_link.h"
#include "rmd/time.h"
#include "harness/suite.h"

#define PREFIX "LINK_"
/* One datagram: channel, NUL and bytes fit LCM_SHORT_MESSAGE_MAX_SIZE. */
#define SHORT_SIZE 100
/* Two fragments on PREFIX "B" (65499 < 7 + 65530), and still one the link keeps (64 KiB). */
#define FRAG_SIZE 65530
/* Four fragments: only sent by the link (more than it keeps). */
#define BIG_SIZE 200000
/* LCM receivers' URLs ask for this buffer: a burst of fragments must fit. */
#define PEER_RCVBUF "recv_buf_size=4194304"

struct fixture {
	char url[80];	    /* the link's */
	char peer_url[128]; /* an LCM peer's: the same group, a receive buffer for fragments */
	struct rmd_lcm_link *link;
};

static bool no_multicast;
static unsigned test_no;
static char python[PATH_MAX], peer_script[PATH_MAX];
static bool have_python;
static unsigned char sent[BIG_SIZE], got[BIG_SIZE];

/* ---- the message bodies: tests/unit/lcm_peer.py computes the same -------------- */

static void pattern(unsigned char *p, size_t size, unsigned seed)
{
	for (size_t i = 0; i < size; i++)
		p[i] = (unsigned char)(i * 7 + seed * 13 + (i >> 8));
}

static uint64_t fnv(const unsigned char *p, size_t size)
{
	uint64_t h = 0xcbf29ce484222325u;

	for (size_t i = 0; i < size; i++)
		h = (h ^ p[i]) * 0x100000001b3u;
	return h;
}

/* ---- set-up ---------------------------------------------------------------------- */

static bool python_imports_lcm(const char *py)
{
	char cmd[2 * PATH_MAX];

	snprintf(cmd, sizeof(cmd), "'%.*s' -c 'import lcm' >/dev/null 2>&1", PATH_MAX, py);
	return system(cmd) == 0;
}

/* The Python that runs the 1.5 peer, and the peer script (run from the tree's top). */
static void find_python(void)
{
	const char *env = getenv("RMD_PYTHON"), *build = getenv("BUILD");
	char c[3][PATH_MAX];

	snprintf(c[0], sizeof(c[0]), "%s", env && *env ? env : "python3");
	snprintf(c[1], sizeof(c[1]), "%.*s/venv/bin/python3", PATH_MAX - 32,
		 build && *build ? build : "build");
	snprintf(c[2], sizeof(c[2]), "build/venv/bin/python3");
	for (unsigned k = 0; k < 3 && !have_python; k++)
		if (python_imports_lcm(c[k])) {
			snprintf(python, sizeof(python), "%.*s", PATH_MAX - 1, c[k]);
			have_python = true;
		}
	snprintf(peer_script, sizeof(peer_script), "tests/unit/lcm_peer.py");
	if (access(peer_script, R_OK) != 0)
		have_python = false;
	if (!have_python)
		fprintf(stderr,
			"\n*** test_lcm_link: SKIPPING the LCM 1.5 tests: no python3 that imports "
			"lcm ($RMD_PYTHON, PATH, build/venv: make python-venv), or no %s here\n\n",
			peer_script);
}

static int group_setup(void **state)
{
	(void)state;
	no_multicast = !lcm_loopback_ready("test_lcm_link");
	find_python();
	return 0;
}

static int setup(void **state)
{
	struct fixture *f = lcm_fixture_new(state, sizeof(*f), !no_multicast);
	struct rmd_lcm_link_opts o = { .prefix = PREFIX, .recv_buf_size = 4 << 20 };
	char err[256] = "";

	if (!f)
		return 0;
	lcm_test_url(f->url, sizeof(f->url), 10000, 250, test_no++);
	snprintf(f->peer_url, sizeof(f->peer_url), "%s&%s", f->url, PEER_RCVBUF);
	o.url = f->url;
	if (rmd_lcm_link_new(&f->link, &o, err, sizeof(err)) < 0)
		fail_msg("rmd_lcm_link_new(%s): %s", f->url, err);
	*state = f;
	return 0;
}

static int teardown(void **state)
{
	struct fixture *f = *state;

	if (f)
		rmd_lcm_link_free(f->link);
	free(f);
	return 0;
}

static int64_t realtime_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_REALTIME, &ts);
	return rmd_timespec_ns(&ts);
}

/* The link's next message (1) or too-long report (-EMSGSIZE) within ms; else -ETIMEDOUT. */
static int link_wait(struct rmd_lcm_link *l, struct rmd_lcm_msg *m, int ms)
{
	int64_t end = rmd_now_ns() + (int64_t)ms * RMD_NS_PER_MS;

	for (;;) {
		struct pollfd p = { .fd = rmd_lcm_link_fd(l), .events = POLLIN };
		int r = rmd_lcm_link_receive(l, m);

		if (r == 1 || r == -EMSGSIZE)
			return r;
		assert_true(r == 0 || r == -EAGAIN);
		if (r == -EAGAIN) {
			if (rmd_now_ns() >= end)
				return -ETIMEDOUT;
			poll(&p, 1, 10);
		}
	}
}

/* What the link holds now, read to the end: the number of messages (none expected). */
static unsigned link_drain(struct rmd_lcm_link *l)
{
	struct rmd_lcm_msg m;
	unsigned n = 0;
	int r;

	while ((r = rmd_lcm_link_receive(l, &m)) != -EAGAIN)
		n += r == 1 || r == -EMSGSIZE;
	return n;
}

/* The next message is on channel, size bytes of pattern(seed), stamped between t0 and now. */
static void expect_message(struct fixture *f, const char *channel, size_t size, unsigned seed,
			   int64_t t0)
{
	struct rmd_lcm_msg m;

	assert_int_equal(link_wait(f->link, &m, 3000), 1);
	assert_string_equal(m.channel, channel);
	assert_int_equal(m.size, size);
	pattern(sent, size, seed);
	if (memcmp(m.data, sent, size) != 0)
		fail_msg("%s: %zu bytes differ from what was sent", channel, size);
	assert_true(m.rx_real_ns >= t0);
	assert_true(m.rx_real_ns <= realtime_ns());
}

/* ---- LCM 1.3.1 (Debian's liblcm, this process) ---------------------------------------- */

struct c_rx {
	char channel[64];
	size_t size;
	unsigned n;
};

static void c_on_msg(const lcm_recv_buf_t *rbuf, const char *channel, void *user)
{
	struct c_rx *rx = user;

	snprintf(rx->channel, sizeof(rx->channel), "%s", channel);
	rx->size = rbuf->data_size;
	if (rbuf->data_size <= sizeof(got))
		memcpy(got, rbuf->data, rbuf->data_size);
	rx->n++;
}

static void test_url_checked(void **state)
{
	static const struct {
		const char *url, *says;
		int r;
	} bad[] = {
		{ "udpm://300.1.1.1:7667", "a bad URL, or multicast has no route", -EINVAL },
		{ "udpm://10.1.2.3:7667", "a bad URL, or multicast has no route", -EINVAL },
		{ "udpm://239.255.76.67:99999", "a bad URL", -EINVAL },
		{ "udpm://239.255.76.67:7667?ttl=300", "option \"ttl=300\"", -EINVAL },
		{ "udpm://239.255.76.67:7667?bogus=1", "option \"bogus=1\"", -EINVAL },
		{ "nosuch://", "cannot create \"nosuch://\"", -EIO },
	};
	struct rmd_lcm_link *l;
	char err[256];

	(void)state;
	for (size_t k = 0; k < sizeof(bad) / sizeof(bad[0]); k++) {
		struct rmd_lcm_link_opts o = { .url = bad[k].url };
		int r = rmd_lcm_link_new(&l, &o, err, sizeof(err));

		if (r != bad[k].r || !strstr(err, bad[k].says))
			fail_msg("%s: %d \"%s\", expected %d and \"%s\"", bad[k].url, r, err,
				 bad[k].r, bad[k].says);
		assert_null(l);
	}
	rmd_lcm_link_free(NULL);
}

/* liblcm 1.3.1 sends a short and a fragmented message, and one on another prefix. */
static void test_lcm13_sends(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	lcm_t *peer = lcm_create(f->peer_url);
	struct rmd_lcm_link_info in;
	int64_t t0 = realtime_ns();

	assert_non_null(peer);
	pattern(sent, SHORT_SIZE, 1);
	assert_int_equal(lcm_publish(peer, PREFIX "A", sent, SHORT_SIZE), 0);
	pattern(sent, 10, 9);
	assert_int_equal(lcm_publish(peer, "OTHER_A", sent, 10), 0);
	pattern(sent, FRAG_SIZE, 2);
	assert_int_equal(lcm_publish(peer, PREFIX "B", sent, FRAG_SIZE), 0);
	expect_message(f, PREFIX "A", SHORT_SIZE, 1, t0);
	expect_message(f, PREFIX "B", FRAG_SIZE, 2, t0);
	assert_int_equal(link_drain(f->link), 0);
	rmd_lcm_link_info(f->link, &in);
	assert_true(in.udpm);
	assert_true(in.stamps);
	assert_int_equal(in.datagrams, 4); /* short, other, and two fragments */
	lcm_destroy(peer);
}

/* What the link sends the receiving peers: one datagram, two fragments, four fragments. */
static const struct {
	const char *channel;
	size_t size;
} msgs[] = { { PREFIX "A", SHORT_SIZE }, { PREFIX "B", FRAG_SIZE }, { PREFIX "C", BIG_SIZE } };

/* liblcm 1.3.1 receives what the link sends: short, two fragments, four fragments. */
static void test_lcm13_receives(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	lcm_t *peer = lcm_create(f->peer_url);
	struct c_rx rx = { 0 };

	assert_non_null(peer);
	assert_non_null(lcm_subscribe(peer, PREFIX ".*", c_on_msg, &rx));
	for (unsigned k = 0; k < 3; k++) {
		int64_t end = rmd_now_ns() + 3 * RMD_NS_PER_S;

		pattern(sent, msgs[k].size, 10 + k);
		assert_int_equal(rmd_lcm_link_publish(f->link, msgs[k].channel, sent, msgs[k].size),
				 0);
		while (rx.n == k && rmd_now_ns() < end)
			lcm_handle_timeout(peer, 50);
		if (rx.n != k + 1)
			fail_msg("%s (%zu bytes): LCM 1.3.1 received %u messages", msgs[k].channel,
				 msgs[k].size, rx.n - k);
		assert_string_equal(rx.channel, msgs[k].channel);
		assert_int_equal(rx.size, msgs[k].size);
		if (memcmp(got, sent, msgs[k].size) != 0)
			fail_msg("%s: LCM 1.3.1 received other bytes", msgs[k].channel);
	}
	lcm_destroy(peer);
}

/* ---- LCM 1.5.x (PyPI's lcm, a Python process) --------------------------------------- */

static void need_python(void)
{
	if (!have_python) {
		print_message("skipped: no python3 with lcm (make python-venv)\n");
		skip();
	}
}

/* The peer's first line: "lcm 1.5.x". */
static void expect_version(FILE *p)
{
	char line[128] = "";

	assert_non_null(fgets(line, sizeof(line), p));
	if (strncmp(line, "lcm 1.5.", 8) != 0)
		fail_msg("the Python peer is not LCM 1.5: %s", line);
}

static void py_send(struct fixture *f, const char *channel, size_t size, unsigned seed)
{
	char cmd[3 * PATH_MAX];
	FILE *p;

	snprintf(cmd, sizeof(cmd), "'%s' '%s' send '%s' '%s' %zu %u", python, peer_script,
		 f->peer_url, channel, size, seed);
	p = popen(cmd, "r");
	assert_non_null(p);
	expect_version(p);
	assert_int_equal(pclose(p), 0);
}

/* LCM 1.5 sends a short and a fragmented message. */
static void test_lcm15_sends(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	int64_t t0 = realtime_ns();

	need_python();
	py_send(f, PREFIX "A", SHORT_SIZE, 3);
	py_send(f, PREFIX "B", FRAG_SIZE, 4);
	expect_message(f, PREFIX "A", SHORT_SIZE, 3, t0);
	expect_message(f, PREFIX "B", FRAG_SIZE, 4, t0);
	assert_int_equal(link_drain(f->link), 0);
}

/* LCM 1.5 receives what the link sends: short, two fragments, four fragments. */
static void test_lcm15_receives(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	char cmd[3 * PATH_MAX], line[256];
	FILE *p;

	need_python();
	snprintf(cmd, sizeof(cmd), "'%s' '%s' recv '%s' '%s.*' 3 10", python, peer_script,
		 f->peer_url, PREFIX);
	p = popen(cmd, "r");
	assert_non_null(p);
	expect_version(p);
	assert_non_null(fgets(line, sizeof(line), p));
	assert_string_equal(line, "ready\n");
	for (unsigned k = 0; k < 3; k++) {
		char want[128];

		pattern(sent, msgs[k].size, 20 + k);
		assert_int_equal(rmd_lcm_link_publish(f->link, msgs[k].channel, sent, msgs[k].size),
				 0);
		snprintf(want, sizeof(want), "%s %zu %016llx\n", msgs[k].channel, msgs[k].size,
			 (unsigned long long)fnv(sent, msgs[k].size));
		if (!fgets(line, sizeof(line), p) || strcmp(line, want) != 0)
			fail_msg("LCM 1.5 received \"%s\", expected \"%s\"", line, want);
	}
	assert_int_equal(pclose(p), 0);
}

/* ---- the link's own datagrams --------------------------------------------------------- */

/*
 * The kernel loops the link's datagrams back to the host: its own socket
 * drops them (none read, not even to drop them), while another member of
 * the group on this host, a second link, hears every one.
 */
static void test_own_datagrams_filtered(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	/* all 50 are sent before any is read: room for them (the kernel's default is 208 KiB) */
	struct rmd_lcm_link_opts o = { .url = f->url, .prefix = PREFIX, .recv_buf_size = 4 << 20 };
	struct rmd_lcm_link *other;
	struct rmd_lcm_link_info in;
	struct rmd_lcm_msg m;
	char err[256];

	assert_int_equal(rmd_lcm_link_new(&other, &o, err, sizeof(err)), 0);
	rmd_lcm_link_info(f->link, &in);
	assert_true(in.filter);
	assert_int_equal(in.filter_error, 0);
	pattern(sent, FRAG_SIZE, 5);
	for (unsigned k = 0; k < 50; k++)
		assert_int_equal(rmd_lcm_link_publish(f->link, PREFIX "OWN", sent,
						      k % 10 ? SHORT_SIZE : FRAG_SIZE),
				 0);
	for (unsigned k = 0; k < 50; k++) {
		assert_int_equal(link_wait(other, &m, 3000), 1);
		assert_int_equal(m.size, k % 10 ? SHORT_SIZE : FRAG_SIZE);
	}
	assert_int_equal(link_drain(f->link), 0);
	rmd_lcm_link_info(f->link, &in);
	assert_int_equal(in.datagrams, 0);
	assert_int_equal(in.own_read, 0);
	assert_int_equal(in.published, 50);
	rmd_lcm_link_free(other);
}

/* ---- limits and the other providers ---------------------------------------------------- */

/* A message longer than the link keeps is said to be, with its channel and size. */
static void test_too_long_said(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	lcm_t *peer = lcm_create(f->peer_url);
	struct rmd_lcm_msg m;

	assert_non_null(peer);
	pattern(sent, BIG_SIZE, 6);
	assert_int_equal(lcm_publish(peer, PREFIX "BIG", sent, BIG_SIZE), 0);
	assert_int_equal(link_wait(f->link, &m, 3000), -EMSGSIZE);
	assert_string_equal(m.channel, PREFIX "BIG");
	assert_int_equal(m.size, BIG_SIZE);
	assert_null(m.data);
	assert_int_equal(link_drain(f->link), 0);
	/* a channel longer than LCM's is refused before anything is sent */
	assert_int_equal(rmd_lcm_link_publish(f->link,
					      "C123456789012345678901234567890123456789"
					      "012345678901234567890123",
					      sent, 1),
			 -EINVAL);
	lcm_destroy(peer);
}

/* memq://: LCM's own path, in this thread; the message comes back with LCM's receive time. */
static void test_memq_through_lcm(void **state)
{
	struct rmd_lcm_link_opts o = { .url = "memq://", .prefix = PREFIX, .queue = 100 };
	struct rmd_lcm_link *l;
	struct rmd_lcm_link_info in;
	struct rmd_lcm_msg m;
	char err[256];
	int64_t t0 = realtime_ns();

	(void)state;
	assert_int_equal(rmd_lcm_link_new(&l, &o, err, sizeof(err)), 0);
	rmd_lcm_link_info(l, &in);
	assert_false(in.udpm);
	assert_false(in.filter);
	assert_int_equal(in.lcm_threads, 0); /* memq starts none */
	assert_true(rmd_lcm_link_fd(l) >= 0);
	pattern(sent, FRAG_SIZE, 7);
	assert_int_equal(rmd_lcm_link_publish(l, "OTHER", sent, 10), 0);
	assert_int_equal(rmd_lcm_link_publish(l, PREFIX "M", sent, FRAG_SIZE), 0);
	assert_int_equal(link_wait(l, &m, 1000), 1);
	assert_string_equal(m.channel, PREFIX "M");
	assert_int_equal(m.size, FRAG_SIZE);
	assert_memory_equal(m.data, sent, FRAG_SIZE);
	assert_true(m.rx_real_ns >= t0 - RMD_NS_PER_US && m.rx_real_ns <= realtime_ns());
	assert_int_equal(link_drain(l), 0);
	rmd_lcm_link_free(l);
}

/* The bridge's thread receives and publishes at SCHED_FIFO: neither allocates (udpm). */
static void test_receive_and_publish_allocate_nothing(void **state)
{
	struct fixture *f = fixture_or_skip(state);
	struct rmd_lcm_link_opts o = { .url = f->url, .prefix = PREFIX };
	struct rmd_lcm_link *other;
	struct rmd_lcm_msg m;
	char err[256];
	unsigned long n;

	if (!alloc_count_available()) {
		print_message("skipped: ASan owns malloc, so allocations are not counted here\n");
		skip();
	}
	assert_int_equal(rmd_lcm_link_new(&other, &o, err, sizeof(err)), 0);
	pattern(sent, FRAG_SIZE, 8);
	alloc_count_reset();
	alloc_count_start();
	for (unsigned k = 0; k < 200; k++) {
		size_t size = k % 20 ? SHORT_SIZE : FRAG_SIZE;

		assert_int_equal(rmd_lcm_link_publish(other, PREFIX "N", sent, size), 0);
		assert_int_equal(link_wait(f->link, &m, 3000), 1);
		assert_int_equal(m.size, size);
	}
	n = alloc_count_stop();
	assert_int_equal(n, 0);
	rmd_lcm_link_free(other);
}

/* A test between setup() and teardown(): a link made for it. */
#define LINKED(f) cmocka_unit_test_setup_teardown(f, setup, teardown)

SUITE_MAIN("lcm_link", group_setup, NULL,
	   {
		   cmocka_unit_test(test_url_checked),
		   LINKED(test_lcm13_sends),
		   LINKED(test_lcm13_receives),
		   LINKED(test_lcm15_sends),
		   LINKED(test_lcm15_receives),
		   LINKED(test_own_datagrams_filtered),
		   LINKED(test_too_long_said),
		   cmocka_unit_test(test_memq_through_lcm),
		   LINKED(test_receive_and_publish_allocate_nothing),
	   })
