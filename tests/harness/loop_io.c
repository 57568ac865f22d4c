// SPDX-License-Identifier: MIT
#include "harness/clock.h"
#include "harness/loop_io.h"

int rig_loop_opts(struct rig_loop_io *io, const struct rmd_config *cfg, const struct rmd_plan *plan,
		  struct rmd_bus *buses, struct rmd_loop_opts *o)
{
	rmd_latest_init(&io->cmds, io->cmd_buf, sizeof(struct rmd_command));
	rmd_latest_init(&io->snaps, io->snap_buf, sizeof(struct rmd_snapshot));
	rmd_latest_init(&io->health, io->health_buf, sizeof(struct rmd_health));
	*o = (struct rmd_loop_opts){
		.cfg = cfg,
		.plan = plan,
		.buses = buses,
		.commands = &io->cmds,
		.snapshots = &io->snaps,
		.health = &io->health,
		.events = &io->events,
		.snapshot_fd = -1,
		.now_ns = fake_now,
		.sleep_ns = fake_sleep,
	};
	return rmd_ring_init(&io->events, io->ev_buf, sizeof(io->ev_buf) / sizeof(io->ev_buf[0]),
			     sizeof(struct rmd_event));
}
