// SPDX-License-Identifier: MIT
/*
 * The real-time loop: one cycle per tick over every bus, reply matching and
 * deadlines, motor lifecycle, host watchdog, safe actions, publishing and
 * stop.  See rmd/loop.h for the behaviour; bring-up is bringup.c, the
 * thread rt_thread.c, and what the three share is loop_priv.h.
 *
 * Everything the cycle touches lives in struct rmd_loop, allocated and
 * written once by rmd_loop_new(): fixed arrays sized by RMD_MAX_MOTORS and
 * RMD_MAX_BUSES.  The cycle (rmd_loop_cycle() and what it calls) takes no
 * lock, allocates nothing and formats no text; it talks to other threads
 * through the triple buffers and the event ring of rmd/spsc.h, and through
 * a sequence lock that rmd_loop_get_*() read.  Bring-up and the thread's
 * set-up are non-rt.
 */
#define _GNU_SOURCE /* ppoll, pthread_setaffinity_np */
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "rmd/time.h"
#include "rmd/hist.h"
#include "rmd/err.h"
#include "rmd/loop.h"
#include "rmd/motor.h"
#include "loop_priv.h"

/* ------------------------------------------------------------------ */
/* Small helpers (rt-safe) */

/* rt-safe. */
int64_t loop_now(const struct rmd_loop *l)
{
	return l->o.now_ns ? l->o.now_ns(l->o.now_ctx) : rmd_now_ns();
}

/* rt-safe. */
struct timespec loop_ts(int64_t ns)
{
	struct timespec ts = { .tv_sec = ns / RMD_NS_PER_S, .tv_nsec = ns % RMD_NS_PER_S };

	return ts;
}

/* Sleep ns: the injected sleep, or clock_nanosleep.  Bounded.  rt-safe. */
static void sleep_plain(const struct rmd_loop *l, int64_t ns)
{
	struct timespec ts;

	if (ns <= 0)
		return;
	if (l->o.sleep_ns) {
		l->o.sleep_ns(l->o.now_ctx, ns);
		return;
	}
	ts = loop_ts(ns);
	clock_nanosleep(CLOCK_MONOTONIC, 0, &ts, NULL);
}

/* Wait up to ns for frames on bus (poll(2) on its fd when it has one).  Non-rt. */
void loop_wait_bus(const struct rmd_loop *l, struct rmd_bus *bus, int64_t ns)
{
	int fd;

	if (ns <= 0)
		return;
	fd = rmd_bus_fd(bus);
	if (l->o.sleep_ns || fd < 0) {
		sleep_plain(l, ns);
	} else {
		struct pollfd pfd = { .fd = fd, .events = POLLIN };
		struct timespec ts = loop_ts(ns);

		ppoll(&pfd, 1, &ts, NULL);
	}
}

/* rt-safe. */
void loop_event(struct rmd_loop *l, int64_t t, unsigned kind, unsigned motor, unsigned bus,
		int64_t a, int64_t b)
{
	struct rmd_event e = {
		.t_ns = t,
		.kind = (uint16_t)kind,
		.motor = (uint8_t)motor,
		.bus = (uint8_t)bus,
		.a = a,
		.b = b,
	};

	if (l->o.events)
		rmd_ring_push(l->o.events, &e);
}

/* rt-safe. */
static unsigned idx_of(const struct rmd_loop *l, const struct lmotor *lm)
{
	return (unsigned)(lm - l->mot);
}

/* ------------------------------------------------------------------ */
/* rt-safe. */
static void wake_record(struct rmd_loop *l, int64_t lat)
{
	if (lat < 0)
		lat = 0;
	l->hist[rmd_hist_bucket(lat)]++;
	l->wake_n++;
	l->wake_sum += lat;
	if (l->wake_n == 1 || lat < l->stats.wake_min_ns)
		l->stats.wake_min_ns = lat;
	if (lat > l->stats.wake_max_ns)
		l->stats.wake_max_ns = lat;
}

/* rt-safe. */
static void wake_summary(struct rmd_loop *l)
{
	uint64_t want, sum = 0;

	if (!l->wake_n)
		return;
	l->stats.wake_avg_ns = l->wake_sum / (int64_t)l->wake_n;
	want = l->wake_n - l->wake_n / 100; /* the 99th percentile, rounded up */
	for (unsigned b = 0; b < RMD_HIST_BUCKETS; b++) {
		sum += l->hist[b];
		if (sum >= want) {
			int64_t up = rmd_hist_upper(b);

			l->stats.wake_p99_ns = up < l->stats.wake_max_ns ? up :
									   l->stats.wake_max_ns;
			break;
		}
	}
}

/* ------------------------------------------------------------------ */
/* Requests in flight */

/* rt-safe. */
static bool echo_is_reply(const struct rmd_motor *m, const struct rmd_frame *f)
{
	const struct rmd_cmd_spec *spec;

	if (f->can_id == RMD_CAN_MULTI || f->can_id == RMD_CAN_MIT_REQ_BASE + m->id || !f->len)
		return false;
	spec = rmd_cmd_find(m->proto, f->data[0]);
	return spec && (spec->flags & RMD_CMD_ECHO);
}

static void miss(struct rmd_loop *l, struct lmotor *lm, int64_t now);

/* rt-safe. */
static void os_add(struct rmd_loop *l, struct lmotor *lm, const struct rmd_frame *f, int64_t now)
{
	struct outstanding *o = NULL, *oldest = NULL;

	for (unsigned k = 0; k < OUTSTANDING; k++) {
		struct outstanding *e = &lm->os[k];

		if (!e->used) {
			o = e;
			break;
		}
		if (!oldest || e->seq < oldest->seq)
			oldest = e;
	}
	if (!o) {
		/* full: the oldest has waited longest, it counts as missed */
		o = oldest;
		o->used = false;
		miss(l, lm, now);
	}
	memset(o, 0, sizeof(*o));
	o->used = true;
	rmd_motor_reply_key(&lm->m, f, &o->reply_id, &o->cmd);
	o->echo_is_reply = echo_is_reply(&lm->m, f);
	o->seq = lm->seq++;
	o->sent_ns = now;
	o->deadline_ns = now + l->bus[lm->bus].reply_ns;
	memcpy(o->data, f->data, sizeof(o->data));
}

/* The oldest request of lm that frame f (id, cmd) answers, or NULL.  rt-safe. */
static struct outstanding *os_match(struct lmotor *lm, uint32_t id, uint16_t cmd)
{
	struct outstanding *best = NULL;

	for (unsigned k = 0; k < OUTSTANDING; k++) {
		struct outstanding *e = &lm->os[k];

		if (e->used && e->reply_id == id && e->cmd == cmd && (!best || e->seq < best->seq))
			best = e;
	}
	return best;
}

/* Forget the one-shots waiting and the damp stream.  rt-safe. */
void loop_frames_drop(struct lmotor *lm)
{
	lm->n_oneshot = 0;
	lm->damp_stream = false;
}

/* rt-safe. */
static void oneshot_push(struct lmotor *lm, const struct rmd_frame *f)
{
	if (lm->n_oneshot < ONESHOTS)
		lm->oneshot[lm->n_oneshot++] = *f;
}

/* rt-safe. */
static void oneshot_pop(struct lmotor *lm)
{
	if (!lm->n_oneshot)
		return;
	for (unsigned k = 1; k < lm->n_oneshot; k++)
		lm->oneshot[k - 1] = lm->oneshot[k];
	lm->n_oneshot--;
}

/* ------------------------------------------------------------------ */
/* Lifecycle and safe actions */

/* rt-safe. */
static enum rmd_safe_action safe_action(const struct rmd_loop *l)
{
	return l->cfg->safety.safe_action;
}

/*
 * Queue the safe action's frames for lm.  stream: a SAFE motor with MIT damp
 * gets the damp frame in every control slot instead of once.
 * rt-safe.
 */
static void queue_safe(struct rmd_loop *l, struct lmotor *lm, bool stream, int64_t now)
{
	enum rmd_safe_action a = safe_action(l);
	struct rmd_frame f[2];
	int n;

	if (a == RMD_SAFE_DAMP && lm->m.proto == RMD_PROTO_MIT && stream) {
		lm->damp_stream = true;
	} else {
		n = rmd_motor_encode_safe(&lm->m, a, f);
		for (int k = 0; k < n; k++)
			oneshot_push(lm, &f[k]);
		if (n <= 0 && rmd_motor_encode_cmd(&lm->m, 0x80, &f[0]) == 0)
			oneshot_push(lm, &f[0]);
	}
	l->cnt.safe_actions++;
	loop_event(l, now, RMD_EV_SAFE_ACTION, idx_of(l, lm), lm->bus, a, 0);
}

/* rt-safe. */
static void push_oneshot_cmd(struct lmotor *lm, uint8_t cmd)
{
	struct rmd_frame f;

	if (rmd_motor_encode_cmd(&lm->m, cmd, &f) == 0)
		oneshot_push(lm, &f);
}

/*
 * The one place a motor changes lifecycle state: the entry actions of lc,
 * then RMD_EV_MOTOR_STATE.  Nothing happens when lm is in lc already.
 *
 *   ENABLED  V3 §2.26 / V2 §3.50: the brake opens before the first setpoint.
 *   SAFE     the safe action, streamed (MIT damp in every control slot).
 *   READY    from ENABLED or SAFE: output off (V3 §2.15) and brake locked
 *            (V3 §2.27), the configured mode; from PROBE: nothing waits.
 *   LOST,    the safe action once when it was ENABLED, else nothing waits;
 *   FAULT    FAULT reports the error code; LOST re-probes after
 *            RMD_LOOP_REPROBE_NS.
 *
 * The enable-edge rule (rmd/loop.h): a motor that enters LOST or FAULT,
 * returns from them, or is made SAFE for any reason but the host
 * watchdog, takes enable = 1 only after an enable = 0; a motor found at
 * bring-up takes it at once.  (A watchdog trip is lifted by any newer
 * enable.)  Leaving FAULT reports error code 0.
 * rt-safe.
 */
void loop_enter(struct rmd_loop *l, struct lmotor *lm, enum rmd_lifecycle lc, int64_t now)
{
	enum rmd_lifecycle old = (enum rmd_lifecycle)lm->st.lifecycle;
	bool was_on = old == RMD_LC_ENABLED || old == RMD_LC_SAFE;

	if (old == lc)
		return;
	if (lc != RMD_LC_READY || was_on) {
		/* LOST -> READY keeps them: the safe action still waiting goes out yet */
		loop_frames_drop(lm);
	}
	switch (lc) {
	case RMD_LC_ENABLED:
		push_oneshot_cmd(lm, 0x77);
		break;
	case RMD_LC_SAFE:
		queue_safe(l, lm, true, now);
		lm->need_edge = l->wd != RMD_WD_TRIPPED;
		break;
	case RMD_LC_READY:
		if (was_on) {
			push_oneshot_cmd(lm, 0x80);
			push_oneshot_cmd(lm, 0x78);
			lm->st.mode = (uint8_t)lm->m.mode;
		} else if (old == RMD_LC_PROBE) {
			lm->need_edge = false;
		} else {
			lm->need_edge = true;
		}
		if (old == RMD_LC_FAULT)
			loop_event(l, now, RMD_EV_MOTOR_ERROR, idx_of(l, lm), lm->bus, 0, 0);
		break;
	case RMD_LC_LOST:
	case RMD_LC_FAULT:
		if (old == RMD_LC_ENABLED)
			queue_safe(l, lm, false, now);
		lm->need_edge = true;
		if (lc == RMD_LC_LOST)
			lm->next_probe_ns = now + RMD_LOOP_REPROBE_NS;
		else
			loop_event(l, now, RMD_EV_MOTOR_ERROR, idx_of(l, lm), lm->bus,
				   lm->st.error_code, 0);
		break;
	case RMD_LC_PROBE:
	case RMD_LC_COUNT:
		break;
	}
	lm->st.lifecycle = (uint8_t)lc;
	loop_event(l, now, RMD_EV_MOTOR_STATE, idx_of(l, lm), lm->bus, old, lc);
}

/* An ENABLED motor gets the safe action and becomes SAFE.  rt-safe. */
static void make_safe(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	if (lm->st.lifecycle == RMD_LC_ENABLED)
		loop_enter(l, lm, RMD_LC_SAFE, now);
}

/* rt-safe. */
static void motor_lost(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	if (lm->st.lifecycle == RMD_LC_LOST)
		return;
	loop_enter(l, lm, RMD_LC_LOST, now);
	if (l->cfg->safety.lost_motor_action == RMD_LOST_ALL)
		for (unsigned j = 0; j < l->n_motors; j++)
			if (&l->mot[j] != lm)
				make_safe(l, &l->mot[j], now);
}

/* rt-safe. */
static void miss(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	unsigned n = l->cfg->safety.missed_replies_lost ? l->cfg->safety.missed_replies_lost : 1;

	lm->st.missed_replies++;
	l->cnt.missed++;
	lm->consecutive++;
	if (lm->consecutive >= n && lm->st.lifecycle != RMD_LC_LOST)
		motor_lost(l, lm, now);
}

/* The motor answered something: it is there.  rt-safe. */
static void alive(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	lm->consecutive = 0;
	lm->replied = true;
	lm->last_reply_cycle = l->cycle;
	if (lm->st.lifecycle == RMD_LC_LOST || lm->st.lifecycle == RMD_LC_PROBE)
		loop_enter(l, lm, RMD_LC_READY, now);
}

/* Error flags from a 0x9A answer or report.  prev: the code before it.  rt-safe. */
void loop_note_errors(struct rmd_loop *l, struct lmotor *lm, uint16_t prev, int64_t now)
{
	uint16_t code = lm->st.error_code;

	if (lm->st.lifecycle != RMD_LC_FAULT) {
		if (code)
			loop_enter(l, lm, RMD_LC_FAULT, now);
	} else if (!code) {
		loop_enter(l, lm, RMD_LC_READY, now);
	} else if (code != prev) {
		loop_event(l, now, RMD_EV_MOTOR_ERROR, idx_of(l, lm), lm->bus, code, 0);
	}
}

/* ------------------------------------------------------------------ */
/* Receiving */

/* rt-safe. */
void loop_unexpected(struct rmd_loop *l, unsigned b, const struct rmd_frame *f, int64_t now)
{
	struct lbus *lb = &l->bus[b];

	l->cnt.unexpected++;
	if (lb->ev_unexpected_any && now - lb->ev_unexpected_ns < EVENT_INTERVAL_NS)
		return;
	lb->ev_unexpected_any = true;
	lb->ev_unexpected_ns = now;
	loop_event(l, now, RMD_EV_UNEXPECTED, 0xFF, b, f->can_id, f->len ? f->data[0] : -1);
}

/* The motor a received identifier belongs to, or NULL.  rt-safe. */
struct lmotor *loop_motor_of(struct rmd_loop *l, unsigned b, uint32_t id)
{
	const struct lbus *lb = &l->bus[b];
	unsigned k = 0;

	if (id > RMD_CAN_V3_REPLY_BASE && id <= RMD_CAN_V3_REPLY_BASE + RMD_MAX_MOTORS)
		k = lb->by_v3[id - RMD_CAN_V3_REPLY_BASE];
	else if (id > RMD_CAN_REQ_BASE && id <= RMD_CAN_REQ_BASE + RMD_MAX_MOTORS)
		k = lb->by_v2[id - RMD_CAN_REQ_BASE];
	else if (id > RMD_CAN_MIT_REPLY_BASE && id <= RMD_CAN_MIT_REPLY_BASE + RMD_MAX_MOTORS)
		k = lb->by_mit[id - RMD_CAN_MIT_REPLY_BASE];
	return k ? &l->mot[k - 1] : NULL;
}

/* Decode f into lm's state; false when it cannot be decoded.  rt-safe. */
static bool take_values(struct rmd_loop *l, struct lmotor *lm, const struct rmd_frame *f,
			int64_t now)
{
	struct rmd_motor_reply r;
	uint16_t prev = lm->st.error_code;

	if (rmd_motor_decode(&lm->m, f, &r) < 0)
		return false;
	rmd_motor_apply(&r, &lm->st);
	if (r.have & RMD_MOTOR_HAVE_ERROR)
		loop_note_errors(l, lm, prev, now);
	return true;
}

/* rt-safe. */
static void handle_frame(struct rmd_loop *l, unsigned b, const struct rmd_bus_rx *rx)
{
	const struct rmd_frame *f = &rx->f;
	struct lmotor *lm = loop_motor_of(l, b, f->can_id);
	int64_t now = rx->t_ns;
	struct outstanding *o;
	uint16_t cmd;

	if (!lm || !f->len) {
		loop_unexpected(l, b, f, now);
		return;
	}
	cmd = f->can_id > RMD_CAN_MIT_REPLY_BASE ? RMD_MOTOR_CMD_MIT : f->data[0];
	o = os_match(lm, f->can_id, cmd);
	if (o) {
		bool echo = !o->echo_is_reply && f->len == RMD_FRAME_LEN &&
			    !memcmp(f->data, o->data, RMD_FRAME_LEN);

		o->used = false;
		l->cnt.replies++;
		lm->st.reply_latency_ns = rx->t_ns - o->sent_ns;
		alive(l, lm, now);
		if (echo) {
			/* DESIGN.md: after a comm-loss trip the first command is only echoed */
			l->cnt.echoes++;
			return;
		}
		if (!take_values(l, lm, f, now))
			l->cnt.bad_replies++;
		return;
	}
	if (cmd == RMD_MOTOR_CMD_COMM_LOST) {
		/* DESIGN.md: the motor's comm-loss protection tripped; its output is off */
		l->cnt.unsolicited++;
		if (lm->st.lifecycle != RMD_LC_LOST) {
			loop_event(l, now, RMD_EV_MOTOR_ERROR, idx_of(l, lm), b, lm->st.error_code,
				   RMD_MOTOR_CMD_COMM_LOST);
			motor_lost(l, lm, now);
		}
		return;
	}
	if (cmd == 0x9A) {
		/* V3 §2.33.4 index 3: error reports every 100 ms, unasked */
		l->cnt.unsolicited++;
		alive(l, lm, now);
		if (!take_values(l, lm, f, now))
			l->cnt.bad_replies++;
		return;
	}
	loop_unexpected(l, b, f, now);
}

/* Take every frame that has arrived on bus b by now.  Bounded.  rt-safe. */
void loop_drain(struct rmd_loop *l, unsigned b, int64_t now)
{
	struct lbus *lb = &l->bus[b];

	for (unsigned round = 0; round < RX_ROUNDS; round++) {
		int n = rmd_bus_recv(lb->bus, lb->rx, RX_BATCH, now);

		if (n <= 0)
			return;
		for (int k = 0; k < n; k++)
			handle_frame(l, b, &lb->rx[k]);
		if (n < RX_BATCH)
			return;
	}
}

/* rt-safe. */
static void check_deadlines(struct rmd_loop *l, int64_t now)
{
	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];

		for (unsigned k = 0; k < OUTSTANDING; k++) {
			struct outstanding *o = &lm->os[k];

			if (o->used && o->deadline_ns <= now) {
				o->used = false;
				miss(l, lm, now);
			}
		}
	}
}

/* ------------------------------------------------------------------ */
/* Commands and the host watchdog */

/* rt-safe. */
static void enable_motor(struct rmd_loop *l, struct lmotor *lm, const struct rmd_setpoint *sp,
			 int64_t now)
{
	switch ((enum rmd_lifecycle)lm->st.lifecycle) {
	case RMD_LC_READY:
	case RMD_LC_SAFE:
		if (lm->need_edge)
			return;
		lm->sp = *sp;
		lm->st.mode = sp->mode;
		loop_enter(l, lm, RMD_LC_ENABLED, now);
		break;
	case RMD_LC_ENABLED:
		lm->sp = *sp;
		lm->st.mode = sp->mode;
		break;
	case RMD_LC_PROBE:
	case RMD_LC_FAULT:
	case RMD_LC_LOST:
	case RMD_LC_COUNT:
		break;
	}
}

/* rt-safe. */
static void disable_motor(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	lm->need_edge = false; /* the enable = 0 the edge rule waits for */
	switch ((enum rmd_lifecycle)lm->st.lifecycle) {
	case RMD_LC_ENABLED:
	case RMD_LC_SAFE:
		loop_enter(l, lm, RMD_LC_READY, now);
		break;
	case RMD_LC_READY:
	case RMD_LC_PROBE:
	case RMD_LC_FAULT:
	case RMD_LC_LOST:
	case RMD_LC_COUNT:
		break;
	}
}

/* rt-safe. */
static void set_watchdog(struct rmd_loop *l, enum rmd_watchdog_state s, int64_t now)
{
	if (l->wd == s)
		return;
	l->wd = (uint8_t)s;
	loop_event(l, now, RMD_EV_WATCHDOG, 0xFF, 0xFF, s, 0);
}

/* rt-safe. */
static void take_command(struct rmd_loop *l, int64_t now)
{
	const struct rmd_command *c = &l->cmd;
	const void *p;
	bool any_enable = false;

	if (!l->o.commands || !rmd_latest_get(l->o.commands, &p))
		return;
	memcpy(&l->cmd, p, sizeof(l->cmd));
	l->cnt.commands++;
	if (!l->have_cmd || c->rx_ns > l->last_cmd_rx_ns)
		l->last_cmd_rx_ns = c->rx_ns;
	l->have_cmd = true;
	/* A command from before the trip does not lift it. */
	if (l->wd == RMD_WD_TRIPPED && c->rx_ns <= l->trip_ns)
		return;
	for (unsigned i = 0; i < l->n_motors; i++) {
		if (!(c->present & (1u << i)))
			continue;
		if (c->m[i].enable) {
			any_enable = true;
			enable_motor(l, &l->mot[i], &c->m[i], now);
		} else {
			disable_motor(l, &l->mot[i], now);
		}
	}
	if (any_enable)
		set_watchdog(l, RMD_WD_OK, now);
}

/* rt-safe. */
static void watchdog(struct rmd_loop *l, int64_t now)
{
	int64_t timeout = (int64_t)l->cfg->safety.command_timeout_ms * RMD_NS_PER_MS;
	bool any = false;

	if (l->wd != RMD_WD_OK || timeout <= 0 || now - l->last_cmd_rx_ns <= timeout)
		return;
	for (unsigned i = 0; i < l->n_motors; i++)
		any |= l->mot[i].st.lifecycle == RMD_LC_ENABLED;
	if (!any)
		return;
	l->trip_ns = now;
	set_watchdog(l, RMD_WD_TRIPPED, now);
	for (unsigned i = 0; i < l->n_motors; i++)
		make_safe(l, &l->mot[i], now);
}

/* ------------------------------------------------------------------ */
/* Sending */

/* rt-safe. */
static void push_tx(struct lbus *lb, const struct rmd_frame *f, unsigned motor, enum req_kind kind)
{
	if (lb->ntx >= TX_MAX)
		return;
	lb->tx[lb->ntx] = *f;
	lb->meta[lb->ntx] = (struct txmeta){ .motor = (uint8_t)motor, .kind = (uint8_t)kind };
	lb->ntx++;
}

/* rt-safe. */
static void push_cmd(struct rmd_loop *l, struct lbus *lb, struct lmotor *lm, uint8_t cmd)
{
	struct rmd_frame f;

	if (rmd_motor_encode_cmd(&lm->m, cmd, &f) == 0)
		push_tx(lb, &f, idx_of(l, lm), REQ_STATUS);
}

/* A lost motor's 0x9A re-probe, when one is due.  rt-safe. */
static void push_reprobe(struct rmd_loop *l, struct lbus *lb, struct lmotor *lm, int64_t now)
{
	if (now < lm->next_probe_ns)
		return;
	lm->next_probe_ns = now + RMD_LOOP_REPROBE_NS;
	push_cmd(l, lb, lm, 0x9A);
}

/* The setpoint's frame, or the safe action's first frame instead of a refused one.  rt-safe. */
static void push_setpoint(struct rmd_loop *l, struct lbus *lb, struct lmotor *lm)
{
	struct rmd_frame f, safe[2];
	unsigned fl = 0;
	int r = rmd_motor_encode(&lm->m, &lm->sp, &f, &fl);

	if (r == 0) {
		if (fl & RMD_MOTOR_CLAMPED)
			l->cnt.clamped++;
		push_tx(lb, &f, idx_of(l, lm), REQ_CONTROL);
		return;
	}
	if (r == -EDOM)
		l->cnt.nonfinite++;
	else
		l->cnt.unsupported++;
	if (rmd_motor_encode_safe(&lm->m, safe_action(l), safe) > 0)
		push_tx(lb, &safe[0], idx_of(l, lm), REQ_CONTROL);
	else
		push_cmd(l, lb, lm, 0x80);
}

/* rt-safe. */
static void add_control(struct rmd_loop *l, struct lbus *lb, struct lmotor *lm, int64_t now)
{
	struct rmd_frame f[2];

	/* one-shots first: an ENABLED motor's brake release, the others' stops */
	if (lm->n_oneshot) {
		push_tx(lb, &lm->oneshot[0], idx_of(l, lm), REQ_ONESHOT);
		return;
	}
	if (lm->st.lifecycle == RMD_LC_ENABLED) {
		push_setpoint(l, lb, lm);
		return;
	}
	switch ((enum rmd_lifecycle)lm->st.lifecycle) {
	case RMD_LC_SAFE:
		if (lm->damp_stream && rmd_motor_encode_safe(&lm->m, RMD_SAFE_DAMP, f) == 1) {
			push_tx(lb, &f[0], idx_of(l, lm), REQ_CONTROL);
			break;
		}
		push_cmd(l, lb, lm, 0x9C);
		break;
	case RMD_LC_PROBE:
	case RMD_LC_READY:
	case RMD_LC_FAULT:
		/* read only: V3 §2.13 / V2 §3.32 status 2 (MIT motors answer V3) */
		push_cmd(l, lb, lm, 0x9C);
		break;
	case RMD_LC_LOST:
		push_reprobe(l, lb, lm, now);
		break;
	case RMD_LC_ENABLED:
	case RMD_LC_COUNT:
		break;
	}
}

/* rt-safe. */
static void add_status(struct rmd_loop *l, struct lbus *lb, struct lmotor *lm, int64_t now)
{
	if (lm->st.lifecycle == RMD_LC_LOST)
		push_reprobe(l, lb, lm, now);
	else
		push_cmd(l, lb, lm, 0x9A);
}

/* The V2 0x280 slot (rmd/loop.h "Frames").  rt-safe. */
static void add_batch(struct rmd_loop *l, struct lbus *lb, int64_t now)
{
	const struct rmd_plan_bus *pb = lb->pb;
	const struct rmd_motor *ms[4] = { NULL };
	double torque[4] = { 0 };
	bool any = false, queued = false;
	struct rmd_frame f;
	unsigned fl = 0, bad = 0, room = (1u + (unsigned)__builtin_popcount(pb->batched)) / 2u;

	/*
	 * One-shots first (brake releases, stops), as many as fit in the
	 * frame's budget (1 + n frames; a one-shot and its answer are 2).
	 */
	for (unsigned k = 0; k < pb->n_motors && room; k++) {
		struct lmotor *lm = &l->mot[pb->motors[k]];

		if ((pb->batched & (1u << k)) && lm->n_oneshot) {
			push_tx(lb, &lm->oneshot[0], idx_of(l, lm), REQ_ONESHOT);
			queued = true;
			room--;
		}
	}
	if (queued)
		return;
	for (unsigned k = 0; k < pb->n_motors; k++) {
		struct lmotor *lm = &l->mot[pb->motors[k]];

		if (!(pb->batched & (1u << k)) || lm->m.id < 1 || lm->m.id > 4)
			continue;
		ms[lm->m.id - 1] = &lm->m;
		if (lm->st.lifecycle != RMD_LC_ENABLED)
			continue;
		any = true;
		if (lm->sp.mode == RMD_MODE_TORQUE) {
			torque[lm->m.id - 1] = lm->sp.torque_nm;
		} else {
			l->cnt.unsupported++; /* 0 A: the frame carries torques only */
		}
	}
	if (any) {
		if (rmd_motor_encode_v2_batch(ms, torque, &f, &fl, &bad) == 0) {
			l->cnt.nonfinite += bad;
			if (fl & RMD_MOTOR_CLAMPED)
				l->cnt.clamped++;
			push_tx(lb, &f, 0, REQ_BATCH);
		}
		return;
	}
	/* Nobody to drive: one status read, the motors in turn. */
	for (unsigned n = 0; n < pb->n_motors; n++) {
		unsigned k = lb->batch_rr++ % pb->n_motors;
		struct lmotor *lm = &l->mot[pb->motors[k]];

		if (!(pb->batched & (1u << k)))
			continue;
		if (lm->st.lifecycle == RMD_LC_LOST) {
			if (now < lm->next_probe_ns)
				continue;
			push_reprobe(l, lb, lm, now);
		} else {
			push_cmd(l, lb, lm, 0x9C);
		}
		return;
	}
}

/* Book frame k of bus b, which the bus took.  rt-safe. */
static void commit(struct rmd_loop *l, struct lbus *lb, unsigned k, int64_t now)
{
	const struct txmeta *mt = &lb->meta[k];
	const struct rmd_frame *f = &lb->tx[k];

	if (mt->kind == REQ_BATCH) {
		for (unsigned j = 0; j < lb->pb->n_motors; j++)
			if (lb->pb->batched & (1u << j))
				os_add(l, &l->mot[lb->pb->motors[j]], f, now);
		return;
	}
	if (mt->kind == REQ_ONESHOT)
		oneshot_pop(&l->mot[mt->motor]);
	os_add(l, &l->mot[mt->motor], f, now);
}

/* Send the cycle's frames of bus b in one call.  False when it did not take them all.  rt-safe. */
static bool send_bus(struct rmd_loop *l, unsigned b, int64_t now)
{
	struct lbus *lb = &l->bus[b];
	struct rmd_plan_slot slots[RMD_PLAN_MAX_SLOTS];
	unsigned n = rmd_plan_cycle(l->plan, b, l->cycle, slots);
	unsigned taken;
	int r;

	lb->ntx = 0;
	for (unsigned s = 0; s < n; s++) {
		switch (slots[s].kind) {
		case RMD_SLOT_CONTROL:
			add_control(l, lb, &l->mot[slots[s].motor], now);
			break;
		case RMD_SLOT_V2_TORQUES:
			add_batch(l, lb, now);
			break;
		case RMD_SLOT_STATUS:
			add_status(l, lb, &l->mot[slots[s].motor], now);
			break;
		}
	}
	if (!lb->ntx)
		return true;
	r = rmd_bus_send(lb->bus, lb->tx, lb->ntx, now);
	taken = r > 0 ? (unsigned)r : 0;
	for (unsigned k = 0; k < taken && k < lb->ntx; k++)
		commit(l, lb, k, now);
	if (taken >= lb->ntx) {
		lb->failing = false;
		return true;
	}
	/*
	 * Dropped: the next cycle sends fresh setpoints; one-shots stay
	 * queued.  A request that never left gets no reply either: it counts
	 * as missed, so a bus that takes nothing (bus-off) loses its motors.
	 */
	l->cnt.frames_not_sent += lb->ntx - taken;
	for (unsigned k = taken; k < lb->ntx; k++) {
		if (lb->meta[k].kind != REQ_BATCH) {
			miss(l, &l->mot[lb->meta[k].motor], now);
			continue;
		}
		for (unsigned j = 0; j < lb->pb->n_motors; j++)
			if (lb->pb->batched & (1u << j))
				miss(l, &l->mot[lb->pb->motors[j]], now);
	}
	if (!lb->failing || !lb->ev_send_any || now - lb->ev_send_ns >= EVENT_INTERVAL_NS) {
		lb->ev_send_any = true;
		lb->ev_send_ns = now;
		loop_event(l, now, RMD_EV_SEND_FAILED, 0xFF, b, r < 0 ? r : -ENOBUFS,
			   lb->ntx - taken);
	}
	lb->failing = true;
	return false;
}

/* ------------------------------------------------------------------ */
/* Publishing */

/* rt-safe. */
void loop_pub_write(struct rmd_loop *l)
{
	atomic_fetch_add_explicit(&l->pub_seq, 1, memory_order_relaxed);
	atomic_thread_fence(memory_order_release);
	memcpy(&l->pub_snap, &l->snap, sizeof(l->snap));
	l->pub_stats = l->stats;
	l->pub_cnt = l->cnt;
	atomic_fetch_add_explicit(&l->pub_seq, 1, memory_order_release);
}

/*
 * Copy `size` bytes at `src` (inside l's published copies) consistently.
 * Any thread; non-rt (spins while the loop writes).
 */
static void pub_read(const struct rmd_loop *l, void *dst, const void *src, size_t size)
{
	for (;;) {
		unsigned s0 = atomic_load_explicit(&l->pub_seq, memory_order_acquire);

		if (s0 & 1u) {
			sched_yield();
			continue;
		}
		memcpy(dst, src, size);
		atomic_thread_fence(memory_order_acquire);
		if (atomic_load_explicit(&l->pub_seq, memory_order_relaxed) == s0)
			return;
	}
}

/* rt-safe. */
static void fill_health(struct rmd_loop *l, struct rmd_health *h, int64_t now)
{
	memset(h, 0, sizeof(*h));
	h->t_ns = now;
	h->loop = l->stats;
	h->nbuses = l->n_buses;
	for (unsigned b = 0; b < l->n_buses; b++) {
		struct lbus *lb = &l->bus[b];
		struct rmd_bus_health *bh = &h->bus[b];
		uint64_t frames = lb->bus->stats.tx_frames + lb->bus->stats.rx_frames;
		int64_t window = now - lb->load_t0;

		if (window > 0 && frames >= lb->frames_t0) {
			int64_t busy =
				rmd_plan_cost_ns(lb->pb, (unsigned)(frames - lb->frames_t0), 0);

			lb->load = (double)busy / (double)window;
		}
		lb->frames_t0 = frames;
		lb->load_t0 = now;
		memcpy(bh->name, lb->cb->name, sizeof(bh->name));
		bh->name[sizeof(bh->name) - 1] = '\0';
		bh->state = (uint8_t)lb->bus->state;
		bh->load = lb->load;
		bh->stats = lb->bus->stats;
	}
	h->watchdog = l->wd;
	h->safe_action_events = l->cnt.safe_actions;
}

/* rt-safe. */
void loop_fill_snapshot(struct rmd_loop *l, int64_t now)
{
	struct rmd_snapshot *s = &l->snap;

	s->t_ns = now;
	s->cycle = l->cycle;
	s->n = l->n_motors;
	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];
		uint64_t age = lm->replied ? l->cycle - lm->last_reply_cycle : UINT32_MAX;

		lm->st.reply_age_cycles = age > UINT32_MAX ? UINT32_MAX : (uint32_t)age;
		s->m[i] = lm->st;
	}
}

/* rt-safe. */
static void publish(struct rmd_loop *l, int64_t now)
{
	struct rmd_snapshot *s = &l->snap;

	loop_fill_snapshot(l, now);
	wake_summary(l);
	loop_pub_write(l);
	if (l->o.snapshots) {
		rmd_latest_put(l->o.snapshots, s);
		if (l->o.snapshot_fd > 0) {
			uint64_t one = 1;
			/* Non-blocking; EAGAIN means the bridge has a wake-up pending anyway. */
			ssize_t w = write(l->o.snapshot_fd, &one, sizeof(one));

			(void)w;
		}
	}
	if (l->o.health && l->cycle >= l->next_health_cycle) {
		fill_health(l, rmd_latest_write_slot(l->o.health), now);
		rmd_latest_publish(l->o.health);
		l->next_health_cycle = l->cycle + l->health_every;
	}
}

/* rt-safe. */
static void bus_states(struct rmd_loop *l, int64_t now)
{
	for (unsigned b = 0; b < l->n_buses; b++) {
		struct lbus *lb = &l->bus[b];

		if (lb->bus->state != lb->state_seen) {
			lb->state_seen = (uint8_t)lb->bus->state;
			loop_event(l, now, RMD_EV_BUS_STATE, 0xFF, b, lb->state_seen, 0);
		}
	}
}

/* ------------------------------------------------------------------ */
/* The cycle */

/*
 * Overrun events: the first at once, later ones at most once a second with
 * the ticks skipped since the last event (an overloaded loop would
 * otherwise report every cycle).
 * rt-safe.
 */
static void overrun_event(struct rmd_loop *l, int64_t now)
{
	if (!l->ov_pending || (l->ov_any && now - l->ov_ev_ns < EVENT_INTERVAL_NS))
		return;
	loop_event(l, now, RMD_EV_OVERRUN, 0xFF, 0xFF, (int64_t)l->ov_pending, 0);
	l->ov_pending = 0;
	l->ov_any = true;
	l->ov_ev_ns = now;
}

/* Overruns: a tick whose whole period passed unserved is skipped and counted.  rt-safe. */
void loop_skip_ticks(struct rmd_loop *l, int64_t now, int64_t skipped)
{
	if (skipped <= 0)
		return;
	l->stats.overruns += (uint64_t)skipped;
	l->ov_pending += (uint64_t)skipped;
	l->next_tick_ns += skipped * l->period_ns;
	overrun_event(l, now);
}

/* rt-safe. */
static void schedule(struct rmd_loop *l, int64_t now)
{
	int64_t tick;

	if (!l->started) {
		/* the first tick is now: no intended wake-up to measure against */
		l->started = true;
		l->next_tick_ns = now + l->period_ns;
		return;
	}
	if (now - l->next_tick_ns >= l->period_ns)
		loop_skip_ticks(l, now, (now - l->next_tick_ns) / l->period_ns);
	tick = l->next_tick_ns;
	l->next_tick_ns = tick + l->period_ns;
	wake_record(l, now - tick);
}

/* rt-safe. */
void rmd_loop_cycle(struct rmd_loop *l, int64_t now)
{
	bool all_sent = true;
	int64_t end;

	schedule(l, now);
	for (unsigned b = 0; b < l->n_buses; b++)
		loop_drain(l, b, now);
	check_deadlines(l, now);
	take_command(l, now);
	watchdog(l, now);
	for (unsigned b = 0; b < l->n_buses; b++)
		all_sent &= send_bus(l, b, now);
	if (!all_sent)
		l->stats.plan_misses++;
	bus_states(l, now);
	overrun_event(l, now);
	l->stats.cycles = l->cycle + 1;
	end = loop_now(l);
	if (end - now > l->stats.cycle_max_ns)
		l->stats.cycle_max_ns = end - now;
	publish(l, now);
	l->cycle++;
	atomic_fetch_add_explicit(&l->heartbeat, 1, memory_order_release);
}

/* rt-safe. */
uint64_t rmd_loop_heartbeat(const struct rmd_loop *l)
{
	return atomic_load_explicit(&l->heartbeat, memory_order_acquire);
}

/* Any thread; non-rt. */
void rmd_loop_get_stats(const struct rmd_loop *l, struct rmd_loop_stats *out)
{
	pub_read(l, out, &l->pub_stats, sizeof(*out));
}

/* Any thread; non-rt. */
void rmd_loop_get_snapshot(const struct rmd_loop *l, struct rmd_snapshot *out)
{
	pub_read(l, out, &l->pub_snap, sizeof(*out));
}

/* Any thread; non-rt. */
void rmd_loop_get_counters(const struct rmd_loop *l, struct rmd_loop_counters *out)
{
	pub_read(l, out, &l->pub_cnt, sizeof(*out));
}

/* ------------------------------------------------------------------ */
/* Stopping the motors */

/* rt-safe. */
static bool outstanding_any(const struct rmd_loop *l)
{
	for (unsigned i = 0; i < l->n_motors; i++)
		for (unsigned k = 0; k < OUTSTANDING; k++)
			if (l->mot[i].os[k].used && l->mot[i].st.lifecycle != RMD_LC_LOST)
				return true;
	return false;
}

/* rt-safe. */
static int64_t max_reply_ns(const struct rmd_loop *l)
{
	int64_t m = 0;

	for (unsigned b = 0; b < l->n_buses; b++)
		if (l->bus[b].reply_ns > m)
			m = l->bus[b].reply_ns;
	return m;
}

/* rt-safe. */
void rmd_loop_stop_motors(struct rmd_loop *l, int64_t now)
{
	unsigned off[RMD_MAX_BUSES] = { 0 };
	bool brake = safe_action(l) == RMD_SAFE_BRAKE;

	for (unsigned b = 0; b < l->n_buses; b++) {
		struct lbus *lb = &l->bus[b];

		lb->ntx = 0;
		for (unsigned k = 0; k < lb->pb->n_motors; k++) {
			struct lmotor *lm = &l->mot[lb->pb->motors[k]];
			struct rmd_frame f;

			/* V3 §2.15 / V2 §3.34 output off; V3 §2.27 / V2 §3.51 brake locked */
			if (rmd_motor_encode_cmd(&lm->m, 0x80, &f) == 0)
				push_tx(lb, &f, idx_of(l, lm), REQ_STATUS);
			if (brake && rmd_motor_encode_cmd(&lm->m, 0x78, &f) == 0)
				push_tx(lb, &f, idx_of(l, lm), REQ_STATUS);
		}
	}
	for (unsigned t = 0; t < STOP_TRIES; t++) {
		bool left = false;

		for (unsigned b = 0; b < l->n_buses; b++) {
			struct lbus *lb = &l->bus[b];
			int r;

			if (off[b] >= lb->ntx)
				continue;
			r = rmd_bus_send(lb->bus, lb->tx + off[b], lb->ntx - off[b], now);
			for (int k = 0; k < r; k++)
				commit(l, lb, off[b] + (unsigned)k, now);
			if (r > 0)
				off[b] += (unsigned)r;
			left |= off[b] < lb->ntx;
		}
		if (!left)
			break;
		sleep_plain(l, STOP_STEP_NS);
		now = loop_now(l);
		/* the sim and RS485 queues advance as they are read */
		for (unsigned b = 0; b < l->n_buses; b++)
			loop_drain(l, b, now);
	}
	for (unsigned b = 0; b < l->n_buses; b++)
		if (off[b] < l->bus[b].ntx)
			loop_event(l, now, RMD_EV_SEND_FAILED, 0xFF, b, -ENOBUFS,
				   l->bus[b].ntx - off[b]);
	/* Wait for the echoes (a reply deadline at most): the frames are out. */
	for (int64_t waited = 0; waited < max_reply_ns(l) && outstanding_any(l);
	     waited += STOP_STEP_NS) {
		sleep_plain(l, STOP_STEP_NS);
		now = loop_now(l);
		for (unsigned b = 0; b < l->n_buses; b++)
			loop_drain(l, b, now);
	}
	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];

		if (lm->st.lifecycle == RMD_LC_ENABLED || lm->st.lifecycle == RMD_LC_SAFE)
			loop_enter(l, lm, RMD_LC_READY, now);
		/* the stop frames went out above: nothing waits any more */
		loop_frames_drop(lm);
	}
}

/* ------------------------------------------------------------------ */
/* Construction (non-rt) */

/* rt-safe. */
static int64_t max64(int64_t a, int64_t b)
{
	return a > b ? a : b;
}

/* Non-rt. */
struct rmd_loop *rmd_loop_new(const struct rmd_loop_opts *opts, char *err, size_t errlen)
{
	const struct rmd_config *cfg;
	const struct rmd_plan *plan;
	struct rmd_loop *l;

	if (err && errlen)
		err[0] = '\0';
	if (!opts || !opts->cfg || !opts->plan || (!opts->buses && opts->cfg->n_buses)) {
		rmd_errf(err, errlen, 0, "loop: no configuration, plan or buses");
		return NULL;
	}
	cfg = opts->cfg;
	plan = opts->plan;
	if (cfg->n_buses > RMD_MAX_BUSES || cfg->n_motors > RMD_MAX_MOTORS ||
	    plan->n_buses != cfg->n_buses || plan->n_motors != cfg->n_motors ||
	    plan->rate_hz != cfg->loop.rate_hz || plan->period_ns <= 0) {
		rmd_errf(err, errlen, 0, "loop: the plan was not built from this configuration");
		return NULL;
	}
	if (!plan->feasible) {
		rmd_errf(err, errlen, 0,
			 "loop: the plan does not fit (rmdd --check-config tells why)");
		return NULL;
	}
	if ((opts->commands && opts->commands->size != sizeof(struct rmd_command)) ||
	    (opts->snapshots && opts->snapshots->size != sizeof(struct rmd_snapshot)) ||
	    (opts->health && opts->health->size != sizeof(struct rmd_health)) ||
	    (opts->events && opts->events->rec_size != sizeof(struct rmd_event))) {
		rmd_errf(err, errlen, 0, "loop: a hand-over buffer has the wrong record size");
		return NULL;
	}
	l = calloc(1, sizeof(*l));
	if (!l) {
		rmd_errf(err, errlen, 0, "loop: out of memory");
		return NULL;
	}
	/* touch every page now: the rt thread must not fault them in */
	memset(l, 0, sizeof(*l));
	l->o = *opts;
	l->cfg = cfg;
	l->plan = plan;
	l->n_buses = cfg->n_buses;
	l->n_motors = cfg->n_motors;
	l->period_ns = plan->period_ns;
	for (unsigned b = 0; b < l->n_buses; b++) {
		struct lbus *lb = &l->bus[b];

		if (!opts->buses[b].ops) {
			rmd_errf(err, errlen, 0, "loop: bus %s is not open", cfg->buses[b].name);
			free(l);
			return NULL;
		}
		lb->bus = &opts->buses[b];
		lb->pb = &plan->bus[b];
		lb->cb = &cfg->buses[b];
		lb->reply_ns = max64(2 * l->period_ns, lb->pb->worst_ns + RMD_LOOP_REPLY_MARGIN_NS);
		lb->state_seen = (uint8_t)lb->bus->state;
	}
	for (unsigned i = 0; i < l->n_motors; i++) {
		const struct rmd_config_motor *c = &cfg->motors[i];
		struct lmotor *lm = &l->mot[i];
		struct lbus *lb;
		int r = rmd_motor_init(&lm->m, c);

		if (r < 0 || c->bus >= l->n_buses) {
			rmd_errf(err, errlen, 0, "loop: motor %s: invalid conversion parameters",
				 c->name);
			free(l);
			return NULL;
		}
		lm->bus = (uint8_t)c->bus;
		lb = &l->bus[c->bus];
		switch (c->proto) {
		case RMD_PROTO_V2:
			lb->by_v2[c->id] = (uint8_t)(i + 1);
			break;
		case RMD_PROTO_MIT:
			lb->by_mit[c->id] = (uint8_t)(i + 1);
			lb->by_v3[c->id] = (uint8_t)(i + 1);
			break;
		case RMD_PROTO_V3:
			lb->by_v3[c->id] = (uint8_t)(i + 1);
			break;
		}
		lm->st.lifecycle = RMD_LC_PROBE;
		lm->st.mode = (uint8_t)c->mode;
		lm->st.pos_rad = NAN;
		lm->st.vel_rad_s = NAN;
		lm->st.torque_nm = NAN;
		lm->st.current_a = NAN;
		lm->st.temp_c = NAN;
		lm->st.voltage_v = NAN;
		lm->st.reply_age_cycles = UINT32_MAX;
	}
	{
		uint64_t every = (uint64_t)cfg->lcm.health_period_ms * cfg->loop.rate_hz / 1000u;

		l->health_every = every ? (unsigned)every : 1u;
	}
	l->wd = RMD_WD_IDLE;
	atomic_init(&l->pub_seq, 0);
	atomic_init(&l->heartbeat, 0);
	atomic_init(&l->stop, false);
	l->snap.n = l->n_motors;
	for (unsigned i = 0; i < l->n_motors; i++)
		l->snap.m[i] = l->mot[i].st;
	loop_pub_write(l);
	return l;
}

/* Non-rt. */
void rmd_loop_free(struct rmd_loop *l)
{
	if (!l)
		return;
	if (l->running) {
		rmd_loop_request_stop(l);
		rmd_loop_join(l);
	}
	free(l);
}
