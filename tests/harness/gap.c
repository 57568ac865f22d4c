// SPDX-License-Identifier: MIT
/* The widest gap between a test's own events: see gap.h. */
#include "harness/gap.h"
#include "rmd/time.h"

void gap_note(struct gap *g)
{
	int64_t now = rmd_now_ns();

	if (g->last_ns && now - g->last_ns > g->max_ns)
		g->max_ns = now - g->last_ns;
	g->last_ns = now;
}

void gap_mark(struct gap *g)
{
	g->max_ns = 0;
}

void gap_pause(struct gap *g)
{
	g->last_ns = 0;
}
