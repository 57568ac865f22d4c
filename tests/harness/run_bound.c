// SPDX-License-Identifier: MIT
/* How long a program may run: see run_bound.h. */
#include "harness/run_bound.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "harness/sleeper.h"

int64_t txn_silent_ns(unsigned n, int64_t timeout_ns, unsigned tries, int64_t spacing_ns)
{
	return (int64_t)tries * (timeout_ns + (int64_t)n * spacing_ns);
}

static double ms_of(int64_t ns)
{
	return (double)ns / 1e6;
}

int64_t run_bound_judge(struct sleeper *s, const char *what, run_bound_fn *run, void *ctx,
			int64_t design0_ns, unsigned waits)
{
	for (unsigned k = 1;; k++) {
		int64_t startup_ns = 0, design_ns = design0_ns, took_ns, worst_ns, held_ns, late_ns;
		int64_t bound_ns;

		if (s)
			sleeper_mark(s);
		took_ns = run(ctx, &startup_ns, &design_ns);
		worst_ns = s ? sleeper_worst_ns(s) : 0;
		held_ns = s ? sleeper_held_off_ns(s) : 0;
		late_ns = (int64_t)waits * worst_ns < held_ns ? (int64_t)waits * worst_ns : held_ns;
		if (s)
			late_ns += (int64_t)waits * s->period_ns;
		bound_ns = design_ns + 2 * startup_ns + late_ns;
		print_message("%s: %.1f ms (design %.1f ms, bound %.1f ms)\n", what, ms_of(took_ns),
			      ms_of(design_ns), ms_of(bound_ns));
		if (took_ns > bound_ns && k == RUN_BOUND_ATTEMPTS)
			fail_msg(
				"%s took %.1f ms, more than its bound of %.1f ms, %u times running: "
				"its design bound, a trivial run (%.1f ms) twice, and %u waits late "
				"by %.1f ms",
				what, ms_of(took_ns), ms_of(bound_ns), k, ms_of(startup_ns), waits,
				ms_of(late_ns));
		if (took_ns > bound_ns) {
			print_message(
				"busy machine: %s took %.1f ms, more than its bound of %.1f ms, "
				"with delays no reference saw: again (%u of %u)\n",
				what, ms_of(took_ns), ms_of(bound_ns), k + 1, RUN_BOUND_ATTEMPTS);
			continue;
		}
		if (took_ns > design_ns + startup_ns)
			print_message(
				"busy machine: %s took %.1f ms, more than its design bound of %.1f "
				"ms and a trivial run (%.1f ms), within what the machine added: that "
				"trivial run again, and %u waits late by up to %.1f ms in all (a "
				"normal-priority thread was held off %.1f ms at worst, %.1f ms in "
				"all, plus a period each)\n",
				what, ms_of(took_ns), ms_of(design_ns), ms_of(startup_ns), waits,
				ms_of(late_ns), ms_of(worst_ns), ms_of(held_ns));
		return bound_ns;
	}
}
