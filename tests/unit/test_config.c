// SPDX-License-Identifier: MIT
/*
 * Configuration loader: the examples load, defaults apply, and every kind
 * of bad input gives an error that names the file, the line and the key.
 *
 * Data: examples/ and tests/data/config/ under the repository root (the
 * current directory; $RMD_SRCDIR overrides).  Inline cases are written to a
 * temporary file first.
 */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <sys/stat.h>

#include <cmocka.h>

#include "rmd/config.h"
#include "rmd/config_yaml.h"
#include "rmd/motor.h"

#include "harness/proc.h"
#include "harness/suite.h"

#define ERR_LEN 8192

static char srcdir[1024] = ".";
static struct rmd_config cfg; /* large: off the stack */
static struct rmd_sim_setup sim;
static char err[ERR_LEN];

static void path_of(char *out, size_t len, const char *rel)
{
	snprintf(out, len, "%s/%s", srcdir, rel);
}

static int load_rel(const char *rel)
{
	char path[2048];

	path_of(path, sizeof(path), rel);
	return rmd_config_load(path, &cfg, &sim, err, sizeof(err));
}

/* Write yaml to a temporary file named after `tag`, load it. */
static int load_str(const char *tag, const char *yaml)
{
	char path[256];
	int r;

	snprintf(path, sizeof(path), "/tmp/rmd-test-%s-XXXXXX", tag);
	temp_file(path, yaml);
	r = rmd_config_load(path, &cfg, &sim, err, sizeof(err));
	unlink(path);
	return r;
}

static void expect_in(const char *haystack, const char *needle)
{
	if (!strstr(haystack, needle))
		fail_msg("expected \"%s\" in:\n%s", needle, haystack);
}

static const char minimal[] =
	"buses:\n"
	"  - {name: can0, type: socketcan}\n"
	"motors:\n"
	"  - {name: m1, bus: can0, id: 1, mode: torque, torque_constant_nm_a: 2}\n";

/* ------------------------------------------------------------------ */

static void test_examples_load(void **state)
{
	static const char *const files[] = {
		"examples/rmdd.yaml",
		"examples/sim-12.yaml",
		"examples/v2-batch.yaml",
		"examples/rs485.yaml",
		"examples/rs485-rig.yaml",
		"examples/sim-faults.yaml",
		"examples/sim-fine.yaml",
		"examples/physics/leg.yaml",
		"examples/physics/leg-vcan.yaml",
		"tests/data/config/five-per-bus.yaml", /* loads; the planner refuses it */
	};

	(void)state;
	for (size_t i = 0; i < sizeof(files) / sizeof(files[0]); i++) {
		int r = load_rel(files[i]);

		if (r)
			fail_msg("%s: %d:\n%s", files[i], r, err);
		assert_string_equal(err, "");
	}
}

static void test_example_sim12(void **state)
{
	const struct rmd_config_motor *m;

	(void)state;
	assert_int_equal(load_rel("examples/sim-12.yaml"), 0);
	assert_int_equal(cfg.n_buses, 4);
	assert_int_equal(cfg.n_motors, 12);
	for (unsigned b = 0; b < 4; b++) {
		assert_int_equal(cfg.buses[b].kind, RMD_BUS_KIND_SIM);
		assert_int_equal(cfg.buses[b].bitrate, 1000000);
		assert_int_equal(sim.buses[b].seed, b + 1);
	}
	for (unsigned i = 0; i < 12; i++) {
		m = &cfg.motors[i];
		assert_int_equal(m->bus, i / 3);
		assert_int_equal(m->id, i % 3 + 1);
		/* the simulated motor takes the motor's own id and protocol */
		assert_int_equal(sim.motors[i].id, m->id);
		assert_int_equal(sim.motors[i].proto, m->proto);
	}
	m = &cfg.motors[2];
	assert_string_equal(m->name, "fl_knee");
	assert_int_equal(m->proto, RMD_PROTO_MIT);
	assert_int_equal(m->mode, RMD_MODE_MIT);
	assert_int_equal(m->direction, -1);
	/* limits through a YAML alias */
	assert_true(m->limits.torque_nm == 18.0);
	assert_true(m->limits.velocity_rad_s == 20.0);
	assert_true(isinf(m->limits.position_max_rad) && m->limits.position_max_rad > 0);
	m = &cfg.motors[7];
	assert_int_equal(m->proto, RMD_PROTO_V3);
	assert_true(m->torque_constant_nm_a == 2.0);
	assert_true(sim.motors[7].kt_nm_a == 2.0);
	assert_true(sim.motors[7].gear_ratio == 6.0);
	assert_int_equal(cfg.safety.safe_action, RMD_SAFE_DAMP);
	assert_int_equal(rmd_config_motor_find(&cfg, "rr_knee"), 11);
	assert_int_equal(rmd_config_bus_find(&cfg, "rl"), 2);
	assert_int_equal(rmd_config_bus_find(&cfg, "xx"), -ENOENT);
}

static void test_example_rmdd(void **state)
{
	const struct rmd_sim_bus_setup *b;
	const struct rmd_config_motor *m;
	int i;

	(void)state;
	assert_int_equal(load_rel("examples/rmdd.yaml"), 0);
	assert_int_equal(cfg.loop.n_cpus, 1);
	assert_int_equal(cfg.loop.cpus[0], 1);
	i = rmd_config_bus_find(&cfg, "can1");
	assert_true(i >= 0);
	assert_string_equal(cfg.buses[i].interface, "can1"); /* defaults to the name */
	i = rmd_config_bus_find(&cfg, "grip");
	assert_string_equal(cfg.buses[i].interface, "can2");
	i = rmd_config_bus_find(&cfg, "sim0");
	b = &sim.buses[i];
	assert_int_equal(b->n_faults, 2);
	assert_int_equal(b->faults[0].kind, RMD_SIM_FAULT_DROP);
	assert_true(b->faults[0].probability == 0.001);
	assert_int_equal(b->faults[1].kind, RMD_SIM_FAULT_DISAPPEAR);
	assert_int_equal(b->faults[1].start_ns, 30000000000LL);
	assert_int_equal(b->faults[1].end_ns, 31000000000LL);
	assert_int_equal(b->faults[1].param, 1);
	assert_true(b->motor.turnaround_ns == 500000.0);
	i = rmd_config_motor_find(&cfg, "spare");
	assert_true(sim.motors[i].load_nm == 0.5);	  /* the motor's override */
	assert_true(sim.motors[i].inertia_kgm2 == 0.005); /* the bus's model */
	i = rmd_config_motor_find(&cfg, "wrist_pitch");
	m = &cfg.motors[i];
	assert_true(m->mit.t_min == -18.0 && m->mit.t_max == 18.0);
	assert_true(m->mit.kp_max == 500.0);
	i = rmd_config_motor_find(&cfg, "grip_l");
	m = &cfg.motors[i];
	assert_int_equal(m->units, RMD_UNITS_ROTOR);
	assert_int_equal(m->rate_divisor, 2);
	assert_true(m->status_poll_hz == 5.0);
}

static void test_defaults(void **state)
{
	const struct rmd_config_motor *m = &cfg.motors[0];
	const struct rmd_config_bus *b = &cfg.buses[0];

	(void)state;
	assert_int_equal(load_str("defaults", minimal), 0);
	assert_int_equal(cfg.loop.rate_hz, 1000);
	assert_int_equal(cfg.loop.rt_priority, 40);
	assert_int_equal(cfg.loop.n_cpus, 0);
	assert_int_equal(cfg.safety.comm_loss_ms, 100);
	assert_int_equal(cfg.safety.missed_replies_lost, 10);
	assert_int_equal(cfg.safety.command_timeout_ms, 100);
	assert_int_equal(cfg.safety.safe_action, RMD_SAFE_DAMP);
	assert_int_equal(cfg.safety.lost_motor_action, RMD_LOST_ALL);
	assert_int_equal(cfg.probe.on_missing, RMD_MISSING_REFUSE);
	assert_string_equal(cfg.lcm.url, "udpm://239.255.76.67:7667?ttl=0");
	assert_string_equal(cfg.lcm.channel_prefix, "RMD_");
	assert_int_equal(cfg.lcm.state_every_n, 1);
	assert_int_equal(cfg.lcm.stale_ms, 100);
	assert_int_equal(b->kind, RMD_BUS_KIND_SOCKETCAN);
	assert_string_equal(b->interface, "can0");
	assert_int_equal(b->bitrate, 1000000);
	assert_int_equal(b->line, 2);
	assert_int_equal(m->proto, RMD_PROTO_V3);
	assert_int_equal(m->mode, RMD_MODE_TORQUE);
	assert_int_equal(m->direction, 1);
	assert_true(m->gear_ratio == 1.0);
	assert_int_equal(m->units, RMD_UNITS_OUTPUT);
	assert_true(m->zero_offset_rad == 0.0);
	assert_int_equal(m->rate_divisor, 1);
	assert_true(m->status_poll_hz == 10.0);
	assert_true(isinf(m->limits.position_min_rad) && m->limits.position_min_rad < 0);
	assert_true(isinf(m->limits.position_max_rad) && m->limits.position_max_rad > 0);
	assert_true(isinf(m->limits.velocity_rad_s));
	assert_true(isinf(m->limits.torque_nm));
	assert_memory_equal(&m->mit, &rmd_mit_default_ranges, sizeof(m->mit));
	assert_int_equal(m->line, 4);
	expect_in(cfg.source, "/tmp/rmd-test-defaults-");

	/* the incident recorder: on, 3 s before, 0.5 s after, 20 kept, no dir (the environment's) */
	assert_true(cfg.incidents.enabled);
	assert_true(cfg.incidents.seconds_before == 3.0);
	assert_true(cfg.incidents.seconds_after == 0.5);
	assert_int_equal(cfg.incidents.keep, 20);
	assert_int_equal(cfg.incidents.overrun_burst, 10);
	assert_string_equal(cfg.incidents.dir, "");

	/* rmd_config_defaults() alone */
	rmd_config_defaults(&cfg);
	assert_int_equal(cfg.n_buses, 0);
	assert_int_equal(cfg.n_motors, 0);
	assert_int_equal(cfg.loop.rate_hz, RMD_CONFIG_DEFAULT_RATE_HZ);
}

/* A file of tests/data/config and what its error must say. */
struct bad_file {
	const char *file;
	int ret;
	const char *expect[3]; /* substrings of err, "FILE:LINE: key: ..." first */
};

static const struct bad_file bad_files[] = {
	{ "syntax.yaml", -EINVAL, { "syntax.yaml:7: motors[0].id", "syntax error" } },
	{ "unknown-key.yaml",
	  -EINVAL,
	  { "unknown-key.yaml:9: motors[0].speed_limit: unknown key",
	    "allowed: name, bus, id, protocol, mode" } },
	{ "wrong-type.yaml",
	  -EINVAL,
	  { "wrong-type.yaml:6: motors[0].id: expected an integer, got \"one\"",
	    "wrong-type.yaml:9: motors[0].limits: expected a mapping" } },
	{ "id-range.yaml",
	  -EINVAL,
	  { "id-range.yaml:7: motors[3].id: 40 is out of range (1..32)" } },
	{ "priority-99.yaml",
	  -EINVAL,
	  { "priority-99.yaml:3: loop.rt_priority: 99 is out of range (1..49)", "IRQ threads",
	    "50" } },
	{ "dup-id.yaml",
	  -EINVAL,
	  { "dup-id.yaml:7: motors[2].id: 1 is already the id of motors[0] (m1, line 5) on bus can0",
	    "dup-id.yaml:8: motors[3].name: \"m1\" is already the name of motors[0] (line 5)" } },
	{ "missing-bus.yaml",
	  -EINVAL,
	  { "missing-bus.yaml:6: motors[1].bus: \"can9\" is not a bus; buses: can0, can1" } },
	{ "nan.yaml",
	  -EINVAL,
	  { "nan.yaml:10: motors[0].limits.torque_nm: .nan is not allowed",
	    "nan.yaml:11: motors[0].limits.velocity_rad_s: .inf is not allowed" } },
	{ "empty.yaml", -EINVAL, { "empty.yaml:1: buses, motors: required keys missing" } },
	{ "bus-type.yaml",
	  -EINVAL,
	  { "bus-type.yaml:6: buses[1].type: \"canbus\" is not one of socketcan, rs485, sim" } },
	{ "mit-mode.yaml",
	  -EINVAL,
	  { "mit-mode.yaml:5: motors[0].mode: torque: protocol mit is V3 firmware driven in mode "
	    "mit (V3 §5): set mode: mit, or protocol: v3 for mode torque",
	    "mit-mode.yaml:7: motors[2].protocol: v2 has no RS485 form",
	    "mit-mode.yaml:8: motors[3].limits.position_min_rad: 1 must be below "
	    "position_max_rad" } },
};

static void test_bad_files(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(bad_files) / sizeof(bad_files[0]); i++) {
		const struct bad_file *t = &bad_files[i];
		char rel[256];
		int r;

		snprintf(rel, sizeof(rel), "tests/data/config/%s", t->file);
		r = load_rel(rel);
		if (r != t->ret)
			fail_msg("%s: returned %d, expected %d:\n%s", t->file, r, t->ret, err);
		for (size_t k = 0; k < 3 && t->expect[k]; k++)
			expect_in(err, t->expect[k]);
		/* no trailing newline; one line per error */
		assert_true(err[0] != '\0' && err[strlen(err) - 1] != '\n');
	}
}

static void test_nonexistent(void **state)
{
	(void)state;
	assert_int_equal(rmd_config_load("/nonexistent/rmdd.yaml", &cfg, &sim, err, sizeof(err)),
			 -ENOENT);
	expect_in(err, "/nonexistent/rmdd.yaml: cannot open: No such file or directory");
}

/* Inline cases: YAML and what the error says. */
struct bad_str {
	const char *name;
	const char *yaml;
	const char *expect[2];
};

#define BUS "buses:\n  - {name: can0, type: socketcan}\n"
#define MOTORS "motors:\n  - {name: m1, bus: can0, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
#define MOTORS_S "motors:\n  - {name: m1, bus: s, id: 1, mode: torque, torque_constant_nm_a: 2}\n"

static const struct bad_str bad_strs[] = {
	{ "duplicate-key",
	  BUS MOTORS "loop:\n  rate_hz: 500\n  rate_hz: 1000\n",
	  { ":7: loop.rate_hz: duplicate key (first at line 6)" } },
	{ "unknown-top",
	  BUS MOTORS "lopo: {}\n",
	  { ":5: lopo: unknown key (did you mean loop?); allowed: loop, safety" } },
	{ "missing-motors", BUS, { ":1: motors: required key missing" } },
	{ "top-seq", "- a\n- b\n", { ":1: (top level): expected a mapping" } },
	{ "negative-id",
	  BUS "motors:\n  - {name: m1, bus: can0, id: -1, mode: torque}\n",
	  { ":4: motors[0].id: -1 is out of range (1..32)" } },
	{ "priority-0",
	  BUS MOTORS "loop: {rt_priority: 0}\n",
	  { "loop.rt_priority: 0 is out of range (1..49)" } },
	{ "priority-50",
	  BUS MOTORS "loop: {rt_priority: 50}\n",
	  { "loop.rt_priority: 50 is out of range" } },
	{ "rate-0",
	  BUS MOTORS "loop: {rate_hz: 0}\n",
	  { "loop.rate_hz: 0 is out of range (1..2000)" } },
	{ "float-for-int",
	  BUS MOTORS "loop: {rate_hz: 1000.5}\n",
	  { "loop.rate_hz: expected an integer" } },
	{ "quoted-number",
	  BUS MOTORS "loop: {rate_hz: \"1000\"}\n",
	  { "loop.rate_hz: expected an integer, got \"1000\"" } },
	{ "bad-bool",
	  "buses:\n  - {name: s, type: sim, sim: {host_fifo: maybe}}\n"
	  "motors:\n  - {name: m1, bus: s, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":2: buses[0].sim.host_fifo: expected true or false, got \"maybe\"" } },
	{ "bad-name",
	  BUS
	  "motors:\n  - {name: Knee-L, bus: can0, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":4: motors[0].name: \"Knee-L\" is not a name" } },
	{ "long-name",
	  BUS
	  "motors:\n  - {name: a_name_that_is_far_too_long_for_rmdd, bus: can0, id: 1, mode: torque}\n",
	  { "motors[0].name: \"a_name_that_is_far_too_long_for_rmdd\" is too long (at most 31" } },
	{ "missing-id",
	  BUS "motors:\n  - {name: m1, bus: can0, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":4: motors[0].id: required key missing" } },
	{ "missing-bus-key",
	  BUS "motors:\n  - {name: m1, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":4: motors[0].bus: required key missing (buses: can0)" } },
	{ "bad-mode",
	  BUS "motors:\n  - {name: m1, bus: can0, id: 1, mode: current, torque_constant_nm_a: 2}\n",
	  { ":4: motors[0].mode: \"current\" is not one of torque, speed, position, mit" } },
	{ "direction-0",
	  BUS
	  "motors:\n  - {name: m1, bus: can0, id: 1, mode: torque, direction: 0, torque_constant_nm_a: 2}\n",
	  { "motors[0].direction: 0 is out of range (+1 or -1)" } },
	{ "gear-negative",
	  BUS
	  "motors:\n  - {name: m1, bus: can0, id: 1, mode: torque, gear_ratio: -6, torque_constant_nm_a: 2}\n",
	  { "motors[0].gear_ratio: -6 is out of range (0.01..10000)" } },
	{ "no-kt",
	  BUS "motors:\n  - {name: m1, bus: can0, id: 1, mode: torque}\n",
	  { ":4: motors[0].torque_constant_nm_a: required for protocol v3" } },
	{ "mit-range",
	  BUS "motors:\n  - name: m1\n    bus: can0\n    id: 1\n    protocol: mit\n    mode: mit\n"
	      "    mit: {t_min: 5, t_max: -5}\n",
	  { ":9: motors[0].mit.t_min: 5 must be below t_max (-5)" } },
	{ "big-number",
	  BUS
	  "motors:\n  - {name: m1, bus: can0, id: 1, mode: torque, torque_constant_nm_a: 1e999}\n",
	  { "motors[0].torque_constant_nm_a: 1e999 is too large" } },
	{ "can-bitrate",
	  "buses:\n  - {name: can0, type: socketcan, bitrate: 250000}\n" MOTORS,
	  { ":2: buses[0].bitrate: 250000 is not a bitrate RMD motors speak" } },
	{ "key-for-other-type",
	  "buses:\n  - {name: can0, type: socketcan, device: /dev/ttyUSB0}\n" MOTORS,
	  { ":2: buses[0].device: only for type rs485 (this bus is socketcan)" } },
	{ "rs485-no-device",
	  "buses:\n  - {name: rs0, type: rs485}\n"
	  "motors:\n  - {name: m1, bus: rs0, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":2: buses[0].device: required for type rs485" } },
	{ "rs485-baud",
	  "buses:\n  - {name: rs0, type: rs485, device: /dev/ttyS0, baud: 9600}\n"
	  "motors:\n  - {name: m1, bus: rs0, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":2: buses[0].baud: 9600 is not a baud rate RMD motors speak" } },
	{ "dup-bus",
	  "buses:\n  - {name: can0, type: socketcan}\n  - {name: can0, type: socketcan}\n" MOTORS,
	  { ":3: buses[1].name: \"can0\" is already the name of buses[0] (line 2)" } },
	/* a socketcan or rs485 bus's sim: is rmd-sim's: what a real wire cannot do is refused */
	{ "sim-on-can-tap",
	  "buses:\n  - name: can0\n    type: socketcan\n    sim: {seed: 2, tap: /tmp/x}\n" MOTORS,
	  { ":4: buses[0].sim.tap: only for type sim (the in-process wire); on a socketcan bus",
	    "candump IFACE" } },
	{ "sim-on-rs485-txqueuelen",
	  "buses:\n  - name: rs0\n    type: rs485\n    device: /dev/ttyS0\n"
	  "    sim:\n      txqueuelen: 4\n"
	  "motors:\n  - {name: m1, bus: rs0, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":6: buses[0].sim.txqueuelen: only for type sim (the in-process wire); on a rs485 bus" } },
	{ "sim-on-can-bus-off",
	  "buses:\n  - name: can0\n    type: socketcan\n    sim:\n      faults:\n"
	  "        - {kind: bus_off, start_s: 1}\n" MOTORS,
	  { ":6: buses[0].sim.faults[0].kind: bus_off is for type sim: on a socketcan bus the "
	    "kernel's controller owns the bus state" } },
	{ "sim-on-rs485-flood",
	  "buses:\n  - name: rs0\n    type: rs485\n    device: /dev/ttyS0\n    sim:\n"
	  "      faults:\n        - {kind: flood, can_id: 0x100, period_us: 1000}\n"
	  "motors:\n  - {name: m1, bus: rs0, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":7: buses[0].sim.faults[0].kind: flood needs a CAN bus" } },
	{ "sim-on-can-fault-motor",
	  "buses:\n  - name: can0\n    type: socketcan\n    sim:\n      faults:\n"
	  "        - {kind: drop, motor: 3}\n" MOTORS,
	  { ":6: buses[0].sim.faults[0].motor: no motor with id 3 on bus can0" } },
	{ "sim-on-can-model",
	  BUS
	  "motors:\n  - {name: m1, bus: can0, id: 1, mode: torque, torque_constant_nm_a: 2, sim: {load_nm: x}}\n",
	  { ":4: motors[0].sim.load_nm: expected a number" } },
	{ "fault-kind",
	  "buses:\n  - name: s\n    type: sim\n    sim:\n      faults:\n        - {kind: explode}\n"
	  "motors:\n  - {name: m1, bus: s, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":6: buses[0].sim.faults[0].kind: \"explode\" is not one of drop, delay" } },
	{ "fault-motor",
	  "buses:\n  - name: s\n    type: sim\n    sim:\n      faults:\n        - {kind: drop, motor: 7}\n"
	  "motors:\n  - {name: m1, bus: s, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":6: buses[0].sim.faults[0].motor: no motor with id 7 on bus s" } },
	{ "fault-param",
	  "buses:\n  - name: s\n    type: sim\n    sim:\n      faults:\n        - {kind: bad_dlc, param: 9}\n"
	  "motors:\n  - {name: m1, bus: s, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":6: buses[0].sim.faults[0].param: 9 is out of range for bad_dlc (0..7" } },
	{ "fault-window",
	  "buses:\n  - name: s\n    type: sim\n    sim:\n      faults:\n        - {kind: bus_off, start_s: 5, end_s: 2}\n"
	  "motors:\n  - {name: m1, bus: s, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":6: buses[0].sim.faults[0].end_s: must be after start_s" } },
	{ "fault-delay-us-kind",
	  "buses:\n  - name: s\n    type: sim\n    sim:\n      faults:\n        - {kind: drop, delay_us: 5}\n"
	  "motors:\n  - {name: m1, bus: s, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":6: buses[0].sim.faults[0].delay_us: only for kind delay" } },
	{ "fault-us-and-param",
	  "buses:\n  - name: s\n    type: sim\n    sim:\n      faults:\n"
	  "        - {kind: flood, period_us: 100, param: 100000}\n"
	  "motors:\n  - {name: m1, bus: s, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":6: buses[0].sim.faults[0].param: give the time in µs" } },
	{ "sim-model",
	  "buses:\n  - name: s\n    type: sim\n    sim:\n      motor:\n        under_voltage_v: 50\n"
	  "        over_voltage_v: 40\n"
	  "motors:\n  - {name: m1, bus: s, id: 1, mode: torque, torque_constant_nm_a: 2}\n",
	  { ":6: buses[0].sim.motor.under_voltage_v: 50 must be below over_voltage_v (40)" } },
	{ "poll-too-fast",
	  BUS
	  "motors:\n  - {name: m1, bus: can0, id: 1, mode: torque, torque_constant_nm_a: 2, rate_divisor: 4, status_poll_hz: 300}\n",
	  { ":4: motors[0].status_poll_hz: 300 is more than the motor's command rate (250 Hz" } },
	{ "comm-loss-short",
	  BUS
	  "motors:\n  - {name: m1, bus: can0, id: 1, mode: torque, torque_constant_nm_a: 2, rate_divisor: 10}\n"
	  "safety: {comm_loss_ms: 20}\n",
	  { ":5: safety.comm_loss_ms: 20 ms is shorter than 5 command periods of motor m1 (50 ms)" } },
	{ "timeout-short",
	  BUS MOTORS "loop: {rate_hz: 100}\nsafety: {command_timeout_ms: 15, comm_loss_ms: 0}\n",
	  { ":6: safety.command_timeout_ms: 15 ms is shorter than two cycles (20 ms at 100 Hz)" } },
	{ "lcm-url",
	  BUS MOTORS "lcm: {url: localhost}\n",
	  { ":5: lcm.url: \"localhost\" is not an LCM provider URL" } },
	{ "two-documents", BUS MOTORS "---\n" BUS, { ":5: a second YAML document" } },
	{ "bad-alias",
	  BUS MOTORS "loop: *nothing\n",
	  { ":5: loop: alias *nothing names no complete anchor" } },
	{ "tab",
	  BUS MOTORS "loop:\n\trate_hz: 5\n",
	  { ":6: loop: syntax error: found character that cannot start any token" } },
	{ "incident-window",
	  BUS MOTORS "incidents:\n  seconds_before: 50\n  seconds_after: 20\n",
	  { ":7: incidents: seconds_before + seconds_after is 70 s: at most 60 s" } },
	{ "incident-empty",
	  BUS MOTORS "incidents: {seconds_before: 0, seconds_after: 0}\n",
	  { ":5: incidents: an empty window", "enabled: false" } },
	{ "incident-keep-0",
	  BUS MOTORS "incidents: {keep: 0}\n",
	  { ":5: incidents.keep: 0 is out of range (1..10000)" } },
	{ "incident-negative",
	  BUS MOTORS "incidents: {seconds_after: -1}\n",
	  { ":5: incidents.seconds_after: -1 is out of range" } },
	{ "travel-order",
	  BUS "motors:\n  - {name: m1, bus: can0, id: 1, mode: torque, torque_constant_nm_a: 2,\n"
	      "     travel_rad: [0.5, -0.5]}\n",
	  { ":5: motors[0].travel_rad: [min, max] in rad, min below max" } },
	{ "travel-one",
	  BUS "motors:\n  - {name: m1, bus: can0, id: 1, mode: torque, torque_constant_nm_a: 2,\n"
	      "     travel_rad: [0.5]}\n",
	  { "motors[0].travel_rad: [min, max] in rad" } },
};

static void test_bad_strings(void **state)
{
	(void)state;
	for (size_t i = 0; i < sizeof(bad_strs) / sizeof(bad_strs[0]); i++) {
		const struct bad_str *t = &bad_strs[i];
		int r = load_str(t->name, t->yaml);

		if (r != -EINVAL)
			fail_msg("%s: returned %d, expected -EINVAL:\n%s", t->name, r, err);
		for (size_t k = 0; k < 2 && t->expect[k]; k++)
			if (!strstr(err, t->expect[k]))
				fail_msg("%s: expected \"%s\" in:\n%s", t->name, t->expect[k], err);
		/* every line names the file */
		expect_in(err, "/tmp/rmd-test-");
	}
}

/* 33 motors: one too many, named at the 33rd entry's line. */
/*
 * Issue 22.7: one file for rmdd and rmd-sim.  A socketcan or rs485 bus takes
 * a sim: section, and its motors theirs; rmdd does not use them (it says so:
 * sim_section), rmd-sim simulates the bus from them: the bus's model with the
 * motor's own keys and entry (id, protocol, kt, gear), its seed and faults.
 */
static void test_sim_on_real_bus(void **state)
{
	static const char yaml[] =
		"buses:\n"
		"  - name: can0\n"
		"    type: socketcan\n"
		"  - name: rs0\n"
		"    type: rs485\n"
		"    device: /dev/ttyS0\n"
		"    baud: 500000\n"
		"    sim:\n"
		"      seed: 9\n"
		"      motor: {model: RIG1, turnaround_us: 300}\n"
		"      faults:\n"
		"        - {kind: drop, motor: 2, probability: 0.25}\n"
		"  - name: can1\n"
		"    type: socketcan\n"
		"motors:\n"
		"  - {name: a, bus: can0, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
		"  - {name: b, bus: rs0, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
		"  - {name: c, bus: rs0, id: 2, mode: torque, torque_constant_nm_a: 0.9,\n"
		"     gear_ratio: 9, sim: {load_nm: 1.5, model: RIG2}}\n"
		"  - {name: d, bus: can1, id: 4, mode: torque, torque_constant_nm_a: 2,\n"
		"     protocol: v2, comm_loss_ms: 0, sim: {inertia_kgm2: 0.02}}\n";
	bool serial = true;

	(void)state;
	if (load_str("sim-real", yaml))
		fail_msg("%s", err);
	assert_false(cfg.buses[0].sim_section);
	assert_true(cfg.buses[1].sim_section);
	assert_true(cfg.buses[2].sim_section); /* from motor d's sim: alone */
	assert_string_equal(rmd_config_bus_wire(&cfg.buses[0], &serial), "can0");
	assert_false(serial);
	assert_string_equal(rmd_config_bus_wire(&cfg.buses[1], &serial), "/dev/ttyS0");
	assert_true(serial);
	assert_int_equal(sim.buses[1].seed, 9);
	assert_int_equal(sim.buses[1].n_faults, 1);
	assert_int_equal(sim.buses[1].faults[0].kind, RMD_SIM_FAULT_DROP);
	assert_int_equal(sim.buses[1].faults[0].motor_id, 2);
	/* b: the bus's model */
	assert_string_equal(sim.motors[1].model, "RIG1");
	assert_int_equal(sim.motors[1].id, 1);
	assert_true(sim.motors[1].turnaround_ns == 300000.0);
	assert_true(sim.motors[1].load_nm == 0.0);
	/* c: its own sim: and its entry win */
	assert_string_equal(sim.motors[2].model, "RIG2");
	assert_int_equal(sim.motors[2].id, 2);
	assert_true(sim.motors[2].load_nm == 1.5);
	assert_true(sim.motors[2].kt_nm_a == 0.9);
	assert_true(sim.motors[2].gear_ratio == 9.0);
	assert_true(sim.motors[2].turnaround_ns == 300000.0);
	/* d: on a bus without sim: of its own, its protocol is the firmware's */
	assert_int_equal(sim.motors[3].proto, RMD_PROTO_V2);
	assert_true(sim.motors[3].inertia_kgm2 == 0.02);
	/* a sim bus has no real wire */
	cfg.buses[0].kind = RMD_BUS_KIND_SIM;
	assert_null(rmd_config_bus_wire(&cfg.buses[0], &serial));
}

static void test_too_many_motors(void **state)
{
	static char yaml[8192];
	size_t k = 0;

	(void)state;
	k += (size_t)snprintf(yaml + k, sizeof(yaml) - k, BUS "motors:\n");
	for (unsigned i = 0; i < RMD_MAX_MOTORS + 1; i++)
		k += (size_t)snprintf(yaml + k, sizeof(yaml) - k,
				      "  - {name: m%u, bus: can0, id: %u, mode: torque, "
				      "torque_constant_nm_a: 2}\n",
				      i, i % 32 + 1);
	assert_int_equal(load_str("too-many", yaml), -EINVAL);
	expect_in(err, ":36: motors: 33 entries, at most 32 allowed");
}

/* Values that must load, and how they are stored. */
/*
 * Issue 33 point 2: buses[].can_id_filter (the spares on a bus ignore a
 * 0x280 frame) and a sim bus's strays (motors on its wire the file does
 * not list), each checked with its line.
 */
static void test_strays_and_filter(void **state)
{
	static const struct bad_str bad[] = {
		{ "stray-is-a-motor",
		  "buses:\n  - {name: s, type: sim, sim: {strays: [{id: 3}, {id: 1}]}}\n" MOTORS_S,
		  { ":2: buses[0].sim.strays[1].id: 1 is the id of motors[0] (m1): a stray is a "
		    "motor the file does not list" } },
		{ "stray-twice",
		  "buses:\n  - {name: s, type: sim,\n     sim: {strays: [{id: 5},\n"
		  "                   {id: 5}]}}\n" MOTORS_S,
		  { ":4: buses[0].sim.strays[1].id: 5 is already the id of strays[0] (line 3)" } },
		{ "stray-without-id",
		  "buses:\n  - {name: s, type: sim, sim: {strays: [{firmware: v3}]}}\n" MOTORS_S,
		  { ":2: buses[0].sim.strays[0].id: required key missing" } },
		{ "filter-on-rs485",
		  "buses:\n  - {name: s, type: rs485, device: /dev/ttyUSB0, can_id_filter: true}\n" MOTORS_S,
		  { ":2: buses[0].can_id_filter: only for type socketcan or sim (this bus is rs485)" } },
	};

	(void)state;
	assert_int_equal(
		load_str("good", "buses:\n"
				 "  - {name: s, type: sim, can_id_filter: true,\n"
				 "     sim: {strays: [{id: 5, firmware: v3, start_angle_deg: 90},\n"
				 "                    {id: 3, firmware: v2}]}}\n" MOTORS_S),
		0);
	assert_true(cfg.buses[0].can_id_filter);
	assert_int_equal(sim.buses[0].n_strays, 2);
	assert_int_equal(sim.buses[0].strays[0].id, 5);
	assert_int_equal(sim.buses[0].strays[0].proto, RMD_PROTO_V3);
	assert_float_equal(sim.buses[0].strays[0].start_angle_deg, 90.0, 0.0);
	assert_int_equal(sim.buses[0].strays[1].proto, RMD_PROTO_V2);
	for (size_t k = 0; k < sizeof(bad) / sizeof(bad[0]); k++) {
		if (load_str(bad[k].name, bad[k].yaml) != -EINVAL)
			fail_msg("%s: accepted", bad[k].name);
		expect_in(err, bad[k].expect[0]);
	}
}

static void test_good_values(void **state)
{
	(void)state;
	assert_int_equal(
		load_str("good",
			 "loop: {rate_hz: 500, rt_priority: 49, cpu_affinity: [1, 3]}\n"
			 "safety: {comm_loss_ms: 0, safe_action: brake, lost_motor_action: motor,\n"
			 "         missed_replies_lost: 3, command_timeout_ms: 50}\n"
			 "probe: {on_missing: start}\n"
			 "lcm: {url: 'memq://', channel_prefix: ARM_, state_every_n: 2}\n"
			 "buses:\n"
			 "  - {name: s, type: sim, bitrate: 500000,\n"
			 "     sim: {seed: 0x10, txqueuelen: 64, host_fifo: no,\n"
			 "           faults: [{kind: flood, can_id: 0x7FF, param: 100000},\n"
			 "                    {kind: error_flag, motor: 2, param: 0x1000}]}}\n"
			 "  - {name: rs0, type: rs485, device: /dev/ttyUSB1, baud: 115200,\n"
			 "     turnaround_us: 250.5}\n"
			 "motors:\n"
			 "  - {name: m1, bus: s, id: 1, protocol: mit, mode: mit, direction: -1,\n"
			 "     zero_offset_rad: -0.25, rate_divisor: 2, status_poll_hz: 0,\n"
			 "     sim: {has_brake: off, model: X6}}\n"
			 "  - {name: m2, bus: s, id: 2, protocol: v2, mode: speed, units: rotor,\n"
			 "     gear_ratio: 9, torque_constant_nm_a: +1.5e0}\n"
			 "  - {name: m3, bus: rs0, id: 1, mode: position, torque_constant_nm_a: 2,\n"
			 "     limits: {position_min_rad: -1, position_max_rad: 1},\n"
			 "     multi_turn_saved: true, travel_rad: [-0.5, 0.25]}\n"),
		0);
	assert_string_equal(err, "");
	assert_int_equal(cfg.loop.rate_hz, 500);
	assert_int_equal(cfg.loop.rt_priority, 49);
	assert_int_equal(cfg.loop.n_cpus, 2);
	assert_int_equal(cfg.loop.cpus[1], 3);
	assert_int_equal(cfg.safety.comm_loss_ms, 0);
	assert_int_equal(cfg.safety.safe_action, RMD_SAFE_BRAKE);
	assert_int_equal(cfg.safety.lost_motor_action, RMD_LOST_MOTOR);
	assert_int_equal(cfg.safety.missed_replies_lost, 3);
	assert_int_equal(cfg.probe.on_missing, RMD_MISSING_START);
	assert_string_equal(cfg.lcm.url, "memq://");
	assert_string_equal(cfg.lcm.channel_prefix, "ARM_");
	assert_int_equal(cfg.lcm.state_every_n, 2);
	assert_int_equal(cfg.buses[0].bitrate, 500000);
	assert_int_equal(sim.buses[0].seed, 16);
	assert_int_equal(sim.buses[0].txqueuelen, 64);
	assert_false(sim.buses[0].host_fifo);
	assert_int_equal(sim.buses[0].n_faults, 2);
	assert_int_equal(sim.buses[0].faults[0].kind, RMD_SIM_FAULT_FLOOD);
	assert_int_equal(sim.buses[0].faults[0].can_id, 0x7FF);
	assert_int_equal(sim.buses[0].faults[0].param, 100000);
	assert_int_equal(sim.buses[0].faults[1].motor_id, 2);
	assert_int_equal(sim.buses[0].faults[1].param, 0x1000);
	assert_true(sim.buses[0].faults[1].probability == 1.0);
	assert_int_equal(cfg.buses[1].kind, RMD_BUS_KIND_RS485);
	assert_string_equal(cfg.buses[1].device, "/dev/ttyUSB1");
	assert_int_equal(cfg.buses[1].baud, 115200);
	assert_int_equal(cfg.buses[1].turnaround_ns, 250500);
	assert_int_equal(cfg.motors[0].direction, -1);
	assert_true(cfg.motors[0].zero_offset_rad == -0.25);
	assert_true(cfg.motors[0].status_poll_hz == 0.0);
	assert_false(sim.motors[0].has_brake);
	assert_string_equal(sim.motors[0].model, "X6");
	assert_int_equal(sim.motors[0].proto, RMD_PROTO_MIT);
	assert_true(cfg.motors[0].torque_constant_nm_a == 0.0); /* optional for MIT */
	assert_true(sim.motors[0].kt_nm_a == 2.0);		/* the model's */
	assert_int_equal(cfg.motors[1].proto, RMD_PROTO_V2);
	assert_int_equal(cfg.motors[1].units, RMD_UNITS_ROTOR);
	assert_true(sim.motors[1].gear_ratio == 9.0);
	assert_true(sim.motors[1].kt_nm_a == 1.5);
	assert_int_equal(cfg.motors[2].bus, 1);
	assert_true(cfg.motors[2].limits.position_max_rad == 1.0);
	assert_true(cfg.motors[2].multi_turn_saved);
	assert_int_equal(cfg.motors[2].n_travel, 2);
	assert_true(cfg.motors[2].travel_rad[0] == -0.5 && cfg.motors[2].travel_rad[1] == 0.25);
	assert_false(cfg.motors[1].multi_turn_saved);
	assert_int_equal(cfg.motors[1].n_travel, 0);
}

/* A small err buffer is cut, never overrun, and stays a string. */
static void test_small_err_buffer(void **state)
{
	char small[24];
	char path[2048];

	(void)state;
	memset(small, 'x', sizeof(small));
	path_of(path, sizeof(path), "tests/data/config/mit-mode.yaml");
	assert_int_equal(rmd_config_load(path, &cfg, &sim, small, sizeof(small)), -EINVAL);
	assert_true(strlen(small) < sizeof(small));
	assert_int_equal(rmd_config_load(path, &cfg, NULL, NULL, 0), -EINVAL);
}

static void test_sim_default(void **state)
{
	(void)state;
	assert_int_equal(rmd_config_sim_default(&cfg, &sim, 0), -EINVAL);
	assert_int_equal(rmd_config_sim_default(&cfg, &sim, RMD_MAX_MOTORS + 1), -EINVAL);
	assert_int_equal(rmd_config_sim_default(&cfg, &sim, 12), 0);
	assert_int_equal(cfg.n_buses, 4);
	assert_int_equal(cfg.n_motors, 12);
	for (unsigned i = 0; i < 12; i++) {
		assert_int_equal(cfg.motors[i].bus, i / 3);
		assert_int_equal(cfg.motors[i].id, i % 3 + 1);
		assert_int_equal(sim.motors[i].id, i % 3 + 1);
		assert_true(cfg.motors[i].torque_constant_nm_a > 0);
	}
	for (unsigned b = 0; b < 4; b++)
		assert_int_equal(cfg.buses[b].kind, RMD_BUS_KIND_SIM);
	assert_string_equal(cfg.buses[3].name, "sim3");
	/*
	 * Issue 22.10: a position in degrees for radians (90 for 1.57) reaches
	 * the wire as one output turn, the frame of 2 pi, not 14 turns.
	 */
	{
		struct rmd_motor m;
		struct rmd_frame slip, turn;
		struct rmd_setpoint sp = { .enable = true,
					   .mode = RMD_MODE_POSITION,
					   .pos_rad = 90.0,
					   .max_vel_rad_s = 1.0 };
		unsigned fl = 0;

		assert_int_equal(rmd_motor_init(&m, &cfg.motors[0]), 0);
		assert_int_equal(rmd_motor_encode(&m, &sp, &slip, &fl), 0);
		assert_true(fl & RMD_MOTOR_CLAMPED);
		sp.pos_rad = 2.0 * M_PI;
		assert_int_equal(rmd_motor_encode(&m, &sp, &turn, &fl), 0);
		assert_memory_equal(slip.data, turn.data, 8);
		sp.pos_rad = 1.57; /* inside: not clamped */
		fl = 0;
		assert_int_equal(rmd_motor_encode(&m, &sp, &turn, &fl), 0);
		assert_false(fl & RMD_MOTOR_CLAMPED);
	}
	assert_int_equal(rmd_config_sim_default(&cfg, &sim, 32), 0);
	assert_int_equal(cfg.n_buses, 11);
	assert_int_equal(rmd_config_sim_default(&cfg, &sim, 1), 0);
	assert_int_equal(cfg.n_buses, 1);
}

/* A fault's times in µs, as rmd-sim's delay:ID:US and flood:..:PERIOD_US, or in ns (param). */
static void test_fault_units(void **state)
{
	(void)state;
	assert_int_equal(load_str("fault-units",
				  "buses:\n  - name: s\n    type: sim\n    sim:\n      faults:\n"
				  "        - {kind: delay, delay_us: 150, probability: 0.5}\n"
				  "        - {kind: flood, can_id: 0x7FF, period_us: 100}\n"
				  "        - {kind: delay, param: 150000}\n"
				  "motors:\n  - {name: m1, bus: s, id: 1, mode: torque, "
				  "torque_constant_nm_a: 2}\n"),
			 0);
	assert_int_equal(sim.buses[0].n_faults, 3);
	assert_int_equal(sim.buses[0].faults[0].param, 150000);
	assert_int_equal(sim.buses[0].faults[1].param, 100000);
	assert_int_equal(sim.buses[0].faults[2].param, 150000);
}

static void test_names(void **state)
{
	(void)state;
	assert_string_equal(rmd_bus_kind_name(RMD_BUS_KIND_RS485), "rs485");
	assert_string_equal(rmd_proto_key(RMD_PROTO_MIT), "mit");
	assert_string_equal(rmd_proto_key(RMD_PROTO_V2), "v2");
	assert_string_equal(rmd_mode_name(RMD_MODE_POSITION), "position");
	assert_string_equal(rmd_safe_action_name(RMD_SAFE_HOLD), "hold");
}

/* ---- hostile files (issue 10, defects 2, 3, 4, 8, 10) --------------------- */

static double mono_s(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + ts.tv_nsec / 1e9;
}

static void key_line(FILE *f, unsigned i)
{
	fprintf(f, "k%05u: 1\n", i);
}

static void dup_line(FILE *f, unsigned i)
{
	fprintf(f, "x: %u\n", i);
}

static void flow_entry(FILE *f, unsigned i)
{
	(void)i;
	fputs("0,", f);
}

static void comment_line(FILE *f, unsigned i)
{
	fprintf(f, "# %07u of a long comment\n", i);
}

/* A temporary file: head, then line(f, i) for i < n, then tail. */
static void write_big(char *path, size_t len, const char *tag, const char *head,
		      void (*line)(FILE *f, unsigned i), unsigned n, const char *tail)
{
	FILE *f;
	int fd;

	snprintf(path, len, "/tmp/rmd-test-%s-XXXXXX", tag);
	fd = mkstemp(path);
	assert_true(fd >= 0);
	f = fdopen(fd, "w");
	assert_non_null(f);
	fputs(head, f);
	for (unsigned i = 0; i < n; i++)
		line(f, i);
	fputs(tail, f);
	assert_int_equal(fclose(f), 0);
}

/* Load path, refused (-EINVAL), within 5 s; remove it. */
static void load_fast(const char *path, const char *what)
{
	double t0 = mono_s(), dt;
	int r = rmd_config_load(path, &cfg, &sim, err, sizeof(err));

	dt = mono_s() - t0;
	unlink(path);
	printf("%s: %.3f s\n", what, dt);
	assert_int_equal(r, -EINVAL);
	if (dt > 5.0)
		fail_msg("%s took %.1f s", what, dt);
}

/*
 * Size and node bounds, the error cap, duplicates in O(n log n): before,
 * 100 000 unknown keys took 20 s (a quadratic duplicate check), and a 100 MB
 * file was read whole (1.8 GB after 90 s).
 */
static void test_hostile_sizes(void **state)
{
	char path[256];
	double t0, dt;
	int fd, r;

	(void)state;
	/* 100 MB, sparse: refused by its size before a byte is read */
	snprintf(path, sizeof(path), "/tmp/rmd-test-huge-XXXXXX");
	fd = mkstemp(path);
	assert_true(fd >= 0);
	assert_int_equal(ftruncate(fd, 100 * 1024 * 1024), 0);
	close(fd);
	t0 = mono_s();
	r = rmd_config_load(path, &cfg, &sim, err, sizeof(err));
	dt = mono_s() - t0;
	unlink(path);
	assert_int_equal(r, -EFBIG);
	expect_in(err, path);
	expect_in(err, ": 104857600 bytes: larger than the limit of 1 MiB (1048576 bytes)");
	assert_true(dt < 1.0);

	/* 100 000 unknown keys (1 MB): the error cap, fast (was 20 s) */
	write_big(path, sizeof(path), "keys", minimal, key_line, 100000, "");
	load_fast(path, "100000 unknown keys");
	expect_in(err, ":5: k00000: unknown key; allowed: loop, safety");
	expect_in(err, "more errors not shown");
	assert_true(count_lines(err) + 1 <= 33); /* lines joined by '\n', none after the last */

	/* 100 000 times the same key: duplicates found by sorting */
	write_big(path, sizeof(path), "dups", "", dup_line, 100000, "");
	load_fast(path, "100000 duplicate keys");
	expect_in(err, ":2: x: duplicate key (first at line 1)");

	/* a flow list of 500 000 entries (1 MB): the node bound */
	write_big(path, sizeof(path), "flow", "motors: [", flow_entry, 500000, "0]\n");
	r = rmd_config_load(path, &cfg, &sim, err, sizeof(err));
	unlink(path);
	assert_int_equal(r, -EINVAL);
	expect_in(err, ":1: motors[262141]: more than 262144 keys, values and entries: a "
		       "configuration file has a few thousand");

	/* over the size bound by text, not by holes */
	write_big(path, sizeof(path), "long", minimal, comment_line, 40000, "");
	r = rmd_config_load(path, &cfg, &sim, err, sizeof(err));
	unlink(path);
	assert_int_equal(r, -EFBIG);
	expect_in(err, "bytes: larger than the limit of 1 MiB");
}

/* More than 64 anchors: said so, with the line; before, "out of memory". */
static void test_hostile_anchors(void **state)
{
	char yaml[4096];
	size_t k = (size_t)snprintf(yaml, sizeof(yaml), "%s", minimal);

	(void)state;
	for (unsigned i = 0; i < 65; i++)
		k += (size_t)snprintf(yaml + k, sizeof(yaml) - k, "x%u: &a%u 1\n", i, i);
	assert_int_equal(load_str("anchors", yaml), -EINVAL);
	expect_in(err, ":69: x64: more than 64 anchors (&name): rmdd keeps at most 64");
	if (strstr(err, "out of memory"))
		fail_msg("%s", err);
}

/* A directory, a FIFO, a device: refused by name, never read (a FIFO blocked before). */
static void test_special_files(void **state)
{
	char dir[] = "/tmp/rmd-test-dir-XXXXXX", fifo[300];

	(void)state;
	assert_non_null(mkdtemp(dir));
	assert_int_equal(rmd_config_load(dir, &cfg, &sim, err, sizeof(err)), -EISDIR);
	expect_in(err, dir);
	expect_in(err, ": is a directory, not a regular file");
	snprintf(fifo, sizeof(fifo), "%s/fifo.yaml", dir);
	assert_int_equal(mkfifo(fifo, 0600), 0);
	alarm(10); /* a blocking open of the FIFO ends the test here */
	assert_int_equal(rmd_config_load(fifo, &cfg, &sim, err, sizeof(err)), -EINVAL);
	alarm(0);
	expect_in(err, "fifo.yaml: is a FIFO, not a regular file");
	unlink(fifo);
	rmdir(dir);
	assert_int_equal(rmd_config_load("/dev/zero", &cfg, &sim, err, sizeof(err)), -EINVAL);
	expect_in(err, "/dev/zero: is a character device, not a regular file");
}

/* An embedded NUL is refused, not cut (before, "ab\0cd" loaded as "ab"). */
static void test_nul_refused(void **state)
{
	char path[256];
	FILE *f;
	int fd;

	(void)state;
	assert_int_equal(load_str("nul-escape", "buses:\n  - {name: can0, type: socketcan}\n"
						"motors:\n  - name: \"m\\0x\"\n"
						"    bus: can0\n    id: 1\n    mode: torque\n"
						"    torque_constant_nm_a: 2\n"),
			 -EINVAL);
	expect_in(err, ":4: motors[0].name: the value contains a NUL character (\\0)");
	/* a raw NUL byte in the file */
	snprintf(path, sizeof(path), "/tmp/rmd-test-nul-XXXXXX");
	fd = mkstemp(path);
	assert_true(fd >= 0);
	f = fdopen(fd, "w");
	assert_non_null(f);
	fputs(minimal, f);
	fwrite("x: a\0b\n", 1, 7, f);
	fclose(f);
	assert_int_equal(rmd_config_load(path, &cfg, &sim, err, sizeof(err)), -EILSEQ);
	unlink(path);
	expect_in(err, ":5: a NUL byte: a configuration file is text");
}

/* A u64 bound prints as 2^64 - 1, not as the double 2^64. */
static void test_range_u64(void **state)
{
	(void)state;
	assert_int_equal(load_str("seed", "buses:\n  - name: s\n    type: sim\n    sim:\n"
					  "      seed: -1\n"
					  "motors:\n  - {name: m1, bus: s, id: 1, mode: torque, "
					  "torque_constant_nm_a: 2}\n"),
			 -EINVAL);
	expect_in(err, ":5: buses[0].sim.seed: -1 is out of range (0..18446744073709551615)");
}

/* Physical quantities have real lower bounds: 1e-300 passed before. */
static void test_physical_lower_bounds(void **state)
{
	static const struct {
		const char *motor, *expect;
	} cases[] = {
		{ "gear_ratio: 1e-300",
		  "motors[0].gear_ratio: 1e-300 is out of range (0.01..10000)" },
		{ "torque_constant_nm_a: 1e-300",
		  "motors[0].torque_constant_nm_a: 1e-300 is out of range (0.001..10000)" },
		{ "limits: {velocity_rad_s: 1e-300}",
		  "motors[0].limits.velocity_rad_s: 1e-300 is out of range (0.001..10000)" },
		{ "limits: {torque_nm: 1e-300}",
		  "motors[0].limits.torque_nm: 1e-300 is out of range (0.001..100000)" },
		{ "status_poll_hz: 1e-300",
		  "motors[0].status_poll_hz: 1e-300 Hz is below 0.001 Hz (one poll every 1000 s): "
		  "use 0 to turn status polls off" },
		{ "status_poll_hz: 2e-7", "motors[0].status_poll_hz: 2e-07 Hz is below 0.001 Hz" },
		{ "mit: {t_min: 0, t_max: 1e-300}",
		  "motors[0].mit.t_min: 0..1e-300 is narrower than 0.001: the MIT frame codes it "
		  "in 12 bits (V3 §5)" },
		{ "mit: {p_min: 1, p_max: 1.0001}",
		  "motors[0].mit.p_min: 1..1.0001 is narrower than 0.001: the MIT frame codes it "
		  "in 16 bits" },
	};
	char yaml[1024];

	(void)state;
	for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
		snprintf(yaml, sizeof(yaml),
			 "buses:\n  - {name: can0, type: socketcan}\nmotors:\n"
			 "  - {name: m1, bus: can0, id: 1, mode: mit, protocol: mit, %s}\n",
			 cases[i].motor);
		if (load_str("lower", yaml) != -EINVAL)
			fail_msg("%s: accepted", cases[i].motor);
		expect_in(err, cases[i].expect);
	}
	/* the bounds themselves pass */
	assert_int_equal(load_str("lower-ok", "buses:\n  - {name: can0, type: socketcan}\n"
					      "motors:\n  - {name: m1, bus: can0, id: 1, mode: "
					      "mit, protocol: mit, gear_ratio: 0.01, "
					      "torque_constant_nm_a: 0.001, status_poll_hz: 0.001, "
					      "limits: {velocity_rad_s: 0.001, torque_nm: 0.001}, "
					      "mit: {kd_min: 0, kd_max: 0.001}}\n"),
			 0);
}

/* Issue 13: a motor's own comm_loss_ms (0: off), its check, and the faults' cmd and count. */
static void test_comm_loss_keys(void **state)
{
	(void)state;
	assert_int_equal(
		load_str("cl.yaml",
			 "safety: {comm_loss_ms: 150}\n"
			 "buses:\n  - name: s\n    type: sim\n    sim:\n      faults:\n"
			 "        - {kind: drop, motor: 1, cmd: 0xB3, count: 1}\n"
			 "motors:\n"
			 "  - {name: a, bus: s, id: 1, mode: torque, torque_constant_nm_a: 2}\n"
			 "  - {name: b, bus: s, id: 2, mode: torque, torque_constant_nm_a: 2, "
			 "comm_loss_ms: 0}\n"
			 "  - {name: c, bus: s, id: 3, mode: torque, torque_constant_nm_a: 2, "
			 "comm_loss_ms: 250}\n"),
		0);
	assert_int_equal(cfg.motors[0].comm_loss_ms, RMD_CONFIG_COMM_LOSS_INHERIT);
	assert_int_equal(rmd_config_comm_loss_ms(&cfg, 0), 150);
	assert_int_equal(rmd_config_comm_loss_ms(&cfg, 1), 0);
	assert_int_equal(rmd_config_comm_loss_ms(&cfg, 2), 250);
	assert_int_equal(sim.buses[0].faults[0].cmd, 0xB3);
	assert_int_equal(sim.buses[0].faults[0].count, 1);
	/* a motor's own time is checked against its command period like the global one */
	assert_int_equal(
		load_str("cl-short.yaml",
			 "loop: {rate_hz: 100}\n"
			 "buses:\n  - {name: s, type: sim}\n"
			 "motors:\n"
			 "  - {name: a, bus: s, id: 1, mode: torque, torque_constant_nm_a: 2, "
			 "comm_loss_ms: 20}\n"),
		-EINVAL);
	expect_in(err, ":5: motors[0].comm_loss_ms: 20 ms is shorter than 5 command "
		       "periods of motor a");
	assert_true(load_str("cl-neg.yaml",
			     "buses:\n  - {name: s, type: sim}\n"
			     "motors:\n"
			     "  - {name: a, bus: s, id: 1, mode: torque, torque_constant_nm_a: 2, "
			     "comm_loss_ms: -1}\n") < 0);
}

/*
 * Issue 13: a V2 motor has no 0xB3 (the V2 manual's command list), so it
 * is driven only when the file turns its protection off: comm_loss_ms 0,
 * its own or safety's.  Otherwise the file is refused, naming the motor
 * and what to write.
 */
static void test_v2_needs_protection_off(void **state)
{
#define V2_BUS "buses:\n  - {name: s, type: sim}\nmotors:\n"
#define V2_MOTOR \
	"  - {name: grip, bus: s, id: 1, protocol: v2, mode: torque, torque_constant_nm_a: 2"
	(void)state;
	/* the default (100 ms) does not do */
	assert_int_equal(load_str("v2-default", V2_BUS V2_MOTOR "}\n"), -EINVAL);
	expect_in(err, ":4: motors[0].comm_loss_ms: motor grip is V2, which has no comm-loss "
		       "protection (no 0xB3 in the V2 manual)");
	expect_in(err, "write comm_loss_ms: 0 in its entry");
	/* nor its own time, nor safety's: the line is the key's */
	assert_int_equal(load_str("v2-own", V2_BUS "  - {name: a, bus: s, id: 2, mode: torque, "
						   "torque_constant_nm_a: 2}\n" V2_MOTOR
						   ",\n     comm_loss_ms: 200}\n"),
			 -EINVAL);
	expect_in(err, ":6: motors[1].comm_loss_ms: motor grip is V2");
	assert_null(strstr(err, "motor a "));
	assert_int_equal(load_str("v2-safety",
				  "safety: {comm_loss_ms: 300}\n" V2_BUS V2_MOTOR "}\n"),
			 -EINVAL);
	expect_in(err, "motor grip is V2");
	/* the motor's own 0 is the consent, and only its own motor gets it */
	assert_int_equal(load_str("v2-off",
				  V2_BUS V2_MOTOR ", comm_loss_ms: 0}\n"
						  "  - {name: b, bus: s, id: 2, mode: torque, "
						  "torque_constant_nm_a: 2}\n"),
			 0);
	assert_string_equal(err, "");
	assert_int_equal(rmd_config_comm_loss_ms(&cfg, 0), 0);
	assert_int_equal(rmd_config_comm_loss_ms(&cfg, 1), RMD_CONFIG_DEFAULT_COMM_LOSS_MS);
	/* safety's 0, written, turns it off for every motor, V2 included */
	assert_int_equal(
		load_str("v2-all-off", "safety: {comm_loss_ms: 0}\n" V2_BUS V2_MOTOR "}\n"), 0);
	assert_int_equal(rmd_config_comm_loss_ms(&cfg, 0), 0);
#undef V2_MOTOR
#undef V2_BUS
}

/* motors[].feedback (docs/feedback.md): its keys, defaults and refusals. */
static void test_feedback_keys(void **state)
{
	static const char head[] =
		"loop: {rate_hz: 500}\nbuses:\n  - {name: s, type: sim}\nmotors:\n";
	static const struct {
		const char *motor, *err;
	} bad[] = {
		/* V2 replies carry the encoder: no 0x92 reads for them */
		{ "protocol: v2, mode: torque, torque_constant_nm_a: 2, feedback: {position: "
		  "multi_turn}",
		  ":5: motors[0].feedback.position: multi_turn is for v3 and mit motors" },
		{ "mode: torque, torque_constant_nm_a: 2, feedback: {rate_hz: 100}",
		  "motors[0].feedback.rate_hz: sets the rate of 0x92 reads: it needs position: "
		  "multi_turn" },
		{ "mode: torque, torque_constant_nm_a: 2, feedback: {position: multi_turn, "
		  "rate_hz: 1000}",
		  "motors[0].feedback.rate_hz: 1000 is more than loop.rate_hz (500)" },
		{ "mode: torque, torque_constant_nm_a: 2, feedback: {position: fine}",
		  "motors[0].feedback.position" },
	};
	char y[1024];

	(void)state;
	snprintf(y, sizeof(y),
		 "%s  - {name: a, bus: s, id: 1, mode: position, torque_constant_nm_a: 2, "
		 "feedback: {position: multi_turn, rate_hz: 125}}\n"
		 "  - {name: b, bus: s, id: 2, protocol: mit, mode: mit, "
		 "feedback: {position: multi_turn}}\n"
		 "  - {name: c, bus: s, id: 3, mode: position, torque_constant_nm_a: 2}\n",
		 head);
	if (load_str("fb.yaml", y))
		fail_msg("%s", err);
	assert_int_equal(cfg.motors[0].feedback.position, RMD_FEEDBACK_MULTI_TURN);
	assert_float_equal(cfg.motors[0].feedback.rate_hz, 125.0, 0);
	assert_int_equal(cfg.motors[1].feedback.position, RMD_FEEDBACK_MULTI_TURN);
	assert_float_equal(cfg.motors[1].feedback.rate_hz, 0.0, 0);
	assert_int_equal(cfg.motors[2].feedback.position, RMD_FEEDBACK_CONTROL);
	for (size_t k = 0; k < sizeof(bad) / sizeof(bad[0]); k++) {
		snprintf(y, sizeof(y), "%s  - {name: a, bus: s, id: 1, %s}\n", head, bad[k].motor);
		if (load_str("fb-bad.yaml", y) != -EINVAL)
			fail_msg("feedback case %zu loaded: %s", k, bad[k].motor);
		expect_in(err, bad[k].err);
	}
}

/* lcm.rt_priority: one below the loop unless set; never at or above the loop's. */
static void test_lcm_rt_priority(void **state)
{
	static const char motors[] = "buses:\n  - {name: s, type: sim}\n"
				     "motors:\n"
				     "  - {name: a, bus: s, id: 1, mode: torque, "
				     "torque_constant_nm_a: 2}\n";
	char doc[512];

	(void)state;
	assert_int_equal(load_str("lp-auto.yaml", motors), 0);
	assert_int_equal(cfg.lcm.rt_priority, RMD_CONFIG_LCM_PRIO_AUTO);
	snprintf(doc, sizeof(doc), "loop: {rt_priority: 30}\nlcm: {rt_priority: 29}\n%s", motors);
	assert_int_equal(load_str("lp-29.yaml", doc), 0);
	assert_int_equal(cfg.lcm.rt_priority, 29);
	snprintf(doc, sizeof(doc), "lcm: {rt_priority: 0}\n%s", motors);
	assert_int_equal(load_str("lp-0.yaml", doc), 0);
	assert_int_equal(cfg.lcm.rt_priority, 0);
	snprintf(doc, sizeof(doc), "loop: {rt_priority: 30}\nlcm: {rt_priority: 30}\n%s", motors);
	assert_int_equal(load_str("lp-30.yaml", doc), -EINVAL);
	expect_in(err, ":2: lcm.rt_priority: 30: must be below loop.rt_priority (30)");
	snprintf(doc, sizeof(doc), "lcm: {rt_priority: 49}\n%s", motors);
	assert_int_equal(load_str("lp-49.yaml", doc), -EINVAL);
	expect_in(err, "lcm.rt_priority: 49 is out of range (0..48)");
}

/* protocol: v4 (docs/protocol-v4.md) on CAN and on RS485 (V4.2 §1.2). */
static void test_protocol_v4(void **state)
{
	(void)state;
	assert_int_equal(load_str("v4",
				  "buses:\n  - {name: can0, type: socketcan}\n"
				  "  - {name: rs0, type: rs485, device: /dev/ttyS0}\n"
				  "motors:\n"
				  "  - {name: m1, bus: can0, id: 1, protocol: v4, mode: torque, "
				  "torque_constant_nm_a: 2}\n"
				  "  - {name: m2, bus: rs0, id: 2, protocol: v4, mode: position, "
				  "torque_constant_nm_a: 2}\n"),
			 0);
	if (cfg.n_motors != 2)
		fail_msg("%s", err);
	assert_int_equal(cfg.motors[0].proto, RMD_PROTO_V4);
	assert_int_equal(cfg.motors[1].proto, RMD_PROTO_V4);
}

/*
 * Issue 19 protocol auto and issue 20.7: auto makes a V3 motor until
 * bring-up; units rotor is refused for motors in mode mit.
 */
static void test_protocol_auto_and_mit_units(void **state)
{
	(void)state;
	assert_int_equal(load_str("auto",
				  BUS "motors:\n  - {name: m1, bus: can0, id: 1, "
				      "protocol: auto, mode: torque, torque_constant_nm_a: 2}\n"),
			 0);
	assert_true(cfg.motors[0].proto_auto);
	assert_int_equal(cfg.motors[0].proto, RMD_PROTO_V3);
	assert_int_not_equal(load_str("mit-rotor", BUS "motors:\n  - {name: m1, bus: can0, id: 1, "
						       "protocol: mit, mode: mit, units: rotor, "
						       "gear_ratio: 6}\n"),
			     0);
	expect_in(err, "motors[0].units: rotor is not for mode mit");
	assert_int_not_equal(load_str("v4-mit-rotor", BUS "motors:\n  - {name: m1, bus: can0, "
							  "id: 1, protocol: v4, mode: mit, "
							  "units: rotor, gear_ratio: 6}\n"),
			     0);
	expect_in(err, "motors[0].units: rotor is not for mode mit");
}

/*
 * Issue 33.5: MIT is a mode of V3 and V4 firmware.  mode mit loads with
 * protocol v3, v4 and auto (no torque constant needed, as its frames carry
 * torque); protocol: mit stays V3 firmware driven in MIT; the mit keys an
 * entry names are recorded, for bring-up to hold them against the
 * firmware's scaling; V2 (no 0x400 frames) and RS485 (MIT is CAN only)
 * are refused at FILE:LINE, saying what to write.
 */
static void test_mit_mode_spellings(void **state)
{
	(void)state;
	assert_int_equal(load_str("mit-mode-ok", BUS
				  "motors:\n"
				  "  - {name: a, bus: can0, id: 1, protocol: v3, mode: mit}\n"
				  "  - {name: b, bus: can0, id: 2, protocol: v4, mode: mit,\n"
				  "     mit: {t_min: -60, t_max: 60, kd_max: 50}}\n"
				  "  - {name: c, bus: can0, id: 3, protocol: auto, mode: mit}\n"
				  "  - {name: d, bus: can0, id: 4, protocol: mit, mode: mit}\n"),
			 0);
	if (cfg.n_motors != 4)
		fail_msg("%s", err);
	assert_int_equal(cfg.motors[0].proto, RMD_PROTO_V3);
	assert_int_equal(cfg.motors[1].proto, RMD_PROTO_V4);
	assert_true(cfg.motors[2].proto_auto);
	for (unsigned i = 0; i < 4; i++) {
		assert_int_equal(cfg.motors[i].mode, RMD_MODE_MIT);
		assert_true(rmd_config_mit_mode(&cfg.motors[i]));
	}
	assert_int_equal(cfg.motors[0].mit_given, 0);
	assert_int_equal(cfg.motors[1].mit_given,
			 RMD_MIT_BOUND(4) | RMD_MIT_BOUND(5) | RMD_MIT_BOUND(9));
	assert_true(cfg.motors[1].mit.t_max == 60.0 && cfg.motors[1].mit.kd_max == 50.0);
	assert_true(cfg.motors[1].mit.p_max == 12.5); /* the preset where it names none */

	assert_int_not_equal(load_str("v2-mit",
				      BUS "motors:\n  - {name: m1, bus: can0, id: 1,\n"
					  "     protocol: v2, mode: mit, comm_loss_ms: 0}\n"),
			     0);
	expect_in(err, ":5: motors[0].mode: mit: v2 firmware has no MIT mode (V2 has no 0x400 "
		       "frames): mode mit is for protocol v3, v4 or auto");
	assert_int_not_equal(load_str("rs485-mit", "buses:\n  - {name: rs0, type: rs485, "
						   "device: /dev/ttyS0}\n"
						   "motors:\n  - {name: m1, bus: rs0, id: 1, "
						   "protocol: v4, mode: mit}\n"),
			     0);
	expect_in(err, ":4: motors[0].mode: mit has no RS485 form (V3 §5: MIT frames travel "
		       "on CAN only); bus rs0 is rs485");
	assert_int_not_equal(load_str("mit-speed", BUS "motors:\n  - {name: m1, bus: can0, id: 1, "
						       "protocol: mit, mode: speed, "
						       "torque_constant_nm_a: 2}\n"),
			     0);
	expect_in(err, ":4: motors[0].mode: speed: protocol mit is V3 firmware driven in mode "
		       "mit (V3 §5): set mode: mit, or protocol: v3 for mode speed");
}

/*
 * Issue 31 point 5: the lines of a motor's position limits and travel_rad,
 * for rmdd --check-config's warnings (FILE:LINE of the key); 0 when the
 * entry does not write them.
 */
static void test_position_key_lines(void **state)
{
	static const struct {
		const char *keys; /* after the entry's first line */
		unsigned min_line, max_line, travel_line;
	} rows[] = {
		{ "", 0, 0, 0 },
		{ "    limits:\n      position_min_rad: -90\n      position_max_rad: 90\n", 9, 10,
		  0 },
		{ "    limits: {position_max_rad: 90}\n    travel_rad: [0, 180]\n", 0, 8, 9 },
		{ "    travel_rad: [0, 1]\n", 0, 0, 8 },
	};
	char yaml[1024];

	(void)state;
	for (size_t k = 0; k < sizeof(rows) / sizeof(rows[0]); k++) {
		snprintf(
			yaml, sizeof(yaml),
			"buses: [{name: s0, type: sim}]\n"
			"motors:\n"
			"  - {name: knee, bus: s0, id: 1, mode: torque, torque_constant_nm_a: 2}\n");
		if (rows[k].keys[0])
			snprintf(
				yaml, sizeof(yaml),
				"buses: [{name: s0, type: sim}]\n"
				"motors:\n"
				"  - name: knee\n"
				"    bus: s0\n    id: 1\n    mode: torque\n    torque_constant_nm_a: 2\n%s",
				rows[k].keys);
		if (load_str("lines", yaml) != 0)
			fail_msg("row %zu: %s", k, err);
		assert_int_equal(cfg.motors[0].pos_min_line, rows[k].min_line);
		assert_int_equal(cfg.motors[0].pos_max_line, rows[k].max_line);
		assert_int_equal(cfg.motors[0].travel_line, rows[k].travel_line);
	}
}

/*
 * Issue 30: robot: keys (docs/robot.md).  No section: alone, the defaults.
 * A section: its instance, peers and times; a peer list naming the
 * daemon itself, a peer twice, peers without an instance, a timeout one
 * heartbeat long, 17 peers, a name that is not one: FILE:LINE errors.
 */
static void test_robot_keys(void **state)
{
	static const char motors[] = "buses:\n  - {name: s, type: sim}\n"
				     "motors:\n"
				     "  - {name: a, bus: s, id: 1, mode: torque, "
				     "torque_constant_nm_a: 2}\n";
	static const struct {
		const char *robot, *expect;
	} bad[] = {
		{ "robot:\n  instance: left\n  peers: [right, left]\n",
		  ":3: robot.peers[1]: \"left\" is this daemon's own instance" },
		{ "robot:\n  instance: left\n  peers:\n    - right\n    - right\n",
		  ":5: robot.peers[1]: \"right\" is listed twice (also [0])" },
		{ "robot:\n  peers: [right]\n",
		  ":2: robot.instance: a robot: section needs this daemon's instance name" },
		{ "robot: {instance: left, heartbeat_ms: 50, peer_timeout_ms: 60}\n",
		  ":1: robot.peer_timeout_ms: 60 ms: at least two heartbeats" },
		{ "robot: {instance: Left}\n", ":1: robot.instance: \"Left\" is not a name" },
		{ "robot: {instance: left, on_peer_lost: ignore}\n",
		  "robot.on_peer_lost: \"ignore\"" },
		{ "robot: {instance: left, heartbeat_ms: 0}\n",
		  "robot.heartbeat_ms: 0 is out of range (1..10000)" },
		{ "robot: {instance: left, peers: [a, b, c, d, e, f, g, h, i, j, k, l, m, n, o, p, "
		  "q]}\n",
		  "robot.peers" },
		{ "robot: {instance: left, peer: [right]}\n",
		  "robot.peer: unknown key (did you mean peers?)" },
	};
	char doc[1024];

	(void)state;
	assert_int_equal(load_str("robot-none.yaml", motors), 0);
	assert_string_equal(cfg.robot.instance, "");
	assert_int_equal(cfg.robot.n_peers, 0);
	assert_int_equal(cfg.robot.heartbeat_ms, RMD_CONFIG_DEFAULT_HEARTBEAT_MS);
	assert_int_equal(cfg.robot.peer_timeout_ms, RMD_CONFIG_DEFAULT_PEER_TIMEOUT_MS);
	assert_int_equal(cfg.robot.on_peer_lost, RMD_PEER_LOST_SAFE);

	snprintf(doc, sizeof(doc),
		 "robot:\n  instance: left_leg\n  peers: [right_leg, torso]\n"
		 "  heartbeat_ms: 20\n  peer_timeout_ms: 200\n  on_peer_lost: report\n"
		 "  max_clock_offset_ms: 5\n%s",
		 motors);
	if (load_str("robot-good.yaml", doc) != 0)
		fail_msg("%s", err);
	assert_string_equal(cfg.robot.instance, "left_leg");
	assert_int_equal(cfg.robot.n_peers, 2);
	assert_string_equal(cfg.robot.peers[0], "right_leg");
	assert_string_equal(cfg.robot.peers[1], "torso");
	assert_int_equal(cfg.robot.heartbeat_ms, 20);
	assert_int_equal(cfg.robot.peer_timeout_ms, 200);
	assert_int_equal(cfg.robot.on_peer_lost, RMD_PEER_LOST_REPORT);
	assert_int_equal(cfg.robot.max_clock_offset_ms, 5);

	for (size_t k = 0; k < sizeof(bad) / sizeof(bad[0]); k++) {
		snprintf(doc, sizeof(doc), "%s%s", bad[k].robot, motors);
		if (load_str("robot-bad.yaml", doc) != -EINVAL)
			fail_msg("case %zu loaded:\n%s", k, bad[k].robot);
		if (!strstr(err, bad[k].expect))
			fail_msg("case %zu: expected \"%s\" in:\n%s", k, bad[k].expect, err);
		expect_in(err, "/tmp/rmd-test-robot-bad.yaml");
	}
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_examples_load),
		cmocka_unit_test(test_protocol_auto_and_mit_units),
		cmocka_unit_test(test_mit_mode_spellings),
		cmocka_unit_test(test_example_sim12),
		cmocka_unit_test(test_example_rmdd),
		cmocka_unit_test(test_defaults),
		cmocka_unit_test(test_bad_files),
		cmocka_unit_test(test_nonexistent),
		cmocka_unit_test(test_bad_strings),
		cmocka_unit_test(test_sim_on_real_bus),
		cmocka_unit_test(test_too_many_motors),
		cmocka_unit_test(test_good_values),
		cmocka_unit_test(test_strays_and_filter),
		cmocka_unit_test(test_small_err_buffer),
		cmocka_unit_test(test_sim_default),
		cmocka_unit_test(test_names),
		cmocka_unit_test(test_fault_units),
		cmocka_unit_test(test_hostile_sizes),
		cmocka_unit_test(test_hostile_anchors),
		cmocka_unit_test(test_special_files),
		cmocka_unit_test(test_nul_refused),
		cmocka_unit_test(test_range_u64),
		cmocka_unit_test(test_physical_lower_bounds),
		cmocka_unit_test(test_comm_loss_keys),
		cmocka_unit_test(test_v2_needs_protection_off),
		cmocka_unit_test(test_feedback_keys),
		cmocka_unit_test(test_lcm_rt_priority),
		cmocka_unit_test(test_protocol_v4),
		cmocka_unit_test(test_position_key_lines),
		cmocka_unit_test(test_robot_keys),
	};
	const char *dir = getenv("RMD_SRCDIR");

	if (dir && *dir)
		snprintf(srcdir, sizeof(srcdir), "%s", dir);
	return SUITE_RUN("config", tests, NULL, NULL);
}
