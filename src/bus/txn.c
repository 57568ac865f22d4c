// SPDX-License-Identifier: MIT
/*
 * Request/reply transactions over any bus: pipelined sends, answers
 * matched by identifier and command byte, per-request deadlines, retries.
 * See rmd/txn.h.  Non-rt.
 */
#define _GNU_SOURCE /* ppoll */
#include <errno.h>
#include <poll.h>
#include <string.h>
#include <time.h>

#include "rmd/dialect.h"
#include "rmd/time.h"
#include "rmd/txn.h"

/* Frames one send() or recv() call moves here. */
#define TXN_BATCH 64
/* Longest sleep in poll(2) between two recv() calls: a transport's queue advances only in them. */
#define TXN_POLL_SLICE_NS 1000000

int rmd_txn_prepare(struct rmd_txn *t, enum rmd_proto proto, uint8_t motor_id,
		    const struct rmd_msg *msg)
{
	/* MIT motors answer the V3 table (V3 §5): the dialect of its 0x140 + ID frames */
	const struct rmd_dialect *d = rmd_dialect(rmd_proto_table(proto));
	const struct rmd_cmd_spec *spec;
	uint32_t set_id_can;
	int r;

	memset(t, 0, sizeof(*t));
	if (!d)
		return -EINVAL;
	spec = rmd_cmd_find(d->proto, msg->cmd);
	if (!spec)
		return -ENOENT;
	/* A broadcast (0x280) has many answers: not a transaction; V3 §4's 0x79 on 0x300 is one. */
	set_id_can = spec->cmd == 0x79 ? rmd_dialect_set_id_can(d) : 0;
	if (motor_id == 0 && !set_id_can)
		return -EINVAL;
	r = rmd_encode(d->proto, RMD_DIR_REQUEST, motor_id, msg, &t->req);
	if (r < 0)
		return r;
	if (set_id_can)
		t->reply_id = set_id_can; /* V3 §4.3: 0x79 answers on 0x300 */
	else
		t->reply_id = d->reply_base + (uint32_t)motor_id; /* V2 §1: shared with requests */
	t->reply_cmd = spec->cmd;
	t->any_cmd = spec->flags & RMD_CMD_NO_CMD_BYTE;
	{
		/* an index in request and reply alike (V4.2 §2.1, §2.4): answers are told apart by it */
		const struct rmd_field_spec *qi =
			rmd_layout_field(spec, RMD_DIR_REQUEST, RMD_FLD_INDEX);
		const struct rmd_field_spec *ai =
			rmd_layout_field(spec, RMD_DIR_REPLY, RMD_FLD_INDEX);

		if (qi && ai && qi->off == ai->off && qi->size == 1 && ai->size == 1 && qi->off) {
			t->index_at = qi->off;
			t->index = t->req.data[qi->off];
		}
	}
	/* V3 §2.25: 0x76 does not answer; V3 §2.31: 0xB4's answer is noise, when it comes. */
	t->no_reply = spec->flags & (RMD_CMD_NO_REPLY | RMD_CMD_RANDOM_REPLY);
	t->check_echo = !(spec->flags & RMD_CMD_ECHO);
	t->guardable = t->req.can_id == RMD_CAN_REQ_BASE + motor_id;
	return 0;
}

bool rmd_txn_matches(const struct rmd_txn *t, const struct rmd_frame *rx)
{
	if (rx->can_id != t->reply_id)
		return false;
	if (t->index_at && (rx->len <= t->index_at || rx->data[t->index_at] != t->index))
		return false;
	return t->any_cmd || (rx->len >= 1 && rx->data[0] == t->reply_cmd);
}

static int64_t spacing_of(const struct rmd_bus *bus, const struct rmd_txn_opts *opts)
{
	if (opts && opts->spacing_ns > 0)
		return opts->spacing_ns;
	return rmd_bus_caps(bus)->request_spacing_ns;
}

static int64_t now_of(const struct rmd_txn_opts *opts)
{
	return opts && opts->now_ns ? opts->now_ns(opts->clock_ctx) : rmd_now_ns();
}

static bool stopped(const struct rmd_txn_opts *opts)
{
	return opts && opts->stop && *opts->stop;
}

/*
 * Did try of x reach an awake motor?  It went out right behind a guard or
 * another request to the same motor that has been answered or echoed
 * since (struct rmd_txn.check_echo).
 */
static bool reached_awake(const struct rmd_txn *t, const struct rmd_txn *x)
{
	return x->guard_heard || (x->prev && t[x->prev - 1].heard > x->prev_heard);
}

/*
 * Is this try still waiting for the frame right ahead of it (its guard, or
 * the request ahead) to be answered?  A motor answers in order, so until
 * then a frame for x is an earlier try's, answered late.
 */
static bool ahead_unheard(const struct rmd_txn *t, const struct rmd_txn *x)
{
	return (x->guard_sent || x->prev) && !reached_awake(t, x);
}

/* x's guard was answered (or echoed). */
static void guard_answered(struct rmd_txn *x)
{
	x->guard_heard = true;
	if (x->guards_owed)
		x->guards_owed--;
}

/*
 * Does rx answer one of t[0..n)?  The first waiting request it matches
 * takes it; a repeat of a request that is only its echo (the comm-loss
 * rule of struct rmd_txn.check_echo) has it sent again at once.  Else a
 * guard's answer.  False: it answers none.
 */
static bool take(struct rmd_txn *t, unsigned n, const struct rmd_bus_rx *rx)
{
	for (unsigned i = 0; i < n; i++) {
		struct rmd_txn *x = &t[i];
		bool repeats;

		/* Any try's answer will do: matched, it answers this request. */
		if (x->done || !x->tries || x->no_reply || !rmd_txn_matches(x, &rx->f))
			continue;
		repeats = rmd_frame_repeats(x->req.data, !x->check_echo, &rx->f);
		/*
		 * A repeat can be an earlier try's late answer or its echo:
		 * neither tells about this try, whose own frame comes after
		 * the one ahead of it (a 0x9A request's guard answers first).
		 */
		if (repeats && ahead_unheard(t, x)) {
			if (x->guard_sent && rx->f.data[0] == RMD_TXN_GUARD_CMD)
				guard_answered(x);
			return true;
		}
		x->heard++;
		x->heard_ns = rx->t_ns;
		if (repeats && !reached_awake(t, x) && (x->guardable || !x->echo_seen)) {
			x->echo_seen = true; /* only echoed: sent again, behind a guard */
			x->sent = false;
			return true;
		}
		x->done = true;
		x->rep = *rx;
		return true;
	}
	for (unsigned i = 0; i < n; i++) {
		struct rmd_txn *x = &t[i];

		if (x->guard_sent && !x->guard_heard && rx->f.can_id == x->reply_id &&
		    rx->f.len >= 1 && rx->f.data[0] == RMD_TXN_GUARD_CMD) {
			guard_answered(x);
			return true;
		}
	}
	return false;
}

/* Take every frame received so far; each answers the first waiting request it matches. */
static int collect(struct rmd_bus *bus, struct rmd_txn *t, unsigned n, int64_t now_ns,
		   const struct rmd_txn_opts *opts)
{
	struct rmd_bus_rx rx[TXN_BATCH];
	int r;

	do {
		r = rmd_bus_recv(bus, rx, TXN_BATCH, now_ns);
		if (r < 0)
			return r;
		for (int k = 0; k < r; k++)
			if (!take(t, n, &rx[k]) && opts && opts->unmatched)
				opts->unmatched(opts->unmatched_ctx, &rx[k]);
	} while (r == TXN_BATCH);
	return 0;
}

/* Can x be sent (again) in this round? */
static bool sendable(const struct rmd_txn *x, unsigned max_tries)
{
	return !x->done && !x->sent && x->tries < max_tries;
}

/* The guard of x (struct rmd_txn.check_echo): a status read on x's identifier. */
static struct rmd_frame guard_of(const struct rmd_txn *x)
{
	struct rmd_frame g = { .can_id = x->req.can_id, .len = RMD_FRAME_LEN };

	g.data[0] = RMD_TXN_GUARD_CMD;
	return g;
}

#define TXN_GUARD_BIT (1u << 31) /* idx[] of send_some(): the guard of that request */

/*
 * Does x's next try go behind a guard?  `ahead`: the frame going right
 * ahead of it in this send, NULL for none.
 * - After an echo; and every resend of a request whose answer can repeat
 *   it, so that a late answer of the try before, which comes ahead of the
 *   guard's, is not judged as this try's (take()).  A status read is its
 *   own guard: resent alone.
 * - A request whose answer is its echo (a write: 0xB3, 0x32, ...) or that
 *   has none (0x76), unless another frame to the motor goes right ahead of
 *   it: a motor whose protection tripped echoes the first command it gets
 *   without executing it, and for such a request that echo looks like the
 *   answer, or goes unseen.
 */
static bool guarded(const struct rmd_txn *x, const struct rmd_frame *ahead)
{
	if (!x->guardable)
		return false;
	if (!x->check_echo || x->no_reply)
		return !ahead || ahead->can_id != x->req.can_id;
	return x->echo_seen || (x->tries && x->req.data[0] != RMD_TXN_GUARD_CMD);
}

/*
 * Send what of this round is not sent yet, as much as the bus takes; a
 * request only echoed so far goes right behind its guard.  Each try
 * notes what went right ahead of it (struct rmd_txn.check_echo).
 */
static int send_some(struct rmd_bus *bus, struct rmd_txn *t, unsigned n, int64_t now_ns,
		     int64_t timeout_ns, int64_t spacing_ns, unsigned max_tries, unsigned *k)
{
	struct rmd_frame frames[TXN_BATCH];
	unsigned idx[TXN_BATCH], m = 0;
	int r;

	for (unsigned i = 0; i < n && m < TXN_BATCH; i++) {
		if (!sendable(&t[i], max_tries))
			continue;
		if (guarded(&t[i], m ? &frames[m - 1] : NULL)) {
			if (m + 2 > TXN_BATCH)
				break;
			idx[m] = i | TXN_GUARD_BIT;
			frames[m++] = guard_of(&t[i]);
		}
		idx[m] = i;
		frames[m++] = t[i].req;
	}
	if (m == 0)
		return 0;
	r = rmd_bus_send(bus, frames, m, now_ns);
	if (r < 0)
		return r;
	for (int j = 0; j < r; j++) {
		struct rmd_txn *x = &t[idx[j] & ~TXN_GUARD_BIT], *a;

		(*k)++; /* a guard holds up what follows like a request */
		if (idx[j] & TXN_GUARD_BIT) {
			x->guards_owed++;
			continue;
		}
		a = j ? &t[idx[j - 1] & ~TXN_GUARD_BIT] : NULL;
		x->guard_sent = a == x;
		x->guard_heard = false;
		x->prev = 0;
		if (a && a != x && a->guardable && x->guardable && a->req.can_id == x->req.can_id) {
			x->prev = (unsigned)(a - t) + 1;
			x->prev_heard = a->heard;
		}
		x->sent = true;
		if (!x->tries++)
			x->first_sent_ns = now_ns;
		x->deadline_ns = now_ns + timeout_ns + (int64_t)(*k - 1) * spacing_ns;
		if (x->no_reply)
			x->done = true;
	}
	return r;
}

/* Sleep until frames arrive or until_ns, whichever is first (EINTR ends it early). */
static void wait_until(struct rmd_bus *bus, int64_t now_ns, int64_t until_ns,
		       const struct rmd_txn_opts *opts)
{
	int64_t d = until_ns - now_ns;
	int fd = rmd_bus_fd(bus);

	if (d <= 0)
		return;
	if (opts && opts->sleep_ns) {
		opts->sleep_ns(opts->clock_ctx,
			       fd < 0 && d > RMD_TXN_STEP_NS ? RMD_TXN_STEP_NS : d);
		return;
	}
	if (fd < 0) {
		struct timespec ts;

		if (d > RMD_TXN_STEP_NS)
			until_ns = now_ns + RMD_TXN_STEP_NS;
		ts.tv_sec = until_ns / 1000000000;
		ts.tv_nsec = until_ns % 1000000000;
		clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL);
		return;
	}
	if (d > TXN_POLL_SLICE_NS)
		d = TXN_POLL_SLICE_NS;
	{
		struct pollfd pfd = { .fd = fd, .events = POLLIN };
		struct timespec ts = { .tv_sec = d / 1000000000, .tv_nsec = d % 1000000000 };

		ppoll(&pfd, 1, &ts, NULL);
	}
}

/* One round: send every waiting request once, wait for answers until the last deadline. */
static int round_once(struct rmd_bus *bus, struct rmd_txn *t, unsigned n, int64_t timeout_ns,
		      int64_t spacing_ns, unsigned max_tries, const struct rmd_txn_opts *opts)
{
	/* A bus that takes no frame at all (bus-off, a stuck queue) ends the round too. */
	int64_t end_ns = now_of(opts) + timeout_ns + (int64_t)n * spacing_ns;
	/* How long the round may wait for the transport's own queue to empty (below). */
	int64_t drain_end_ns = end_ns + (int64_t)rmd_bus_caps(bus)->queue_len * spacing_ns;
	unsigned k = 0;

	for (unsigned i = 0; i < n; i++)
		t[i].sent = false;
	for (;;) {
		int64_t now = now_of(opts), next = INT64_MAX, due;
		bool waiting = false, unsent = false;
		int r;

		if (stopped(opts))
			return -EINTR;
		if (now < end_ns) {
			r = send_some(bus, t, n, now, timeout_ns, spacing_ns, max_tries, &k);
			if (r < 0)
				return r;
		}
		r = collect(bus, t, n, now, opts);
		if (r < 0)
			return r;
		for (unsigned i = 0; i < n; i++) {
			if (t[i].done)
				continue;
			if (sendable(&t[i], max_tries)) {
				unsent |= now < end_ns;
				continue;
			}
			if (!t[i].sent)
				continue;
			if (t[i].deadline_ns > now) {
				waiting = true;
				if (t[i].deadline_ns < next)
					next = t[i].deadline_ns;
			}
		}
		/*
		 * A transport with a queue of its own (half-duplex RS485
		 * writes each queued request only after the previous one's
		 * answer or timeout, judged when recv() runs) falls behind the
		 * deadlines above.  A request given up on here still goes out
		 * later, ahead of the next round's and the next batch's, which
		 * then time out in turn (32 silent ids of a scan starve its
		 * 0xB5/0xB2 reads).  So the round lasts until that queue is
		 * empty, waking when the transport is due; late answers still
		 * count (collect()).
		 */
		due = rmd_bus_next_due_ns(bus);
		if (due != INT64_MAX && now < drain_end_ns) {
			if (due <= now) /* a write the tty refused: retry soon */
				due = now + RMD_TXN_STEP_NS;
			waiting = true;
			if (due < next)
				next = due;
		}
		if (!waiting && !unsent)
			return 0;
		/* The bus refused frames: look again soon, it drains as the wire runs. */
		if (unsent && next > now + RMD_TXN_STEP_NS)
			next = now + RMD_TXN_STEP_NS;
		if (unsent && next > end_ns)
			next = end_ns;
		wait_until(bus, now, next, opts);
	}
}

int rmd_txn_run(struct rmd_bus *bus, struct rmd_txn *t, unsigned n, const struct rmd_txn_opts *opts)
{
	int64_t timeout_ns = opts && opts->timeout_ns > 0 ? opts->timeout_ns : RMD_TXN_TIMEOUT_NS;
	unsigned tries = opts && opts->tries > 0 ? opts->tries : RMD_TXN_TRIES;
	int64_t spacing_ns = spacing_of(bus, opts);
	unsigned done = 0;
	int r;

	for (unsigned i = 0; i < n; i++) {
		t[i].done = false;
		t[i].tries = 0;
		t[i].sent = false;
		t[i].echo_seen = false;
		t[i].heard = 0;
		t[i].heard_ns = 0;
		t[i].prev = 0;
		t[i].guard_sent = false;
		t[i].guard_heard = false;
		t[i].guards_owed = 0;
	}
	/* Nothing received before the requests left can answer them. */
	r = collect(bus, t, 0, now_of(opts), opts);
	if (r < 0)
		return r;
	for (unsigned round = 0; round < tries; round++) {
		r = round_once(bus, t, n, timeout_ns, spacing_ns, tries, opts);
		if (r < 0)
			return r;
		done = 0;
		for (unsigned i = 0; i < n; i++)
			done += t[i].done;
		if (done == n)
			break;
	}
	return (int)done;
}
