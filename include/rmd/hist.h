/* SPDX-License-Identifier: MIT */
/*
 * A log-scale histogram of nanosecond latencies: 4 buckets per octave, so
 * any percentile is known within 25% from a fixed array of
 * RMD_HIST_BUCKETS counters (no allocation, no sorting).  Pure, rt-safe.
 */
#ifndef RMD_HIST_H
#define RMD_HIST_H

#include <stdint.h>

#define RMD_HIST_SUB 4 /* buckets per octave */
#define RMD_HIST_BUCKETS (64 * RMD_HIST_SUB)

/* The bucket of a value (negative values count as 0). */
static inline unsigned rmd_hist_bucket(int64_t ns)
{
	uint64_t v = ns > 0 ? (uint64_t)ns : 0;
	unsigned msb;

	if (v < RMD_HIST_SUB)
		return (unsigned)v;
	msb = 63u - (unsigned)__builtin_clzll(v);
	return msb * RMD_HIST_SUB + (unsigned)((v >> (msb - 2)) & 3u);
}

/* The largest value of bucket b. */
static inline int64_t rmd_hist_upper(unsigned b)
{
	unsigned msb = b / RMD_HIST_SUB, sub = b % RMD_HIST_SUB;

	if (b < RMD_HIST_SUB)
		return b;
	if (msb >= 62)
		return INT64_MAX;
	return (int64_t)(((uint64_t)(RMD_HIST_SUB + sub + 1) << (msb - 2)) - 1);
}

#endif /* RMD_HIST_H */
