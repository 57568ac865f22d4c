// SPDX-License-Identifier: MIT
/*
 * A simulated RMD motor behind its frame interface (docs/design.md, layer sim):
 * lifecycle, settings (RAM/ROM), comm-loss protection, unsolicited frames
 * and every command of the V2.0 and V3.6 manuals.  Under them, the
 * mechanics, the firmware's control loops, temperature and fault detection
 * are sim_physics.c (its face for this file: sim_physics.h).
 *
 * Requests are decoded and replies encoded by the codec's tables
 * (rmd_decode / rmd_encode), so the motor speaks exactly the bytes the
 * daemon parses; values are scaled with each row's own LSB.  Commands the
 * manual answers with "the same data as the host sent" are echoed byte for
 * byte.  Section numbers (§) are the manuals': "V3 §" is
 * rmd-can-rs485-protocol-v3.6-zh.txt, "V2 §" rmd-can-protocol-v2.0-en.txt.
 *
 * No allocation, I/O or clock: time comes in as now_ns.  Every function
 * here is rt-safe.
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "rmd/rng.h"
#include "rmd/codec.h"
#include "rmd/mit.h"
#include "rmd/sim.h"
#include "sim_physics.h"

/* docs/design.md (seen on V4 firmware): a 0xF1 frame each second after a trip. */
#define COMM_LOST_PERIOD_MS 1000u
/* V3 §2.33.4 index 3: while faulted, 0x9A every 100 ms. */
#define ERROR_REPORT_PERIOD_NS INT64_C(100000000)
/* V4.2 §2.33.2: 0xB6's interval counts 10 ms steps. */
#define ACTIVE_REPLY_STEP_NS INT64_C(10000000)
/* V2 §3.47: auxiliary (encoder backup) battery; no figure given, 3.6 V cell. */
#define BATTERY_V 3.6
/* V3 §2.4.4: the example's 10000 dps/s, taken as the factory value. */
#define ACCEL_DEFAULT_DPS2 10000u

/* -------------------------------------------------------------------------- */
/* Parameters, PRNG                                                           */

/* The simulator's default motor (id, protocol and MIT ranges aside). */
static const struct rmd_sim_motor_params default_params = {
	/* An X8-class geared actuator (X8-S2 V10), all at the output shaft. */
	.model = "X8S2V10",
	.version_date = 0, /* its dialect's example_version (rmd/dialect.h) */
	.inertia_kgm2 = 0.005,
	.viscous_nm_s_rad = 0.02,
	.coulomb_nm = 0.1,
	.kt_nm_a = 2.0,
	.gear_ratio = 6.0,
	.pole_pairs = 10,
	.max_current_a = 20.0,
	.load_nm = 0.0,
	/* Beyond the ~1190 dps no-load speed at 48 V: only a load gets there. */
	.max_speed_dps = 1500.0,
	.fw_max_speed_dps = 1000.0,
	.phase_resistance_ohm = 0.3,
	.thermal_resistance_c_w = 2.0,
	.thermal_tau_s = 300.0,
	.ambient_c = 25.0,
	.supply_v = 48.0,
	.over_temp_c = 80.0,
	.over_temp_clear_c = 70.0,
	.under_voltage_v = 24.0,
	.over_voltage_v = 60.0,
	.stall_time_s = 1.0,
	.has_brake = true,
	.encoder_bits = 16,
	/* docs/design.md: motors answer 0.5-0.8 ms after a request. */
	.turnaround_ns = 500000.0,
	.turnaround_jitter_ns = 100000.0,
	.comm_loss_f1_ms = COMM_LOST_PERIOD_MS,
};

void rmd_sim_motor_params_default(struct rmd_sim_motor_params *p, uint8_t id, enum rmd_proto proto)
{
	*p = default_params;
	p->id = id;
	p->proto = proto;
	p->mit = rmd_mit_default_ranges;
}

/* splitmix64: spreads a small seed (the ID) over all 64 bits, never 0 out. */
void rmd_sim_motor_seed(struct rmd_sim_motor *m, uint64_t seed)
{
	m->rng = rmd_rng_seed(seed ? seed : m->p.id);
}

uint64_t rmd_sim_motor_rand(struct rmd_sim_motor *m)
{
	if (!m->rng)
		m->rng = rmd_rng_seed(0);
	return rmd_rng_next(&m->rng);
}

/* [0, 1) from the motor's PRNG */
static double rand_unit(struct rmd_sim_motor *m)
{
	return (double)(rmd_sim_motor_rand(m) >> 11) * 0x1.0p-53;
}

int64_t rmd_sim_motor_turnaround_ns(struct rmd_sim_motor *m)
{
	double u = rand_unit(m);
	double t = m->p.turnaround_ns + (2.0 * u - 1.0) * m->p.turnaround_jitter_ns;

	if (!(t > 0.0))
		return 0;
	if (t > 1e15)
		return INT64_C(1000000000000000);
	return (int64_t)llround(t);
}

int64_t rmd_sim_motor_rom_extra_ns(const struct rmd_sim_motor *m, const struct rmd_frame *req)
{
	const struct rmd_cmd_spec *spec;

	/* MIT frames (0x400 + ID) carry no command byte */
	if (m->p.rom_write_ns <= 0 || req->len < 1 || req->can_id >= 0x400)
		return 0;
	spec = rmd_cmd_find(m->d->table, req->data[0]);
	return spec && spec->flags & RMD_CMD_ROM ? (int64_t)m->p.rom_write_ns : 0;
}

/*
 * The turnaround of the reply to req: drawn from its personality's line for
 * the command (a recording, rmd/sim_personality.h), else mean +- jitter.
 */
static int64_t turnaround_for(struct rmd_sim_motor *m, const struct rmd_frame *req)
{
	unsigned key = req->can_id >= RMD_CAN_MIT_REQ_BASE ? 256u : req->len ? req->data[0] : 0u;
	unsigned row = m->turnaround_row[key];

	if (!row)
		return rmd_sim_motor_turnaround_ns(m);
	return rmd_personality_turnaround_ns(&m->p.personality.turnaround[row - 1], rand_unit(m));
}

int64_t rmd_sim_motor_reply_due(struct rmd_sim_motor *m, int64_t t_ns, const struct rmd_frame *req)
{
	int64_t due = t_ns + turnaround_for(m, req) + rmd_sim_motor_rom_extra_ns(m, req);

	if (due < m->last_due_ns)
		due = m->last_due_ns;
	m->last_due_ns = due;
	return due;
}

/* Replace nonsense (zero inertia, NaN, ...) by the defaults: never divide by 0. */
static void sanitize(struct rmd_sim_motor_params *p)
{
	struct rmd_sim_motor_params d;

	rmd_sim_motor_params_default(&d, p->id, p->proto);
	if (p->id < 1 || p->id > RMD_MAX_MOTORS)
		p->id = 1;
	if (!rmd_dialect(p->proto))
		p->proto = RMD_PROTO_V3;
	if (!p->version_date)
		p->version_date = rmd_dialect(p->proto)->example_version;
	/* the firmware's personality: chosen by model and date, or named */
	rmd_personality_apply(p);
	if (!rmd_dialect(p->proto))
		p->proto = RMD_PROTO_V3;
	if (!p->version_date)
		p->version_date = rmd_dialect(p->proto)->example_version;
	if (!p->comm_loss_f1_ms)
		p->comm_loss_f1_ms = COMM_LOST_PERIOD_MS;
	if (p->comm_loss_f1_ms > 60000)
		p->comm_loss_f1_ms = 60000;
#define POSITIVE(f)                                   \
	do {                                          \
		if (!(p->f > 0.0) || !isfinite(p->f)) \
			p->f = d.f;                   \
	} while (0)
#define FINITE_NONNEG(f)                               \
	do {                                           \
		if (!(p->f >= 0.0) || !isfinite(p->f)) \
			p->f = d.f;                    \
	} while (0)
	POSITIVE(inertia_kgm2);
	POSITIVE(kt_nm_a);
	POSITIVE(gear_ratio);
	POSITIVE(max_current_a);
	POSITIVE(max_speed_dps);
	POSITIVE(fw_max_speed_dps);
	POSITIVE(thermal_resistance_c_w);
	POSITIVE(thermal_tau_s);
	POSITIVE(stall_time_s);
	FINITE_NONNEG(viscous_nm_s_rad);
	FINITE_NONNEG(coulomb_nm);
	FINITE_NONNEG(phase_resistance_ohm);
	FINITE_NONNEG(supply_v);
	FINITE_NONNEG(turnaround_ns);
	FINITE_NONNEG(turnaround_jitter_ns);
	FINITE_NONNEG(rom_write_ns);
	FINITE_NONNEG(adapter_latency_timer_ns);
	FINITE_NONNEG(adapter_usb_frame_ns);
	FINITE_NONNEG(adapter_delay_ns);
#undef POSITIVE
#undef FINITE_NONNEG
	if (!isfinite(p->load_nm))
		p->load_nm = 0.0;
	if (!isfinite(p->ambient_c))
		p->ambient_c = d.ambient_c;
	if (!isfinite(p->over_temp_c) || !isfinite(p->over_temp_clear_c) ||
	    p->over_temp_clear_c > p->over_temp_c) {
		p->over_temp_c = d.over_temp_c;
		p->over_temp_clear_c = d.over_temp_clear_c;
	}
	if (!isfinite(p->under_voltage_v) || !isfinite(p->over_voltage_v) ||
	    p->under_voltage_v >= p->over_voltage_v) {
		p->under_voltage_v = d.under_voltage_v;
		p->over_voltage_v = d.over_voltage_v;
	}
	if (p->encoder_bits < 8 || p->encoder_bits > 24)
		p->encoder_bits = d.encoder_bits;
	if (!rmd_mit_ranges_valid(&p->mit))
		p->mit = d.mit;
	p->model[sizeof(p->model) - 1] = '\0';
}

/* -------------------------------------------------------------------------- */
/* Lifecycle                                                                  */

static void rom_defaults(struct rmd_sim_motor *m)
{
	struct rmd_sim_settings *r = &m->rom;

	memset(r, 0, sizeof(*r));
	r->can_id = m->p.id;
	for (unsigned i = 0; i < RMD_SIM_NPID; i++)
		r->pid[i] = rmd_sim_pid_default(m->p.proto, i);
	for (unsigned i = 0; i < RMD_SIM_NGAIN; i++)
		r->gain[i] = V4_GAIN_DEFAULT;
	for (unsigned i = 0; i < 4; i++)
		r->accel_dps2[i] = ACCEL_DEFAULT_DPS2;
	r->baud_code = 1;			    /* V3 §2.31.1: 1 is CAN 1 Mbit/s */
	r->comm_timeout_ms = m->p.comm_loss_rom_ms; /* an earlier run's 0xB3 */
	/* V3 §3.1: off, so 0x280 reaches the motor out of the box. */
	r->can_filter = false;
	r->multiturn_save = m->p.multi_turn_save; /* an earlier 0x20 index 4 */
}

/* The slot of command `cmd` in the dialect's 0xB6 list (V4.2 §2.33.2), or -1. */
static int report_slot(const struct rmd_dialect *d, int64_t cmd)
{
	for (unsigned k = 0; k < d->n_report_cmds; k++)
		if (d->report_cmds[k] == cmd)
			return (int)k;
	return -1;
}

/*
 * Start the firmware: power-on or 0x76.  RAM settings come from ROM, the
 * multi-turn count is lost (docs/design.md) unless 0x20 index 4 saved it and
 * index 1 did not ask to clear it (V3 §2.33.4), the brake is locked
 * (V3 §2.27.1: the brake state without power) and the shaft is at rest.
 * It answers boot_time_ns later (rmd_sim_motor_params.boot_ms); its
 * runtime (0xB1, V3 §2.28) counts from now.
 */
static void boot(struct rmd_sim_motor *m, int64_t now_ns, int64_t boot_time_ns)
{
	m->ram = m->rom;
	m->error_reports = false;
	/* V4.2 §2.33: active replies are not said to be saved: a reset ends them */
	memset(m->report_steps, 0, sizeof(m->report_steps));
	if (!m->rom.multiturn_save || m->clear_multiturn) {
		double off = rmd_sim_offset_rad(m);
		double a = m->pos_rad - off;
		/* one output turn, or one rotor turn (struct rmd_sim_motor_params.wrap_rotor) */
		double turn = 2.0 * M_PI / (m->p.wrap_rotor ? m->p.gear_ratio : 1.0);

		a -= turn * floor((a + turn / 2.0) / turn);
		m->pos_rad = off + a;
	}
	m->clear_multiturn = false;
	m->vel_rad_s = 0.0;
	rmd_sim_off_state(m);
	m->brake_locked = true;
	m->errors_latched = 0;
	m->comm_armed = false;
	m->comm_lost = false;
	m->echo_next = false;
	m->next_f1_ns = 0;
	m->next_9a_ns = 0;
	m->reply_as = 0; /* 0x76: the ID 0x20 index 5 wrote holds now (ROM) */
	m->mit_seen = false;
	m->boot_ns = now_ns;
	m->awake_ns = now_ns + boot_time_ns;
	rmd_sim_detect_faults(m, 0.0);
}

/*
 * What the simulated firmware scales MIT frames by: its dialect's own
 * ranges for its date and model where they are fixed (V4.4), else the
 * ranges set (p.mit): the table is the one rmdd decides by
 * (rmd_mit_scaling_decide()), asked without an entry.
 */
static struct rmd_mit_ranges firmware_mit(const struct rmd_sim_motor *m)
{
	struct rmd_mit_decision dec;

	rmd_mit_scaling_decide(m->d, m->p.version_date, m->p.model, &m->p.mit, 0, &dec);
	return dec.source == RMD_MIT_FROM_FIRMWARE ? dec.r : m->p.mit;
}

/* The firmware's boot time, ns (rmd_sim_motor_params.boot_ms). */
static int64_t boot_time_ns(const struct rmd_sim_motor *m)
{
	return (int64_t)m->p.boot_ms * 1000000;
}

/* Whether the firmware runs: present, and done booting. */
static bool awake(const struct rmd_sim_motor *m, int64_t now_ns)
{
	return m->present && now_ns >= m->awake_ns;
}

void rmd_sim_motor_init(struct rmd_sim_motor *m, const struct rmd_sim_motor_params *p,
			int64_t now_ns)
{
	memset(m, 0, sizeof(*m));
	m->p = *p;
	sanitize(&m->p);
	m->d = rmd_dialect(m->p.proto);
	m->mit_ranges = firmware_mit(m);
	/* V4.2 §2.1.4: the index of each PI gain addressed by one, by its key ("current_kp") */
	for (unsigned i = 0; i < RMD_SIM_NPID; i++) {
		m->gain_index[i] = -1;
		for (size_t k = 0; k < m->d->n_pid_slots; k++)
			if (m->d->pid_slots[k].field == RMD_FLD_CURR_KP + i &&
			    m->d->pid_slots[k].index && m->d->pid_slots[k].index < RMD_SIM_NGAIN)
				m->gain_index[i] = (int8_t)m->d->pid_slots[k].index;
	}
	/* the personality's turnaround lines by command (rmd_sim_motor_reply_due()) */
	for (unsigned c = 0; c < 257; c++) {
		const struct rmd_personality_turnaround *t = rmd_personality_turnaround_for(
			&m->p.personality, c < 256 ? c : RMD_PERSONALITY_CMD_MIT);

		m->turnaround_row[c] = t ? (uint8_t)(t - m->p.personality.turnaround + 1) : 0;
	}
	rom_defaults(m);
	m->pos_rad = 0.0;
	m->temp_c = m->p.ambient_c;
	m->t_ns = now_ns;
	m->present = true;
	rmd_sim_motor_seed(m, m->p.seed);
	boot(m, now_ns, 0); /* the first power-on was before: it answers at once */
	/* first power-on: where the shaft happens to be, turns included */
	m->pos_rad = m->p.start_angle_deg * (M_PI / 180.0);
	/* an earlier run's protection, tripped since (V2 has none) */
	if (m->p.comm_loss_tripped && m->ram.comm_timeout_ms &&
	    rmd_dialect_has(m->d, RMD_DIALECT_COMM_LOSS_B3)) {
		m->comm_armed = true;
		m->last_rx_ns = now_ns;
		m->comm_lost = true;
		m->echo_next = !m->p.comm_loss_executes_first;
		m->next_f1_ns = now_ns;
	}
	/* another tool's active reply (V4.2 §2.33), until 0xB6 or a reset ends it */
	if (m->p.active_reply_9c_ms && rmd_dialect_has(m->d, RMD_DIALECT_ACTIVE_REPLY)) {
		int k = report_slot(m->d, 0x9C);

		if (k >= 0) {
			m->report_steps[k] = (uint16_t)((m->p.active_reply_9c_ms + 9) / 10);
			m->report_next_ns[k] =
				now_ns + (int64_t)m->report_steps[k] * ACTIVE_REPLY_STEP_NS;
		}
	}
}

void rmd_sim_motor_power_cycle(struct rmd_sim_motor *m, int64_t now_ns)
{
	rmd_sim_motor_step(m, now_ns);
	boot(m, now_ns > m->t_ns ? now_ns : m->t_ns, boot_time_ns(m));
}

void rmd_sim_motor_set_error(struct rmd_sim_motor *m, uint16_t bits)
{
	m->errors_injected = bits;
	rmd_sim_update_errors(m);
}

/* -------------------------------------------------------------------------- */
/* Reply building                                                             */

/* Reply field `fld` of `spec` (if its layout has it) = raw, saturated to the field. */
static void put_int(struct rmd_msg *msg, const struct rmd_cmd_spec *spec, enum rmd_field fld,
		    int64_t raw)
{
	const struct rmd_field_spec *fs = rmd_layout_field(spec, RMD_DIR_REPLY, fld);
	int64_t lo, hi;

	if (!fs)
		return;
	rmd_field_range(fs, &lo, &hi);
	rmd_msg_set(msg, fld, raw < lo ? lo : raw > hi ? hi : raw);
}

/*
 * Reply field `fld` = `native` in the field's unit (the key's unit: A, dps,
 * deg, V, ...) by the codec's rule, rounded and saturated: e.g. the int16
 * angle of V3 §2.13.3 stops at +-32767 deg.
 */
static void put(struct rmd_msg *msg, const struct rmd_cmd_spec *spec, enum rmd_field fld,
		double native)
{
	rmd_msg_set_native(msg, spec, RMD_DIR_REPLY, fld, native);
}

/* Request field `fld` in its native unit, or `def` when the row lacks it. */
static double get(const struct rmd_cmd_spec *spec, const struct rmd_msg *msg, enum rmd_field fld,
		  double def)
{
	return rmd_msg_get_native(msg, spec, RMD_DIR_REQUEST, fld, def);
}

/* "The reply is the same as the request": the request's bytes on the reply id. */
static int echo(const struct rmd_frame *f, uint32_t reply_id, struct rmd_frame *out, int max)
{
	if (max < 1 || !out)
		return 0;
	*out = *f;
	out->can_id = reply_id;
	return 1;
}

/*
 * V2 §3.21 .. §3.23, §3.29: the other reading of a negative multi-turn
 * value the manual allows, the magnitude in data[1..6] and the flag 1 in
 * data[7] (the codec writes two's complement and the flag 1).
 */
static void v2_sign_magnitude(enum rmd_proto proto, const struct rmd_msg *msg, struct rmd_frame *fr)
{
	const struct rmd_cmd_spec *spec = rmd_cmd_find(proto, msg->cmd);
	const struct rmd_layout *l;
	uint64_t mag;

	/* only V2's rows have a sign byte (rmd_field_spec.sign_byte) */
	if (!spec)
		return;
	l = rmd_cmd_layout(spec, RMD_DIR_REPLY);
	if (l->n != 1 || !l->f[0].sign_byte || msg->v[l->f[0].field] >= 0)
		return;
	mag = (uint64_t)(-msg->v[l->f[0].field]);
	for (unsigned b = 0; b < l->f[0].size; b++, mag >>= 8)
		fr->data[l->f[0].off + b] = (uint8_t)mag;
	fr->data[l->f[0].off + l->f[0].size] = 1;
}

/*
 * The ID its replies carry: its own, or after 0x20 index 5 on firmware that
 * answers from the new one at once (p.set_id_replies_new) that one.
 */
static uint8_t reply_can_id(const struct rmd_sim_motor *m)
{
	return m->reply_as ? m->reply_as : m->ram.can_id;
}

static int emit(const struct rmd_sim_motor *m, enum rmd_proto proto, const struct rmd_msg *msg,
		struct rmd_frame *out, int max)
{
	struct rmd_frame fr;

	if (max < 1 || !out)
		return 0;
	if (rmd_encode(proto, RMD_DIR_REPLY, reply_can_id(m), msg, &fr) < 0)
		return 0;
	if (m->p.v2_angle_magnitude)
		v2_sign_magnitude(proto, msg, &fr);
	*out = fr;
	return 1;
}

/* A reply message for command `cmd`, its row in *spec (NULL: no such row). */
static void msg_for(enum rmd_proto proto, uint8_t cmd, struct rmd_msg *msg,
		    const struct rmd_cmd_spec **spec)
{
	memset(msg, 0, sizeof(*msg));
	msg->cmd = cmd;
	*spec = rmd_cmd_find(proto, cmd);
}

/* [0, 360) */
static double wrap360(double d)
{
	d = fmod(d, 360.0);
	return d < 0.0 ? d + 360.0 : d;
}

/* Motor-side single-turn encoder, V2 §3.26 / §3.32: 0..2^bits-1 (16 bits at most). */
static uint32_t encoder_single_raw(const struct rmd_sim_motor *m)
{
	unsigned bits = m->p.encoder_bits;
	uint64_t c = (uint64_t)rmd_sim_raw_counts(m) & ((UINT64_C(1) << bits) - 1);

	return (uint32_t)(bits > 16 ? c >> (bits - 16) : c);
}

static uint32_t encoder_single_mask(const struct rmd_sim_motor *m)
{
	unsigned bits = m->p.encoder_bits > 16 ? 16 : m->p.encoder_bits;

	return (1u << bits) - 1;
}

static uint32_t encoder_single(const struct rmd_sim_motor *m)
{
	return (encoder_single_raw(m) - m->ram.encoder_offset_single) & encoder_single_mask(m);
}

/*
 * Status 2, the reply of 0x9C and of every motion command: V3 §2.13.3
 * (temperature, iq, speed, output angle in deg), V2 §3.32 (iq in 33/2048 A,
 * single-turn encoder instead of the angle).
 */
static void fill_status2(const struct rmd_sim_motor *m, struct rmd_msg *msg,
			 const struct rmd_cmd_spec *spec)
{
	put(msg, spec, RMD_FLD_TEMP, m->temp_c);
	put(msg, spec, RMD_FLD_CURRENT, m->iq_a);
	put(msg, spec, RMD_FLD_SPEED, deg(m->vel_rad_s));
	put(msg, spec, RMD_FLD_ANGLE, deg(rmd_sim_angle_rad(m)));
	put_int(msg, spec, RMD_FLD_ENCODER, encoder_single(m));
}

/* Status 1, V3 §2.12.3 / V2 §3.31: temperature, brake, voltage, error flags. */
static void fill_status1(const struct rmd_sim_motor *m, struct rmd_msg *msg,
			 const struct rmd_cmd_spec *spec)
{
	put(msg, spec, RMD_FLD_TEMP, m->temp_c);
	/*
	 * V3 §2.12.3: data[3] is the brake command state, 1 released; firmware
	 * 2025070202 says 1 while it executes commands (p.status1_executing).
	 */
	if (m->p.status1_executing)
		put_int(msg, spec, RMD_FLD_BRAKE, m->ctrl != RMD_SIM_OFF);
	else
		put_int(msg, spec, RMD_FLD_BRAKE, m->brake_locked ? 0 : 1);
	put(msg, spec, RMD_FLD_VOLTAGE, m->p.supply_v);
	put_int(msg, spec, RMD_FLD_ERROR, m->errors);
}

/* Status 3, V3 §2.14.3 / V2 §3.33: phase currents from iq (id = 0). */
static void fill_status3(const struct rmd_sim_motor *m, struct rmd_msg *msg,
			 const struct rmd_cmd_spec *spec)
{
	double th = m->pos_rad * m->p.gear_ratio * (double)m->p.pole_pairs;

	put(msg, spec, RMD_FLD_TEMP, m->temp_c);
	put(msg, spec, RMD_FLD_PHASE_A, -m->iq_a * sin(th));
	put(msg, spec, RMD_FLD_PHASE_B, -m->iq_a * sin(th - 2.0 * M_PI / 3.0));
	put(msg, spec, RMD_FLD_PHASE_C, -m->iq_a * sin(th + 2.0 * M_PI / 3.0));
}

/* The code of run mode `name` in the dialect's 0x70 table (struct rmd_dialect.run_modes), or 0. */
static uint8_t run_mode_code(const struct rmd_dialect *d, const char *name)
{
	for (size_t i = 0; i < d->n_run_modes; i++)
		if (!strcmp(d->run_modes[i].name, name))
			return (uint8_t)d->run_modes[i].code;
	return 0;
}

/* Run mode, V3 §2.23.3 (1 current, 2 speed, 3 position) / V2 §3.45 (0, 1, 2, 0xFF). */
static uint8_t run_mode(const struct rmd_sim_motor *m)
{
	uint8_t base = run_mode_code(m->d, "current_loop");

	switch (m->ctrl) {
	case RMD_SIM_TORQUE:
	case RMD_SIM_MIT:
		return base;
	case RMD_SIM_SPEED:
		return base + 1;
	case RMD_SIM_POS_TRACK:
	case RMD_SIM_POS_ABS:
	case RMD_SIM_HOLD:
		return base + 2;
	case RMD_SIM_OFF:
		break;
	}
	/* V2: "not in three-ring mode" 0xFF (init); V3 lists no value: 0. */
	return run_mode_code(m->d, "init");
}

/* -------------------------------------------------------------------------- */
/* Motion commands                                                            */

static bool speed_loop_mode(enum rmd_sim_ctrl c)
{
	switch (c) {
	case RMD_SIM_SPEED:
	case RMD_SIM_POS_TRACK:
	case RMD_SIM_POS_ABS:
	case RMD_SIM_HOLD:
		return true;
	case RMD_SIM_OFF:
	case RMD_SIM_TORQUE:
	case RMD_SIM_MIT:
		break;
	}
	return false;
}

/* Switch mode; the speed loop takes over the present current without a bump. */
static void enter(struct rmd_sim_motor *m, enum rmd_sim_ctrl c)
{
	if (speed_loop_mode(c) && !speed_loop_mode(m->ctrl))
		m->speed_int_a = m->iq_a;
	if (c == RMD_SIM_SPEED && m->ctrl != RMD_SIM_SPEED)
		m->ramp_speed_rad_s = m->vel_rad_s;
	if ((c == RMD_SIM_POS_ABS || c == RMD_SIM_HOLD) && m->ctrl != RMD_SIM_POS_ABS &&
	    m->ctrl != RMD_SIM_HOLD) {
		m->traj_pos_rad = m->pos_rad;
		m->traj_vel_rad_s = m->vel_rad_s;
		m->traj_acc_rad_s2 = 0.0;
	}
	m->ctrl = c;
}

/* Max speed of a move: the command's, or the firmware's when it gives 0 or none. */
static double move_speed(const struct rmd_sim_motor *m, double dps)
{
	if (!(dps > 0.0))
		dps = m->p.fw_max_speed_dps;
	return rad(dps);
}

/* Enter a position mode aiming at `target` (pos_rad frame) at up to `vmax`. */
static void aim(struct rmd_sim_motor *m, enum rmd_sim_ctrl mode, double target, double vmax)
{
	enter(m, mode);
	m->sp_pos_rad = target;
	m->sp_max_speed_rad_s = vmax;
}

/* Planned move to `target` at up to `vmax`: 0xA4 and kin. */
static void move_to(struct rmd_sim_motor *m, double target, double vmax)
{
	aim(m, RMD_SIM_POS_ABS, target, vmax);
}

/*
 * Stop (V3 §2.16.1: brake the speed to zero and hold, not moved by outside
 * forces; V2 §3.35: keep the mode for 0x88).  The stop decelerates at the
 * position-planning deceleration (0x43 index 1), then holds there.
 */
static void stop_hold(struct rmd_sim_motor *m)
{
	double dec = rmd_sim_accel_rad(m, 1), v = m->vel_rad_s;

	if (m->ctrl != RMD_SIM_HOLD && m->ctrl != RMD_SIM_OFF)
		m->ctrl_stopped = m->ctrl;
	enter(m, RMD_SIM_HOLD);
	m->traj_pos_rad = m->pos_rad;
	m->traj_vel_rad_s = v;
	m->hold_pos_rad = m->pos_rad + (isinf(dec) ? 0.0 : v * fabs(v) / (2.0 * dec));
}

/*
 * V2 §3.41, §3.42: single-turn target 0..359.99 deg, turning clockwise
 * (0, the direction in which the §3.30 angle grows) or counter-clockwise (1).
 */
static double single_turn_target(const struct rmd_sim_motor *m, double target_deg, int64_t dir)
{
	double delta = wrap360(wrap360(target_deg) - wrap360(deg(rmd_sim_angle_rad(m))));

	if (dir != 0 && delta > 0.0)
		delta -= 360.0;
	return m->pos_rad + rad(delta);
}

/*
 * 0xA1..0xA8 (V3 §2.17..§2.22, V2 §3.37..§3.44).  V3 §2.17.1: a control
 * command runs only when the motor has no fault; it is answered anyway.
 */
static void motion(struct rmd_sim_motor *m, enum rmd_proto proto, const struct rmd_cmd_spec *spec,
		   const struct rmd_msg *msg)
{
	double ang = rad(get(spec, msg, RMD_FLD_ANGLE, 0.0));
	double vmax = move_speed(m, get(spec, msg, RMD_FLD_MAX_SPEED, 0.0));
	double off = rmd_sim_offset_rad(m);
	/* V3.4 .. V3.6: 0xA3 and 0xA5 track; V2: they move (absolute, single turn) */
	bool track = rmd_dialect_has(m->d, RMD_DIALECT_TRACK_A3_A5);

	(void)proto;
	if (m->errors)
		return;
	switch (msg->cmd) {
	case 0xA1:
		enter(m, RMD_SIM_TORQUE);
		m->sp_current_a = get(spec, msg, RMD_FLD_CURRENT, 0.0);
		break;
	case 0xA2:
		enter(m, RMD_SIM_SPEED);
		m->sp_speed_rad_s = rad(get(spec, msg, RMD_FLD_SPEED, 0.0));
		break;
	case 0xA3:
		/* V2 §3.39: absolute, with the firmware's speed and acceleration. */
		if (!track) {
			move_to(m, ang + off, vmax);
			break;
		}
		/* V3 §2.19.1: direct tracking through the position PI. */
		aim(m, RMD_SIM_POS_TRACK, ang + off, vmax);
		break;
	case 0xA4:
		/* X6-P20 2025070202: ignored after an MIT frame until a reset */
		if (m->p.a4_ignored_after_mit && m->mit_seen)
			break;
		/* V3 §2.20 / V2 §3.40: absolute, planned with 0x43 index 0/1. */
		move_to(m, ang + off, vmax);
		break;
	case 0xA5:
		if (!track) {
			move_to(m, single_turn_target(m, deg(ang), msg->v[RMD_FLD_SPIN_DIR]), vmax);
			break;
		}
		/* V3 §2.21: tracking with a speed limit (0.01 dps, row-scaled). */
		aim(m, RMD_SIM_POS_TRACK, ang + off, vmax);
		break;
	case 0xA6:
		move_to(m, single_turn_target(m, deg(ang), msg->v[RMD_FLD_SPIN_DIR]), vmax);
		break;
	case 0xA7:
	case 0xA8:
		/* V3 §2.22.1 / V2 §3.43: the increment starts at the current position. */
		move_to(m, m->pos_rad + ang, vmax);
		break;
	default:
		break;
	}
}

/* After a command changed the control state: the current it asks for now. */
static void settle(struct rmd_sim_motor *m)
{
	m->iq_a = rmd_sim_control(m, 0.0);
}

/* -------------------------------------------------------------------------- */
/* Commands                                                                   */

/*
 * Where the simulated firmware keeps gain k of its dialect: a binary32 by
 * index (V4.2 §2.1.4), or the wire's integer per gain (V3 §2.1 uint8, V2
 * §3.1 Q24); NULL: nowhere.  With the factory values
 * (rmd_sim_pid_default()) the places the firmware's layout is modelled.
 */
static float *gain_float(struct rmd_sim_settings *st, const struct rmd_dialect *d, unsigned k)
{
	unsigned i = d->pid_slots[k].index;

	return i && i < RMD_SIM_NGAIN ? &st->gain[i] : NULL;
}

static int64_t *gain_int(struct rmd_sim_settings *st, const struct rmd_dialect *d, unsigned k)
{
	unsigned i = (unsigned)d->pid_slots[k].field - RMD_FLD_CURR_KP;

	return !d->pid_slots[k].index && i < RMD_SIM_NPID ? &st->pid[i] : NULL;
}

/* Gain k as the wire carries it (rmd_pid_answer()). */
static int64_t gain_raw(struct rmd_sim_motor *m, unsigned k)
{
	const struct rmd_field_spec *fs = rmd_pid_spec(m->d, k);
	float *g = gain_float(&m->ram, m->d, k);
	int64_t *v = gain_int(&m->ram, m->d, k), raw = 0;

	if (g && fs)
		rmd_field_from_native(fs, *g, &raw);
	return v ? *v : raw;
}

/* Gain k written from the wire to RAM (and ROM); a float gain only when finite. */
static void gain_store(struct rmd_sim_motor *m, unsigned k, int64_t raw, bool rom)
{
	const struct rmd_field_spec *fs = rmd_pid_spec(m->d, k);
	double x = fs ? rmd_field_to_native(fs, raw) : NAN;

	if (gain_int(&m->ram, m->d, k)) {
		*gain_int(&m->ram, m->d, k) = raw;
		if (rom)
			*gain_int(&m->rom, m->d, k) = raw;
	} else if (gain_float(&m->ram, m->d, k) && isfinite(x)) {
		*gain_float(&m->ram, m->d, k) = (float)x;
		if (rom)
			*gain_float(&m->rom, m->d, k) = (float)x;
	}
}

/*
 * The dialect's PID requests (rmd_pid_parse()): V3 §2.1 .. §2.3 six gains
 * in one frame, V2 §3.1 .. §3.18 one command a gain, V4.2 §2.1 .. §2.3 one
 * gain by index.  A read is answered with the gains it names, a write
 * stores them (0x32 and V2's ROM writes in ROM too) and is echoed.  An
 * index §2.1.4 does not list gets no answer (the manual says nothing; the
 * simulator stays quiet).
 */
static int pid_request(struct rmd_sim_motor *m, enum rmd_proto proto, const struct rmd_msg *req,
		       enum rmd_pid_op op, uint32_t named, const struct rmd_pid_set *carried,
		       const struct rmd_frame *f, uint32_t reply_id, struct rmd_frame *out, int max)
{
	struct rmd_pid_set now = { .slots = named };
	struct rmd_msg rep;

	if (!named)
		return 0;
	if (op != RMD_PID_READ) {
		for (unsigned k = 0; k < m->d->n_pid_slots; k++)
			if (carried->slots & (UINT32_C(1) << k))
				gain_store(m, k, carried->raw[k], op == RMD_PID_WRITE_ROM);
		return echo(f, reply_id, out, max);
	}
	for (unsigned k = 0; k < m->d->n_pid_slots; k++)
		if (named & (UINT32_C(1) << k))
			now.raw[k] = gain_raw(m, k);
	rmd_pid_answer(m->d, req, &now, &rep);
	return emit(m, proto, &rep, out, max);
}

/*
 * V4.2 §2.33: 0xB6 turns the pushed reply of one command on (every n x
 * 10 ms; n = 0 taken as 1) or off.  Several commands each keep their own
 * period.  No reply either way.
 */
static void active_reply(struct rmd_sim_motor *m, const struct rmd_msg *msg, int64_t now_ns)
{
	int k = report_slot(m->d, msg->v[RMD_FLD_REPORT_CMD]);
	int64_t steps = msg->v[RMD_FLD_REPORT_MS];

	if (k < 0)
		return;
	if (!msg->v[RMD_FLD_REPORT_ON]) {
		m->report_steps[k] = 0;
		return;
	}
	m->report_steps[k] = (uint16_t)(steps < 1 ? 1 : steps);
	m->report_next_ns[k] = now_ns + (int64_t)m->report_steps[k] * ACTIVE_REPLY_STEP_NS;
}

/* Whether the motor pushes `cmd`'s reply, and so does not answer it (V4.2 §2.33.1). */
static bool pushed(const struct rmd_sim_motor *m, uint8_t cmd)
{
	int k = rmd_dialect_has(m->d, RMD_DIALECT_ACTIVE_REPLY) ? report_slot(m->d, cmd) : -1;

	return k >= 0 && m->report_steps[k];
}

/* V3 §2.33: function control. */
static void function_control(struct rmd_sim_motor *m, const struct rmd_msg *msg, int64_t now_ns)
{
	bool on = msg->v[RMD_FLD_VALUE] != 0;

	switch (msg->v[RMD_FLD_INDEX]) {
	case 1: /* clear the multi-turn value, saved, effective after restart */
		m->clear_multiturn = true;
		break;
	case 2: /* CAN ID filter, saved in flash */
		m->ram.can_filter = m->rom.can_filter = on;
		break;
	case 3: /* 0x9A every 100 ms while an error lasts (RAM: not said saved) */
		if (on && !m->error_reports)
			m->next_9a_ns = now_ns;
		m->error_reports = on;
		break;
	case 4: /* save the multi-turn value at power-off (kept: it must outlive it) */
		m->ram.multiturn_save = m->rom.multiturn_save = on;
		break;
	case 6: /* V4.2 §2.34.4: position limits, to ROM, effective at once */
	case 7:
		if (rmd_dialect_has(m->d, RMD_DIALECT_ANGLE_LIMITS)) {
			int64_t v = msg->v[RMD_FLD_VALUE];
			unsigned k = msg->v[RMD_FLD_INDEX] == 6 ? 0 : 1;

			m->ram.angle_limit[k] = m->rom.angle_limit[k] = (int32_t)v;
		}
		break;
	default:
		break;
	}
}

/*
 * One command of the V3 table (also on 0x280, and the V3 side of MIT
 * motors), the V2 table or the V4 table, answered whether or not 0xB6
 * pushes it.  Returns the number of replies in out[].
 */
static int answer(struct rmd_sim_motor *m, enum rmd_proto proto, int64_t now_ns,
		  const struct rmd_frame *f, uint32_t reply_id, struct rmd_frame *out, int max)
{
	const struct rmd_cmd_spec *spec, *rspec;
	struct rmd_msg req, rep;
	const struct rmd_dialect *d = m->d;
	struct rmd_pid_set carried;
	enum rmd_pid_op op;
	uint32_t named;
	int64_t id;
	uint8_t cmd;

	if (rmd_decode(proto, RMD_DIR_REQUEST, f, &req, NULL) < 0)
		return 0;
	cmd = req.cmd;
	spec = rmd_cmd_find(proto, cmd);
	if (!spec)
		return 0;
	msg_for(proto, cmd, &rep, &rspec);

	if (rmd_pid_parse(d, &req, &op, &named, &carried))
		return pid_request(m, proto, &req, op, named, &carried, f, reply_id, out, max);

	switch (cmd) {
	case 0x42: {
		/* V4.2 §2.4: the index asked, echoed; V3 §2.4 / V2 §3.19: none, index 0 */
		int64_t i = rmd_dialect_has(d, RMD_DIALECT_ACCEL_INDEX) ? req.v[RMD_FLD_INDEX] : 0;

		if (i < 0 || i > 3)
			return 0;
		put_int(&rep, rspec, RMD_FLD_INDEX, i);
		put_int(&rep, rspec, RMD_FLD_ACCEL, m->ram.accel_dps2[i]);
		return emit(m, proto, &rep, out, max);
	}
	case 0x43:
		if (!rmd_layout_field(spec, RMD_DIR_REQUEST, RMD_FLD_INDEX)) {
			/* V2 §3.20: one acceleration, RAM only. */
			int64_t a = req.v[RMD_FLD_ACCEL];
			uint32_t u = a < 0 ? 0 : a > UINT32_MAX ? UINT32_MAX : (uint32_t)a;

			for (unsigned i = 0; i < 4; i++)
				m->ram.accel_dps2[i] = u;
		} else if (req.v[RMD_FLD_INDEX] >= 0 && req.v[RMD_FLD_INDEX] < 4) {
			/* V3 §2.5: RAM and ROM, by index (§2.5.4). */
			unsigned i = (unsigned)req.v[RMD_FLD_INDEX];

			m->ram.accel_dps2[i] = m->rom.accel_dps2[i] =
				(uint32_t)req.v[RMD_FLD_ACCEL];
		}
		return echo(f, reply_id, out, max);
	case 0x60: /* V3 §2.6 / V2 §3.21: raw minus offset */
		put_int(&rep, rspec, RMD_FLD_ENCODER,
			rmd_sim_raw_counts(m) - m->ram.encoder_offset);
		return emit(m, proto, &rep, out, max);
	case 0x61: /* V3 §2.7 / V2 §3.22 */
		put_int(&rep, rspec, RMD_FLD_ENCODER_RAW, rmd_sim_raw_counts(m));
		return emit(m, proto, &rep, out, max);
	case 0x62: /* V3 §2.8 / V2 §3.23: the offset in use */
		put_int(&rep, rspec, RMD_FLD_ENCODER_OFF, m->ram.encoder_offset);
		return emit(m, proto, &rep, out, max);
	case 0x63: /* V3 §2.9 / V2 §3.24: ROM, effective after a restart */
		m->rom.encoder_offset = req.v[RMD_FLD_ENCODER_OFF];
		return echo(f, reply_id, out, max);
	case 0x64: /* V3 §2.10 / V2 §3.25: here becomes zero, in ROM, after a restart */
		m->rom.encoder_offset = rmd_sim_raw_counts(m);
		put_int(&rep, rspec, RMD_FLD_ENCODER_OFF, m->rom.encoder_offset);
		return emit(m, proto, &rep, out, max);
	case 0x70: /* V3 §2.23 / V2 §3.45 */
		put_int(&rep, rspec, RMD_FLD_MODE, run_mode(m));
		return emit(m, proto, &rep, out, max);
	case 0x71: /* V3 §2.24 / V2 §3.46: 0.1 W */
		put(&rep, rspec, RMD_FLD_POWER, rmd_sim_power_w(m));
		return emit(m, proto, &rep, out, max);
	case 0x72: /* V2 §3.47 */
		put(&rep, rspec, RMD_FLD_BATTERY, BATTERY_V);
		return emit(m, proto, &rep, out, max);
	case 0x73: { /* V2 §3.48: feed-forward current; the reply has no command byte */
		int n;

		m->tf_current_a = get(spec, &req, RMD_FLD_CURRENT, 0.0);
		settle(m);
		put(&rep, rspec, RMD_FLD_CURRENT, m->iq_a);
		put(&rep, rspec, RMD_FLD_SPEED, deg(m->vel_rad_s));
		put_int(&rep, rspec, RMD_FLD_ENCODER,
			rmd_sim_raw_counts(m) - m->ram.encoder_offset);
		n = emit(m, proto, &rep, out, max);
		return n;
	}
	case 0x76: {
		/* V3 §2.25: resets and does not answer; V2 §3.49: echoes first. */
		int n = spec->flags & RMD_CMD_NO_REPLY ? 0 : echo(f, reply_id, out, max);

		boot(m, now_ns, boot_time_ns(m));
		return n;
	}
	case 0x77: /* V3 §2.26 / V2 §3.50 */
	case 0x78: /* V3 §2.27 / V2 §3.51 */
		m->brake_locked = cmd == 0x78;
		settle(m);
		return echo(f, reply_id, out, max);
	case 0x79: {
		/* V3 §4 (on 0x300, routed by the caller) / V2 §3.52: 1 read, 0 write. */
		int64_t now = rmd_set_id_read_answer(d, m->ram.can_id);

		/* docs/protocol-v4.md: firmware that sets its ID by 0x20 no longer answers */
		if (now < 0)
			return 0;
		if (req.v[RMD_FLD_READ_FLAG] == 1) {
			put_int(&rep, rspec, RMD_FLD_READ_FLAG, 1);
			put_int(&rep, rspec, RMD_FLD_CAN_ID, now);
			return emit(m, proto, &rep, out, max);
		}
		if (!rmd_set_id_parse(d, &req, &id) || id < 1 || id > RMD_MAX_MOTORS)
			return 0;
		/* §4.3 / §3.52: a write returns the request, then the new ID holds. */
		{
			int n = echo(f, reply_id, out, max);

			m->ram.can_id = m->rom.can_id = (uint8_t)id;
			return n;
		}
	}
	case 0x80: /* V3 §2.15 / V2 §3.34: output off, state cleared */
		rmd_sim_off_state(m);
		return echo(f, reply_id, out, max);
	case 0x81: /* V3 §2.16 / V2 §3.35 */
		if (!m->errors)
			stop_hold(m);
		settle(m);
		return echo(f, reply_id, out, max);
	case 0x88: /* V2 §3.36: resume the mode held before 0x81 */
		if (!m->errors && m->ctrl == RMD_SIM_HOLD && m->ctrl_stopped != RMD_SIM_OFF)
			enter(m, m->ctrl_stopped);
		settle(m);
		return echo(f, reply_id, out, max);
	case 0x90: /* V2 §3.26: single-turn encoder, raw, offset */
		put_int(&rep, rspec, RMD_FLD_ENCODER, encoder_single(m));
		put_int(&rep, rspec, RMD_FLD_ENCODER_RAW, encoder_single_raw(m));
		put_int(&rep, rspec, RMD_FLD_ENCODER_OFF, m->ram.encoder_offset_single);
		return emit(m, proto, &rep, out, max);
	case 0x91: /* V2 §3.27: ROM */
		m->rom.encoder_offset_single =
			(uint16_t)(req.v[RMD_FLD_ENCODER_OFF] & encoder_single_mask(m));
		return echo(f, reply_id, out, max);
	case 0x19: /* V2 §3.28: here becomes the single-turn zero, after re-power */
		m->rom.encoder_offset_single = (uint16_t)encoder_single_raw(m);
		put_int(&rep, rspec, RMD_FLD_ENCODER_OFF, m->rom.encoder_offset_single);
		return emit(m, proto, &rep, out, max);
	case 0x92: /* V3 §2.11 / V2 §3.29: output shaft multi-turn angle */
		put(&rep, rspec, RMD_FLD_ANGLE, deg(rmd_sim_angle_rad(m)));
		return emit(m, proto, &rep, out, max);
	case 0x94: { /* V2 §3.30: 0..35999, 0.01 deg, growing clockwise */
		const struct rmd_field_spec *fs =
			rmd_layout_field(rspec, RMD_DIR_REPLY, RMD_FLD_ANGLE);
		double lsb = fs && fs->scale > 0.0 ? fs->scale : 0.01;
		int64_t turn = llround(360.0 / lsb);
		int64_t a = llround(wrap360(deg(rmd_sim_angle_rad(m))) / lsb);

		put_int(&rep, rspec, RMD_FLD_ANGLE, a >= turn ? a - turn : a);
		return emit(m, proto, &rep, out, max);
	}
	case 0x9A: /* V3 §2.12 / V2 §3.31 */
		fill_status1(m, &rep, rspec);
		return emit(m, proto, &rep, out, max);
	case 0x9C: /* V3 §2.13 / V2 §3.32 */
		fill_status2(m, &rep, rspec);
		return emit(m, proto, &rep, out, max);
	case 0x9D: /* V3 §2.14 / V2 §3.33 */
		fill_status3(m, &rep, rspec);
		return emit(m, proto, &rep, out, max);
	case 0xA1:
	case 0xA2:
	case 0xA3:
	case 0xA4:
	case 0xA5:
	case 0xA6:
	case 0xA7:
	case 0xA8:
		motion(m, proto, spec, &req);
		settle(m);
		fill_status2(m, &rep, rspec);
		return emit(m, proto, &rep, out, max);
	case 0xB1: /* V3 §2.28: ms since power-on or reset, uint32 */
		put_int(&rep, rspec, RMD_FLD_RUNTIME,
			(int64_t)(((uint64_t)(now_ns - m->boot_ns) / 1000000u) & UINT32_MAX));
		return emit(m, proto, &rep, out, max);
	case 0xB2: /* V3 §2.29 */
		put_int(&rep, rspec, RMD_FLD_VERSION, m->p.version_date);
		return emit(m, proto, &rep, out, max);
	case 0xB3: /* V3 §2.30: ROM, echoed (or, example 2, zeros) */
		m->ram.comm_timeout_ms = m->rom.comm_timeout_ms = (uint32_t)req.v[RMD_FLD_TIMEOUT];
		if (m->p.b3_answer_zeros)
			return emit(m, proto, &rep, out, max);
		return echo(f, reply_id, out, max);
	case 0xB4: { /* V3 §2.31: stored; "the reply is random content" */
		uint64_t r = rmd_sim_motor_rand(m);

		m->ram.baud_code = m->rom.baud_code = (uint8_t)req.v[RMD_FLD_BAUD];
		if ((r & 1) || max < 1 || !out)
			return 0;
		memset(out, 0, sizeof(*out));
		out->can_id = reply_id;
		out->len = RMD_FRAME_LEN;
		r = rmd_sim_motor_rand(m);
		memcpy(out->data, &r, RMD_FRAME_LEN);
		return 1;
	}
	case 0xB5: /* V3 §2.32: seven ASCII bytes */
		put_int(&rep, rspec, RMD_FLD_MODEL, rmd_model_raw(m->p.model));
		return emit(m, proto, &rep, out, max);
	case 0x20: /* V3 §2.33.3: echoed */
		/*
		 * V4.2 §2.34.4 index 5: the new ID to ROM, effective after 0x76;
		 * firmware 2025070202 echoes from the new 0x240 + ID at once and
		 * takes requests on the old one until the reset.
		 */
		if (rmd_set_id_parse(d, &req, &id)) {
			if (id >= 1 && id <= RMD_MAX_MOTORS) {
				m->rom.can_id = (uint8_t)id;
				reply_id = d->reply_base + (uint32_t)id;
				/* and every reply after it, until the reset (PR 28's scan) */
				if (m->p.set_id_replies_new)
					m->reply_as = (uint8_t)id;
			}
			return echo(f, reply_id, out, max);
		}
		function_control(m, &req, now_ns);
		return echo(f, reply_id, out, max);
	case 0xB6: /* V4.2 §2.33.3: no reply */
		active_reply(m, &req, now_ns);
		return 0;
	default:
		return 0;
	}
}

/* A request: not answered while 0xB6 pushes its reply (V4.2 §2.33.1). */
static int command(struct rmd_sim_motor *m, enum rmd_proto proto, int64_t now_ns,
		   const struct rmd_frame *f, uint32_t reply_id, struct rmd_frame *out, int max)
{
	if (pushed(m, f->data[0]))
		return 0;
	/* X4-64 2025070202: 0x79, whatever its bytes, answered as 0xB2 (p.answers_79_as_b2) */
	if (m->p.answers_79_as_b2 && f->data[0] == 0x79) {
		const struct rmd_cmd_spec *spec;
		struct rmd_msg rep;

		msg_for(proto, 0xB2, &rep, &spec);
		if (!spec)
			return 0;
		put_int(&rep, spec, RMD_FLD_VERSION, m->p.version_date);
		return emit(m, proto, &rep, out, max);
	}
	return answer(m, proto, now_ns, f, reply_id, out, max);
}

/* V2 §4.1: motor k (1..4) takes torque k and answers like 0xA1 (§4.2). */
static int v2_multi_torque(struct rmd_sim_motor *m, const struct rmd_frame *f,
			   struct rmd_frame *out, int max)
{
	const struct rmd_cmd_spec *spec, *a1;
	struct rmd_msg req, rep;
	enum rmd_field fld = (enum rmd_field)(RMD_FLD_CURRENT_1 + m->ram.can_id - 1);

	if (rmd_decode(m->d->proto, RMD_DIR_REQUEST, f, &req, NULL) < 0)
		return 0;
	spec = rmd_cmd_find(m->d->proto, RMD_V2_CMD_MULTI_TORQUE);
	if (!spec)
		return 0;
	if (!m->errors) {
		enter(m, RMD_SIM_TORQUE);
		m->sp_current_a = get(spec, &req, fld, 0.0);
	}
	settle(m);
	msg_for(m->d->proto, 0xA1, &rep, &a1);
	if (!a1)
		return 0;
	fill_status2(m, &rep, a1);
	return emit(m, m->d->proto, &rep, out, max);
}

/* V3 §5, V4.2 §5: MIT motion mode; the reply on 0x500 + ID. */
static int mit_command(struct rmd_sim_motor *m, const struct rmd_frame *f, struct rmd_frame *out,
		       int max)
{
	struct rmd_mit_cmd cmd;
	struct rmd_mit_reply rep;
	uint8_t id;

	if (rmd_mit_decode_cmd(&m->mit_ranges, f, &id, &cmd) < 0)
		return 0;
	if (!m->errors) {
		enter(m, RMD_SIM_MIT);
		m->mit = cmd;
		m->mit_seen = true;
	}
	settle(m);
	if (max < 1 || !out)
		return 0;
	rep.motor_id = reply_can_id(m);
	rep.pos_rad = rmd_sim_angle_rad(m);
	rep.vel_rad_s = m->vel_rad_s;
	rep.torque_nm = m->p.kt_nm_a * m->iq_a;
	return rmd_mit_encode_reply(&m->mit_ranges, &rep, out) < 0 ? 0 : 1;
}

/*
 * A frame addressed to the motor arrived: comm-loss bookkeeping (V3 §2.30).
 * True when this is the first frame after a trip, to be echoed only.
 */
static bool note_rx(struct rmd_sim_motor *m, int64_t now_ns)
{
	bool echo_only = m->echo_next;

	m->comm_armed = true;
	m->last_rx_ns = now_ns;
	m->comm_lost = false;
	m->echo_next = false;
	return echo_only;
}

enum route { R_NONE, R_SINGLE, R_BROADCAST, R_SET_ID, R_V2_MULTI, R_MIT };

/* Which of the motor's inputs a frame reaches, if any. */
static enum route route_of(const struct rmd_sim_motor *m, uint32_t can_id)
{
	uint8_t id = m->ram.can_id;
	bool batch = rmd_dialect_has(m->d, RMD_DIALECT_BATCH_280);

	if (can_id == m->d->req_base + id)
		return R_SINGLE;
	if (can_id == RMD_CAN_MULTI) {
		/* V2 §4.1: motors 1..4 only.  V3 §3.1: only with the filter off. */
		if (batch)
			return id >= 1 && id <= 4 ? R_V2_MULTI : R_NONE;
		return m->ram.can_filter ? R_NONE : R_BROADCAST;
	}
	/* V3 §4.1: every motor takes 0x300, unless its filter is on (§2.33.4). */
	if (can_id == rmd_dialect_set_id_can(m->d) && can_id)
		return m->ram.can_filter ? R_NONE : R_SET_ID;
	/* V3 §5, V4.2 §5: the firmware takes MIT frames, driven in MIT or not */
	if (can_id == RMD_CAN_MIT_REQ_BASE + id && rmd_dialect_offers_mit(m->d))
		return R_MIT;
	return R_NONE;
}

int rmd_sim_motor_receive(struct rmd_sim_motor *m, int64_t now_ns, const struct rmd_frame *f,
			  struct rmd_frame *out, int max)
{
	enum rmd_proto proto;
	enum route r;
	uint32_t reply_id;

	if (!m || !f)
		return 0;
	rmd_sim_motor_step(m, now_ns);
	if (!awake(m, now_ns) || f->len != RMD_FRAME_LEN)
		return 0;
	r = route_of(m, f->can_id);
	if (r == R_NONE)
		return 0;

	proto = rmd_proto_table(m->p.proto);
	switch (r) {
	case R_SET_ID:
		reply_id = RMD_CAN_SET_ID;
		break;
	case R_MIT:
		reply_id = RMD_CAN_MIT_REPLY_BASE + reply_can_id(m);
		break;
	case R_NONE:
	case R_SINGLE:
	case R_BROADCAST:
	case R_V2_MULTI:
	default:
		reply_id = m->d->reply_base + reply_can_id(m);
		break;
	}

	/* docs/design.md: after a comm-loss trip the first command is only echoed. */
	if (note_rx(m, now_ns))
		return echo(f, reply_id, out, max);

	/* firmware without the command: no answer (rmd/sim.h ignores_cmd, a recording's list) */
	if (((m->p.ignores_cmd && f->data[0] == m->p.ignores_cmd) ||
	     rmd_personality_ignores(&m->p.personality, f->data[0])) &&
	    (r == R_SINGLE || r == R_BROADCAST))
		return 0;
	switch (r) {
	case R_MIT:
		return mit_command(m, f, out, max);
	case R_V2_MULTI:
		return v2_multi_torque(m, f, out, max);
	case R_SET_ID:
	case R_SINGLE:
	case R_BROADCAST:
		return command(m, proto, now_ns, f, reply_id, out, max);
	case R_NONE:
		break;
	}
	return 0;
}

/* -------------------------------------------------------------------------- */
/* Unsolicited frames                                                         */

void rmd_sim_motor_hold_comm(struct rmd_sim_motor *m, int64_t held_ns)
{
	if (m->comm_armed && !m->comm_lost && held_ns > 0)
		m->last_rx_ns += held_ns;
}

/* The 0xF1 period after a trip (p.comm_loss_f1_ms, sanitized to 1..60000 ms). */
static int64_t f1_period_ns(const struct rmd_sim_motor *m)
{
	return (int64_t)(m->p.comm_loss_f1_ms ? m->p.comm_loss_f1_ms : COMM_LOST_PERIOD_MS) *
	       1000000;
}

/* Whether 0xF1 frames come: tripped, and the firmware sends them (p.comm_loss_silent). */
static bool f1_due(const struct rmd_sim_motor *m)
{
	return m->comm_lost && !m->p.comm_loss_silent;
}

static bool reporting(const struct rmd_sim_motor *m)
{
	return rmd_dialect_has(m->d, RMD_DIALECT_FUNC_CTRL) && m->error_reports && m->errors;
}

int rmd_sim_motor_poll(struct rmd_sim_motor *m, int64_t now_ns, struct rmd_frame *out, int max)
{
	int n = 0;

	if (!m)
		return 0;
	rmd_sim_motor_step(m, now_ns);
	if (!awake(m, now_ns) || !out)
		max = 0;
	/* docs/design.md: 0xF1 each second while the protection holds (V4 firmware). */
	while (f1_due(m) && m->next_f1_ns <= now_ns) {
		if (n >= max) {
			if (m->present && out)
				break;
			m->next_f1_ns += f1_period_ns(m); /* lost: nobody hears it */
			continue;
		}
		memset(&out[n], 0, sizeof(out[n]));
		out[n].can_id = RMD_CAN_V3_REPLY_BASE + reply_can_id(m);
		out[n].len = RMD_FRAME_LEN;
		out[n].data[0] = RMD_SIM_CMD_COMM_LOST;
		n++;
		m->next_f1_ns += f1_period_ns(m);
	}
	/* V3 §2.33.4 index 3: the 0x9A reply every 100 ms while faulted. */
	while (reporting(m) && m->next_9a_ns <= now_ns) {
		const struct rmd_cmd_spec *spec;
		struct rmd_msg rep;

		if (n >= max) {
			if (m->present && out)
				break;
			m->next_9a_ns += ERROR_REPORT_PERIOD_NS;
			continue;
		}
		msg_for(m->d->table, 0x9A, &rep, &spec);
		if (!spec)
			break;
		fill_status1(m, &rep, spec);
		n += emit(m, m->d->table, &rep, &out[n], max - n);
		m->next_9a_ns += ERROR_REPORT_PERIOD_NS;
	}
	/* V4.2 §2.33: the replies 0xB6 asked for, each on its own period. */
	for (unsigned k = 0; k < m->d->n_report_cmds && k < RMD_DIALECT_REPORTS_MAX; k++) {
		int64_t period = (int64_t)m->report_steps[k] * ACTIVE_REPLY_STEP_NS;

		while (period && m->report_next_ns[k] <= now_ns) {
			struct rmd_frame req = { .can_id = m->d->req_base + m->ram.can_id,
						 .len = RMD_FRAME_LEN,
						 .data = { m->d->report_cmds[k] } };

			if (n >= max) {
				if (m->present && out)
					break;
				m->report_next_ns[k] += period;
				continue;
			}
			n += answer(m, m->d->table, now_ns, &req, m->d->reply_base + m->ram.can_id,
				    &out[n], max - n);
			m->report_next_ns[k] += period;
		}
	}
	return n;
}

int64_t rmd_sim_motor_next_event_ns(const struct rmd_sim_motor *m)
{
	int64_t t = INT64_MAX;

	if (m->comm_lost) {
		if (f1_due(m))
			t = m->next_f1_ns;
	} else if (m->comm_armed && m->ram.comm_timeout_ms &&
		   rmd_dialect_has(m->d, RMD_DIALECT_COMM_LOSS_B3)) {
		/* The trip, and its first 0xF1, at the first step past the timeout. */
		int64_t due = m->last_rx_ns + (int64_t)m->ram.comm_timeout_ms * 1000000 + 1;
		int64_t k =
			due > m->t_ns ? (due - m->t_ns + RMD_SIM_STEP_NS - 1) / RMD_SIM_STEP_NS : 1;

		t = m->t_ns + k * RMD_SIM_STEP_NS;
	}
	if (reporting(m) && m->next_9a_ns < t)
		t = m->next_9a_ns;
	for (unsigned k = 0; k < m->d->n_report_cmds && k < RMD_DIALECT_REPORTS_MAX; k++)
		if (m->report_steps[k] && m->report_next_ns[k] < t)
			t = m->report_next_ns[k];
	return t;
}
