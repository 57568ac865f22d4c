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
