// SPDX-License-Identifier: MIT
/*
 * The simulated CAN bus: a discrete-event model of one wire.  The bus's
 * time jumps from event to event (end of frame, wire free, a frame ready,
 * a motor's unsolicited frame due, a fault window opening or closing);
 * at each it does, in this order: open/close fault windows, deliver the
 * frame whose end of frame it is, collect the motors' unsolicited frames,
 * and, if the wire is idle, start the arbitration winner.  The motors, their
 * queue and what the faults do to them are the node's (rmd/sim_node.h); the
 * wire is the host's queue, arbitration, frame times, delivery to the host.
 *
 * All of it is rt-safe: fixed arrays, linear scans bounded by their sizes.
 */
#include <errno.h>
#include <string.h>

#include "rmd/rng.h"
#include "rmd/can_timing.h"
#include "rmd/sim_adapter.h"
#include "rmd/sim_node.h"
#include "rmd/sim_wire.h"

_Static_assert((RMD_SIM_WIRE_TXQ & (RMD_SIM_WIRE_TXQ - 1)) == 0, "TXQ: power of two");
_Static_assert((RMD_SIM_WIRE_MOTQ & (RMD_SIM_WIRE_MOTQ - 1)) == 0, "MOTQ: power of two");
_Static_assert((RMD_SIM_WIRE_RXQ & (RMD_SIM_WIRE_RXQ - 1)) == 0, "RXQ: power of two");
_Static_assert((RMD_SIM_WIRE_HIST & (RMD_SIM_WIRE_HIST - 1)) == 0, "HIST: power of two");

/* ---- faults (rmd/sim_faults.h) -------------------------------------------- */

/* The wire asks these per frame and per event: no table, no call. */
static bool is_bus_off(const struct rmd_sim_wire *bus)
{
	return bus->node.faults.n && rmd_sim_faults_bus_off(&bus->node.faults);
}

static bool is_unpowered_bus(const struct rmd_sim_wire *bus)
{
	return bus->node.faults.n && rmd_sim_faults_bus_unpowered(&bus->node.faults);
}

/*
 * The counters the node keeps, into the wire's statistics (errors is the
 * sum of its four causes).
 */
static void sync_stats(struct rmd_sim_wire *bus)
{
	const struct rmd_sim_node_stats *n = &bus->node.stats;
	struct rmd_sim_wire_stats *st = &bus->stats;

	st->motq_dropped = n->dropped;
	st->absent_lost = n->absent_lost;
	st->busoff_lost = n->busoff_lost;
	st->motq_hwm = n->q_hwm;
	memcpy(st->faults, n->faults, sizeof(st->faults));
	st->errors = st->tx_refused + st->motq_dropped + st->rxq_dropped + st->busoff_lost;
}

/* ---- queues --------------------------------------------------------------- */

static void deliver_host(struct rmd_sim_wire *bus, const struct rmd_frame *f, int64_t t)
{
	unsigned used = bus->rxq_head - bus->rxq_tail;
	unsigned i = bus->rxq_head & (RMD_SIM_WIRE_RXQ - 1);

	if (used >= RMD_SIM_WIRE_RXQ) {
		bus->stats.rxq_dropped++;
		return;
	}
	bus->rxq[i] = *f;
	bus->rxq_t_ns[i] = t;
	if (t > bus->rxq_last_ns)
		bus->rxq_last_ns = t;
	bus->rxq_head++;
	bus->stats.rx_delivered++;
	if (used + 1 > bus->stats.rxq_hwm)
		bus->stats.rxq_hwm = used + 1;
}

/* ---- the wire ------------------------------------------------------------- */

/* Take the frame off the wire unfinished (bus-off, sender gone). */
static void abort_wire(struct rmd_sim_wire *bus, int64_t t)
{
	bus->wire_busy = false;
	bus->wire_free_ns = t;
}

/*
 * What the fault windows that changed did to the wire: the frame of a motor
 * that fell silent leaves it unfinished; bus-off drops what the host's
 * controller holds, the frame on the wire too.
 */
static void windows_changed(struct rmd_sim_wire *bus, const struct rmd_sim_node_change *ch,
			    int64_t t)
{
	if (bus->wire_busy && bus->wire.src >= 0 && ((ch->silenced >> bus->wire.src) & 1)) {
		abort_wire(bus, t);
		bus->node.stats.absent_lost++;
	}
	if (ch->bus_off) {
		bus->node.stats.busoff_lost += bus->txq_n + bus->wire_busy;
		bus->txq_n = 0;
		if (bus->wire_busy)
			abort_wire(bus, t);
	}
}

/* Open and close the windows as of time t, and act on what changed. */
static void apply_windows(struct rmd_sim_wire *bus, int64_t t)
{
	struct rmd_sim_node_change ch;

	if (bus->node.faults.n && rmd_sim_node_update(&bus->node, t, &ch))
		windows_changed(bus, &ch, t);
}

/* The frame on the wire reaches its end of frame: everyone takes it. */
/* When a motor's frame on the wire at t reaches the host: at t without an adapter model. */
static inline int64_t adapter_ns(struct rmd_sim_wire *bus, const struct rmd_sim_motor_params *p,
				 int64_t t)
{
	if (!p->adapter_latency_timer_ns && !p->adapter_usb_frame_ns && !p->adapter_delay_ns)
		return t;
	return rmd_sim_adapter_ns(&bus->adapter, p, t);
}

/*
 * A host frame no node acknowledged (BUS_POWER): an ACK error; it goes back
 * to the head of the queue (its seq kept) and is tried again at once.
 */
static void ack_missed(struct rmd_sim_wire *bus, const struct rmd_sim_pending *w)
{
	bus->stats.acks_missed++;
	bus->no_ack = true;
	if (bus->txq_n < sizeof(bus->txq) / sizeof(bus->txq[0]))
		bus->txq[bus->txq_n++] = *w;
}

static void finish_frame(struct rmd_sim_wire *bus)
{
	const struct rmd_sim_pending *w = &bus->wire;
	int64_t t = bus->wire_eof_ns;
	unsigned h = bus->hist_n++ & (RMD_SIM_WIRE_HIST - 1);

	bus->wire_busy = false;
	bus->stats.bits += bus->wire_bits;
	bus->stats.busy_ns += bus->wire_free_ns - bus->wire_start_ns;
	bus->hist_start_ns[h] = bus->wire_start_ns;
	bus->hist_free_ns[h] = bus->wire_free_ns;
	if (w->src == RMD_SIM_SRC_HOST && is_unpowered_bus(bus)) {
		ack_missed(bus, w);
		return;
	}
	bus->no_ack = false; /* a frame completed: some node acknowledged it */
	if (bus->tap)
		bus->tap(bus->tap_ctx, w, bus->wire_start_ns, t);
	if (w->src == RMD_SIM_SRC_HOST)
		bus->stats.frames_host++;
	else if (w->src == RMD_SIM_SRC_FOREIGN)
		bus->stats.frames_foreign++;
	else
		bus->stats.frames_motor++;

	rmd_sim_node_receive(&bus->node, &w->f, t, w->src);
	/* a motor's frame reaches the host through its adapter (rmd/sim_adapter.h) */
	if (w->src >= 0)
		deliver_host(bus, &w->f, adapter_ns(bus, &bus->node.motors[w->src].p, t));
	else if (w->src != RMD_SIM_SRC_HOST)
		deliver_host(bus, &w->f, t);
}

/* a goes before b in arbitration. */
static bool wins(const struct rmd_sim_pending *a, const struct rmd_sim_pending *b)
{
	uint32_t ia = a->f.can_id & 0x7FFu, ib = b->f.can_id & 0x7FFu;

	if (ia != ib)
		return ia < ib;
	if (a->ready_ns != b->ready_ns)
		return a->ready_ns < b->ready_ns;
	return a->seq < b->seq;
}

/* The host frames allowed to compete: all, or only the oldest (FIFO). */
static bool host_competes(const struct rmd_sim_wire *bus, unsigned j)
{
	if (!(bus->flags & RMD_SIM_WIRE_HOST_FIFO))
		return true;
	for (unsigned k = 0; k < bus->txq_n; k++)
		if (bus->txq[k].seq < bus->txq[j].seq)
			return false;
	return true;
}

/* Arbitration at t on an idle wire: the winner goes on the wire. */
static void start_frame(struct rmd_sim_wire *bus, int64_t t)
{
	struct rmd_sim_node *n = &bus->node;
	struct rmd_sim_pending flood;
	const struct rmd_sim_pending *best = NULL;
	enum { FROM_HOST, FROM_NODE, FROM_FLOOD } from = FROM_HOST;
	unsigned best_j = 0;

	for (unsigned j = 0; j < bus->txq_n; j++) {
		if (bus->txq[j].ready_ns <= t && host_competes(bus, j) &&
		    (!best || wins(&bus->txq[j], best))) {
			best = &bus->txq[j];
			best_j = j;
		}
	}
	/* the node's queue is a heap on ready time: nothing is ready when its head is not */
	for (unsigned j = 0; n->qn && n->q[0].ready_ns <= t && j < n->qn; j++) {
		if (n->q[j].ready_ns <= t && (!best || wins(&n->q[j], best))) {
			best = &n->q[j];
			from = FROM_NODE;
			best_j = j;
		}
	}
	for (unsigned k = 0; k < n->faults.n; k++) {
		struct rmd_sim_pending c = { 0 };

		if (!rmd_sim_faults_flood_due(&n->faults, k, t))
			continue;
		c.f.can_id = n->faults.f[k].can_id;
		c.f.len = RMD_FRAME_LEN;
		c.ready_ns = n->faults.flood_next_ns[k];
		c.src = RMD_SIM_SRC_FOREIGN;
		if (!best || wins(&c, best)) {
			flood = c;
			best = &flood;
			from = FROM_FLOOD;
			best_j = k;
		}
	}
	if (!best)
		return;

	bus->wire = *best;
	if (from == FROM_HOST)
		bus->txq[best_j] = bus->txq[--bus->txq_n];
	else if (from == FROM_NODE)
		rmd_sim_node_take(n, best_j);
	else
		rmd_sim_faults_flood_take(&n->faults, best_j, &n->rng, &bus->wire.f,
					  n->stats.faults);
	bus->wire_busy = true;
	bus->wire_bits = rmd_can_frame_bits(&bus->wire.f);
	bus->wire_start_ns = t;
	bus->wire_eof_ns = t + rmd_can_wire_ns(bus->wire_bits - RMD_CAN_IFS_BITS, bus->bitrate);
	bus->wire_free_ns = t + rmd_can_wire_ns(bus->wire_bits, bus->bitrate);
}

static int64_t min64(int64_t a, int64_t b)
{
	return a < b ? a : b;
}

/*
 * The next time after t at which something happens, capped at until;
 * motors_ns: when a motor's next unsolicited frame falls due.
 */
static int64_t next_event(const struct rmd_sim_wire *bus, int64_t t, int64_t until,
			  int64_t motors_ns)
{
	int64_t n = min64(until, motors_ns);

	if (bus->wire_busy) {
		n = min64(n, bus->wire_eof_ns);
	} else if (t < bus->wire_free_ns) {
		n = min64(n, bus->wire_free_ns);
	} else {
		for (unsigned j = 0; j < bus->txq_n; j++)
			if (bus->txq[j].ready_ns > t)
				n = min64(n, bus->txq[j].ready_ns);
		n = min64(n, rmd_sim_node_next_ready_ns(&bus->node, t));
	}
	/* window edges, and a flood's next frame (a no-op step while the wire is busy) */
	return min64(n, rmd_sim_node_faults_next_ns(&bus->node, t));
}

/* Run the wire and the motors to until_ns (>= now_ns). */
static void run_to(struct rmd_sim_wire *bus, int64_t until_ns)
{
	for (;;) {
		int64_t t = bus->now_ns;
		int64_t next, motors_ns;

		apply_windows(bus, t);
		if (bus->wire_busy && bus->wire_eof_ns <= t)
			finish_frame(bus);
		motors_ns = rmd_sim_node_poll(&bus->node, t);
		if (!bus->wire_busy && t >= bus->wire_free_ns && t < until_ns && !is_bus_off(bus))
			start_frame(bus, t);
		next = next_event(bus, t, until_ns, motors_ns);
		if (next <= t)
			break;
		bus->now_ns = next;
	}
	rmd_sim_node_step(&bus->node, until_ns);
}

/*
 * The host calls at until_ns, gap after its last call: past hold_after_ns
 * the rest of the gap is the host's (rmd/sim_wire.h "Host gaps").  The
 * wire and the motors run to the end of the gap's first hold_after_ns, so
 * that what the host sent before it reaches them in time; the motors'
 * comm-loss timers then skip the rest.
 */
static void host_gap(struct rmd_sim_wire *bus, int64_t until_ns)
{
	int64_t from = bus->host_ns + bus->hold_after_ns, held;

	if (from > bus->now_ns)
		run_to(bus, from);
	held = until_ns - (from > bus->now_ns ? from : bus->now_ns);
	if (held <= 0)
		return;
	for (unsigned i = 0; i < bus->node.n_motors; i++)
		rmd_sim_motor_hold_comm(&bus->node.motors[i], held);
	bus->stats.host_gaps++;
	bus->stats.host_held_ns += held;
}

int rmd_sim_wire_advance(struct rmd_sim_wire *bus, int64_t until_ns)
{
	uint64_t delivered = bus->stats.rx_delivered;

	if (until_ns < bus->now_ns)
		return 0;
	if (bus->hold_after_ns && until_ns - bus->host_ns > bus->hold_after_ns)
		host_gap(bus, until_ns);
	bus->host_ns = until_ns;
	run_to(bus, until_ns);
	sync_stats(bus);
	return (int)(bus->stats.rx_delivered - delivered);
}

void rmd_sim_wire_set_hold_after(struct rmd_sim_wire *bus, int64_t hold_after_ns)
{
	bus->hold_after_ns = hold_after_ns > 0 ? hold_after_ns : 0;
	bus->host_ns = bus->now_ns;
}

/* ---- API ----------------------------------------------------------------- */

int rmd_sim_wire_init(struct rmd_sim_wire *bus, uint32_t bitrate, uint64_t seed, unsigned flags)
{
	if (bitrate == 0 || (flags & ~(unsigned)RMD_SIM_WIRE_HOST_FIFO))
		return -EINVAL;
	memset(bus, 0, sizeof(*bus));
	bus->bitrate = bitrate;
	bus->flags = flags;
	bus->txq_len = RMD_SIM_WIRE_TXQ;
	bus->seed = seed;
	rmd_sim_node_init(&bus->node, bus->motq, RMD_SIM_WIRE_MOTQ, rmd_rng_seed(seed), 0, 0);
	rmd_sim_adapter_init(&bus->adapter);
	return 0;
}

void rmd_sim_wire_fini(struct rmd_sim_wire *bus)
{
	(void)bus;
}

int rmd_sim_wire_set_txqueuelen(struct rmd_sim_wire *bus, unsigned len)
{
	if (len < 1 || len > RMD_SIM_WIRE_TXQ)
		return -EINVAL;
	bus->txq_len = len;
	return 0;
}

int rmd_sim_wire_add_motor(struct rmd_sim_wire *bus, const struct rmd_sim_motor_params *p,
			   int64_t now_ns)
{
	struct rmd_sim_motor_params q = *p;

	if (p->id < 1 || p->id > RMD_MAX_MOTORS)
		return -EINVAL;
	if (rmd_sim_wire_motor(bus, p->id))
		return -EEXIST;
	if (bus->node.n_motors >= RMD_MAX_MOTORS)
		return -ENOSPC;
	rmd_sim_wire_advance(bus, now_ns);
	if (q.seed == 0)
		q.seed = rmd_rng_seed(bus->seed ^ ((uint64_t)p->id << 56));
	return rmd_sim_node_add(&bus->node, &q, bus->now_ns);
}

void rmd_sim_wire_set_tap(struct rmd_sim_wire *bus, rmd_sim_wire_tap_fn *fn, void *ctx)
{
	bus->tap = fn;
	bus->tap_ctx = ctx;
}

struct rmd_sim_motor *rmd_sim_wire_motor(struct rmd_sim_wire *bus, uint8_t id)
{
	return rmd_sim_node_motor(&bus->node, id);
}

int rmd_sim_wire_set_faults(struct rmd_sim_wire *bus, const struct rmd_sim_fault *faults, size_t n)
{
	int r;

	if (n > RMD_SIM_MAX_FAULTS)
		return -E2BIG;
	r = rmd_sim_node_set_faults(&bus->node, faults, (unsigned)n, bus->now_ns);
	if (r < 0)
		return r;
	apply_windows(bus, bus->now_ns);
	sync_stats(bus);
	return 0;
}

int rmd_sim_wire_send(struct rmd_sim_wire *bus, int64_t now_ns, const struct rmd_frame *frames,
		      unsigned n)
{
	unsigned taken = 0;

	rmd_sim_wire_advance(bus, now_ns);
	if (is_bus_off(bus)) {
		bus->node.stats.busoff_lost += n;
		sync_stats(bus);
		return -ENETDOWN;
	}
	while (taken < n && bus->txq_n < bus->txq_len) {
		struct rmd_sim_pending *p;

		/* Classical CAN 2.0A only, as a CAN_RAW socket would insist. */
		if (frames[taken].can_id > 0x7FFu || frames[taken].len > RMD_FRAME_LEN)
			break;
		p = &bus->txq[bus->txq_n++];
		p->f = frames[taken++];
		p->ready_ns = bus->now_ns;
		p->seq = bus->node.seq++; /* one order of arrival with the motors' frames */
		p->src = RMD_SIM_SRC_HOST;
	}
	if (bus->txq_n > bus->stats.txq_hwm)
		bus->stats.txq_hwm = bus->txq_n;
	if (taken < n) {
		if (bus->txq_n < bus->txq_len) /* stopped at a bad frame */
			return taken ? (int)taken : -EINVAL;
		bus->stats.tx_refused += n - taken;
		sync_stats(bus);
		if (taken == 0)
			return -ENOBUFS;
	}
	return (int)taken;
}

int rmd_sim_wire_recv(struct rmd_sim_wire *bus, struct rmd_frame *out, unsigned max, int64_t *t_ns)
{
	/* frames still held in the adapter (rmd/sim_adapter.h) end the take; none: no look */
	bool held = bus->rxq_last_ns > bus->now_ns;
	unsigned n = 0;

	while (n < max && bus->rxq_tail != bus->rxq_head) {
		unsigned i = bus->rxq_tail & (RMD_SIM_WIRE_RXQ - 1);

		if (held && bus->rxq_t_ns[i] > bus->now_ns)
			break;
		bus->rxq_tail++;
		out[n] = bus->rxq[i];
		if (t_ns)
			t_ns[n] = bus->rxq_t_ns[i];
		n++;
	}
	return (int)n;
}

enum rmd_bus_state rmd_sim_wire_state(const struct rmd_sim_wire *bus)
{
	if (is_bus_off(bus))
		return RMD_BUS_OFF;
	return bus->no_ack ? RMD_BUS_NO_ACK : RMD_BUS_ACTIVE;
}

unsigned rmd_sim_wire_flush(struct rmd_sim_wire *bus)
{
	unsigned n = bus->txq_n;

	bus->txq_n = 0;
	if (bus->wire_busy && bus->wire.src == RMD_SIM_SRC_HOST) {
		abort_wire(bus, bus->now_ns);
		n++;
	}
	bus->stats.flushed += n;
	return n;
}

/* Length of [a0, a1) inside [b0, b1). */
static int64_t overlap(int64_t a0, int64_t a1, int64_t b0, int64_t b1)
{
	int64_t lo = a0 > b0 ? a0 : b0, hi = a1 < b1 ? a1 : b1;

	return hi > lo ? hi - lo : 0;
}

int rmd_sim_wire_load(const struct rmd_sim_wire *bus, int64_t window_ns, double *pct)
{
	int64_t to = bus->now_ns, from = to - window_ns, busy = 0;
	unsigned kept = bus->hist_n < RMD_SIM_WIRE_HIST ? bus->hist_n : RMD_SIM_WIRE_HIST;

	if (window_ns <= 0)
		return -EINVAL;
	if (bus->hist_n > RMD_SIM_WIRE_HIST &&
	    bus->hist_start_ns[bus->hist_n & (RMD_SIM_WIRE_HIST - 1)] > from)
		return -ERANGE;
	for (unsigned j = 0; j < kept; j++)
		busy += overlap(bus->hist_start_ns[j], bus->hist_free_ns[j], from, to);
	if (bus->wire_busy)
		busy += overlap(bus->wire_start_ns, bus->wire_free_ns, from, to);
	*pct = 100.0 * (double)busy / (double)window_ns;
	return 0;
}

unsigned rmd_sim_wire_pending(const struct rmd_sim_wire *bus)
{
	return bus->txq_n + bus->node.qn;
}
