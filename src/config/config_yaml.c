// SPDX-License-Identifier: MIT
/*
 * rmdd's configuration file (rmd/config_yaml.h): YAML -> struct rmd_config
 * and struct rmd_sim_setup.  Non-rt.
 *
 * The generic work, the document tree and walking it against schema tables,
 * is yaml_schema.c; this file holds rmdd's tables and the checks across
 * keys (validate_*): a motor's bus exists, IDs are unique per bus, names
 * are unique, protocol and mode agree, ranges are ordered, keys belong to
 * the bus type; every motor gets its simulated model's parameters (rmdd's
 * sim buses use them; on a socketcan or rs485 bus they are rmd-sim's).
 * Every error goes through rmd_yaml_report(): "FILE:LINE: key.path:
 * message".
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/config_yaml.h"
#include "rmd/dialect.h"
#include "rmd/personality_load.h"
#include "rmd/rs485.h"
#include "rmd/sim_params.h"
#include "rmd/sim_wire.h"
#include "yaml_schema.h"

/* struct yctx.bad[] masks (struct field.mark). */
enum { MARK_BUS = 1, MARK_MOTOR = 2 };

#define SEQM(k, st, m, cnt, el, ini, mk)                                                           \
	{                                                                                          \
		.key = k, .type = T_SEQ, .off = offsetof(st, m),                                   \
		.size = sizeof(((st *)0)->m) / sizeof(((st *)0)->m[0]), .elem = el,                \
		.elem_size = sizeof(((st *)0)->m[0]), .count_off = offsetof(st, cnt), .init = ini, \
		.mark = mk                                                                         \
	}

/* ------------------------------------------------------------------ */
/* rmdd's schema */

static const char prio_why[] =
	"the kernel's IRQ threads run at SCHED_FIFO 50 and deliver this loop's own replies; a "
	"loop at 50 or above starves them (docs/design.md), and 99 is the kernel's own level";

static const struct field loop_fields[] = {
	UINT("rate_hz", struct rmd_config_loop, rate_hz, 1, RMD_CONFIG_RATE_MAX_HZ, 0),
	UINTW("rt_priority", struct rmd_config_loop, rt_priority, 1, RMD_CONFIG_PRIO_MAX, prio_why),
	{ .key = "cpu_affinity",
	  .type = T_SEQ,
	  .off = offsetof(struct rmd_config_loop, cpus),
	  .size = RMD_CONFIG_MAX_CPUS,
	  .elem = &(const struct field){ .type = T_UINT, .size = sizeof(uint16_t), .max = 1023 },
	  .elem_size = sizeof(uint16_t),
	  .count_off = offsetof(struct rmd_config_loop, n_cpus) },
	BOOL("keep_cpus_awake", struct rmd_config_loop, keep_cpus_awake),
	END
};

static const struct field safety_fields[] = {
	UINT("comm_loss_ms", struct rmd_config_safety, comm_loss_ms, 0, 600000, 0),
	UINT("missed_replies_lost", struct rmd_config_safety, missed_replies_lost, 1, 10000, 0),
	UINT("command_timeout_ms", struct rmd_config_safety, command_timeout_ms, 1, 600000, 0),
	ENUM("safe_action", struct rmd_config_safety, safe_action, rmd_safe_action_names, 0),
	ENUM("lost_motor_action", struct rmd_config_safety, lost_motor_action,
	     rmd_lost_action_names, 0),
	ENUM("shutdown_action", struct rmd_config_safety, shutdown_action,
	     rmd_shutdown_action_names, 0),
	UINT("shutdown_damp_ms", struct rmd_config_safety, shutdown_damp_ms, 0, 10000, 0),
	END
};

static const struct field probe_fields[] = {
	ENUM("on_missing", struct rmd_config_probe, on_missing, rmd_on_missing_names, 0),
	UINT("reply_timeout_ms", struct rmd_config_probe, reply_timeout_ms, 1, 10000, 0), END
};

static const struct field lcm_fields[] = {
	STR("url", struct rmd_config_lcm, url, 0),
	STR("channel_prefix", struct rmd_config_lcm, channel_prefix, 0),
	UINT("state_every_n", struct rmd_config_lcm, state_every_n, 1, 10000, 0),
	UINT("stale_ms", struct rmd_config_lcm, stale_ms, 0, 600000, 0),
	UINT("health_period_ms", struct rmd_config_lcm, health_period_ms, 10, 600000, 0),
	UINT("rt_priority", struct rmd_config_lcm, rt_priority, 0, RMD_CONFIG_PRIO_MAX - 1, 0),
	END
};

static const struct field robot_fields[] = {
	STR("instance", struct rmd_config_robot, instance, F_IDENT),
	{ .key = "peers",
	  .type = T_SEQ,
	  .off = offsetof(struct rmd_config_robot, peers),
	  .size = RMD_CONFIG_MAX_PEERS,
	  .elem = &(const struct field){ .type = T_STR,
					 .flags = F_IDENT,
					 .size = RMD_CONFIG_INSTANCE_LEN },
	  .elem_size = RMD_CONFIG_INSTANCE_LEN,
	  .count_off = offsetof(struct rmd_config_robot, n_peers) },
	UINT("heartbeat_ms", struct rmd_config_robot, heartbeat_ms, 1, 10000, 0),
	UINT("peer_timeout_ms", struct rmd_config_robot, peer_timeout_ms, 2, 600000, 0),
	ENUM("on_peer_lost", struct rmd_config_robot, on_peer_lost, rmd_peer_lost_names, 0),
	UINT("max_clock_offset_ms", struct rmd_config_robot, max_clock_offset_ms, 1, 3600000, 0),
	END
};

static const struct field incidents_fields[] = {
	BOOL("enabled", struct rmd_config_incidents, enabled),
	STR("dir", struct rmd_config_incidents, dir, 0),
	DBL("seconds_before", struct rmd_config_incidents, seconds_before, 0.0,
	    RMD_CONFIG_INCIDENT_MAX_WINDOW_S, 0),
	DBL("seconds_after", struct rmd_config_incidents, seconds_after, 0.0,
	    RMD_CONFIG_INCIDENT_MAX_WINDOW_S, 0),
	UINT("keep", struct rmd_config_incidents, keep, 1, 10000, 0),
	UINT("overrun_burst", struct rmd_config_incidents, overrun_burst, 1, 1000000, 0),
	END
};

/*
 * The simulated motor's model: bus-wide (sim.motor) or per motor
 * (motors[].sim).  Its keys are the rows of the simulator's parameter
 * table (rmd/sim_params.h), the ones rmd-sim reads, but for those the motor
 * entry sets itself (protocol, mit), plus the motor's PRNG seed.
 */
#define SIM_MOTOR_FIELDS 64
static struct field sim_motor_fields[SIM_MOTOR_FIELDS];
/* buses[].sim.strays[]: the same keys and the motor's id (sim_motor_fields_build()) */
static struct field stray_fields[SIM_MOTOR_FIELDS + 1];

/* T_TEXT: a parameter row's own parser (model, version_date). */
static int sim_param_text(const struct field *f, const char *text, void *dst, char *allowed,
			  size_t size)
{
	const struct rmd_sim_param *row = f->ctx;
	struct rmd_sim_motor_params scratch;
	int r;

	rmd_sim_motor_params_default(&scratch, 1, RMD_PROTO_V3);
	r = rmd_sim_param_parse_file(&scratch, row, text, allowed, size);
	if (r == 0)
		memcpy(dst, (const char *)&scratch + row->off, rmd_sim_param_size(row));
	return r;
}

/* sim_motor_fields[] from the table, once.  Non-rt, not thread-safe (the loader is neither). */
static void sim_motor_fields_build(void)
{
	unsigned n = 0;

	if (sim_motor_fields[0].key)
		return;
	for (size_t i = 0; i < rmd_sim_n_params && n + 2 < SIM_MOTOR_FIELDS; i++) {
		const struct rmd_sim_param *row = &rmd_sim_params[i];
		struct field *f = &sim_motor_fields[n];

		if (row->flags & RMD_SIM_PARAM_MOTOR_KEY)
			continue;
		*f = (struct field){ .key = row->key,
				     .off = row->off,
				     .min = row->min,
				     .max = row->max,
				     .flags = row->min_excl ? F_MIN_EXCL : 0 };
		switch (row->type) {
		case RMD_SIM_PARAM_US:
			f->scale = 1000.0; /* µs -> the ns field */
					   /* fall through */
		case RMD_SIM_PARAM_REAL:
			f->type = T_DOUBLE;
			break;
		case RMD_SIM_PARAM_UINT:
			f->type = T_UINT;
			f->size = sizeof(unsigned);
			break;
		case RMD_SIM_PARAM_BOOL:
			f->type = T_BOOL;
			break;
		case RMD_SIM_PARAM_PROTO:
		case RMD_SIM_PARAM_MODEL:
		case RMD_SIM_PARAM_VERSION:
		case RMD_SIM_PARAM_MIT:
		case RMD_SIM_PARAM_PERSONALITY:
			f->type = T_TEXT;
			f->parse = sim_param_text;
			f->ctx = row;
			break;
		}
		n++;
	}
	sim_motor_fields[n++] = (struct field)UINT("seed", struct rmd_sim_motor_params, seed, 0,
						   18446744073709551615.0, 0);
	sim_motor_fields[n] = (struct field)END;
	stray_fields[0] = (struct field)UINT("id", struct rmd_sim_motor_params, id, 1,
					     RMD_MAX_MOTORS, F_REQUIRED);
	memcpy(stray_fields + 1, sim_motor_fields, (n + 1) * sizeof(sim_motor_fields[0]));
}

/* A stray motor of a sim bus: the simulator's default (V3), id from its entry. */
static void stray_init(void *elem)
{
	rmd_sim_motor_params_default(elem, 1, RMD_PROTO_V3);
}

static const struct field stray_elem = { .type = T_MAP, .sub = stray_fields };

static void fault_init(void *elem)
{
	struct rmd_sim_fault *f = elem;

	memset(f, 0, sizeof(*f));
	f->probability = 1.0;
}

#define F struct rmd_sim_fault
static const struct field fault_fields[] = {
	ENUM("kind", F, kind, rmd_sim_fault_kind_names, F_REQUIRED),
	UINT("motor", F, motor_id, 0, RMD_MAX_MOTORS, 0),
	DBL("probability", F, probability, 0, 1, 0), NS("start_s", F, start_ns, 0, 1e6, 1e9),
	NS("end_s", F, end_ns, 0, 1e6, 1e9), INT("param", F, param, -1e15, 1e15, 0),
	/* rmd-sim's units: delay:ID:US, flood:..:PERIOD_US */
	NS("delay_us", F, param, 0, 1e7, 1000.0), NS("period_us", F, param, 0, 1e7, 1000.0),
	UINT("can_id", F, can_id, 0, 0x7FF, 0),
	/* per-frame kinds: answers to this command only, at most count of them */
	UINT("cmd", F, cmd, 0, 255, 0), UINT("count", F, count, 0, 4294967295.0, 0), END
};
#undef F

static const struct field fault_elem = { .type = T_MAP, .sub = fault_fields };

#define S struct rmd_sim_bus_setup
static const struct field sim_fields[] = {
	UINT("seed", S, seed, 0, 18446744073709551615.0, 0),
	UINT("txqueuelen", S, txqueuelen, 1, RMD_SIM_WIRE_TXQ, 0),
	BOOL("host_fifo", S, host_fifo),
	BOOL("refuse_flush", S, refuse_flush),
	MAP("motor", S, motor, sim_motor_fields),
	SEQ("faults", S, faults, n_faults, &fault_elem, fault_init),
	SEQ("strays", S, strays, n_strays, &stray_elem, stray_init),
	STR("tap", S, tap, 0),
	END
};
#undef S

#define B struct rmd_config_bus
static const struct field bus_fields[] = { STR("name", B, name, F_REQUIRED | F_IDENT),
					   ENUM("type", B, kind, rmd_bus_kind_names, F_REQUIRED),
					   STR("interface", B, interface, 0),
					   STR("device", B, device, 0),
					   UINT("baud", B, baud, 1, 100000000, 0),
					   UINT("bitrate", B, bitrate, 1, 100000000, 0),
					   NS("turnaround_us", B, turnaround_ns, 0, 1e6, 1000.0),
					   BOOL("can_id_filter", B, can_id_filter),
					   LATER("sim"),
					   END };
#undef B

#define L struct rmd_config_limits
static const struct field limits_fields[] = {
	DBL("position_min_rad", L, position_min_rad, -1e6, 1e6, 0),
	DBL("position_max_rad", L, position_max_rad, -1e6, 1e6, 0),
	DBL("velocity_rad_s", L, velocity_rad_s, RMD_CONFIG_MIN_LIMIT, 1e4, 0),
	DBL("torque_nm", L, torque_nm, RMD_CONFIG_MIN_LIMIT, 1e5, 0), END
};
#undef L

#define R struct rmd_mit_ranges
static const struct field mit_fields[] = {
	DBL("p_min", R, p_min, -RMD_MIT_RANGE_LIMIT, RMD_MIT_RANGE_LIMIT, 0),
	DBL("p_max", R, p_max, -RMD_MIT_RANGE_LIMIT, RMD_MIT_RANGE_LIMIT, 0),
	DBL("v_min", R, v_min, -RMD_MIT_RANGE_LIMIT, RMD_MIT_RANGE_LIMIT, 0),
	DBL("v_max", R, v_max, -RMD_MIT_RANGE_LIMIT, RMD_MIT_RANGE_LIMIT, 0),
	DBL("t_min", R, t_min, -RMD_MIT_RANGE_LIMIT, RMD_MIT_RANGE_LIMIT, 0),
	DBL("t_max", R, t_max, -RMD_MIT_RANGE_LIMIT, RMD_MIT_RANGE_LIMIT, 0),
	DBL("kp_min", R, kp_min, 0, RMD_MIT_RANGE_LIMIT, 0),
	DBL("kp_max", R, kp_max, 0, RMD_MIT_RANGE_LIMIT, 0),
	DBL("kd_min", R, kd_min, 0, RMD_MIT_RANGE_LIMIT, 0),
	DBL("kd_max", R, kd_max, 0, RMD_MIT_RANGE_LIMIT, 0),
	END
};
#undef R

#define FB struct rmd_config_feedback
static const struct field feedback_fields[] = {
	ENUM("position", FB, position, rmd_feedback_pos_names, 0),
	DBL("rate_hz", FB, rate_hz, 1, RMD_CONFIG_RATE_MAX_HZ, 0), END
};
#undef FB

#define M struct rmd_config_motor
static const struct field motor_fields[] = {
	STR("name", M, name, F_REQUIRED | F_IDENT),
	LATER("bus"),
	UINT("id", M, id, 1, RMD_MAX_MOTORS, F_REQUIRED),
	ENUM("protocol", M, proto, rmd_config_proto_keys, 0),
	ENUM("mode", M, mode, rmd_mode_names, F_REQUIRED),
	INT("direction", M, direction, -1, 1, F_SIGN),
	DBL("gear_ratio", M, gear_ratio, RMD_CONFIG_MIN_GEAR_RATIO, 1e4, 0),
	ENUM("units", M, units, rmd_units_names, 0),
	DBL("zero_offset_rad", M, zero_offset_rad, -1e6, 1e6, 0),
	DBL("torque_constant_nm_a", M, torque_constant_nm_a, RMD_CONFIG_MIN_KT_NM_A, 1e4, 0),
	MAP("limits", M, limits, limits_fields),
	MAP("mit", M, mit, mit_fields),
	UINT("rate_divisor", M, rate_divisor, 1, RMD_CONFIG_DIVISOR_MAX, 0),
	DBL("status_poll_hz", M, status_poll_hz, 0, RMD_CONFIG_RATE_MAX_HZ, 0),
	INT("comm_loss_ms", M, comm_loss_ms, 0, 600000, 0),
	MAP("feedback", M, feedback, feedback_fields),
	BOOL("multi_turn_saved", M, multi_turn_saved),
	UINT("brake_release_ms", M, brake_release_ms, 0, 2000, 0),
	{ .key = "travel_rad",
	  .type = T_SEQ,
	  .off = offsetof(M, travel_rad),
	  .size = 2,
	  .elem = &(const struct field){ .type = T_DOUBLE, .min = -1e6, .max = 1e6 },
	  .elem_size = sizeof(double),
	  .count_off = offsetof(M, n_travel) },
	LATER("sim"),
	END
};
#undef M

/* SEQ init hooks: an entry starts from the model's defaults. */
static void bus_init(void *elem)
{
	rmd_config_bus_defaults(elem);
}

static void motor_init(void *elem)
{
	rmd_config_motor_defaults(elem);
}

static const struct field bus_elem = { .type = T_MAP, .sub = bus_fields };
static const struct field motor_elem = { .type = T_MAP, .sub = motor_fields };

#define C struct rmd_config
static const struct field top_fields[] = {
	MAP("loop", C, loop, loop_fields),
	MAP("safety", C, safety, safety_fields),
	MAP("probe", C, probe, probe_fields),
	MAP("lcm", C, lcm, lcm_fields),
	MAP("robot", C, robot, robot_fields),
	MAP("incidents", C, incidents, incidents_fields),
	SEQM("buses", C, buses, n_buses, &bus_elem, bus_init, MARK_BUS),
	SEQM("motors", C, motors, n_motors, &motor_elem, motor_init, MARK_MOTOR),
	LATER("sim"),
	END
};
#undef C

/* The top-level sim: section, the simulator's across buses: the physics (docs/physics.md). */
#define P struct rmd_sim_physics_setup
static const struct field physics_fields[] = {
	STR("model", P, model, F_REQUIRED),
	UINT("rate_hz", P, rate_hz, 1, 20000, 0),
	UINT("substeps", P, substeps, 1, 100, 0),
	LATER("joints"),
	END,
};
#undef P

#define T struct rmd_sim_setup
static const struct field sim_top_fields[] = { MAP("physics", T, physics, physics_fields), END };
#undef T

/* ------------------------------------------------------------------ */
/* The simulator's settings */

/* Every bus and motor of the simulator's settings at its defaults. */
static void sim_setup_default(struct rmd_sim_setup *sim)
{
	for (unsigned b = 0; b < RMD_MAX_BUSES; b++)
		rmd_sim_bus_setup_default(&sim->buses[b], 1);
	for (unsigned i = 0; i < RMD_MAX_MOTORS; i++)
		sim->motors[i] = sim->buses[0].motor;
	memset(&sim->physics, 0, sizeof(sim->physics));
}

/*
 * Each bus's `sim:` section into the simulator's settings (beside struct
 * rmd_config, so not in bus_fields' offsets); errors there mark the bus.
 */
static void walk_bus_sims(struct yctx *c, const struct rmd_config *cfg, struct rmd_sim_setup *sim,
			  const struct ynode *seq)
{
	static const struct field f = { .type = T_MAP, .sub = sim_fields };
	char path[PATH_LEN];

	for (unsigned i = 0; seq && seq->kind == Y_SEQ && i < cfg->n_buses; i++) {
		const struct ynode *sn = rmd_yaml_get(seq->kids[i], "sim", NULL);
		unsigned before = c->nerr;

		if (!sn)
			continue;
		snprintf(path, sizeof(path), "buses[%u].sim", i);
		rmd_yaml_walk_value(c, sn, &f, &sim->buses[i], path);
		if (c->nerr != before)
			c->bad[MARK_BUS - 1] |= 1u << i;
	}
}

/* The model's path as given, relative ones against the configuration file's folder. */
static void physics_model_path(struct yctx *c, const char *cfg_path, const struct ynode *pn,
			       struct rmd_sim_physics_setup *ps)
{
	const char *slash = strrchr(cfg_path, '/');
	char given[RMD_SIM_MODEL_PATH_LEN];
	int n;

	if (!ps->model[0] || ps->model[0] == '/' || !slash)
		return;
	snprintf(given, sizeof(given), "%s", ps->model);
	n = snprintf(ps->model, sizeof(ps->model), "%.*s/%s", (int)(slash - cfg_path), cfg_path,
		     given);
	if (n < 0 || (size_t)n >= sizeof(ps->model))
		rmd_yaml_report(c, rmd_yaml_line_of(pn, "model"), "sim.physics.model",
				"\"%s\" beside %s: the path is longer than %d bytes", given,
				cfg_path, RMD_SIM_MODEL_PATH_LEN - 1);
}

/*
 * sim.physics.joints: motor name -> joint name.  Every motor a motor of
 * motors[], each joint for one motor; whether the model has those joints
 * is known when the simulator loads it (rmd/sim_body.h).
 */
static void physics_joints(struct yctx *c, const struct rmd_config *cfg, const struct ynode *pn,
			   struct rmd_sim_physics_setup *ps)
{
	unsigned kl;
	const struct ynode *jn = rmd_yaml_get(pn, "joints", &kl);
	char kp[PATH_LEN];

	if (!jn) {
		rmd_yaml_report(c, pn->line, "sim.physics.joints",
				"required key missing: which motor drives which joint of the "
				"model (motor_name: joint_name)");
		return;
	}
	if (jn->kind != Y_MAP) {
		rmd_yaml_report(c, jn->line, "sim.physics.joints",
				"expected a mapping of motor names to joint names, got %s",
				rmd_yaml_kind_desc(jn));
		return;
	}
	for (unsigned k = 0; k + 1 < jn->n; k += 2) {
		const struct ynode *key = jn->kids[k], *v = jn->kids[k + 1];
		struct rmd_sim_physics_joint *pj = &ps->joints[ps->n_joints];
		unsigned i;

		rmd_yaml_path_key(kp, "sim.physics.joints", key->str ? key->str : "?");
		for (i = 0; i < cfg->n_motors; i++)
			if (key->str && !strcmp(cfg->motors[i].name, key->str))
				break;
		if (i == cfg->n_motors) {
			rmd_yaml_report(c, key->line, kp, "no motor of that name in motors[]");
			continue;
		}
		if (v->kind != Y_SCALAR || !v->str || !v->str[0] ||
		    strlen(v->str) >= RMD_SIM_JOINT_NAME_LEN) {
			rmd_yaml_report(
				c, v->line, kp,
				"expected the name of a joint of the model (1..%d characters)",
				RMD_SIM_JOINT_NAME_LEN - 1);
			continue;
		}
		for (unsigned o = 0; o < ps->n_joints; o++)
			if (!strcmp(ps->joints[o].joint, v->str)) {
				rmd_yaml_report(
					c, v->line, kp,
					"joint \"%s\" is mapped twice (motor %s, line %u, too): "
					"one motor per joint",
					v->str, cfg->motors[ps->joints[o].motor].name,
					ps->joints[o].line);
				break;
			}
		if (ps->n_joints >= RMD_MAX_MOTORS)
			break;
		pj->motor = i;
		pj->line = v->line;
		snprintf(pj->joint, sizeof(pj->joint), "%s", v->str);
		ps->n_joints++;
	}
}

/* The top-level `sim:` section (sim.physics) into the simulator's settings. */
static void walk_top_sim(struct yctx *c, const struct rmd_config *cfg, struct rmd_sim_setup *sim,
			 const struct ynode *root, const char *cfg_path)
{
	static const struct field f = { .type = T_MAP, .sub = sim_top_fields };
	const unsigned step_hz = 1000000000 / RMD_SIM_STEP_NS;
	struct rmd_sim_physics_setup *ps = &sim->physics;
	const struct ynode *sn = rmd_yaml_get(root, "sim", NULL), *pn;
	unsigned before = c->nerr;

	if (!sn)
		return;
	rmd_yaml_walk_value(c, sn, &f, sim, "sim");
	pn = sn->kind == Y_MAP ? rmd_yaml_get(sn, "physics", NULL) : NULL;
	if (!pn || pn->kind != Y_MAP || c->nerr != before)
		return;
	snprintf(ps->source, sizeof(ps->source), "%s", cfg_path);
	ps->model_line = rmd_yaml_line_of(pn, "model");
	if (!ps->rate_hz)
		ps->rate_hz = RMD_SIM_PHYSICS_RATE_HZ;
	else
		ps->rate_line = rmd_yaml_line_of(pn, "rate_hz");
	if (!ps->substeps)
		ps->substeps = 1;
	if (step_hz % ps->rate_hz)
		rmd_yaml_report(c, ps->rate_line, "sim.physics.rate_hz",
				"%u Hz does not divide the motors' step rate (%u Hz): e.g. 1000, "
				"2000, 4000, 5000, 10000",
				ps->rate_hz, step_hz);
	else if (ps->rate_hz < cfg->loop.rate_hz)
		rmd_yaml_report(c, ps->rate_line ? ps->rate_line : pn->line, "sim.physics.rate_hz",
				"%u Hz is below loop.rate_hz (%u Hz): the physics steps at least "
				"once a cycle",
				ps->rate_hz, cfg->loop.rate_hz);
	physics_model_path(c, cfg_path, pn, ps);
	physics_joints(c, cfg, pn, ps);
}

/* ------------------------------------------------------------------ */
/* Checks across keys */

/* Bus key `key` of value v must be one of set[n]: "%u is not <what>". */
static void rate_in(struct yctx *c, const struct ynode *bn, const char *path, const char *key,
		    uint32_t v, const uint32_t *set, size_t n, const char *what)
{
	char kp[PATH_LEN];

	for (size_t i = 0; i < n; i++)
		if (set[i] == v)
			return;
	rmd_yaml_path_key(kp, path, key);
	rmd_yaml_report(c, rmd_yaml_line_of(bn, key), kp, "%u is not %s", v, what);
}

/* A key that the bus's type does not use. */
/* A bus entry's keys that only some types take: each one another type has is refused. */
static void bus_keys_unused(struct yctx *c, const struct ynode *bn, const char *path,
			    const struct rmd_config_bus *b)
{
#define KIND(k) (1u << RMD_BUS_KIND_##k)
	static const struct {
		const char *key, *which;
		unsigned kinds;
	} keys[] = {
		{ "interface", "socketcan", KIND(SOCKETCAN) },
		{ "bitrate", "socketcan or sim", KIND(SOCKETCAN) | KIND(SIM) },
		{ "can_id_filter", "socketcan or sim", KIND(SOCKETCAN) | KIND(SIM) },
		{ "device", "rs485", KIND(RS485) },
		{ "baud", "rs485", KIND(RS485) },
		{ "turnaround_us", "rs485", KIND(RS485) },
	};
#undef KIND
	unsigned kl;
	char kp[PATH_LEN];

	for (size_t k = 0; k < sizeof(keys) / sizeof(keys[0]); k++) {
		if (keys[k].kinds & (1u << b->kind) || !rmd_yaml_get(bn, keys[k].key, &kl))
			continue;
		rmd_yaml_path_key(kp, path, keys[k].key);
		rmd_yaml_report(c, kl, kp, "only for type %s (this bus is %s)", keys[k].which,
				rmd_bus_kind_name(b->kind));
	}
}

/*
 * The `sim:` section of a socketcan or rs485 bus: rmd-sim's, which
 * simulates that bus's motors on the real wire (docs/rmd-sim.md); rmdd
 * talks to the wire and does not use it.  Its keys of the in-process wire
 * have no meaning there and are refused.
 */
static void real_bus_sim(struct yctx *c, const struct ynode *bn, const char *path,
			 struct rmd_config_bus *b)
{
	static const struct {
		const char *key, *instead;
	} wire_only[] = {
		{ "tap", "candump IFACE or rmd-sim -v logs a real wire's frames" },
		{ "txqueuelen", "the interface's own (ip link set IFACE txqueuelen N)" },
		{ "host_fifo", "the kernel's queue sends in order" },
		{ "refuse_flush", "rmdd's capabilities decide (docs/faults.md \"E-stop\")" },
	};
	const struct ynode *sn = rmd_yaml_get(bn, "sim", NULL);
	char sp[PATH_LEN], kp[PATH_LEN];
	unsigned kl;

	if (!sn)
		return;
	b->sim_section = true;
	rmd_yaml_path_key(sp, path, "sim");
	for (size_t k = 0; k < sizeof(wire_only) / sizeof(wire_only[0]); k++) {
		if (!rmd_yaml_get(sn, wire_only[k].key, &kl))
			continue;
		rmd_yaml_path_key(kp, sp, wire_only[k].key);
		rmd_yaml_report(c, kl, kp,
				"only for type sim (the in-process wire); on a %s bus, which "
				"rmd-sim simulates, %s",
				rmd_bus_kind_name(b->kind), wire_only[k].instead);
	}
}

static void validate_sim_model(struct yctx *c, const struct rmd_sim_motor_params *p,
			       const struct ynode *n, const char *path)
{
	char kp[PATH_LEN];

	if (p->over_temp_clear_c > p->over_temp_c) {
		rmd_yaml_path_key(kp, path, "over_temp_clear_c");
		rmd_yaml_report(c, rmd_yaml_line_of(n, "over_temp_clear_c"), kp,
				"%g is above over_temp_c (%g): the fault would never clear",
				p->over_temp_clear_c, p->over_temp_c);
	}
	if (p->under_voltage_v >= p->over_voltage_v) {
		rmd_yaml_path_key(kp, path, "under_voltage_v");
		rmd_yaml_report(c, rmd_yaml_line_of(n, "under_voltage_v"), kp,
				"%g must be below over_voltage_v (%g)", p->under_voltage_v,
				p->over_voltage_v);
	}
}

/*
 * Entry i of seq (node n): its line into *line, its path into path.
 * Returns whether it is a map: only a map has keys to check.  Non-rt.
 */
static bool entry_start(const struct ynode *n, const char *seq, unsigned i, unsigned *line,
			char *path)
{
	*line = n->line;
	rmd_yaml_path_idx(path, seq, i);
	return n->kind == Y_MAP;
}

/*
 * Entry i (at path) of the sequence seq, which is named `what`: reported
 * when `name` is already that of entry `first` (the first so named, or
 * -ENOENT).  Non-rt.
 */
static void name_unique(struct yctx *c, const struct ynode *seq, unsigned i, const char *path,
			const char *what, const char *name, int first)
{
	char kp[PATH_LEN];

	if (!name[0] || first < 0 || (unsigned)first >= i)
		return;
	rmd_yaml_path_key(kp, path, "name");
	rmd_yaml_report(c, rmd_yaml_line_of(seq->kids[i], "name"), kp,
			"\"%s\" is already the name of %s[%d] (line %u)", name, what, first,
			seq->kids[first]->line);
}

/*
 * buses[b].sim.strays (node sn): each a model of its own, and an id that
 * no motor of the file on that bus has, nor another stray.  Non-rt.
 */
static void validate_strays(struct yctx *c, const struct rmd_config *cfg,
			    const struct rmd_sim_setup *sim, unsigned b, const struct ynode *sn,
			    const char *path)
{
	const struct rmd_sim_bus_setup *s = &sim->buses[b];
	char sp[PATH_LEN], ip[PATH_LEN], kp[PATH_LEN];

	if (!sn || sn->kind != Y_SEQ)
		return;
	rmd_yaml_path_key(sp, path, "sim.strays");
	for (unsigned k = 0; k < s->n_strays && k < sn->n; k++) {
		const struct rmd_sim_motor_params *p = &s->strays[k];
		const struct ynode *in = sn->kids[k];

		rmd_yaml_path_idx(ip, sp, k);
		rmd_yaml_path_key(kp, ip, "id");
		for (unsigned i = 0; i < cfg->n_motors; i++)
			if (cfg->motors[i].bus == b && cfg->motors[i].id == p->id)
				rmd_yaml_report(
					c, rmd_yaml_line_of(in, "id"), kp,
					"%u is the id of motors[%u] (%s): a stray is a motor "
					"the file does not list",
					p->id, i, cfg->motors[i].name);
		for (unsigned j = 0; j < k; j++)
			if (s->strays[j].id == p->id)
				rmd_yaml_report(c, rmd_yaml_line_of(in, "id"), kp,
						"%u is already the id of strays[%u] (line %u)",
						p->id, j, sn->kids[j]->line);
		validate_sim_model(c, p, in, ip);
	}
}

static void validate_buses(struct yctx *c, struct rmd_config *cfg, struct rmd_sim_setup *sim,
			   const struct ynode *seq)
{
	static const uint32_t can_rates[] = { 500000, 1000000 };
	char path[PATH_LEN], kp[PATH_LEN];

	for (unsigned i = 0; i < cfg->n_buses; i++) {
		struct rmd_config_bus *b = &cfg->buses[i];
		const struct ynode *bn = seq->kids[i];

		if (!entry_start(bn, "buses", i, &b->line, path))
			continue;
		name_unique(c, seq, i, path, "buses", b->name, rmd_config_bus_find(cfg, b->name));
		if (c->bad[MARK_BUS - 1] & (1u << i))
			continue;
		bus_keys_unused(c, bn, path, b);
		switch (b->kind) {
		case RMD_BUS_KIND_SOCKETCAN:
			real_bus_sim(c, bn, path, b);
			rmd_yaml_path_key(kp, path, "interface");
			if (!rmd_yaml_get(bn, "interface", NULL)) {
				if (strlen(b->name) >= sizeof(b->interface))
					rmd_yaml_report(
						c, bn->line, kp,
						"required: the name \"%s\" is too long for an "
						"interface name (at most %zu characters)",
						b->name, sizeof(b->interface) - 1);
				else
					memcpy(b->interface, b->name, strlen(b->name) + 1);
			} else if (!b->interface[0] || strpbrk(b->interface, "/: \t") ||
				   !strcmp(b->interface, ".") || !strcmp(b->interface, "..")) {
				rmd_yaml_report(c, rmd_yaml_line_of(bn, "interface"), kp,
						"\"%s\" is not a network interface name",
						b->interface);
			}
			rate_in(c, bn, path, "bitrate", b->bitrate, can_rates, 2,
				"a bitrate RMD motors speak (V3 §2.31: 500000 or 1000000)");
			break;
		case RMD_BUS_KIND_RS485:
			real_bus_sim(c, bn, path, b);
			rmd_yaml_path_key(kp, path, "device");
			if (!rmd_yaml_get(bn, "device", NULL))
				rmd_yaml_report(c, bn->line, kp,
						"required for type rs485 (e.g. /dev/ttyUSB0)");
			else if (b->device[0] != '/')
				rmd_yaml_report(c, rmd_yaml_line_of(bn, "device"), kp,
						"\"%s\" is not a device path (e.g. /dev/ttyUSB0)",
						b->device);
			if (rmd_rs485_baud_speed(b->baud, NULL) < 0) {
				rmd_yaml_path_key(kp, path, "baud");
				rmd_yaml_report(
					c, rmd_yaml_line_of(bn, "baud"), kp,
					"%u is not a baud rate RMD motors speak (V3 §1.2.1: "
					"115200, 500000, 1000000, 1500000, 2000000)",
					b->baud);
			}
			break;
		case RMD_BUS_KIND_SIM:
			if (b->bitrate < 10000 || b->bitrate > 1000000) {
				rmd_yaml_path_key(kp, path, "bitrate");
				rmd_yaml_report(c, rmd_yaml_line_of(bn, "bitrate"), kp,
						"%u is out of range (10000..1000000 for a sim bus)",
						b->bitrate);
			}
			break;
		}
		rmd_yaml_path_key(kp, path, "sim.motor");
		validate_sim_model(c, &sim->buses[i].motor,
				   rmd_yaml_get(rmd_yaml_get(bn, "sim", NULL), "motor", NULL), kp);
		validate_strays(c, cfg, sim, i,
				rmd_yaml_get(rmd_yaml_get(bn, "sim", NULL), "strays", NULL), path);
	}
}

/* A fault entry's key that only kind `kind` takes. */
static void only_for(struct yctx *c, const struct ynode *fn, const char *path, const char *key,
		     enum rmd_sim_fault_kind have, enum rmd_sim_fault_kind kind)
{
	char kp[PATH_LEN];

	if (have == kind || !rmd_yaml_get(fn, key, NULL))
		return;
	rmd_yaml_path_key(kp, path, key);
	rmd_yaml_report(c, rmd_yaml_line_of(fn, key), kp, "only for kind %s",
			rmd_sim_fault_kind_name(kind));
}

/* motors[].feedback: 0x92 reads for V3 and MIT motors, at most once a cycle. */
static void validate_feedback(struct yctx *c, const struct rmd_config *cfg,
			      const struct rmd_config_motor *m, const struct ynode *fn,
			      const char *path)
{
	const struct rmd_config_feedback *fb = &m->feedback;
	char kp[PATH_LEN];

	if (fb->position == RMD_FEEDBACK_MULTI_TURN &&
	    !rmd_dialect_has(rmd_dialect(m->proto), RMD_DIALECT_FINE_ANGLE)) {
		rmd_yaml_path_key(kp, path, "feedback.position");
		rmd_yaml_report(
			c, rmd_yaml_line_of(fn, "position"), kp,
			"multi_turn is for v3 and mit motors: a v2 motor's control replies "
			"carry its encoder (V2 §3.32, 2^16 counts a rotor turn), finer than "
			"0x92's 0.01 deg");
	}
	if (fb->rate_hz > 0 && fb->position != RMD_FEEDBACK_MULTI_TURN) {
		rmd_yaml_path_key(kp, path, "feedback.rate_hz");
		rmd_yaml_report(c, rmd_yaml_line_of(fn, "rate_hz"), kp,
				"sets the rate of 0x92 reads: it needs position: multi_turn");
	} else if (fb->rate_hz > cfg->loop.rate_hz) {
		rmd_yaml_path_key(kp, path, "feedback.rate_hz");
		rmd_yaml_report(c, rmd_yaml_line_of(fn, "rate_hz"), kp,
				"%g is more than loop.rate_hz (%u): at most one read a cycle",
				fb->rate_hz, cfg->loop.rate_hz);
	}
}

/* The fault entries of sim bus i, once its motors are known. */
static void validate_faults(struct yctx *c, const struct rmd_config *cfg,
			    const struct rmd_sim_setup *sim, unsigned bi, const struct ynode *bn)
{
	const struct rmd_config_bus *b = &cfg->buses[bi];
	const struct rmd_sim_bus_setup *sb = &sim->buses[bi];
	const struct ynode *faults = rmd_yaml_get(rmd_yaml_get(bn, "sim", NULL), "faults", NULL);
	char path[PATH_LEN], kp[PATH_LEN];

	for (unsigned i = 0; i < sb->n_faults && faults && faults->kind == Y_SEQ; i++) {
		const struct rmd_sim_fault *f = &sb->faults[i];
		const struct ynode *fn = faults->kids[i];
		const char *kind = rmd_sim_fault_kind_names[f->kind];
		const struct rmd_sim_fault_rule *rule = rmd_sim_fault_rule(f->kind);
		bool bus_wide = rule->bus_wide;
		bool found = false;

		snprintf(path, sizeof(path), "buses[%u].sim.faults[%u]", bi, i);
		/* rmd-sim's faults on a real wire (docs/rmd-sim.md "Faults") */
		if (f->kind == RMD_SIM_FAULT_BUS_OFF && b->kind != RMD_BUS_KIND_SIM) {
			rmd_yaml_path_key(kp, path, "kind");
			rmd_yaml_report(
				c, rmd_yaml_line_of(fn, "kind"), kp,
				"bus_off is for type sim: on a %s bus the kernel's controller "
				"owns the bus state, which rmd-sim cannot change (take the "
				"interface down: ip link set IFACE down)",
				rmd_bus_kind_name(b->kind));
		} else if (f->kind == RMD_SIM_FAULT_FLOOD && b->kind == RMD_BUS_KIND_RS485) {
			rmd_yaml_path_key(kp, path, "kind");
			rmd_yaml_report(
				c, rmd_yaml_line_of(fn, "kind"), kp,
				"flood needs a CAN bus (an RS485 line has no arbitration to win)");
		}
		if (bus_wide && f->motor_id) {
			rmd_yaml_path_key(kp, path, "motor");
			rmd_yaml_report(c, rmd_yaml_line_of(fn, "motor"), kp,
					"%s acts on the whole bus: leave motor out (or 0)", kind);
		}
		for (unsigned m = 0; m < cfg->n_motors && f->motor_id; m++)
			if (cfg->motors[m].bus == bi && cfg->motors[m].id == f->motor_id)
				found = true;
		if (f->motor_id && !found && !bus_wide) {
			rmd_yaml_path_key(kp, path, "motor");
			rmd_yaml_report(c, rmd_yaml_line_of(fn, "motor"), kp,
					"no motor with id %u on bus %s", f->motor_id, b->name);
		}
		if (f->end_ns && f->end_ns <= f->start_ns) {
			rmd_yaml_path_key(kp, path, "end_s");
			rmd_yaml_report(c, rmd_yaml_line_of(fn, "end_s"), kp,
					"must be after start_s, or 0 to leave the window open");
		}
		if (rule->param_what && (f->param < rule->param_lo || f->param > rule->param_hi)) {
			const char *pk = rmd_yaml_get(fn, "delay_us", NULL)  ? "delay_us" :
					 rmd_yaml_get(fn, "period_us", NULL) ? "period_us" :
									       "param";

			rmd_yaml_path_key(kp, path, pk);
			rmd_yaml_report(c, rmd_yaml_line_of(fn, pk), kp,
					"%lld is out of range for %s (%lld..%lld: %s)",
					(long long)f->param, kind, (long long)rule->param_lo,
					(long long)rule->param_hi, rule->param_what);
		}
		only_for(c, fn, path, "can_id", f->kind, RMD_SIM_FAULT_FLOOD);
		only_for(c, fn, path, "delay_us", f->kind, RMD_SIM_FAULT_DELAY);
		only_for(c, fn, path, "period_us", f->kind, RMD_SIM_FAULT_FLOOD);
		if (rmd_yaml_get(fn, "param", NULL) &&
		    (rmd_yaml_get(fn, "delay_us", NULL) || rmd_yaml_get(fn, "period_us", NULL))) {
			rmd_yaml_path_key(kp, path, "param");
			rmd_yaml_report(c, rmd_yaml_line_of(fn, "param"), kp,
					"give the time in µs (delay_us, period_us) or in ns "
					"(param), not both");
		}
	}
}

static void validate_motor_sim(struct yctx *c, struct rmd_config *cfg, struct rmd_sim_setup *sim,
			       unsigned i, const struct ynode *mn, const char *path)
{
	struct rmd_config_motor *m = &cfg->motors[i];
	const struct rmd_config_bus *b = &cfg->buses[m->bus];
	struct rmd_sim_motor_params *p = &sim->motors[i];
	const struct ynode *sn = rmd_yaml_get(mn, "sim", NULL);
	char kp[PATH_LEN];

	rmd_yaml_path_key(kp, path, "sim");
	/* on a socketcan or rs485 bus: rmd-sim's, as the bus's own sim: (real_bus_sim()) */
	if (sn && b->kind != RMD_BUS_KIND_SIM)
		cfg->buses[m->bus].sim_section = true;
	*p = sim->buses[m->bus].motor;
	if (sn) {
		struct field f = { .type = T_MAP, .sub = sim_motor_fields };

		rmd_yaml_walk_value(c, sn, &f, p, kp);
		validate_sim_model(c, p, sn, kp);
	}
	p->id = m->id;
	/* the simulated firmware: the motor's protocol, unless its sim: says another */
	if (!(sn && rmd_yaml_get(sn, "firmware", NULL)))
		p->proto = m->proto;
	p->mit = m->mit;
	if (rmd_yaml_get(mn, "gear_ratio", NULL))
		p->gear_ratio = m->gear_ratio;
	if (m->multi_turn_saved)
		p->multi_turn_save = true; /* as the config says the motor was set up */
	if (m->torque_constant_nm_a > 0)
		p->kt_nm_a = m->torque_constant_nm_a;
}

static void validate_mit(struct yctx *c, const struct rmd_mit_ranges *r, const struct ynode *n,
			 const char *path)
{
	static const struct {
		const char *lo, *hi;
		size_t lo_off, hi_off;
	} pairs[] = {
#define PAIR(a, b) \
	{ #a, #b, offsetof(struct rmd_mit_ranges, a), offsetof(struct rmd_mit_ranges, b) }
		PAIR(p_min, p_max),   PAIR(v_min, v_max),   PAIR(t_min, t_max),
		PAIR(kp_min, kp_max), PAIR(kd_min, kd_max),
#undef PAIR
	};
	char kp[PATH_LEN];

	for (size_t i = 0; i < sizeof(pairs) / sizeof(pairs[0]); i++) {
		double lo, hi;

		memcpy(&lo, (const char *)r + pairs[i].lo_off, sizeof(lo));
		memcpy(&hi, (const char *)r + pairs[i].hi_off, sizeof(hi));
		if (!(lo < hi)) {
			rmd_yaml_path_key(kp, path, pairs[i].lo);
			rmd_yaml_report(c, rmd_yaml_line_of(n, pairs[i].lo), kp,
					"%g must be below %s (%g)", lo, pairs[i].hi, hi);
		} else if (hi - lo < RMD_CONFIG_MIT_MIN_WIDTH) {
			unsigned bits = i == 0 ? 16 : 12;

			rmd_yaml_path_key(kp, path, pairs[i].lo);
			rmd_yaml_report(c, rmd_yaml_line_of(n, pairs[i].lo), kp,
					"%g..%g is narrower than %g: the MIT frame codes it in %u "
					"bits (V3 §5), and steps of %g are finer than the value "
					"itself can be told apart",
					lo, hi, RMD_CONFIG_MIT_MIN_WIDTH, bits,
					(hi - lo) / ((1u << bits) - 1));
		}
	}
}

/*
 * The bounds a motor's `mit` mapping names (RMD_MIT_BOUND() bits): the
 * others are V3 §5.1's preset, or its firmware's (rmd_mit_scaling_decide()).
 */
static unsigned mit_given(const struct ynode *n)
{
	unsigned given = 0;

	for (unsigned k = 0; n && k < RMD_MIT_BOUNDS; k++)
		if (rmd_yaml_get(n, rmd_mit_bound_key(k), NULL))
			given |= RMD_MIT_BOUND(k);
	return given;
}

static void validate_motors(struct yctx *c, struct rmd_config *cfg, struct rmd_sim_setup *sim,
			    const struct ynode *seq)
{
	char path[PATH_LEN], kp[PATH_LEN], names[RMD_MAX_BUSES * (RMD_CONFIG_NAME_LEN + 2)];
	const unsigned rate = cfg->loop.rate_hz;

	names[0] = '\0';
	for (unsigned i = 0, k = 0; i < cfg->n_buses; i++)
		if (cfg->buses[i].name[0])
			k += (unsigned)snprintf(names + k, sizeof(names) - k, "%s%s", k ? ", " : "",
						cfg->buses[i].name);
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		struct rmd_config_motor *m = &cfg->motors[i];
		const struct ynode *mn = seq->kids[i], *bv;
		const struct rmd_dialect *d;
		unsigned bl = 0;
		int bi = -1;

		if (!entry_start(mn, "motors", i, &m->line, path))
			continue;
		name_unique(c, seq, i, path, "motors", m->name,
			    rmd_config_motor_find(cfg, m->name));
		/* bus */
		rmd_yaml_path_key(kp, path, "bus");
		bv = rmd_yaml_get(mn, "bus", &bl);
		if (!bv) {
			rmd_yaml_report(c, mn->line, kp, "required key missing (buses: %s)", names);
		} else if (bv->kind != Y_SCALAR || rmd_yaml_is_null(bv)) {
			rmd_yaml_report(c, bv->line, kp, "expected the name of a bus (%s)", names);
		} else {
			bi = rmd_config_bus_find(cfg, bv->str);
			if (bi < 0)
				rmd_yaml_report(c, bv->line, kp, "\"%s\" is not a bus; buses: %s",
						bv->str, cfg->n_buses ? names : "none");
		}
		if (bi < 0) {
			m->bus = RMD_MAX_BUSES; /* unresolved */
			continue;
		}
		m->bus = (unsigned)bi;
		if ((c->bad[MARK_MOTOR - 1] & (1u << i)) || (c->bad[MARK_BUS - 1] & (1u << bi)))
			continue;
		/* id unique per bus */
		for (unsigned j = 0; j < i; j++) {
			const struct rmd_config_motor *o = &cfg->motors[j];

			if (o->bus == m->bus && o->id == m->id && m->id) {
				rmd_yaml_path_key(kp, path, "id");
				rmd_yaml_report(
					c, rmd_yaml_line_of(mn, "id"), kp,
					"%u is already the id of motors[%u] (%s, line %u) on bus %s",
					m->id, j, o->name, rmd_yaml_line_of(seq->kids[j], "id"),
					cfg->buses[bi].name);
				break;
			}
		}
		/* protocol and mode; auto: V3 until bring-up hears the motor */
		if (m->proto == RMD_CONFIG_PROTO_AUTO) {
			m->proto_auto = true;
			m->proto = RMD_PROTO_V3;
		}
		d = rmd_dialect(m->proto);
		/*
		 * MIT is a mode of V3 and V4 firmware (V3 §5, V4.2 §5); the
		 * key mit names V3 firmware driven in it, as earlier files did
		 */
		if (!rmd_dialect_is_firmware(d) && m->mode != RMD_MODE_MIT) {
			rmd_yaml_path_key(kp, path, "mode");
			rmd_yaml_report(
				c, rmd_yaml_line_of(mn, "mode"), kp,
				"%s: protocol mit is V3 firmware driven in mode mit (V3 §5): "
				"set mode: mit, or protocol: v3 for mode %s",
				rmd_mode_name(m->mode), rmd_mode_name(m->mode));
		} else if (m->mode == RMD_MODE_MIT && !rmd_dialect_offers_mit(d)) {
			rmd_yaml_path_key(kp, path, "mode");
			rmd_yaml_report(
				c, rmd_yaml_line_of(mn, "mode"), kp,
				"mit: %s firmware has no MIT mode (V2 has no 0x400 frames): "
				"mode mit is for protocol v3, v4 or auto",
				rmd_proto_key(m->proto));
		}
		/*
		 * MIT frames carry the motor's own position and speed (V3 §5):
		 * a rotor/output ratio applied to its 0x92 reads but not to its
		 * MIT frames would report one angle two ways (issue 20.7)
		 */
		if (rmd_config_mit_mode(m) && m->units == RMD_UNITS_ROTOR) {
			rmd_yaml_path_key(kp, path, "units");
			rmd_yaml_report(
				c, rmd_yaml_line_of(mn, "units"), kp,
				"rotor is not for mode mit: its MIT frames carry the "
				"position the motor reports, which rmdd cannot divide by the "
				"gear ratio in one place for both frame kinds; leave units at "
				"output and set the MIT ranges (p_min, p_max) in those units");
		}
		if (cfg->buses[bi].kind == RMD_BUS_KIND_RS485 &&
		    !rmd_dialect_has(d, RMD_DIALECT_RS485)) {
			rmd_yaml_path_key(kp, path, "protocol");
			rmd_yaml_report(
				c, rmd_yaml_line_of(mn, "protocol"), kp,
				"%s has no RS485 form (V3 §1.2: RS485 carries v3 frames); bus %s is "
				"rs485",
				rmd_proto_key(m->proto), cfg->buses[bi].name);
		} else if (cfg->buses[bi].kind == RMD_BUS_KIND_RS485 && rmd_config_mit_mode(m)) {
			rmd_yaml_path_key(kp, path, "mode");
			rmd_yaml_report(c, rmd_yaml_line_of(mn, "mode"), kp,
					"mit has no RS485 form (V3 §5: MIT frames travel on CAN "
					"only); bus %s is rs485",
					cfg->buses[bi].name);
		}
		if (!rmd_config_mit_mode(m) && !(m->torque_constant_nm_a > 0)) {
			rmd_yaml_path_key(kp, path, "torque_constant_nm_a");
			rmd_yaml_report(
				c, mn->line, kp,
				"required for protocol %s: its frames carry current (0.01 A), "
				"which rmdd converts to N·m",
				rmd_proto_key(m->proto));
		}
		/* limits */
		{
			const struct ynode *ln = rmd_yaml_get(mn, "limits", NULL);

			if (ln && rmd_yaml_get(ln, "position_min_rad", NULL))
				m->pos_min_line = rmd_yaml_line_of(ln, "position_min_rad");
			if (ln && rmd_yaml_get(ln, "position_max_rad", NULL))
				m->pos_max_line = rmd_yaml_line_of(ln, "position_max_rad");
			if (rmd_yaml_get(mn, "travel_rad", NULL))
				m->travel_line = rmd_yaml_line_of(mn, "travel_rad");
		}
		if (!(m->limits.position_min_rad < m->limits.position_max_rad)) {
			const struct ynode *ln = rmd_yaml_get(mn, "limits", NULL);

			rmd_yaml_path_key(kp, path, "limits.position_min_rad");
			rmd_yaml_report(c, rmd_yaml_line_of(ln, "position_min_rad"), kp,
					"%g must be below position_max_rad (%g)",
					m->limits.position_min_rad, m->limits.position_max_rad);
		}
		rmd_yaml_path_key(kp, path, "mit");
		validate_mit(c, &m->mit, rmd_yaml_get(mn, "mit", NULL), kp);
		m->mit_given = mit_given(rmd_yaml_get(mn, "mit", NULL));
		/* rates */
		/* the default never asks more than the motor's command rate (rate_hz below 10) */
		if (!rmd_yaml_get(mn, "status_poll_hz", NULL) &&
		    m->status_poll_hz > (double)rate / m->rate_divisor)
			m->status_poll_hz = (double)rate / m->rate_divisor;
		if (m->status_poll_hz > 0 && m->status_poll_hz < RMD_CONFIG_MIN_STATUS_POLL_HZ) {
			rmd_yaml_path_key(kp, path, "status_poll_hz");
			rmd_yaml_report(c, rmd_yaml_line_of(mn, "status_poll_hz"), kp,
					"%g Hz is below %g Hz (one poll every %g s): use 0 to turn "
					"status polls off",
					m->status_poll_hz, RMD_CONFIG_MIN_STATUS_POLL_HZ,
					1.0 / RMD_CONFIG_MIN_STATUS_POLL_HZ);
		} else if (m->status_poll_hz > (double)rate / m->rate_divisor) {
			rmd_yaml_path_key(kp, path, "status_poll_hz");
			rmd_yaml_report(
				c, rmd_yaml_line_of(mn, "status_poll_hz"), kp,
				"%g is more than the motor's command rate (%g Hz: rate_hz %u / "
				"rate_divisor %u)",
				m->status_poll_hz, (double)rate / m->rate_divisor, rate,
				m->rate_divisor);
		}
		validate_feedback(c, cfg, m, rmd_yaml_get(mn, "feedback", NULL), path);
		if (rmd_yaml_get(mn, "travel_rad", NULL) &&
		    (m->n_travel != 2 || !(m->travel_rad[0] < m->travel_rad[1]))) {
			rmd_yaml_path_key(kp, path, "travel_rad");
			rmd_yaml_report(c, rmd_yaml_line_of(mn, "travel_rad"), kp,
					"[min, max] in rad, min below max: where the joint can be "
					"(docs/faults.md \"Position uncertain after power-off\")");
		}
		validate_motor_sim(c, cfg, sim, i, mn, path);
	}
}

static void validate_lcm(struct yctx *c, const struct rmd_config *cfg, const struct ynode *root)
{
	const struct ynode *ln = rmd_yaml_get(root, "lcm", NULL);
	const char *p = cfg->lcm.channel_prefix;
	const char *scheme = strstr(cfg->lcm.url, "://");

	if (!scheme || scheme == cfg->lcm.url)
		rmd_yaml_report(
			c, rmd_yaml_line_of(ln, "url"), "lcm.url",
			"\"%s\" is not an LCM provider URL (e.g. udpm://239.255.76.67:7667?ttl=0, "
			"memq://)",
			cfg->lcm.url);
	if (strspn(p, "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_.-/") !=
	    strlen(p))
		rmd_yaml_report(c, rmd_yaml_line_of(ln, "channel_prefix"), "lcm.channel_prefix",
				"\"%s\": use letters, digits and _ . - / only", p);
	if (cfg->lcm.rt_priority != RMD_CONFIG_LCM_PRIO_AUTO &&
	    cfg->lcm.rt_priority >= cfg->loop.rt_priority)
		rmd_yaml_report(c, rmd_yaml_line_of(ln, "rt_priority"), "lcm.rt_priority",
				"%u: must be below loop.rt_priority (%u): the bridge must never "
				"hold off the rt loop; 0 runs it at normal priority",
				cfg->lcm.rt_priority, cfg->loop.rt_priority);
}

/*
 * robot: a named instance to list peers; none of them itself or twice; a
 * timeout a heartbeat fits into more than once (one lost heartbeat is not
 * a lost peer).  docs/robot.md.
 */
static void validate_robot(struct yctx *c, const struct rmd_config *cfg, const struct ynode *root)
{
	const struct ynode *rn = rmd_yaml_get(root, "robot", NULL);
	const struct ynode *pn = rmd_yaml_get(rn, "peers", NULL);
	const struct rmd_config_robot *r = &cfg->robot;
	char path[64];

	if (!rn || rn->kind != Y_MAP)
		return;
	if (!r->instance[0])
		rmd_yaml_report(c, rmd_yaml_line_of(rn, "instance"), "robot.instance",
				"a robot: section needs this daemon's instance name (unique on "
				"the robot, e.g. left_leg)");
	for (unsigned i = 0; i < r->n_peers; i++) {
		unsigned line = pn && pn->kind == Y_SEQ && i < pn->n ?
					pn->kids[i]->line :
					rmd_yaml_line_of(rn, "peers");

		snprintf(path, sizeof(path), "robot.peers[%u]", i);
		if (r->instance[0] && !strcmp(r->peers[i], r->instance))
			rmd_yaml_report(c, line, path,
					"\"%s\" is this daemon's own instance: list the other "
					"instances of the robot",
					r->peers[i]);
		for (unsigned j = 0; j < i; j++)
			if (!strcmp(r->peers[i], r->peers[j]))
				rmd_yaml_report(c, line, path, "\"%s\" is listed twice (also [%u])",
						r->peers[i], j);
	}
	if (r->peer_timeout_ms < 2 * r->heartbeat_ms)
		rmd_yaml_report(c, rmd_yaml_line_of(rn, "peer_timeout_ms"), "robot.peer_timeout_ms",
				"%u ms: at least two heartbeats (2 x heartbeat_ms = %u ms), so "
				"that one lost datagram does not stop the robot",
				r->peer_timeout_ms, 2 * r->heartbeat_ms);
}

/* The recorder's window: the loop keeps it in memory. */
static void validate_incidents(struct yctx *c, const struct rmd_config *cfg,
			       const struct ynode *root)
{
	const struct ynode *in = rmd_yaml_get(root, "incidents", NULL);
	const struct rmd_config_incidents *ic = &cfg->incidents;

	if (ic->seconds_before + ic->seconds_after > RMD_CONFIG_INCIDENT_MAX_WINDOW_S)
		rmd_yaml_report(c, rmd_yaml_line_of(in, "seconds_after"), "incidents",
				"seconds_before + seconds_after is %g s: at most %g s (the rt loop "
				"keeps the window in memory)",
				ic->seconds_before + ic->seconds_after,
				RMD_CONFIG_INCIDENT_MAX_WINDOW_S);
	if (ic->enabled && ic->seconds_before + ic->seconds_after <= 0.0)
		rmd_yaml_report(c, rmd_yaml_line_of(in, "seconds_before"), "incidents",
				"an empty window (seconds_before and seconds_after 0): set one, "
				"or enabled: false");
}

/* The entry of motor i in the file, or NULL. */
static const struct ynode *motor_node(const struct ynode *root, unsigned i)
{
	const struct ynode *seq = rmd_yaml_get(root, "motors", NULL);

	return seq && seq->kind == Y_SEQ && i < seq->n ? seq->kids[i] : NULL;
}

/* Timeouts against the loop and the motors' command periods. */
static void validate_timing(struct yctx *c, const struct rmd_config *cfg, const struct ynode *root)
{
	const struct ynode *sn = rmd_yaml_get(root, "safety", NULL);
	const struct rmd_config_safety *s = &cfg->safety;
	const unsigned rate = cfg->loop.rate_hz;
	double cycle_ms = 1000.0 / rate;

	if ((double)s->command_timeout_ms < 2.0 * cycle_ms)
		rmd_yaml_report(c, rmd_yaml_line_of(sn, "command_timeout_ms"),
				"safety.command_timeout_ms",
				"%u ms is shorter than two cycles (%g ms at %u Hz)",
				s->command_timeout_ms, 2.0 * cycle_ms, rate);
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		const struct rmd_config_motor *m = &cfg->motors[i];
		uint32_t ms = rmd_config_comm_loss_ms(cfg, i);
		double need_ms = 5.0 * cycle_ms * m->rate_divisor;
		bool own = m->comm_loss_ms >= 0;
		char kp[PATH_LEN];

		if (ms == 0 || (double)ms >= need_ms)
			continue;
		if (own)
			snprintf(kp, sizeof(kp), "motors[%u].comm_loss_ms", i);
		rmd_yaml_report(c,
				own ? rmd_yaml_line_of(motor_node(root, i), "comm_loss_ms") :
				      rmd_yaml_line_of(sn, "comm_loss_ms"),
				own ? kp : "safety.comm_loss_ms",
				"%u ms is shorter than 5 command periods of motor %s (%g ms): its "
				"own protection would trip in normal operation; use >= %.0f, or 0 "
				"(off)",
				ms, m->name, need_ms, ceil(need_ms));
		if (!own)
			return;
	}
}

/*
 * Issue 13: a motor that cannot be armed moves only when the config turns
 * its protection off.  V2 motors have none: the V2 manual's command list
 * (rmd-can-protocol-v2.0-en.txt §2, 52 commands) has no 0xB3 and no other
 * communication timeout.  So a V2 motor needs comm_loss_ms 0, its own or
 * safety's, written in the file (the default is not 0).
 */
static void validate_v2_protection(struct yctx *c, const struct rmd_config *cfg,
				   const struct ynode *root)
{
	for (unsigned i = 0; i < cfg->n_motors; i++) {
		const struct rmd_config_motor *m = &cfg->motors[i];
		const struct ynode *mn = motor_node(root, i);
		char kp[PATH_LEN];

		if (rmd_dialect_has(rmd_dialect(m->proto), RMD_DIALECT_COMM_LOSS_B3) ||
		    !rmd_config_comm_loss_ms(cfg, i))
			continue;
		snprintf(kp, sizeof(kp), "motors[%u].comm_loss_ms", i);
		rmd_yaml_report(
			c,
			m->comm_loss_ms >= 0 ? rmd_yaml_line_of(mn, "comm_loss_ms") :
					       rmd_yaml_line_of(mn, "protocol"),
			kp,
			"motor %s is V2, which has no comm-loss protection (no 0xB3 in the "
			"V2 manual): rmdd drives it only with the protection off explicitly; "
			"write comm_loss_ms: 0 in its entry (if rmdd dies, nothing stops it "
			"but its power)",
			m->name);
	}
}

/* ------------------------------------------------------------------ */
/* API */

int rmd_config_load(const char *path, struct rmd_config *cfg, struct rmd_sim_setup *sim, char *err,
		    size_t errlen)
{
	struct yctx c = { .file = path, .err = err, .errlen = errlen };
	struct rmd_sim_setup *scratch = NULL;
	struct ytree t = { 0 };
	const struct ynode *root;
	char *text, why[160];
	unsigned line;
	size_t len;
	int ret;

	if (err && errlen)
		err[0] = '\0';
	sim_motor_fields_build();
	rmd_config_defaults(cfg);
	snprintf(cfg->source, sizeof(cfg->source), "%s", path);
	if (!sim) {
		scratch = malloc(sizeof(*scratch));
		if (!scratch) {
			rmd_yaml_report(&c, 0, "", "out of memory");
			return -ENOMEM;
		}
		sim = scratch;
	}
	sim_setup_default(sim);
	ret = rmd_config_file_read(path, &text, &len, &line, why, sizeof(why));
	if (ret < 0) {
		rmd_yaml_report(&c, line, "", "%s", why);
		free(scratch);
		return ret;
	}
	ret = rmd_yaml_tree_load(&c, text, len, &t);
	free(text);
	if (ret == -ENOMEM)
		rmd_yaml_report(&c, 0, "", "out of memory");
	if (ret)
		goto out;
	root = t.root;
	if (!root || rmd_yaml_is_null(root)) {
		rmd_yaml_report(&c, 1, "buses, motors",
				"required keys missing (the file is empty)");
		ret = -EINVAL;
		goto out;
	}
	if (root->kind != Y_MAP) {
		char names[256];

		rmd_yaml_join_names(names, sizeof(names), NULL, top_fields);
		rmd_yaml_report(&c, root->line, "(top level)", "expected a mapping of %s, got %s",
				names, rmd_yaml_kind_desc(root));
		ret = -EINVAL;
		goto out;
	}
	rmd_yaml_walk_map(&c, root, top_fields, cfg, "");
	walk_bus_sims(&c, cfg, sim, rmd_yaml_get(root, "buses", NULL));
	walk_top_sim(&c, cfg, sim, root, path);
	if (!rmd_yaml_get(root, "buses", NULL))
		rmd_yaml_report(&c, root->line, "buses", "required key missing");
	if (!rmd_yaml_get(root, "motors", NULL))
		rmd_yaml_report(&c, root->line, "motors", "required key missing");
	if (cfg->n_buses == 0 && rmd_yaml_get(root, "buses", NULL))
		rmd_yaml_report(&c, rmd_yaml_line_of(root, "buses"), "buses",
				"at least one bus is required");
	if (cfg->n_motors == 0 && rmd_yaml_get(root, "motors", NULL))
		rmd_yaml_report(&c, rmd_yaml_line_of(root, "motors"), "motors",
				"at least one motor is required");
	{
		const struct ynode *bs = rmd_yaml_get(root, "buses", NULL);
		const struct ynode *ms = rmd_yaml_get(root, "motors", NULL);

		if (bs && bs->kind == Y_SEQ)
			validate_buses(&c, cfg, sim, bs);
		if (ms && ms->kind == Y_SEQ)
			validate_motors(&c, cfg, sim, ms);
		for (unsigned i = 0; bs && bs->kind == Y_SEQ && i < cfg->n_buses; i++)
			if (!(c.bad[MARK_BUS - 1] & (1u << i)))
				validate_faults(&c, cfg, sim, i, bs->kids[i]);
	}
	validate_lcm(&c, cfg, root);
	validate_robot(&c, cfg, root);
	validate_incidents(&c, cfg, root);
	validate_timing(&c, cfg, root);
	validate_v2_protection(&c, cfg, root);
	{
		const struct ynode *ln = rmd_yaml_get(root, "lcm", NULL);

		cfg->lcm.url_given = ln && ln->kind == Y_MAP && rmd_yaml_get(ln, "url", NULL);
	}
	ret = c.nerr ? -EINVAL : 0;
out:
	rmd_yaml_tree_free(&t);
	free(scratch);
	return ret;
}

int rmd_config_sim_default(struct rmd_config *cfg, struct rmd_sim_setup *sim, unsigned nmotors)
{
	const unsigned per_bus = 3; /* docs/design.md: 3 motors per 1 Mbit/s bus at 1 kHz */
	struct rmd_sim_bus_setup model;

	if (nmotors < 1 || nmotors > RMD_MAX_MOTORS)
		return -EINVAL;
	rmd_config_defaults(cfg);
	if (sim)
		sim_setup_default(sim);
	rmd_sim_bus_setup_default(&model, 1);
	snprintf(cfg->source, sizeof(cfg->source), "(built-in sim)");
	cfg->n_buses = (nmotors + per_bus - 1) / per_bus;
	for (unsigned b = 0; b < cfg->n_buses; b++) {
		struct rmd_config_bus *bus = &cfg->buses[b];

		rmd_config_bus_defaults(bus);
		snprintf(bus->name, sizeof(bus->name), "sim%u", b);
		bus->kind = RMD_BUS_KIND_SIM;
		if (sim)
			sim->buses[b].seed = b + 1;
	}
	cfg->n_motors = nmotors;
	for (unsigned i = 0; i < nmotors; i++) {
		struct rmd_config_motor *m = &cfg->motors[i];

		rmd_config_motor_defaults(m);
		snprintf(m->name, sizeof(m->name), "motor%u", i + 1);
		m->bus = i / per_bus;
		m->id = (uint8_t)(i % per_bus + 1);
		m->gear_ratio = model.motor.gear_ratio;
		m->torque_constant_nm_a = model.motor.kt_nm_a;
		m->limits.velocity_rad_s = 20.0;
		m->limits.torque_nm = 10.0;
		/*
		 * One output turn either way: a position sent in degrees for
		 * radians (90 for 1.57) is clamped to a turn, not 14 of them.
		 */
		m->limits.position_min_rad = -2.0 * M_PI;
		m->limits.position_max_rad = 2.0 * M_PI;
		/*
		 * Its simulated motors keep their multi-turn count (0x20 index 4,
		 * V3 §2.33.4), so their positions are trusted from the start.
		 */
		m->multi_turn_saved = true;
		if (!sim)
			continue;
		sim->motors[i] = sim->buses[m->bus].motor;
		sim->motors[i].id = m->id;
		sim->motors[i].proto = m->proto;
		sim->motors[i].multi_turn_save = true;
	}
	return 0;
}

/* ------------------------------------------------------------------ */
/* The schema as JSON Schema */

/* What the keys the validators check (T_LATER) hold. */
static const struct field *schema_later(const struct field *table, const struct field *f)
{
	static const struct field bus_name = STR("bus", struct rmd_config_bus, name, F_IDENT);
	static const struct field bus_sim = { .type = T_MAP, .sub = sim_fields };
	static const struct field motor_sim = { .type = T_MAP, .sub = sim_motor_fields };

	if (!strcmp(f->key, "bus"))
		return &bus_name;
	static const struct field top_sim = { .type = T_MAP, .sub = sim_top_fields };

	if (!strcmp(f->key, "sim"))
		return table == bus_fields ? &bus_sim : table == top_fields ? &top_sim : &motor_sim;
	return NULL;
}

int rmd_config_schema_json(FILE *out)
{
	sim_motor_fields_build();
	return rmd_yaml_schema_json(out, "rmdd configuration (rmdd.yaml(5))", top_fields,
				    schema_later);
}
