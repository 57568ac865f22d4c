/* SPDX-License-Identifier: MIT */
/*
 * The widest gap between a test's own events (issue 10: tests that hold on
 * a busy machine), e.g. a controller's publishes: how long whoever listens
 * heard nothing from it, measured where the events are made.  A reference
 * sleeper (sleeper.h) is another thread, which the machine may run while
 * it holds this one.  Windows as the sleeper's: gap_mark() begins one.
 */
#ifndef RMD_TESTS_GAP_H
#define RMD_TESTS_GAP_H

#include <stdint.h>

struct gap {
	int64_t last_ns; /* the latest event, CLOCK_MONOTONIC; 0: none since gap_pause() */
	int64_t max_ns;	 /* the widest gap between two events since gap_mark() */
};

/* An event now (rmd_now_ns()). */
void gap_note(struct gap *g);

/* Begin a window: forget the widest gap so far (the next event still closes the open one). */
void gap_mark(struct gap *g);

/* The events pause on purpose: the next one opens no gap. */
void gap_pause(struct gap *g);

#endif /* RMD_TESTS_GAP_H */
