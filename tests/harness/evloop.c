// SPDX-License-Identifier: MIT
/* The event loop of the system suites (evloop.h). */
#include <poll.h>

#include "harness/evloop.h"
#include "harness/proc.h"
#include "rmd/time.h"

#define NS_PER_MS INT64_C(1000000)

/* t_ms, or less so that a wait of it ends by due_ns. */
static int ms_until(int64_t due_ns, int64_t now, int t_ms)
{
	int64_t due = (due_ns - now + NS_PER_MS - 1) / NS_PER_MS;

	if (due < t_ms)
		t_ms = due < 0 ? 0 : (int)due;
	return t_ms;
}

void evloop_turn(lcm_t *lcm, struct ctl_clock *c, int64_t other_due_ns, int max_ms)
{
	struct pollfd p[KID_MAX + 1];
	struct kid *who[KID_MAX + 1];
	int64_t now = rmd_now_ns();
	int n = 0, t = max_ms;

	if (c->on)
		t = ms_until(c->next_ns, now, t);
	if (other_due_ns != INT64_MAX)
		t = ms_until(other_due_ns, now, t);
	if (lcm) {
		p[n] = (struct pollfd){ .fd = lcm_get_fileno(lcm), .events = POLLIN };
		who[n++] = NULL;
	}
	n += (int)kid_pollfds(p + n, who + n, KID_MAX);
	if (poll(p, (nfds_t)n, t) > 0) {
		for (int i = 0; i < n; i++) {
			if (!p[i].revents)
				continue;
			if (who[i]) {
				kid_read(who[i]);
				continue;
			}
			for (int k = 0; k < 200 && lcm_handle_timeout(lcm, 0) > 0; k++)
				;
		}
	}
	now = rmd_now_ns();
	if (c->on && now >= c->next_ns) {
		c->publish();
		c->next_ns += c->period_ns;
		if (c->next_ns <= now) /* late: skip ahead, no burst */
			c->next_ns = now + c->period_ns;
	}
}

void evloop_run_for(void (*service)(int max_ms), int ms)
{
	int64_t end = rmd_now_ns() + ms * NS_PER_MS;

	for (int64_t now = rmd_now_ns(); now < end; now = rmd_now_ns())
		service((int)((end - now + NS_PER_MS - 1) / NS_PER_MS));
}
