// SPDX-License-Identifier: MIT
/*
 * The real-time loop: one cycle per tick over every bus, reply matching and
 * deadlines, motor lifecycle, host watchdog, safe actions, the SCHED_FIFO
 * thread, and bring-up.  See rmd/loop.h for the behaviour.
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
#include <sched.h>
#include <stdarg.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include "rmd/time.h"
#include "rmd/hist.h"
#include "rmd/err.h"
#include "rmd/bus_rs485.h"
#include "rmd/loop.h"
#include "rmd/motor.h"

#define OUTSTANDING 8			/* requests in flight per motor */
#define ONESHOTS 4			/* one-shot frames waiting per motor */
#define RX_BATCH 64			/* frames per recv() call */
#define RX_ROUNDS 8			/* recv() calls per bus per drain: bounded work */
#define TX_MAX (RMD_PLAN_MAX_SLOTS + 8) /* frames of one bus in one cycle */
#define EVENT_INTERVAL_NS RMD_NS_PER_S	/* repeated bus events: at most one a second */
#define COLLECT_GUARD_NS 50000		/* stop polling the buses this long before the tick */
#define COLLECT_MIN_STEP_NS 50000	/* shortest wait between two looks at the buses */
#define STOP_TRIES 50			/* rmd_loop_stop_motors(): sends per bus ... */
#define STOP_STEP_NS 200000		/* ... this far apart */
#define PROBE_STEP_NS 100000		/* bring-up: longest wait between two looks */
#define REPORT_LINE 256

/* What a frame of a cycle is, to book it once the bus took it. */
enum req_kind {
	REQ_CONTROL = 0, /* a setpoint, or a safe action's streamed frame */
	REQ_STATUS,	 /* a status read (0x9A, 0x9C) */
	REQ_ONESHOT,	 /* the head of the motor's one-shot queue */
	REQ_BATCH,	 /* V2 0x280: one request, every batched motor answers */
};

/* A request in flight. */
struct outstanding {
	bool used;
	bool echo_is_reply; /* the command's answer repeats it (0x80, 0xB3, ...) */
	uint16_t cmd;	    /* command byte of the answer, or RMD_MOTOR_CMD_MIT */
	uint32_t reply_id;
	uint64_t seq; /* send order */
	int64_t sent_ns;
	int64_t deadline_ns;
	uint8_t data[RMD_FRAME_LEN]; /* the request, to tell an echo */
};

struct lmotor {
	struct rmd_motor m;
	uint8_t bus;
	struct rmd_motor_state st;
	struct outstanding os[OUTSTANDING];
	uint64_t seq;
	unsigned consecutive;	/* missed replies in a row */
	struct rmd_setpoint sp; /* in force while ENABLED */
	bool need_edge;		/* enable = 1 counts only after an enable = 0 */
	struct rmd_frame oneshot[ONESHOTS];
	unsigned n_oneshot;
	bool damp_stream; /* SAFE with MIT damp: the damp frame in every control slot */
	int64_t next_probe_ns;
	bool replied;
	uint64_t last_reply_cycle;
	/* bring-up */
	char model[8];
	uint32_t version;
};

struct txmeta {
	uint8_t motor; /* config index; unused for REQ_BATCH */
	uint8_t kind;  /* enum req_kind */
};

struct lbus {
	struct rmd_bus *bus;
	const struct rmd_plan_bus *pb;
	const struct rmd_config_bus *cb;
	/* reply identifier -> config index + 1 (0: no motor) */
	uint8_t by_v3[RMD_MAX_MOTORS + 1];  /* 0x240 + ID: V3 and MIT motors */
	uint8_t by_v2[RMD_MAX_MOTORS + 1];  /* 0x140 + ID: V2 motors */
	uint8_t by_mit[RMD_MAX_MOTORS + 1]; /* 0x500 + ID */
	int64_t reply_ns;		    /* reply deadline after the send */
	struct rmd_bus_rx rx[RX_BATCH];
	struct rmd_frame tx[TX_MAX];
	struct txmeta meta[TX_MAX];
	unsigned ntx;
	unsigned batch_rr; /* round robin of the 0x280 slot's status reads */
	uint8_t state_seen;
	bool failing;
	int64_t ev_send_ns, ev_unexpected_ns;
	bool ev_send_any, ev_unexpected_any;
	/* load over the last health window */
	uint64_t frames_t0;
	int64_t load_t0;
	double load;
	uint32_t unexpected_ids; /* bring-up: ids that answered but are not configured */
};

struct rmd_loop {
	struct rmd_loop_opts o;
	const struct rmd_config *cfg;
	const struct rmd_plan *plan;
	unsigned n_buses, n_motors;
	int64_t period_ns;
	struct lbus bus[RMD_MAX_BUSES];
	struct lmotor mot[RMD_MAX_MOTORS];

	/* schedule */
	bool started;
	int64_t next_tick_ns;
	uint64_t cycle; /* index of the cycle running, from 0 */

	/* commands and the host watchdog */
	struct rmd_command cmd;
	bool have_cmd;
	int64_t last_cmd_rx_ns;
	uint8_t wd; /* enum rmd_watchdog_state */
	int64_t trip_ns;

	/* statistics */
	struct rmd_loop_stats stats;
	struct rmd_loop_counters cnt;
	uint64_t hist[RMD_HIST_BUCKETS];
	uint64_t wake_n;
	int64_t wake_sum;
	uint64_t safe_events;
	uint64_t ov_pending; /* ticks skipped, not yet reported */
	bool ov_any;
	int64_t ov_ev_ns;
	uint64_t next_health_cycle;
	unsigned health_every;

	/* work copies */
	struct rmd_snapshot snap;

	/* for rmd_loop_get_*(): a sequence lock, written by the loop only */
	atomic_uint pub_seq;
	struct rmd_snapshot pub_snap;
	struct rmd_loop_stats pub_stats;
	struct rmd_loop_counters pub_cnt;

	atomic_uint_fast64_t heartbeat;
	atomic_bool stop;
	pthread_t thread;
	bool running;
	bool locked;   /* mlockall done, or refused: */
	int mlock_err; /* -errno of the refusal, said when the thread starts */
};

/* ------------------------------------------------------------------ */
/* Small helpers (rt-safe) */

/* rt-safe. */
static int64_t clock_now(const struct rmd_loop *l)
{
	return l->o.now_ns ? l->o.now_ns(l->o.now_ctx) : rmd_now_ns();
}

/* rt-safe. */
static struct timespec to_ts(int64_t ns)
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
	ts = to_ts(ns);
	clock_nanosleep(CLOCK_MONOTONIC, 0, &ts, NULL);
}

/* Wait up to ns for frames on bus (poll(2) on its fd when it has one).  Non-rt. */
static void wait_bus(const struct rmd_loop *l, struct rmd_bus *bus, int64_t ns)
{
	int fd;

	if (ns <= 0)
		return;
	fd = rmd_bus_fd(bus);
	if (l->o.sleep_ns || fd < 0) {
		sleep_plain(l, ns);
	} else {
		struct pollfd pfd = { .fd = fd, .events = POLLIN };
		struct timespec ts = to_ts(ns);

		ppoll(&pfd, 1, &ts, NULL);
	}
}

/* rt-safe. */
static void event(struct rmd_loop *l, int64_t t, unsigned kind, unsigned motor, unsigned bus,
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

/* rt-safe. */
static void set_lifecycle(struct rmd_loop *l, struct lmotor *lm, enum rmd_lifecycle lc, int64_t now)
{
	uint8_t old = lm->st.lifecycle;

	if (old == lc)
		return;
	lm->st.lifecycle = (uint8_t)lc;
	event(l, now, RMD_EV_MOTOR_STATE, idx_of(l, lm), lm->bus, old, lc);
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
	spec = rmd_cmd_find(m->proto == RMD_PROTO_V2 ? RMD_PROTO_V2 : RMD_PROTO_V3, f->data[0]);
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

/* rt-safe. */
static void oneshot_clear(struct lmotor *lm)
{
	lm->n_oneshot = 0;
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

	oneshot_clear(lm);
	lm->damp_stream = false;
	if (a == RMD_SAFE_DAMP && lm->m.proto == RMD_PROTO_MIT && stream) {
		lm->damp_stream = true;
	} else {
		n = rmd_motor_encode_safe(&lm->m, a, f);
		for (int k = 0; k < n; k++)
			oneshot_push(lm, &f[k]);
		if (n <= 0 && rmd_motor_encode_cmd(&lm->m, 0x80, &f[0]) == 0)
			oneshot_push(lm, &f[0]);
	}
	l->safe_events++;
	l->cnt.safe_actions++;
	event(l, now, RMD_EV_SAFE_ACTION, idx_of(l, lm), lm->bus, a, 0);
}

/* An ENABLED motor gets the safe action and becomes SAFE.  rt-safe. */
static void make_safe(struct rmd_loop *l, struct lmotor *lm, bool need_edge, int64_t now)
{
	if (lm->st.lifecycle != RMD_LC_ENABLED)
		return;
	queue_safe(l, lm, true, now);
	lm->need_edge = need_edge;
	set_lifecycle(l, lm, RMD_LC_SAFE, now);
}

/* rt-safe. */
static void motor_lost(struct rmd_loop *l, struct lmotor *lm, int64_t now)
{
	uint8_t old = lm->st.lifecycle;

	if (old == RMD_LC_LOST)
		return;
	oneshot_clear(lm);
	lm->damp_stream = false;
	if (old == RMD_LC_ENABLED)
		queue_safe(l, lm, false, now);
	lm->need_edge = true;
	lm->next_probe_ns = now + RMD_LOOP_REPROBE_NS;
	set_lifecycle(l, lm, RMD_LC_LOST, now);
	if (l->cfg->safety.lost_motor_action == RMD_LOST_ALL)
		for (unsigned j = 0; j < l->n_motors; j++)
			if (&l->mot[j] != lm)
				make_safe(l, &l->mot[j], true, now);
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
	switch ((enum rmd_lifecycle)lm->st.lifecycle) {
	case RMD_LC_LOST:
		/* safe-action frames still waiting go out yet */
		lm->need_edge = true;
		set_lifecycle(l, lm, RMD_LC_READY, now);
		break;
	case RMD_LC_PROBE:
		set_lifecycle(l, lm, RMD_LC_READY, now);
		break;
	case RMD_LC_READY:
	case RMD_LC_ENABLED:
	case RMD_LC_FAULT:
	case RMD_LC_SAFE:
	case RMD_LC_COUNT:
		break;
	}
}

/* Error flags from a 0x9A answer or report.  prev: the code before it.  rt-safe. */
static void note_errors(struct rmd_loop *l, struct lmotor *lm, uint16_t prev, int64_t now)
{
	uint16_t code = lm->st.error_code;
	uint8_t lc = lm->st.lifecycle;

	if (code) {
		if (lc == RMD_LC_FAULT) {
			if (code != prev)
				event(l, now, RMD_EV_MOTOR_ERROR, idx_of(l, lm), lm->bus, code, 0);
			return;
		}
		if (lc == RMD_LC_ENABLED)
			queue_safe(l, lm, false, now);
		else
			oneshot_clear(lm);
		lm->damp_stream = false;
		lm->need_edge = true;
		event(l, now, RMD_EV_MOTOR_ERROR, idx_of(l, lm), lm->bus, code, 0);
		set_lifecycle(l, lm, RMD_LC_FAULT, now);
	} else if (lc == RMD_LC_FAULT) {
		lm->need_edge = true;
		event(l, now, RMD_EV_MOTOR_ERROR, idx_of(l, lm), lm->bus, 0, 0);
		set_lifecycle(l, lm, RMD_LC_READY, now);
	}
}

/* ------------------------------------------------------------------ */
/* Receiving */

/* rt-safe. */
static void unexpected(struct rmd_loop *l, unsigned b, const struct rmd_frame *f, int64_t now)
{
	struct lbus *lb = &l->bus[b];

	l->cnt.unexpected++;
	if (lb->ev_unexpected_any && now - lb->ev_unexpected_ns < EVENT_INTERVAL_NS)
		return;
	lb->ev_unexpected_any = true;
	lb->ev_unexpected_ns = now;
	event(l, now, RMD_EV_UNEXPECTED, 0xFF, b, f->can_id, f->len ? f->data[0] : -1);
}

/* The motor a received identifier belongs to, or NULL.  rt-safe. */
static struct lmotor *motor_of(struct rmd_loop *l, unsigned b, uint32_t id)
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
		note_errors(l, lm, prev, now);
	return true;
}

/* rt-safe. */
static void handle_frame(struct rmd_loop *l, unsigned b, const struct rmd_bus_rx *rx)
{
	const struct rmd_frame *f = &rx->f;
	struct lmotor *lm = motor_of(l, b, f->can_id);
	int64_t now = rx->t_ns;
	struct outstanding *o;
	uint16_t cmd;

	if (!lm || !f->len) {
		unexpected(l, b, f, now);
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
			event(l, now, RMD_EV_MOTOR_ERROR, idx_of(l, lm), b, lm->st.error_code,
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
	unexpected(l, b, f, now);
}

/* Take every frame that has arrived on bus b by now.  Bounded.  rt-safe. */
static void drain(struct rmd_loop *l, unsigned b, int64_t now)
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
	struct rmd_frame f;

	switch ((enum rmd_lifecycle)lm->st.lifecycle) {
	case RMD_LC_READY:
	case RMD_LC_SAFE:
		if (lm->need_edge)
			return;
		oneshot_clear(lm);
		lm->damp_stream = false;
		/* V3 §2.26 / V2 §3.50: the brake opens before the first setpoint */
		if (rmd_motor_encode_cmd(&lm->m, 0x77, &f) == 0)
			oneshot_push(lm, &f);
		lm->sp = *sp;
		lm->st.mode = sp->mode;
		set_lifecycle(l, lm, RMD_LC_ENABLED, now);
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
	struct rmd_frame f;

	lm->need_edge = false;
	switch ((enum rmd_lifecycle)lm->st.lifecycle) {
	case RMD_LC_ENABLED:
	case RMD_LC_SAFE:
		oneshot_clear(lm);
		lm->damp_stream = false;
		/* READY: output off (V3 §2.15), brake locked (V3 §2.27) */
		if (rmd_motor_encode_cmd(&lm->m, 0x80, &f) == 0)
			oneshot_push(lm, &f);
		if (rmd_motor_encode_cmd(&lm->m, 0x78, &f) == 0)
			oneshot_push(lm, &f);
		lm->st.mode = (uint8_t)l->cfg->motors[idx_of(l, lm)].mode;
		set_lifecycle(l, lm, RMD_LC_READY, now);
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
	event(l, now, RMD_EV_WATCHDOG, 0xFF, 0xFF, s, 0);
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
		make_safe(l, &l->mot[i], false, now);
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
		event(l, now, RMD_EV_SEND_FAILED, 0xFF, b, r < 0 ? r : -ENOBUFS, lb->ntx - taken);
	}
	lb->failing = true;
	return false;
}

/* ------------------------------------------------------------------ */
/* Publishing */

/* rt-safe. */
static void pub_write(struct rmd_loop *l)
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
	h->safe_action_events = l->safe_events;
}

/* rt-safe. */
static void fill_snapshot(struct rmd_loop *l, int64_t now)
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

	fill_snapshot(l, now);
	wake_summary(l);
	pub_write(l);
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
			event(l, now, RMD_EV_BUS_STATE, 0xFF, b, lb->state_seen, 0);
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
	event(l, now, RMD_EV_OVERRUN, 0xFF, 0xFF, (int64_t)l->ov_pending, 0);
	l->ov_pending = 0;
	l->ov_any = true;
	l->ov_ev_ns = now;
}

/* Overruns: a tick whose whole period passed unserved is skipped and counted.  rt-safe. */
static void skip_ticks(struct rmd_loop *l, int64_t now, int64_t skipped)
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
		skip_ticks(l, now, (now - l->next_tick_ns) / l->period_ns);
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
		drain(l, b, now);
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
	end = clock_now(l);
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
		now = clock_now(l);
		/* the sim and RS485 queues advance as they are read */
		for (unsigned b = 0; b < l->n_buses; b++)
			drain(l, b, now);
	}
	for (unsigned b = 0; b < l->n_buses; b++)
		if (off[b] < l->bus[b].ntx)
			event(l, now, RMD_EV_SEND_FAILED, 0xFF, b, -ENOBUFS,
			      l->bus[b].ntx - off[b]);
	/* Wait for the echoes (a reply deadline at most): the frames are out. */
	for (int64_t waited = 0; waited < max_reply_ns(l) && outstanding_any(l);
	     waited += STOP_STEP_NS) {
		sleep_plain(l, STOP_STEP_NS);
		now = clock_now(l);
		for (unsigned b = 0; b < l->n_buses; b++)
			drain(l, b, now);
	}
	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];

		oneshot_clear(lm);
		lm->damp_stream = false;
		if (lm->st.lifecycle == RMD_LC_ENABLED || lm->st.lifecycle == RMD_LC_SAFE) {
			lm->st.mode = (uint8_t)l->cfg->motors[i].mode;
			set_lifecycle(l, lm, RMD_LC_READY, now);
		}
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
	pub_write(l);
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

/* ------------------------------------------------------------------ */
/* Bring-up (non-rt) */

struct report {
	char *buf;
	size_t len, used;
};

/* Non-rt. */
__attribute__((format(printf, 2, 3))) static void rep_add(struct report *r, const char *fmt, ...)
{
	va_list ap;
	int n;

	if (!r->buf || !r->len || r->used + 1 >= r->len)
		return;
	va_start(ap, fmt);
	n = vsnprintf(r->buf + r->used, r->len - r->used, fmt, ap);
	va_end(ap);
	if (n > 0)
		r->used += (size_t)n;
	if (r->used >= r->len)
		r->used = r->len - 1;
}

/* Bring-up: a frame nobody asked for; remember ids that are not configured.  Non-rt (bring-up). */
static void probe_stray(struct rmd_loop *l, unsigned b, const struct rmd_frame *f)
{
	uint32_t id = f->can_id;
	unsigned mid = 0;

	if (motor_of(l, b, id))
		return;
	if (id > RMD_CAN_V3_REPLY_BASE && id <= RMD_CAN_V3_REPLY_BASE + RMD_MAX_MOTORS)
		mid = id - RMD_CAN_V3_REPLY_BASE;
	else if (id > RMD_CAN_REQ_BASE && id <= RMD_CAN_REQ_BASE + RMD_MAX_MOTORS)
		mid = id - RMD_CAN_REQ_BASE;
	else if (id > RMD_CAN_MIT_REPLY_BASE && id <= RMD_CAN_MIT_REPLY_BASE + RMD_MAX_MOTORS)
		mid = id - RMD_CAN_MIT_REPLY_BASE;
	if (mid)
		l->bus[b].unexpected_ids |= 1u << (mid - 1);
}

/* True when the reply to `cmd` repeats the request (RMD_CMD_ECHO).  Non-rt. */
static bool cmd_echoes(const struct lmotor *lm, uint8_t cmd)
{
	enum rmd_proto proto = lm->m.proto == RMD_PROTO_V2 ? RMD_PROTO_V2 : RMD_PROTO_V3;
	const struct rmd_cmd_spec *spec = rmd_cmd_find(proto, cmd);

	return spec && (spec->flags & RMD_CMD_ECHO);
}

/*
 * One request to lm and its answer, with retries.  Returns 0 with the
 * answer in *rep, or -ETIMEDOUT.
 * Non-rt: blocks for a bounded time.
 */
static int probe_xfer(struct rmd_loop *l, struct lmotor *lm, const struct rmd_frame *req,
		      unsigned tries, int64_t timeout_ns, struct rmd_frame *rep)
{
	struct lbus *lb = &l->bus[lm->bus];
	bool check_echo, echo_seen = false;
	uint32_t rid;
	uint16_t cmd;

	rmd_motor_reply_key(&lm->m, req, &rid, &cmd);
	check_echo = cmd != RMD_MOTOR_CMD_MIT && !cmd_echoes(lm, (uint8_t)cmd);
	for (unsigned t = 0; t < tries; t++) {
		int64_t now = clock_now(l), deadline = now + timeout_ns;
		bool resend = false;

		rmd_bus_send(lb->bus, req, 1, now);
		while (!resend) {
			int n;

			now = clock_now(l);
			n = rmd_bus_recv(lb->bus, lb->rx, RX_BATCH, now);
			for (int k = 0; k < n; k++) {
				const struct rmd_frame *f = &lb->rx[k].f;

				if (f->can_id != rid || !f->len ||
				    (cmd != RMD_MOTOR_CMD_MIT && f->data[0] != cmd)) {
					probe_stray(l, lm->bus, f);
					continue;
				}
				/*
				 * A copy of a request whose answer is no copy: a motor
				 * whose comm-loss protection tripped echoes the first
				 * command and does not execute it.  Ask again; a second
				 * copy is the answer (V3 0x70 in mode 0 is all zeros).
				 */
				if (check_echo && !echo_seen && f->len == req->len &&
				    !memcmp(f->data, req->data, req->len)) {
					echo_seen = true;
					resend = true;
					break;
				}
				*rep = *f;
				return 0;
			}
			if (resend || now >= deadline)
				break;
			if (n < RX_BATCH)
				wait_bus(l, lb->bus,
					 deadline - now < PROBE_STEP_NS ? deadline - now :
									  PROBE_STEP_NS);
		}
	}
	return -ETIMEDOUT;
}

/* Non-rt. */
static int probe_cmd(struct rmd_loop *l, struct lmotor *lm, uint8_t cmd, unsigned tries,
		     int64_t timeout_ns, struct rmd_motor_reply *r)
{
	struct rmd_frame req, rep;
	int ret = rmd_motor_encode_cmd(&lm->m, cmd, &req);

	if (ret < 0)
		return ret;
	ret = probe_xfer(l, lm, &req, tries, timeout_ns, &rep);
	if (ret < 0)
		return ret;
	return rmd_motor_decode(&lm->m, &rep, r) < 0 ? -EBADMSG : 0;
}

/* Probe motor i and write its report line.  Returns 0, or -ENODEV when it is missing.  Non-rt. */
static int probe_motor(struct rmd_loop *l, unsigned i, struct report *rp)
{
	const struct rmd_config_motor *c = &l->cfg->motors[i];
	struct lmotor *lm = &l->mot[i];
	struct lbus *lb = &l->bus[lm->bus];
	const char *bus = lb->cb->name;
	bool v2 = lm->m.proto == RMD_PROTO_V2;
	const unsigned tries = RMD_LOOP_PROBE_TRIES;
	int64_t timeout = RMD_LOOP_PROBE_TIMEOUT_NS;
	struct rmd_motor_reply r;
	uint8_t first = v2 ? 0x9A : 0xB5;
	int64_t now;
	int ret;

	if (lb->cb->kind == RMD_BUS_KIND_RS485)
		timeout = rmd_rs485_reply_timeout_ns(lb->bus) + RMD_NS_PER_MS;
	rep_add(rp, "%s: motor %u (%s): ", bus, c->id, c->name);
	/* V3 §2.32 model; V2 has no model or version query: its status answers */
	ret = probe_cmd(l, lm, first, tries, timeout, &r);
	now = clock_now(l);
	if (ret < 0) {
		rep_add(rp, "missing (no answer to 0x%02X in %u tries of %lld ms)\n", first, tries,
			(long long)(timeout / RMD_NS_PER_MS));
		event(l, now, RMD_EV_PROBE, i, lm->bus, -ENODEV, 0);
		oneshot_clear(lm);
		lm->next_probe_ns = now;
		lm->need_edge = true;
		set_lifecycle(l, lm, RMD_LC_LOST, now);
		return -ENODEV;
	}
	if (!v2) {
		snprintf(lm->model, sizeof(lm->model), "%s", r.model);
		/* V3 §2.29 firmware date */
		if (probe_cmd(l, lm, 0xB2, tries, timeout, &r) == 0)
			lm->version = r.version_date;
		rep_add(rp, "%s", lm->model[0] ? lm->model : "(no model)");
		if (!lm->version)
			rep_add(rp, ", no answer to 0xB2");
		else if (rmd_version_date_valid(lm->version))
			rep_add(rp, ", firmware %u", (unsigned)lm->version);
		else
			rep_add(rp, ", firmware date %u implausible", (unsigned)lm->version);
		/* V3 §2.12 status 1 */
		ret = probe_cmd(l, lm, 0x9A, tries, timeout, &r);
	} else {
		rep_add(rp, "V2 (no model or version query)");
	}
	if (ret == 0) {
		rmd_motor_apply(&r, &lm->st);
		rep_add(rp, ", %.1f V, %.0f °C", r.voltage_v, r.temp_c);
		if (r.error_code) {
			const char *names[4];
			size_t n = rmd_error_names(v2 ? RMD_PROTO_V2 : RMD_PROTO_V3, r.error_code,
						   names, 4);

			rep_add(rp, ", errors 0x%04X (", r.error_code);
			for (size_t k = 0; k < n && k < 4; k++)
				rep_add(rp, "%s%s", k ? ", " : "", names[k]);
			rep_add(rp, "%s)", n > 4 ? ", ..." : "");
		}
	} else {
		rep_add(rp, ", no answer to 0x9A");
	}
	if (v2) {
		/* V2 §3.29: the multi-turn angle anchors the unwrapped encoder */
		if (probe_cmd(l, lm, 0x92, tries, timeout, &r) == 0 &&
		    (r.have & RMD_MOTOR_HAVE_POS))
			rmd_motor_set_v2_reference(&lm->m,
						   rmd_motor_to_native_pos(&lm->m, r.pos_rad));
		else
			rep_add(rp, ", no 0x92 angle: positions start at 0");
		rep_add(rp, ", no 0xB3 in V2 (no comm-loss protection)");
	}
	rep_add(rp, "\n");
	now = clock_now(l);
	event(l, now, RMD_EV_PROBE, i, lm->bus, 0, lm->version);
	lm->consecutive = 0;
	lm->need_edge = false;
	set_lifecycle(l, lm, RMD_LC_READY, now);
	if (lm->st.error_code)
		note_errors(l, lm, 0, now);
	return 0;
}

/*
 * Ask every id that is not configured on bus b for its status (0x9A, read
 * only; V3 §2.12 on 0x140 + ID, which V2 motors take as well), all at
 * once, and note who answers.  Bounded: one try, the wire time of the
 * requests (RS485: one reply timeout each) plus RMD_LOOP_PROBE_TIMEOUT_NS.
 * Non-rt.
 */
static void scan_bus(struct rmd_loop *l, unsigned b)
{
	struct lbus *lb = &l->bus[b];
	struct rmd_frame req[RMD_MAX_MOTORS];
	unsigned n = 0, off = 0;
	int64_t now = clock_now(l), end;

	for (unsigned id = 1; id <= RMD_MAX_MOTORS; id++) {
		struct rmd_msg msg;

		if (lb->by_v3[id] || lb->by_v2[id] || lb->by_mit[id])
			continue;
		memset(&msg, 0, sizeof(msg));
		msg.cmd = 0x9A;
		if (rmd_encode(RMD_PROTO_V3, RMD_DIR_REQUEST, (uint8_t)id, &msg, &req[n]) == 0)
			n++;
	}
	if (lb->cb->kind == RMD_BUS_KIND_RS485)
		end = now + (int64_t)(n + 1) * rmd_rs485_reply_timeout_ns(lb->bus);
	else
		end = now + rmd_plan_cost_ns(lb->pb, 2 * n, n);
	end += RMD_LOOP_PROBE_TIMEOUT_NS;
	while (now < end) {
		int r;

		if (off < n) {
			r = rmd_bus_send(lb->bus, req + off, n - off, now);
			if (r > 0)
				off += (unsigned)r;
		}
		r = rmd_bus_recv(lb->bus, lb->rx, RX_BATCH, now);
		for (int k = 0; k < r; k++)
			probe_stray(l, b, &lb->rx[k].f);
		if (r < RX_BATCH)
			wait_bus(l, lb->bus, end - now < PROBE_STEP_NS ? end - now : PROBE_STEP_NS);
		now = clock_now(l);
	}
}

/* Non-rt. */
/*
 * V3 §2.30: write the comm-loss protection time (ROM) to every motor of bus
 * b that answered the probe, and check each echo, as the last step of
 * bring-up: a motor starts counting at the write, and the loop's first
 * cycle follows at once.  One report line per bus.  Non-rt.
 */
static void arm_comm_loss(struct rmd_loop *l, unsigned b, struct report *rp)
{
	struct lbus *lb = &l->bus[b];
	uint32_t ms = l->cfg->safety.comm_loss_ms;
	int64_t timeout = RMD_LOOP_PROBE_TIMEOUT_NS;
	unsigned set = 0;
	bool any = false;

	if (lb->cb->kind == RMD_BUS_KIND_RS485)
		timeout = rmd_rs485_reply_timeout_ns(lb->bus) + RMD_NS_PER_MS;
	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];
		const struct rmd_config_motor *c = &l->cfg->motors[i];
		struct rmd_frame req, echo;

		if (lm->bus != b || lm->m.proto == RMD_PROTO_V2 || lm->st.lifecycle == RMD_LC_LOST)
			continue;
		if (!any)
			rep_add(rp, "%s: comm-loss protection (0xB3) %s", lb->cb->name,
				ms ? "" : "off (disabled by safety.comm_loss_ms: 0)");
		if (ms && !any)
			rep_add(rp, "%u ms:", (unsigned)ms);
		any = true;
		if (rmd_motor_encode_comm_timeout(&lm->m, ms, &req) < 0 ||
		    probe_xfer(l, lm, &req, RMD_LOOP_PROBE_TRIES, timeout, &echo) < 0) {
			rep_add(rp, " motor %u (%s) did not answer 0xB3;", c->id, c->name);
		} else if (echo.len != req.len || memcmp(echo.data, req.data, RMD_FRAME_LEN)) {
			rep_add(rp, " motor %u (%s) NOT confirmed (the echo differs);", c->id,
				c->name);
		} else {
			rep_add(rp, " %u", c->id);
			set++;
		}
	}
	if (any)
		rep_add(rp, " (%u set, echo verified)\n", set);
}

int rmd_loop_bringup(struct rmd_loop *l, char *report, size_t len)
{
	struct report rp = { .buf = report, .len = len };
	unsigned missing = 0;

	if (report && len)
		report[0] = '\0';
	if (l->running)
		return -EBUSY;
	for (unsigned b = 0; b < l->n_buses; b++) {
		struct lbus *lb = &l->bus[b];
		int64_t now = clock_now(l);

		lb->unexpected_ids = 0;
		/* what came before the first request answers none of them */
		while (rmd_bus_recv(lb->bus, lb->rx, RX_BATCH, now) == RX_BATCH)
			;
	}
	for (unsigned i = 0; i < l->n_motors; i++)
		if (probe_motor(l, i, &rp) < 0)
			missing++;
	for (unsigned b = 0; b < l->n_buses; b++) {
		struct lbus *lb = &l->bus[b];
		int64_t now = clock_now(l);
		int n;

		/* late answers tell of ids too */
		while ((n = rmd_bus_recv(lb->bus, lb->rx, RX_BATCH, now)) > 0) {
			for (int k = 0; k < n; k++)
				probe_stray(l, b, &lb->rx[k].f);
			if (n < RX_BATCH)
				break;
		}
		scan_bus(l, b);
		now = clock_now(l);
		for (unsigned id = 1; id <= RMD_MAX_MOTORS; id++) {
			if (!(lb->unexpected_ids & (1u << (id - 1))))
				continue;
			rep_add(&rp, "%s: motor %u: unexpected (answers, but is not configured)\n",
				lb->cb->name, id);
			event(l, now, RMD_EV_PROBE, 0xFF, b, -EEXIST, id);
		}
	}
	/* last, so that no motor goes quiet between its 0xB3 and the first cycle */
	for (unsigned b = 0; b < l->n_buses; b++)
		arm_comm_loss(l, b, &rp);
	if (rp.used && report[rp.used - 1] == '\n')
		report[--rp.used] = '\0';
	/* what bring-up found is the state before the first cycle */
	fill_snapshot(l, clock_now(l));
	pub_write(l);
	if (missing && l->cfg->probe.on_missing == RMD_MISSING_REFUSE)
		return -ENODEV;
	return 0;
}

/* ------------------------------------------------------------------ */
/* The thread */

/* rt thread, before its first cycle. */
static void __attribute__((noinline)) prefault_stack(void)
{
	volatile unsigned char buf[RMD_LOOP_PREFAULT_STACK];

	for (size_t i = 0; i < sizeof(buf); i += 4096)
		buf[i] = 0;
}

/* rt-safe. */
static bool stopping(const struct rmd_loop *l)
{
	return atomic_load_explicit(&l->stop, memory_order_acquire);
}

/*
 * Between ticks: wait on the buses that have a descriptor and read what
 * comes (and let the RS485 queues advance at their deadlines), until just
 * before the next tick.
 * rt-safe.
 */
static void collect_until_tick(struct rmd_loop *l)
{
	struct pollfd pfd[RMD_MAX_BUSES];
	unsigned which[RMD_MAX_BUSES], n = 0;

	for (unsigned b = 0; b < l->n_buses; b++) {
		int fd = rmd_bus_fd(l->bus[b].bus);

		if (fd < 0)
			continue;
		pfd[n] = (struct pollfd){ .fd = fd, .events = POLLIN };
		which[n++] = b;
	}
	if (!n)
		return;
	while (!stopping(l)) {
		int64_t now = rmd_now_ns(), until = l->next_tick_ns - COLLECT_GUARD_NS;
		struct timespec ts;
		int r;

		if (now >= until)
			return;
		for (unsigned k = 0; k < n; k++) {
			unsigned b = which[k];

			if (l->bus[b].cb->kind == RMD_BUS_KIND_RS485) {
				int64_t d = rmd_rs485_deadline_ns(l->bus[b].bus);

				/* at least a short step: a past deadline must not spin */
				if (d < now + COLLECT_MIN_STEP_NS)
					d = now + COLLECT_MIN_STEP_NS;
				if (d < until)
					until = d;
			}
		}
		ts = to_ts(until - now);
		r = ppoll(pfd, n, &ts, NULL);
		if (r < 0 && errno != EINTR)
			return;
		now = rmd_now_ns();
		for (unsigned k = 0; k < n; k++)
			drain(l, which[k], now);
	}
}

/* The rt thread. */
static void *thread_main(void *arg)
{
	struct rmd_loop *l = arg;
	int64_t now;

	prefault_stack();
	now = rmd_now_ns();
	while (!stopping(l)) {
		struct timespec ts;

		rmd_loop_cycle(l, now);
		now = rmd_now_ns();
		/* the work ran past the next tick: skip it, never catch up in a burst */
		if (now > l->next_tick_ns)
			skip_ticks(l, now, (now - l->next_tick_ns) / l->period_ns + 1);
		collect_until_tick(l);
		ts = to_ts(l->next_tick_ns);
		while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR &&
		       !stopping(l))
			;
		now = rmd_now_ns();
	}
	rmd_loop_stop_motors(l, rmd_now_ns());
	return NULL;
}

/* Create the thread with SCHED_FIFO (fifo) and the configured CPUs (cpus).  Non-rt. */
static int create_thread(struct rmd_loop *l, bool fifo, bool cpus)
{
	const struct rmd_config_loop *cl = &l->cfg->loop;
	struct sched_param sp = { .sched_priority = (int)cl->rt_priority };
	pthread_attr_t attr;
	int r;

	r = -pthread_attr_init(&attr);
	if (r)
		return r;
	r = -pthread_attr_setstacksize(&attr, RMD_LOOP_STACK_SIZE);
	if (!r && fifo) {
		r = -pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED);
		if (!r)
			r = -pthread_attr_setschedpolicy(&attr, SCHED_FIFO);
		if (!r)
			r = -pthread_attr_setschedparam(&attr, &sp);
	}
	if (!r && cpus) {
		cpu_set_t set;

		CPU_ZERO(&set);
		for (unsigned k = 0; k < cl->n_cpus && k < RMD_CONFIG_MAX_CPUS; k++)
			if (cl->cpus[k] < CPU_SETSIZE)
				CPU_SET(cl->cpus[k], &set);
		r = -pthread_attr_setaffinity_np(&attr, sizeof(set), &set);
	}
	if (!r)
		r = -pthread_create(&l->thread, &attr, thread_main, l);
	pthread_attr_destroy(&attr);
	return r;
}

/* Non-rt. */
int rmd_loop_lock_memory(struct rmd_loop *l)
{
	if (l->locked)
		return 0;
	if (mlockall(MCL_CURRENT | MCL_FUTURE) < 0) {
		if (l->o.require_rt)
			return -EPERM;
		/* said by rmd_loop_start(), with the other real-time refusals */
		l->mlock_err = -errno;
	}
	l->locked = true;
	return 0;
}

int rmd_loop_start(struct rmd_loop *l)
{
	bool fifo = true, cpus = l->cfg->loop.n_cpus > 0;
	int64_t now = rmd_now_ns();
	int r;

	if (l->running)
		return -EBUSY;
	if (l->o.now_ns)
		return -EINVAL;
	atomic_store(&l->stop, false);
	r = rmd_loop_lock_memory(l);
	if (r < 0)
		return r;
	if (l->mlock_err)
		event(l, now, RMD_EV_RT, 0xFF, 0xFF, l->mlock_err, RMD_LOOP_RT_MLOCK);
	/*
	 * Every fallback is decided, and said through the event ring, before
	 * the thread exists: the ring has one producer at a time.
	 */
	for (;;) {
		r = create_thread(l, fifo, cpus);
		if (r == -EPERM && fifo && !l->o.require_rt) {
			event(l, now, RMD_EV_RT, 0xFF, 0xFF, r, RMD_LOOP_RT_FIFO);
			fifo = false;
			continue;
		}
		if (r == -EINVAL && cpus && !l->o.require_rt) {
			event(l, now, RMD_EV_RT, 0xFF, 0xFF, r, RMD_LOOP_RT_AFFINITY);
			cpus = false;
			continue;
		}
		break;
	}
	if (r)
		return r;
	l->running = true;
	return 0;
}

/* rt-safe and async-signal-safe. */
void rmd_loop_request_stop(struct rmd_loop *l)
{
	atomic_store_explicit(&l->stop, true, memory_order_release);
}

/* Non-rt. */
int rmd_loop_join(struct rmd_loop *l)
{
	int r;

	if (!l->running)
		return 0;
	r = -pthread_join(l->thread, NULL);
	if (!r)
		l->running = false;
	return r;
}
