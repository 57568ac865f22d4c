// SPDX-License-Identifier: MIT
/*
 * The motors' side of a wire (rmd/sim_node.h): the motors, their queue of
 * frames by ready time, and what the fault table does to them, for the
 * in-process wire and rmd-sim alike.
 *
 * All of it is rt-safe: fixed arrays, loops bounded by their sizes.
 */
#include <errno.h>
#include <string.h>

#include "rmd/sim_node.h"

/* ---- the queue: a binary heap on (ready_ns, seq) ---------------------------------------- */

static bool before(const struct rmd_sim_pending *a, const struct rmd_sim_pending *b)
{
	return a->ready_ns < b->ready_ns || (a->ready_ns == b->ready_ns && a->seq < b->seq);
}

static void swap(struct rmd_sim_pending *a, struct rmd_sim_pending *b)
{
	struct rmd_sim_pending t = *a;

	*a = *b;
	*b = t;
}

static void sift_up(struct rmd_sim_node *n, unsigned i)
{
	while (i > 0) {
		unsigned parent = (i - 1) / 2;

		if (!before(&n->q[i], &n->q[parent]))
			break;
		swap(&n->q[i], &n->q[parent]);
		i = parent;
	}
}

static void sift_down(struct rmd_sim_node *n, unsigned i)
{
	for (;;) {
		unsigned l = 2 * i + 1, r = l + 1, m = i;

		if (l < n->qn && before(&n->q[l], &n->q[m]))
			m = l;
		if (r < n->qn && before(&n->q[r], &n->q[m]))
			m = r;
		if (m == i)
			return;
		swap(&n->q[i], &n->q[m]);
		i = m;
	}
}

static void push(struct rmd_sim_node *n, int src, const struct rmd_frame *f, int64_t ready_ns)
{
	struct rmd_sim_pending *p;

	if (n->qn >= n->qcap) {
		n->stats.dropped++;
		return;
	}
	p = &n->q[n->qn];
	p->f = *f;
	p->ready_ns = ready_ns;
	p->seq = n->seq++;
	p->src = src;
	sift_up(n, n->qn++);
	if (n->qn > n->stats.q_hwm)
		n->stats.q_hwm = n->qn;
}

void rmd_sim_node_take(struct rmd_sim_node *n, unsigned j)
{
	if (j >= n->qn)
		return;
	n->q[j] = n->q[--n->qn];
	if (j < n->qn) {
		sift_down(n, j);
		sift_up(n, j);
	}
}

/* Discard the queued frames of motor i (i < 0: of every motor).  Returns how many. */
static unsigned discard(struct rmd_sim_node *n, int i)
{
	unsigned kept = 0, was = n->qn;

	for (unsigned j = 0; j < was; j++) {
		int src = n->q[j].src;

		if ((i < 0 && src >= 0) || (i >= 0 && src == i))
			continue;
		n->q[kept++] = n->q[j];
	}
	n->qn = kept;
	for (unsigned j = kept / 2; j-- > 0;)
		sift_down(n, j);
	return was - kept;
}

int64_t rmd_sim_node_next_ready_ns(const struct rmd_sim_node *n, int64_t t)
{
	int64_t e = INT64_MAX;

	if (n->qn && n->q[0].ready_ns > t)
		return n->q[0].ready_ns;
	for (unsigned j = 0; j < n->qn; j++)
		if (n->q[j].ready_ns > t && n->q[j].ready_ns < e)
			e = n->q[j].ready_ns;
	return e;
}

/*
 * A frame motor i makes at t, ready at ready_ns: the per-frame faults act on
 * it, then it waits (for the host's adapter too, with RMD_SIM_NODE_HOST_ADAPTER).
 */
static void emit(struct rmd_sim_node *n, unsigned i, struct rmd_frame f, int64_t t,
		 int64_t ready_ns)
{
	const struct rmd_sim_motor_params *p = &n->motors[i].p;

	if (n->faults.n && !rmd_sim_faults_frame(&n->faults, &n->rng, p->id, t - n->epoch_ns, &f,
						 &ready_ns, n->stats.faults))
		return;
	if (n->flags & RMD_SIM_NODE_HOST_ADAPTER)
		ready_ns = rmd_sim_adapter_ns(&n->adapter, p, ready_ns);
	push(n, (int)i, &f, ready_ns);
}

/* ---- the motors ------------------------------------------------------------------------- */

void rmd_sim_node_init(struct rmd_sim_node *n, struct rmd_sim_pending *q, unsigned qcap,
		       uint64_t rng, int64_t epoch_ns, unsigned flags)
{
	memset(n, 0, sizeof(*n));
	rmd_sim_faults_init(&n->faults);
	n->epoch_ns = epoch_ns;
	n->rng = rng;
	n->flags = flags;
	rmd_sim_adapter_init(&n->adapter);
	n->q = q;
	n->qcap = qcap;
}

struct rmd_sim_motor *rmd_sim_node_motor(struct rmd_sim_node *n, uint8_t id)
{
	for (unsigned i = 0; i < n->n_motors; i++)
		if (n->motors[i].p.id == id)
			return &n->motors[i];
	return NULL;
}

/* Make the motors' injected error bits those of the open ERROR_FLAG windows. */
static void sync_error_flags(struct rmd_sim_node *n, int64_t t)
{
	for (unsigned i = 0; i < n->n_motors; i++) {
		struct rmd_sim_motor *m = &n->motors[i];
		uint16_t bits = rmd_sim_faults_error_bits(&n->faults, m->p.id);

		if (bits != n->injected[i]) {
			rmd_sim_motor_step(m, t);
			rmd_sim_motor_set_error(m, bits);
			n->injected[i] = bits;
		}
	}
}

int rmd_sim_node_add(struct rmd_sim_node *n, const struct rmd_sim_motor_params *p, int64_t t)
{
	unsigned i = n->n_motors;

	if (p->id < 1 || p->id > RMD_MAX_MOTORS)
		return -EINVAL;
	if (rmd_sim_node_motor(n, p->id))
		return -EEXIST;
	if (i >= RMD_MAX_MOTORS)
		return -ENOSPC;
	rmd_sim_motor_init(&n->motors[i], p, t);
	n->injected[i] = 0;
	n->n_motors++;
	sync_error_flags(n, t);
	return (int)i;
}

void rmd_sim_node_step(struct rmd_sim_node *n, int64_t t)
{
	for (unsigned i = 0; i < n->n_motors; i++)
		rmd_sim_motor_step(&n->motors[i], t);
}

int rmd_sim_node_receive(struct rmd_sim_node *n, const struct rmd_frame *f, int64_t t, int src)
{
	struct rmd_frame out[RMD_SIM_NODE_MAX_REPLIES];
	int total = 0;

	for (unsigned i = 0; i < n->n_motors; i++) {
		struct rmd_sim_motor *m = &n->motors[i];
		int k;

		if ((int)i == src || rmd_sim_node_absent(n, i))
			continue;
		k = rmd_sim_motor_receive(m, t, f, out, RMD_SIM_NODE_MAX_REPLIES);
		for (int j = 0; j < k; j++)
			emit(n, i, out[j], t, rmd_sim_motor_reply_due(m, t, f));
		total += k;
	}
	return total;
}

int64_t rmd_sim_node_poll(struct rmd_sim_node *n, int64_t t)
{
	struct rmd_frame out[RMD_SIM_NODE_MAX_REPLIES];
	bool off = n->faults.n && rmd_sim_faults_bus_off(&n->faults);
	int64_t next = INT64_MAX;

	for (unsigned i = 0; i < n->n_motors; i++) {
		struct rmd_sim_motor *m = &n->motors[i];
		bool absent = rmd_sim_node_absent(n, i);
		int64_t e = rmd_sim_motor_next_event_ns(m);

		/* Frames that did not fit stay due: a few rounds take them all. */
		for (unsigned round = 0; round < 8 && e <= t; round++) {
			int k = rmd_sim_motor_poll(m, t, out, RMD_SIM_NODE_MAX_REPLIES);

			for (int j = 0; j < k; j++) {
				if (absent)
					n->stats.absent_lost++;
				else if (off)
					n->stats.busoff_lost++;
				else
					emit(n, i, out[j], t, t);
			}
			e = rmd_sim_motor_next_event_ns(m);
			if (k < RMD_SIM_NODE_MAX_REPLIES)
				break;
		}
		if (e > t && e < next)
			next = e;
	}
	return next;
}

void rmd_sim_node_queue_floods(struct rmd_sim_node *n, int64_t t)
{
	for (unsigned k = 0; k < n->faults.n; k++) {
		while (rmd_sim_faults_flood_due(&n->faults, k, t - n->epoch_ns)) {
			struct rmd_frame f;
			int64_t due = rmd_sim_faults_flood_take(&n->faults, k, &n->rng, &f,
								n->stats.faults);

			push(n, RMD_SIM_SRC_FOREIGN, &f, n->epoch_ns + due);
		}
	}
}

int64_t rmd_sim_node_faults_next_ns(const struct rmd_sim_node *n, int64_t t)
{
	int64_t e;

	if (!n->faults.n)
		return INT64_MAX;
	e = rmd_sim_faults_next_ns(&n->faults, t - n->epoch_ns);
	return e == INT64_MAX ? INT64_MAX : n->epoch_ns + e;
}

/* ---- fault windows ---------------------------------------------------------------------- */

/* Bit i set for each motor i whose params id has its bit (id - 1) in ids. */
static uint32_t motors_of(const struct rmd_sim_node *n, uint32_t ids)
{
	uint32_t mask = 0;

	for (unsigned i = 0; ids && i < n->n_motors; i++)
		if ((ids >> (n->motors[i].p.id - 1)) & 1)
			mask |= UINT32_C(1) << i;
	return mask;
}

/*
 * The motors from the windows open now, against what the last table state
 * said (was_absent, was_unpowered: by id): power off and on, silence.
 */
static void act(struct rmd_sim_node *n, int64_t t, uint32_t was_absent, uint32_t was_unpowered,
		struct rmd_sim_node_change *ch)
{
	uint32_t power = motors_of(n, n->faults.unpowered ^ was_unpowered);
	uint32_t off = power & motors_of(n, n->faults.unpowered);

	ch->power_off |= off;
	ch->power_on |= power & ~off;
	ch->silenced |= motors_of(n, n->faults.absent & ~was_absent);
	for (unsigned i = 0; i < n->n_motors; i++) {
		/* Without power the drive lets go and the brake locks; back, it boots. */
		if ((power >> i) & 1)
			rmd_sim_motor_power_cycle(&n->motors[i], t);
		if ((ch->silenced >> i) & 1)
			n->stats.absent_lost += discard(n, (int)i);
	}
	/* The controllers drop what they hold, like a SocketCAN restart. */
	if (ch->bus_off)
		n->stats.busoff_lost += discard(n, -1);
	sync_error_flags(n, t);
}

bool rmd_sim_node_update(struct rmd_sim_node *n, int64_t t, struct rmd_sim_node_change *ch)
{
	uint32_t was_absent = n->faults.absent, was_unpowered = n->faults.unpowered;
	uint32_t changed;

	*ch = (struct rmd_sim_node_change){ 0 };
	/* called at every event of a wire: between two edges, no more than this */
	if (!n->faults.n ||
	    !(changed = rmd_sim_faults_update(&n->faults, t - n->epoch_ns, n->stats.faults)))
		return false;
	ch->windows = changed;
	for (unsigned k = 0; k < n->faults.n; k++)
		if (((ch->windows >> k) & 1) && n->faults.open[k] &&
		    n->faults.f[k].kind == RMD_SIM_FAULT_BUS_OFF)
			ch->bus_off = true;
	act(n, t, was_absent, was_unpowered, ch);
	return true;
}

int rmd_sim_node_set_faults(struct rmd_sim_node *n, const struct rmd_sim_fault *faults,
			    unsigned count, int64_t t)
{
	uint32_t was_unpowered = n->faults.unpowered;
	struct rmd_sim_node_change closed = { 0 };
	int r;

	r = rmd_sim_faults_set(&n->faults, faults, count);
	if (r < 0)
		return r;
	/* The old table's windows close now: its motors without power boot. */
	act(n, t, 0, was_unpowered, &closed);
	return 0;
}
