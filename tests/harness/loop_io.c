// SPDX-License-Identifier: MIT
#include "harness/clock.h"
#include "harness/loop_io.h"

int rig_loop_opts(struct rig_loop *r, struct rmd_loop_opts *o)
{
	rmd_latest_init(&r->cmds, r->cmd_buf, sizeof(struct rmd_command));
	rmd_latest_init(&r->snaps, r->snap_buf, sizeof(struct rmd_snapshot));
	rmd_latest_init(&r->health, r->health_buf, sizeof(struct rmd_health));
	rmd_latest_init(&r->homes, r->home_buf, sizeof(struct rmd_home));
	*o = (struct rmd_loop_opts){
		.cfg = &r->cfg,
		.plan = &r->plan,
		.buses = r->buses,
		.commands = &r->cmds,
		.homes = &r->homes,
		.snapshots = &r->snaps,
		.health = &r->health,
		.events = &r->events,
		.snapshot_fd = -1,
		.now_ns = fake_now,
		.sleep_ns = fake_sleep,
	};
	return rmd_ring_init(&r->events, r->ev_buf, sizeof(r->ev_buf) / sizeof(r->ev_buf[0]),
			     sizeof(struct rmd_event));
}

void rig_loop_cycle(struct rmd_loop *l, int64_t now, int64_t period_ns)
{
	int64_t due;

	rmd_loop_tick(l, now);
	due = rmd_loop_reply_due(l, now);
	if (due > 0 && !rmd_loop_collect(l, due)) {
		due = now + period_ns * 9 / 10;
		rmd_loop_collect(l, due);
	}
	if (due >= 0)
		rmd_loop_publish(l, due ? due : now);
}
