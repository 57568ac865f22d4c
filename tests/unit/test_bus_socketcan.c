// SPDX-License-Identifier: MIT
/*
 * SocketCAN transport tests.
 *
 * The error-frame parser is a pure function and runs everywhere.  The rest
 * needs a kernel with SocketCAN and vcan: run it as
 *   tests/vm/vm-run --vcan 3 -- build/tests/unit/test_bus_socketcan
 * which gives vcan0..vcan2, up, and root (the tests create and delete more
 * interfaces with ip(8), and put a netem qdisc on vcan1).  Without SocketCAN
 * those tests are skipped with one loud line.
 *
 * Interface use: vcan0 filters, timestamps, lifecycle; vcan1 bursts
 * (netem); vcan2 error frames, no acknowledgement (netem) and candump;
 * vcan7/can7/vcan8 are made and deleted by the open tests, the vxcan pair
 * vxcan8/vxcan9 by the flush test.
 */
#define _GNU_SOURCE

#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <sched.h>
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

#include <net/if.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/wait.h>

#include <linux/capability.h>

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>

#include <cmocka.h>

#include "rmd/time.h"
#include "rmd/bus_open.h"
#include "rmd/bus_rs485.h"
#include "rmd/bus_sim.h"
#include "rmd/bus_socketcan.h"

#include "harness/alloc_count.h"
#include "harness/suite.h"

#define NS_PER_MS 1000000LL

static bool have_socketcan;

static int bus_send(struct rmd_bus *bus, const struct rmd_frame *f, unsigned n)
{
	int r;

	alloc_count_start();
	r = rmd_bus_send(bus, f, n, 0);
	alloc_count_stop();
	return r;
}

static int bus_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max)
{
	int r;

	alloc_count_start();
	r = rmd_bus_recv(bus, out, max, 0);
	alloc_count_stop();
	return r;
}

/* One rt-loop period: the caller's next cycle, not a wait for a result. */
static void next_cycle(void)
{
	struct timespec ts = { 0, 1000000 };

	clock_nanosleep(CLOCK_MONOTONIC, 0, &ts, NULL);
}

__attribute__((format(printf, 1, 2))) static void sh(const char *fmt, ...)
{
	char cmd[256];
	va_list ap;
	int r;

	va_start(ap, fmt);
	vsnprintf(cmd, sizeof(cmd), fmt, ap);
	va_end(ap);
	r = system(cmd);
	if (r != 0)
		fail_msg("`%s` failed (status %d)", cmd, r);
}

/* Best effort (cleanup): a failure is reported, not fatal. */
static void sh_try(const char *cmd)
{
	if (system(cmd) != 0)
		printf("note: `%s` failed\n", cmd);
}

static struct rmd_frame frame(uint32_t id, uint8_t len, uint8_t seed)
{
	struct rmd_frame f = { .can_id = id, .len = len };

	for (int i = 0; i < len; i++)
		f.data[i] = (uint8_t)(seed + i * 17);
	return f;
}

static void assert_frame_equal(const struct rmd_frame *a, const struct rmd_frame *b, int i)
{
	if (a->can_id != b->can_id || a->len != b->len || memcmp(a->data, b->data, a->len))
		fail_msg("frame %d: got %03X [%u], want %03X [%u] (or data differs)", i, a->can_id,
			 a->len, b->can_id, b->len);
}

/* A second raw socket on the same interface: the motors' side of the bus. */
static int peer_open(const char *ifname)
{
	struct sockaddr_can addr = { .can_family = AF_CAN };
	int fd, big = 1 << 20;

	fd = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
	assert_true(fd >= 0);
	addr.can_ifindex = (int)if_nametoindex(ifname);
	assert_true(addr.can_ifindex > 0);
	setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &big, sizeof(big));
	assert_int_equal(bind(fd, (struct sockaddr *)&addr, sizeof(addr)), 0);
	return fd;
}

static void peer_send_raw(int fd, canid_t id, uint8_t len, const uint8_t *data)
{
	struct can_frame cf = { .can_id = id, .len = len };

	if (data)
		memcpy(cf.data, data, len);
	if (write(fd, &cf, sizeof(cf)) != (ssize_t)sizeof(cf))
		fail_msg("peer write %X: %s", id, strerror(errno));
}

static void peer_send(int fd, const struct rmd_frame *f)
{
	peer_send_raw(fd, f->can_id, f->len, f->data);
}

/* Read up to n frames from the peer, waiting at most timeout_ms for each. */
static int peer_recv(int fd, struct rmd_frame *out, int n, int timeout_ms)
{
	int got = 0;

	while (got < n) {
		struct pollfd pfd = { .fd = fd, .events = POLLIN };
		struct can_frame cf;

		if (poll(&pfd, 1, timeout_ms) <= 0)
			break;
		if (read(fd, &cf, sizeof(cf)) != (ssize_t)sizeof(cf))
			break;
		out[got].can_id = cf.can_id;
		out[got].len = cf.len;
		memcpy(out[got].data, cf.data, sizeof(cf.data));
		got++;
	}
	return got;
}

/* Collect frames from the bus until `want` arrived or timeout_ms passed without one. */
static int recv_until(struct rmd_bus *bus, struct rmd_bus_rx *out, int want, int timeout_ms)
{
	int got = 0;

	while (got < want) {
		struct pollfd pfd = { .fd = rmd_bus_fd(bus), .events = POLLIN };
		int r;

		if (poll(&pfd, 1, timeout_ms) <= 0)
			break;
		r = bus_recv(bus, out + got, (unsigned)(want - got));
		assert_true(r >= 0);
		got += r;
	}
	return got;
}

/* ---- the error-frame parser: pure, runs everywhere ---- */

static struct can_frame err_frame(canid_t cls, uint8_t ctrl)
{
	struct can_frame cf = { .can_id = CAN_ERR_FLAG | cls, .len = CAN_ERR_DLC };

	cf.data[1] = ctrl;
	return cf;
}

static void test_error_frame_states(void **state)
{
	static const struct {
		const char *name;
		canid_t cls;
		uint8_t ctrl;
		enum rmd_bus_state want;
		bool changes;
	} steps[] = {
		{ "rx overflow: no state", CAN_ERR_CRTL, CAN_ERR_CRTL_RX_OVERFLOW, RMD_BUS_ACTIVE,
		  false },
		{ "tx warning", CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING, RMD_BUS_WARNING, true },
		{ "rx warning again", CAN_ERR_CRTL, CAN_ERR_CRTL_RX_WARNING, RMD_BUS_WARNING,
		  false },
		{ "tx passive + rx warning", CAN_ERR_CRTL,
		  CAN_ERR_CRTL_TX_PASSIVE | CAN_ERR_CRTL_RX_WARNING, RMD_BUS_PASSIVE, true },
		{ "back to warning", CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING, RMD_BUS_WARNING, true },
		{ "bus-off", CAN_ERR_BUSOFF, 0, RMD_BUS_OFF, true },
		{ "protocol error while off", CAN_ERR_PROT, 0, RMD_BUS_OFF, false },
		{ "restarted", CAN_ERR_RESTARTED, 0, RMD_BUS_ACTIVE, true },
		{ "rx passive", CAN_ERR_CRTL, CAN_ERR_CRTL_RX_PASSIVE, RMD_BUS_PASSIVE, true },
		{ "recovered to active", CAN_ERR_CRTL, CAN_ERR_CRTL_ACTIVE, RMD_BUS_ACTIVE, true },
		{ "bus-off with passive", CAN_ERR_BUSOFF | CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE,
		  RMD_BUS_OFF, true },
		{ "ack error", CAN_ERR_ACK, 0, RMD_BUS_OFF, false },
	};
	struct rmd_bus bus = { .state = RMD_BUS_ACTIVE };
	struct rmd_socketcan_errs e = { .ctrl = RMD_BUS_ACTIVE };
	uint64_t changes = 0;

	(void)state;
	for (size_t i = 0; i < sizeof(steps) / sizeof(steps[0]); i++) {
		struct can_frame cf = err_frame(steps[i].cls, steps[i].ctrl);

		rmd_socketcan_error_frame(&bus, &e, &cf);
		changes += steps[i].changes;
		if (bus.state != steps[i].want)
			fail_msg("%s: state %s, want %s", steps[i].name,
				 rmd_bus_state_name(bus.state), rmd_bus_state_name(steps[i].want));
		if (bus.stats.state_changes != changes)
			fail_msg("%s: %llu state changes, want %llu", steps[i].name,
				 (unsigned long long)bus.stats.state_changes,
				 (unsigned long long)changes);
		assert_int_equal(bus.stats.bus_errors, i + 1);
	}
	assert_int_equal(bus.stats.rx_frames, 0);
}

/*
 * Nobody acknowledges (rmd/bus_socketcan.h): RMD_SOCKETCAN_NO_ACK_ERRORS
 * ACK errors in a row, or one while the transmitter is error-passive; it
 * ends when the transmitter leaves error-passive (a frame of ours was
 * acknowledged), and a bus-off, or a restart after it, does not end it.
 */
static void test_no_ack_states(void **state)
{
	static const struct {
		const char *name;
		canid_t cls;
		uint8_t ctrl;
		unsigned times;
		enum rmd_bus_state want;
		bool changes;
	} steps[] = {
		{ "15 ack errors: not yet", CAN_ERR_ACK, 0, RMD_SOCKETCAN_NO_ACK_ERRORS - 1,
		  RMD_BUS_ACTIVE, false },
		{ "the 16th: nobody acknowledges", CAN_ERR_ACK, 0, 1, RMD_BUS_NO_ACK, true },
		{ "tx passive: still nobody", CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE, 1,
		  RMD_BUS_NO_ACK, false },
		{ "an rx overflow says nothing", CAN_ERR_CRTL, CAN_ERR_CRTL_RX_OVERFLOW, 1,
		  RMD_BUS_NO_ACK, false },
		{ "tx back to warning: acknowledged", CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING, 1,
		  RMD_BUS_WARNING, true },
		{ "tx passive again", CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE, 1, RMD_BUS_PASSIVE,
		  true },
		{ "one ack error while passive", CAN_ERR_ACK, 0, 1, RMD_BUS_NO_ACK, true },
		{ "rx passive too: still nobody", CAN_ERR_CRTL,
		  CAN_ERR_CRTL_TX_PASSIVE | CAN_ERR_CRTL_RX_PASSIVE, 1, RMD_BUS_NO_ACK, false },
		{ "bus-off wins", CAN_ERR_BUSOFF, 0, 1, RMD_BUS_OFF, true },
		{ "restarted: nothing acknowledged yet", CAN_ERR_RESTARTED, 0, 1, RMD_BUS_NO_ACK,
		  true },
		{ "error active again is no acknowledgement", CAN_ERR_CRTL, CAN_ERR_CRTL_ACTIVE, 1,
		  RMD_BUS_NO_ACK, false },
	};
	struct rmd_bus bus = { .state = RMD_BUS_ACTIVE };
	struct rmd_socketcan_errs e = { .ctrl = RMD_BUS_ACTIVE };
	uint64_t changes = 0, errors = 0;

	(void)state;
	for (size_t i = 0; i < sizeof(steps) / sizeof(steps[0]); i++) {
		struct can_frame cf = err_frame(steps[i].cls, steps[i].ctrl);

		for (unsigned k = 0; k < steps[i].times; k++)
			rmd_socketcan_error_frame(&bus, &e, &cf);
		changes += steps[i].changes;
		errors += steps[i].times;
		if (bus.state != steps[i].want || bus.stats.state_changes != changes)
			fail_msg("%s: state %s after %llu changes, want %s after %llu",
				 steps[i].name, rmd_bus_state_name(bus.state),
				 (unsigned long long)bus.stats.state_changes,
				 rmd_bus_state_name(steps[i].want), (unsigned long long)changes);
		assert_int_equal(bus.stats.bus_errors, errors);
	}
}

static void test_open_bad_name(void **state)
{
	struct rmd_bus bus;
	char err[256];

	(void)state;
	assert_int_equal(rmd_socketcan_open(&bus, "", NULL, err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "not an interface name"));
	assert_int_equal(rmd_socketcan_open(&bus, "a_name_far_too_long", NULL, err, sizeof(err)),
			 -EINVAL);
	assert_null(bus.ops);
	rmd_bus_close(&bus); /* unopened: no-op */
}

/* On a kernel without SocketCAN the error says so and names the way out. */
static void test_open_no_socketcan(void **state)
{
	struct rmd_bus bus;
	char err[256];

	(void)state;
	if (have_socketcan) {
		print_message("skipped: this kernel has SocketCAN (checked on one without)\n");
		skip();
	}
	assert_int_equal(rmd_socketcan_open(&bus, "can0", NULL, err, sizeof(err)), -EAFNOSUPPORT);
	assert_non_null(strstr(err, "can0: this kernel has no SocketCAN"));
}

/* ---- everything below needs SocketCAN and vcan ---- */

/*
 * This suite's SocketCAN tests, as one: skipped on a kernel without
 * SocketCAN (the host's tally then names them "ran in the other place"
 * when the guest ran this one), run where it has it.
 */
static void test_vcan_suite_needs_socketcan(void **state)
{
	int fd;

	(void)state;
	if (!have_socketcan)
		skip();
	fd = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
	assert_true(fd >= 0);
	close(fd);
}

static void test_open_missing_interface(void **state)
{
	struct rmd_bus bus;
	char err[256];

	(void)state;
	assert_int_equal(rmd_socketcan_open(&bus, "vcan9", NULL, err, sizeof(err)), -ENODEV);
	assert_string_equal(err, "vcan9: no such interface (is the driver loaded? `ip link show`)");
	assert_null(bus.ops);
}

static void test_open_not_can(void **state)
{
	struct rmd_bus bus;
	char err[256];

	(void)state;
	assert_int_equal(rmd_socketcan_open(&bus, "lo", NULL, err, sizeof(err)), -ENODEV);
	assert_non_null(strstr(err, "lo: not a CAN interface"));
}

static void test_open_interface_down(void **state)
{
	struct rmd_bus bus;
	char err[256];
	int r;

	(void)state;
	sh("ip link add dev vcan7 type vcan"); /* created down */
	r = rmd_socketcan_open(&bus, "vcan7", NULL, err, sizeof(err));
	sh("ip link del dev vcan7");
	assert_int_equal(r, -ENETDOWN);
	assert_string_equal(err, "vcan7: interface is down: run `ip link set vcan7 up`");

	/* A real controller's name gets the bitrate and bus-off restart too. */
	sh("ip link add dev can7 type vcan");
	r = rmd_socketcan_open(&bus, "can7", NULL, err, sizeof(err));
	sh("ip link del dev can7");
	assert_int_equal(r, -ENETDOWN);
	assert_string_equal(err, "can7: interface is down: run `ip link set can7 up type can "
				 "bitrate 1000000 restart-ms 100`");
}

static void test_open_small_txqueuelen(void **state)
{
	const struct rmd_socketcan_motor m = { 1, RMD_PROTO_V3, false };
	struct rmd_socketcan_opts opts = { .motors = &m, .n_motors = 1, .burst = 24 };
	struct rmd_bus bus;
	char err[256];
	int r;

	(void)state;
	sh("ip link add dev vcan8 type vcan && ip link set vcan8 txqueuelen 10 up");
	r = rmd_socketcan_open(&bus, "vcan8", &opts, err, sizeof(err));
	if (r != -ENOBUFS)
		sh("ip link del dev vcan8");
	assert_int_equal(r, -ENOBUFS);
	assert_string_equal(err, "vcan8: txqueuelen 10 cannot hold a 24-frame cycle: run `ip link "
				 "set vcan8 txqueuelen 128`");

	/* Doing what the message says fixes it. */
	sh("ip link set vcan8 txqueuelen 128");
	r = rmd_socketcan_open(&bus, "vcan8", &opts, err, sizeof(err));
	if (r == 0)
		rmd_bus_close(&bus);
	sh("ip link del dev vcan8");
	assert_int_equal(r, 0);
}

static void test_open_bad_motor(void **state)
{
	struct rmd_socketcan_motor m = { 0, RMD_PROTO_V3, false };
	struct rmd_socketcan_opts opts = { .motors = &m, .n_motors = 1 };
	struct rmd_bus bus;
	char err[256];

	(void)state;
	assert_int_equal(rmd_socketcan_open(&bus, "vcan0", &opts, err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "motor id 0 out of range"));
	m.id = 33;
	assert_int_equal(rmd_socketcan_open(&bus, "vcan0", &opts, err, sizeof(err)), -EINVAL);
	m.id = 1;
	m.proto = (enum rmd_proto)7;
	assert_int_equal(rmd_socketcan_open(&bus, "vcan0", &opts, err, sizeof(err)), -EINVAL);
	assert_non_null(strstr(err, "unknown protocol"));
}

static void open_ok(struct rmd_bus *bus, const char *ifname, const struct rmd_socketcan_opts *opts)
{
	char err[256];
	int r = rmd_socketcan_open(bus, ifname, opts, err, sizeof(err));

	if (r != 0)
		fail_msg("open %s: %d: %s", ifname, r, err);
	assert_string_equal(bus->ops->kind, "socketcan");
	assert_string_equal(bus->name, ifname);
	assert_int_equal(bus->state, RMD_BUS_ACTIVE);
}

/*
 * Only the configured reply identifiers arrive: V3 motor 1 (0x241), MIT
 * motor 3 (0x503, and 0x243 for its V3 probes).  Foreign identifiers,
 * requests, 0x300 (not asked for), extended and remote frames are dropped
 * in the kernel, and our own frames do not come back.  The last frame is
 * admitted, so its arrival proves the ones before it were dropped, not late.
 */
static void test_filter(void **state)
{
	static const struct rmd_socketcan_motor motors[] = { { 1, RMD_PROTO_V3, false },
							     { 3, RMD_PROTO_MIT, false } };
	const struct rmd_socketcan_opts opts = { .motors = motors, .n_motors = 2 };
	const struct rmd_frame want[] = { frame(0x241, 8, 1), frame(0x503, 8, 4),
					  frame(0x243, 8, 8), frame(0x241, 4, 11) };
	const struct rmd_frame own = frame(0x241, 8, 99);
	struct rmd_bus_rx rx[16];
	struct rmd_bus bus;
	int peer, n;

	(void)state;
	open_ok(&bus, "vcan0", &opts);
	peer = peer_open("vcan0");

	assert_int_equal(bus_send(&bus, &own, 1), 1);
	peer_send_raw(peer, 0x123, 8, NULL);
	peer_send(peer, &want[0]);
	peer_send_raw(peer, 0x7FF, 8, NULL);
	peer_send_raw(peer, 0x501, 8, NULL); /* MIT reply of motor 1: V3, not MIT */
	peer_send(peer, &want[1]);
	peer_send_raw(peer, 0x141, 8, NULL); /* a V3 request */
	peer_send_raw(peer, 0x300, 8, NULL);
	peer_send_raw(peer, 0x241 | CAN_EFF_FLAG, 8, NULL);
	peer_send_raw(peer, 0x241 | CAN_RTR_FLAG, 0, NULL);
	peer_send(peer, &want[2]);
	peer_send_raw(peer, 0x244, 8, NULL);
	peer_send(peer, &want[3]); /* DLC 4 passes: the codec judges it */

	n = recv_until(&bus, rx, 4, 2000);
	assert_int_equal(n, 4);
	for (int i = 0; i < n; i++)
		assert_frame_equal(&rx[i].f, &want[i], i);
	/* Nothing else is queued. */
	assert_int_equal(bus_recv(&bus, rx, 16), 0);
	assert_int_equal(bus.stats.rx_frames, 4);
	assert_int_equal(bus.stats.rx_errors, 0);
	assert_int_equal(bus.stats.tx_frames, 1);
	assert_int_equal(alloc_count(), 0);

	close(peer);
	rmd_bus_close(&bus);
}

/*
 * Issue 33.5: a V4 motor driven in MIT mode (opts.mit_ids) has its MIT
 * replies on 0x500 + ID admitted beside its 0x240 + ID; a V4 motor not in
 * MIT mode has not.
 */
static void test_filter_mit_mode(void **state)
{
	static const struct rmd_socketcan_motor motors[] = { { 1, RMD_PROTO_V4, false },
							     { 2, RMD_PROTO_V4, false } };
	const struct rmd_socketcan_opts opts = { .motors = motors,
						 .n_motors = 2,
						 .mit_ids = 1u << 1 };
	const struct rmd_frame want[] = { frame(0x502, 8, 1), frame(0x241, 8, 2),
					  frame(0x242, 8, 3) };
	struct rmd_bus_rx rx[8];
	struct rmd_bus bus;
	int peer, n;

	(void)state;
	open_ok(&bus, "vcan0", &opts);
	peer = peer_open("vcan0");
	peer_send_raw(peer, 0x501, 8, NULL); /* motor 1 is not in MIT mode */
	peer_send(peer, &want[0]);
	peer_send(peer, &want[1]);
	peer_send(peer, &want[2]);
	n = recv_until(&bus, rx, 3, 2000);
	assert_int_equal(n, 3);
	for (int i = 0; i < n; i++)
		assert_frame_equal(&rx[i].f, &want[i], i);
	assert_int_equal(bus_recv(&bus, rx, 8), 0);
	close(peer);
	rmd_bus_close(&bus);
}

/* Kernel receive stamps, converted to CLOCK_MONOTONIC, fall between send and receive. */
static void test_timestamps(void **state)
{
	enum { N = 20 };
	const struct rmd_socketcan_motor m = { 2, RMD_PROTO_V3, false };
	const struct rmd_socketcan_opts opts = { .motors = &m, .n_motors = 1 };
	struct rmd_bus_rx rx[N];
	struct rmd_bus bus;
	int64_t t_sent[N], t_recv;
	int peer, n;

	(void)state;
	open_ok(&bus, "vcan0", &opts);
	peer = peer_open("vcan0");
	for (int i = 0; i < N; i++) {
		struct rmd_frame f = frame(0x242, 8, (uint8_t)i);

		t_sent[i] = rmd_now_ns();
		peer_send(peer, &f);
		if (i % 5 == 4)
			next_cycle(); /* spread the stamps out */
	}
	n = recv_until(&bus, rx, N, 2000);
	t_recv = rmd_now_ns();
	assert_int_equal(n, N);
	for (int i = 0; i < N; i++) {
		/* 1 ms of slack for the realtime/monotonic conversion. */
		if (rx[i].t_ns < t_sent[i] - NS_PER_MS || rx[i].t_ns > t_recv)
			fail_msg("frame %d stamped %lld ns after its send, receive %lld ns after",
				 i, (long long)(rx[i].t_ns - t_sent[i]),
				 (long long)(t_recv - t_sent[i]));
		if (i > 0 && rx[i].t_ns < rx[i - 1].t_ns)
			fail_msg("frame %d stamped %lld ns before frame %d", i,
				 (long long)(rx[i - 1].t_ns - rx[i].t_ns), i - 1);
		assert_int_equal(rx[i].f.data[0], i);
	}
	printf("timestamps: first frame %lld us after send, last read %lld us after its stamp\n",
	       (long long)(rx[0].t_ns - t_sent[0]) / 1000,
	       (long long)(t_recv - rx[N - 1].t_ns) / 1000);
	close(peer);
	rmd_bus_close(&bus);
}

/*
 * A burst larger than the transmit queue.  vcan has no queue (qdisc
 * noqueue: every frame is "transmitted" inside sendmsg), so txqueuelen
 * alone never refuses a frame there.  A netem qdisc with a 10-frame limit
 * that drains at a wire rate behaves like a real controller's queue: the
 * burst's tail gets ENOBUFS.  The rate is 100 kbit/s (1.3 ms per frame)
 * rather than 1 Mbit/s because under QEMU's TCG one sendmmsg of 32 frames
 * takes milliseconds, long enough for a 1 Mbit/s queue to drain as it
 * fills.
 */
static void test_burst_over_txqueuelen(void **state)
{
	enum { N = 32 };
	const struct rmd_socketcan_motor m = { 1, RMD_PROTO_V3, false };
	const struct rmd_socketcan_opts opts = { .motors = &m, .n_motors = 1 };
	struct rmd_frame tx[N], rx[N + 1];
	struct rmd_bus bus;
	int64_t t0, slowest = 0;
	int peer, first, sent, calls = 1, n;

	(void)state;
	for (int i = 0; i < N; i++)
		tx[i] = frame(0x141 + (unsigned)(i % 4), 8, (uint8_t)i);

	/* Plain vcan: the whole burst goes in one call whatever txqueuelen says. */
	sh("ip link set vcan1 txqueuelen 10");
	open_ok(&bus, "vcan1", &opts);
	peer = peer_open("vcan1");
	assert_int_equal(bus_send(&bus, tx, N), N);
	assert_int_equal(peer_recv(peer, rx, N, 2000), N);
	close(peer);
	rmd_bus_close(&bus);

	if (system("modprobe sch_netem 2>/dev/null; "
		   "tc qdisc replace dev vcan1 root netem rate 100kbit limit 10") != 0) {
		printf("SKIP burst: cannot add a netem qdisc to vcan1 (sch_netem, tc)\n");
		skip();
	}
	open_ok(&bus, "vcan1", &opts);
	peer = peer_open("vcan1");

	t0 = rmd_now_ns();
	first = bus_send(&bus, tx, N);
	slowest = rmd_now_ns() - t0;
	if (first < 0 || first >= N)
		fail_msg("first send of %d frames returned %d in %lld us: want a refused tail", N,
			 first, (long long)slowest / 1000);
	assert_true(bus.stats.tx_busy >= (uint64_t)(N - first));
	sent = first;
	while (sent < N && calls < 5000) {
		int64_t t;
		int r;

		next_cycle();
		t = rmd_now_ns();
		r = bus_send(&bus, tx + sent, (unsigned)(N - sent));
		t = rmd_now_ns() - t;
		slowest = t > slowest ? t : slowest;
		assert_true(r >= 0);
		sent += r;
		calls++;
	}
	printf("burst: %d of %d frames in the first call, the rest in %d more; tx_busy %llu, "
	       "slowest call %lld us\n",
	       first, N, calls - 1, (unsigned long long)bus.stats.tx_busy,
	       (long long)slowest / 1000);
	assert_int_equal(sent, N);
	assert_int_equal(bus.stats.tx_frames, N);
	assert_true(slowest < 100 * NS_PER_MS); /* never blocks; TCG is slow, not blocking */

	n = peer_recv(peer, rx, N + 1, 1000);
	sh_try("tc qdisc del dev vcan1 root");
	assert_int_equal(n, N);
	for (int i = 0; i < N; i++)
		assert_frame_equal(&rx[i], &tx[i], i);
	assert_int_equal(alloc_count(), 0);
	close(peer);
	rmd_bus_close(&bus);
}

/*
 * Error frames.  vcan cannot go bus-off, but an error frame written by a
 * second raw socket reaches every socket whose CAN_RAW_ERR_FILTER admits
 * its class, which is how a controller's error frames reach us.
 */
static void test_error_frames_on_vcan(void **state)
{
	static const struct {
		canid_t cls;
		uint8_t ctrl;
		enum rmd_bus_state want;
		uint64_t bus_errors;
	} steps[] = {
		{ CAN_ERR_CRTL, CAN_ERR_CRTL_TX_WARNING, RMD_BUS_WARNING, 1 },
		{ CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE, RMD_BUS_PASSIVE, 2 },
		{ CAN_ERR_BUSOFF, 0, RMD_BUS_OFF, 3 },
		{ CAN_ERR_LOSTARB, 0, RMD_BUS_OFF, 3 }, /* not in our error mask */
		{ CAN_ERR_RESTARTED, 0, RMD_BUS_ACTIVE, 4 },
	};
	const struct rmd_socketcan_motor m = { 1, RMD_PROTO_V3, false };
	const struct rmd_socketcan_opts opts = { .motors = &m, .n_motors = 1 };
	const struct rmd_frame sentinel = frame(0x241, 8, 0x55);
	struct rmd_bus_rx rx[4];
	struct rmd_bus bus;
	int peer;

	(void)state;
	open_ok(&bus, "vcan2", &opts);
	peer = peer_open("vcan2");
	for (size_t i = 0; i < sizeof(steps) / sizeof(steps[0]); i++) {
		struct can_frame cf = err_frame(steps[i].cls, steps[i].ctrl);

		peer_send_raw(peer, cf.can_id, cf.len, cf.data);
		peer_send(peer, &sentinel);
		assert_int_equal(recv_until(&bus, rx, 1, 2000), 1);
		assert_frame_equal(&rx[0].f, &sentinel, (int)i);
		if (bus.state != steps[i].want || bus.stats.bus_errors != steps[i].bus_errors)
			fail_msg("step %zu (class %03X): state %s, bus_errors %llu; want %s, %llu",
				 i, steps[i].cls, rmd_bus_state_name(bus.state),
				 (unsigned long long)bus.stats.bus_errors,
				 rmd_bus_state_name(steps[i].want),
				 (unsigned long long)steps[i].bus_errors);
	}
	assert_int_equal(bus.stats.state_changes, 4);
	assert_int_equal(bus.stats.rx_frames, 5); /* the sentinels only */
	assert_int_equal(alloc_count(), 0);
	close(peer);
	rmd_bus_close(&bus);
}

/* Receive (nothing but error frames come) until the bus counted `errors` of them. */
static void recv_errors(struct rmd_bus *bus, uint64_t errors)
{
	struct rmd_bus_rx rx[4];

	for (int k = 0; k < 2000 && bus->stats.bus_errors < errors; k++) {
		struct pollfd pfd = { .fd = rmd_bus_fd(bus), .events = POLLIN };

		if (poll(&pfd, 1, 1) > 0)
			assert_int_equal(bus_recv(bus, rx, 4), 0);
	}
	assert_int_equal(bus->stats.bus_errors, errors);
}

/*
 * Nobody acknowledges, on vcan: the error frames a controller sends when
 * no node acknowledges (CAN_ERR_ACK with berr-reporting, the transmitter's
 * error-passive state without), written by a second socket, make the bus
 * RMD_BUS_NO_ACK; a data frame from a motor ends it.  Then the other way
 * in: error-passive and a queue that refuses frames (a netem qdisc that
 * holds what it takes, as a controller nobody acknowledges holds its queue).
 * What vcan cannot show: a real controller's own error frames and its
 * buffers (docs/faults.md "E-stop").
 */
static void test_no_ack_on_vcan(void **state)
{
	const struct rmd_socketcan_motor m = { 1, RMD_PROTO_V3, false };
	const struct rmd_socketcan_opts opts = { .motors = &m, .n_motors = 1 };
	const struct rmd_frame reply = frame(0x241, 8, 0x9C);
	struct can_frame ack = err_frame(CAN_ERR_ACK, 0);
	struct can_frame passive = err_frame(CAN_ERR_CRTL, CAN_ERR_CRTL_TX_PASSIVE);
	struct rmd_frame tx[8];
	struct rmd_bus_rx rx[4];
	struct rmd_bus bus;
	int peer, sent = 0;

	(void)state;
	for (int i = 0; i < 8; i++)
		tx[i] = frame(0x141, 8, (uint8_t)i);
	open_ok(&bus, "vcan2", &opts);
	peer = peer_open("vcan2");
	for (int i = 0; i < RMD_SOCKETCAN_NO_ACK_ERRORS; i++)
		peer_send_raw(peer, ack.can_id, ack.len, ack.data);
	recv_errors(&bus, RMD_SOCKETCAN_NO_ACK_ERRORS);
	assert_int_equal(rmd_bus_state(&bus), RMD_BUS_NO_ACK);
	assert_int_equal(bus.stats.state_changes, 1);
	/* motor 1 answers: a powered node, which acknowledges */
	peer_send(peer, &reply);
	assert_int_equal(recv_until(&bus, rx, 1, 2000), 1);
	assert_int_equal(rmd_bus_state(&bus), RMD_BUS_ACTIVE);
	assert_int_equal(bus.stats.state_changes, 2);

	if (system("modprobe sch_netem 2>/dev/null; "
		   "tc qdisc replace dev vcan2 root netem delay 10s limit 4") != 0) {
		printf("SKIP no-ack by ENOBUFS: cannot add a netem qdisc to vcan2 (sch_netem, tc)\n");
		close(peer);
		rmd_bus_close(&bus);
		skip();
	}
	peer_send_raw(peer, passive.can_id, passive.len, passive.data);
	recv_errors(&bus, RMD_SOCKETCAN_NO_ACK_ERRORS + 1);
	assert_int_equal(rmd_bus_state(&bus), RMD_BUS_PASSIVE);
	for (int k = 0; k < 8 && sent < 8; k++) {
		int r = bus_send(&bus, tx + sent, (unsigned)(8 - sent));

		assert_true(r >= 0);
		sent += r;
		if (r == 0)
			break;
	}
	assert_true(sent <= 5); /* the qdisc's 4, and one in flight */
	assert_int_equal(rmd_bus_state(&bus), RMD_BUS_NO_ACK);
	sh("tc qdisc del dev vcan2 root");
	assert_int_equal(alloc_count(), 0);
	close(peer);
	rmd_bus_close(&bus);
}

/* Drop CAP_NET_ADMIN from this process: SocketCAN without it (a service without the grant). */
static void drop_net_admin(void)
{
	struct __user_cap_header_struct h = { .version = _LINUX_CAPABILITY_VERSION_3 };
	struct __user_cap_data_struct d[2];

	assert_int_equal(syscall(SYS_capget, &h, d), 0);
	d[CAP_NET_ADMIN / 32].effective &= ~(1u << (CAP_NET_ADMIN % 32));
	d[CAP_NET_ADMIN / 32].permitted &= ~(1u << (CAP_NET_ADMIN % 32));
	assert_int_equal(syscall(SYS_capset, &h, d), 0);
}

/*
 * What flush drops.  A vxcan pair, because vcan hands every frame to the
 * host's other sockets as it is sent (the CAN core's loopback), before its
 * queue: on vxcan8 -> vxcan9 a frame reaches the peer's end only when it
 * leaves vxcan8's queue, as a frame reaches the wire when it leaves a
 * controller's.  A netem qdisc on vxcan8 holds each frame for 1 s, as the
 * queue behind a controller nobody acknowledges holds them.  After
 * rmd_bus_flush() none of the four held frames reaches vxcan9: restarting
 * the interface reset its queue; it is up again, its qdisc in place, and
 * the same socket sends and receives.  Without CAP_NET_ADMIN (a child that
 * dropped it) flush says -EPERM and changes nothing: the four go out, the
 * replay.  The driver's and controller's own buffers, which virtual
 * interfaces lack, are not tested here (docs/faults.md "E-stop").
 */
static void test_flush_on_vcan(void **state)
{
	const struct rmd_socketcan_motor m = { 1, RMD_PROTO_V3, false };
	const struct rmd_socketcan_opts opts = { .motors = &m, .n_motors = 1 };
	const struct rmd_frame reply = frame(0x241, 8, 0x9C);
	struct rmd_frame tx[4], rx[8];
	struct rmd_bus_rx brx[4];
	struct rmd_bus bus;
	int64_t t;
	int peer, status;
	pid_t pid;

	(void)state;
	for (int i = 0; i < 4; i++)
		tx[i] = frame(0x141, 8, (uint8_t)(0x40 + i));
	if (system("modprobe vxcan 2>/dev/null; modprobe sch_netem 2>/dev/null; "
		   "ip link add vxcan8 type vxcan peer name vxcan9 && ip link set vxcan8 up && "
		   "ip link set vxcan9 up && "
		   "tc qdisc replace dev vxcan8 root netem delay 1s limit 16") != 0) {
		printf("SKIP flush: cannot make a vxcan pair with a netem qdisc (vxcan, sch_netem, "
		       "tc)\n");
		sh_try("ip link del vxcan8 2>/dev/null");
		skip();
	}
	open_ok(&bus, "vxcan8", &opts);
	peer = peer_open("vxcan9");
	assert_int_equal(bus_send(&bus, tx, 4), 4);
	t = rmd_now_ns();
	assert_int_equal(rmd_bus_flush(&bus), 0);
	t = rmd_now_ns() - t;
	printf("flush: vxcan8 restarted in %lld us\n", (long long)(t / 1000));
	sh("ip link show vxcan8 | grep -q ',UP'");
	sh("tc qdisc show dev vxcan8 | grep -q netem");
	/* the socket works on: a frame out (1 s late, through netem), a reply in */
	assert_int_equal(bus_send(&bus, tx + 3, 1), 1);
	assert_int_equal(peer_recv(peer, rx, 8, 3000), 1); /* none of the four held */
	assert_frame_equal(&rx[0], &tx[3], 0);
	peer_send(peer, &reply);
	assert_int_equal(recv_until(&bus, brx, 1, 2000), 1);
	rmd_bus_close(&bus);

	/* without CAP_NET_ADMIN: refused, and the queue replays */
	pid = fork();
	assert_true(pid >= 0);
	if (pid == 0) {
		struct rmd_bus b;
		char err[256];

		drop_net_admin();
		if (rmd_socketcan_open(&b, "vxcan8", &opts, err, sizeof(err)) != 0)
			_exit(2);
		if (rmd_bus_send(&b, tx, 4, 0) != 4)
			_exit(3);
		_exit(rmd_bus_flush(&b) == -EPERM ? 0 : 4);
	}
	assert_int_equal(waitpid(pid, &status, 0), pid);
	assert_true(WIFEXITED(status));
	assert_int_equal(WEXITSTATUS(status), 0);
	assert_int_equal(peer_recv(peer, rx, 8, 3000), 4);
	for (int i = 0; i < 4; i++)
		assert_frame_equal(&rx[i], &tx[i], i);
	close(peer);
	sh_try("ip link del vxcan8");
}

/* True once some socket listens to every frame of `ifname` (candump is bound). */
static bool all_frames_listener(const char *ifname)
{
	char line[256];
	bool found = false;
	FILE *f = fopen("/proc/net/can/rcvlist_all", "r");

	if (!f)
		return false;
	while (!found && fgets(line, sizeof(line), f)) {
		char dev[IFNAMSIZ + 1];

		found = sscanf(line, " %16s", dev) == 1 && !strcmp(dev, ifname);
	}
	fclose(f);
	return found;
}

/* candump, run alongside, sees exactly the frames sent: count and content. */
static void test_candump_sees_sent_frames(void **state)
{
	enum { N = 100, PER_CYCLE = 20 };
	const char *log = "/dev/shm/rmd_test_bus_socketcan.log";
	const struct rmd_socketcan_motor m = { 1, RMD_PROTO_V3, false };
	const struct rmd_socketcan_opts opts = { .motors = &m, .n_motors = 1, .burst = PER_CYCLE };
	struct rmd_frame tx[N];
	struct rmd_bus bus;
	char line[256];
	int64_t deadline;
	int status, sent = 0, lines = 0;
	pid_t pid;
	FILE *f;

	(void)state;
	if (system("command -v candump >/dev/null") != 0) {
		printf("SKIP candump: candump not installed (can-utils)\n");
		skip();
	}
	for (int i = 0; i < N; i++)
		tx[i] = frame(0x141 + (unsigned)(i % 7), (uint8_t)(i % 9), (uint8_t)(3 * i));

	pid = fork();
	assert_true(pid >= 0);
	if (pid == 0) {
		int fd = open(log, O_WRONLY | O_CREAT | O_TRUNC, 0644);

		if (fd < 0 || dup2(fd, STDOUT_FILENO) < 0)
			_exit(126);
		execlp("timeout", "timeout", "60", "candump", "-r", "4194304", "-L", "-n", "100",
		       "vcan2", (char *)NULL);
		_exit(127);
	}
	deadline = rmd_now_ns() + 20000 * NS_PER_MS;
	while (!all_frames_listener("vcan2") && rmd_now_ns() < deadline)
		next_cycle();
	assert_true(all_frames_listener("vcan2"));

	open_ok(&bus, "vcan2", &opts);
	while (sent < N) {
		int r = bus_send(&bus, tx + sent, PER_CYCLE);

		assert_true(r >= 0);
		sent += r;
		next_cycle();
	}
	assert_int_equal(bus.stats.tx_frames, N);
	assert_int_equal(waitpid(pid, &status, 0), pid);
	rmd_bus_close(&bus);
	if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
		fail_msg("candump exited with status %#x", status);

	/* "(1700000000.000000) vcan2 141#0003060C" */
	f = fopen(log, "r");
	assert_non_null(f);
	while (fgets(line, sizeof(line), f)) {
		char want[64], *got = strchr(line, ')');
		int k;

		assert_true(lines < N);
		k = snprintf(want, sizeof(want), " vcan2 %03X#", tx[lines].can_id);
		for (int j = 0; j < tx[lines].len; j++)
			k += snprintf(want + k, sizeof(want) - (size_t)k, "%02X",
				      tx[lines].data[j]);
		line[strcspn(line, "\n")] = '\0';
		if (!got || strcmp(got + 1, want))
			fail_msg("candump line %d: \"%s\", want \"%s\"", lines, line, want);
		lines++;
	}
	fclose(f);
	unlink(log);
	assert_int_equal(lines, N);
}

/*
 * recv() never returns more than asked, drains more than one recvmmsg
 * batch in a call, and keeps the order.
 */
static void test_recv_batches(void **state)
{
	enum { BIG = 150, SMALL = 20, MAX_SMALL = 7 };
	const struct rmd_socketcan_motor m = { 5, RMD_PROTO_V3, false };
	const struct rmd_socketcan_opts opts = { .motors = &m, .n_motors = 1 };
	struct rmd_bus_rx rx[BIG];
	struct rmd_bus bus;
	int peer, got = 0;

	(void)state;
	open_ok(&bus, "vcan0", &opts);
	peer = peer_open("vcan0");
	for (int i = 0; i < BIG; i++) {
		struct rmd_frame f = frame(0x245, 8, (uint8_t)i);

		peer_send(peer, &f);
	}
	assert_int_equal(recv_until(&bus, rx, BIG, 2000), BIG);
	for (int i = 0; i < BIG; i++)
		assert_int_equal(rx[i].f.data[0], (uint8_t)i);

	for (int i = 0; i < SMALL; i++) {
		struct rmd_frame f = frame(0x245, 8, (uint8_t)i);

		peer_send(peer, &f);
	}
	while (got < SMALL) {
		struct pollfd pfd = { .fd = rmd_bus_fd(&bus), .events = POLLIN };
		int r;

		assert_true(poll(&pfd, 1, 2000) == 1);
		r = bus_recv(&bus, rx + got, MAX_SMALL);
		assert_true(r >= 0 && r <= MAX_SMALL);
		got += r;
	}
	for (int i = 0; i < SMALL; i++)
		assert_int_equal(rx[i].f.data[0], (uint8_t)i);
	assert_int_equal(bus_recv(&bus, rx, BIG), 0);
	assert_int_equal(bus.stats.rx_frames, BIG + SMALL);
	assert_int_equal(alloc_count(), 0);
	close(peer);
	rmd_bus_close(&bus);
}

/*
 * Frames the kernel drops because our receive buffer is full are counted
 * (SO_RXQ_OVFL) as receive errors.  The kernel reports the drop count with
 * the next frame it does queue, hence the last frame, sent after a read.
 */
static void test_rx_overflow_counted(void **state)
{
	enum { N = 50 };
	const struct rmd_socketcan_motor m = { 6, RMD_PROTO_V3, false };
	const struct rmd_socketcan_opts opts = { .motors = &m, .n_motors = 1, .rcvbuf_bytes = 1 };
	struct rmd_bus_rx rx[N + 1];
	struct rmd_bus bus;
	int peer, got;

	(void)state;
	open_ok(&bus, "vcan0", &opts);
	peer = peer_open("vcan0");
	for (int i = 0; i < N; i++) {
		struct rmd_frame f = frame(0x246, 8, (uint8_t)i);

		peer_send(peer, &f);
	}
	got = recv_until(&bus, rx, N, 200);
	assert_true(got > 0 && got < N);
	{
		struct rmd_frame last = frame(0x246, 8, 0xEE);

		peer_send(peer, &last);
	}
	got += recv_until(&bus, rx, 1, 2000);
	printf("overflow: receive buffer %d bytes held %d of %d frames\n",
	       rmd_socketcan_rcvbuf(&bus), got - 1, N);
	assert_int_equal(bus.stats.rx_frames, (uint64_t)got);
	assert_int_equal(bus.stats.rx_frames + bus.stats.rx_errors, N + 1);
	close(peer);
	rmd_bus_close(&bus);
}

static void test_fd_and_close(void **state)
{
	static const struct rmd_bus zero;
	struct rmd_bus bus;
	int fd;

	(void)state;
	open_ok(&bus, "vcan0", NULL); /* sniffer: no filter list */
	fd = rmd_bus_fd(&bus);
	assert_true(fd >= 0);
	assert_true(fcntl(fd, F_GETFL) & O_NONBLOCK);
	assert_true(rmd_socketcan_rcvbuf(&bus) > 0);
	rmd_bus_close(&bus);
	assert_memory_equal(&bus, &zero, sizeof(bus));
	assert_int_equal(fcntl(fd, F_GETFD), -1); /* the socket is closed */
	rmd_bus_close(&bus);			  /* closed: no-op */
}

/* caps and next_due_ns of a CAN bus; the other transports' accessors refuse it. */
static void test_caps_and_accessors(void **state)
{
	struct rmd_rs485_stats xs;
	struct rmd_bus bus;

	(void)state;
	open_ok(&bus, "vcan0", NULL);
	assert_false(rmd_bus_caps(&bus)->half_duplex);
	assert_int_equal(rmd_bus_caps(&bus)->reply_timeout_ns, 0);
	assert_int_equal(rmd_bus_caps(&bus)->request_spacing_ns, RMD_BUS_CAN_SPACING_NS);
	assert_int_equal(rmd_bus_caps(&bus)->queue_len, 0);
	assert_int_equal(rmd_bus_next_due_ns(&bus), INT64_MAX);
	assert_int_equal(rmd_rs485_stats(&bus, &xs), -EINVAL);
	assert_null(rmd_bus_sim_get(&bus));
	rmd_bus_close(&bus);
}

/*
 * The device role (rmd-sim's side, opened through the factory): requests to
 * every id come in, replies do not.
 */
static void test_device_role(void **state)
{
	const struct rmd_bus_open_opts o = { .proto = RMD_PROTO_V3, .device = true };
	const struct rmd_frame want[] = { frame(0x141, 8, 1), frame(0x160, 8, 2),
					  frame(0x280, 8, 3), frame(0x300, 8, 4),
					  frame(0x41F, 8, 5) };
	struct rmd_bus_rx rx[16];
	struct rmd_bus bus;
	char err[256];
	int peer, n;

	(void)state;
	assert_int_equal(rmd_bus_open_spec(&bus, "vcan0", &o, err, sizeof(err)), 0);
	peer = peer_open("vcan0");
	peer_send(peer, &want[0]);
	peer_send_raw(peer, 0x241, 8, NULL); /* a reply */
	peer_send(peer, &want[1]);
	peer_send_raw(peer, 0x161, 8, NULL); /* no id 33 */
	peer_send(peer, &want[2]);
	peer_send_raw(peer, 0x501, 8, NULL); /* an MIT reply */
	peer_send(peer, &want[3]);
	peer_send(peer, &want[4]);
	n = recv_until(&bus, rx, 5, 2000);
	assert_int_equal(n, 5);
	for (int i = 0; i < n; i++)
		assert_frame_equal(&rx[i].f, &want[i], i);
	assert_int_equal(bus_recv(&bus, rx, 16), 0);
	close(peer);
	rmd_bus_close(&bus);
}

/*
 * The tests judge the order in which other sockets see frames.  A raw
 * socket's sent frame reaches them as a copy put on the sending CPU's
 * receive backlog (af_can.c can_send(): vcan has no IFF_ECHO), so a sender
 * that migrates to the other vCPU between two frames can have them seen
 * out of order when the first CPU's backlog waits (seen on a busy guest:
 * frame 1 before frame 0).  Only those local copies are reordered: the
 * device gets the frames in the qdisc's order, and a real CAN controller
 * echoes them from its driver in that order.  One CPU keeps the copies in
 * the order sent.
 */
static void pin_to_one_cpu(void)
{
	cpu_set_t set;
	int cpu = sched_getcpu();

	CPU_ZERO(&set);
	CPU_SET(cpu >= 0 ? cpu : 0, &set);
	if (sched_setaffinity(0, sizeof(set), &set) != 0)
		printf("note: sched_setaffinity to CPU %d failed: frames sent may be seen out "
		       "of order on a busy guest\n",
		       cpu);
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_error_frame_states),
		cmocka_unit_test(test_no_ack_states),
		cmocka_unit_test(test_open_bad_name),
		cmocka_unit_test(test_open_no_socketcan),
		cmocka_unit_test(test_open_missing_interface),
		cmocka_unit_test(test_open_not_can),
		cmocka_unit_test(test_open_interface_down),
		cmocka_unit_test(test_open_small_txqueuelen),
		cmocka_unit_test(test_open_bad_motor),
		cmocka_unit_test(test_filter),
		cmocka_unit_test(test_filter_mit_mode),
		cmocka_unit_test(test_timestamps),
		cmocka_unit_test(test_burst_over_txqueuelen),
		cmocka_unit_test(test_error_frames_on_vcan),
		cmocka_unit_test(test_no_ack_on_vcan),
		cmocka_unit_test(test_flush_on_vcan),
		cmocka_unit_test(test_candump_sees_sent_frames),
		cmocka_unit_test(test_recv_batches),
		cmocka_unit_test(test_rx_overflow_counted),
		cmocka_unit_test(test_fd_and_close),
		cmocka_unit_test(test_caps_and_accessors),
		cmocka_unit_test(test_device_role),
		cmocka_unit_test(test_vcan_suite_needs_socketcan),
	};
	const struct CMUnitTest host_tests[] = {
		cmocka_unit_test(test_error_frame_states),
		cmocka_unit_test(test_no_ack_states),
		cmocka_unit_test(test_open_bad_name),
		cmocka_unit_test(test_open_no_socketcan),
		cmocka_unit_test(test_vcan_suite_needs_socketcan),
	};
	int fd = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);

	have_socketcan = fd >= 0;
	if (fd >= 0)
		close(fd);
	if (!have_socketcan) {
		printf("SKIP: no SocketCAN in this kernel (run via tests/vm/vm-run)\n");
		return SUITE_RUN("bus_socketcan", host_tests, NULL, NULL);
	}
	pin_to_one_cpu();
	return SUITE_RUN("bus_socketcan", tests, NULL, NULL);
}
