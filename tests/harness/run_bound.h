/* SPDX-License-Identifier: MIT */
/*
 * How long a program may run (issue 10: tests that hold on a busy
 * machine): the design bound, what the run must take on an idle machine
 * (its timeouts and tries, rmd/txn.h), plus what the machine measurably
 * added in that very run -- what a run costs besides its waits (a
 * process's start and end, opening and closing the bus), measured on a
 * trivial run of the same program beside it, and the
 * scheduling delays a reference sleeper (sleeper.h) saw during the run,
 * for the waits the run makes in sequence.  An idle machine keeps the
 * bound near its design, so a program that waits too long still fails; a
 * busy one stretches it by what it took, and says so.
 */
#ifndef RMD_TESTS_RUN_BOUND_H
#define RMD_TESTS_RUN_BOUND_H

#include <stdint.h>

struct sleeper;

/*
 * Longest rmd_txn_run() (rmd/txn.h) stays busy with a batch of n requests
 * nobody answers: tries * (timeout + n * spacing), ns.
 */
int64_t txn_silent_ns(unsigned n, int64_t timeout_ns, unsigned tries, int64_t spacing_ns);

/*
 * One attempt of a timed run, for run_bound_judge(): run what is judged
 * and return its took, ns; set *startup_ns to the took of a trivial run
 * beside it (see below; 0: none).  *design_ns comes preset to
 * run_bound_judge()'s design_ns; a run that picked its own pace sets the
 * design bound of that pace.
 */
typedef int64_t run_bound_fn(void *ctx, int64_t *startup_ns, int64_t *design_ns);

/* Attempts of a timed run before its bound fails the test. */
#define RUN_BOUND_ATTEMPTS 3

/*
 * Run run(ctx), s marked just before, and judge its took against its
 * bound: design_ns, plus twice startup_ns (the took of a trivial run: what
 * a run costs besides its waits, which varies from run to run), plus how
 * late the run's `waits` waits in sequence can have woken up, each when
 * the machine held a thread of its class off then.  A hold-off of s that
 * began just after one of its wake-ups shows only past s's period, so
 * each wait may be late by s's worst delay plus its period; and all of
 * them together by no more than the hold-offs s saw in all
 * (sleeper_held_off_ns()) plus a period each: the smaller of the two
 * counts.  s NULL: no waits counted.
 *
 * Prints the took, the design and the bound of each attempt.  An attempt
 * over its bound is said on a "busy machine:" line and made again, up to
 * RUN_BOUND_ATTEMPTS in all; the test fails when every one was over.  A
 * program that waits too long does so every time; a machine that stalls
 * one process for a moment no reference saw (an exec that waits for the
 * disk, say) seldom does it twice running.  An attempt that took longer
 * than its design and one trivial run held only by what the machine
 * measurably added: a "busy machine:" line says so, with the figures.
 * Returns the bound of the attempt that held.
 */
int64_t run_bound_judge(struct sleeper *s, const char *what, run_bound_fn *run, void *ctx,
			int64_t design_ns, unsigned waits);

#endif /* RMD_TESTS_RUN_BOUND_H */
