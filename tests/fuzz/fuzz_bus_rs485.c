// SPDX-License-Identifier: MIT
/*
 * The RS485 bus's receive path (src/bus/bus_rs485.c) as test_bus_rs485
 * drives it: the bus opens the slave of a fresh pseudo-terminal pair and
 * the harness, on the master side, is the line: it writes any bytes the
 * input gives (noise, partial and corrupt frames, replies to what the bus
 * sent), while the bus sends requests and receives with the time the input
 * says, so replies, echoes, broadcasts, resynchronisation and timeouts all
 * come into play.  Every frame recv() returns is an 8-byte frame on a
 * reply identifier (0x241..0x260, or 0x300 from 0xCD); recv() never
 * returns more than asked for; the transport's counters stay consistent.
 *
 * Input: [0] options (bit 0 local echo, bits 1..3 broadcast replies);
 * then records, [0] op:
 *   0: send: [1..2] CAN identifier, [3] DLC, [4..11] data
 *   1: line: [1] n, then n bytes written by the "motors"
 *   2: a valid frame on the line: [1] RS485 id, [2..9] data
 *   3: time passes: [1] x 100 us
 * and after each record the bus receives (at most op >> 2 & 7 + 1 frames
 * a call) until it has nothing more.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <sys/ioctl.h>

#include "rmd/bus.h"
#include "rmd/bus_rs485.h"
#include "rmd/rs485.h"

#include "fuzz.h"

#define MAX_RECORDS 64
/*
 * The pty moves bytes through the kernel's tty worker, a normal-priority
 * kernel thread: on a busy machine it held them 0.5-0.8 s (an hour's run
 * beside other work failed here at 500 ms; tests/harness/pty_probe.h).
 * This only bounds a stuck run.
 */
#define WAIT_MS 10000

static int pty_open(char *path, size_t len)
{
	int fd = posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC | O_NONBLOCK);

	FUZZ_CHECK(fd >= 0);
	FUZZ_CHECK(grantpt(fd) == 0 && unlockpt(fd) == 0);
	FUZZ_CHECK(ptsname_r(fd, path, len) == 0);
	return fd;
}

/* What the bus wrote to the line: read and forget. */
static void drain(int master)
{
	uint8_t buf[512];

	while (read(master, buf, sizeof(buf)) > 0)
		;
}

static int64_t ms_since(const struct timespec *t0)
{
	struct timespec t;

	clock_gettime(CLOCK_MONOTONIC, &t);
	return (int64_t)(t.tv_sec - t0->tv_sec) * 1000 + (t.tv_nsec - t0->tv_nsec) / 1000000;
}

/*
 * Write to the line and wait until the bus's side can read all of it.  The
 * write itself may take part of it, or be interrupted (libFuzzer's alarm),
 * while the tty worker is held off: the rest goes on, within WAIT_MS.
 */
static void line_write(int master, int slave, const uint8_t *buf, size_t len)
{
	int avail = 0, before = 0;
	struct timespec t0;
	size_t done = 0;

	if (!len)
		return;
	FUZZ_CHECK(ioctl(slave, FIONREAD, &before) == 0);
	clock_gettime(CLOCK_MONOTONIC, &t0);
	while (done < len) {
		ssize_t w = write(master, buf + done, len - done);

		if (w > 0)
			done += (size_t)w;
		else
			FUZZ_CHECK(w < 0 && (errno == EAGAIN || errno == EINTR));
		FUZZ_CHECK(ms_since(&t0) <= WAIT_MS || !"the pty took no more bytes");
		if (done < len)
			poll(NULL, 0, 1);
	}
	for (;;) {
		FUZZ_CHECK(ioctl(slave, FIONREAD, &avail) == 0);
		if ((size_t)avail >= (size_t)before + len)
			return;
		if (ms_since(&t0) > WAIT_MS)
			break;
		poll(NULL, 0, 1);
	}
	FUZZ_CHECK(!"the pty did not pass the bytes on");
}

static void receive(struct rmd_bus *bus, unsigned max, int64_t now)
{
	struct rmd_bus_rx rx[8];
	int n;

	do {
		n = rmd_bus_recv(bus, rx, max, now);
		FUZZ_CHECK(n >= 0 && (unsigned)n <= max);
		for (int i = 0; i < n; i++) {
			uint32_t id = rx[i].f.can_id;

			FUZZ_CHECK(rx[i].f.len == RMD_FRAME_LEN);
			FUZZ_CHECK((id > RMD_CAN_V3_REPLY_BASE &&
				    id <= RMD_CAN_V3_REPLY_BASE + RMD_MAX_MOTORS) ||
				   id == RMD_CAN_SET_ID);
			FUZZ_CHECK(rx[i].t_ns == now);
		}
	} while (n == (int)max);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static struct rmd_bus bus;
	struct fuzz_in in = { data, size };
	struct rmd_rs485_opts opts = { .baud = 1000000 };
	struct rmd_rs485_stats xs;
	char path[64], err[256];
	uint8_t head = fuzz_u8(&in);
	int64_t now = 1000000000;
	int master, r;

	opts.local_echo = head & 1;
	opts.broadcast_replies = (head >> 1) & 7;
	master = pty_open(path, sizeof(path));
	r = rmd_rs485_open(&bus, path, &opts, err, sizeof(err));
	FUZZ_CHECK(r == 0);
	for (int k = 0; k < MAX_RECORDS && in.n > 0; k++) {
		uint8_t op = fuzz_u8(&in), buf[256], d[RMD_FRAME_LEN], id;
		struct rmd_frame f;
		size_t len;

		switch (op & 3) {
		case 0:
			f.can_id = fuzz_u16(&in);
			f.len = fuzz_u8(&in);
			fuzz_take(&in, f.data, sizeof(f.data));
			r = rmd_bus_send(&bus, &f, 1, now);
			FUZZ_CHECK(r == -EINVAL || r == 0 || r == 1);
			break;
		case 1:
			len = fuzz_u8(&in);
			len = len < in.n ? len : in.n;
			fuzz_take(&in, buf, len);
			line_write(master, rmd_bus_fd(&bus), buf, len);
			break;
		case 2:
			id = fuzz_u8(&in);
			fuzz_take(&in, d, sizeof(d));
			if (rmd_rs485_build(id, d, buf, sizeof(buf)) == RMD_RS485_FRAME_LEN)
				line_write(master, rmd_bus_fd(&bus), buf, RMD_RS485_FRAME_LEN);
			break;
		default:
			now += (int64_t)fuzz_u8(&in) * 100000;
			break;
		}
		drain(master);
		receive(&bus, ((op >> 2) & 7) + 1, now);
		FUZZ_CHECK(rmd_bus_next_due_ns(&bus) >= 0);
		FUZZ_CHECK(rmd_rs485_stats(&bus, &xs) == 0);
		FUZZ_CHECK(xs.pending <= RMD_RS485_QUEUE);
	}
	rmd_bus_close(&bus);
	close(master);
	return 0;
}
