// SPDX-License-Identifier: MIT
/*
 * Whether a motor that missed replies rebooted meanwhile: the check's
 * record and its judgements (rmd/reboot.h).
 *
 * Execution context: pure, rt-safe.
 */
#include <math.h>
#include <string.h>

#include "rmd/reboot.h"
#include "rmd/time.h"

void rmd_reboot_init(struct rmd_reboot *r)
{
	memset(r, 0, sizeof(*r));
}

/* The episode ends.  rt-safe. */
static void episode_end(struct rmd_reboot *r)
{
	r->pending = false;
	r->first = false;
	r->tries = 0;
	r->undecided = 0;
}

void rmd_reboot_found(struct rmd_reboot *r, int64_t now_ns, bool first_check)
{
	episode_end(r);
	r->since_ns = now_ns;
	r->boot_known = false;
	r->pending = r->first = first_check && !r->off;
	r->ignored = 0;
	r->astray = false;
}

enum rmd_reboot_verdict rmd_reboot_count(struct rmd_reboot *r, enum rmd_reboot_verdict v,
					 bool *news)
{
	*news = false;
	if (v == RMD_REBOOT_SAYS_COUNT_ASTRAY) {
		*news = !r->astray;
		r->astray = true;
		episode_end(r);
	}
	return r->astray ? RMD_REBOOT_SAYS_NOTHING : v;
}

void rmd_reboot_forget(struct rmd_reboot *r)
{
	episode_end(r);
	r->since_ns = 0;
	r->boot_known = false;
}

void rmd_reboot_slow(struct rmd_reboot *r, int64_t now_ns)
{
	r->slow_ns = now_ns;
}

enum rmd_reboot_outcome rmd_reboot_missed(struct rmd_reboot *r, uint64_t seq, bool check,
					  uint64_t heard_seq, int64_t now_ns, int64_t slow_hold_ns)
{
	if (r->off || r->astray || !r->since_ns || seq < r->told_seq)
		return RMD_REBOOT_WAIT;
	/* found, it answered a later request, not this check read: its firmware may not know it */
	if (check && r->first && heard_seq > seq + 1 && ++r->ignored >= RMD_REBOOT_IGNORED_MAX) {
		r->off = true;
		episode_end(r);
		return RMD_REBOOT_UNCHECKABLE;
	}
	/* it answered a later request: it was there after this one, this was no silence */
	if (!r->pending && heard_seq <= seq + 1 &&
	    !(r->slow_ns && now_ns - r->slow_ns < slow_hold_ns)) {
		r->pending = true;
		r->tries = 0;
		r->undecided = 0;
	}
	return RMD_REBOOT_WAIT;
}

uint8_t rmd_reboot_next(struct rmd_reboot *r, uint8_t cmd)
{
	if (!r->pending)
		return 0;
	return r->tries++ % 2 ? RMD_REBOOT_CMD_STATUS : cmd;
}

enum rmd_reboot_outcome rmd_reboot_answer(struct rmd_reboot *r, uint64_t seq,
					  enum rmd_reboot_verdict v)
{
	if (v == RMD_REBOOT_SAYS_BOOTED) {
		episode_end(r);
		r->told_seq = seq;
		return RMD_REBOOT_REBOOTED;
	}
	if (!r->pending)
		return RMD_REBOOT_WAIT;
	r->ignored = 0;
	if (v != RMD_REBOOT_SAYS_RUNNING && ++r->undecided < RMD_REBOOT_UNDECIDED_MAX)
		return RMD_REBOOT_WAIT;
	episode_end(r);
	r->told_seq = seq;
	return v == RMD_REBOOT_SAYS_RUNNING ? RMD_REBOOT_FINE : RMD_REBOOT_UNDECIDED;
}

enum rmd_reboot_verdict rmd_reboot_runtime_says(const struct rmd_reboot *r, uint32_t runtime_ms,
						int64_t sent_ns)
{
	double gap = (double)(sent_ns - r->since_ns);
	double ran =
		((double)runtime_ms + 1.0) * (double)RMD_NS_PER_MS * (1.0 + RMD_REBOOT_CLOCK_SLACK);
	double count;

	if (ran > gap)
		return RMD_REBOOT_SAYS_RUNNING;
	if (!r->boot_known)
		return RMD_REBOOT_SAYS_BOOTED;
	/* its count since it last started from 0: near 2^32 ms, a short one may be its wrap */
	count = (double)(sent_ns - r->boot_ns) * (1.0 + RMD_REBOOT_CLOCK_SLACK) +
		(double)RMD_NS_PER_MS;
	return count >= (double)RMD_REBOOT_RUNTIME_WRAP_NS ? RMD_REBOOT_SAYS_NOTHING :
							     RMD_REBOOT_SAYS_BOOTED;
}

enum rmd_reboot_outcome rmd_reboot_runtime(struct rmd_reboot *r, uint64_t seq, uint32_t runtime_ms,
					   int64_t sent_ns, int64_t recv_ns, int64_t *least_ms)
{
	enum rmd_reboot_verdict v;
	enum rmd_reboot_outcome out;

	if (least_ms)
		*least_ms = (sent_ns - r->since_ns) / RMD_NS_PER_MS;
	if (!r->pending || !r->since_ns)
		return RMD_REBOOT_WAIT;
	v = rmd_reboot_runtime_says(r, runtime_ms, sent_ns);
	out = rmd_reboot_answer(r, seq, v);
	if (v != RMD_REBOOT_SAYS_BOOTED) {
		/* running (or its count wrapped): it was running then, its count zero then */
		r->since_ns = recv_ns;
		r->boot_ns = recv_ns - (int64_t)runtime_ms * RMD_NS_PER_MS;
		r->boot_known = true;
	}
	return out;
}

void rmd_reboot_released(struct rmd_reboot *r, uint64_t seq)
{
	r->release_seq = seq;
	r->brake_open = false;
}

enum rmd_reboot_verdict rmd_reboot_brake_says(struct rmd_reboot *r, bool held, uint64_t seq,
					      bool released)
{
	if (!held) {
		r->brake_open = false;
		return RMD_REBOOT_SAYS_NOTHING;
	}
	if (seq <= r->release_seq)
		return RMD_REBOOT_SAYS_NOTHING; /* asked before the release went out */
	if (released) {
		r->brake_open = true;
		return RMD_REBOOT_SAYS_RUNNING;
	}
	return r->brake_open ? RMD_REBOOT_SAYS_BOOTED : RMD_REBOOT_SAYS_NOTHING;
}

enum rmd_reboot_outcome rmd_reboot_brake(struct rmd_reboot *r, uint64_t seq,
					 enum rmd_reboot_verdict v, bool checkable)
{
	if (v != RMD_REBOOT_SAYS_BOOTED)
		return RMD_REBOOT_WAIT;
	if (!checkable || r->off || !r->since_ns)
		return rmd_reboot_answer(r, seq, v);
	r->brake_open = false;
	if (!r->pending) {
		r->pending = true;
		r->tries = 0;
		r->undecided = 0;
	}
	return RMD_REBOOT_WAIT;
}

enum rmd_reboot_verdict rmd_reboot_turns_says(const struct rmd_multiturn *mt,
					      const struct rmd_reboot_reading *before,
					      const struct rmd_reboot_reading *now)
{
	double dt = (double)(now->t_ns - before->t_ns) * 1e-9;
	double v = fmax(fabs(before->vel_rad_s), fabs(now->vel_rad_s));
	double d = now->pos_rad - before->pos_rad, step = 2.0 * mt->tol_rad;
	double may = 2.0 * v * dt + step + fabs(before->err_rad) + fabs(now->err_rad);
	double p = mt->period_rad;

	if (!(p > 0.0) || !isfinite(d) || !isfinite(may) || dt < 0.0)
		return RMD_REBOOT_SAYS_NOTHING;
	if (fabs(d) <= may || fabs(d) < p / 2.0 + step)
		return RMD_REBOOT_SAYS_RUNNING;
	if (fabs(d - round(d / p) * p) <= may)
		return RMD_REBOOT_SAYS_BOOTED;
	return RMD_REBOOT_SAYS_COUNT_ASTRAY;
}
