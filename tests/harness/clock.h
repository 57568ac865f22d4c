/* SPDX-License-Identifier: MIT */
/*
 * The injected clock of the loop suites: rmd_loop_opts.now_ns = fake_now,
 * .sleep_ns = fake_sleep, and the test moves t_now.  A "sleep" only
 * advances t_now, so a test runs thousands of cycles in no time and the
 * same way on every machine.
 */
#ifndef RMD_TESTS_CLOCK_H
#define RMD_TESTS_CLOCK_H

#include <stdint.h>

/* Now, in the loop's nanoseconds; the test sets and advances it. */
extern int64_t t_now;

/* rmd_loop_opts.now_ns: t_now (ctx unused). */
int64_t fake_now(void *ctx);

/* rmd_loop_opts.sleep_ns: t_now += ns (ctx unused). */
void fake_sleep(void *ctx, int64_t ns);

#endif /* RMD_TESTS_CLOCK_H */
