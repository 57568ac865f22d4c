/* SPDX-License-Identifier: MIT */
/*
 * Request/reply transactions over any bus (struct rmd_bus_ops), for callers
 * outside the rt loop: rmdctl, and bring-up (src/rt/bringup.c: the probes
 * 0xB5, 0xB2, 0x9A, the id scan and the 0xB3 write) before the rt loop
 * starts.  This is the one request/reply engine; the rt loop matches its
 * own replies in its cycle.
 *
 * A batch of requests goes out at once (pipelined: the bus takes what it
 * can, the rest follows as it drains), then each request waits for its own
 * answer, matched by reply identifier and command byte, never by "the next
 * frame": replies of other motors, late replies and unsolicited frames are
 * not mistaken for it (docs/design.md "Turnaround").  What did not answer by its
 * deadline is sent again, up to `tries` sends in all; what was only echoed
 * (struct rmd_txn.check_echo) is sent again at once, and that send counts.
 * A silent motor thus costs at most tries * (timeout + its place in the
 * batch * spacing); the call never hangs.
 *
 * Time is CLOCK_MONOTONIC (or the caller's clock, opts.now_ns).  The
 * caller sleeps: in poll(2) on the bus's fd, or, for a bus without one
 * (the sim bus, whose time advances with each call's now_ns), in short
 * clock_nanosleep() steps (or opts.sleep_ns).  The transport is never
 * named: its rmd_bus_caps give the spacing, rmd_bus_next_due_ns() when its
 * own queue must be serviced.  Non-rt throughout.
 */
#ifndef RMD_TXN_H
#define RMD_TXN_H

#include <signal.h>
#include <stdbool.h>
#include <stdint.h>

#include "rmd/bus.h"
#include "rmd/codec.h"

/* Per-try wait for an answer: a motor answers in 0.5-0.8 ms, USB adds ~1 ms (docs/design.md). */
#define RMD_TXN_TIMEOUT_NS 5000000
#define RMD_TXN_TRIES 3
/* The spacing of a CAN bus (struct rmd_bus_caps.request_spacing_ns). */
#define RMD_TXN_CAN_SPACING_NS RMD_BUS_CAN_SPACING_NS
/* Longest sleep between two looks at a bus without fd (the sim bus). */
#define RMD_TXN_STEP_NS 100000
/* The guard's command (struct rmd_txn.check_echo): read status 1 (V3 §2.12, V2 §3.31). */
#define RMD_TXN_GUARD_CMD 0x9A

/* One request and its answer. */
struct rmd_txn {
	/* filled by rmd_txn_prepare() or the caller */
	struct rmd_frame req;
	uint32_t reply_id; /* identifier the answer comes on */
	uint8_t reply_cmd; /* its data[0] */
	bool any_cmd;	   /* the answer has no command byte: match by identifier */
	/*
	 * The answer names the request's index too (V4.2 §2.1.3, §2.4.3: 0x30
	 * and 0x42 answer the index asked): data[index_at] must be index.
	 * index_at 0: no such byte.
	 */
	uint8_t index_at, index;
	bool no_reply; /* nothing answers (V3 0x76): done once sent */
	/*
	 * The command's reply is not a copy of the request, yet a frame can
	 * repeat the request byte for byte (rmd_frame_repeats()): the echo of
	 * a motor whose comm-loss protection tripped (it echoes the first
	 * command it gets next and does not execute it), or a real answer of
	 * zeros (V3 §2.8: 0x62 with offset 0; §2.1: 0x30 of a motor with no
	 * gains).  The bytes cannot tell; the order can: such a frame is the
	 * answer when this try went out right behind another frame to the
	 * same motor in the same send (a request of the batch, or the guard
	 * below) and that frame was answered or echoed before it, so the
	 * motor was awake when the request reached it.  Otherwise it is an
	 * echo (echo_seen): the request is sent again at once, right behind a
	 * status read (0x9A, the guard) to the same motor, whose answer, echo
	 * or not, proves that try.  Never "the second identical frame": a try
	 * that waited longer than the motor's comm-loss time is echoed again.
	 * A motor answers in order: a repeat that comes while the frame ahead
	 * of this try is unanswered is an earlier try's (answered late, or
	 * echoed), and is passed over; so every resend of such a request
	 * goes behind a guard, after a timeout too (a 0x9A request, its own
	 * guard, excepted).  A request whose answer is its echo (a write) or
	 * that has none goes behind a guard too, at every try, unless another
	 * frame to the motor goes right ahead of it in the send: a tripped
	 * motor's echo would pass for its answer, and it is not executed.
	 * Requests not on the motor's own identifier (0x79 on 0x300) cannot
	 * be guarded: for them a repeat of a resend, made at once after the
	 * echo, is the answer.
	 */
	bool check_echo;
	bool guardable; /* sent on 0x140 + ID: a 0x9A to that id can go ahead of it */
	bool echo_seen; /* only echoed so far (also a result: done false, echo_seen: echoes only) */
	unsigned heard; /* frames that answered or echoed it, this run */
	/*
	 * Receive time of the last of those: with tries 1, heard_ns -
	 * first_sent_ns is a round trip through the motor even when the
	 * answer could not be told from an echo (rmdctl rtt: 0x92 at angle 0).
	 */
	int64_t heard_ns;
	unsigned prev; /* 1 + index of the request right ahead of this try, same motor; 0: none */
	unsigned prev_heard; /* its `heard` when this try went out */
	bool guard_sent;     /* this try went out right behind a guard */
	bool guard_heard;    /* ... and the guard was answered or echoed */
	/*
	 * Guards sent this run and not answered yet: their answers (0x9A on
	 * reply_id) may still come, after the run, and must not be taken for
	 * a later request's (rmd_loop's bring-up counts them owed).
	 */
	unsigned guards_owed;
	/* results */
	bool done;	       /* answered (or, no_reply, sent) */
	unsigned tries;	       /* sends made */
	struct rmd_bus_rx rep; /* the answer, when done and !no_reply */
	int64_t first_sent_ns; /* when its first try went out: tries 1, rep.t_ns - this is its round trip */
	/* rmd_txn_run() internals */
	bool sent;
	int64_t deadline_ns;
};

struct rmd_txn_opts {
	int64_t timeout_ns; /* per try, from the request's send; 0: RMD_TXN_TIMEOUT_NS */
	unsigned tries;	    /* sends per request; 0: RMD_TXN_TRIES */
	/*
	 * Added to the deadline of the k-th request of a batch k times: the
	 * time one request holds up the next.  0: the bus's
	 * rmd_bus_caps()->request_spacing_ns (RS485: its reply timeout, half
	 * duplex; CAN and sim: RMD_TXN_CAN_SPACING_NS).
	 */
	int64_t spacing_ns;
	/* When not NULL and set (by a signal handler), rmd_txn_run() returns -EINTR. */
	volatile sig_atomic_t *stop;
	/* The clock (ctx: clock_ctx); NULL: CLOCK_MONOTONIC. */
	int64_t (*now_ns)(void *ctx);
	/* Sleep ns on that clock instead of polling the bus; NULL: poll(2)/clock_nanosleep(). */
	void (*sleep_ns)(void *ctx, int64_t ns);
	void *clock_ctx;
	/*
	 * Called with every received frame that answers none of the requests
	 * (other motors, late and unsolicited frames, what was received
	 * before the requests left); may be NULL.
	 */
	void (*unmatched)(void *ctx, const struct rmd_bus_rx *rx);
	void *unmatched_ctx;
};

/*
 * Fill t for the request `msg` (V2 or V3 table row) to motor `motor_id`:
 * the frame, and the identifier and command byte its answer carries (V3
 * replies on 0x240 + ID, 0x79 on 0x300; V2 on 0x140 + ID).  A row without
 * reply (V3 0x76) or with a meaningless one (0xB4) is marked no_reply.
 * Returns 0 or rmd_encode()'s -errno.  Non-rt.
 */
int rmd_txn_prepare(struct rmd_txn *t, enum rmd_proto proto, uint8_t motor_id,
		    const struct rmd_msg *msg);

/* True when rx answers t (identifier, command byte, and index where it has one).  Pure. */
bool rmd_txn_matches(const struct rmd_txn *t, const struct rmd_frame *rx);

/*
 * Send t[0..n) and collect their answers, retrying those that did not
 * answer in time.  Frames already received when the call starts are
 * dropped first: they came before the requests and answer none of them.
 * Returns how many of t[] are done (t[i].done tells which), -EINTR when
 * opts->stop was set, or a bus error (-errno of send or recv).  Non-rt:
 * blocks, at most about tries * (timeout + n * spacing).
 */
int rmd_txn_run(struct rmd_bus *bus, struct rmd_txn *t, unsigned n,
		const struct rmd_txn_opts *opts);

#endif /* RMD_TXN_H */
