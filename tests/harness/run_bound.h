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
 * Judge a run that took took_ns against its bound, and return the bound:
 * design_ns, plus twice startup_ns (the took of a trivial run: what a run
 * costs besides its waits, which varies from run to run), plus how late the run's
 * `waits` waits in sequence can have woken up, each when the machine held
 * a thread of its class off then.  A hold-off of s (marked just before the
 * run) that began just after one of its wake-ups shows only past s's
 * period, so each wait may be late by s's worst delay plus its period; and
 * all of them together by no more than the hold-offs s saw in all
 * (sleeper_held_off_ns()) plus a period each: the smaller of the two
 * counts.  s NULL: no waits counted.
 *
 * Prints the took, the design and the bound; fails the test when the run
 * took longer than the bound.  A run that took longer than its design and
 * one trivial run passed only by what the machine measurably added: a
 * "busy machine:" line says so, with the figures.
 */
int64_t run_bound_check(struct sleeper *s, const char *what, int64_t took_ns, int64_t design_ns,
			int64_t startup_ns, unsigned waits);

#endif /* RMD_TESTS_RUN_BOUND_H */
