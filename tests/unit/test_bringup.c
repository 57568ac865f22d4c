// SPDX-License-Identifier: MIT
/*
 * Bring-up as data (rmd/bringup.h) and the bus contract it stands on
 * (rmd/bus.h, rmd/bus_open.h), on simulated buses with an injected clock:
 *
 * - what rmd_loop_bringup() returns: found, missing and faulty motors, and
 *   every 0xB3 outcome, made by a bus decorator that drops or rewrites the
 *   motors' answers to 0xB3 on the way in;
 * - a decorator forwards state and stats instead of copying them;
 * - the sim bus's caps and next_due_ns, and the typed accessors of the
 *   other transports refusing it;
 * - rmd_bus_open() from a config entry and rmd_bus_open_spec() from the
 *   spec string give the same bus.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "harness/clock.h"
#include "harness/loop_io.h"
#include "harness/rig.h"
#include "rmd/bringup.h"
#include "rmd/bus_open.h"
#include "rmd/bus_rs485.h"
#include "rmd/bus_sim.h"
#include "rmd/bus_socketcan.h"
#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/loop.h"
#include "rmd/plan.h"
#include "rmd/sim.h"
#include "rmd/sim_wire.h"
#include "harness/suite.h"

#define MS INT64_C(1000000)

/* ---- a decorator that tampers with the answers to 0xB3 ------------------------------ */

enum tamper {
	TAMPER_NONE = 0,
	TAMPER_DROP,   /* the answer never arrives */
	TAMPER_ZEROS,  /* the command byte and zeros (V3 §2.30 example 2) */
	TAMPER_DIFFER, /* another time than written */
};

static int tb_recv(struct rmd_bus *bus, struct rmd_bus_rx *out, unsigned max, int64_t now_ns)
{
	const struct rmd_bus_wrap *w = bus->priv;
	const enum tamper *how = w->ctx;
	int n = rmd_bus_wrap_recv(bus, out, max, now_ns), k = 0;

	for (int i = 0; i < n; i++) {
		struct rmd_frame *f = &out[i].f;

		if (f->len == RMD_FRAME_LEN && f->data[0] == 0xB3) {
			if (*how == TAMPER_DROP)
				continue;
			if (*how == TAMPER_ZEROS)
				memset(f->data + 1, 0, RMD_FRAME_LEN - 1);
			if (*how == TAMPER_DIFFER)
				f->data[4] ^= 0x01; /* the time's low byte */
		}
		out[k++] = out[i];
	}
	return n < 0 ? n : k;
}

/* What the loop sent, (identifier, command byte), from when `sent_log` is set. */
#define SENT_MAX 4096
static bool sent_log;
static unsigned sent_n;
static struct {
	uint32_t id;
	uint8_t cmd;
} sent[SENT_MAX];

static int tb_send(struct rmd_bus *bus, const struct rmd_frame *frames, unsigned n, int64_t now_ns)
{
	int r = rmd_bus_wrap_send(bus, frames, n, now_ns);

	for (int k = 0; sent_log && k < r && sent_n < SENT_MAX; k++, sent_n++) {
		sent[sent_n].id = frames[k].can_id;
		sent[sent_n].cmd = frames[k].len ? frames[k].data[0] : 0;
	}
	return r;
}

static const struct rmd_bus_ops tamper_ops = RMD_BUS_WRAP_OPS("tamper", tb_send, tb_recv);

/* ---- the rig: n sim motors (three to a bus) behind the decorator, one loop ---------- */

static struct {
	struct rig_loop io; /* configuration, sim setup, plan, the sim buses as opened */
	struct rmd_bus_wrap tb[RMD_MAX_BUSES];
	enum tamper how;
	struct rmd_bus bus[RMD_MAX_BUSES]; /* what the loop drives */
	struct rmd_loop *l;
	struct rmd_bringup bu;
} R;
/* when set, rig_up() hands it the simulated motors' setup before it opens the buses */
static void (*rig_sim_tweak)(struct rmd_sim_setup *sim);
/* when set, rig_up() hands it the configuration and the simulated motors' setup, first */
static void (*rig_cfg_tweak)(struct rmd_config *cfg, struct rmd_sim_setup *sim);

static void rig_up(unsigned n, enum tamper how, const struct rmd_sim_fault *faults,
		   unsigned n_faults)
{
	struct rmd_loop_opts o;
	char err[1024];

	memset(&R, 0, sizeof(R));
	sent_log = false;
	sent_n = 0;
	R.how = how;
	t_now = 1000 * MS;
	assert_int_equal(rmd_config_sim_default(&R.io.cfg, &R.io.sim, n), 0);
	if (n_faults)
		memcpy(R.io.sim.buses[0].faults, faults, n_faults * sizeof(*faults));
	R.io.sim.buses[0].n_faults = n_faults;
	if (rig_cfg_tweak)
		rig_cfg_tweak(&R.io.cfg, &R.io.sim);
	if (rig_sim_tweak)
		rig_sim_tweak(&R.io.sim);
	if (rmd_plan_build(&R.io.cfg, &R.io.plan, err, sizeof(err)))
		fail_msg("plan: %s", err);
	rig_open_buses(&R.io.cfg, &R.io.sim, R.io.buses);
	for (unsigned b = 0; b < R.io.cfg.n_buses; b++) {
		R.tb[b] = (struct rmd_bus_wrap){ .inner = &R.io.buses[b], .ctx = &R.how };
		rmd_bus_wrap_init(&R.bus[b], &tamper_ops, &R.tb[b]);
	}
	assert_int_equal(rig_loop_opts(&R.io, &o), 0);
	o.buses = R.bus;
	R.l = rmd_loop_new(&o, err, sizeof(err));
	if (!R.l)
		fail_msg("rmd_loop_new: %s", err);
}

/* rig_up(n, TAMPER_NONE, NULL, 0) with tweak handed the configuration and simulators. */
static void rig_up_tweaked(unsigned n, void (*tweak)(struct rmd_config *, struct rmd_sim_setup *))
{
	rig_cfg_tweak = tweak;
	rig_up(n, TAMPER_NONE, NULL, 0);
	rig_cfg_tweak = NULL;
}

/* n of the loop's cycles, a period apart on the rig's clock. */
static void cycles(unsigned n)
{
	for (unsigned k = 0; k < n; k++) {
		t_now += R.io.plan.period_ns;
		rmd_loop_cycle(R.l, t_now);
	}
}

/* The loop's cycles, a period apart, until the rig's clock reaches t_ns. */
static void cycle_until(int64_t t_ns)
{
	while (t_now < t_ns) {
		t_now += R.io.plan.period_ns;
		rmd_loop_cycle(R.l, t_now);
	}
}

static void rig_down(void)
{
	rmd_loop_free(R.l);
	for (unsigned b = 0; b < R.io.cfg.n_buses; b++) {
		rmd_bus_close(&R.bus[b]);
		rmd_bus_close(&R.io.buses[b]);
	}
}

/* ---- bring-up's values --------------------------------------------------------------- */

static void test_found(void **state)
{
	(void)state;
	rig_up(4, TAMPER_NONE, NULL, 0);
	assert_int_equal(rmd_loop_bringup(R.l, &R.bu), 0);
	assert_int_equal(R.bu.n_motors, 4);
	assert_int_equal(R.bu.n_buses, 2);
	assert_int_equal(R.bu.missing, 0);
	assert_int_equal(R.bu.comm_loss_ms, R.io.cfg.safety.comm_loss_ms);
	for (unsigned i = 0; i < 4; i++)
		rig_assert_default_motor(&R.bu.motor[i]);
	assert_int_equal(R.bu.unexpected_ids[0], 0);
	assert_int_equal(R.bu.unexpected_ids[1], 0);
	rig_down();
}

/* Motor 2 gone, motor 3 reporting low voltage, motor 9 answering unconfigured. */
static void test_missing_fault_unexpected(void **state)
{
	const struct rmd_sim_fault faults[] = {
		{ .kind = RMD_SIM_FAULT_DISAPPEAR, .motor_id = 2 },
		{ .kind = RMD_SIM_FAULT_ERROR_FLAG,
		  .motor_id = 3,
		  .param = RMD_SIM_ERR_LOW_VOLTAGE },
	};
	struct rmd_sim_motor_params p;

	(void)state;
	rig_up(3, TAMPER_NONE, faults, 2);
	rmd_sim_motor_params_default(&p, 9, RMD_PROTO_V3);
	assert_true(rmd_sim_wire_add_motor(rmd_bus_sim_get(&R.io.buses[0]), &p, 0) >= 0);
	/* on_missing: refuse still refuses, and says what it found all the same */
	assert_int_equal(rmd_loop_bringup(R.l, &R.bu), -ENODEV);
	assert_int_equal(R.bu.missing, 1);
	assert_int_equal(R.bu.motor[0].state, RMD_BRINGUP_FOUND);
	assert_int_equal(R.bu.motor[1].state, RMD_BRINGUP_MISSING);
	assert_int_equal(R.bu.motor[1].probe_cmd, 0xB5);
	assert_int_equal(R.bu.motor[1].tries, RMD_LOOP_PROBE_TRIES);
	assert_int_equal(R.bu.motor[1].timeout_ns, RMD_LOOP_PROBE_TIMEOUT_NS);
	assert_int_equal(R.bu.motor[1].b3, RMD_B3_NOT_APPLICABLE);
	assert_int_equal(R.bu.motor[2].state, RMD_BRINGUP_FAULT);
	assert_int_equal(R.bu.motor[2].error_code & RMD_SIM_ERR_LOW_VOLTAGE,
			 RMD_SIM_ERR_LOW_VOLTAGE);
	assert_int_equal(R.bu.motor[2].b3, RMD_B3_SET);
	assert_int_equal(R.bu.unexpected_ids[0], 1u << (9 - 1));
	rig_down();
}

/* Every 0xB3 outcome: the motors are found all the same. */
static void test_b3_outcomes(void **state)
{
	static const struct {
		enum tamper how;
		uint32_t comm_loss_ms;
		enum rmd_bringup_b3 want;
	} cases[] = {
		{ TAMPER_NONE, 100, RMD_B3_SET },    { TAMPER_DROP, 100, RMD_B3_NO_ANSWER },
		{ TAMPER_ZEROS, 100, RMD_B3_ZEROS }, { TAMPER_DIFFER, 100, RMD_B3_DIFFERS },
		{ TAMPER_ZEROS, 0, RMD_B3_SET }, /* writing 0 is answered by zeros */
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		/* issue 13: probe.on_missing refuse counts a motor not armed as missing */
		bool unarmed = cases[k].want == RMD_B3_NO_ANSWER || cases[k].want == RMD_B3_DIFFERS;

		rig_up(2, cases[k].how, NULL, 0);
		R.io.cfg.safety.comm_loss_ms = cases[k].comm_loss_ms;
		assert_int_equal(rmd_loop_bringup(R.l, &R.bu), unarmed ? -ENODEV : 0);
		assert_int_equal(R.bu.unarmed, unarmed ? 2 : 0);
		assert_int_equal(R.bu.missing, 0);
		assert_int_equal(R.bu.comm_loss_ms, cases[k].comm_loss_ms);
		for (unsigned i = 0; i < 2; i++) {
			if (R.bu.motor[i].b3 != cases[k].want)
				fail_msg("case %zu motor %u: 0xB3 outcome %d, want %d", k, i,
					 (int)R.bu.motor[i].b3, (int)cases[k].want);
			assert_int_equal(R.bu.motor[i].state, RMD_BRINGUP_FOUND);
		}
		rig_down();
	}
}

/* ---- the contract -------------------------------------------------------------------- */

/* A decorator forwards state, stats and next_due_ns: nothing is copied back. */
static void test_decorator_forwards(void **state)
{
	struct rmd_frame f = { .can_id = 0x141, .len = 8, .data = { 0x9A } };

	(void)state;
	rig_up(1, TAMPER_NONE, NULL, 0);
	assert_int_equal(rmd_bus_send(&R.bus[0], &f, 1, t_now), 1);
	assert_ptr_equal(rmd_bus_stats(&R.bus[0]), &R.io.buses[0].stats);
	assert_int_equal(rmd_bus_stats(&R.bus[0])->tx_frames, 1);
	assert_int_equal(rmd_bus_state(&R.bus[0]), RMD_BUS_ACTIVE);
	assert_int_equal(rmd_bus_next_due_ns(&R.bus[0]), INT64_MAX);
	rig_down();
}

/* The sim bus: a CAN bus in a box; the other transports' accessors refuse it. */
static void test_sim_caps_and_accessors(void **state)
{
	struct rmd_frame f = { .can_id = 0x141, .len = 8, .data = { 0x9A } };
	struct rmd_rs485_stats xs;
	struct rmd_bus bus;
	char err[256];

	(void)state;
	assert_int_equal(rmd_bus_open_spec(&bus, "sim:1", NULL, err, sizeof(err)), 0);
	assert_false(rmd_bus_caps(&bus)->half_duplex);
	assert_int_equal(rmd_bus_caps(&bus)->reply_timeout_ns, 0);
	assert_int_equal(rmd_bus_caps(&bus)->request_spacing_ns, RMD_BUS_CAN_SPACING_NS);
	assert_int_equal(rmd_bus_caps(&bus)->queue_len, 0);
	assert_int_equal(rmd_bus_next_due_ns(&bus), INT64_MAX);
	assert_int_equal(rmd_bus_send(&bus, &f, 1, 1000 * MS), 1);
	assert_int_equal(rmd_bus_next_due_ns(&bus), INT64_MAX);
	assert_non_null(rmd_bus_sim_get(&bus));
	assert_int_equal(rmd_rs485_stats(&bus, &xs), -EINVAL);
	assert_int_equal(rmd_socketcan_rcvbuf(&bus), -EINVAL);
	rmd_bus_close(&bus);
}

/* A config entry and the spec that names the same bus open the same bus. */
static void test_open_config_equals_spec(void **state)
{
	static const uint8_t ids[] = { 1, 2, 3, 7 };
	struct rmd_bus_open_opts o = { .proto = RMD_PROTO_V2, .sim_bitrate = 500000 };
	struct rmd_bus_open_motor motors[4];
	struct rmd_sim_bus_setup sim = { .host_fifo = true };
	struct rmd_bus_open_ctx ctx = { .motors = motors, .n_motors = 4, .sim = &sim };
	struct rmd_config_bus cb = { .kind = RMD_BUS_KIND_SIM, .bitrate = 500000 };
	struct rmd_config_bus parsed;
	struct rmd_bus a, b;
	uint8_t got[RMD_MAX_MOTORS];
	struct rmd_sim_wire *sa, *sb;
	char err[256];

	(void)state;
	snprintf(cb.name, sizeof(cb.name), "sim:1-3,7");
	for (unsigned i = 0; i < 4; i++)
		motors[i] = (struct rmd_bus_open_motor){ .id = ids[i], .proto = RMD_PROTO_V2 };
	/* the spec parses into that entry */
	assert_int_equal(rmd_bus_spec_parse("sim:1-3,7", &o, &parsed, got, err, sizeof(err)), 4);
	assert_int_equal(parsed.kind, RMD_BUS_KIND_SIM);
	assert_string_equal(parsed.name, cb.name);
	assert_int_equal(parsed.bitrate, cb.bitrate);
	assert_memory_equal(got, ids, sizeof(ids));

	assert_int_equal(rmd_bus_open(&a, &cb, &ctx, err, sizeof(err)), 0);
	assert_int_equal(rmd_bus_open_spec(&b, "sim:1-3,7", &o, err, sizeof(err)), 0);
	assert_ptr_equal(a.ops, b.ops);
	assert_string_equal(a.name, b.name);
	assert_memory_equal(&a.caps, &b.caps, sizeof(a.caps));
	sa = rmd_bus_sim_get(&a);
	sb = rmd_bus_sim_get(&b);
	assert_int_equal(sa->bitrate, sb->bitrate);
	assert_int_equal(sa->flags, sb->flags);
	assert_int_equal(sa->seed, sb->seed);
	assert_int_equal(sa->n_motors, sb->n_motors);
	for (unsigned i = 0; i < sa->n_motors; i++) {
		assert_int_equal(sa->motors[i].p.id, sb->motors[i].p.id);
		assert_int_equal(sa->motors[i].p.proto, RMD_PROTO_V2);
		assert_int_equal(sb->motors[i].p.proto, RMD_PROTO_V2);
	}
	rmd_bus_close(&a);
	rmd_bus_close(&b);

	/* the spec's errors come from the one parser */
	assert_int_equal(rmd_bus_spec_parse("sim:0-3", NULL, &parsed, got, err, sizeof(err)),
			 -EINVAL);
	assert_non_null(strstr(err, "bad motor list"));
	assert_int_equal(rmd_bus_spec_parse("can0", NULL, &parsed, got, err, sizeof(err)), 0);
	assert_int_equal(parsed.kind, RMD_BUS_KIND_SOCKETCAN);
	assert_string_equal(parsed.interface, "can0");
	assert_int_equal(rmd_bus_spec_parse("/dev/ttyX", NULL, &parsed, got, err, sizeof(err)), 0);
	assert_int_equal(parsed.kind, RMD_BUS_KIND_RS485);
	assert_string_equal(parsed.device, "/dev/ttyX");
}

/* The planner's wire rule per transport comes from the bus layer. */
static void test_config_timing(void **state)
{
	struct rmd_config_bus can = { .kind = RMD_BUS_KIND_SOCKETCAN, .bitrate = 1000000 };
	struct rmd_config_bus rs = { .kind = RMD_BUS_KIND_RS485,
				     .baud = 115200,
				     .turnaround_ns = 1500000 };
	struct rmd_bus_timing t;

	(void)state;
	assert_int_equal(rmd_bus_config_timing(&can, &t), 0);
	assert_int_equal(t.bitrate, 1000000);
	assert_int_equal(t.frame_bits, 135); /* docs/design.md: worst-case stuffed 8-byte frame */
	assert_int_equal(t.turnaround_ns, 0);
	assert_false(t.half_duplex);
	assert_int_equal(rmd_bus_config_timing(&rs, &t), 0);
	assert_int_equal(t.bitrate, 115200);
	assert_int_equal(t.frame_bits, 130); /* 13 bytes, 8N1 */
	assert_int_equal(t.turnaround_ns, 1500000);
	assert_true(t.half_duplex);
}

/*
 * Motor 1 kept a 1 ms protection in ROM from an earlier run: armed by its
 * probe, it trips while bring-up scans the bus, so it only echoes the
 * first command it gets next, and 0xB3's answer is its echo.  The status
 * read that goes first takes the echo: the write is done and its echo is
 * the motor's, the ROM holds the configured time (commit f3bb014; without
 * the read, 0xB3 was reported set while the ROM kept 1 ms).
 */
static void rom_1ms_motor1(struct rmd_sim_setup *sim)
{
	sim->motors[0].comm_loss_rom_ms = 1;
}

static void test_b3_after_trip(void **state)
{
	const struct rmd_sim_motor *m;

	(void)state;
	rig_sim_tweak = rom_1ms_motor1;
	rig_up(3, TAMPER_NONE, NULL, 0);
	rig_sim_tweak = NULL;
	m = rmd_sim_wire_motor(rmd_bus_sim_get(&R.io.buses[0]), 1);
	assert_int_equal(m->rom.comm_timeout_ms, 1);
	assert_int_equal(rmd_loop_bringup(R.l, &R.bu), 0);
	for (unsigned i = 0; i < 3; i++) {
		m = rmd_sim_wire_motor(rmd_bus_sim_get(&R.io.buses[R.io.cfg.motors[i].bus]),
				       R.io.cfg.motors[i].id);
		assert_int_equal(R.bu.motor[i].b3, RMD_B3_SET);
		if (m->rom.comm_timeout_ms != R.io.cfg.safety.comm_loss_ms)
			fail_msg(
				"motor %u: ROM keeps %u ms, configured %u: its echo passed for the write",
				i + 1, m->rom.comm_timeout_ms, R.io.cfg.safety.comm_loss_ms);
	}
	rig_down();
}

/* ---- protocol: auto ----------------------------------------------------------------- */

/*
 * Motors 1 and 2 `protocol: auto`, their simulated firmware V3 and V2 (with
 * comm_loss_ms 0, as a V2 motor needs); motor 3 v3 as configured.
 */
static void tweak_auto(struct rmd_config *cfg, struct rmd_sim_setup *sim)
{
	cfg->motors[0].proto_auto = true;
	cfg->motors[1].proto_auto = true;
	cfg->motors[1].comm_loss_ms = 0;
	sim->motors[1].proto = RMD_PROTO_V2;
}

/* Motor 1 auto on V4 firmware; motor 2 v3 as configured, but on V4 firmware. */
static void tweak_v4(struct rmd_config *cfg, struct rmd_sim_setup *sim)
{
	cfg->motors[0].proto_auto = true;
	sim->motors[0].proto = RMD_PROTO_V4;
	sim->motors[1].proto = RMD_PROTO_V4;
}

/* The V2 motor of tweak_auto(), its comm_loss_ms left at the default (not 0). */
static void tweak_auto_v2_protected(struct rmd_config *cfg, struct rmd_sim_setup *sim)
{
	cfg->motors[1].proto_auto = true;
	sim->motors[1].proto = RMD_PROTO_V2;
}

static void test_auto_picks_each_dialect(void **state)
{
	struct rmd_snapshot s;

	(void)state;
	rig_up_tweaked(3, tweak_auto);
	assert_int_equal(rmd_loop_bringup(R.l, &R.bu), 0);
	/* motor 1: V3 firmware dated 20220206, a date that tells */
	assert_true(R.bu.motor[0].proto_auto);
	assert_int_equal(R.bu.motor[0].proto, RMD_PROTO_V3);
	assert_true(R.bu.motor[0].auto_certain);
	rig_assert_default_motor(&R.bu.motor[0]);
	/* motor 2: no answer to 0xB5 on 0x240 + ID, its V2 status on 0x140 + ID */
	assert_true(R.bu.motor[1].proto_auto);
	assert_int_equal(R.bu.motor[1].proto, RMD_PROTO_V2);
	assert_int_equal(R.bu.motor[1].state, RMD_BRINGUP_FOUND);
	assert_true(R.bu.motor[1].status);
	assert_int_equal(R.bu.motor[1].b3, RMD_B3_NOT_APPLICABLE);
	/* motor 3: as configured */
	assert_false(R.bu.motor[2].proto_auto);
	assert_int_equal(R.bu.motor[2].proto, RMD_PROTO_V3);
	assert_int_equal(R.bu.mismatched, 0);
	assert_int_equal(R.bu.missing, 0);
	/* the loop takes each motor's answers on its dialect's identifiers */
	cycles(300);
	rmd_loop_get_snapshot(R.l, &s);
	for (unsigned k = 0; k < 3; k++)
		if (s.m[k].lifecycle != RMD_LC_READY || s.m[k].reply_age_cycles > 200 ||
		    s.m[k].missed_replies)
			fail_msg("motor %u: lifecycle %u, last reply %u cycles ago, %llu missed",
				 k + 1, s.m[k].lifecycle, s.m[k].reply_age_cycles,
				 (unsigned long long)s.m[k].missed_replies);
	rig_down();
}

static void test_auto_v4_and_a_mismatch(void **state)
{
	struct rmd_snapshot s;

	(void)state;
	rig_up_tweaked(3, tweak_v4);
	R.io.cfg.probe.on_missing = RMD_MISSING_START;
	/*
	 * a previous owner left motor 2 running: brake released (0x77), 100 dps
	 * (0xA2), and pushing its status (V4.2 §2.33: 0x9A every 50 ms)
	 */
	{
		struct rmd_frame f[3] = {
			{ .can_id = RMD_CAN_REQ_BASE + 2, .len = 8, .data = { 0x77 } },
			{ .can_id = RMD_CAN_REQ_BASE + 2,
			  .len = 8,
			  .data = { 0xA2, 0, 0, 0, 0x10, 0x27 } },
			{ .can_id = RMD_CAN_REQ_BASE + 2,
			  .len = 8,
			  .data = { 0xB6, 0x9A, 1, 5, 0 } },
		};
		const struct rmd_sim_motor *m;

		struct rmd_bus_rx rx[8];

		assert_int_equal(rmd_bus_send(&R.io.buses[0], f, 3, t_now), 3);
		for (unsigned k = 0; k < 10; k++) { /* the sim bus's time moves with its calls */
			t_now += MS;
			rmd_bus_recv(&R.io.buses[0], rx, 8, t_now);
		}
		m = rmd_sim_wire_motor(rmd_bus_sim_get(&R.io.buses[0]), 2);
		assert_int_equal(m->ctrl, RMD_SIM_SPEED);
		assert_false(m->brake_locked);
	}
	assert_int_equal(rmd_loop_bringup(R.l, &R.bu), -EPROTO);
	/* motor 1: its 0xB2 says a date after V4.2's, and the yyyymmddNN form */
	assert_int_equal(R.bu.motor[0].proto, RMD_PROTO_V4);
	assert_true(R.bu.motor[0].auto_certain);
	assert_int_equal(R.bu.motor[0].version, 2025070202);
	assert_int_equal(R.bu.motor[0].state, RMD_BRINGUP_FOUND);
	assert_int_equal(R.bu.motor[0].b3, RMD_B3_SET);
	/* motor 2: protocol v3, firmware V4: refused, never driven */
	assert_int_equal(R.bu.motor[1].state, RMD_BRINGUP_MISMATCH);
	/* ... and stopped, in case a previous owner left it running: output off, brake locked */
	{
		const struct rmd_sim_motor *m =
			rmd_sim_wire_motor(rmd_bus_sim_get(&R.io.buses[0]), 2);

		assert_non_null(m);
		assert_int_equal(m->ctrl, RMD_SIM_OFF);
		assert_true(m->brake_locked);
	}
	assert_int_equal(R.bu.motor[1].mismatch, RMD_BRINGUP_MISMATCH_FIRMWARE);
	assert_int_equal(R.bu.mismatched, 1);
	rmd_loop_get_snapshot(R.l, &s);
	assert_int_equal(s.m[1].lifecycle, RMD_LC_LOST);
	assert_int_equal(s.m[0].lifecycle, RMD_LC_READY);
	assert_int_equal(s.m[2].lifecycle, RMD_LC_READY);
	/* what it pushes never brings it back: nothing goes to it */
	sent_log = true;
	cycles(500);
	rmd_loop_get_snapshot(R.l, &s);
	assert_int_equal(s.m[1].lifecycle, RMD_LC_LOST);
	for (unsigned k = 0; k < sent_n; k++)
		if (sent[k].id == RMD_CAN_REQ_BASE + 2)
			fail_msg("0x%02X sent to motor 2, refused at bring-up", sent[k].cmd);
	rig_down();
}

/* Three V4 motors, as configured. */
static void tweak_all_v4(struct rmd_config *cfg, struct rmd_sim_setup *sim)
{
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		cfg->motors[i].proto = RMD_PROTO_V4;
		sim->motors[i].proto = RMD_PROTO_V4;
	}
}

/*
 * V4.2 §2.33: motor 1 was left by another tool pushing 0x9C every 20 ms and
 * 0x92 every 30 ms (and not answering those reads).  Bring-up sees it,
 * turns every push off, and the loop runs it with nothing unexpected.
 */
static void test_active_reply_left_on(void **state)
{
	struct rmd_bus_rx rx[16];
	struct rmd_frame f[2] = {
		{ .can_id = RMD_CAN_REQ_BASE + 1, .len = 8, .data = { 0xB6, 0x9C, 1, 2, 0 } },
		{ .can_id = RMD_CAN_REQ_BASE + 1, .len = 8, .data = { 0xB6, 0x92, 1, 3, 0 } },
	};
	const struct rmd_sim_motor *m;
	struct rmd_loop_counters c;
	struct rmd_snapshot s;
	unsigned pushed = 0;

	(void)state;
	rig_up_tweaked(3, tweak_all_v4);
	assert_int_equal(rmd_bus_send(&R.io.buses[0], f, 2, t_now), 2);
	for (unsigned k = 0; k < 100; k++) { /* 100 ms of the sim bus: pushes come */
		int n;

		t_now += MS;
		n = rmd_bus_recv(&R.io.buses[0], rx, 16, t_now);
		for (int j = 0; j < n; j++)
			pushed += rx[j].f.can_id == RMD_CAN_V3_REPLY_BASE + 1;
	}
	if (pushed < 5)
		fail_msg("the simulated motor pushed %u replies in 100 ms", pushed);
	assert_int_equal(rmd_loop_bringup(R.l, &R.bu), 0);
	assert_int_equal(R.bu.motor[0].state, RMD_BRINGUP_FOUND);
	assert_true(R.bu.motor[0].reports_off);
	for (unsigned i = 0; i < 3; i++)
		assert_int_equal(R.bu.motor[i].b3, RMD_B3_SET);
	m = rmd_sim_wire_motor(rmd_bus_sim_get(&R.io.buses[0]), 1);
	for (unsigned k = 0; k < RMD_DIALECT_REPORTS_MAX; k++)
		if (m->report_steps[k])
			fail_msg("0x%02X still pushed after bring-up", m->d->report_cmds[k]);
	cycles(300);
	rmd_loop_get_counters(R.l, &c);
	rmd_loop_get_snapshot(R.l, &s);
	if (c.unexpected || c.missed || s.m[0].lifecycle != RMD_LC_READY)
		fail_msg("after bring-up: unexpected %llu, missed %llu, motor 1 lifecycle %u",
			 (unsigned long long)c.unexpected, (unsigned long long)c.missed,
			 s.m[0].lifecycle);
	rig_down();
}

static void test_auto_v2_with_protection_is_refused(void **state)
{
	struct rmd_snapshot s;

	(void)state;
	rig_up_tweaked(3, tweak_auto_v2_protected);
	/* whatever probe.on_missing says: the configuration must change */
	R.io.cfg.probe.on_missing = RMD_MISSING_START;
	assert_int_equal(rmd_loop_bringup(R.l, &R.bu), -EPROTO);
	assert_int_equal(R.bu.mismatched, 1);
	assert_int_equal(R.bu.motor[1].state, RMD_BRINGUP_MISMATCH);
	assert_int_equal(R.bu.motor[1].mismatch, RMD_BRINGUP_MISMATCH_NO_COMM_LOSS);
	assert_int_equal(R.bu.motor[1].proto, RMD_PROTO_V2);
	assert_int_equal(R.bu.motor[0].state, RMD_BRINGUP_FOUND);
	rmd_loop_get_snapshot(R.l, &s);
	assert_int_equal(s.m[1].lifecycle, RMD_LC_LOST);
	rig_down();
}

/*
 * Motors 1 (V3 firmware) and 2 (V4), both `protocol: auto`, and 3, a v3
 * entry on V4 firmware, all powered only 2 s after bring-up began (the
 * window is the sim bus's time, which begins with it).
 */
static void tweak_auto_late(struct rmd_config *cfg, struct rmd_sim_setup *sim)
{
	cfg->probe.on_missing = RMD_MISSING_START;
	cfg->motors[0].proto_auto = true;
	cfg->motors[1].proto_auto = true;
	sim->motors[1].proto = RMD_PROTO_V4;
	sim->motors[2].proto = RMD_PROTO_V4;
	for (unsigned k = 0; k < 3; k++)
		sim->buses[0].faults[k] = (struct rmd_sim_fault){ .kind = RMD_SIM_FAULT_DISAPPEAR,
								  .motor_id = (uint8_t)(k + 1),
								  .start_ns = 0,
								  .end_ns = 2000 * MS };
	sim->buses[0].n_faults = 3;
}

/*
 * Motors missing at bring-up: the loop asks each its firmware date (0xB2)
 * (behind a status read 0x9A) when it answers at last, as bring-up would
 * have.  The V3 one comes up; the V4 ones -- taken for V3 by `protocol:
 * auto`, or a v3 entry -- are left out, reported, and get nothing but
 * those two reads on the wire: they are never driven as V3.
 */
static void test_auto_missing_then_found(void **state)
{
	struct rmd_snapshot s;
	struct rmd_event e;
	unsigned dialect_events = 0;

	(void)state;
	rig_up_tweaked(3, tweak_auto_late);
	assert_int_equal(rmd_loop_bringup(R.l, &R.bu), 0);
	assert_int_equal(R.bu.missing, 3);
	sent_log = true;
	cycle_until(4000 * MS);
	rmd_loop_get_snapshot(R.l, &s);
	assert_int_equal(s.m[0].lifecycle, RMD_LC_READY);
	assert_int_equal(s.m[1].lifecycle, RMD_LC_LOST);
	assert_int_equal(s.m[2].lifecycle, RMD_LC_LOST);
	while (rmd_ring_pop(&R.io.events, &e)) {
		if (e.kind != RMD_EV_DIALECT)
			continue;
		dialect_events++;
		assert_true(e.motor == 1 || e.motor == 2);
		assert_int_equal(e.a, 2025070202);
		assert_int_equal(e.b, RMD_PROTO_V4);
	}
	assert_int_equal(dialect_events, 2);
	{
		unsigned b2[3] = { 0, 0, 0 }, st[3] = { 0, 0, 0 }, other[3] = { 0, 0, 0 };

		for (unsigned k = 0; k < sent_n; k++)
			for (unsigned i = 0; i < 3; i++)
				if (sent[k].id == RMD_CAN_REQ_BASE + i + 1) {
					b2[i] += sent[k].cmd == 0xB2;
					st[i] += sent[k].cmd == 0x9A;
					other[i] += sent[k].cmd != 0xB2 && sent[k].cmd != 0x9A;
				}
		/* motor 1: asked its date, then run as any motor that came back */
		if (!b2[0] || !other[0])
			fail_msg("motor 1: %u 0xB2, %u other frames", b2[0], other[0]);
		/* motors 2 and 3: their date asked until they answered, then nothing more */
		for (unsigned i = 1; i < 3; i++)
			if (!b2[i] || st[i] != b2[i] || other[i])
				fail_msg(
					"motor %u (V4 firmware): %u 0xB2, %u 0x9A, %u other frames "
					"sent to it",
					i + 1, b2[i], st[i], other[i]);
	}
	rig_down();
}

/* Motor 1 `protocol: auto` (comm_loss_ms 0) on V2 firmware, powered 2 s late. */
static void tweak_auto_v2_late(struct rmd_config *cfg, struct rmd_sim_setup *sim)
{
	cfg->probe.on_missing = RMD_MISSING_START;
	cfg->motors[0].proto_auto = true;
	cfg->motors[0].comm_loss_ms = 0;
	sim->motors[0].proto = RMD_PROTO_V2;
	sim->buses[0].faults[0] = (struct rmd_sim_fault){
		.kind = RMD_SIM_FAULT_DISAPPEAR, .motor_id = 1, .start_ns = 0, .end_ns = 2000 * MS
	};
	sim->buses[0].n_faults = 1;
}

/*
 * A `protocol: auto` motor found late on V2 firmware: V2 has no firmware
 * date, but its status answer comes on 0x140 + ID, which tells.  It is
 * left out, reported once, not counted as unexpected frames, and no more
 * is sent to it.
 */
static void test_auto_v2_found_late(void **state)
{
	struct rmd_loop_counters c;
	struct rmd_snapshot s;
	struct rmd_event e;
	unsigned dialect_events = 0, after = 0;

	(void)state;
	rig_up_tweaked(3, tweak_auto_v2_late);
	assert_int_equal(rmd_loop_bringup(R.l, &R.bu), 0);
	assert_int_equal(R.bu.missing, 1);
	cycle_until(4000 * MS);
	while (rmd_ring_pop(&R.io.events, &e))
		if (e.kind == RMD_EV_DIALECT) {
			dialect_events++;
			assert_int_equal(e.motor, 0);
			assert_int_equal(e.a, 0);
			assert_int_equal(e.b, RMD_PROTO_V2);
		}
	assert_int_equal(dialect_events, 1);
	rmd_loop_get_snapshot(R.l, &s);
	assert_int_equal(s.m[0].lifecycle, RMD_LC_LOST);
	rmd_loop_get_counters(R.l, &c);
	assert_int_equal(c.unexpected, 0);
	sent_log = true;
	cycle_until(5000 * MS);
	for (unsigned k = 0; k < sent_n; k++)
		after += sent[k].id == RMD_CAN_REQ_BASE + 1;
	if (after)
		fail_msg("%u frames sent to motor 1 after it was left out", after);
	rig_down();
}

/*
 * Three V4 motors; motor 1 left by another tool pushing 0x9C every 20 ms
 * (V4.2 §2.33), its cable cut for the first 2 s of the sim bus's time.
 */
static void tweak_v4_pushing_late(struct rmd_config *cfg, struct rmd_sim_setup *sim)
{
	tweak_all_v4(cfg, sim);
	cfg->probe.on_missing = RMD_MISSING_START;
	sim->motors[0].active_reply_9c_ms = 20;
	sim->buses[0].faults[0] = (struct rmd_sim_fault){
		.kind = RMD_SIM_FAULT_DISAPPEAR, .motor_id = 1, .start_ns = 0, .end_ns = 2000 * MS
	};
	sim->buses[0].n_faults = 1;
}

/*
 * A V4 motor that comes back during the run gets bring-up's 0xB6 offs: it
 * stops pushing 0x9C and answers the loop's reads again, READY for good.
 */
static void test_v4_back_reports_off(void **state)
{
	struct rmd_loop_counters c0, c1;
	struct rmd_snapshot s;
	struct rmd_event e;
	unsigned offs = 0, lost = 0;
	const struct rmd_sim_motor *m;

	(void)state;
	rig_up_tweaked(3, tweak_v4_pushing_late);
	assert_int_equal(rmd_loop_bringup(R.l, &R.bu), 0);
	assert_int_equal(R.bu.motor[0].state, RMD_BRINGUP_MISSING);
	sent_log = true;
	/* the window is the sim bus's time, which began with bring-up: it is back at 3 s */
	cycle_until(4000 * MS);
	m = rmd_sim_wire_motor(rmd_bus_sim_get(&R.io.buses[0]), 1);
	for (unsigned k = 0; k < RMD_DIALECT_REPORTS_MAX; k++)
		if (m->report_steps[k])
			fail_msg("motor 1 still pushes 0x%02X", m->d->report_cmds[k]);
	for (unsigned k = 0; k < sent_n; k++)
		offs += sent[k].id == RMD_CAN_REQ_BASE + 1 && sent[k].cmd == 0xB6;
	assert_int_equal(offs, m->d->n_report_cmds);
	/* from now on every read is answered, and it stays */
	rmd_loop_get_counters(R.l, &c0);
	while (rmd_ring_pop(&R.io.events, &e))
		;
	cycle_until(5000 * MS);
	rmd_loop_get_counters(R.l, &c1);
	while (rmd_ring_pop(&R.io.events, &e))
		lost += e.kind == RMD_EV_MOTOR_STATE && e.b == RMD_LC_LOST;
	rmd_loop_get_snapshot(R.l, &s);
	if (s.m[0].lifecycle != RMD_LC_READY || c1.missed != c0.missed || lost)
		fail_msg("motor 1: lifecycle %u, %llu missed, lost %u times in the last second",
			 s.m[0].lifecycle, (unsigned long long)(c1.missed - c0.missed), lost);
	rig_down();
}

/* ---- slow answers (issue 21) ---------------------------------------------------------- */

/* Motors that answer 8 ms late, a 5 ms try, 50 Hz: every probe is tried twice. */
static void tweak_slow(struct rmd_config *cfg, struct rmd_sim_setup *sim)
{
	cfg->loop.rate_hz = 50;
	cfg->safety.comm_loss_ms = 200;
	cfg->safety.command_timeout_ms = 200;
	cfg->probe.reply_timeout_ms = 5;
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		cfg->motors[i].status_poll_hz = 10;
		sim->motors[i].turnaround_ns = 8 * MS;
		sim->motors[i].turnaround_jitter_ns = 0;
	}
}

/* Motors that answer 20 ms late: a bring-up that waits probe.reply_timeout_ms (100). */
static void tweak_20ms(struct rmd_config *cfg, struct rmd_sim_setup *sim)
{
	cfg->loop.rate_hz = 10;
	cfg->safety.comm_loss_ms = 1000;
	cfg->safety.command_timeout_ms = 500;
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		cfg->motors[i].status_poll_hz = 10;
		sim->motors[i].turnaround_ns = 20 * MS;
		sim->motors[i].turnaround_jitter_ns = 0;
	}
}

static void test_slow_motors_are_found_and_measured(void **state)
{
	(void)state;
	rig_up_tweaked(2, tweak_20ms);
	assert_int_equal(rmd_loop_bringup(R.l, &R.bu), 0);
	for (unsigned i = 0; i < 2; i++) {
		assert_int_equal(R.bu.motor[i].state, RMD_BRINGUP_FOUND);
		assert_int_equal(R.bu.motor[i].b3, RMD_B3_SET);
	}
	/* the round trip the motors took, measured: 20 ms and the frames' wire time */
	assert_true(R.bu.bus[0].n >= 4);
	assert_true(R.bu.bus[0].rtt_min_ns >= 20 * MS);
	assert_true(R.bu.bus[0].rtt_max_ns < 21 * MS);
	assert_false(R.bu.bus[0].exceeds_period); /* 100 ms at 10 Hz */
	rig_down();
}

/*
 * Bring-up's earlier try answered after it gave up, then the loop: the
 * answer is counted late, never unexpected.
 */
static void test_late_answers_of_bringup_are_late(void **state)
{
	struct rmd_loop_counters c;

	(void)state;
	rig_up_tweaked(2, tweak_slow);
	assert_int_equal(rmd_loop_bringup(R.l, &R.bu), 0);
	/* an answer to an earlier try is no measure of a later request's round trip */
	if (R.bu.bus[0].n && R.bu.bus[0].rtt_min_ns < 8 * MS)
		fail_msg("round trip %.2f .. %.2f ms (%u answers at their first try): the motors "
			 "answer 8 ms late",
			 (double)R.bu.bus[0].rtt_min_ns / 1e6, (double)R.bu.bus[0].rtt_max_ns / 1e6,
			 R.bu.bus[0].n);
	cycles(50);
	rmd_loop_get_counters(R.l, &c);
	if (c.unexpected || !c.late || c.missed)
		fail_msg("unexpected %llu, late %llu (the latest %.1f ms), missed %llu: bring-up's "
			 "retried probes' answers must come as late",
			 (unsigned long long)c.unexpected, (unsigned long long)c.late,
			 (double)c.late_max_ns / 1e6, (unsigned long long)c.missed);
	rig_down();
}

SUITE_MAIN("bringup", NULL, NULL,
	   {
		   cmocka_unit_test(test_found),
		   cmocka_unit_test(test_missing_fault_unexpected),
		   cmocka_unit_test(test_b3_outcomes),
		   cmocka_unit_test(test_decorator_forwards),
		   cmocka_unit_test(test_sim_caps_and_accessors),
		   cmocka_unit_test(test_open_config_equals_spec),
		   cmocka_unit_test(test_config_timing),
		   cmocka_unit_test(test_b3_after_trip),
		   cmocka_unit_test(test_auto_picks_each_dialect),
		   cmocka_unit_test(test_auto_v2_with_protection_is_refused),
		   cmocka_unit_test(test_auto_v4_and_a_mismatch),
		   cmocka_unit_test(test_active_reply_left_on),
		   cmocka_unit_test(test_auto_missing_then_found),
		   cmocka_unit_test(test_auto_v2_found_late),
		   cmocka_unit_test(test_v4_back_reports_off),
		   cmocka_unit_test(test_slow_motors_are_found_and_measured),
		   cmocka_unit_test(test_late_answers_of_bringup_are_late),
	   })
