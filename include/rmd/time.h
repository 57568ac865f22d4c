/* SPDX-License-Identifier: MIT */
/*
 * The one clock (util layer): int64_t nanoseconds of CLOCK_MONOTONIC, the
 * only time type in rmdd (STYLE.md "Names").  Kernel receive stamps
 * (CLOCK_REALTIME) are moved onto it with rmd_realtime_offset_ns(): the
 * SocketCAN bus's frames, the bridge's datagrams.
 */
#ifndef RMD_TIME_H
#define RMD_TIME_H

#include <stdint.h>
#include <time.h>

#define RMD_NS_PER_S INT64_C(1000000000)
#define RMD_NS_PER_MS INT64_C(1000000)
#define RMD_NS_PER_US INT64_C(1000)

/* Now on CLOCK_MONOTONIC.  rt-safe (vDSO, no syscall on x86-64). */
static inline int64_t rmd_now_ns(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t)ts.tv_sec * RMD_NS_PER_S + ts.tv_nsec;
}

/* A timespec as nanoseconds (no clock read).  Pure. */
static inline int64_t rmd_timespec_ns(const struct timespec *ts)
{
	return (int64_t)ts->tv_sec * RMD_NS_PER_S + ts->tv_nsec;
}

/*
 * CLOCK_REALTIME - CLOCK_MONOTONIC now, for moving a kernel receive stamp
 * (CLOCK_REALTIME: no socket option gives a CLOCK_MONOTONIC one) onto the
 * one clock: the REALTIME read bracketed between two MONOTONIC reads,
 * against their midpoint.  The offset drifts only while REALTIME is slewed
 * (adjtimex: <= 500 ppm) or stepped (settimeofday, an NTP/PTP step); a
 * step between a stamp and this read misplaces the stamp by the step, so
 * callers clamp the result to *mono_now_ns (what came cannot have come
 * after it was read), where this stores the MONOTONIC time of the read.
 * rt-safe.
 */
static inline int64_t rmd_realtime_offset_ns(int64_t *mono_now_ns)
{
	struct timespec m0, r, m1;
	int64_t m0_ns, m1_ns;

	clock_gettime(CLOCK_MONOTONIC, &m0);
	clock_gettime(CLOCK_REALTIME, &r);
	clock_gettime(CLOCK_MONOTONIC, &m1);
	m0_ns = rmd_timespec_ns(&m0);
	m1_ns = rmd_timespec_ns(&m1);
	*mono_now_ns = m1_ns;
	return rmd_timespec_ns(&r) - (m0_ns + (m1_ns - m0_ns) / 2);
}

#endif /* RMD_TIME_H */
