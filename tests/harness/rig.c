// SPDX-License-Identifier: MIT
/* The sim rig (rig.h). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "harness/clock.h"
#include "harness/rig.h"
#include "rmd/bus_open.h"
#include "rmd/bus_sim.h"
#include "rmd/plan.h"
#include "rmd/spsc.h"

#define MS INT64_C(1000000)

void rig_open_buses(const struct rmd_config *cfg, const struct rmd_sim_setup *sim,
		    struct rmd_bus *buses)
{
	char err[256];

	for (unsigned b = 0; b < cfg->n_buses; b++) {
		struct rmd_bus_open_motor motors[RMD_MAX_MOTORS];
		struct rmd_bus_open_ctx ctx;

		rmd_bus_open_ctx_of(cfg, sim, b, motors, &ctx);
		if (rmd_bus_open(&buses[b], &cfg->buses[b], &ctx, err, sizeof(err)) == 0)
			continue;
		for (unsigned k = 0; k < b; k++)
			rmd_bus_close(&buses[k]);
		fail_msg("sim bus %s: %s", cfg->buses[b].name, err);
	}
}

void rig_assert_default_motor(const struct rmd_bringup_motor *m)
{
	assert_int_equal(m->state, RMD_BRINGUP_FOUND);
	assert_string_equal(m->model, "X8S2V10");
	assert_int_equal(m->version, 20220206);
	assert_true(m->status);
	assert_float_equal(m->voltage_v, 48.0, 0.05);
	assert_float_equal(m->temp_c, 25.0, 0.5);
	assert_int_equal(m->error_code, 0);
	assert_int_equal(m->b3, RMD_B3_SET);
}

struct rmd_frame rig_host[RIG_WIRE_MAX], rig_motor[RIG_WIRE_MAX];
unsigned rig_host_n, rig_motor_n;

void rig_reset(struct rig *r)
{
	memset(r, 0, sizeof(*r));
	rig_host_n = rig_motor_n = 0;
	t_now = 1000 * MS;
}

void rig_wire_tap(void *ctx, const struct rmd_sim_pending *p, int64_t start_ns, int64_t eof_ns)
{
	(void)ctx;
	(void)start_ns;
	(void)eof_ns;
	if (p->src == RMD_SIM_SRC_HOST && rig_host_n < RIG_WIRE_MAX)
		rig_host[rig_host_n++] = p->f;
	else if (p->src != RMD_SIM_SRC_HOST && rig_motor_n < RIG_WIRE_MAX)
		rig_motor[rig_motor_n++] = p->f;
}

void rig_start(struct rig *r, rmd_sim_wire_tap_fn *tap)
{
	struct rmd_loop_opts o;
	char err[1024];

	if (rmd_plan_build(&r->io.cfg, &r->io.plan, err, sizeof(err)))
		fail_msg("plan: %s", err);
	rig_open(r, tap);
	assert_int_equal(rig_loop_opts(&r->io, &o), 0);
	if (r->real_clock) {
		o.now_ns = NULL;
		o.sleep_ns = NULL;
	}
	r->l = rmd_loop_new(&o, err, sizeof(err));
	if (!r->l)
		fail_msg("rmd_loop_new: %s", err);
}

void rig_open(struct rig *r, rmd_sim_wire_tap_fn *tap)
{
	rig_open_buses(&r->io.cfg, &r->io.sim, r->io.buses);
	for (unsigned b = 0; tap && b < r->io.cfg.n_buses; b++)
		rmd_sim_wire_set_tap(rmd_bus_sim_get(&r->io.buses[b]), tap, (void *)(uintptr_t)b);
}

void rig_bring_up(struct rig *r)
{
	int ret = rmd_loop_bringup(r->l, &r->report);

	if (ret)
		fail_msg("bring-up: %d", ret);
	t_now = (t_now / MS + 1) * MS;
	for (unsigned b = 0; b < r->io.cfg.n_buses; b++)
		r->epoch[b] = t_now - rmd_bus_sim_time_ns(&r->io.buses[b], t_now);
}

void rig_stop(struct rig *r)
{
	rmd_loop_free(r->l);
	r->l = NULL;
	for (unsigned b = 0; b < r->io.cfg.n_buses; b++)
		rmd_bus_close(&r->io.buses[b]);
}

void rig_run(struct rig *r, unsigned n, bool with_cmd)
{
	for (unsigned k = 0; k < n; k++) {
		if (with_cmd) {
			r->cmd.rx_ns = t_now;
			r->cmd.seq++;
			rmd_latest_put(&r->io.cmds, &r->cmd);
		}
		if (r->rt)
			rig_loop_cycle(r->l, t_now, r->io.plan.period_ns);
		else
			rmd_loop_cycle(r->l, t_now);
		t_now += r->io.plan.period_ns;
		if (r->each)
			r->each();
	}
	if (!r->events_in_ring)
		rig_events(r);
}

void rig_events(struct rig *r)
{
	struct rmd_event e;

	while (rmd_ring_pop(&r->io.events, &e))
		if (r->nev < RIG_EVENTS_MAX)
			r->ev[r->nev++] = e;
}

unsigned rig_count_events(struct rig *r, unsigned kind, int motor, int64_t a)
{
	unsigned n = 0;

	rig_events(r);
	for (unsigned k = 0; k < r->nev; k++)
		if (r->ev[k].kind == kind && (motor < 0 || r->ev[k].motor == motor) &&
		    (a < 0 || r->ev[k].a == a))
			n++;
	return n;
}
