/* SPDX-License-Identifier: MIT */
/*
 * The simulated CAN wire (docs/design.md, layer sim): up to RMD_MAX_MOTORS simulated
 * motors (rmd/sim.h) on one wire with a timing model and fault injection.
 * The bus layer's transport over it is rmd/bus_sim.h.  The motors' side
 * (the motors, their frames by ready time, what fault windows do to them)
 * is a node, rmd/sim_node.h, the one rmd-sim runs on a real wire; the wire
 * adds the host's queue, arbitration, frame times and delivery to the host.
 *
 * Time is injected: the bus never reads a clock.  rmd_sim_wire_advance()
 * runs the wire from where it stopped to a given time:
 * - Whenever the wire is idle, every frame that is ready by then, the
 *   host's, the motors' and foreign ones, takes part in arbitration, and
 *   the lowest identifier wins (with RMD_SIM_WIRE_HOST_FIFO only the oldest
 *   host frame competes, as with SocketCAN's single transmit queue).
 * - The winner holds the wire for rmd_can_frame_bits() bit times (its
 *   exact stuffed length, interframe space included).  Its end of frame,
 *   3 bit times before the wire is free, is when receivers take it: every
 *   motor but the sender sees it then (rmd_sim_motor_receive()), and a
 *   motor's or foreign frame goes into the host's receive queue with that
 *   time stamp.  Host frames are not echoed back.
 * - A motor's reply is ready a turnaround (rmd_sim_motor_turnaround_ns(),
 *   mean +- jitter) after the end of the request, never before its
 *   previous reply (rmd_sim_motor_reply_due(): firmware answers in order);
 *   its unsolicited frames (rmd_sim_motor_poll()) are ready when they fall
 *   due.  A ROM write's answer comes rom_write_ns later
 *   (rmd_sim_motor_rom_extra_ns()).
 * - The host gets a motor's frame through its adapter (rmd/sim_adapter.h:
 *   a converter's latency timer, USB frames, a fixed delay): later than
 *   its end of frame, and rmd_sim_wire_recv() holds it until then.
 * So a cycle that asks for more than the wire carries runs late: frames
 * wait, and replies arrive later.  Nothing is lost unless a queue
 * overflows, a fault drops it, or the bus goes off, and each is counted.
 * - While a BUS_POWER window is open no node acknowledges: a host frame
 *   holds the wire for its length and goes back to the head of the host
 *   queue (an ACK error; the controller tries again at once, as a CAN
 *   controller does), and the bus reports RMD_BUS_NO_ACK from the first
 *   such try until a frame completes again.  The queue fills up to its
 *   length (txqueuelen: a SocketCAN queue and the controller's buffers in
 *   one) and then refuses (-ENOBUFS); what it holds goes out when power
 *   returns, unless rmd_sim_wire_flush() dropped it (what restarting a
 *   CAN interface does).
 *
 * No allocation: fixed arrays sized by RMD_MAX_MOTORS and power-of-two
 * queues; the caller allocates struct rmd_sim_wire (about 60 KiB) before
 * the rt thread starts.  Every function is rt-safe: bounded work per frame
 * and per event (no syscalls, no locks, no stdio).  Not thread-safe: one
 * owner.
 *
 * Faults (struct rmd_sim_fault, rmd/sim_faults.h) are a plain array, so a
 * YAML config or a command line can fill it.  Their randomness comes from one PRNG seeded by
 * rmd_sim_wire_init(), and the motors' (turnaround jitter) from seeds
 * derived from it, so a run is reproducible from its seed.
 */
#ifndef RMD_SIM_WIRE_H
#define RMD_SIM_WIRE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/frame.h"
#include "rmd/sim.h"
#include "rmd/sim_adapter.h"
#include "rmd/sim_faults.h"
#include "rmd/sim_node.h"

#define RMD_SIM_WIRE_TXQ 64   /* host frames waiting for the wire (power of two) */
#define RMD_SIM_WIRE_MOTQ 128 /* motor frames waiting for the wire (power of two) */
#define RMD_SIM_WIRE_RXQ 256  /* frames waiting for the host (power of two) */
#define RMD_SIM_WIRE_HIST 512 /* recent frames kept for rmd_sim_wire_load() */

/* rmd_sim_wire_init() flags */
enum {
	/* Host frames leave in the order sent, as from a SocketCAN queue. */
	RMD_SIM_WIRE_HOST_FIFO = 1u << 0,
};

/* Statistics since rmd_sim_wire_init().  Counters only grow. */
struct rmd_sim_wire_stats {
	uint64_t bits;		 /* transmitted, stuff bits and IFS included */
	int64_t busy_ns;	 /* wire time of those bits */
	uint64_t frames_host;	 /* transmitted by the host */
	uint64_t frames_motor;	 /* transmitted by motors */
	uint64_t frames_foreign; /* transmitted by a flood */
	uint64_t rx_delivered;	 /* put into the host's receive queue */
	uint64_t tx_refused;	 /* rmd_sim_wire_send(): TX queue full (-ENOBUFS) */
	uint64_t motq_dropped;	 /* motor frames lost: motor queue full */
	uint64_t rxq_dropped;	 /* frames lost: host receive queue full */
	uint64_t busoff_lost;	 /* frames discarded or refused by bus-off */
	uint64_t errors;	 /* sum of the four lines above */
	uint64_t absent_lost;	 /* frames of a disappeared motor discarded */
	uint64_t acks_missed;	 /* host frame tries no node acknowledged (BUS_POWER) */
	uint64_t flushed;	 /* host frames dropped by rmd_sim_wire_flush() */
	uint64_t host_gaps;	 /* calls after a host gap (rmd_sim_wire_set_hold_after()) */
	int64_t host_held_ns;	 /* their time the motors' comm-loss timers did not count */
	unsigned txq_hwm;	 /* queue high-water marks */
	unsigned motq_hwm;
	unsigned rxq_hwm;
	/*
	 * Injected faults by kind: per-frame kinds count frames hit; DISAPPEAR,
	 * ERROR_FLAG and BUS_OFF count windows opened; FLOOD counts frames sent.
	 */
	uint64_t faults[RMD_SIM_FAULT_COUNT];
};

/*
 * Called for every frame that completes on the wire, at its end of frame,
 * with its start time: a candump of the simulated wire for tools and tests.
 * Runs inside rmd_sim_wire_advance(): it must be as rt-safe as the caller.
 */
typedef void rmd_sim_wire_tap_fn(void *ctx, const struct rmd_sim_pending *p, int64_t start_ns,
				 int64_t eof_ns);

struct rmd_sim_wire {
	uint32_t bitrate;
	unsigned flags;
	unsigned txq_len; /* host TX queue capacity, <= RMD_SIM_WIRE_TXQ */
	uint64_t seed;
	int64_t now_ns; /* the wire has run up to here */

	/*
	 * The motors' side (rmd/sim_node.h): the motors, their frames waiting
	 * for the wire (in motq), the fault table and its PRNG, on the wire's
	 * time axis.  The node's first two fields are named here too, for
	 * readers of the motors.
	 */
	union {
		struct rmd_sim_node node;
		struct {
			struct rmd_sim_motor motors[RMD_MAX_MOTORS];
			unsigned n_motors;
		};
	};
	struct rmd_sim_pending motq[RMD_SIM_WIRE_MOTQ];

	/*
	 * Host frames waiting for the wire: an unordered pool, arbitration
	 * picks (among them and the motors' ready frames).  It has one more
	 * slot: the frame the controller tries again while its queue is full
	 * (BUS_POWER).
	 */
	struct rmd_sim_pending txq[RMD_SIM_WIRE_TXQ + 1];
	unsigned txq_n;

	/* A host frame went unacknowledged since the last frame that completed. */
	bool no_ack;

	/* The frame on the wire. */
	bool wire_busy;
	struct rmd_sim_pending wire;
	unsigned wire_bits;
	int64_t wire_start_ns, wire_eof_ns;
	int64_t wire_free_ns; /* end of the interframe space */

	/* Host receive queue: a ring. */
	struct rmd_frame rxq[RMD_SIM_WIRE_RXQ];
	int64_t rxq_t_ns[RMD_SIM_WIRE_RXQ]; /* when the host gets it (after the adapter) */
	int64_t rxq_last_ns;		    /* the latest of them ever queued */
	unsigned rxq_head, rxq_tail;	    /* free-running; index & (RXQ - 1) */

	/* Recent frames' wire intervals: a ring. */
	int64_t hist_start_ns[RMD_SIM_WIRE_HIST];
	int64_t hist_free_ns[RMD_SIM_WIRE_HIST];
	unsigned hist_n; /* free-running */

	/* between the wire and the host: the motors' adapter_* parameters */
	struct rmd_sim_adapter adapter;

	/* host gaps (rmd_sim_wire_set_hold_after()): 0 none; the host's last call */
	int64_t hold_after_ns, host_ns;

	struct rmd_sim_wire_stats stats;
	rmd_sim_wire_tap_fn *tap;
	void *tap_ctx;
};

/*
 * Set up an empty bus at time 0: bitrate in bit/s (> 0), seed for the
 * faults' PRNG and the motors' jitter, flags RMD_SIM_WIRE_*.  Returns 0 or
 * -EINVAL.  rt-safe.
 */
int rmd_sim_wire_init(struct rmd_sim_wire *bus, uint32_t bitrate, uint64_t seed, unsigned flags);

/* Nothing to release; for the _init/_fini pairing.  rt-safe. */
void rmd_sim_wire_fini(struct rmd_sim_wire *bus);

/*
 * Capacity of the host TX queue, 1..RMD_SIM_WIRE_TXQ (SocketCAN's default
 * txqueuelen is 10).  Frames already queued stay.  Returns 0 or -EINVAL.
 * rt-safe.
 */
int rmd_sim_wire_set_txqueuelen(struct rmd_sim_wire *bus, unsigned len);

/*
 * Run the bus to now_ns, then power on a motor there.  A params seed of 0
 * is replaced by one derived from the bus seed and the id.  Returns the
 * motor's index, -EINVAL (id not 1..32), -EEXIST (id taken) or -ENOSPC.
 * rt-safe.
 */
int rmd_sim_wire_add_motor(struct rmd_sim_wire *bus, const struct rmd_sim_motor_params *p,
			   int64_t now_ns);

/* Call fn for every frame on the wire (NULL: stop).  rt-safe. */
void rmd_sim_wire_set_tap(struct rmd_sim_wire *bus, rmd_sim_wire_tap_fn *fn, void *ctx);

/* The motor with params id `id`, or NULL.  rt-safe. */
struct rmd_sim_motor *rmd_sim_wire_motor(struct rmd_sim_wire *bus, uint8_t id);

/*
 * Replace the fault table by n entries (n <= RMD_SIM_MAX_FAULTS).  The
 * old table's open windows close at the bus's current time (a motor
 * powered off by DISAPPEAR boots, injected error bits clear).  Returns 0,
 * -E2BIG, or -EINVAL for an entry that makes no sense (the table is then
 * unchanged).  rt-safe.
 */
int rmd_sim_wire_set_faults(struct rmd_sim_wire *bus, const struct rmd_sim_fault *faults, size_t n);

/*
 * Run the bus to now_ns, then queue frames for the wire, ready at now_ns.
 * Returns how many were taken (the rest did not fit, or the first of them
 * is not a 2.0A frame: the caller keeps them), -ENOBUFS when none fit,
 * -EINVAL when the first is not a 2.0A frame (identifier > 0x7FF, len > 8),
 * -ENETDOWN while the bus is off.  rt-safe.
 */
int rmd_sim_wire_send(struct rmd_sim_wire *bus, int64_t now_ns, const struct rmd_frame *frames,
		      unsigned n);

/*
 * Run the wire from its current time up to until_ns: frames that start
 * before until_ns are sent, frames whose end of frame is <= until_ns are
 * delivered; a frame still on the wire finishes on the next call.  Motor
 * physics is advanced to until_ns.  Earlier times are a no-op.  Returns
 * the count of frames put into the host's receive queue.  rt-safe.
 */
int rmd_sim_wire_advance(struct rmd_sim_wire *bus, int64_t until_ns);

/*
 * Host gaps.  A simulated bus in the host's own process (rmd/bus_sim.h) is
 * stepped only when the host calls it: time the host spent away (its
 * thread preempted, the process stopped) is not time it chose to be
 * silent.  With hold_after_ns > 0, every rmd_sim_wire_advance() (send()
 * and recv() included) is the host's call; when one comes more than
 * hold_after_ns after the one before, the wire and the motors first run to
 * hold_after_ns after that call (frames sent before the gap arrive in
 * time), and the rest of the gap does not count on the motors' comm-loss
 * timers (rmd_sim_motor_hold_comm()): a host that calls at least every
 * hold_after_ns, sending or not, trips them as before; a host held away
 * for 300 ms does not.  Everything else (physics, replies, unsolicited
 * frames, fault windows) runs through the gap in full.  Counted in
 * stats.host_gaps and host_held_ns.  hold_after_ns 0 (the default): no
 * gap is the host's, as on a real wire.  rt-safe.
 */
void rmd_sim_wire_set_hold_after(struct rmd_sim_wire *bus, int64_t hold_after_ns);

/*
 * Pop up to max received frames, oldest first, with their end-of-frame
 * times in t_ns[] (may be NULL).  Takes no time: call advance first.
 * Returns the count.  rt-safe.
 */
int rmd_sim_wire_recv(struct rmd_sim_wire *bus, struct rmd_frame *out, unsigned max, int64_t *t_ns);

/*
 * RMD_BUS_OFF while a BUS_OFF fault window is open; RMD_BUS_NO_ACK from a
 * host frame no node acknowledged until a frame completes; else
 * RMD_BUS_ACTIVE.  rt-safe.
 */
enum rmd_bus_state rmd_sim_wire_state(const struct rmd_sim_wire *bus);

/*
 * Drop every host frame still waiting for the wire, the one being tried
 * included (an interface restarted: its queue and the controller's buffers
 * emptied).  The frames motors and floods send are not the host's and
 * stay.  Returns how many were dropped (stats.flushed counts them too).
 * rt-safe.
 */
unsigned rmd_sim_wire_flush(struct rmd_sim_wire *bus);

/*
 * Wire load over the last window_ns before the bus's current time, in
 * percent (busy time / window).  Returns 0, -EINVAL for a window <= 0, or
 * -ERANGE when the window reaches past the RMD_SIM_WIRE_HIST frames kept.
 * rt-safe.
 */
int rmd_sim_wire_load(const struct rmd_sim_wire *bus, int64_t window_ns, double *pct);

/* Frames waiting for the wire (host and motors).  rt-safe. */
unsigned rmd_sim_wire_pending(const struct rmd_sim_wire *bus);

#endif /* RMD_SIM_WIRE_H */
