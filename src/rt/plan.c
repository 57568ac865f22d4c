// SPDX-License-Identifier: MIT
/*
 * Per-bus cycle plans and their worst-case wire time (rmd/plan.h).
 *
 * Building a bus's plan (non-rt):
 * 1. plan_control(): decide the V2 0x280 batch, the control pattern's
 *    length hc (lcm of the rate divisors and 0x92 read divisors), and a
 *    phase per unit (a motor, the batch, or a motor's 0x92 reads), greedily: units commanded every cycle first,
 *    then the costlier ones, each in the phase that keeps the busiest
 *    cycle lowest.  The busiest cycle must fit in the cycle.
 * 2. plan_polls(): the status polls' round robin, how many go in one poll
 *    cycle, and where in the control pattern each poll goes (extra, or in
 *    place of a control frame).
 * All frames are 8-byte frames, so a cycle's cost is a count of frames
 * (requests + replies) and of requests: rmd_plan_cost_ns().
 *
 * rmd_plan_cycle() (rt-safe) reads the plan: the control pattern at
 * n % hc, and the polls of round-robin entries poll_burst * p ..
 * poll_burst * (p + 1) - 1, p = (n / poll_every) % (n_polls / poll_burst),
 * whose cycle is n % poll_every.
 */
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/bus_open.h"
#include "rmd/can_timing.h"
#include "rmd/dialect.h"
#include "rmd/motor.h"
#include "rmd/plan.h"

/* Frames of a request and its reply. */
#define EXCHANGE_FRAMES 2u

/* The overload message of a bus with 0x92 reads (rmd/plan.h). */
#define FINE_INCLUDED " (0x92 position reads included)"
#define FINE_LOWER ", or a lower feedback.rate_hz"

/* Error lines, joined with '\n'. */
struct errbuf {
	char *buf;
	size_t len;
	size_t used;
};

__attribute__((format(printf, 2, 3))) static void add_err(struct errbuf *e, const char *fmt, ...)
{
	va_list ap;
	int n;

	if (!e->buf || e->len == 0 || e->used + 1 >= e->len)
		return;
	if (e->used) {
		e->buf[e->used++] = '\n';
		e->buf[e->used] = '\0';
	}
	va_start(ap, fmt);
	n = vsnprintf(e->buf + e->used, e->len - e->used, fmt, ap);
	va_end(ap);
	if (n > 0)
		e->used += (size_t)n;
	if (e->used >= e->len)
		e->used = e->len - 1;
}

static uint64_t gcd_u64(uint64_t a, uint64_t b)
{
	while (b) {
		uint64_t t = a % b;

		a = b;
		b = t;
	}
	return a;
}

static uint64_t lcm_u64(uint64_t a, uint64_t b)
{
	return a / gcd_u64(a, b) * b;
}

/* "1350", or "1351.4" (rounded up to 0.1 us) when ns is not whole microseconds. */
static const char *fmt_us(char *buf, size_t len, int64_t ns)
{
	if (ns % 1000 == 0)
		snprintf(buf, len, "%lld", (long long)(ns / 1000));
	else
		snprintf(buf, len, "%.1f", (double)((ns + 99) / 100) / 10.0);
	return buf;
}

int64_t rmd_plan_cost_ns(const struct rmd_plan_bus *b, unsigned frames, unsigned requests)
{
	return rmd_can_wire_ns(frames * b->frame_bits, b->bitrate) +
	       (int64_t)requests * b->turnaround_ns;
}

/* A motor, the 0x280 batch, or a motor's 0x92 reads: sent together, in one phase. */
struct unit {
	uint32_t mask; /* local bits */
	unsigned divisor;
	unsigned frames; /* per command: request + replies */
	unsigned order;	 /* file order of its first motor */
	bool fine;	 /* 0x92 reads, not setpoints */
};

/*
 * Setpoints before 0x92 reads (the reads fill the cycles the setpoints
 * leave least busy); then units every cycle first, then costlier, then
 * shorter divisors, then file order.
 */
static bool unit_before(const struct unit *a, const struct unit *b)
{
	if (a->fine != b->fine)
		return !a->fine;
	if ((a->divisor == 1) != (b->divisor == 1))
		return a->divisor == 1;
	if (a->frames != b->frames)
		return a->frames > b->frames;
	if (a->divisor != b->divisor)
		return a->divisor < b->divisor;
	return a->order < b->order;
}

/*
 * The 0x280 batch of the first n motors of bus pb: every V2 motor with
 * ID 1..4, when there are two or more, all in torque mode with one
 * divisor, and no V3/MIT motor on the bus (rmd/plan.h).
 */
static void plan_batch(const struct rmd_config *cfg, struct rmd_plan_bus *pb, unsigned n)
{
	uint32_t cand = 0;
	unsigned ncand = 0, divisor = 0;
	bool torque = true, same_div = true, others = false;

	for (unsigned l = 0; l < n; l++) {
		const struct rmd_config_motor *m = &cfg->motors[pb->motors[l]];

		if (!rmd_dialect_has(rmd_dialect(m->proto), RMD_DIALECT_BATCH_280)) {
			others = true;
			continue;
		}
		if (m->id < 1 || m->id > 4)
			continue;
		cand |= 1u << l;
		if (ncand++ == 0)
			divisor = m->rate_divisor;
		if (m->rate_divisor != divisor)
			same_div = false;
		if (m->mode != RMD_MODE_TORQUE)
			torque = false;
	}
	pb->batched = 0;
	if (ncand < 2)
		pb->batch = RMD_BATCH_NONE;
	else if (!torque)
		pb->batch = RMD_BATCH_MODES;
	else if (!same_div)
		pb->batch = RMD_BATCH_DIVISORS;
	else if (others)
		pb->batch = RMD_BATCH_V3_ON_BUS;
	else
		pb->batch = RMD_BATCH_ON;
	if (pb->batch == RMD_BATCH_ON)
		pb->batched = cand;
}

/*
 * Control pattern of the first n motors of bus b.  Returns 0, or -E2BIG
 * when their divisors' lcm exceeds RMD_PLAN_MAX_HC (*hc_out holds it,
 * saturated).
 */
static int plan_control(const struct rmd_config *cfg, struct rmd_plan *plan, unsigned b, unsigned n,
			uint64_t *hc_out)
{
	struct rmd_plan_bus *pb = &plan->bus[b];
	struct unit units[2 * RMD_MAX_MOTORS];
	unsigned nu = 0;
	uint64_t hc = 1;

	for (unsigned l = 0; l < n; l++) {
		unsigned fd = plan->motor[pb->motors[l]].fine_divisor;

		hc = lcm_u64(hc, cfg->motors[pb->motors[l]].rate_divisor);
		if (fd)
			hc = lcm_u64(hc, fd);
		if (hc > 1000000)
			hc = 1000000; /* saturate: only the message uses it */
	}
	*hc_out = hc;
	if (hc > RMD_PLAN_MAX_HC)
		return -E2BIG;
	pb->hc = (unsigned)hc;
	memset(pb->due, 0, sizeof(pb->due));
	memset(pb->frames, 0, sizeof(pb->frames));
	memset(pb->requests, 0, sizeof(pb->requests));
	memset(pb->fine, 0, sizeof(pb->fine));
	pb->n_fine = 0;
	plan_batch(cfg, pb, n);

	if (pb->batched) {
		unsigned first = (unsigned)__builtin_ctz(pb->batched);

		units[nu++] = (struct unit){
			.mask = pb->batched,
			.divisor = cfg->motors[pb->motors[first]].rate_divisor,
			.frames = 1 + (unsigned)__builtin_popcount(pb->batched),
			.order = first,
		};
	}
	for (unsigned l = 0; l < n; l++) {
		if (pb->batched & (1u << l))
			continue;
		units[nu++] = (struct unit){
			.mask = 1u << l,
			.divisor = cfg->motors[pb->motors[l]].rate_divisor,
			.frames = EXCHANGE_FRAMES,
			.order = l,
		};
	}
	for (unsigned l = 0; l < n; l++) {
		unsigned fd = plan->motor[pb->motors[l]].fine_divisor;

		if (!fd)
			continue;
		units[nu++] = (struct unit){
			.mask = 1u << l,
			.divisor = fd,
			.frames = EXCHANGE_FRAMES,
			.order = l,
			.fine = true,
		};
		pb->n_fine++;
	}
	/* insertion sort: at most 64 units */
	for (unsigned i = 1; i < nu; i++) {
		struct unit u = units[i];
		unsigned j = i;

		for (; j > 0 && unit_before(&u, &units[j - 1]); j--)
			units[j] = units[j - 1];
		units[j] = u;
	}
	for (unsigned i = 0; i < nu; i++) {
		const struct unit *u = &units[i];
		unsigned best = 0;
		int64_t best_max = INT64_MAX, best_sum = INT64_MAX;

		for (unsigned ph = 0; ph < u->divisor; ph++) {
			int64_t mx = 0, sum = 0;

			for (unsigned c = ph; c < pb->hc; c += u->divisor) {
				int64_t cost = rmd_plan_cost_ns(pb, pb->frames[c] + u->frames,
								pb->requests[c] + 1u);

				mx = cost > mx ? cost : mx;
				sum += cost;
			}
			if (mx < best_max || (mx == best_max && sum < best_sum)) {
				best = ph;
				best_max = mx;
				best_sum = sum;
			}
		}
		for (unsigned c = best; c < pb->hc; c += u->divisor) {
			pb->frames[c] = (uint16_t)(pb->frames[c] + u->frames);
			pb->requests[c]++;
			if (u->fine)
				pb->fine[c] |= u->mask;
			else
				pb->due[c] |= u->mask;
		}
		for (unsigned l = 0; l < n; l++) {
			if (u->fine && (u->mask & (1u << l))) {
				plan->motor[pb->motors[l]].fine_phase = best;
			} else if (u->mask & (1u << l)) {
				plan->motor[pb->motors[l]].phase = best;
				plan->motor[pb->motors[l]].batched = (pb->batched >> l) & 1u;
			}
		}
	}
	pb->control_ns = 0;
	pb->max_frames = 0;
	pb->max_requests = 0;
	for (unsigned c = 0; c < pb->hc; c++) {
		int64_t cost = rmd_plan_cost_ns(pb, pb->frames[c], pb->requests[c]);

		if (cost > pb->control_ns)
			pb->control_ns = cost;
		if (pb->frames[c] > pb->max_frames)
			pb->max_frames = pb->frames[c];
		if (pb->requests[c] > pb->max_requests)
			pb->max_requests = pb->requests[c];
	}
	return 0;
}

/* Longest spacing of status polls, in cycles (24 days at 1 kHz). */
#define POLL_EVERY_MAX ((double)(UINT32_MAX / 2))

/*
 * The spacing of poll cycles of k entries each: the largest multiple of hc
 * that still polls every motor at least every 1/status_poll_hz s, a motor
 * whose entries are at most gap[l] apart waiting at most ceil(gap[l] / k)
 * poll cycles; 0 when there is none.  Non-rt.
 */
static unsigned poll_spacing(const struct rmd_config *cfg, const struct rmd_plan_bus *pb,
			     unsigned rate, const unsigned gap[], unsigned k)
{
	double s_max = INFINITY;

	for (unsigned l = 0; l < pb->n_motors; l++) {
		double f = cfg->motors[pb->motors[l]].status_poll_hz, s;

		if (!gap[l])
			continue;
		s = floor((double)rate / (f * ((gap[l] + k - 1u) / k)) * (1.0 + 1e-12));
		if (s < s_max)
			s_max = s;
	}
	/*
	 * A rate near 0 (the loader refuses below RMD_CONFIG_MIN_STATUS_POLL_HZ,
	 * other callers may not) gives an s_max no unsigned holds: polling more
	 * often than asked is allowed, converting it would be undefined.
	 */
	if (!(s_max <= POLL_EVERY_MAX))
		s_max = POLL_EVERY_MAX;
	return (unsigned)(s_max / pb->hc) * pb->hc;
}

/*
 * The polls of entry i's poll cycle (its poll_burst entries) before it
 * that go in cycle c as extra requests.  Non-rt.
 */
static unsigned group_extras(const struct rmd_plan_bus *pb, unsigned i, unsigned c)
{
	unsigned cnt = 0;

	for (unsigned j = i - i % pb->poll_burst; j < i; j++)
		if (!pb->polls[j].replaces && pb->polls[j].cycle == c)
			cnt++;
	return cnt;
}

/*
 * The status polls of bus b: round-robin weights from status_poll_hz, the
 * polls per poll cycle poll_burst (as few as the rates need), the spacing
 * poll_every (poll_spacing()), and each entry's cycle.  Returns 0 or
 * -ENOSPC.
 */
static int plan_polls(const struct rmd_config *cfg, struct rmd_plan *plan, unsigned b,
		      struct errbuf *e)
{
	struct rmd_plan_bus *pb = &plan->bus[b];
	const int64_t period = plan->period_ns;
	const unsigned rate = plan->rate_hz;
	uint64_t w[RMD_MAX_MOTORS] = { 0 }, g = 0, total = 0;
	int64_t cur[RMD_MAX_MOTORS] = { 0 };
	uint8_t seq[RMD_PLAN_MAX_POLLS];
	unsigned gap[RMD_MAX_MOTORS] = { 0 };
	double hz_sum = 0.0;
	unsigned every = 0, burst, burst_max = RMD_MAX_MOTORS, n_entries;
	char a[32], c_us[32];

	pb->poll_every = 0;
	pb->poll_burst = 0;
	pb->n_polls = 0;
	for (unsigned l = 0; l < pb->n_motors; l++) {
		double f = cfg->motors[pb->motors[l]].status_poll_hz;

		if (!(f > 0.0))
			continue;
		w[l] = (uint64_t)llround(f * 1000.0);
		if (w[l] == 0)
			w[l] = 1;
		g = gcd_u64(g, w[l]);
		hz_sum += f;
	}
	if (g == 0)
		return 0;
	for (unsigned l = 0; l < pb->n_motors; l++)
		total += (w[l] /= g);
	if (total > RMD_PLAN_MAX_POLLS) {
		/* Too fine a ratio: round each share up (every motor keeps >= its rate). */
		const uint64_t target = RMD_PLAN_MAX_POLLS - RMD_MAX_MOTORS;
		uint64_t t2 = 0;

		g = 0;
		for (unsigned l = 0; l < pb->n_motors; l++) {
			if (w[l])
				w[l] = (w[l] * target + total - 1) / total;
			g = gcd_u64(g, w[l]);
		}
		for (unsigned l = 0; l < pb->n_motors; l++)
			t2 += (w[l] /= g);
		total = t2;
	}
	/* smooth weighted round robin: each motor's entries evenly spread */
	for (unsigned k = 0; k < total; k++) {
		unsigned pick = 0;
		int64_t best = INT64_MIN;

		for (unsigned l = 0; l < pb->n_motors; l++) {
			if (!w[l])
				continue;
			cur[l] += (int64_t)w[l];
			if (cur[l] > best) {
				best = cur[l];
				pick = l;
			}
		}
		cur[pick] -= (int64_t)total;
		seq[k] = (uint8_t)pick;
	}
	/*
	 * gap[l]: the longest, step: the shortest distance between two of
	 * motor l's entries (round the wheel).  A poll cycle takes k entries
	 * of the wheel in turn, so k must not exceed any motor's step: the k
	 * polls of a poll cycle go to k different motors.
	 */
	for (unsigned l = 0; l < pb->n_motors; l++) {
		unsigned first = 0, last = 0, step = (unsigned)total;
		bool seen = false;

		if (!w[l])
			continue;
		for (unsigned k = 0; k < total; k++) {
			if (seq[k] != l)
				continue;
			if (!seen)
				first = k;
			else if (k - last > gap[l])
				gap[l] = k - last;
			if (seen && k - last < step)
				step = k - last;
			last = k;
			seen = true;
		}
		if (first + (unsigned)total - last > gap[l])
			gap[l] = first + (unsigned)total - last;
		if (first + (unsigned)total - last < step)
			step = first + (unsigned)total - last;
		if (step < burst_max)
			burst_max = step;
	}
	/* as few polls per poll cycle as the rates need: k = 1 is the plan of one poll a cycle */
	for (burst = 1; burst <= burst_max; burst++) {
		if (lcm_u64(total, burst) > RMD_PLAN_MAX_POLLS)
			continue;
		every = poll_spacing(cfg, pb, rate, gap, burst);
		if (every)
			break;
	}
	if (every == 0) {
		if (burst_max == 1)
			add_err(e,
				"%s: status polls at %g Hz in all do not fit in one poll every %u "
				"cycle%s (%g a second at %u Hz): lower status_poll_hz",
				cfg->buses[b].name, hz_sum, pb->hc, pb->hc == 1 ? "" : "s",
				(double)rate / pb->hc, rate);
		else
			add_err(e,
				"%s: status polls at %g Hz in all do not fit in %u polls of different "
				"motors every %u cycle%s (%g a second at %u Hz): lower "
				"status_poll_hz",
				cfg->buses[b].name, hz_sum, burst_max, pb->hc,
				pb->hc == 1 ? "" : "s", (double)burst_max * rate / pb->hc, rate);
		return -ENOSPC;
	}
	/* the wheel repeated until its length is a whole number of poll cycles */
	n_entries = (unsigned)lcm_u64(total, burst);
	for (unsigned k = (unsigned)total; k < n_entries; k++)
		seq[k] = seq[k - total];
	pb->poll_every = every;
	pb->poll_burst = burst;
	pb->n_polls = n_entries;
	/* where each entry goes */
	for (unsigned k = 0; k < n_entries; k++) {
		struct rmd_plan_poll *p = &pb->polls[k];
		struct rmd_plan_motor *pm;
		int64_t best_cost = INT64_MAX;
		int cyc = -1;

		p->motor = pb->motors[seq[k]];
		pm = &plan->motor[p->motor];
		/* extra, in the least busy cycle (its poll cycle's polls included), if it fits */
		for (unsigned c = 0; c < pb->hc; c++) {
			unsigned x = group_extras(pb, k, c) + 1u;
			int64_t cost = rmd_plan_cost_ns(pb, pb->frames[c] + x * EXCHANGE_FRAMES,
							pb->requests[c] + x);

			if (cost < best_cost) {
				best_cost = cost;
				cyc = (int)c;
			}
		}
		if (best_cost <= period) {
			p->cycle = (uint8_t)cyc;
			p->replaces = false;
		} else if (!pm->batched) {
			/* in place of its control frame: the same two frames */
			p->cycle = (uint8_t)(pm->phase % pb->hc);
			p->replaces = true;
			pm->replacing++;
		} else {
			add_err(e,
				"%s: no room for the status polls of motor %s, which is in the "
				"0x280 frame: the least busy cycle with a poll needs %s µs of %s "
				"µs; set its status_poll_hz to 0",
				cfg->buses[b].name, cfg->motors[p->motor].name,
				fmt_us(a, sizeof(a), best_cost),
				fmt_us(c_us, sizeof(c_us), period));
			pb->n_polls = k - k % burst;
			return -ENOSPC;
		}
		pm->polls++;
	}
	for (unsigned l = 0; l < pb->n_motors; l++) {
		struct rmd_plan_motor *pm = &plan->motor[pb->motors[l]];

		pm->poll_hz = (double)pm->polls * rate * burst / ((double)n_entries * every);
	}
	return 0;
}

/* The busiest cycle, the TX burst and the averages, polls included. */
static void plan_totals(struct rmd_plan_bus *pb)
{
	int64_t sum_ns = 0;
	unsigned sum_frames = 0;

	pb->worst_ns = pb->control_ns;
	for (unsigned c = 0; c < pb->hc; c++) {
		sum_ns += rmd_plan_cost_ns(pb, pb->frames[c], pb->requests[c]);
		sum_frames += pb->frames[c];
	}
	pb->avg_frames = (double)sum_frames / pb->hc;
	pb->avg_ns = (double)sum_ns / pb->hc;
	pb->hyperperiod =
		pb->poll_every ? (uint64_t)pb->poll_every * (pb->n_polls / pb->poll_burst) : pb->hc;
	for (unsigned k = 0; k < pb->n_polls; k++) {
		const struct rmd_plan_poll *p = &pb->polls[k];
		unsigned f = pb->frames[p->cycle], r = pb->requests[p->cycle], x;
		int64_t base, with;

		if (p->replaces)
			continue;
		/* this poll is the x-th extra one in its cycle */
		x = group_extras(pb, k, p->cycle) + 1u;
		f += (x - 1u) * EXCHANGE_FRAMES;
		r += x - 1u;
		base = rmd_plan_cost_ns(pb, f, r);
		with = rmd_plan_cost_ns(pb, f + EXCHANGE_FRAMES, r + 1u);
		if (with > pb->worst_ns)
			pb->worst_ns = with;
		if (f + EXCHANGE_FRAMES > pb->max_frames)
			pb->max_frames = f + EXCHANGE_FRAMES;
		if (r + 1u > pb->max_requests)
			pb->max_requests = r + 1u;
		pb->avg_frames += (double)EXCHANGE_FRAMES / (double)pb->hyperperiod;
		pb->avg_ns += (double)(with - base) / (double)pb->hyperperiod;
	}
}

/*
 * The batched motors a cycle of bus pb's 0x280 frame can give their own
 * frames instead (struct rmd_plan_bus.batch_own): the most whose frames,
 * beyond the 1 + n the frame and its replies take, still fit in the
 * busiest cycle; never fewer than those 1 + n frames hold, which fit
 * already.  The budget grows by the extra frames.  Non-rt.
 */
static void plan_batch_own(struct rmd_plan_bus *pb, int64_t period_ns)
{
	unsigned n = (unsigned)__builtin_popcount(pb->batched), budget = 1u + n;

	pb->batch_own = 0;
	for (unsigned k = n; k > 0; k--) {
		unsigned frames = EXCHANGE_FRAMES * k;
		int64_t extra = frames > budget ? rmd_plan_cost_ns(pb, frames - budget, k - 1u) : 0;

		if (frames > budget && pb->worst_ns + extra > period_ns)
			continue;
		pb->batch_own = k;
		pb->worst_ns += extra;
		if (frames > budget)
			pb->max_frames += frames - budget;
		pb->max_requests += k - 1u;
		return;
	}
}

/* "can0: 5 motors at 1000 Hz need 1350 µs ...: use ≤ 3 motors, or a rate ≤ 740 Hz" */
static void report_overload(const struct rmd_config *cfg, struct rmd_plan *plan, unsigned b,
			    struct errbuf *e)
{
	struct rmd_plan_bus *pb = &plan->bus[b];
	const int64_t need = pb->control_ns;
	const unsigned count = pb->n_motors;
	unsigned fit = 0;
	uint64_t hc;
	char n_us[32], c_us[32];
	long long rate_max = 1000000000LL / need;

	for (unsigned n = count - 1; n > 0; n--) {
		if (plan_control(cfg, plan, b, n, &hc) == 0 && pb->control_ns <= plan->period_ns) {
			fit = n;
			break;
		}
	}
	plan_control(cfg, plan, b, count, &hc); /* restore the full pattern */
	fmt_us(n_us, sizeof(n_us), need);
	fmt_us(c_us, sizeof(c_us), plan->period_ns);
	if (fit > 0)
		add_err(e,
			"%s: %u motor%s at %u Hz need%s %s µs per cycle worst case%s, the cycle is "
			"%s µs: use ≤ %u motor%s, or a rate ≤ %lld Hz%s",
			cfg->buses[b].name, count, count == 1 ? "" : "s", plan->rate_hz,
			count == 1 ? "s" : "", n_us, pb->n_fine ? FINE_INCLUDED : "", c_us, fit,
			fit == 1 ? "" : "s", rate_max, pb->n_fine ? FINE_LOWER : "");
	else
		add_err(e,
			"%s: %u motor%s at %u Hz need%s %s µs per cycle worst case%s, the cycle is "
			"%s µs: use a rate ≤ %lld Hz%s",
			cfg->buses[b].name, count, count == 1 ? "" : "s", plan->rate_hz,
			count == 1 ? "s" : "", n_us, pb->n_fine ? FINE_INCLUDED : "", c_us,
			rate_max, pb->n_fine ? FINE_LOWER : "");
}

/*
 * Cycles between a motor's 0x92 reads: the largest that keeps at least
 * feedback.rate_hz (default: the command rate); 0: no fine feedback.
 */
static unsigned fine_divisor(const struct rmd_config *cfg, const struct rmd_config_motor *m)
{
	double d;

	if (m->feedback.position != RMD_FEEDBACK_MULTI_TURN)
		return 0;
	if (!(m->feedback.rate_hz > 0.0))
		return m->rate_divisor;
	d = floor((double)cfg->loop.rate_hz / m->feedback.rate_hz * (1.0 + 1e-12));
	return d < 1.0 ? 1u : d > RMD_CONFIG_DIVISOR_MAX ? RMD_CONFIG_DIVISOR_MAX : (unsigned)d;
}

int rmd_plan_build(const struct rmd_config *cfg, struct rmd_plan *plan, char *err, size_t errlen)
{
	struct errbuf e = { .buf = err, .len = errlen };
	int ret = 0;

	if (err && errlen)
		err[0] = '\0';
	memset(plan, 0, sizeof(*plan));
	if (cfg->n_buses > RMD_MAX_BUSES || cfg->n_motors > RMD_MAX_MOTORS ||
	    cfg->loop.rate_hz < 1 || cfg->loop.rate_hz > RMD_CONFIG_RATE_MAX_HZ) {
		add_err(&e, "plan: the configuration was not validated");
		return -EINVAL;
	}
	plan->rate_hz = cfg->loop.rate_hz;
	plan->period_ns = 1000000000LL / cfg->loop.rate_hz;
	plan->n_buses = cfg->n_buses;
	plan->n_motors = cfg->n_motors;
	for (unsigned b = 0; b < cfg->n_buses; b++) {
		const struct rmd_config_bus *cb = &cfg->buses[b];
		struct rmd_plan_bus *pb = &plan->bus[b];

		struct rmd_bus_timing t = { 0 };

		pb->kind = cb->kind;
		pb->hc = 1;
		/* the transport's rule: CAN pipelines, RS485 pays a turnaround per request */
		rmd_bus_config_timing(cb, &t);
		pb->bitrate = t.bitrate;
		pb->frame_bits = t.frame_bits;
		pb->turnaround_ns = t.turnaround_ns;
		if (pb->bitrate == 0) {
			add_err(&e, "%s: bitrate 0", cb->name);
			return -EINVAL;
		}
	}
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		const struct rmd_config_motor *m = &cfg->motors[i];
		struct rmd_plan_bus *pb;

		if (m->bus >= cfg->n_buses || m->rate_divisor < 1 || m->id < 1 ||
		    m->id > RMD_MAX_MOTORS) {
			add_err(&e, "plan: motor %s: the configuration was not validated", m->name);
			return -EINVAL;
		}
		pb = &plan->bus[m->bus];
		plan->motor[i] = (struct rmd_plan_motor){
			.bus = (uint8_t)m->bus,
			.local = (uint8_t)pb->n_motors,
			.id = m->id,
			.proto = m->proto,
			.divisor = m->rate_divisor,
			.fine_divisor = fine_divisor(cfg, m),
		};
		plan->motor[i].pos_hz = (double)plan->rate_hz /
					(plan->motor[i].fine_divisor ? plan->motor[i].fine_divisor :
								       m->rate_divisor);
		pb->req_id[pb->n_motors] = (uint16_t)(rmd_dialect(m->proto)->req_base + m->id);
		pb->ctl_id[pb->n_motors] = (uint16_t)(rmd_dialect(m->proto)->ctl_req_base + m->id);
		pb->motors[pb->n_motors++] = (uint8_t)i;
	}
	plan->feasible = true;
	for (unsigned b = 0; b < cfg->n_buses; b++) {
		struct rmd_plan_bus *pb = &plan->bus[b];
		uint64_t hc;

		pb->feasible = false;
		if (plan_control(cfg, plan, b, pb->n_motors, &hc)) {
			char divs[RMD_MAX_MOTORS * 6] = "";
			size_t k = 0;

			for (unsigned l = 0; l < pb->n_motors && k < sizeof(divs); l++)
				k += (size_t)snprintf(divs + k, sizeof(divs) - k, "%s%u",
						      l ? ", " : "",
						      cfg->motors[pb->motors[l]].rate_divisor);
			add_err(&e,
				"%s: rate divisors %s repeat every %llu%s cycles, more than %d: use "
				"divisors that divide one another (1, 2, 4, 8, ...)",
				cfg->buses[b].name, divs, (unsigned long long)hc,
				hc >= 1000000 ? "+" : "", RMD_PLAN_MAX_HC);
			pb->hc = 1;
			memset(pb->due, 0, sizeof(pb->due));
			plan->feasible = false;
			ret = -EINVAL;
			continue;
		}
		if (pb->control_ns > plan->period_ns) {
			report_overload(cfg, plan, b, &e);
			plan_totals(pb);
			plan->feasible = false;
			if (!ret)
				ret = -ENOSPC;
			continue;
		}
		if (plan_polls(cfg, plan, b, &e)) {
			plan_totals(pb);
			plan->feasible = false;
			if (!ret)
				ret = -ENOSPC;
			continue;
		}
		plan_totals(pb);
		plan_batch_own(pb, plan->period_ns);
		pb->feasible = true;
	}
	return ret;
}

bool rmd_plan_due(const struct rmd_plan *plan, unsigned bus, uint64_t n, struct rmd_plan_due *d)
{
	const struct rmd_plan_bus *pb;
	uint32_t due;

	if (bus >= plan->n_buses)
		return false;
	pb = &plan->bus[bus];
	if (pb->n_motors == 0 || pb->hc == 0)
		return false;
	due = pb->due[n % pb->hc];
	d->polls = NULL;
	d->n_polls = 0;
	d->at = 0;
	if (pb->poll_every && pb->n_polls) {
		/* the poll cycle's entries; those for this cycle, in place of a setpoint or not */
		d->n_polls = pb->poll_burst;
		d->polls =
			&pb->polls[(n / pb->poll_every) % (pb->n_polls / d->n_polls) * d->n_polls];
		d->at = (unsigned)(n % pb->poll_every);
		for (unsigned j = 0; j < d->n_polls; j++)
			if (d->polls[j].cycle == d->at && d->polls[j].replaces)
				due &= ~(1u << plan->motor[d->polls[j].motor].local);
	}
	d->batch = (due & pb->batched) != 0;
	d->control = due & ~pb->batched;
	d->fine = pb->fine[n % pb->hc];
	return true;
}

/*
 * A slot of kind for each motor of pb in mask, one reply each, to its
 * identifier in ids: the set bits in order, the motors in file order as
 * the masks' bits are.  Appended at out[cnt]; returns the new count.
 */
static unsigned add_slots(struct rmd_plan_slot *out, unsigned cnt, enum rmd_slot_kind kind,
			  uint32_t mask, const struct rmd_plan_bus *pb, const uint16_t *ids)
{
	for (uint32_t m = mask; m; m &= m - 1) {
		unsigned l = (unsigned)__builtin_ctz(m);

		out[cnt++] = (struct rmd_plan_slot){
			.kind = kind,
			.motor = pb->motors[l],
			.replies = 1,
			.can_id = ids[l],
		};
	}
	return cnt;
}

unsigned rmd_plan_cycle(const struct rmd_plan *plan, unsigned bus, uint64_t n,
			struct rmd_plan_slot out[RMD_PLAN_MAX_SLOTS])
{
	const struct rmd_plan_bus *pb;
	struct rmd_plan_due d;
	unsigned cnt = 0;

	if (!rmd_plan_due(plan, bus, n, &d))
		return 0;
	pb = &plan->bus[bus];
	if (d.batch)
		out[cnt++] = (struct rmd_plan_slot){
			.kind = RMD_SLOT_V2_TORQUES,
			.motor = 0,
			.replies = (uint8_t)__builtin_popcount(pb->batched),
			.can_id = RMD_CAN_MULTI,
		};
	cnt = add_slots(out, cnt, RMD_SLOT_CONTROL, d.control, pb, pb->ctl_id);
	cnt = add_slots(out, cnt, RMD_SLOT_FINE, d.fine, pb, pb->req_id);
	for (unsigned j = 0; j < d.n_polls; j++) {
		if (d.polls[j].cycle != d.at)
			continue;
		out[cnt++] = (struct rmd_plan_slot){
			.kind = RMD_SLOT_STATUS,
			.motor = d.polls[j].motor,
			.replies = 1,
			.can_id = (uint16_t)(RMD_CAN_REQ_BASE + plan->motor[d.polls[j].motor].id),
		};
	}
	return cnt;
}

/* ------------------------------------------------------------------ */
/* Printing (non-rt) */

static const char *batch_note(enum rmd_plan_batch batch)
{
	switch (batch) {
	case RMD_BATCH_NONE:
	case RMD_BATCH_ON:
		return NULL;
	case RMD_BATCH_MODES:
		return "no 0x280 batching: a V2 motor with ID 1..4 is not in torque mode, and "
		       "would take the frame's torque";
	case RMD_BATCH_DIVISORS:
		return "no 0x280 batching: the V2 motors with ID 1..4 have different rate "
		       "divisors";
	case RMD_BATCH_V3_ON_BUS:
		return "no 0x280 batching: a V3/MIT motor on this bus would take 0x280 as a "
		       "broadcast command (V3 §3)";
	}
	return NULL;
}

/*
 * The highest loop rate at which bus b fits with its 0x92 reads at their
 * asked rates (not below the fastest feedback.rate_hz); 0: none.  Non-rt.
 */
static unsigned fine_max_rate(const struct rmd_config *cfg, unsigned b)
{
	struct rmd_config *c = malloc(sizeof(*c));
	struct rmd_plan *p = malloc(sizeof(*p));
	unsigned found = 0, r_min = 1;

	if (!c || !p)
		goto out;
	memcpy(c, cfg, sizeof(*c));
	for (unsigned i = 0; i < c->n_motors; i++)
		if (c->motors[i].bus == b && c->motors[i].feedback.rate_hz > r_min)
			r_min = (unsigned)ceil(c->motors[i].feedback.rate_hz);
	for (unsigned r = RMD_CONFIG_RATE_MAX_HZ; r >= r_min && !found; r--) {
		c->loop.rate_hz = r;
		rmd_plan_build(c, p, NULL, 0);
		if (p->bus[b].feasible)
			found = r;
	}
out:
	free(p);
	free(c);
	return found;
}

/* A motor's fine position line of the plan: its reads and their resolution.  Non-rt. */
static void print_fine(const struct rmd_plan *plan, const struct rmd_config *cfg, unsigned mi,
		       FILE *out)
{
	const struct rmd_plan_motor *pm = &plan->motor[mi];
	struct rmd_motor m;
	double res = NAN;

	if (rmd_motor_init(&m, &cfg->motors[mi]) == 0)
		res = rmd_motor_pos_resolution_rad(&m);
	char every[32] = "every cycle";

	if (pm->fine_divisor > 1)
		snprintf(every, sizeof(every), "every %u cycles", pm->fine_divisor);
	fprintf(out, "  %-20s position: 0x92 %s (%g Hz), step %g° (%.3g µrad)\n", "", every,
		pm->pos_hz, res * 180.0 / M_PI, res * 1e6);
}

/* What bus pb's 0x280 cycles send while one of its motors is not driven.  Non-rt. */
static void own_line(const struct rmd_plan_bus *pb, FILE *out)
{
	unsigned n = (unsigned)__builtin_popcount(pb->batched);

	fprintf(out, "  while one of them is not enabled in torque mode: no 0x280; ");
	if (pb->batch_own >= n)
		fprintf(out, "each its own frames, every cycle of the frame\n");
	else
		fprintf(out, "their own frames, %u of the %u a cycle of the frame, in turn\n",
			pb->batch_own, n);
}

static void print_bus(const struct rmd_plan *plan, const struct rmd_config *cfg, unsigned b,
		      FILE *out)
{
	const struct rmd_plan_bus *pb = &plan->bus[b];
	const struct rmd_config_bus *cb = &cfg->buses[b];
	const char *note = batch_note(pb->batch);
	struct rmd_bus_timing t = { 0 };
	char w_us[32], c_us[32], a_us[32];

	fprintf(out, "bus %s (%s", cb->name, rmd_bus_kind_name(cb->kind));
	rmd_bus_config_timing(cb, &t);
	if (t.port)
		fprintf(out, " %s", t.port);
	fprintf(out, ", %u %s", t.bitrate, t.rate_unit ? t.rate_unit : "bit/s");
	if (t.half_duplex)
		fprintf(out, ", turnaround %s µs", fmt_us(w_us, sizeof(w_us), t.turnaround_ns));
	fprintf(out, "): %u motor%s\n", pb->n_motors, pb->n_motors == 1 ? "" : "s");
	if (pb->n_motors == 0) {
		fprintf(out, "  verdict: ok (nothing to send)\n\n");
		return;
	}
	fprintf(out, "  %-20s %3s  %-8s %-8s %9s  %s\n", "motor", "id", "protocol", "mode", "rate",
		"status polls");
	for (unsigned l = 0; l < pb->n_motors; l++) {
		unsigned mi = pb->motors[l];
		const struct rmd_config_motor *m = &cfg->motors[mi];
		const struct rmd_plan_motor *pm = &plan->motor[mi];
		char rate[32];

		snprintf(rate, sizeof(rate), "%g Hz", (double)plan->rate_hz / m->rate_divisor);
		fprintf(out, "  %-20s %3u  %-8s %-8s %9s  ", m->name, m->id,
			rmd_proto_key(m->proto), rmd_mode_name(m->mode), rate);
		if (!(m->status_poll_hz > 0))
			fprintf(out, "none");
		else if (!pb->feasible || !pm->polls)
			fprintf(out, "%g Hz asked", m->status_poll_hz);
		else
			fprintf(out, "%g Hz asked, %.3g Hz planned%s", m->status_poll_hz,
				pm->poll_hz,
				pm->replacing == pm->polls ? ", each in place of a setpoint" :
				pm->replacing		   ? ", some in place of a setpoint" :
							     ", extra frames");
		fprintf(out, "%s\n", pm->batched ? "  [0x280]" : "");
		if (pm->fine_divisor)
			print_fine(plan, cfg, mi, out);
	}
	if (pb->batched) {
		fprintf(out, "  0x280 frame: torques of");
		for (unsigned l = 0; l < pb->n_motors; l++)
			if (pb->batched & (1u << l))
				fprintf(out, " %s", cfg->motors[pb->motors[l]].name);
		fprintf(out, " (V2 §4.1)\n");
		own_line(pb, out);
	}
	if (note)
		fprintf(out, "  %s\n", note);
	fprintf(out, "  frames per cycle: busiest %u (%u request%s), average %.2f\n",
		pb->max_frames, pb->max_requests, pb->max_requests == 1 ? "" : "s", pb->avg_frames);
	fprintf(out,
		"  worst case: %s µs per cycle of %s µs, load %.1f%% (average %s µs, %.1f%%)\n",
		fmt_us(w_us, sizeof(w_us), pb->worst_ns),
		fmt_us(c_us, sizeof(c_us), plan->period_ns),
		100.0 * (double)pb->worst_ns / (double)plan->period_ns,
		fmt_us(a_us, sizeof(a_us), (int64_t)ceil(pb->avg_ns)),
		100.0 * pb->avg_ns / (double)plan->period_ns);
	fprintf(out, "  schedule: control pattern %u cycle%s", pb->hc, pb->hc == 1 ? "" : "s");
	if (pb->poll_every && pb->poll_burst == 1)
		fprintf(out, ", a status poll every %u cycles, repeats every %llu cycles",
			pb->poll_every, (unsigned long long)pb->hyperperiod);
	else if (pb->poll_every)
		fprintf(out, ", %u status polls every %u cycles, repeats every %llu cycles",
			pb->poll_burst, pb->poll_every, (unsigned long long)pb->hyperperiod);
	if (pb->n_fine) {
		unsigned r = fine_max_rate(cfg, b);

		if (r)
			fprintf(out,
				"\n  with its 0x92 reads this bus fits a loop rate up to %u Hz", r);
		else
			fprintf(out,
				"\n  with its 0x92 reads this bus fits no loop rate up to %u Hz",
				RMD_CONFIG_RATE_MAX_HZ);
	}
	fprintf(out, "\n  verdict: %s\n\n", pb->feasible ? "ok" : "DOES NOT FIT");
}

void rmd_plan_print(const struct rmd_plan *plan, const struct rmd_config *cfg, FILE *out)
{
	char c_us[32];

	fprintf(out, "%s: %u motor%s on %u bus%s, loop %u Hz (cycle %s µs)\n\n", cfg->source,
		plan->n_motors, plan->n_motors == 1 ? "" : "s", plan->n_buses,
		plan->n_buses == 1 ? "" : "es", plan->rate_hz,
		fmt_us(c_us, sizeof(c_us), plan->period_ns));
	for (unsigned b = 0; b < plan->n_buses; b++)
		print_bus(plan, cfg, b, out);
	fprintf(out, "verdict: %s\n",
		plan->feasible ? "every bus fits" : "does not fit (see the messages)");
}
