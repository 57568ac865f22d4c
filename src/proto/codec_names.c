// SPDX-License-Identifier: MIT
/*
 * Names and checks for codec values: protocols, error flags, run modes, the
 * 0xB5 model string and the 0xB2 version date.  Pure and rt-safe; every
 * string returned is static.
 */
#include <errno.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "rmd/codec.h"

/* In the order of enum rmd_proto. */
const char *const rmd_proto_keys[] = { "v3", "v2", "mit", NULL };
static const char *const proto_names[] = { "V3", "V2", "MIT" };
_Static_assert(RMD_PROTO_V3 == 0 && RMD_PROTO_V2 == 1 && RMD_PROTO_MIT == 2,
	       "rmd_proto_keys[] follows enum rmd_proto");

const char *rmd_proto_key(enum rmd_proto proto)
{
	return (unsigned)proto < 3 ? rmd_proto_keys[proto] : "?";
}

const char *rmd_proto_name(enum rmd_proto proto)
{
	return (unsigned)proto < 3 ? proto_names[proto] : "?";
}

int rmd_proto_parse(const char *s, enum rmd_proto *proto)
{
	for (unsigned i = 0; i < 3; i++) {
		const char *k = rmd_proto_keys[i];
		size_t j;

		/* ASCII case-insensitive, whatever the locale. */
		for (j = 0; k[j] && (s[j] == k[j] || s[j] == k[j] - 'a' + 'A'); j++)
			;
		if (!k[j] && !s[j]) {
			*proto = (enum rmd_proto)i;
			return 0;
		}
	}
	return -EINVAL;
}

struct flag_name {
	uint16_t code;
	const char *name;
};

/* V3 §2.12 table 1 (System_errorState): one bit per condition. */
static const struct flag_name v3_error_bits[] = {
	{ 0x0002, "stall" },
	{ 0x0004, "low_voltage" },
	{ 0x0008, "over_voltage" },
	{ 0x0010, "phase_overcurrent" },
	{ 0x0040, "power_overrun" },
	/* §8.2 calls it a calibration parameter read error; §2.12 says write. */
	{ 0x0080, "calibration_write_error" },
	{ 0x0100, "overspeed" },
	{ 0x1000, "over_temperature" },
	{ 0x2000, "encoder_calibration_error" },
};

/*
 * V2 §3.31 table 1 (System_errorState): one bit per condition.  The table
 * lists hardware over-current as 0x0000, which no bit can be; it is the
 * only free bit below 0x2000 and heads the list as bit 0 would, so it is
 * taken as 0x0001.
 */
static const struct flag_name v2_error_bits[] = {
	{ 0x0001, "hardware_overcurrent" },
	{ 0x0002, "stall" },
	{ 0x0004, "low_voltage" },
	{ 0x0008, "over_voltage" },
	{ 0x0010, "overcurrent" },
	{ 0x0020, "brake_open_failed" },
	{ 0x0040, "bus_current_error" },
	{ 0x0080, "battery_voltage_error" },
	{ 0x0100, "overspeed" },
	{ 0x0200, "position_loop_exceeded" },
	{ 0x0400, "vdd_error" },
	{ 0x0800, "dsp_over_temperature" },
	{ 0x1000, "over_temperature" },
	{ 0x2000, "encoder_calibration_error" },
};

/*
 * V2 §3.31 table 2 (CAN_errorState): whole codes, not bits (0x00F0 is not
 * bits 4..7 of table 1).  §3.37 names 0x00F6 as the "three-loop operation
 * error" that table 2 lists as 0x00F2; both are accepted.
 */
static const struct flag_name v2_error_codes[] = {
	{ 0x00F0, "pid_rom_write_unsafe" }, { 0x00F1, "encoder_rom_write_unsafe" },
	{ 0x00F2, "loop_switch_unsafe" },   { 0x00F3, "brake_not_open" },
	{ 0x00F4, "rom_write_unsafe" },	    { 0x00F6, "loop_switch_unsafe" },
};

/* A bit no table names keeps a name of its own, so no flag goes unreported. */
static const char *const unknown_bits[16] = {
	"unknown_0x0001", "unknown_0x0002", "unknown_0x0004", "unknown_0x0008",
	"unknown_0x0010", "unknown_0x0020", "unknown_0x0040", "unknown_0x0080",
	"unknown_0x0100", "unknown_0x0200", "unknown_0x0400", "unknown_0x0800",
	"unknown_0x1000", "unknown_0x2000", "unknown_0x4000", "unknown_0x8000",
};

#define ARRAY_SIZE(a) (sizeof(a) / sizeof((a)[0]))

static const char *bit_name(const struct flag_name *t, size_t n, uint16_t bit)
{
	for (size_t i = 0; i < n; i++)
		if (t[i].code == bit)
			return t[i].name;
	return NULL;
}

size_t rmd_error_names(enum rmd_proto proto, uint16_t code, const char **names, size_t max)
{
	const struct flag_name *bits;
	size_t nbits, count = 0;

	switch (proto) {
	case RMD_PROTO_V3:
		bits = v3_error_bits;
		nbits = ARRAY_SIZE(v3_error_bits);
		break;
	case RMD_PROTO_V2:
		for (size_t i = 0; i < ARRAY_SIZE(v2_error_codes); i++) {
			if (v2_error_codes[i].code == code) {
				if (max > 0)
					names[0] = v2_error_codes[i].name;
				return 1;
			}
		}
		bits = v2_error_bits;
		nbits = ARRAY_SIZE(v2_error_bits);
		break;
	case RMD_PROTO_MIT:
	default:
		return 0;
	}

	for (unsigned b = 0; b < 16; b++) {
		uint16_t bit = (uint16_t)(1u << b);
		const char *name;

		if (!(code & bit))
			continue;
		name = bit_name(bits, nbits, bit);
		if (count < max)
			names[count] = name ? name : unknown_bits[b];
		count++;
	}
	return count;
}

const char *rmd_run_mode_name(enum rmd_proto proto, uint8_t mode)
{
	switch (proto) {
	case RMD_PROTO_V3:
		/* V3 §2.23.3 */
		switch (mode) {
		case 0x01:
			return "current_loop";
		case 0x02:
			return "speed_loop";
		case 0x03:
			return "position_loop";
		default:
			return NULL;
		}
	case RMD_PROTO_V2:
		/* V2 §3.45 */
		switch (mode) {
		case 0x00:
			return "current_loop";
		case 0x01:
			return "speed_loop";
		case 0x02:
			return "position_loop";
		case 0xFF:
			return "init";
		default:
			return NULL;
		}
	case RMD_PROTO_MIT:
		break;
	}
	return NULL;
}

/* V3 §2.32: seven ASCII bytes, data[1] first (the field's LSB). */
void rmd_model_string(int64_t raw, char buf[8])
{
	uint64_t u = (uint64_t)raw;
	unsigned n;

	for (n = 0; n < 7; n++, u >>= 8) {
		uint8_t c = (uint8_t)u;

		if (!c)
			break;
		buf[n] = (c >= 0x20 && c < 0x7F) ? (char)c : '?';
	}
	buf[n] = '\0';
}

int64_t rmd_model_raw(const char *s)
{
	uint64_t u = 0;

	if (!s)
		return 0;
	for (unsigned i = 0; i < 7 && s[i]; i++)
		u |= (uint64_t)(uint8_t)s[i] << (8 * i);
	return (int64_t)u;
}

/* V3 §2.29: yyyymmdd, e.g. 20220206.  Plausible: a real date in 2000..2099. */
bool rmd_version_date_valid(uint32_t yyyymmdd)
{
	static const uint8_t mdays[12] = { 31, 29, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31 };
	uint32_t y = yyyymmdd / 10000, m = yyyymmdd / 100 % 100, d = yyyymmdd % 100;
	bool leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;

	if (y < 2000 || y > 2099 || m < 1 || m > 12 || d < 1 || d > mdays[m - 1])
		return false;
	return !(m == 2 && d == 29 && !leap);
}
