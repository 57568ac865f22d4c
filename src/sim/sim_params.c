// SPDX-License-Identifier: MIT
/*
 * The simulated motor's parameters as text (rmd/sim_params.h): the one
 * table rmdd.yaml's sim sections and rmd-sim read, and its parser.  Non-rt.
 */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "rmd/codec.h"
#include "rmd/mit.h"
#include "rmd/sim_params.h"
#include "rmd/sim_personality.h"

#define ROW(k, a, t, field, lo, hi, excl, u, h, fl)                                        \
	{                                                                                  \
		.key = k, .alias = a, .type = RMD_SIM_PARAM_##t,                           \
		.off = offsetof(struct rmd_sim_motor_params, field), .min = lo, .max = hi, \
		.min_excl = excl, .unit = u, .help = h, .flags = fl                        \
	}

/*
 * Ranges are the union of what rmdd.yaml and rmd-sim allowed before they
 * shared this table, so no file or command line that worked is refused.
 */
const struct rmd_sim_param rmd_sim_params[] = {
	ROW("protocol", NULL, PROTO, proto, 0, 0, false, "",
	    "(MIT motors also speak V3); rmdd.yaml: the motor's protocol",
	    RMD_SIM_PARAM_MOTOR_KEY | RMD_SIM_PARAM_KEYS_FIRST),
	ROW("firmware", NULL, PROTO, proto, 0, 0, false, "",
	    "the simulated firmware's dialect (a protocol key); rmdd.yaml motors[].sim: what a "
	    "motor with protocol auto turns out to speak (or another than its protocol, to see "
	    "the mismatch refused); rmd-sim: the same as protocol",
	    0),
	ROW("model", NULL, MODEL, model, 0, 0, false, "",
	    "0xB5 model string, 1..7 ASCII characters", 0),
	ROW("version_date", "version", VERSION, version_date, 0, 0, false, "yyyymmdd[NN]",
	    "0xB2 firmware date (default: one of its dialect's, V3 20220206, V4 2025070202)", 0),
	ROW("inertia_kgm2", "inertia", REAL, inertia_kgm2, 0, 1000, true, "kg·m²",
	    "inertia at the output shaft, rotor reflected", 0),
	ROW("viscous_nm_s_rad", "viscous", REAL, viscous_nm_s_rad, 0, 1e4, false, "N·m·s/rad",
	    "viscous friction", 0),
	ROW("coulomb_nm", "coulomb", REAL, coulomb_nm, 0, 1e4, false, "N·m", "Coulomb friction", 0),
	ROW("kt_nm_a", "kt", REAL, kt_nm_a, 0, 1e4, true, "N·m/A",
	    "output torque per amp of iq (rmdd.yaml: torque_constant_nm_a wins)", 0),
	ROW("gear_ratio", "gear", REAL, gear_ratio, 0, 1e4, true, "",
	    "motor turns per output turn (rmdd.yaml: the motor's gear_ratio wins)", 0),
	ROW("pole_pairs", "pole-pairs", UINT, pole_pairs, 1, 100, false, "", "rotor pole pairs", 0),
	ROW("max_current_a", "max-current", REAL, max_current_a, 0, 1000, true, "A",
	    "drive current limit", 0),
	ROW("load_nm", "load", REAL, load_nm, -1e4, 1e4, false, "N·m",
	    "constant external torque on the shaft", 0),
	ROW("max_speed_dps", "max-speed", REAL, max_speed_dps, 0, 1e6, true, "dps",
	    "over-speed fault above this", 0),
	ROW("fw_max_speed_dps", "fw-max-speed", REAL, fw_max_speed_dps, 0, 1e6, true, "dps",
	    "the firmware's Max Speed (0xA3, V2 0xA5/0xA7)", 0),
	ROW("phase_resistance_ohm", "resistance", REAL, phase_resistance_ohm, 0, 100, false, "Ω",
	    "phase resistance", 0),
	ROW("thermal_resistance_c_w", "thermal-resistance", REAL, thermal_resistance_c_w, 0, 1000,
	    true, "°C/W", "winding to ambient", 0),
	ROW("thermal_tau_s", "thermal-tau", REAL, thermal_tau_s, 0, 1e6, true, "s",
	    "thermal time constant", 0),
	ROW("ambient_c", "ambient", REAL, ambient_c, -60, 150, false, "°C", "ambient temperature",
	    0),
	ROW("supply_v", "supply", REAL, supply_v, 0, 1000, false, "V", "supply voltage", 0),
	ROW("over_temp_c", "over-temp", REAL, over_temp_c, -60, 300, false, "°C",
	    "over-temperature fault above this", 0),
	ROW("over_temp_clear_c", "over-temp-clear", REAL, over_temp_clear_c, -60, 300, false, "°C",
	    "... until the winding cools below this", 0),
	ROW("under_voltage_v", "under-voltage", REAL, under_voltage_v, 0, 1000, false, "V",
	    "low-voltage fault below this", 0),
	ROW("over_voltage_v", "over-voltage", REAL, over_voltage_v, 0, 1000, false, "V",
	    "over-voltage fault above this", 0),
	ROW("stall_time_s", "stall-time", REAL, stall_time_s, 0, 1e4, true, "s",
	    "near-limit current at standstill this long: stall fault", 0),
	ROW("has_brake", "brake", BOOL, has_brake, 0, 0, false, "",
	    "the motor has a holding brake (yes/no)", 0),
	ROW("encoder_bits", "encoder-bits", UINT, encoder_bits, 8, 24, false, "",
	    "motor-side single-turn encoder resolution", 0),
	ROW("mit_ranges", "mit-ranges", MIT, mit, 0, 0, false, "",
	    "MIT ranges P,V,T,KP,KD: p ±P rad, v ±V rad/s, t ±T N·m, kp 0..KP, kd 0..KD; "
	    "rmdd.yaml: the motor's mit",
	    RMD_SIM_PARAM_MOTOR_KEY),
	ROW("start_angle_deg", "start-angle", REAL, start_angle_deg, -1e9, 1e9, false, "°",
	    "output angle at first power-on, multi-turn", 0),
	ROW("v2_angle_magnitude", "v2-angle-magnitude", BOOL, v2_angle_magnitude, 0, 0, false, "",
	    "V2 0x92/0x60..0x62: a negative value as magnitude + sign flag 1 (yes/no)", 0),
	ROW("ignores_cmd", "ignores-cmd", UINT, ignores_cmd, 0, 255, false, "",
	    "a command byte the firmware does not know (e.g. 0x92 on old V2 firmware): never "
	    "answered; 0: none",
	    0),
	ROW("b3_answer_zeros", "b3-answer-zeros", BOOL, b3_answer_zeros, 0, 0, false, "",
	    "answer 0xB3 with zeros (V3 §2.30 example 2), not its echo (yes/no)", 0),
	ROW("comm_loss_rom_ms", "comm-loss-rom", UINT, comm_loss_rom_ms, 0, 600000, false, "ms",
	    "0xB3 time already in ROM at first power-on (an earlier run's); 0: off", 0),
	ROW("comm_loss_tripped", "comm-loss-tripped", BOOL, comm_loss_tripped, 0, 0, false, "",
	    "that protection has tripped already: the first command is only echoed (yes/no)", 0),
	ROW("active_reply_9c_ms", "active-reply-9c", UINT, active_reply_9c_ms, 0, 655350, false,
	    "ms",
	    "V4: left by another tool pushing 0x9C every this many ms (0xB6), not answering 0x9C "
	    "reads; 0: off",
	    0),
	ROW("multi_turn_save", "multi-turn-save", BOOL, multi_turn_save, 0, 0, false, "",
	    "0x20 index 4 set in ROM: the multi-turn count survives power-off (yes/no)", 0),
	ROW("wrap_rotor", "wrap-rotor", BOOL, wrap_rotor, 0, 0, false, "",
	    "a start without it wraps the angle within one rotor turn, not one output turn (yes/no)",
	    0),
	ROW("boot_ms", "boot", UINT, boot_ms, 0, 600000, false, "ms",
	    "firmware boot after power returns (a disappear fault with param 1 ending) or a "
	    "0x76 reset: it answers nothing this long (an X-series motor: about 1100); 0: at once",
	    0),
	ROW("personality", NULL, PERSONALITY, personality, 0, 0, false, "",
	    "the firmware's personality (docs/rmd-sim.md \"Personalities\"): auto (the built-in "
	    "one of model, version_date and protocol, if any), none, a built-in name, or a "
	    "personality file; what it gives replaces the keys of the same name",
	    0),
	ROW("answers_79_as_b2", NULL, BOOL, answers_79_as_b2, 0, 0, false, "",
	    "0x79 (read or write) answered with the 0xB2 reply, the ID unchanged (X4-64 "
	    "2025070202) (yes/no)",
	    0),
	ROW("set_id_replies_new", NULL, BOOL, set_id_replies_new, 0, 0, false, "",
	    "after 0x20 index 5 every reply comes from the new ID, requests still on the old one, "
	    "until 0x76 (X4-36/X4-64 2025070202) (yes/no)",
	    0),
	ROW("comm_loss_f1_ms", NULL, UINT, comm_loss_f1_ms, 1, 60000, false, "ms",
	    "after a comm-loss trip, a 0xF1 frame this often (as V4 firmware: 1000)", 0),
	ROW("comm_loss_silent", NULL, BOOL, comm_loss_silent, 0, 0, false, "",
	    "after a comm-loss trip, no 0xF1 frames (yes/no)", 0),
	ROW("comm_loss_executes_first", NULL, BOOL, comm_loss_executes_first, 0, 0, false, "",
	    "after a comm-loss trip, the first command is executed, not only echoed (yes/no)", 0),
	ROW("a4_ignored_after_mit", NULL, BOOL, a4_ignored_after_mit, 0, 0, false, "",
	    "0xA4 not executed after an MIT frame until a reset, answered as the motor stands "
	    "(X6-P20 2025070202) (yes/no)",
	    0),
	ROW("status1_executing", NULL, BOOL, status1_executing, 0, 0, false, "",
	    "0x9A data[3] is 1 while a control mode runs, not the brake's state (2025070202) "
	    "(yes/no)",
	    0),
	ROW("turnaround_us", NULL, US, turnaround_ns, 0, 1e6, false, "µs",
	    "request end to reply start, mean", 0),
	ROW("turnaround_jitter_us", "jitter-us", US, turnaround_jitter_ns, 0, 1e6, false, "µs",
	    "turnaround jitter, uniform ±", 0),
	ROW("rom_write_us", "rom-write", US, rom_write_ns, 0, 10e6, false, "µs",
	    "extra answer time of commands that write ROM (0x32, 0x64, 0x79, 0xB3, ...)", 0),
	ROW("adapter_latency_timer_us", NULL, US, adapter_latency_timer_ns, 0, 255e3, false, "µs",
	    "the host's adapter: a USB-RS485 converter's latency timer, received bytes held "
	    "until it expires (FTDI default 16000); 0: none",
	    0),
	ROW("adapter_usb_frame_us", NULL, US, adapter_usb_frame_ns, 0, 1e6, false, "µs",
	    "the host's adapter: frames reach the host at the end of the USB frame they fell "
	    "in (full speed: 1000); 0: none",
	    0),
	ROW("adapter_delay_us", NULL, US, adapter_delay_ns, 0, 1e6, false, "µs",
	    "the host's adapter: a fixed delay on every frame to the host; 0: none", 0),
	ROW("adapter_rx_batch", NULL, UINT, adapter_rx_batch, 0, 64, false, "frames",
	    "the host's adapter, with adapter_usb_frame_us: up to this many received frames "
	    "packed into one USB packet, sent at the end of the USB frame after the one its "
	    "first frame fell in, all stamped at once (PCAN-USB); 0: none",
	    0),
};
#undef ROW

const size_t rmd_sim_n_params = sizeof(rmd_sim_params) / sizeof(rmd_sim_params[0]);

/* a and b alike, any case, '-' and '_' the same. */
static bool same_key(const char *a, const char *b)
{
	for (; *a && *b; a++, b++) {
		char x = *a == '-' ? '_' : (char)tolower((unsigned char)*a);
		char y = *b == '-' ? '_' : (char)tolower((unsigned char)*b);

		if (x != y)
			return false;
	}
	return *a == *b;
}

const struct rmd_sim_param *rmd_sim_param_find(const char *key)
{
	for (size_t i = 0; i < rmd_sim_n_params; i++) {
		const struct rmd_sim_param *p = &rmd_sim_params[i];

		if (same_key(key, p->key) || (p->alias && same_key(key, p->alias)))
			return p;
	}
	return NULL;
}

size_t rmd_sim_param_size(const struct rmd_sim_param *spec)
{
	const struct rmd_sim_motor_params *p = NULL;

	switch (spec->type) {
	case RMD_SIM_PARAM_REAL:
	case RMD_SIM_PARAM_US:
		return sizeof(double);
	case RMD_SIM_PARAM_UINT:
		return sizeof(unsigned);
	case RMD_SIM_PARAM_BOOL:
		return sizeof(bool);
	case RMD_SIM_PARAM_PROTO:
		return sizeof(p->proto);
	case RMD_SIM_PARAM_MODEL:
		return sizeof(p->model);
	case RMD_SIM_PARAM_VERSION:
		return sizeof(p->version_date);
	case RMD_SIM_PARAM_MIT:
		return sizeof(p->mit);
	case RMD_SIM_PARAM_PERSONALITY:
		return sizeof(p->personality);
	}
	return 0;
}

int rmd_sim_parse_real(const char *s, double *v)
{
	char *end;

	errno = 0;
	*v = strtod(s, &end);
	if (end == s || *end != '\0' || errno == ERANGE || !isfinite(*v) ||
	    isspace((unsigned char)*s))
		return -EINVAL;
	return 0;
}

int rmd_sim_parse_u64(const char *s, uint64_t *v)
{
	char *end;

	if (!*s || *s == '-' || *s == '+' || isspace((unsigned char)*s))
		return -EINVAL;
	errno = 0;
	/* Decimal, or hex with 0x; never octal ("010" is ten). */
	*v = strtoull(s, &end, (s[0] == '0' && (s[1] == 'x' || s[1] == 'X')) ? 16 : 10);
	if (*end != '\0' || errno == ERANGE)
		return -EINVAL;
	return 0;
}

int rmd_sim_parse_bool(const char *s, bool *b)
{
	static const char *const yes[] = { "yes", "true", "on", "1" };
	static const char *const no[] = { "no", "false", "off", "0" };

	for (size_t i = 0; i < sizeof(yes) / sizeof(yes[0]); i++) {
		if (!strcasecmp(s, yes[i])) {
			*b = true;
			return 0;
		}
		if (!strcasecmp(s, no[i])) {
			*b = false;
			return 0;
		}
	}
	return -EINVAL;
}

static int parse_proto(const char *s, enum rmd_proto *proto)
{
	return rmd_proto_parse(s, proto); /* the dialects' keys (rmd/dialect.h) */
}

/* "P,V,T,KP,KD", each > 0 and at most 1e6. */
static int parse_mit(const char *s, struct rmd_mit_ranges *r)
{
	struct rmd_mit_ranges t;

	if (rmd_mit_ranges_parse(s, &t) < 0 || t.p_max > 1e6 || t.v_max > 1e6 || t.t_max > 1e6 ||
	    t.kp_max > 1e6 || t.kd_max > 1e6)
		return -EINVAL;
	*r = t;
	return 0;
}

/* auto, none or a built-in personality's name (a file: rmd_sim_param_parse_file()). */
static int parse_personality(const char *s, struct rmd_personality *out, char *allowed, size_t size)
{
	const struct rmd_personality *b = rmd_personality_builtin(s);
	char names[256];

	if (!strcasecmp(s, "auto") || !strcasecmp(s, "none")) {
		memset(out, 0, sizeof(*out));
		out->source = strcasecmp(s, "auto") ? RMD_PERSONALITY_NONE : RMD_PERSONALITY_AUTO;
		return 0;
	}
	if (b) {
		*out = *b;
		return 0;
	}
	snprintf(allowed, size, "auto, none, a built-in personality (%s) or a personality file",
		 rmd_personality_names(names, sizeof(names)));
	return -EINVAL;
}

int rmd_sim_param_parse(struct rmd_sim_motor_params *p, const struct rmd_sim_param *spec,
			const char *value, char *allowed, size_t size)
{
	char *field = (char *)p + spec->off;
	double v;
	uint64_t u;

	switch (spec->type) {
	case RMD_SIM_PARAM_REAL:
	case RMD_SIM_PARAM_US:
		if (rmd_sim_parse_real(value, &v) < 0 || v > spec->max || v < spec->min ||
		    (spec->min_excl && v == spec->min)) {
			snprintf(allowed, size, "a number %s %g and <= %g%s%s",
				 spec->min_excl ? ">" : ">=", spec->min, spec->max,
				 *spec->unit ? ", in " : "", spec->unit);
			return -EINVAL;
		}
		if (spec->type == RMD_SIM_PARAM_US)
			v *= 1000.0;
		memcpy(field, &v, sizeof(v));
		return 0;
	case RMD_SIM_PARAM_UINT: {
		unsigned x;

		if (rmd_sim_parse_u64(value, &u) < 0 || u < spec->min || u > spec->max) {
			snprintf(allowed, size, "an integer %g..%g", spec->min, spec->max);
			return -EINVAL;
		}
		x = (unsigned)u;
		memcpy(field, &x, sizeof(x));
		return 0;
	}
	case RMD_SIM_PARAM_BOOL: {
		bool b;

		if (rmd_sim_parse_bool(value, &b) < 0) {
			snprintf(allowed, size, "yes or no (true/false, on/off, 1/0)");
			return -EINVAL;
		}
		memcpy(field, &b, sizeof(b));
		return 0;
	}
	case RMD_SIM_PARAM_PROTO: {
		enum rmd_proto proto;

		if (parse_proto(value, &proto) < 0) {
			rmd_proto_keys_text(allowed, size, ", ", " or ");
			return -EINVAL;
		}
		memcpy(field, &proto, sizeof(proto));
		return 0;
	}
	case RMD_SIM_PARAM_MODEL: {
		size_t n = strlen(value);

		for (size_t i = 0; i < n; i++) {
			if (value[i] < 0x21 || value[i] > 0x7E)
				n = 0;
		}
		if (n < 1 || n > 7) {
			snprintf(allowed, size,
				 "1..7 printable ASCII characters without spaces "
				 "(V3 §2.32)");
			return -EINVAL;
		}
		memset(field, 0, sizeof(p->model));
		memcpy(field, value, n);
		return 0;
	}
	case RMD_SIM_PARAM_VERSION: {
		uint32_t d;

		if (rmd_sim_parse_u64(value, &u) < 0 || u > UINT32_MAX ||
		    !rmd_version_date_valid((uint32_t)u)) {
			snprintf(allowed, size,
				 "a date yyyymmdd, e.g. 20220206 (V3 §2.29), or yyyymmddNN, e.g. "
				 "2025070202");
			return -EINVAL;
		}
		d = (uint32_t)u;
		memcpy(field, &d, sizeof(d));
		return 0;
	}
	case RMD_SIM_PARAM_MIT: {
		struct rmd_mit_ranges r;

		if (parse_mit(value, &r) < 0) {
			snprintf(allowed, size,
				 "P,V,T,KP,KD: five numbers > 0, e.g. "
				 "12.5,45,24,500,5 (V3 §5.1)");
			return -EINVAL;
		}
		memcpy(field, &r, sizeof(r));
		return 0;
	}
	case RMD_SIM_PARAM_PERSONALITY:
		return parse_personality(value, &p->personality, allowed, size);
	}
	snprintf(allowed, size, "?");
	return -EINVAL;
}
