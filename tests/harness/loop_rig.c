// SPDX-License-Identifier: MIT
/* The rig of the rt loop suites (loop_rig.h). */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "harness/loop_rig.h"
#include "rmd/config_yaml.h"

struct sent trace[TRACE_MAX];
unsigned trace_n;
void (*rig_tap_hook)(unsigned b, const struct rmd_sim_pending *p, int64_t start_ns);
struct rig R;
void (*rig_sim_tweak)(struct rmd_sim_setup *sim);

static void tap(void *ctx, const struct rmd_sim_pending *p, int64_t start_ns, int64_t eof_ns)
{
	unsigned b = (unsigned)(uintptr_t)ctx;

	(void)eof_ns;
	if (rig_tap_hook)
		rig_tap_hook(b, p, start_ns);
	if (p->src != RMD_SIM_SRC_HOST || trace_n >= TRACE_MAX)
		return;
	trace[trace_n++] = (struct sent){ .bus = b, .f = p->f, .t_ns = start_ns + R.epoch[b] };
}

void events_pump(void)
{
	rig_events(&R);
}

unsigned count_ev(unsigned kind, int motor)
{
	return rig_count_events(&R, kind, motor, -1);
}

/* Every sim motor follows its config entry (after a tweak changed it). */
static void sync_sim(struct rmd_config *cfg)
{
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		struct rmd_config_motor *m = &cfg->motors[i];
		struct rmd_sim_motor_params *p = &R.io.sim.motors[i];

		p->id = m->id;
		p->proto = m->proto;
		p->mit = m->mit;
		p->gear_ratio = m->gear_ratio;
		if (m->torque_constant_nm_a > 0)
			p->kt_nm_a = m->torque_constant_nm_a;
	}
}

void rig_up_clock(unsigned n, tweak_fn *tweak, bool real)
{
	rig_reset(&R);
	trace_n = 0;
	assert_int_equal(rmd_config_sim_default(&R.io.cfg, &R.io.sim, n), 0);
	R.io.cfg.safety.safe_action = RMD_SAFE_STOP;
	R.io.cfg.safety.lost_motor_action = RMD_LOST_MOTOR;
	if (tweak)
		tweak(&R.io.cfg);
	sync_sim(&R.io.cfg);
	if (rig_sim_tweak)
		rig_sim_tweak(&R.io.sim);
	R.real_clock = real; /* else the injected clock */
	rig_start(&R, tap);
}

void open_buses(void)
{
	rig_open(&R, tap);
}

void rig_up(unsigned n, tweak_fn *tweak)
{
	rig_up_clock(n, tweak, false);
}

void rig_down(void)
{
	rig_stop(&R);
}

void bring_up(void)
{
	rig_bring_up(&R);
}

int64_t period(void)
{
	return R.io.plan.period_ns;
}

void run(unsigned n, bool with_cmd)
{
	rig_run(&R, n, with_cmd);
}

uint64_t ignored_over(unsigned n, enum rmd_ignore why)
{
	struct rmd_loop_counters c0, c1;

	rmd_loop_get_counters(R.l, &c0);
	run(n, true);
	rmd_loop_get_counters(R.l, &c1);
	return c1.ignored[why] - c0.ignored[why];
}

void cmd_clear(void)
{
	memset(&R.cmd, 0, sizeof(R.cmd));
}

struct rmd_setpoint *cmd_motor(unsigned i, bool enable, enum rmd_mode mode)
{
	struct rmd_setpoint *sp = &R.cmd.m[i];

	R.cmd.present |= 1u << i;
	memset(sp, 0, sizeof(*sp));
	sp->enable = enable;
	sp->mode = (uint8_t)mode;
	return sp;
}

struct rmd_snapshot snap(void)
{
	struct rmd_snapshot s;

	rmd_loop_get_snapshot(R.l, &s);
	return s;
}

struct rmd_sim_motor *sim_motor(unsigned i)
{
	const struct rmd_config_motor *m = &R.io.cfg.motors[i];

	return rmd_sim_wire_motor(rmd_bus_sim_get(&R.io.buses[m->bus]), m->id);
}

unsigned lifecycle(unsigned i)
{
	return snap().m[i].lifecycle;
}

unsigned sent_to(unsigned i, int cmd, unsigned from)
{
	const struct rmd_config_motor *m = &R.io.cfg.motors[i];
	unsigned n = 0;

	for (unsigned k = from; k < trace_n; k++) {
		const struct sent *s = &trace[k];

		if (s->bus != m->bus)
			continue;
		if (cmd == 0x400 && s->f.can_id == 0x400u + m->id)
			n++;
		else if (cmd != 0x400 && s->f.can_id == 0x140u + m->id && s->f.data[0] == cmd)
			n++;
	}
	return n;
}

bool moves_frame(const struct rmd_frame *f)
{
	uint8_t c = f->data[0];

	if (f->can_id >= 0x400 || f->can_id == 0x280)
		return true;
	return (c >= 0xA1 && c <= 0xA8) || c == 0x77 || c == 0x88;
}

void set_faults(unsigned bus, const struct rmd_sim_fault *f, size_t n)
{
	static const struct rmd_sim_fault none;

	assert_int_equal(
		rmd_sim_wire_set_faults(rmd_bus_sim_get(&R.io.buses[bus]), f ? f : &none, n), 0);
}

int64_t sim_time(unsigned bus)
{
	return rmd_bus_sim_time_ns(&R.io.buses[bus], t_now);
}

unsigned fault_now(struct rmd_sim_fault *f, int64_t for_ns)
{
	f->start_ns = sim_time(0);
	if (for_ns)
		f->end_ns = f->start_ns + for_ns;
	set_faults(0, f, 1);
	return trace_n;
}

void motors_at_speed(unsigned motors, tweak_fn *tweak, unsigned n, double vel_rad_s,
		     unsigned cycles)
{
	rig_up(motors, tweak);
	bring_up();
	cmd_clear();
	for (unsigned i = 0; i < n; i++)
		cmd_motor(i, true, RMD_MODE_SPEED)->vel_rad_s = vel_rad_s;
	run(cycles, true);
}

void up_at_speed(tweak_fn *tweak, unsigned n, double vel_rad_s, unsigned cycles)
{
	motors_at_speed(3, tweak, n, vel_rad_s, cycles);
}

void three_at_speed(void)
{
	up_at_speed(NULL, 3, 1.0, 200);
	assert_int_equal(lifecycle(1), RMD_LC_ENABLED);
}

void assert_motor2_alone_stopped(unsigned from)
{
	assert_int_equal(count_ev(RMD_EV_SAFE_ACTION, 1), 1);
	assert_int_equal(count_ev(RMD_EV_SAFE_ACTION, 0), 0);
	run(5, true);
	assert_int_equal(sent_to(1, 0x80, from), 1);
	assert_int_equal(sim_motor(1)->ctrl, RMD_SIM_OFF);
	assert_int_equal(lifecycle(0), RMD_LC_ENABLED);
	assert_int_equal(lifecycle(2), RMD_LC_ENABLED);
}

void cl_reenable(unsigned i)
{
	cmd_motor(i, false, RMD_MODE_SPEED);
	run(2, true);
	cmd_motor(i, true, RMD_MODE_SPEED)->vel_rad_s = 1.0;
	run(20, true);
}

void missing_start(struct rmd_config *cfg)
{
	cfg->probe.on_missing = RMD_MISSING_START;
}
