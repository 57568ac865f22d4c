/* SPDX-License-Identifier: MIT */
/*
 * The motors' side of a wire (docs/design.md, layer sim): up to RMD_MAX_MOTORS
 * simulated motors (rmd/sim.h), the frames they have made and not yet sent,
 * and what the fault table (rmd/sim_faults.h) does to them.  One node serves
 * both simulators, which differ in what carries the frames and how time runs:
 *
 * - the in-process wire (rmd/sim_wire.h) drives it in simulated time: it
 *   hands the motors each frame that completes on the wire, polls them at
 *   each of its events and lets the ready frames of q[] compete in
 *   arbitration (taking the winner out with rmd_sim_node_take());
 * - rmd-sim drives it in CLOCK_MONOTONIC time on a real interface or line:
 *   it hands the motors each frame it reads, polls them when its timer
 *   fires and writes the queue's head (rmd_sim_node_head()) when it falls
 *   due, with RMD_SIM_NODE_HOST_ADAPTER: a frame is due when the host's
 *   adapter would hand it on (rmd/sim_adapter.h), since the real wire after
 *   it is the host's.
 *
 * What the node does at the time it is given:
 * - rmd_sim_node_receive(): every motor but the sender and those absent
 *   sees the frame (rmd_sim_motor_receive()); each reply is ready a
 *   turnaround later, never before that motor's previous reply
 *   (rmd_sim_motor_reply_due(): firmware answers in order).
 * - rmd_sim_node_poll(): the motors' unsolicited frames due by then
 *   (rmd_sim_motor_poll(): 0xF1, 0x9A, V4 0xB6 reports), ready at once;
 *   it returns when the next falls due, the caller's next time to poll.
 * - Every frame a motor makes meets the per-frame faults as it is made
 *   (dropped, delayed, cut short, garbled, retargeted), then waits in the
 *   queue, a binary heap on (ready_ns, seq) of the caller's storage; a
 *   frame that does not fit is counted in stats.dropped.
 * - rmd_sim_node_update(): the fault windows open and close; a motor that
 *   a DISAPPEAR or BUS_POWER window silences loses its queued frames, a
 *   motor whose power goes (DISAPPEAR param 1, BUS_POWER) is power cycled
 *   (drive off, brake locked) and again when it returns (it boots), the
 *   injected error bits follow the ERROR_FLAG windows, and a BUS_OFF window
 *   empties the queue of the motors' frames.  What it did is returned, for
 *   the wire's own part (the frame on the wire, the host's queue) and logs.
 *
 * Time: the node's time axis is the caller's; the fault table's is node
 * time minus epoch_ns (0 for the in-process wire, the start for rmd-sim).
 *
 * No allocation, no clock, no syscalls: every function is rt-safe, bounded
 * by RMD_MAX_MOTORS, RMD_SIM_MAX_FAULTS and the queue's capacity.  Not
 * thread-safe: one owner.  The node points at its queue's storage: it is
 * not moved or copied after rmd_sim_node_init().
 */
#ifndef RMD_SIM_NODE_H
#define RMD_SIM_NODE_H

#include <stdbool.h>
#include <stdint.h>

#include "rmd/frame.h"
#include "rmd/sim.h"
#include "rmd/sim_adapter.h"
#include "rmd/sim_faults.h"

#define RMD_SIM_NODE_MAX_REPLIES 4 /* frames one motor may answer one frame with */

/* rmd_sim_node_init() flags */
enum {
	/* A frame is ready when the host's adapter hands it on (a real wire follows). */
	RMD_SIM_NODE_HOST_ADAPTER = 1u << 0,
};

/* A frame waiting for the wire. */
struct rmd_sim_pending {
	struct rmd_frame f;
	int64_t ready_ns;
	uint64_t seq; /* order of arrival, breaks ties */
	int src;      /* motor index, or RMD_SIM_SRC_HOST / RMD_SIM_SRC_FOREIGN */
};

#define RMD_SIM_SRC_HOST (-1)
#define RMD_SIM_SRC_FOREIGN (-2)

/*
 * Counters since rmd_sim_node_init(); they only grow.  A wire adds its own
 * losses of the same kinds here (the frame on it cut short, the host's
 * queue at bus-off), so that each is counted in one place.
 */
struct rmd_sim_node_stats {
	uint64_t dropped;     /* frames lost: the queue was full */
	uint64_t absent_lost; /* frames of a silenced motor, discarded or never queued */
	uint64_t busoff_lost; /* motors' frames lost to bus-off */
	unsigned q_hwm;	      /* queue high-water mark */
	/*
	 * Injected faults by kind: per-frame kinds count frames hit; window
	 * kinds count windows opened; FLOOD counts frames sent (the caller's
	 * flood frames count here too, rmd_sim_faults_flood_take()).
	 */
	uint64_t faults[RMD_SIM_FAULT_COUNT];
};

/* What rmd_sim_node_update() did. */
struct rmd_sim_node_change {
	uint32_t windows;   /* bit k: fault entry k opened or closed (faults.open[k]: which) */
	uint32_t silenced;  /* bit i: motor i fell silent; its queued frames are gone */
	uint32_t power_off; /* bit i: motor i lost power: output off, brake locked */
	uint32_t power_on;  /* bit i: motor i has power again: it boots */
	bool bus_off;	    /* a BUS_OFF window opened: the motors' queued frames are gone */
};

/*
 * The node.  Read the fields; change them only through the functions below
 * (a motor's params p may be tuned between calls, as rmd/sim.h allows).
 */
struct rmd_sim_node {
	/* The first two fields stay first: struct rmd_sim_wire names them too. */
	struct rmd_sim_motor motors[RMD_MAX_MOTORS];
	unsigned n_motors;
	uint16_t injected[RMD_MAX_MOTORS]; /* error bits applied by ERROR_FLAG windows */

	struct rmd_sim_faults faults; /* on the axis node time - epoch_ns */
	int64_t epoch_ns;
	uint64_t rng; /* the faults' PRNG (xorshift state, rmd/rng.h) */
	unsigned flags;
	struct rmd_sim_adapter adapter; /* RMD_SIM_NODE_HOST_ADAPTER */

	/* Frames waiting: a binary heap on (ready_ns, seq) in the caller's q[qcap]. */
	struct rmd_sim_pending *q;
	unsigned qn, qcap;
	uint64_t seq; /* the next frame's; a wire numbers its own frames from it too */

	struct rmd_sim_node_stats stats;
};

/*
 * An empty node: no motors, no faults, the queue in q[0..qcap) (qcap > 0),
 * rng a non-zero PRNG state (rmd_rng_seed()), the fault table's time 0 at
 * node time epoch_ns, flags RMD_SIM_NODE_*.  rt-safe.
 */
void rmd_sim_node_init(struct rmd_sim_node *n, struct rmd_sim_pending *q, unsigned qcap,
		       uint64_t rng, int64_t epoch_ns, unsigned flags);

/*
 * Power on a motor at t (rmd_sim_motor_init(); p->seed as given) with the
 * error bits the open windows inject.  Returns its index, -EINVAL (id not
 * 1..32), -EEXIST (id taken) or -ENOSPC.  rt-safe.
 */
int rmd_sim_node_add(struct rmd_sim_node *n, const struct rmd_sim_motor_params *p, int64_t t);

/* The motor with params id `id`, or NULL.  rt-safe. */
struct rmd_sim_motor *rmd_sim_node_motor(struct rmd_sim_node *n, uint8_t id);

/* Whether motor i hears and says nothing now (an open DISAPPEAR or BUS_POWER window).  rt-safe. */
static inline bool rmd_sim_node_absent(const struct rmd_sim_node *n, unsigned i)
{
	return n->faults.n && rmd_sim_faults_absent(&n->faults, n->motors[i].p.id);
}

/*
 * Replace the fault table by `count` entries at time t: the old table's
 * windows close (a motor it left without power boots, injected error bits
 * clear); the new one's open at the next rmd_sim_node_update().  Returns
 * 0, -E2BIG, or -EINVAL for an entry rmd_sim_fault_check() refuses
 * (nothing changed).  rt-safe.
 */
int rmd_sim_node_set_faults(struct rmd_sim_node *n, const struct rmd_sim_fault *faults,
			    unsigned count, int64_t t);

/*
 * Open and close the fault windows as of t and act on the motors (see the
 * top of this file).  Returns whether a window changed; *ch says what was
 * done (all zero when nothing changed).  rt-safe.
 */
bool rmd_sim_node_update(struct rmd_sim_node *n, int64_t t, struct rmd_sim_node_change *ch);

/*
 * Frame f, from src (a motor index, RMD_SIM_SRC_HOST or _FOREIGN), reaches
 * the motors at t: every one but the sender and those absent sees it.
 * Returns the replies they made (before faults).  rt-safe.
 */
int rmd_sim_node_receive(struct rmd_sim_node *n, const struct rmd_frame *f, int64_t t, int src);

/*
 * The motors' unsolicited frames due by t, ready at t; those of a motor
 * that is absent, or while the bus is off, are counted lost.  Returns the
 * first time after t at which a motor's next one falls due, if nothing else
 * happens to the motors before (INT64_MAX: none scheduled).  rt-safe.
 */
int64_t rmd_sim_node_poll(struct rmd_sim_node *n, int64_t t);

/* Every open FLOOD's frames due by t into the queue, each ready when due (src FOREIGN).  rt-safe. */
void rmd_sim_node_queue_floods(struct rmd_sim_node *n, int64_t t);

/* Advance every motor's physics to t.  rt-safe. */
void rmd_sim_node_step(struct rmd_sim_node *n, int64_t t);

/*
 * The first time after t at which a fault window opens or closes, or a
 * FLOOD frame falls due; INT64_MAX: none.  rt-safe.
 */
int64_t rmd_sim_node_faults_next_ns(const struct rmd_sim_node *n, int64_t t);

/* The earliest ready time after t of a queued frame; INT64_MAX: none.  rt-safe. */
int64_t rmd_sim_node_next_ready_ns(const struct rmd_sim_node *n, int64_t t);

/* The queued frame ready first (ties: queued first), or NULL.  rt-safe. */
static inline const struct rmd_sim_pending *rmd_sim_node_head(const struct rmd_sim_node *n)
{
	return n->qn ? &n->q[0] : NULL;
}

/* Take queued frame q[j] out (j < qn; rmd_sim_node_head() is q[0]).  rt-safe. */
void rmd_sim_node_take(struct rmd_sim_node *n, unsigned j);

#endif /* RMD_SIM_NODE_H */
