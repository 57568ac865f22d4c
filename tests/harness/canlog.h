/* SPDX-License-Identifier: MIT */
/*
 * The wire as candump saw it, for the SocketCAN system suites: candump
 * (can-utils) runs beside the test on the buses it watches, logging with
 * the kernel's receive times (candump -L: CLOCK_REALTIME), and the test
 * reads that log as it grows.  A marker frame (CANLOG_MARKER_ID, which no
 * motor nor rmdd listens to) sent on every bus tells when the log has
 * caught up with "now" (canlog_sync()).  The test also sends frames of its
 * own (a status read) on raw sockets.  Every wait polls until a deadline.
 */
#ifndef RMD_TESTS_CANLOG_H
#define RMD_TESTS_CANLOG_H

#include <pthread.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/frame.h"
#include "harness/proc.h"

#define CANLOG_BUSES 3		/* buses one log follows at most */
#define CANLOG_MARKER_ID 0x7E0u /* not a motor's, not rmdd's: nobody answers it */
#define CANLOG_IFACE_LEN 16	/* IFNAMSIZ */
#define CANLOG_T_END INT64_MAX	/* "no end" of a time window */

/* One frame of candump's log. */
struct cframe {
	int64_t t_ns; /* kernel receive time, CLOCK_REALTIME */
	uint16_t id;
	uint8_t bus; /* index into the log's interfaces */
	uint8_t len;
	uint8_t data[RMD_FRAME_LEN];
};

struct sleeper;

/* candump on up to CANLOG_BUSES interfaces, and what its log said so far. */
struct canlog {
	unsigned nbus;
	char iface[CANLOG_BUSES][CANLOG_IFACE_LEN];
	char path[192]; /* candump's log */
	struct kid *candump;
	int log_fd;
	int can_fd[CANLOG_BUSES]; /* send only: markers and the test's own requests */
	char lbuf[256 * 1024];
	size_t llen;
	struct cframe *frames; /* in the order of the log (it merges sockets: not in time order) */
	size_t nframes, cap;
	unsigned bad_lines, drop_lines; /* lines that were no frame; candump's DROPCOUNT lines */
	char drop_text[160];
	uint32_t marker, marker_seen[CANLOG_BUSES];
};

/* CLOCK_REALTIME now, ns: the clock of candump's times. */
int64_t real_ns(void);

/* A log that follows nothing yet (every descriptor closed). */
void canlog_init(struct canlog *c);

/*
 * Start candump on the n interfaces ifaces[] (its log into path), at
 * SCHED_FIFO priority fifo (0: normal), and open a raw socket on each to
 * send from; wait (canlog_sync()) until candump logs.  service runs while
 * it waits, for at most sync_ms in all.
 */
void canlog_start(struct canlog *c, const char *path, const char *const *ifaces, unsigned n,
		  int fifo, int sync_ms, service_fn *service, struct sleeper *ref);

/* Take what candump wrote since the last call. */
void canlog_tail(struct canlog *c);

/* Forget the frames logged so far (each step of a test looks at its own). */
void canlog_forget(struct canlog *c);

/*
 * Wait until the log holds everything sent on every bus before this call:
 * a marker on each, sent again every 200 ms (candump may not listen yet
 * when the first one passes), until candump logged it; service (NULL:
 * none) runs meanwhile.  Fails after ms, saying how long the machine held
 * the reference sleeper ref (NULL: none) off meanwhile.
 */
void canlog_sync(struct canlog *c, int ms, service_fn *service, struct sleeper *ref);

/* Close the log's descriptors and free its frames (candump is the caller's kid). */
void canlog_free(struct canlog *c);

/*
 * A raw CAN socket bound to iface, non-blocking: receiving everything, or
 * (receive false) nothing, only to send.  Fails the test when it cannot.
 */
int can_raw_open(const char *iface, bool receive);

/* Write one 8-byte frame to bus b of the log; fails the test when it cannot. */
void canlog_send(struct canlog *c, unsigned b, uint32_t id, const uint8_t data[RMD_FRAME_LEN]);

/*
 * Send req (8 bytes) on bus b with identifier req_id and return the first
 * frame read on rx_fd (a receiving can_raw_open() socket on that bus) with
 * identifier rep_id whose first byte is req[0]: the motor's answer.
 * service (NULL: none) runs meanwhile; fails after ms.
 */
struct rmd_frame canlog_ask(struct canlog *c, int rx_fd, unsigned b, uint32_t req_id,
			    const uint8_t req[RMD_FRAME_LEN], uint32_t rep_id, int ms,
			    service_fn *service);

/*
 * When a frame is delivered: candump's times are the kernel's receive
 * times, taken when a frame is queued for the sockets, and on a busy
 * machine the kernel may deliver it later (its softirq left to ksoftirqd, a
 * normal-priority thread that the real-time ones hold off).  A watch reads
 * one identifier on its own socket in a thread at SCHED_FIFO priority
 * fifo, above everything under test, and notes when the first such frame
 * reached it: the kernel hands a frame to every socket on the bus in one
 * pass, so the others had it by then (a little earlier when the watch
 * itself was held off).
 */
struct canwatch {
	int fd;
	uint32_t id;
	pthread_t thread;
	bool started;
	bool is_fifo; /* the priority was granted (as root) */
	atomic_bool stop;
	atomic_llong first_ns; /* CLOCK_REALTIME when the first frame was read; 0: none yet */
};

/* Start watching identifier id on iface.  Fails the test when it cannot. */
void canwatch_start(struct canwatch *w, const char *iface, uint32_t id, int fifo);

/* When the first frame with the watched identifier was read (CLOCK_REALTIME), or 0. */
int64_t canwatch_first_ns(struct canwatch *w);

/* Stop and join the thread, close the socket (nothing when not started). */
void canwatch_stop(struct canwatch *w);

/* f is on bus b with identifier id and command byte cmd (-1: any), and t0 <= t < t1. */
bool cframe_is(const struct cframe *f, unsigned b, unsigned id, int cmd, int64_t t0, int64_t t1);

/* The earliest (latest; how many) of the frames from index `from` on that cframe_is(). */
const struct cframe *canlog_first(const struct canlog *c, size_t from, unsigned b, unsigned id,
				  int cmd, int64_t t0, int64_t t1);
const struct cframe *canlog_last(const struct canlog *c, size_t from, unsigned b, unsigned id,
				 int cmd, int64_t t0, int64_t t1);
unsigned canlog_count(const struct canlog *c, size_t from, unsigned b, unsigned id, int cmd,
		      int64_t t0, int64_t t1);

#endif /* RMD_TESTS_CANLOG_H */
