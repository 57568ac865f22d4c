// SPDX-License-Identifier: MIT
/*
 * LCM's udpm wire format, received (rmd/udpm_rx.h): short messages and
 * fragments as LCM 1.3's lcm_udpm_publish() sends them (hand-written vectors,
 * and a builder that splits a message the way it does), in order, out of
 * order and interleaved; and every malformed or inconsistent datagram
 * dropped with its reason counted: a repeated fragment, a count that
 * disagrees with the size, bytes past the size, a message that never
 * finishes, bad channels, sizes past the limit.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "harness/hex.h"
#include "harness/rng.h"
#include "rmd/udpm_rx.h"
#include "harness/suite.h"

/* Senders: (address, port) as sockaddr_in carries them; only their equality matters. */
#define A_ADDR 0x0100007fu
#define A_PORT 0x3930
#define B_PORT 0x3a30

/* Room for the largest message's datagrams at the smallest fragment size used. */
#define DG_MAX 80

struct dgram {
	unsigned char b[RMD_UDPM_PKT_MAX];
	size_t n;
};

static struct dgram dg[DG_MAX];
static struct rmd_udpm_rx rx;
static unsigned char payload[RMD_UDPM_MSG_MAX + 16];

/* An LC03 fragment header and what follows it, into d. */
static void fragment(struct dgram *d, uint32_t seqno, uint32_t size, uint32_t off, uint16_t no,
		     uint16_t count, const char *channel, const unsigned char *data, size_t len)
{
	size_t cl = channel ? strlen(channel) + 1 : 0;

	rmd_udpm_put_fragment_header(d->b, seqno, size, off, no, count);
	if (cl)
		memcpy(d->b + RMD_UDPM_LONG_HDR, channel, cl);
	memcpy(d->b + RMD_UDPM_LONG_HDR + cl, data, len);
	d->n = RMD_UDPM_LONG_HDR + cl + len;
}

/*
 * A message as lcm_udpm_publish() (LCM 1.3, lcm/lcm_udpm.c) sends it, with
 * `frag` bytes a fragment (LCM_FRAGMENT_MAX_PAYLOAD: 65487 on Linux, 1423 on
 * macOS): one LC02 datagram if channel, NUL and data fit a short message
 * (frag + 12 bytes, LCM_SHORT_MESSAGE_MAX_SIZE), else LC03 fragments of
 * `frag` bytes whose first carries the channel and NUL in that room.
 * Returns the number of datagrams in dg[].
 */
static unsigned lcm_publish_as(const char *channel, const unsigned char *data, uint32_t len,
			       uint32_t seqno, uint32_t frag)
{
	uint32_t cl = (uint32_t)strlen(channel) + 1, total = cl + len, off;
	unsigned n;

	if (total <= frag + 12) {
		rmd_udpm_put_short_header(dg[0].b, seqno);
		memcpy(dg[0].b + RMD_UDPM_SHORT_HDR, channel, cl);
		memcpy(dg[0].b + RMD_UDPM_SHORT_HDR + cl, data, len);
		dg[0].n = RMD_UDPM_SHORT_HDR + cl + len;
		return 1;
	}
	n = total / frag + !!(total % frag);
	assert_true(n <= DG_MAX);
	fragment(&dg[0], seqno, len, 0, 0, (uint16_t)n, channel, data, frag - cl);
	off = frag - cl;
	for (unsigned k = 1; k < n; k++) {
		uint32_t l = len - off < frag ? len - off : frag;

		fragment(&dg[k], seqno, len, off, (uint16_t)k, (uint16_t)n, NULL, data + off, l);
		off += l;
	}
	assert_int_equal(off, len);
	return n;
}

static enum rmd_udpm_verdict feed(uint16_t port, const struct dgram *d, struct rmd_udpm_msg *m)
{
	return rmd_udpm_rx_packet(&rx, A_ADDR, port, d->b, d->n, m);
}

/* Feed d, expect verdict v; named in the failure. */
#define EXPECT(port, d, v, m)                                                            \
	do {                                                                             \
		enum rmd_udpm_verdict got_ = feed(port, d, m);                           \
		if (got_ != (v))                                                         \
			fail_msg("%s:%d: %s, expected %s", __FILE__, __LINE__,           \
				 rmd_udpm_verdict_name(got_), rmd_udpm_verdict_name(v)); \
	} while (0)

static void assert_message(const struct rmd_udpm_msg *m, const char *channel,
			   const unsigned char *data, uint32_t size)
{
	assert_string_equal(m->channel, channel);
	assert_int_equal(m->size, size);
	if (size)
		assert_memory_equal(m->data, data, size);
}

static void fill(unsigned char *p, size_t n, uint64_t seed)
{
	for (size_t i = 0; i < n; i++)
		p[i] = (unsigned char)splitmix64(&seed);
}

static int setup(void **state)
{
	(void)state;
	memset(&rx, 0x5a, sizeof(rx)); /* init, not a zeroed struct, must make it usable */
	rmd_udpm_rx_init(&rx);
	return 0;
}

static uint64_t total_counted(void)
{
	uint64_t t = 0;

	for (unsigned v = 0; v < RMD_UDPM_VERDICTS; v++)
		t += rx.n[v];
	return t;
}

/* LC02 vectors written out by hand: "FOO" with 01 02 03, and an empty payload. */
static void test_short_message(void **state)
{
	struct dgram d;
	struct rmd_udpm_msg m;
	static const unsigned char three[] = { 1, 2, 3 };

	(void)state;
	d.n = bytes_from("4C433032"
			 "00000007"
			 "464F4F00"
			 "010203",
			 d.b, sizeof(d.b));
	EXPECT(A_PORT, &d, RMD_UDPM_MESSAGE, &m);
	assert_message(&m, "FOO", three, 3);
	assert_ptr_equal(m.data, d.b + 12); /* in place: no copy */

	d.n = bytes_from("4C433032"
			 "00000001"
			 "4100",
			 d.b, sizeof(d.b));
	EXPECT(A_PORT, &d, RMD_UDPM_MESSAGE, &m);
	assert_message(&m, "A", NULL, 0);

	/* the builder makes the same bytes */
	d.n = bytes_from("4C433032"
			 "00000007"
			 "464F4F00"
			 "010203",
			 d.b, sizeof(d.b));
	assert_int_equal(lcm_publish_as("FOO", three, 3, 7, 65487), 1);
	assert_int_equal(dg[0].n, d.n);
	assert_memory_equal(dg[0].b, d.b, d.n);
	assert_int_equal(rx.n[RMD_UDPM_MESSAGE], 2);
	assert_int_equal(total_counted(), 2);
}

/* Datagrams that are not LCM's, or name no usable channel: dropped, each counted. */
static void test_bad_datagrams(void **state)
{
	struct dgram d;
	struct rmd_udpm_msg m;
	char ch[RMD_UDPM_CHANNEL_MAX + 2];

	(void)state;
	d.n = bytes_from("4C433034"
			 "00000001"
			 "4100",
			 d.b, sizeof(d.b)); /* "LC04" */
	EXPECT(A_PORT, &d, RMD_UDPM_BAD_MAGIC, &m);
	d.n = bytes_from("4C4330320000", d.b, sizeof(d.b)); /* shorter than the header */
	EXPECT(A_PORT, &d, RMD_UDPM_BAD_MAGIC, &m);
	d.n = 0;
	EXPECT(A_PORT, &d, RMD_UDPM_BAD_MAGIC, &m);
	/* an LC03 header cut short */
	d.n = bytes_from("4C433033"
			 "00000001"
			 "00000100"
			 "00000000"
			 "0000",
			 d.b, sizeof(d.b));
	EXPECT(A_PORT, &d, RMD_UDPM_BAD_MAGIC, &m);
	d.n = bytes_from("4C433032"
			 "00000001"
			 "414243",
			 d.b, sizeof(d.b)); /* no NUL */
	EXPECT(A_PORT, &d, RMD_UDPM_BAD_CHANNEL, &m);
	assert_string_equal(m.channel, "");
	assert_null(m.data);

	/* 63 characters is LCM's longest channel; 64 is refused */
	memset(ch, 'C', sizeof(ch));
	ch[RMD_UDPM_CHANNEL_MAX] = '\0';
	lcm_publish_as(ch, (const unsigned char *)"x", 1, 1, 65487);
	EXPECT(A_PORT, &dg[0], RMD_UDPM_MESSAGE, &m);
	assert_int_equal(strlen(m.channel), RMD_UDPM_CHANNEL_MAX);
	ch[RMD_UDPM_CHANNEL_MAX] = 'C';
	ch[RMD_UDPM_CHANNEL_MAX + 1] = '\0';
	lcm_publish_as(ch, (const unsigned char *)"x", 1, 1, 65487);
	EXPECT(A_PORT, &dg[0], RMD_UDPM_BAD_CHANNEL, &m);

	/* a first fragment without a NUL, or with a 64-character channel */
	fragment(&d, 1, 10, 0, 0, 2, NULL, (const unsigned char *)"ABCDEFGH", 8);
	EXPECT(A_PORT, &d, RMD_UDPM_BAD_CHANNEL, &m);
	fragment(&d, 1, 10, 0, 0, 2, ch, (const unsigned char *)"ABCDEFGH", 8);
	EXPECT(A_PORT, &d, RMD_UDPM_BAD_CHANNEL, &m);

	assert_int_equal(rx.n[RMD_UDPM_BAD_MAGIC], 4);
	assert_int_equal(rx.n[RMD_UDPM_BAD_CHANNEL], 4);
	assert_int_equal(rx.n[RMD_UDPM_MESSAGE], 1);
	assert_int_equal(total_counted(), 9);
}

/* LC03 written out by hand: 6 bytes on "CH" in two fragments, 3 + 3. */
static void test_fragment_vector(void **state)
{
	struct dgram d[2];
	struct rmd_udpm_msg m;

	(void)state;
	d[0].n = bytes_from("4C433033"
			    "0000002A"
			    "00000006"
			    "00000000"
			    "0000"
			    "0002"
			    "434800"
			    "AABBCC",
			    d[0].b, sizeof(d[0].b));
	d[1].n = bytes_from("4C433033"
			    "0000002A"
			    "00000006"
			    "00000003"
			    "0001"
			    "0002"
			    "DDEEFF",
			    d[1].b, sizeof(d[1].b));
	EXPECT(A_PORT, &d[0], RMD_UDPM_PENDING, &m);
	EXPECT(A_PORT, &d[1], RMD_UDPM_MESSAGE, &m);
	assert_message(&m, "CH", (const unsigned char *)"\xAA\xBB\xCC\xDD\xEE\xFF", 6);

	/* rmd_udpm_put_fragment_header() writes the same bytes */
	fragment(&dg[0], 42, 6, 0, 0, 2, "CH", (const unsigned char *)"\xAA\xBB\xCC", 3);
	fragment(&dg[1], 42, 6, 3, 1, 2, NULL, (const unsigned char *)"\xDD\xEE\xFF", 3);
	for (unsigned k = 0; k < 2; k++) {
		assert_int_equal(dg[k].n, d[k].n);
		assert_memory_equal(dg[k].b, d[k].b, d[k].n);
	}
}

/*
 * Long messages as LCM splits them: in order (macOS's 1423-byte fragments;
 * Linux's 65487, where the largest short message fills UDP's largest
 * datagram and the largest message here takes two), every fragment but the
 * last pending.
 */
static void test_long_in_order(void **state)
{
	struct rmd_udpm_msg m;
	/* RMD_COMMAND and its NUL take 12 bytes of the first fragment or the short message */
	static const struct {
		uint32_t len, frag;
		unsigned n;
	} cases[] = { { 5000, 1423, 4 },
		      { 65487, 65487, 1 } /* UDP's largest */,
		      { 65488, 65487, 2 },
		      { RMD_UDPM_MSG_MAX, 65487, 2 },
		      { RMD_UDPM_MSG_MAX, 1423, 47 },
		      { 1424, 1423, 2 } };

	(void)state;
	for (unsigned c = 0; c < sizeof(cases) / sizeof(cases[0]); c++) {
		unsigned n;

		fill(payload, cases[c].len, c);
		n = lcm_publish_as("RMD_COMMAND", payload, cases[c].len, 100 + c, cases[c].frag);
		assert_int_equal(n, cases[c].n);
		for (unsigned k = 0; k + 1 < n; k++)
			EXPECT(A_PORT, &dg[k], RMD_UDPM_PENDING, &m);
		EXPECT(A_PORT, &dg[n - 1], RMD_UDPM_MESSAGE, &m);
		assert_message(&m, "RMD_COMMAND", payload, cases[c].len);
	}
	assert_int_equal(rx.abandoned, 0);
}

/* Any order goes together, the first fragment last included. */
static void test_long_out_of_order(void **state)
{
	struct rmd_udpm_msg m;
	uint64_t seed = 11;

	(void)state;
	fill(payload, 6000, 3);
	for (unsigned round = 0; round < 50; round++) {
		unsigned n = lcm_publish_as("CH", payload, 6000, round, 1000), order[DG_MAX];

		assert_int_equal(n, 7);
		for (unsigned k = 0; k < n; k++)
			order[k] = k;
		if (round == 0) { /* reversed: the channel comes last */
			for (unsigned k = 0; k < n; k++)
				order[k] = n - 1 - k;
		} else {
			for (unsigned k = n - 1; k > 0; k--) {
				unsigned j = (unsigned)(splitmix64(&seed) % (k + 1)), t = order[k];

				order[k] = order[j];
				order[j] = t;
			}
		}
		for (unsigned k = 0; k + 1 < n; k++)
			EXPECT(A_PORT, &dg[order[k]], RMD_UDPM_PENDING, &m);
		EXPECT(A_PORT, &dg[order[n - 1]], RMD_UDPM_MESSAGE, &m);
		assert_message(&m, "CH", payload, 6000);
	}
	assert_int_equal(rx.abandoned, 0);
}

/* Two senders' fragments interleaved, even with the same sequence number: both whole. */
static void test_two_senders_interleaved(void **state)
{
	static struct dgram a[8], b[8];
	static unsigned char pa[4000], pb[4000];
	struct rmd_udpm_msg m;
	unsigned na, nb;

	(void)state;
	fill(pa, sizeof(pa), 1);
	fill(pb, sizeof(pb), 2);
	na = lcm_publish_as("RMD_COMMAND", pa, sizeof(pa), 9, 1423);
	memcpy(a, dg, sizeof(a));
	nb = lcm_publish_as("RMD_CONFIG_REQUEST", pb, sizeof(pb), 9, 1423);
	memcpy(b, dg, sizeof(b));
	assert_int_equal(na, 3);
	assert_int_equal(nb, 3);
	for (unsigned k = 0; k < 2; k++) {
		EXPECT(A_PORT, &a[k], RMD_UDPM_PENDING, &m);
		EXPECT(B_PORT, &b[k], RMD_UDPM_PENDING, &m);
	}
	EXPECT(B_PORT, &b[2], RMD_UDPM_MESSAGE, &m);
	assert_message(&m, "RMD_CONFIG_REQUEST", pb, sizeof(pb));
	EXPECT(A_PORT, &a[2], RMD_UDPM_MESSAGE, &m);
	assert_message(&m, "RMD_COMMAND", pa, sizeof(pa));
	assert_int_equal(rx.abandoned, 0);
}

/*
 * A repeated fragment is not another one: LCM 1.3 counts fragments down,
 * so 0, 1, 1 of three completed a message whose third part was whatever the
 * buffer held.  Here the repeat is dropped and the message waits for 2.
 */
static void test_duplicate_fragment(void **state)
{
	struct rmd_udpm_msg m;
	unsigned n;

	(void)state;
	memset(payload, 0xEE, 3000); /* an earlier message's bytes, in the slot after it */
	n = lcm_publish_as("CH", payload, 3000, 1, 1000);
	for (unsigned k = 0; k < n; k++)
		feed(A_PORT, &dg[k], &m);
	assert_int_equal(rx.n[RMD_UDPM_MESSAGE], 1);

	fill(payload, 3000, 5);
	assert_int_equal(lcm_publish_as("CH", payload, 3000, 2, 1000), 4);
	EXPECT(A_PORT, &dg[0], RMD_UDPM_PENDING, &m);
	EXPECT(A_PORT, &dg[1], RMD_UDPM_PENDING, &m);
	EXPECT(A_PORT, &dg[1], RMD_UDPM_DUPLICATE, &m);
	EXPECT(A_PORT, &dg[0], RMD_UDPM_DUPLICATE, &m);
	EXPECT(A_PORT, &dg[3], RMD_UDPM_PENDING, &m);
	EXPECT(A_PORT, &dg[3], RMD_UDPM_DUPLICATE, &m);
	EXPECT(A_PORT, &dg[2], RMD_UDPM_MESSAGE, &m);
	assert_message(&m, "CH", payload, 3000);
	assert_int_equal(rx.n[RMD_UDPM_DUPLICATE], 3);
	/* after it is whole, a late repeat starts a message of its own, which never completes */
	EXPECT(A_PORT, &dg[2], RMD_UDPM_PENDING, &m);
}

/*
 * Counts and ranges that disagree with the size: a message of one fragment
 * that covers half of it, fragments that overlap, a fragment number past
 * the count, a count of 0 or more than a message can have, a count that
 * changes, bytes past the size (with an offset that would wrap 32 bits).
 */
static void test_inconsistent_fragments(void **state)
{
	struct dgram d;
	struct rmd_udpm_msg m;

	(void)state;
	fill(payload, 200, 8);
	fragment(&d, 1, 200, 0, 0, 1, "CH", payload, 100); /* one of one, half the size */
	EXPECT(A_PORT, &d, RMD_UDPM_HOLES, &m);
	assert_null(m.data);

	/* two of two, but the second overlaps the first and leaves 100..119 unsent */
	fragment(&d, 2, 200, 0, 0, 2, "CH", payload, 100);
	EXPECT(A_PORT, &d, RMD_UDPM_PENDING, &m);
	fragment(&d, 2, 200, 120, 1, 2, NULL, payload + 120, 80);
	EXPECT(A_PORT, &d, RMD_UDPM_HOLES, &m);
	/* two of two that cover it, but in the wrong number order */
	fragment(&d, 3, 200, 100, 0, 2, "CH", payload + 100, 100);
	EXPECT(A_PORT, &d, RMD_UDPM_PENDING, &m);
	fragment(&d, 3, 200, 0, 1, 2, NULL, payload, 100);
	EXPECT(A_PORT, &d, RMD_UDPM_HOLES, &m);
	/* more bytes than the size */
	fragment(&d, 4, 200, 0, 0, 2, "CH", payload, 100);
	EXPECT(A_PORT, &d, RMD_UDPM_PENDING, &m);
	fragment(&d, 4, 200, 100, 1, 2, NULL, payload, 101);
	EXPECT(A_PORT, &d, RMD_UDPM_BAD_FRAGMENT, &m);
	fragment(&d, 4, 200, 0xFFFFFFF0u, 1, 2, NULL, payload, 100);
	EXPECT(A_PORT, &d, RMD_UDPM_BAD_FRAGMENT, &m);
	fragment(&d, 4, 200, 100, 2, 2, NULL, payload + 100, 100); /* number past the count */
	EXPECT(A_PORT, &d, RMD_UDPM_BAD_FRAGMENT, &m);
	fragment(&d, 4, 200, 100, 1, 3, NULL, payload + 100, 100); /* another count */
	EXPECT(A_PORT, &d, RMD_UDPM_BAD_FRAGMENT, &m);
	fragment(&d, 4, 200, 100, 1, 0, NULL, payload + 100, 100);
	EXPECT(A_PORT, &d, RMD_UDPM_BAD_FRAGMENT, &m);
	fragment(&d, 5, 200, 100, 1, RMD_UDPM_FRAGS_MAX + 1, NULL, payload + 100, 100);
	EXPECT(A_PORT, &d, RMD_UDPM_BAD_FRAGMENT, &m);
	/* message 4 was left as it was: its right second fragment completes it */
	fragment(&d, 4, 200, 100, 1, 2, NULL, payload + 100, 100);
	EXPECT(A_PORT, &d, RMD_UDPM_MESSAGE, &m);
	assert_message(&m, "CH", payload, 200);
	assert_int_equal(rx.n[RMD_UDPM_HOLES], 3);
	assert_int_equal(rx.n[RMD_UDPM_BAD_FRAGMENT], 6);

	/* RMD_UDPM_FRAGS_MAX fragments of one byte each make a message */
	for (unsigned k = 0; k < RMD_UDPM_FRAGS_MAX; k++) {
		fragment(&d, 6, RMD_UDPM_FRAGS_MAX, k, (uint16_t)k, RMD_UDPM_FRAGS_MAX,
			 k ? NULL : "CH", payload + k, 1);
		EXPECT(A_PORT, &d, k + 1 < RMD_UDPM_FRAGS_MAX ? RMD_UDPM_PENDING : RMD_UDPM_MESSAGE,
		       &m);
	}
	assert_message(&m, "CH", payload, RMD_UDPM_FRAGS_MAX);
}

/* Sizes past RMD_UDPM_MSG_MAX: refused at once, naming the channel when the datagram does. */
static void test_too_long(void **state)
{
	struct dgram d;
	struct rmd_udpm_msg m;

	(void)state;
	fragment(&d, 1, RMD_UDPM_MSG_MAX + 1, 0, 0, 2, "RMD_COMMAND", payload, 100);
	EXPECT(A_PORT, &d, RMD_UDPM_TOO_LONG, &m);
	assert_string_equal(m.channel, "RMD_COMMAND");
	assert_int_equal(m.size, RMD_UDPM_MSG_MAX + 1);
	assert_null(m.data);
	fragment(&d, 1, 0xFFFFFFFFu, 100, 1, 2, NULL, payload, 100);
	EXPECT(A_PORT, &d, RMD_UDPM_TOO_LONG, &m);
	assert_string_equal(m.channel, "");
	assert_int_equal(m.size, 0xFFFFFFFFu);
	/* a datagram longer than any the socket gives */
	assert_int_equal(rmd_udpm_rx_packet(&rx, A_ADDR, A_PORT, dg[0].b, RMD_UDPM_PKT_MAX + 1, &m),
			 RMD_UDPM_TOO_LONG);
	assert_int_equal(rx.n[RMD_UDPM_TOO_LONG], 3);
	for (unsigned k = 0; k < RMD_UDPM_SLOTS; k++)
		assert_false(rx.slot[k].used); /* nothing was kept */
}

/*
 * Messages that never finish: a sender's next message takes its own slot
 * (LCM sends fragments back to back), and when every slot is busy the one
 * touched longest ago goes; each counted as abandoned, and a late fragment
 * of it completes nothing.
 */
static void test_unfinished_messages(void **state)
{
	struct rmd_udpm_msg m;
	unsigned n;

	(void)state;
	fill(payload, 3000, 4);
	n = lcm_publish_as("CH", payload, 3000, 1, 1000);
	assert_int_equal(n, 4);
	EXPECT(A_PORT, &dg[0], RMD_UDPM_PENDING, &m);
	EXPECT(A_PORT, &dg[1], RMD_UDPM_PENDING, &m);
	/* the sender's next message: the first is given up */
	n = lcm_publish_as("CH", payload, 3000, 2, 1000);
	for (unsigned k = 0; k + 1 < n; k++)
		EXPECT(A_PORT, &dg[k], RMD_UDPM_PENDING, &m);
	assert_int_equal(rx.abandoned, 1);
	/* every other slot taken by other senders' unfinished messages, then one more */
	for (uint16_t port = 1; port <= RMD_UDPM_SLOTS; port++)
		EXPECT(port, &dg[0], RMD_UDPM_PENDING, &m);
	assert_int_equal(rx.abandoned, 2); /* A's second, the oldest */
	/* A's last fragment now starts a new message, which waits for the rest */
	EXPECT(A_PORT, &dg[n - 1], RMD_UDPM_PENDING, &m);
	assert_int_equal(rx.abandoned, 3);
	for (unsigned k = 0; k < RMD_UDPM_SLOTS; k++)
		assert_true(rx.slot[k].used);
	/* and whole messages still go through: short ones take no slot */
	lcm_publish_as("CH", payload, 10, 3, 1000);
	EXPECT(A_PORT, &dg[0], RMD_UDPM_MESSAGE, &m);
	assert_message(&m, "CH", payload, 10);
}

SUITE_MAIN("udpm_rx", NULL, NULL,
	   {
		   cmocka_unit_test_setup(test_short_message, setup),
		   cmocka_unit_test_setup(test_bad_datagrams, setup),
		   cmocka_unit_test_setup(test_fragment_vector, setup),
		   cmocka_unit_test_setup(test_long_in_order, setup),
		   cmocka_unit_test_setup(test_long_out_of_order, setup),
		   cmocka_unit_test_setup(test_two_senders_interleaved, setup),
		   cmocka_unit_test_setup(test_duplicate_fragment, setup),
		   cmocka_unit_test_setup(test_inconsistent_fragments, setup),
		   cmocka_unit_test_setup(test_too_long, setup),
		   cmocka_unit_test_setup(test_unfinished_messages, setup),
	   })
