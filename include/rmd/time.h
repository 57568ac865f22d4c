/* SPDX-License-Identifier: MIT */
/*
 * The one clock (util layer): int64_t nanoseconds of CLOCK_MONOTONIC, the
 * only time type in rmdd (STYLE.md "Names").  Kernel receive stamps of
 * SocketCAN frames are converted onto this clock by the bus layer.
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

#endif /* RMD_TIME_H */
