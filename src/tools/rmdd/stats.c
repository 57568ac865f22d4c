// SPDX-License-Identifier: MIT
/*
 * rmdd's statistics, printed on SIGUSR1 and on exit: the rt loop's wake-up
 * latency (min/avg/p99/max), overruns and plan misses; every bus's load and
 * counters; every motor's state, sampled reply latency and missed replies;
 * the LCM bridge's counters.  The loop measures every figure itself: the
 * wake-up lateness counts every period a stall skipped (cyclictest's
 * meaning), its histogram has cyclictest's 1 us buckets, and the reply
 * latencies are every matched reply's, from the loop's own stamps.  And the one-line summary systemd shows as the
 * service's STATUS=.  Non-rt.
 *
 * The lines are stable and easy to grep (bench/sim-60s.sh reads
 * "overruns N, plan misses N"):
 *
 *   <6>rmdd: statistics (exit) after 60.0 s: 60000 cycles at 1000 Hz (1000.0 Hz measured)
 *   <6>rmdd:   loop: wake-up latency min 3 us, avg 12 us, p99 45 us, max 1203 us; ...
 *   <6>rmdd:   loop: overruns 0, plan misses 0, frames not sent 0
 */
#include <inttypes.h>
#include <stdio.h>
#include <string.h>

#include "rmd/time.h"

#include "rmdd.h"

static double us(int64_t ns)
{
	return (double)ns / (double)RMD_NS_PER_US;
}

static const char *wd_name(unsigned wd)
{
	switch ((enum rmd_watchdog_state)wd) {
	case RMD_WD_IDLE:
		return "idle";
	case RMD_WD_OK:
		return "ok";
	case RMD_WD_TRIPPED:
		return "TIMED OUT (safe action latched)";
	}
	return "?";
}

static void print_buses(const struct rmdd_stats_src *s, const struct rmd_health *h, bool have_h,
			double secs)
{
	const struct rmd_config *cfg = s->cfg;

	for (unsigned b = 0; b < cfg->n_buses; b++) {
		const struct rmd_config_bus *cb = &cfg->buses[b];
		const struct rmd_plan_bus *pb = &s->plan->bus[b];
		double period = (double)s->plan->period_ns;
		char load[96] = "load: no health yet";
		char counters[320] = "";

		if (have_h && b < h->nbuses) {
			const struct rmd_bus_stats *st = &h->bus[b].stats;
			double run = 0;

			if (secs > 0)
				run = (double)rmd_plan_cost_ns(
					      pb, (unsigned)(st->tx_frames + st->rx_frames),
					      (unsigned)st->tx_frames) /
				      (secs * 1e9);
			snprintf(load, sizeof(load), "load %.0f%% (last window), %.0f%% (run)",
				 100.0 * h->bus[b].load, 100.0 * run);
			snprintf(counters, sizeof(counters),
				 "; frames tx %" PRIu64 ", rx %" PRIu64 ", tx busy %" PRIu64
				 " (%" PRIu64 " retried in their cycle), rx errors %" PRIu64
				 ", bus errors %" PRIu64 ", rx stamps batched %" PRIu64
				 ", before their request %" PRIu64 ", %s",
				 st->tx_frames, st->rx_frames, st->tx_busy, st->tx_retried,
				 st->rx_errors, st->bus_errors, st->rx_stamps_shared,
				 st->rx_stamps_early,
				 rmd_bus_state_name((enum rmd_bus_state)h->bus[b].state));
		}
		tool_log_always(
			6,
			"  bus %s (%s, %u bit/s, %u motors): %s; plan %.0f%% worst, %.0f%% avg%s",
			cb->name, rmd_bus_kind_name(cb->kind), pb->bitrate, pb->n_motors, load,
			100.0 * (double)pb->worst_ns / period, 100.0 * pb->avg_ns / period,
			counters);
	}
}

/*
 * Host stalls (issue 32 point 11: a dataset writer flushing, a loaded
 * host): the wake-ups RMD_LOOP_WAKE_US_BUCKETS us or more late, and the
 * longest; each skipped its periods (an overrun), none caught up.
 */
static void print_stalls(const struct rmdd_stats_src *s, const struct rmd_loop_stats *st)
{
	static struct rmd_loop_wake_hist wh; /* main thread only */

	rmd_loop_get_wake_hist(s->loop, &wh);
	tool_log_always(6,
			"  loop: host stalls (wake-ups %u us or more late) %" PRIu64
			", the longest %.1f ms, their periods skipped, none caught up",
			RMD_LOOP_WAKE_US_BUCKETS, wh.over,
			wh.over ? (double)st->wake_max_ns / 1e6 : 0.0);
}

/*
 * The wake-up lateness histogram in cyclictest's buckets (1 us, [k, k+1)
 * us, to 1000 us): the non-empty ones as "us:count", a few lines of them.
 */
static void print_wake_hist(const struct rmdd_stats_src *s)
{
	static struct rmd_loop_wake_hist wh; /* main thread only */
	char line[900];
	size_t used = 0;
	bool first = true;

	rmd_loop_get_wake_hist(s->loop, &wh);
	tool_log_always(
		6,
		"  loop: wake-up lateness histogram, 1 us buckets [k, k+1) us as cyclictest "
		"-h %u: %" PRIu64 " wake-ups, %" PRIu64 " at %u us or later",
		RMD_LOOP_WAKE_US_BUCKETS, wh.n, wh.over, RMD_LOOP_WAKE_US_BUCKETS);
	line[0] = '\0';
	for (unsigned k = 0; k < RMD_LOOP_WAKE_US_BUCKETS; k++) {
		if (!wh.us[k])
			continue;
		if (used > sizeof(line) - 32) {
			tool_log_always(6, "  loop: wake-up us:count %s", line);
			used = 0;
			line[0] = '\0';
		}
		used += (size_t)snprintf(line + used, sizeof(line) - used, "%s%u:%" PRIu64,
					 used ? " " : "", k, wh.us[k]);
		first = false;
	}
	if (!first)
		tool_log_always(6, "  loop: wake-up us:count %s", line);
}

static void print_motors(const struct rmdd_stats_src *s, const struct rmd_snapshot *snap)
{
	static struct rmd_latency lat; /* main thread only */
	const struct rmd_config *cfg = s->cfg;

	for (unsigned i = 0; i < cfg->n_motors; i++) {
		const struct rmd_config_motor *c = &cfg->motors[i];
		const struct rmd_motor_state *ms = &snap->m[i];
		const struct rmd_latency *l = &lat;
		char latency[160] = "reply latency: no samples";
		char age[48] = "no reply yet";

		if (!rmd_loop_get_reply_latency(s->loop, i, &lat))
			lat.n = 0;
		if (l->n)
			snprintf(latency, sizeof(latency),
				 "reply latency min %.0f, avg %.0f, p99 %.0f, max %.0f us (%" PRIu64
				 " samples)",
				 us(l->min_ns), us(l->sum_ns / (int64_t)l->n),
				 us(rmd_latency_p99(l)), us(l->max_ns), l->n);
		if (ms->reply_age_cycles != UINT32_MAX)
			snprintf(age, sizeof(age), "last reply %u cycles ago",
				 (unsigned)ms->reply_age_cycles);
		tool_log_always(6, "  motor %s (%s id %u, %s): %s; %s; missed %" PRIu64 "; %s",
				c->name, c->bus < cfg->n_buses ? cfg->buses[c->bus].name : "?",
				c->id, rmd_proto_key(rmdd_motor_dialect(cfg, i)),
				rmdd_lifecycle_name(ms->lifecycle), latency, ms->missed_replies,
				age);
	}
}

void rmdd_stats_print(const struct rmdd_stats_src *s, const char *why)
{
	static struct rmd_snapshot snap; /* main thread only */
	static struct rmd_health h;
	struct rmd_loop_stats st;
	struct rmd_loop_counters c;
	bool have_h;
	double secs = (double)(rmd_now_ns() - s->start_ns) / 1e9;

	rmd_loop_get_stats(s->loop, &st);
	rmd_loop_get_counters(s->loop, &c);
	rmd_loop_get_snapshot(s->loop, &snap);
	have_h = rmd_loop_get_health(s->loop, &h);
	for (unsigned i = 0; have_h && i < h.nmotors && i < RMD_MAX_MOTORS; i++)
		rmdd_dialect_found(i, (enum rmd_proto)h.proto[i]);
	flockfile(stderr);
	tool_log_always(
		6, "statistics (%s) after %.1f s: %" PRIu64 " cycles at %u Hz (%.1f Hz measured)",
		why, secs, st.cycles, s->plan->rate_hz, secs > 0 ? (double)st.cycles / secs : 0.0);
	tool_log_always(
		6,
		"  loop: wake-up latency min %.0f us, avg %.0f us, p99 %.0f us, max %.0f us; "
		"longest cycle %.0f us",
		us(st.wake_min_ns), us(st.wake_avg_ns), us(st.wake_p99_ns), us(st.wake_max_ns),
		us(st.cycle_max_ns));
	tool_log_always(6,
			"  loop: overruns %" PRIu64 ", plan misses %" PRIu64
			", frames not sent %" PRIu64,
			st.overruns, st.plan_misses, c.frames_not_sent);
	print_stalls(s, &st);
	print_wake_hist(s);
	tool_log_always(6,
			"  replies: matched %" PRIu64 ", missed %" PRIu64 ", echoed %" PRIu64
			", unsolicited %" PRIu64 ", unexpected %" PRIu64 ", late %" PRIu64
			" (the latest %.1f ms), undecodable %" PRIu64,
			c.replies, c.missed, c.echoes, c.unsolicited, c.unexpected, c.late,
			(double)c.late_max_ns / 1e6, c.bad_replies);
	tool_log_always(6,
			"  setpoints: commands %" PRIu64 ", clamped %" PRIu64
			", non-finite %" PRIu64 ", unsupported %" PRIu64 ", safe actions %" PRIu64
			", output-off/brake resends %" PRIu64 "; controller %s",
			c.commands, c.clamped, c.nonfinite, c.unsupported, c.safe_actions,
			c.owed_resends, have_h ? wd_name(h.watchdog) : "idle");
	print_buses(s, &h, have_h, secs);
	print_motors(s, &snap);
	if (s->bridge) {
		struct rmd_bridge_stats bs;

		rmd_bridge_get_stats(s->bridge, &bs);
		tool_log_always(6,
				"  lcm: commands accepted %" PRIu64 ", rejected %" PRIu64
				", clamped %" PRIu64 "; published state %" PRIu64
				", health %" PRIu64 ", config %" PRIu64 "; publish errors %" PRIu64
				", receive errors %" PRIu64,
				bs.accepted, bs.rejected, bs.clamped, bs.states_published,
				bs.health_published, bs.configs_published, bs.publish_errors,
				bs.lcm_errors);
		if (bs.foreign)
			tool_log_always(6,
					"  lcm: another rmdd on the prefix: %" PRIu64
					" of its health_t and config_t heard (docs/lcm.md, \"One "
					"daemon per prefix\")",
					bs.foreign);
	}
	if (rmd_ring_dropped(s->events))
		tool_log_always(6, "  events lost (ring full): %" PRIu64,
				rmd_ring_dropped(s->events));
	funlockfile(stderr);
}

void rmdd_stats_status(const struct rmdd_stats_src *s, double hz, bool stalled, char *buf,
		       size_t len)
{
	static struct rmd_snapshot snap; /* main thread only */
	static struct rmd_health h;
	unsigned count[RMD_LC_COUNT] = { 0 };
	struct rmd_loop_stats st;
	size_t n;

	rmd_loop_get_stats(s->loop, &st);
	rmd_loop_get_snapshot(s->loop, &snap);
	for (unsigned i = 0; i < snap.n && i < RMD_MAX_MOTORS; i++)
		if (snap.m[i].lifecycle < RMD_LC_COUNT)
			count[snap.m[i].lifecycle]++;
	n = (size_t)snprintf(buf, len, "%u motors: enabled %u, ready %u", s->cfg->n_motors,
			     count[RMD_LC_ENABLED], count[RMD_LC_READY]);
	for (unsigned lc = RMD_LC_FAULT; lc < RMD_LC_COUNT; lc++)
		if (count[lc] && n < len)
			n += (size_t)snprintf(buf + n, len - n, ", %s %u", rmdd_lifecycle_name(lc),
					      count[lc]);
	if (count[RMD_LC_PROBE] && n < len)
		n += (size_t)snprintf(buf + n, len - n, ", probe %u", count[RMD_LC_PROBE]);
	if (n < len)
		n += (size_t)snprintf(
			buf + n, len - n,
			"; loop %.0f Hz, p99 %.0f us, %" PRIu64 " overruns; controller %s; %s", hz,
			us(st.wake_p99_ns), st.overruns,
			rmd_loop_get_health(s->loop, &h) ? wd_name(h.watchdog) : "idle",
			stalled ? "LOOP STALLED" : "loop ok");
}
