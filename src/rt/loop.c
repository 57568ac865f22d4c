// SPDX-License-Identifier: MIT
/*
 * The real-time loop: its construction, the cycle (rmd_loop_tick(),
 * rmd_loop_collect(), rmd_loop_publish(); rmd_loop_cycle() for the suites;
 * in the order rmd/loop.h gives), the schedule, publishing, the getters and
 * stopping the motors.  See rmd/loop.h for the behaviour.  Receiving is
 * loop_rx.c, the lifecycle and commands lifecycle.c, sending loop_tx.c,
 * bring-up bringup.c, the thread rt_thread.c; what they share is
 * loop_state.h.
 *
 * Execution context: the cycle's functions and what they call are rt-safe;
 * rmd_loop_stop_motors() is bounded but blocking (it sleeps between
 * sends); construction is non-rt; the getters are non-rt, any thread.
 *
 * Everything the cycle touches lives in struct rmd_loop, allocated and
 * written once by rmd_loop_new(): fixed arrays sized by RMD_MAX_MOTORS and
 * RMD_MAX_BUSES.  The cycle (its functions and what they call) takes no
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
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "rmd/time.h"
#include "rmd/hist.h"
#include "rmd/err.h"
#include "rmd/incident.h"
#include "rmd/loop.h"
#include "rmd/motor.h"
#include "loop_state.h"
#include "loop_env.h"

/* Wake the events' reader when events came (one eventfd write a cycle at most).  rt-safe. */
static void events_wake(struct rmd_loop *l)
{
	uint64_t one = 1;
	ssize_t w;

	if (!l->ev_pushed || l->events_fd < 0)
		return;
	l->ev_pushed = false;
	/* Non-blocking; EAGAIN means a wake-up is pending anyway. */
	w = write(l->events_fd, &one, sizeof(one));
	(void)w;
}

/* Non-rt. */
void rmd_loop_set_events_fd(struct rmd_loop *l, int fd)
{
	l->events_fd = fd;
}

/* ------------------------------------------------------------------ */
/*
 * The window's slots that ended by now leave it, oldest first; after a
 * stall of a whole window or more, every one.  Once a second.  rt-safe.
 */
static void __attribute__((noinline)) wake_win_roll(struct loop_wake_win *w, int64_t now)
{
	for (unsigned k = 0; k < RMD_LOOP_WAKE_WIN_S && now >= w->slot_end_ns; k++) {
		unsigned next = (w->cur + 1) % RMD_LOOP_WAKE_WIN_S;
		struct loop_wake_slot *sl = &w->slot[next];

		if (sl->n) {
			w->n -= sl->n;
			for (unsigned b = 0; b < RMD_HIST_BUCKETS; b++)
				w->hist[b] -= sl->hist[b];
			for (unsigned b = 0; b < RMD_LOOP_WAKE_US_BUCKETS; b++)
				w->us[b] -= sl->us[b];
			memset(sl, 0, sizeof(*sl));
		}
		w->cur = next;
		w->slot_end_ns += RMD_NS_PER_S;
	}
	if (now >= w->slot_end_ns)
		w->slot_end_ns = now + RMD_NS_PER_S;
}

/* One wake-up `lat` late at now (under stat_begin()).  rt-safe. */
static void wake_record(struct rmd_loop *l, int64_t lat, int64_t now)
{
	struct loop_wake_win *w = &l->wake_win;
	unsigned h;
	uint64_t us;

	if (lat < 0)
		lat = 0;
	h = rmd_hist_bucket(lat);
	l->wake.hist[h]++;
	us = (uint64_t)lat / RMD_NS_PER_US;
	if (us < RMD_LOOP_WAKE_US_BUCKETS)
		l->wake.us[us]++;
	else
		l->wake.over++;
	if (__builtin_expect(now >= w->slot_end_ns, 0)) {
		if (!w->slot_end_ns)
			w->slot_end_ns = now + RMD_NS_PER_S;
		else
			wake_win_roll(w, now);
	}
	w->n++;
	w->slot[w->cur].n++;
	w->hist[h]++;
	w->slot[w->cur].hist[h]++;
	if (us < RMD_LOOP_WAKE_US_BUCKETS) {
		w->us[us]++;
		w->slot[w->cur].us[us]++;
	}
	l->wake.n++;
	l->wake.sum += lat;
	if (l->wake.n == 1 || lat < l->stats.wake_min_ns)
		l->stats.wake_min_ns = lat;
	if (lat > l->stats.wake_max_ns)
		l->stats.wake_max_ns = lat;
}

/*
 * The 99th percentile of n samples, rounded up to their bucket's bound and
 * capped at max: from the 1 us buckets when it lies in them (us may be
 * NULL), else from the log-scale ones.  Pure.
 */
static int64_t p99_of(uint64_t n, const uint64_t *us, const uint64_t *logh, const uint32_t *logh32,
		      int64_t max)
{
	uint64_t want = n - n / 100, sum = 0; /* the 99th percentile, rounded up */

	if (!n)
		return 0;
	for (unsigned k = 0; us && k < RMD_LOOP_WAKE_US_BUCKETS; k++) {
		sum += us[k];
		if (sum >= want) {
			int64_t up = (int64_t)(k + 1) * RMD_NS_PER_US - 1;

			return up < max ? up : max;
		}
	}
	sum = 0;
	for (unsigned b = 0; b < RMD_HIST_BUCKETS; b++) {
		sum += logh ? logh[b] : logh32[b];
		if (sum >= want) {
			int64_t up = rmd_hist_upper(b);

			return up < max ? up : max;
		}
	}
	return max;
}

/*
 * Average of the wake-ups so far and p99 of the last RMD_LOOP_WAKE_WIN_S
 * seconds' (rmd/loop.h), into l->stats (with the health: ~10 Hz).  rt-safe.
 */
static void wake_summary(struct rmd_loop *l)
{
	const struct loop_wake_win *w = &l->wake_win;

	if (!l->wake.n)
		return;
	l->stats.wake_avg_ns = l->wake.sum / (int64_t)l->wake.n;
	l->stats.wake_p99_ns = p99_of(w->n, w->us, w->hist, NULL, l->stats.wake_max_ns);
}

/* Non-rt. */
int64_t rmd_latency_p99(const struct rmd_latency *lat)
{
	return p99_of(lat->n, NULL, NULL, lat->hist, lat->max_ns);
}

/* ------------------------------------------------------------------ */
/* Publishing */

/* rt-safe. */
void loop_pub_write(struct rmd_loop *l)
{
	atomic_fetch_add_explicit(&l->pub_seq, 1, memory_order_relaxed);
	atomic_thread_fence(memory_order_release);
	/* the motors past n stay as rmd_loop_new() left them, in both copies */
	memcpy(&l->pub_snap, &l->snap,
	       offsetof(struct rmd_snapshot, m) + l->n_motors * sizeof(l->snap.m[0]));
	l->pub_stats = l->stats;
	l->pub_cnt = l->cnt;
	if (l->health_fresh) {
		memcpy(&l->pub_health, &l->health, sizeof(l->health));
		l->pub_have_health = true;
		l->health_fresh = false;
	}
	atomic_fetch_add_explicit(&l->pub_seq, 1, memory_order_release);
}

/*
 * Copy `size` bytes at `src` consistently under the sequence lock `seq`
 * (only the loop writes what it guards).  Any thread; non-rt (spins while
 * the loop writes).
 */
static void seq_read(const atomic_uint *seq, void *dst, const void *src, size_t size)
{
	for (;;) {
		unsigned s0 = atomic_load_explicit(seq, memory_order_acquire);

		if (s0 & 1u) {
			sched_yield();
			continue;
		}
		memcpy(dst, src, size);
		atomic_thread_fence(memory_order_acquire);
		if (atomic_load_explicit(seq, memory_order_relaxed) == s0)
			return;
	}
}

/* Copy `size` bytes at `src` (inside l's published copies) consistently.  Non-rt. */
static void pub_read(const struct rmd_loop *l, void *dst, const void *src, size_t size)
{
	seq_read(&l->pub_seq, dst, src, size);
}

/* The health of the window since the last one, into l->health.  rt-safe. */
void loop_fill_health(struct rmd_loop *l, int64_t now)
{
	struct rmd_health *h = &l->health;

	memset(h, 0, sizeof(*h));
	h->t_ns = now;
	wake_summary(l);
	h->loop = l->stats;
	h->nbuses = l->n_buses;
	for (unsigned b = 0; b < l->n_buses; b++) {
		struct lbus *lb = &l->bus[b];
		struct rmd_bus_health *bh = &h->bus[b];
		const struct rmd_bus_stats *bs = rmd_bus_stats(lb->bus);
		uint64_t frames = bs->tx_frames + bs->rx_frames;
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
		bh->state = (uint8_t)rmd_bus_state(lb->bus);
		bh->load = lb->load;
		bh->stats = *bs;
		bh->stats.tx_retried = lb->tx_retried;
		bh->stats.rx_stamps_early = lb->rx_early;
	}
	h->watchdog = l->wd;
	h->safe_action_events = l->cnt.safe_actions;
	h->watchdog_trips = l->cnt.watchdog_trips;
	h->robot_stops = l->robot_stops_seen;
	memcpy(h->ignored, l->cnt.ignored, sizeof(h->ignored));
	h->homes_refused = l->cnt.homes_refused;
	h->nmotors = l->n_motors;
	for (unsigned i = 0; i < l->n_motors; i++) {
		h->comm_loss[i] = l->mot[i].arm.cl;
		h->comm_loss_ms[i] = rmd_config_comm_loss_ms(l->cfg, i);
		h->proto[i] = (uint8_t)l->mot[i].m.proto;
		h->firmware[i] = l->mot[i].ident.version;
		h->unarmed_rejects[i] = l->mot[i].arm.rejects;
	}
	l->health_fresh = true;
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

		/* lm->st is s->m[i] */
		lm->st->reply_age_cycles = age > UINT32_MAX ? UINT32_MAX : (uint32_t)age;
	}
}

/* rt-safe. */
static void publish(struct rmd_loop *l, int64_t now)
{
	struct rmd_snapshot *s = &l->snap;

	bool health = l->cycle >= l->next_health_cycle;

	loop_fill_snapshot(l, now);
	if (health) {
		loop_fill_health(l, now);
		l->next_health_cycle = l->cycle + l->health_every;
	}
	loop_pub_write(l);
	if (l->o.snapshots) {
		struct rmd_latest *sl = l->o.snapshots;
		unsigned slot = 1u << sl->write_idx;

		/*
		 * The motors up to n; past them a slot keeps what its first,
		 * whole copy put there: l->snap's, which stay as rmd_loop_new()
		 * left them.
		 */
		memcpy(rmd_latest_write_slot(sl), s,
		       l->snap_slots & slot ?
			       offsetof(struct rmd_snapshot, m) + l->n_motors * sizeof(s->m[0]) :
			       sizeof(*s));
		l->snap_slots |= slot;
		rmd_latest_publish(sl);
		/*
		 * The bridge publishes every lcm.state_every_n-th state (LCM's
		 * udpm cannot tell whether anyone listens): it is woken for
		 * those only, not every cycle (issue 11 point 4).
		 */
		if (l->o.snapshot_fd >= 0 && l->cycle % l->state_every == 0) {
			uint64_t one = 1;
			/* Non-blocking; EAGAIN means the bridge has a wake-up pending anyway. */
			ssize_t w = write(l->o.snapshot_fd, &one, sizeof(one));

			(void)w;
		}
	}
	if (health && l->o.health)
		rmd_latest_put(l->o.health, &l->health);
}

/* Each bus's state, an event when it changed (lbus.state_seen).  rt-safe. */
static void bus_states(struct rmd_loop *l, int64_t now)
{
	for (unsigned b = 0; b < l->n_buses; b++)
		loop_bus_state(l, b, now);
}

/* ------------------------------------------------------------------ */
/* The cycle */

/*
 * Overrun events: the first at once, later ones at most once a second with
 * the ticks skipped since the last event (an overloaded loop would
 * otherwise report every cycle), but a burst -- incidents.overrun_burst
 * ticks skipped by one late wake-up, not scattered over the second -- at
 * once: the incident recorder dates it by its event.  rt-safe.
 */
static void overrun_event(struct rmd_loop *l, int64_t now)
{
	if (!l->ov_pending || (l->ov_any && now - l->ov_ev_ns < EVENT_INTERVAL_NS &&
			       l->ov_worst < l->cfg->incidents.overrun_burst))
		return;
	loop_event(l, now, RMD_EV_OVERRUN, 0xFF, 0xFF, (int64_t)l->ov_pending,
		   (int64_t)l->ov_worst);
	l->ov_pending = 0;
	l->ov_worst = 0;
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
	if ((uint64_t)skipped > l->ov_worst)
		l->ov_worst = (uint64_t)skipped;
	l->next_tick_ns += skipped * l->period_ns;
	overrun_event(l, now);
}

/*
 * The tick intended at next_tick_ns, reached at now -- woken for it, or
 * back from the last one's work (a stall of the process in that work
 * included): its true lateness recorded, however many periods it skipped,
 * and the whole periods since skipped; that tick itself too unless it is
 * served now (the rt thread skips it: never a catch-up burst).  One rule
 * for both, so a stall shows in wake_max wherever it held the loop.
 * rt-safe.
 */
void loop_reached_tick(struct rmd_loop *l, int64_t now, bool served)
{
	stat_begin(l);
	wake_record(l, now - l->next_tick_ns, now);
	stat_end(l);
	skip_ticks(l, now, (now - l->next_tick_ns) / l->period_ns + !served);
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
	loop_reached_tick(l, now, true);
	tick = l->next_tick_ns;
	l->next_tick_ns = tick + l->period_ns;
}

/* Incident recorder: a command the loop took this cycle (rmd/incident.h).  rt-safe. */
static void incident_command(struct rmd_loop *l, int64_t now)
{
	if (!l->o.incidents || !l->cmd || l->cmd->rx_ns == l->inc_cmd_rx_ns)
		return;
	l->inc_cmd_rx_ns = l->cmd->rx_ns;
	rmd_incident_command(l->o.incidents, l->cmd, now);
}

/* rt-safe. */
void rmd_loop_tick(struct rmd_loop *l, int64_t now)
{
	bool all_sent = true;
	int64_t end;

	schedule(l, now);
	for (unsigned b = 0; b < l->n_buses; b++)
		loop_drain(l, b, now);
	/* what the last cycle's retries did not get onto a bus never left (loop_tx.c) */
	if (__builtin_expect(l->retry_buses != 0, 0))
		loop_retry_sends(l, now, true);
	/* the last cycle's state, if its replies were not in before this tick: with them */
	if (!l->published)
		rmd_loop_publish(l, now);
	l->published = false;
	l->await_due_ns = 0;
	/* as the drain left them: the sends below act on a bus nobody acknowledges (loop_tx.c) */
	bus_states(l, now);
	loop_check_deadlines(l, now);
	loop_take_command(l, now);
	loop_take_homes(l, now);
	incident_command(l, now);
	loop_comm_loss(l, now);
	loop_watchdog(l, now);
	for (unsigned b = 0; b < l->n_buses; b++)
		all_sent &= loop_send_bus(l, b, now);
	if (!all_sent)
		l->stats.plan_misses++;
	overrun_event(l, now);
	l->stats.cycles = l->cycle + 1;
	end = loop_now(l);
	if (end - now > l->stats.cycle_max_ns)
		l->stats.cycle_max_ns = end - now;
	events_wake(l);
}

/* rt-safe. */
bool rmd_loop_collect(struct rmd_loop *l, int64_t now)
{
	if (l->retry_buses && now >= l->retry_next_ns)
		loop_retry_sends(l, now, false);
	for (unsigned b = 0; b < l->n_buses; b++)
		loop_drain(l, b, now);
	return !loop_awaited(l) && !l->retry_buses;
}

/* rmd_loop_reply_due(), and in *owing the buses that owe replies (loop_awaited()).  rt-safe. */
int64_t loop_reply_due(const struct rmd_loop *l, int64_t now, unsigned *owing)
{
	int64_t due = l->await_due_ns, deadline = loop_publish_deadline(l);

	*owing = 0;
	if (l->published || due > deadline)
		return -1; /* the next tick publishes, after its receive */
	*owing = loop_awaited(l);
	if (!*owing)
		return 0;
	if (now >= deadline)
		return -1;
	return due > now ? due : now;
}

/* rt-safe. */
int64_t rmd_loop_reply_due(const struct rmd_loop *l, int64_t now)
{
	unsigned owing;
	int64_t due = loop_reply_due(l, now, &owing);

	/* a refused send to try again (loop_tx.c loop_retry_sends()) is due too */
	if (l->retry_buses && !l->published) {
		int64_t retry = l->retry_next_ns > now ? l->retry_next_ns : now;

		if (due <= 0 || retry < due)
			due = retry;
	}
	return due;
}

/* rt-safe. */
void rmd_loop_publish(struct rmd_loop *l, int64_t now)
{
	if (l->published)
		return;
	l->published = true;
	publish(l, now);
	/* incident recorder: every motor's state of this cycle */
	if (l->o.incidents)
		rmd_incident_snapshot(l->o.incidents, &l->snap);
	l->cycle++;
	atomic_fetch_add_explicit(&l->heartbeat, 1, memory_order_release);
}

/* rt-safe. */
void rmd_loop_cycle(struct rmd_loop *l, int64_t now)
{
	rmd_loop_tick(l, now);
	rmd_loop_publish(l, now);
}

/* rt-safe. */
uint64_t rmd_loop_heartbeat(const struct rmd_loop *l)
{
	return atomic_load_explicit(&l->heartbeat, memory_order_acquire);
}

/* Any thread; non-rt: the average and p99 from the histograms as they are now. */
void rmd_loop_get_stats(const struct rmd_loop *l, struct rmd_loop_stats *out)
{
	struct loop_wake w; /* ~10 KB on the caller's (non-rt) stack */

	pub_read(l, out, &l->pub_stats, sizeof(*out));
	seq_read(&l->stat_seq, &w, &l->wake, sizeof(w));
	if (w.n) {
		out->wake_avg_ns = w.sum / (int64_t)w.n;
		out->wake_p99_ns = p99_of(w.n, w.us, w.hist, NULL, out->wake_max_ns);
	}
}

/* Any thread; non-rt. */
void rmd_loop_get_wake_hist(const struct rmd_loop *l, struct rmd_loop_wake_hist *out)
{
	struct loop_wake w;

	seq_read(&l->stat_seq, &w, &l->wake, sizeof(w));
	out->n = w.n;
	memcpy(out->us, w.us, sizeof(out->us));
	out->over = w.over;
}

/* Any thread; non-rt. */
bool rmd_loop_get_reply_latency(const struct rmd_loop *l, unsigned i, struct rmd_latency *out)
{
	if (i >= l->n_motors)
		return false;
	seq_read(&l->stat_seq, out, &l->mot[i].lat, sizeof(*out));
	return true;
}

/* Any thread; non-rt. */
void rmd_loop_get_snapshot(const struct rmd_loop *l, struct rmd_snapshot *out)
{
	pub_read(l, out, &l->pub_snap, sizeof(*out));
}

/* Any thread; non-rt. */
const struct rmd_motor *rmd_loop_motor(const struct rmd_loop *l, unsigned i)
{
	return i < l->n_motors ? &l->mot[i].m : NULL;
}

/* Any thread; non-rt. */
bool rmd_loop_get_health(const struct rmd_loop *l, struct rmd_health *out)
{
	bool have;

	/* pub_have_health never goes back to false: health read after it is one */
	pub_read(l, &have, &l->pub_have_health, sizeof(have));
	if (have)
		pub_read(l, out, &l->pub_health, sizeof(*out));
	return have;
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
		if (l->mot[i].os_used && l->mot[i].st->lifecycle != RMD_LC_LOST)
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

/* The configured shutdown action; "default" is what rmdd did before it could be set.  rt-safe. */
static enum rmd_shutdown_action shutdown_action(const struct rmd_loop *l)
{
	enum rmd_shutdown_action a = l->cfg->safety.shutdown_action;

	if (a == RMD_SHUTDOWN_DEFAULT)
		a = loop_safe_action(l) == RMD_SAFE_BRAKE ? RMD_SHUTDOWN_BRAKE : RMD_SHUTDOWN_STOP;
	return a;
}

/*
 * One step of stop_motors()'s waits: STOP_STEP_NS asleep, then every bus
 * read (the sim and RS485 queues advance as they are read).  Returns the
 * time after.  Blocking.
 */
static int64_t stop_step(struct rmd_loop *l)
{
	int64_t now;

	loop_sleep(l, STOP_STEP_NS);
	now = loop_now(l);
	for (unsigned b = 0; b < l->n_buses; b++)
		loop_drain(l, b, now);
	return now;
}

/* Every bus's tx list sent, retried for ~10 ms while a bus refuses.  Bounded, blocking. */
static int64_t send_queued(struct rmd_loop *l, int64_t now)
{
	unsigned off[RMD_MAX_BUSES] = { 0 };

	for (unsigned t = 0; t < STOP_TRIES; t++) {
		bool left = false;

		for (unsigned b = 0; b < l->n_buses; b++) {
			struct lbus *lb = &l->bus[b];
			int r;

			if (off[b] >= lb->ntx)
				continue;
			r = rmd_bus_send(lb->bus, lb->tx + off[b], lb->ntx - off[b], now);
			if (r > 0) {
				loop_commit(l, lb, off[b], off[b] + (unsigned)r, now);
				off[b] += (unsigned)r;
			}
			left |= off[b] < lb->ntx;
		}
		if (!left)
			break;
		now = stop_step(l);
	}
	for (unsigned b = 0; b < l->n_buses; b++) {
		struct lbus *lb = &l->bus[b];

		if (off[b] < lb->ntx)
			loop_event(l, now, RMD_EV_SEND_FAILED, 0xFF, b, -ENOBUFS, lb->ntx - off[b]);
		/* what never left: its motor was not reached (the exit line says so) */
		for (unsigned k = off[b]; k < lb->ntx; k++)
			l->mot[lb->meta[k].motor].stop_unreached = true;
		lb->ntx = 0;
	}
	return now;
}

/*
 * Queue on every bus, per motor: the safe action `driven` for a motor that
 * is ENABLED or SAFE (none: -1), else `cmd` (0: nothing); `brake`, or a
 * brake the motor owes (lifecycle.c "Owed frames"), adds 0x78.  rt-safe.
 */
static void queue_stop(struct rmd_loop *l, int driven, uint8_t cmd, bool brake)
{
	for (unsigned b = 0; b < l->n_buses; b++) {
		struct lbus *lb = &l->bus[b];

		lb->ntx = 0;
		for (unsigned k = 0; k < lb->pb->n_motors; k++) {
			struct lmotor *lm = &l->mot[lb->pb->motors[k]];
			bool on = lm->st->lifecycle == RMD_LC_ENABLED ||
				  lm->st->lifecycle == RMD_LC_SAFE;
			struct rmd_frame f[2];
			int n = 0;

			/*
			 * nobody acknowledges (loop_tx.c): a stop reaches no motor now,
			 * and would go out when power returns, after rmdd is gone
			 */
			if (lb->unacked) {
				lm->stop_unreached = true;
				continue;
			}

			if (on && driven >= 0)
				n = rmd_motor_encode_safe(&lm->m, (enum rmd_safe_action)driven, f);
			/* not driven, or the action has no frame for this motor (MIT hold): cmd */
			if (n <= 0)
				n = cmd && rmd_motor_encode_cmd(&lm->m, cmd, &f[0]) == 0 ? 1 : 0;
			for (int j = 0; j < n; j++)
				loop_push_tx(lb, &f[j], loop_idx(l, lm), REQ_STATUS);
			/* V3 §2.27 / V2 §3.51 brake locked */
			if ((brake || (lm->owed.bits & RMD_OWE_BRAKE)) &&
			    rmd_motor_encode_cmd(&lm->m, 0x78, &f[0]) == 0)
				loop_push_tx(lb, &f[0], loop_idx(l, lm), REQ_STATUS);
		}
	}
}

/* Bounded, blocking: sleeps between sends (rmd/loop.h). */
void rmd_loop_stop_motors(struct rmd_loop *l, int64_t now)
{
	enum rmd_shutdown_action a = shutdown_action(l);

	/* the stops below take the buses' frame lists: a retry still pending never left */
	if (l->retry_buses)
		loop_retry_sends(l, now, true);
	for (unsigned i = 0; i < l->n_motors; i++)
		l->mot[i].stop_unreached = false;
	if (a == RMD_SHUTDOWN_DAMP) {
		/* damp the driven motors, one frame each per period, then brake them all */
		int64_t end = now + (int64_t)l->cfg->safety.shutdown_damp_ms * RMD_NS_PER_MS;

		/*
		 * the others get a status read (V3 §2.13) each period too: their
		 * comm-loss protection must not trip during a damp phase longer
		 * than it, and swallow the final stop as its trip's echo (issue 20.5)
		 */
		while (now < end) {
			queue_stop(l, RMD_SAFE_DAMP, 0x9C, false);
			now = send_queued(l, now);
			loop_sleep(l, l->period_ns);
			now = loop_now(l);
			for (unsigned b = 0; b < l->n_buses; b++)
				loop_drain(l, b, now);
		}
		a = RMD_SHUTDOWN_BRAKE;
	}
	/*
	 * brake: the driven motors (and those on their way) are STOPPING, and
	 * READY once they echo the frames below (lifecycle.c "Owed frames").
	 */
	l->stopping = true;
	for (unsigned i = 0; i < l->n_motors && a == RMD_SHUTDOWN_BRAKE; i++) {
		struct lmotor *lm = &l->mot[i];

		if (lm->st->lifecycle == RMD_LC_ENABLED || lm->st->lifecycle == RMD_LC_SAFE)
			loop_enter(l, lm, RMD_LC_STOPPING, now);
	}
	/* V3 §2.15 / V2 §3.34 output off; V3 §2.17 stop and hold */
	queue_stop(l, a == RMD_SHUTDOWN_HOLD ? RMD_SAFE_HOLD : -1, 0x80, a == RMD_SHUTDOWN_BRAKE);
	now = send_queued(l, now);
	/* Wait for the echoes (a reply deadline at most): the frames are out. */
	for (int64_t waited = 0; waited < max_reply_ns(l) && outstanding_any(l);
	     waited += STOP_STEP_NS)
		now = stop_step(l);
	for (unsigned i = 0; i < l->n_motors; i++) {
		struct lmotor *lm = &l->mot[i];

		/* a final frame still unanswered: not known to have reached the motor */
		if (lm->os_used)
			lm->stop_unreached = true;
		/*
		 * stop and hold leave a driven motor SAFE: output off with its
		 * brake open, or held by its drive (docs/lcm.md "Shutdown"),
		 * which READY would deny; nothing more is sent.  The event
		 * names what was sent, not the configured safe action.
		 */
		if (lm->st->lifecycle == RMD_LC_ENABLED) {
			loop_event(l, now, RMD_EV_SAFE_ACTION, i, lm->m.bus,
				   a == RMD_SHUTDOWN_HOLD ? RMD_SAFE_HOLD : RMD_SAFE_STOP, 1);
			loop_enter(l, lm, RMD_LC_SAFE, now);
		}
		/* the stop frames went out above: nothing waits any more (hold must not be undone) */
		loop_frames_drop(lm);
	}
	l->stopping = false;
	/*
	 * A last state and health after the stops (issue 13): the exit
	 * statistics then count every frame sent, the final stops included,
	 * and the states say READY.
	 */
	l->next_health_cycle = l->cycle; /* a health now, whatever its period */
	publish(l, now);
}

/* Non-rt (after rmd_loop_stop_motors()). */
bool rmd_loop_stop_reached(const struct rmd_loop *l, unsigned i)
{
	return i < l->n_motors && !l->mot[i].stop_unreached;
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
	l->published = true; /* no cycle yet whose state is owed */
	l->qos_fd = -1;
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
		lb->state_seen = (uint8_t)rmd_bus_state(lb->bus);
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
		lb = &l->bus[c->bus];
		/* the identifiers its dialect answers on: its replies, its control replies */
		*lbus_slot(lb, lm->m.reply_id) = (uint8_t)(i + 1);
		*lbus_slot(lb, rmd_motor_ctl_reply_id(&lm->m)) = (uint8_t)(i + 1);
		lm->st = &l->snap.m[i];
		rmd_reboot_init(&lm->rb);
		lm->st->lifecycle = RMD_LC_PROBE;
		lm->st->mode = (uint8_t)c->mode;
		lm->st->pos_rad = NAN;
		lm->st->vel_rad_s = NAN;
		lm->st->torque_nm = NAN;
		lm->st->current_a = NAN;
		lm->st->temp_c = NAN;
		lm->st->voltage_v = NAN;
		lm->st->reply_age_cycles = UINT32_MAX;
	}
	{
		uint64_t every = (uint64_t)cfg->lcm.health_period_ms * cfg->loop.rate_hz / 1000u;

		l->health_every = every ? (unsigned)every : 1u;
	}
	l->state_every = cfg->lcm.state_every_n ? cfg->lcm.state_every_n : 1u;
	l->wd = RMD_WD_IDLE;
	l->wd_due_ns = INT64_MAX;
	l->events_fd = -1;
	atomic_init(&l->pub_seq, 0);
	atomic_init(&l->stat_seq, 0);
	atomic_init(&l->heartbeat, 0);
	atomic_init(&l->stop, false);
	l->snap.n = l->n_motors; /* the motors' states are in it already (lmotor.st) */
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
	loop_release_cpus(l);
	free(l);
}
