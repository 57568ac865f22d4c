// SPDX-License-Identifier: MIT
/*
 * RS485 transport tests on a real pseudo-terminal pair: the bus opens the
 * slave path as a user opens /dev/ttyUSB0, and the master side plays the
 * motors, either from a thread (struct fake: up to three motors answering
 * with the manual's examples after a set delay) or byte by byte from the
 * test itself.  Nothing sleeps for a result: every wait polls a descriptor
 * against a bounded deadline.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <sys/stat.h>
#include <sys/sysmacros.h>

#include <cmocka.h>

#include "rmd/time.h"
#include "rmd/bus_open.h"
#include "rmd/bus_rs485.h"
#include "rmd/bus_sim.h"
#include "rmd/bus_socketcan.h"
#include "rmd/rs485.h"
#include "harness/suite.h"

#define MS 1000000LL
#define LIMIT_NS (10000 * MS) /* no test waits longer than this for anything */
/*
 * Reply timeouts.  The fake motors run in a thread of a loaded machine (a
 * VM whose wake-up latency peaks near 50 ms): an answer the test needs gets
 * ANSWER_NS; a test that needs a timeout and an answer on the same bus uses
 * SHORT_NS, still well above that latency.
 */
#define ANSWER_NS (2000 * MS)
#define SHORT_NS (150 * MS)
#define MAX_SEEN 64

/* Requests queued or in flight: the gauge of rmd_rs485_stats(). */
static unsigned pending_of(const struct rmd_bus *bus)
{
	struct rmd_rs485_stats xs;

	assert_int_equal(rmd_rs485_stats(bus, &xs), 0);
	return (unsigned)xs.pending;
}

/* V3 §2.12.4: 0x9A reply, 50 °C, brake released, 48.5 V, low-voltage error. */
static const uint8_t status1_reply[RMD_FRAME_LEN] = {
	0x9A, 0x32, 0x00, 0x01, 0xE5, 0x01, 0x04, 0x00
};
static const uint8_t status1_req[RMD_FRAME_LEN] = { 0x9A };
static const uint8_t off_req[RMD_FRAME_LEN] = { 0x80 };

static struct timespec ts_of(int64_t ns)
{
	struct timespec ts = { .tv_sec = ns / 1000000000LL, .tv_nsec = ns % 1000000000LL };

	return ts;
}

/* Motors on the master side of the pty, run by a thread. */
struct fake {
	int master;
	uint64_t present;	/* bit n: motor n answers */
	int64_t delay_ns;	/* request to reply */
	unsigned corrupt_first; /* replies sent with a broken CRC */
	const uint8_t *garbage; /* written before every reply */
	size_t garbage_len;
	bool echo; /* hear our own request back, like a two-wire adapter */

	pthread_t thread;
	atomic_bool stop;
	/* Written by the thread, read after the join. */
	unsigned requests;
	unsigned overlaps; /* requests that came while an answer was owed */
	unsigned bad_bytes;
	uint8_t seen_id[MAX_SEEN];
	uint8_t seen_cmd[MAX_SEEN];
	int64_t seen_ns[MAX_SEEN];
};

static void fake_write(struct fake *fk, const uint8_t *buf, size_t len)
{
	while (len) {
		ssize_t w = write(fk->master, buf, len);

		if (w < 0) {
			if (errno == EINTR || errno == EAGAIN)
				continue;
			return;
		}
		buf += w;
		len -= (size_t)w;
	}
}

static void fake_reply(struct fake *fk, uint8_t id, const uint8_t data[RMD_FRAME_LEN])
{
	uint8_t wire[RMD_RS485_FRAME_LEN];

	rmd_rs485_build(id, data, wire, sizeof(wire));
	if (fk->corrupt_first) {
		fk->corrupt_first--;
		wire[RMD_RS485_FRAME_LEN - 1] ^= 0x5A;
	}
	if (fk->garbage_len)
		fake_write(fk, fk->garbage, fk->garbage_len);
	fake_write(fk, wire, sizeof(wire));
}

/* What the motors owe: one request's answers, written at due_ns. */
#define OWED_MAX 8 /* a power of two */
struct owed {
	int64_t due_ns;
	uint8_t id;
	uint8_t data[RMD_FRAME_LEN];
};

static void fake_answer(struct fake *fk, const struct owed *o)
{
	const uint8_t *data = o->data[0] == 0x9A ? status1_reply : o->data;

	if (o->id != RMD_RS485_BROADCAST) {
		if (fk->present & (1ull << o->id))
			fake_reply(fk, o->id, data);
		return;
	}
	if (o->data[0] == 0x79) { /* V3 §7.3: the ID command answers from 0xCD */
		fake_reply(fk, RMD_RS485_BROADCAST, o->data);
		return;
	}
	for (uint8_t id = 1; id <= RMD_MAX_MOTORS; id++) /* V3 §6.2: each from its own ID */
		if (fk->present & (1ull << id))
			fake_reply(fk, id, data);
}

static void *fake_run(void *arg)
{
	struct fake *fk = arg;
	uint8_t buf[512];
	size_t len = 0;
	struct owed owed[OWED_MAX];
	unsigned oh = 0, ot = 0; /* answers owed: owed[oh..ot) */

	while (!atomic_load(&fk->stop)) {
		struct pollfd pfd = { .fd = fk->master, .events = POLLIN };
		int64_t wait = 5 * MS;
		struct timespec ts;
		ssize_t got;

		if (oh != ot) {
			wait = owed[oh % OWED_MAX].due_ns - rmd_now_ns();
			if (wait < 0)
				wait = 0;
		}
		ts = ts_of(wait);
		if (ppoll(&pfd, 1, &ts, NULL) > 0 && (pfd.revents & POLLIN)) {
			got = read(fk->master, buf + len, sizeof(buf) - len);
			if (got > 0)
				len += (size_t)got;
		}
		for (;;) {
			uint8_t id, data[RMD_FRAME_LEN];
			int r = rmd_rs485_parse(buf, len, &id, data);

			if (r == -EAGAIN)
				break;
			if (r < 0) {
				fk->bad_bytes++;
				memmove(buf, buf + 1, --len);
				continue;
			}
			memmove(buf, buf + r, len -= (size_t)r);
			if (fk->requests < MAX_SEEN) {
				fk->seen_id[fk->requests] = id;
				fk->seen_cmd[fk->requests] = data[0];
				fk->seen_ns[fk->requests] = rmd_now_ns();
			}
			fk->requests++;
			if (oh != ot)
				fk->overlaps++;
			if (ot - oh < OWED_MAX) {
				struct owed *o = &owed[ot++ % OWED_MAX];

				o->due_ns = rmd_now_ns() + fk->delay_ns;
				o->id = id;
				memcpy(o->data, data, sizeof(o->data));
			}
			if (fk->echo) {
				uint8_t wire[RMD_RS485_FRAME_LEN];

				rmd_rs485_build(id, data, wire, sizeof(wire));
				fake_write(fk, wire, sizeof(wire));
			}
		}
		while (oh != ot && rmd_now_ns() >= owed[oh % OWED_MAX].due_ns)
			fake_answer(fk, &owed[oh++ % OWED_MAX]);
	}
	return NULL;
}

/*
 * The one fake of the running test, outside its stack frame so that the
 * teardown can still stop the thread after a failed assertion.
 */
static struct fake the_fake;
static bool fake_running;

static struct fake *fake_new(struct fake tmpl)
{
	the_fake = tmpl;
	return &the_fake;
}

static void fake_start(struct fake *fk)
{
	atomic_store(&fk->stop, false);
	assert_int_equal(pthread_create(&fk->thread, NULL, fake_run, fk), 0);
	fake_running = true;
}

static void fake_stop(struct fake *fk)
{
	atomic_store(&fk->stop, true);
	fake_running = false;
	assert_int_equal(pthread_join(fk->thread, NULL), 0);
}

static int teardown(void **state)
{
	(void)state;
	if (fake_running)
		fake_stop(&the_fake);
	return 0;
}

/* A pty pair: the master fd for the test, the slave's path for the bus. */
struct pty {
	int master;
	char path[64];
};

static void pty_open(struct pty *pt)
{
	pt->master = posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC);
	assert_true(pt->master >= 0);
	assert_int_equal(grantpt(pt->master), 0);
	assert_int_equal(unlockpt(pt->master), 0);
	assert_int_equal(ptsname_r(pt->master, pt->path, sizeof(pt->path)), 0);
}

static void open_bus(struct rmd_bus *bus, struct pty *pt, const struct rmd_rs485_opts *opts)
{
	char err[256];
	int r;

	pty_open(pt);
	r = rmd_rs485_open(bus, pt->path, opts, err, sizeof(err));
	if (r < 0)
		fail_msg("rmd_rs485_open(%s): %d: %s", pt->path, r, err);
	assert_string_equal(bus->ops->kind, "rs485");
}

/* open_bus() with the fake motors fk answering on the other end. */
static void open_bus_fake(struct rmd_bus *bus, struct pty *pt, const struct rmd_rs485_opts *opts,
			  struct fake *fk)
{
	open_bus(bus, pt, opts);
	fk->master = pt->master;
	fake_start(fk);
}

/* One test's line: the bus, its pseudo-terminal, what it received, its counters. */
struct link {
	struct rmd_bus bus;
	struct pty pt;
	struct rmd_bus_rx rx[8];
	struct rmd_rs485_stats xs;
};

/* The line open with the fake motors fk, and frames f[0..n) sent at once: when. */
static int64_t link_start(struct link *l, const struct rmd_rs485_opts *opts, struct fake *fk,
			  const struct rmd_frame *f, unsigned n)
{
	int64_t t0;

	open_bus_fake(&l->bus, &l->pt, opts, fk);
	t0 = rmd_now_ns();
	assert_int_equal(rmd_bus_send(&l->bus, f, n, t0), (int)n);
	return t0;
}

static void close_bus(struct rmd_bus *bus, struct pty *pt)
{
	rmd_bus_close(bus);
	close(pt->master);
}

static struct rmd_frame frame(uint32_t can_id, const uint8_t data[RMD_FRAME_LEN])
{
	struct rmd_frame f = { .can_id = can_id, .len = RMD_FRAME_LEN };

	memcpy(f.data, data, RMD_FRAME_LEN);
	return f;
}

/*
 * Drive the bus until it has returned `want` frames and holds at most
 * `pending` requests, or until limit_ns: wait on its fd, but no longer than
 * its own deadline.  Returns the number of frames stored in out.
 */
static unsigned drive_to(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, unsigned want,
			 unsigned pending, int64_t limit_ns)
{
	unsigned n = 0;

	for (;;) {
		struct pollfd pfd = { .fd = rmd_bus_fd(bus), .events = POLLIN };
		int64_t t = rmd_now_ns(), until = limit_ns;
		struct timespec ts;
		int r;

		if ((n >= want && pending_of(bus) <= pending) || t >= limit_ns)
			return n;
		if (rmd_bus_next_due_ns(bus) < until)
			until = rmd_bus_next_due_ns(bus);
		ts = ts_of(until > t ? until - t : 0);
		ppoll(&pfd, 1, &ts, NULL);
		r = rmd_bus_recv(bus, out + n, max - n, rmd_now_ns());
		assert_true(r >= 0);
		n += (unsigned)r;
	}
}

/* drive_to() until every request is answered or timed out. */
static unsigned drive(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, unsigned want,
		      int64_t limit_ns)
{
	return drive_to(bus, out, max, want, 0, limit_ns);
}

/*
 * The whole exchange: open the bus with fk behind it, send n frames, drive
 * until `want` replies came, stop fk.  The bus stays open for the checks.
 */
static void exchange(struct rmd_bus *bus, struct pty *pt, const struct rmd_rs485_opts *opts,
		     struct fake *fk, const struct rmd_frame *f, unsigned n, struct rmd_bus_rx *rx,
		     unsigned max, unsigned want)
{
	open_bus_fake(bus, pt, opts, fk);
	assert_int_equal(rmd_bus_send(bus, f, n, rmd_now_ns()), n);
	assert_int_equal(drive(bus, rx, max, want, rmd_now_ns() + LIMIT_NS), want);
	fake_stop(fk);
}

/* Until fd is readable, within LIMIT_NS. */
static void wait_readable(int fd)
{
	struct pollfd pfd = { .fd = fd, .events = POLLIN };
	struct timespec ts = ts_of(LIMIT_NS);

	assert_int_equal(ppoll(&pfd, 1, &ts, NULL), 1);
}

/* Read exactly len bytes the bus wrote, within LIMIT_NS. */
static void master_read(int master, uint8_t *buf, size_t len)
{
	int64_t limit = rmd_now_ns() + LIMIT_NS;

	while (len) {
		struct pollfd pfd = { .fd = master, .events = POLLIN };
		int64_t t = rmd_now_ns();
		struct timespec ts;
		ssize_t got;

		if (t >= limit)
			fail_msg("the bus wrote %zu bytes too few", len);
		ts = ts_of(limit - t);
		if (ppoll(&pfd, 1, &ts, NULL) <= 0)
			continue;
		got = read(master, buf, len);
		if (got > 0) {
			buf += got;
			len -= (size_t)got;
		}
	}
}

/* Nothing more from the bus within wait_ns. */
static void master_quiet(int master, int64_t wait_ns)
{
	struct pollfd pfd = { .fd = master, .events = POLLIN };
	struct timespec ts = ts_of(wait_ns);

	assert_int_equal(ppoll(&pfd, 1, &ts, NULL), 0);
}

static void master_write_frame(int master, uint8_t id, const uint8_t data[RMD_FRAME_LEN])
{
	uint8_t wire[RMD_RS485_FRAME_LEN];

	assert_int_equal(rmd_rs485_build(id, data, wire, sizeof(wire)), RMD_RS485_FRAME_LEN);
	assert_int_equal(write(master, wire, sizeof(wire)), sizeof(wire));
}

static void assert_rx(const struct rmd_bus_rx *rx, uint32_t can_id,
		      const uint8_t data[RMD_FRAME_LEN])
{
	if (rx->f.can_id != can_id)
		fail_msg("got 0x%03x, want 0x%03x", rx->f.can_id, can_id);
	assert_int_equal(rx->f.len, RMD_FRAME_LEN);
	assert_memory_equal(rx->f.data, data, RMD_FRAME_LEN);
}

static void test_frame_time(void **state)
{
	(void)state;
	/* 13 bytes of 10 bits. */
	assert_int_equal(rmd_rs485_frame_ns(1000000), 130000);
	assert_int_equal(rmd_rs485_frame_ns(2000000), 65000);
	assert_int_equal(rmd_rs485_frame_ns(115200), 1128473);
	assert_int_equal(rmd_rs485_frame_ns(0), 0);
}

static void test_open_errors(void **state)
{
	struct rmd_rs485_opts opts = { .baud = 9600 };
	struct rmd_bus bus = { 0 };
	struct pty pt;
	char err[256];

	(void)state;
	pty_open(&pt);
	assert_int_equal(rmd_rs485_open(&bus, pt.path, &opts, err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, pt.path));
	assert_non_null(strstr(err, "115200, 500000, 1000000, 1500000 or 2000000"));
	assert_null(bus.ops);

	opts.baud = 1000000;
	assert_int_equal(rmd_rs485_open(&bus, pt.path, NULL, err, sizeof(err)), -EINVAL);
	assert_int_equal(rmd_rs485_open(&bus, "/dev/ttyRMDnone", &opts, err, sizeof(err)), -ENOENT);
	assert_non_null(strstr(err, "/dev/ttyRMDnone: no such device"));
	assert_int_equal(rmd_rs485_open(&bus, "/dev/null", &opts, err, sizeof(err)), -ENOTTY);
	assert_string_equal(err, "/dev/null: not a serial port");
	opts.reply_timeout_ns = -1;
	assert_int_equal(rmd_rs485_open(&bus, pt.path, &opts, err, sizeof(err)), -EINVAL);
	assert_null(bus.ops);
	close(pt.master);
}

/* The pty has no RS485 mode: the open succeeds with a notice; 2 Mbit/s really is set. */
static void test_open_pty(void **state)
{
	struct rmd_rs485_opts opts = { .baud = 2000000 };
	struct rmd_bus bus;
	struct termios tios;
	struct pty pt;
	char err[256];

	(void)state;
	pty_open(&pt);
	assert_int_equal(rmd_rs485_open(&bus, pt.path, &opts, err, sizeof(err)), 0);
	assert_non_null(strstr(err, pt.path));
	assert_non_null(strstr(err, "pseudo-terminal"));
	assert_string_equal(bus.name, pt.path);
	assert_true(rmd_bus_fd(&bus) >= 0);
	assert_int_equal(tcgetattr(rmd_bus_fd(&bus), &tios), 0);
	assert_true(cfgetospeed(&tios) == B2000000);
	assert_true(cfgetispeed(&tios) == B2000000);
	/* V3 §1.2.1 default: 2 ms turnaround + request and reply wire time. */
	assert_int_equal(rmd_bus_caps(&bus)->reply_timeout_ns, 2000000 + 2 * 65000);
	assert_int_equal(rmd_bus_next_due_ns(&bus), INT64_MAX);
	close_bus(&bus, &pt);
	assert_null(bus.ops);
	rmd_bus_close(&bus); /* twice: a no-op */
}

static void test_round_trip(void **state)
{
	struct rmd_rs485_opts opts = { .baud = 1000000, .reply_timeout_ns = ANSWER_NS };
	struct fake *fk = fake_new((struct fake){ .present = 1u << 1 });
	struct rmd_frame f = frame(0x141, status1_req);
	struct link l;
	int64_t t0, t1;

	(void)state;
	t0 = link_start(&l, &opts, fk, &f, 1);
	assert_int_equal(pending_of(&l.bus), 1);
	assert_int_equal(rmd_bus_next_due_ns(&l.bus), t0 + ANSWER_NS);
	assert_int_equal(drive(&l.bus, l.rx, 4, 1, t0 + LIMIT_NS), 1);
	t1 = rmd_now_ns();
	fake_stop(fk);

	assert_rx(&l.rx[0], 0x241, status1_reply);
	assert_true(l.rx[0].t_ns > t0 && l.rx[0].t_ns <= t1);
	assert_int_equal(fk->requests, 1);
	assert_int_equal(fk->seen_id[0], 1);
	assert_int_equal(fk->seen_cmd[0], 0x9A);
	assert_int_equal(fk->bad_bytes, 0);
	assert_int_equal(l.bus.stats.tx_frames, 1);
	assert_int_equal(l.bus.stats.rx_frames, 1);
	assert_int_equal(l.bus.stats.rx_errors, 0);
	close_bus(&l.bus, &l.pt);
}

/* Six requests to three motors in one send(): the wire carries one at a time. */
static void test_one_request_at_a_time(void **state)
{
	struct rmd_rs485_opts opts = { .baud = 1000000, .reply_timeout_ns = ANSWER_NS };
	struct fake *fk = fake_new((struct fake){ .present = 0xEu, .delay_ns = 3 * MS });
	struct rmd_frame f[6];
	struct link l;

	(void)state;
	for (unsigned i = 0; i < 6; i++)
		f[i] = frame(0x141 + i % 3, status1_req);
	open_bus_fake(&l.bus, &l.pt, &opts, fk);
	assert_int_equal(rmd_bus_send(&l.bus, f, 6, rmd_now_ns()), 6);
	assert_int_equal(pending_of(&l.bus), 6);
	assert_int_equal(drive(&l.bus, l.rx, 8, 6, rmd_now_ns() + LIMIT_NS), 6);
	fake_stop(fk);

	assert_int_equal(fk->overlaps, 0);
	assert_int_equal(fk->requests, 6);
	for (unsigned i = 0; i < 6; i++) {
		assert_int_equal(fk->seen_id[i], 1 + i % 3);
		assert_rx(&l.rx[i], 0x241 + i % 3, status1_reply);
		if (i)
			assert_true(l.rx[i].t_ns >=
				    l.rx[i - 1].t_ns + 2 * MS); /* delay_ns, less slack */
	}
	rmd_rs485_stats(&l.bus, &l.xs);
	assert_int_equal(l.xs.reply_timeouts, 0);
	assert_int_equal(l.bus.stats.tx_frames, 6);
	assert_int_equal(l.bus.stats.rx_frames, 6);
	close_bus(&l.bus, &l.pt);
}

/* A silent motor costs its reply timeout, then the queue moves on. */
static void test_silent_motor_times_out(void **state)
{
	const int64_t timeout = SHORT_NS;
	struct rmd_rs485_opts opts = { .baud = 115200, .reply_timeout_ns = timeout };
	struct fake *fk = fake_new((struct fake){ .present = 1u << 1 });
	struct rmd_frame f[2] = { frame(0x145, status1_req), frame(0x141, status1_req) };
	struct link l;
	int64_t t0;

	(void)state;
	t0 = link_start(&l, &opts, fk, f, 2);
	/* Motor 5 never answers: nothing but the timeout ends its request. */
	assert_int_equal(drive(&l.bus, l.rx, 4, 1, t0 + LIMIT_NS), 1);
	fake_stop(fk);

	assert_rx(&l.rx[0], 0x241, status1_reply);
	assert_int_equal(fk->requests, 2);
	assert_int_equal(fk->seen_id[0], 5);
	assert_int_equal(fk->seen_id[1], 1);
	/* Motor 1 was asked once motor 5's time was up, not before (and not much later). */
	assert_true(fk->seen_ns[1] >= t0 + timeout);
	assert_true(fk->seen_ns[1] < t0 + timeout + 1000 * MS);
	/* Motor 1's answer is late only on a machine that stalls the fake for SHORT_NS. */
	rmd_rs485_stats(&l.bus, &l.xs);
	assert_in_range(l.xs.reply_timeouts, 1, 2);
	close_bus(&l.bus, &l.pt);
}

/* A reply with a broken CRC is dropped and counted; its request times out. */
static void test_bad_crc_dropped(void **state)
{
	struct rmd_rs485_opts opts = { .baud = 1000000, .reply_timeout_ns = SHORT_NS };
	struct fake *fk = fake_new((struct fake){ .present = 1u << 1, .corrupt_first = 1 });
	struct rmd_frame f[2] = { frame(0x141, status1_req), frame(0x141, status1_req) };
	struct link l;

	(void)state;
	exchange(&l.bus, &l.pt, &opts, fk, f, 2, l.rx, 4, 1);

	assert_rx(&l.rx[0], 0x241, status1_reply);
	assert_int_equal(l.bus.stats.rx_errors, 1);
	assert_int_equal(l.bus.stats.rx_frames, 1);
	rmd_rs485_stats(&l.bus, &l.xs);
	assert_in_range(l.xs.reply_timeouts, 1, 2); /* 2: the good answer came late */
	assert_int_equal(l.xs.dropped_bytes, RMD_RS485_FRAME_LEN);
	assert_int_equal(fk->overlaps, 0);
	close_bus(&l.bus, &l.pt);
}

/* Line noise before a reply, stray headers in it, is skipped: one error per run. */
static void test_garbage_skipped(void **state)
{
	static const uint8_t noise[] = { 0x00, 0xFF, 0x3E, 0x55, 0xAA, 0x3E, 0x01, 0x07, 0x3E };
	struct rmd_rs485_opts opts = { .baud = 1000000, .reply_timeout_ns = ANSWER_NS };
	struct fake *fk = fake_new((struct fake){
		.present = 1u << 2, .garbage = noise, .garbage_len = sizeof(noise) });
	struct rmd_frame f = frame(0x142, status1_req);
	struct link l;

	(void)state;
	exchange(&l.bus, &l.pt, &opts, fk, &f, 1, l.rx, 4, 1);

	assert_rx(&l.rx[0], 0x242, status1_reply);
	assert_int_equal(l.bus.stats.rx_errors, 1);
	rmd_rs485_stats(&l.bus, &l.xs);
	assert_int_equal(l.xs.dropped_bytes, sizeof(noise));
	assert_int_equal(l.xs.reply_timeouts, 0);
	close_bus(&l.bus, &l.pt);
}

/* V3 §6.2: one 0xCD request, every motor answers from its own ID. */
static void test_broadcast(void **state)
{
	struct rmd_rs485_opts opts = { .baud = 1000000,
				       .reply_timeout_ns = ANSWER_NS,
				       .broadcast_replies = 3,
				       .broadcast_timeout_ns = 5000 * MS };
	struct fake *fk = fake_new((struct fake){ .present = 0xEu, .delay_ns = 2 * MS });
	struct rmd_frame f[2] = { frame(0x280, off_req), frame(0x142, status1_req) };
	struct link l;
	int64_t t0;

	(void)state;
	t0 = link_start(&l, &opts, fk, f, 2);
	assert_int_equal(rmd_bus_next_due_ns(&l.bus), t0 + 5000 * MS);
	assert_int_equal(drive(&l.bus, l.rx, 8, 4, t0 + LIMIT_NS), 4);
	fake_stop(fk);

	assert_rx(&l.rx[0], 0x241, off_req);
	assert_rx(&l.rx[1], 0x242, off_req);
	assert_rx(&l.rx[2], 0x243, off_req);
	assert_rx(&l.rx[3], 0x242, status1_reply);
	/* Ended by the third answer, long before its 5 s timeout. */
	assert_true(l.rx[3].t_ns < t0 + 5000 * MS);
	assert_int_equal(fk->requests, 2);
	assert_int_equal(fk->seen_id[0], RMD_RS485_BROADCAST);
	assert_int_equal(fk->seen_cmd[0], 0x80);
	assert_int_equal(fk->overlaps, 0);
	rmd_rs485_stats(&l.bus, &l.xs);
	assert_int_equal(l.xs.reply_timeouts, 0);
	assert_int_equal(l.xs.broadcasts_short, 0);
	close_bus(&l.bus, &l.pt);
}

/* Unknown motor count: the broadcast lasts its timeout, which is no error. */
static void test_broadcast_unknown_count(void **state)
{
	const int64_t timeout = SHORT_NS;
	struct rmd_rs485_opts opts = { .baud = 1000000, .broadcast_timeout_ns = timeout };
	struct fake *fk = fake_new((struct fake){ .present = 0x6u });
	struct rmd_frame f = frame(0x280, off_req);
	struct link l;
	int64_t t0, t1;

	(void)state;
	t0 = link_start(&l, &opts, fk, &f, 1);
	assert_int_equal(drive(&l.bus, l.rx, 4, 2, t0 + LIMIT_NS), 2);
	t1 = rmd_now_ns();
	fake_stop(fk);

	assert_rx(&l.rx[0], 0x241, off_req);
	assert_rx(&l.rx[1], 0x242, off_req);
	assert_true(t1 >= t0 + timeout);
	rmd_rs485_stats(&l.bus, &l.xs);
	assert_int_equal(l.xs.reply_timeouts, 0);
	assert_int_equal(l.xs.broadcasts_short, 0);
	close_bus(&l.bus, &l.pt);
}

/* V3 §4 / §7: 0x79 goes out on 0x300 as 0xCD, and its answer from 0xCD comes back on 0x300. */
static void test_set_id_mapping(void **state)
{
	static const uint8_t read_id[RMD_FRAME_LEN] = { 0x79, 0x00, 0x01 };
	struct rmd_rs485_opts opts = { .baud = 500000,
				       .broadcast_replies = 1,
				       .broadcast_timeout_ns = ANSWER_NS };
	struct fake *fk = fake_new((struct fake){ .present = 1u << 2 });
	struct rmd_frame f = frame(0x300, read_id);
	struct link l;

	(void)state;
	exchange(&l.bus, &l.pt, &opts, fk, &f, 1, l.rx, 4, 1);

	assert_int_equal(fk->seen_id[0], RMD_RS485_BROADCAST);
	assert_rx(&l.rx[0], 0x300, read_id);
	rmd_rs485_stats(&l.bus, &l.xs);
	assert_int_equal(l.xs.broadcasts_short, 0);
	close_bus(&l.bus, &l.pt);
}

/* A two-wire adapter hears the request: with local_echo the echo is dropped,
 * even for 0x80, whose answer is byte for byte the request. */
static void test_local_echo(void **state)
{
	struct rmd_rs485_opts opts = { .baud = 1000000,
				       .reply_timeout_ns = ANSWER_NS,
				       .local_echo = true };
	struct fake *fk =
		fake_new((struct fake){ .present = 1u << 1, .echo = true, .delay_ns = 1 * MS });
	struct rmd_frame f[2] = { frame(0x141, off_req), frame(0x141, status1_req) };
	struct link l;

	(void)state;
	exchange(&l.bus, &l.pt, &opts, fk, f, 2, l.rx, 4, 2);

	assert_rx(&l.rx[0], 0x241, off_req);
	assert_rx(&l.rx[1], 0x241, status1_reply);
	rmd_rs485_stats(&l.bus, &l.xs);
	assert_int_equal(l.xs.echoes, 2);
	assert_int_equal(l.xs.reply_timeouts, 0);
	assert_int_equal(fk->overlaps, 0);
	close_bus(&l.bus, &l.pt);
}

/*
 * Byte by byte from the master: a reply split across reads, an unsolicited
 * frame, a late answer that must not end the next request.
 */
static void test_partial_and_late_frames(void **state)
{
	static const uint8_t angle_req[RMD_FRAME_LEN] = { 0x92 };
	const int64_t timeout = 500 * MS;
	struct rmd_rs485_opts opts = { .baud = 1000000, .reply_timeout_ns = timeout };
	struct rmd_frame f[2] = { frame(0x141, status1_req), frame(0x142, angle_req) };
	uint8_t wire[RMD_RS485_FRAME_LEN], want[RMD_RS485_FRAME_LEN];
	struct link l;
	int64_t t0;

	(void)state;
	open_bus(&l.bus, &l.pt, &opts);
	t0 = rmd_now_ns();
	assert_int_equal(rmd_bus_send(&l.bus, f, 2, t0), 2);
	master_read(l.pt.master, wire, RMD_RS485_FRAME_LEN);
	rmd_rs485_build(1, status1_req, want, sizeof(want));
	assert_memory_equal(wire, want, RMD_RS485_FRAME_LEN);

	/* Motor 1 answers too late: only its timeout sends the request for motor 2. */
	assert_int_equal(drive_to(&l.bus, l.rx, 4, 0, 1, t0 + 10 * MS), 0);
	assert_int_equal(pending_of(&l.bus), 2);
	master_quiet(l.pt.master, 0);
	assert_int_equal(drive_to(&l.bus, l.rx, 4, 0, 1, t0 + LIMIT_NS), 0);
	assert_true(rmd_now_ns() >= t0 + timeout);
	rmd_rs485_stats(&l.bus, &l.xs);
	assert_int_equal(l.xs.reply_timeouts, 1);
	assert_int_equal(pending_of(&l.bus), 1);
	master_read(l.pt.master, wire, RMD_RS485_FRAME_LEN);
	rmd_rs485_build(2, angle_req, want, sizeof(want));
	assert_memory_equal(wire, want, RMD_RS485_FRAME_LEN);

	/* The late answer, in two pieces, is passed on but answers nothing. */
	rmd_rs485_build(1, status1_reply, wire, sizeof(wire));
	assert_int_equal(write(l.pt.master, wire, 5), 5);
	wait_readable(rmd_bus_fd(&l.bus));
	assert_int_equal(rmd_bus_recv(&l.bus, l.rx, 4, rmd_now_ns()), 0);
	assert_int_equal(write(l.pt.master, wire + 5, RMD_RS485_FRAME_LEN - 5),
			 RMD_RS485_FRAME_LEN - 5);
	/* An unsolicited 0x9A from motor 2 has the wrong command byte to answer 0x92. */
	master_write_frame(l.pt.master, 2, status1_reply);
	assert_int_equal(drive_to(&l.bus, l.rx, 4, 2, 1, rmd_now_ns() + LIMIT_NS), 2);
	assert_rx(&l.rx[0], 0x241, status1_reply);
	assert_rx(&l.rx[1], 0x242, status1_reply);
	assert_int_equal(pending_of(&l.bus), 1);

	master_write_frame(l.pt.master, 2, angle_req);
	assert_int_equal(drive(&l.bus, l.rx, 4, 1, rmd_now_ns() + LIMIT_NS), 1);
	assert_rx(&l.rx[0], 0x242, angle_req);
	assert_int_equal(pending_of(&l.bus), 0);
	assert_int_equal(l.bus.stats.rx_errors, 0);
	rmd_rs485_stats(&l.bus, &l.xs);
	assert_int_equal(l.xs.reply_timeouts, 1);
	close_bus(&l.bus, &l.pt);
}

static void test_send_refusals(void **state)
{
	struct rmd_rs485_opts opts = { .baud = 1000000 };
	struct rmd_frame f[RMD_RS485_QUEUE + 6];
	struct rmd_bus bus;
	struct pty pt;

	(void)state;
	open_bus(&bus, &pt, &opts);

	/* No RS485 form: MIT (V3 §5 is CAN only), id 0 and 33, short frames. */
	f[0] = frame(0x401, status1_req);
	assert_int_equal(rmd_bus_send(&bus, f, 1, rmd_now_ns()), -EINVAL);
	f[0] = frame(0x140, status1_req);
	assert_int_equal(rmd_bus_send(&bus, f, 1, rmd_now_ns()), -EINVAL);
	f[0] = frame(0x161, status1_req);
	assert_int_equal(rmd_bus_send(&bus, f, 1, rmd_now_ns()), -EINVAL);
	f[0] = frame(0x141, status1_req);
	f[1] = frame(0x142, status1_req);
	f[1].len = 7;
	assert_int_equal(rmd_bus_send(&bus, f, 2, rmd_now_ns()), -EINVAL);
	assert_int_equal(pending_of(&bus), 0);
	assert_int_equal(bus.stats.tx_frames, 0);

	/* A full queue takes what fits; the rest is the caller's, counted. */
	for (unsigned i = 0; i < RMD_RS485_QUEUE + 6; i++)
		f[i] = frame(0x141 + i % 32, status1_req);
	assert_int_equal(rmd_bus_send(&bus, f, RMD_RS485_QUEUE + 6, rmd_now_ns()), RMD_RS485_QUEUE);
	assert_int_equal(bus.stats.tx_busy, 6);
	assert_int_equal(pending_of(&bus), RMD_RS485_QUEUE);
	assert_int_equal(rmd_bus_send(&bus, f, 1, rmd_now_ns()), 0);
	assert_int_equal(bus.stats.tx_busy, 7);
	assert_int_equal(bus.stats.tx_frames, 1);
	close_bus(&bus, &pt);
}

/* caps, next_due_ns, and the other transports' accessors refusing an RS485 bus. */
static void test_caps_and_accessors(void **state)
{
	struct rmd_rs485_opts opts = { .baud = 1000000 };
	struct rmd_frame f = frame(0x141, status1_req);
	const struct rmd_bus_caps *caps;
	struct rmd_bus bus;
	struct pty pt;
	int64_t t0;

	(void)state;
	open_bus(&bus, &pt, &opts);
	caps = rmd_bus_caps(&bus);
	assert_true(caps->half_duplex);
	assert_int_equal(caps->reply_timeout_ns, RMD_RS485_TURNAROUND_NS + 2 * 130000);
	assert_int_equal(caps->request_spacing_ns, caps->reply_timeout_ns);
	assert_int_equal(caps->queue_len, RMD_RS485_QUEUE);
	assert_int_equal(rmd_bus_next_due_ns(&bus), INT64_MAX);
	t0 = rmd_now_ns();
	assert_int_equal(rmd_bus_send(&bus, &f, 1, t0), 1);
	assert_int_equal(rmd_bus_next_due_ns(&bus), t0 + caps->reply_timeout_ns);
	assert_null(rmd_bus_sim_get(&bus));
	assert_int_equal(rmd_bus_sim_time_ns(&bus, t0), 0);
	assert_int_equal(rmd_socketcan_rcvbuf(&bus), -EINVAL);
	close_bus(&bus, &pt);
}

/* A config entry and the spec naming the same line open the same bus. */
static void test_open_config_equals_spec(void **state)
{
	struct rmd_bus_open_opts o = { .proto = RMD_PROTO_V3, .baud = 500000 };
	struct rmd_config_bus cb = { .kind = RMD_BUS_KIND_RS485, .baud = 500000 };
	struct rmd_bus_open_motor m = { .id = 1, .proto = RMD_PROTO_V2 };
	struct rmd_bus_open_ctx v2 = { .motors = &m, .n_motors = 1 };
	struct rmd_bus a, b;
	struct pty pt;
	char err[256];

	(void)state;
	pty_open(&pt);
	snprintf(cb.name, sizeof(cb.name), "rs0");
	snprintf(cb.device, sizeof(cb.device), "%s", pt.path);
	assert_int_equal(rmd_bus_open(&a, &cb, NULL, err, sizeof(err)), 0);
	b = a;
	rmd_bus_close(&a);
	assert_int_equal(rmd_bus_open_spec(&a, pt.path, &o, err, sizeof(err)), 0);
	assert_ptr_equal(a.ops, b.ops);
	assert_string_equal(a.name, b.name);
	assert_memory_equal(&a.caps, &b.caps, sizeof(a.caps));
	rmd_bus_close(&a);
	/* V3 §1.2: no V2 motor on an RS485 line, whichever way it is named */
	assert_int_equal(rmd_bus_open(&a, &cb, &v2, err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "V2 motors are CAN only"));
	close(pt.master);
}

/*
 * The line's reply timeout follows the bus's turnaround_us: a converter
 * whose latency timer adds 16 ms needs a turnaround that includes it, and
 * the line then waits for its answers instead of writing over them.
 */
static void test_reply_timeout_follows_turnaround(void **state)
{
	const int64_t frame = rmd_rs485_frame_ns(1000000);
	struct rmd_config_bus cb = { .kind = RMD_BUS_KIND_RS485, .baud = 1000000 };
	struct rmd_bus a;
	struct pty pt;
	char err[512];

	(void)state;
	assert_int_equal(frame, 130000);
	/* the default turnaround (800 us) keeps the 2 ms floor */
	assert_int_equal(rmd_rs485_reply_timeout_ns(1000000, 800000), 2000000 + 2 * frame);
	assert_int_equal(rmd_rs485_reply_timeout_ns(1000000, 17000000), 34000000 + 2 * frame);
	pty_open(&pt);
	snprintf(cb.name, sizeof(cb.name), "rs0");
	snprintf(cb.device, sizeof(cb.device), "%s", pt.path);
	cb.turnaround_ns = 17000000;
	assert_int_equal(rmd_bus_open(&a, &cb, NULL, err, sizeof(err)), 0);
	assert_int_equal(rmd_bus_caps(&a)->reply_timeout_ns, 34000000 + 2 * frame);
	assert_int_equal(rmd_bus_caps(&a)->request_spacing_ns, 34000000 + 2 * frame);
	rmd_bus_close(&a);
	close(pt.master);
}

/* mkdir -p of path's directories (not its last part). */
static void mkdirs(char *path)
{
	for (char *s = strchr(path + 1, '/'); s; s = strchr(s + 1, '/')) {
		*s = '\0';
		if (mkdir(path, 0755) < 0 && errno != EEXIST)
			fail_msg("mkdir %s: %s", path, strerror(errno));
		*s = '/';
	}
}

static void write_file(const char *path, const char *text)
{
	FILE *f = fopen(path, "w");

	assert_non_null(f);
	fputs(text, f);
	assert_int_equal(fclose(f), 0);
}

static void read_file(const char *path, char *buf, size_t len)
{
	FILE *f = fopen(path, "r");

	assert_non_null(f);
	if (!fgets(buf, (int)len, f))
		buf[0] = '\0';
	fclose(f);
}

/*
 * An FTDI converter's latency timer (sysfs, found through the port's
 * device number) is set to 1 ms at open; one already at 1 is left alone;
 * a port with none (this pty under the real /sys) opens without a word
 * about it.  The fake sysfs tree stands in for the converter.
 */
static void test_latency_timer_set(void **state)
{
	char root[] = "/tmp/rmd-sysfs-XXXXXX", path[256], buf[16], err[512];
	struct rmd_rs485_opts opts = { .baud = 1000000 };
	struct rmd_bus bus;
	struct stat st;
	struct pty pt;

	(void)state;
	assert_non_null(mkdtemp(root));
	pty_open(&pt);
	assert_int_equal(stat(pt.path, &st), 0);
	snprintf(path, sizeof(path), "%s/dev/char/%u:%u/device/latency_timer", root,
		 major(st.st_rdev), minor(st.st_rdev));
	mkdirs(path);
	write_file(path, "16\n");
	opts.sysfs_root = root;
	assert_int_equal(rmd_rs485_open(&bus, pt.path, &opts, err, sizeof(err)), 0);
	read_file(path, buf, sizeof(buf));
	assert_string_equal(buf, "1\n");
	assert_null(strstr(err, "latency timer"));
	rmd_bus_close(&bus);

	write_file(path, "1\n");
	assert_int_equal(rmd_rs485_open(&bus, pt.path, &opts, err, sizeof(err)), 0);
	assert_null(strstr(err, "latency timer"));
	rmd_bus_close(&bus);

	/* a pty has no timer: nothing to say beyond what a pty always gets */
	opts.sysfs_root = NULL;
	assert_int_equal(rmd_rs485_open(&bus, pt.path, &opts, err, sizeof(err)), 0);
	assert_null(strstr(err, "latency"));
	assert_non_null(strstr(err, "pseudo-terminal"));
	rmd_bus_close(&bus);
	close(pt.master);
	unlink(path);
}

/* ---- device role: the motors' side (rmd-sim) ------------------------------------------------ */

static void open_device(struct rmd_bus *bus, struct pty *pt, bool local_echo)
{
	struct rmd_bus_open_opts o = {
		.proto = RMD_PROTO_V3, .baud = 1000000, .local_echo = local_echo, .device = true
	};
	char err[256];
	int r;

	pty_open(pt);
	r = rmd_bus_open_spec(bus, pt->path, &o, err, sizeof(err));
	if (r < 0)
		fail_msg("rmd_bus_open_spec(%s, device): %d: %s", pt->path, r, err);
	assert_string_equal(bus->ops->kind, "rs485");
}

/* Receive until want frames came (at now_ns + skew_ns), within LIMIT_NS. */
static unsigned device_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max,
			    unsigned want, int64_t skew_ns)
{
	int64_t limit = rmd_now_ns() + LIMIT_NS;
	unsigned n = 0;

	while (n < want && rmd_now_ns() < limit) {
		struct pollfd pfd = { .fd = rmd_bus_fd(bus), .events = POLLIN };
		struct timespec ts = ts_of(10 * MS);
		int r;

		ppoll(&pfd, 1, &ts, NULL);
		r = rmd_bus_recv(bus, out + n, max - n, rmd_now_ns() + skew_ns);
		assert_true(r >= 0);
		n += (unsigned)r;
	}
	return n;
}

/* Requests in as the motors see them, replies out as the host sees them; no queue. */
static void test_device_role(void **state)
{
	static const uint8_t set_id_read[RMD_FRAME_LEN] = { 0x79, 0, 1 };
	static const uint8_t noise[] = { 0x3E, 0x00, 0x55, 0x3E, 0x01, 0x07 };
	struct rmd_frame f = frame(0x241, status1_reply);
	uint8_t wire[RMD_RS485_FRAME_LEN], id, data[RMD_FRAME_LEN];
	struct rmd_bus_rx rx[4];
	const struct rmd_bus_caps *caps;
	struct rmd_bus bus;
	struct pty pt;
	uint16_t crc;

	(void)state;
	open_device(&bus, &pt, false);
	caps = rmd_bus_caps(&bus);
	assert_false(caps->half_duplex);
	assert_int_equal(caps->queue_len, 0);
	assert_int_equal(caps->reply_timeout_ns, 0);
	assert_int_equal(rmd_bus_next_due_ns(&bus), INT64_MAX);

	/* Line noise, then three requests: V3 §1.2.2 id 1, §7 0x79 and §6 to 0xCD. */
	assert_int_equal(write(pt.master, noise, sizeof(noise)), sizeof(noise));
	master_write_frame(pt.master, 1, status1_req);
	master_write_frame(pt.master, RMD_RS485_BROADCAST, set_id_read);
	master_write_frame(pt.master, RMD_RS485_BROADCAST, off_req);
	assert_int_equal(device_recv(&bus, rx, 4, 3, 0), 3);
	assert_rx(&rx[0], 0x141, status1_req);
	assert_rx(&rx[1], 0x300, set_id_read);
	assert_rx(&rx[2], 0x280, off_req);
	assert_int_equal(rmd_bus_stats(&bus)->rx_noise_bytes, sizeof(noise));
	assert_int_equal(rmd_bus_stats(&bus)->rx_errors, 1);
	assert_int_equal(rmd_bus_stats(&bus)->rx_frames, 3);

	/* Replies: 0x241 -> id 1, 0x300 -> 0xCD (V3 §7.3). */
	assert_int_equal(rmd_bus_send(&bus, &f, 1, rmd_now_ns()), 1);
	master_read(pt.master, wire, sizeof(wire));
	assert_int_equal(rmd_rs485_parse(wire, sizeof(wire), &id, data), RMD_RS485_FRAME_LEN);
	assert_int_equal(id, 1);
	assert_memory_equal(data, status1_reply, RMD_FRAME_LEN);
	f = frame(0x300, set_id_read);
	assert_int_equal(rmd_bus_send(&bus, &f, 1, rmd_now_ns()), 1);
	master_read(pt.master, wire, sizeof(wire));
	assert_int_equal(rmd_rs485_parse(wire, sizeof(wire), &id, data), RMD_RS485_FRAME_LEN);
	assert_int_equal(id, RMD_RS485_BROADCAST);

	/* No RS485 form (MIT 0x400 + ID), or more than 8 bytes: refused, nothing written. */
	f = frame(0x401, status1_reply);
	assert_int_equal(rmd_bus_send(&bus, &f, 1, rmd_now_ns()), -EINVAL);
	f = frame(0x241, status1_reply);
	f.len = 9;
	assert_int_equal(rmd_bus_send(&bus, &f, 1, rmd_now_ns()), -EINVAL);

	/* BAD_DLC: 3 data bytes go out with length byte 3 and the CRC after them. */
	f.len = 3;
	assert_int_equal(rmd_bus_send(&bus, &f, 1, rmd_now_ns()), 1);
	master_read(pt.master, wire, 8);
	assert_int_equal(wire[0], RMD_RS485_HEADER);
	assert_int_equal(wire[1], 1);
	assert_int_equal(wire[2], 3);
	assert_memory_equal(wire + 3, status1_reply, 3);
	crc = rmd_crc16_modbus(wire, 6);
	assert_int_equal(wire[6], crc & 0xFF);
	assert_int_equal(wire[7], crc >> 8);
	master_quiet(pt.master, 20 * MS);
	assert_int_equal(rmd_bus_stats(&bus)->tx_frames, 3);
	assert_int_equal(rmd_bus_next_due_ns(&bus), INT64_MAX);
	close_bus(&bus, &pt);
}

/*
 * V3 §7.4: the reply to the RS485-ID read carries the ID itself (example 2
 * answers "0x0002") where CAN carries the reply identifier 0x240 + ID; a
 * motor speaks CAN, the device role gives it the line's form.  Every other
 * frame goes out as it is, the write's reply and a value that is no reply
 * identifier included.
 */
static void test_device_set_id_read(void **state)
{
	/* 0x79 replies: D2 (1: read, 0: write), D6..D7 as the motor says them and on the line */
	static const struct {
		const char *name;
		uint8_t d2;
		uint16_t value, on_line;
	} cases[] = {
		{ "read of motor 2", 1, 0x0242, 0x0002 },
		{ "read of motor 32", 1, 0x0260, 0x0020 },
		{ "write", 0, 0x0242, 0x0242 },
		{ "read, no reply id", 1, 0x0240, 0x0240 },
	};
	uint8_t wire[RMD_RS485_FRAME_LEN], id, data[RMD_FRAME_LEN], want[RMD_FRAME_LEN];
	struct rmd_frame f = { .can_id = RMD_CAN_SET_ID, .len = RMD_FRAME_LEN }, form;
	struct rmd_bus bus;
	struct pty pt;

	(void)state;
	open_device(&bus, &pt, false);
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		memset(f.data, 0, sizeof(f.data));
		f.data[0] = RMD_RS485_CMD_SET_ID;
		f.data[2] = cases[i].d2;
		memcpy(want, f.data, sizeof(want));
		f.data[6] = (uint8_t)cases[i].value;
		f.data[7] = (uint8_t)(cases[i].value >> 8);
		want[6] = (uint8_t)cases[i].on_line;
		want[7] = (uint8_t)(cases[i].on_line >> 8);
		assert_int_equal(rmd_rs485_from_can(&f, false, &form), RMD_RS485_BROADCAST);
		if (memcmp(form.data, want, RMD_FRAME_LEN))
			fail_msg("%s: rmd_rs485_from_can() data differ", cases[i].name);
		assert_int_equal(rmd_bus_send(&bus, &f, 1, rmd_now_ns()), 1);
		master_read(pt.master, wire, sizeof(wire));
		assert_int_equal(rmd_rs485_parse(wire, sizeof(wire), &id, data),
				 RMD_RS485_FRAME_LEN);
		assert_int_equal(id, RMD_RS485_BROADCAST);
		if (memcmp(data, want, RMD_FRAME_LEN))
			fail_msg("%s: the line carried other data", cases[i].name);
	}
	/* A request is never rewritten; a frame with no RS485 form has no id. */
	f.data[2] = 1;
	f.data[6] = 0x42;
	f.data[7] = 0x02;
	assert_int_equal(rmd_rs485_from_can(&f, true, &form), RMD_RS485_BROADCAST);
	assert_memory_equal(form.data, f.data, RMD_FRAME_LEN);
	f.can_id = 0x501;
	assert_int_equal(rmd_rs485_from_can(&f, false, &form), -EINVAL);
	close_bus(&bus, &pt);
}

/* --local-echo: a frame we sent, heard back, is dropped once, in order, within 500 ms. */
static void test_device_local_echo(void **state)
{
	struct rmd_frame f = frame(0x241, off_req);
	struct rmd_bus_rx rx[4];
	struct rmd_bus bus;
	struct pty pt;
	uint8_t wire[RMD_RS485_FRAME_LEN];
	int64_t t;

	(void)state;
	open_device(&bus, &pt, true);
	/* 0x80's reply is byte for byte a request to id 1 (V3 §2.28). */
	assert_int_equal(rmd_bus_send(&bus, &f, 1, rmd_now_ns()), 1);
	master_read(pt.master, wire, sizeof(wire));
	assert_int_equal(write(pt.master, wire, sizeof(wire)), sizeof(wire));
	assert_int_equal(write(pt.master, wire, sizeof(wire)), sizeof(wire));
	/* The first copy is the echo; the second is a request. */
	assert_int_equal(device_recv(&bus, rx, 4, 1, 0), 1);
	assert_rx(&rx[0], 0x141, off_req);
	assert_int_equal(rmd_bus_stats(&bus)->echoes, 1);

	/* Heard back later than RMD_RS485_ECHO_EXPIRY_NS: no echo any more. */
	t = rmd_now_ns();
	assert_int_equal(rmd_bus_send(&bus, &f, 1, t), 1);
	master_read(pt.master, wire, sizeof(wire));
	assert_int_equal(write(pt.master, wire, sizeof(wire)), sizeof(wire));
	assert_int_equal(device_recv(&bus, rx, 4, 1, RMD_RS485_ECHO_EXPIRY_NS + MS), 1);
	assert_rx(&rx[0], 0x141, off_req);
	assert_int_equal(rmd_bus_stats(&bus)->echoes, 1);
	close_bus(&bus, &pt);
}

/* Replies the tty refuses wait in the transport: next_due_ns says so, send(n 0) drains them. */
static void test_device_backlog(void **state)
{
	struct rmd_frame f = frame(0x241, status1_reply);
	struct rmd_bus bus;
	struct pty pt;
	uint64_t sent = 0, got = 0;
	int64_t limit;
	int r;

	(void)state;
	open_device(&bus, &pt, false);
	/* Nobody reads the master: the tty and then the transport's buffer fill. */
	while ((r = rmd_bus_send(&bus, &f, 1, rmd_now_ns())) == 1) {
		sent++;
		assert_true(sent < 1000000);
	}
	assert_int_equal(r, 0);
	assert_true(sent * RMD_RS485_FRAME_LEN > RMD_RS485_DEVICE_TXBUF);
	assert_int_equal(rmd_bus_stats(&bus)->tx_busy, 1);
	assert_int_equal(rmd_bus_stats(&bus)->tx_frames, sent);
	assert_true(rmd_bus_next_due_ns(&bus) != INT64_MAX);

	/* Read everything, writing on whenever the tty is writable again. */
	limit = rmd_now_ns() + LIMIT_NS;
	while (got < sent * RMD_RS485_FRAME_LEN && rmd_now_ns() < limit) {
		uint8_t buf[4096];
		struct pollfd pfd = { .fd = pt.master, .events = POLLIN };
		struct timespec ts = ts_of(10 * MS);
		ssize_t n;

		if (ppoll(&pfd, 1, &ts, NULL) == 1) {
			n = read(pt.master, buf, sizeof(buf));
			if (n > 0)
				got += (uint64_t)n;
		}
		if (rmd_bus_next_due_ns(&bus) != INT64_MAX)
			assert_int_equal(rmd_bus_send(&bus, NULL, 0, rmd_now_ns()), 0);
	}
	assert_int_equal(got, sent * RMD_RS485_FRAME_LEN);
	assert_int_equal(rmd_bus_next_due_ns(&bus), INT64_MAX);
	close_bus(&bus, &pt);
}

SUITE_MAIN("bus_rs485", NULL, NULL,
	   {
		   cmocka_unit_test_teardown(test_frame_time, teardown),
		   cmocka_unit_test_teardown(test_open_errors, teardown),
		   cmocka_unit_test_teardown(test_open_pty, teardown),
		   cmocka_unit_test_teardown(test_round_trip, teardown),
		   cmocka_unit_test_teardown(test_one_request_at_a_time, teardown),
		   cmocka_unit_test_teardown(test_silent_motor_times_out, teardown),
		   cmocka_unit_test_teardown(test_bad_crc_dropped, teardown),
		   cmocka_unit_test_teardown(test_garbage_skipped, teardown),
		   cmocka_unit_test_teardown(test_broadcast, teardown),
		   cmocka_unit_test_teardown(test_broadcast_unknown_count, teardown),
		   cmocka_unit_test_teardown(test_set_id_mapping, teardown),
		   cmocka_unit_test_teardown(test_local_echo, teardown),
		   cmocka_unit_test_teardown(test_partial_and_late_frames, teardown),
		   cmocka_unit_test_teardown(test_send_refusals, teardown),
		   cmocka_unit_test_teardown(test_caps_and_accessors, teardown),
		   cmocka_unit_test_teardown(test_reply_timeout_follows_turnaround, teardown),
		   cmocka_unit_test_teardown(test_latency_timer_set, teardown),
		   cmocka_unit_test_teardown(test_open_config_equals_spec, teardown),
		   cmocka_unit_test_teardown(test_device_role, teardown),
		   cmocka_unit_test_teardown(test_device_set_id_read, teardown),
		   cmocka_unit_test_teardown(test_device_local_echo, teardown),
		   cmocka_unit_test_teardown(test_device_backlog, teardown),
	   })
