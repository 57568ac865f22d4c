// SPDX-License-Identifier: MIT
/*
 * Protocol V2.0 command table (rmd-can-protocol-v2.0-en.txt).
 * Section numbers (§) are the manual's.  Requests and replies on 0x140 + ID;
 * 0x280 carries four torque setpoints (§4.1).
 *
 * Three things the table interpreter cannot say, and how the rows settle
 * them:
 * - §3.21 .. §3.25, §3.29: multi-turn values are "int64_t, valid data is 6
 *   bytes" at data[1..6] with data[7] described as a sign flag (1 negative,
 *   0 positive).  Firmware writes a negative value either as the int64's
 *   low six bytes (two's complement) with the flag 1 (or 0xFF, the int64's
 *   seventh byte), or as the magnitude with the flag 1: the rows read
 *   data[1..6] with data[7] as a sign byte (struct rmd_field_spec.sign_byte),
 *   which takes both: -50.00 deg is 78 EC FF FF FF FF 01 or 88 13 00 00 00
 *   00 01.  Encoding writes the first form.
 * - §3.48: the 0x73 TF reply has no command byte (iq sits in data[0..1]).
 *   Its reply layout starts at data[0]; encoding is exact, but rmd_decode()
 *   finds the row only when data[0] happens to be 0x73.  A caller that sent
 *   0x73 must match the reply by identifier and time, not by data[0].
 * - §3.37: in an unsafe loop switch the 0xA1..0xA8 reply carries an error
 *   code (table 2, e.g. 0x00F6) in data[6..7] and zeros elsewhere; it
 *   decodes as encoder = the code.  Temperature, iq and speed all zero with
 *   an encoder value of 0x00F0..0x00F6 is the caller's hint.
 */
#include "codec_tables.h"

/* §3.32, §3.37 .. §3.44: measured iq -2048..2048 is -33..33 A. */
#define V2_IQ_A (33.0 / 2048.0)
/* §3.37, §4.1: iqControl -2000..2000 is -32..32 A. */
#define V2_IQ_SET_A (32.0 / 2000.0)
#define V2_MULTI_CITE "V2 §4.1: -2000..2000 is -32..32 A"
/* §3.1 .. §3.18: PI gains are Q24 fixed point, 1.0 = 16777216. */
#define V2_Q24 (1.0 / 16777216.0)
/* §3.33: phase current 1 A per 64 LSB. */
#define V2_PHASE_A (1.0 / 64.0)

/* §3.32, §3.37 .. §3.44: temperature, iq, speed 1 dps, encoder uint16. */
#define V2_STATUS2                                                                                 \
	RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_S(CURRENT, 2, 2, V2_IQ_A), RMD_S(SPEED, 4, 2, 1.0), \
		   RMD_U(ENCODER, 6, 2, 1.0))

/* §3.1 .. §3.18: one Q24 int32 gain at data[4..7]. */
#define V2_GAIN(fld) RMD_LAYOUT(RMD_S(fld, 4, 4, V2_Q24))

/* §3.21 .. §3.25, §3.29: 48-bit multi-turn value at data[1..6], sign at data[7] (see above). */
#define V2_MULTI(fld, scale) RMD_LAYOUT(RMD_SF(fld, 1, 6, scale))

RMD_ROWS_BEGIN
const struct rmd_cmd_spec rmd_v2_cmds[] = {
	/* §3.1 .. §3.6: read one gain; the reply carries it at data[4..7]. */
	{ 0x30, "read_pos_kp", 0, { 0 }, V2_GAIN(POS_KP) },
	{ 0x31, "read_pos_ki", 0, { 0 }, V2_GAIN(POS_KI) },
	{ 0x32, "read_speed_kp", 0, { 0 }, V2_GAIN(SPD_KP) },
	{ 0x33, "read_speed_ki", 0, { 0 }, V2_GAIN(SPD_KI) },
	{ 0x34, "read_current_kp", 0, { 0 }, V2_GAIN(CURR_KP) },
	{ 0x35, "read_current_ki", 0, { 0 }, V2_GAIN(CURR_KI) },
	/* §3.7 .. §3.12: write one gain to RAM, lost at power off; echoes. */
	{ 0x36, "write_pos_kp_ram", RMD_CMD_ECHO, V2_GAIN(POS_KP), { 0 } },
	{ 0x37, "write_pos_ki_ram", RMD_CMD_ECHO, V2_GAIN(POS_KI), { 0 } },
	{ 0x38, "write_speed_kp_ram", RMD_CMD_ECHO, V2_GAIN(SPD_KP), { 0 } },
	{ 0x39, "write_speed_ki_ram", RMD_CMD_ECHO, V2_GAIN(SPD_KI), { 0 } },
	{ 0x3A, "write_current_kp_ram", RMD_CMD_ECHO, V2_GAIN(CURR_KP), { 0 } },
	{ 0x3B, "write_current_ki_ram", RMD_CMD_ECHO, V2_GAIN(CURR_KI), { 0 } },
	/* §3.13 .. §3.18: write one gain to ROM, kept at power off; echoes. */
	{ 0x3C, "write_pos_kp_rom", RMD_CMD_ECHO | RMD_CMD_ROM, V2_GAIN(POS_KP), { 0 } },
	{ 0x3D, "write_pos_ki_rom", RMD_CMD_ECHO | RMD_CMD_ROM, V2_GAIN(POS_KI), { 0 } },
	{ 0x3E, "write_speed_kp_rom", RMD_CMD_ECHO | RMD_CMD_ROM, V2_GAIN(SPD_KP), { 0 } },
	{ 0x3F, "write_speed_ki_rom", RMD_CMD_ECHO | RMD_CMD_ROM, V2_GAIN(SPD_KI), { 0 } },
	{ 0x40, "write_current_kp_rom", RMD_CMD_ECHO | RMD_CMD_ROM, V2_GAIN(CURR_KP), { 0 } },
	{ 0x41, "write_current_ki_rom", RMD_CMD_ECHO | RMD_CMD_ROM, V2_GAIN(CURR_KI), { 0 } },
	/* §3.19: acceleration, int32 1 dps/s at data[4..7], no index. */
	{ 0x42, "read_accel", 0, { 0 }, RMD_LAYOUT(RMD_S(ACCEL, 4, 4, 1.0)), RMD_SAY0("accel-read") },
	/* §3.20: acceleration to RAM, int32 1 dps/s; echoes. */
	{ 0x43,
	  "write_accel_ram",
	  RMD_CMD_ECHO,
	  RMD_LAYOUT(RMD_S(ACCEL, 4, 4, 1.0)),
	  { 0 },
	  RMD_SAY1("accel", ACCEL),
	  RMD_RANGES(RMD_RANGE(ACCEL, 0, 10000, "V2 §3.20: 0..10000 dps/s")) },
	/* §3.21: multi-turn encoder position (raw minus zero offset). */
	{ 0x60, "read_encoder_multi", 0, { 0 }, V2_MULTI(ENCODER, 1.0) },
	/* §3.22: multi-turn encoder position without the offset. */
	{ 0x61, "read_encoder_multi_raw", 0, { 0 }, V2_MULTI(ENCODER_RAW, 1.0) },
	/* §3.23: multi-turn encoder zero offset. */
	{ 0x62, "read_encoder_multi_offset", 0, { 0 }, V2_MULTI(ENCODER_OFF, 1.0) },
	/*
	 * §3.24: write a multi-turn zero offset to ROM.  The reply "contains
	 * the following parameters" but lists none: taken as an echo.
	 */
	{ 0x63,
	  "write_encoder_multi_zero_rom",
	  RMD_CMD_ECHO | RMD_CMD_ROM,
	  V2_MULTI(ENCODER_OFF, 1.0),
	  { 0 } },
	/* §3.25: the current position becomes the multi-turn zero, in ROM. */
	{ 0x64, "write_current_multi_zero_rom", RMD_CMD_ROM, { 0 }, V2_MULTI(ENCODER_OFF, 1.0) },
	/*
	 * §3.45: run mode at data[7] (0 current, 1 speed, 2 position, 0xFF
	 * power-on initialisation).
	 */
	{ 0x70, "read_run_mode", 0, { 0 }, RMD_LAYOUT(RMD_U(MODE, 7, 1, 1.0)), RMD_SAY0("mode") },
	/* §3.46: motor power, uint16 0.1 W. */
	{ 0x71, "read_power", 0, { 0 }, RMD_LAYOUT(RMD_U(POWER, 6, 2, 0.1)), RMD_SAY0("power") },
	/* §3.47: auxiliary battery voltage, uint8 0.1 V at data[7]. */
	{ 0x72, "read_battery", 0, { 0 }, RMD_LAYOUT(RMD_U(BATTERY, 7, 1, 0.1)) },
	/*
	 * §3.48: TF feed-forward current int16 0.01 A and multi-turn encoder
	 * int32.  The reply has no command byte: iq int16 0.01 A at data[0..1],
	 * speed int16 1 dps, encoder int32 (see the top of this file).
	 */
	{ 0x73, "tf_current", RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_S(CURRENT, 2, 2, 0.01), RMD_S(ENCODER, 4, 4, 1.0)),
	  RMD_LAYOUT(RMD_S(CURRENT, 0, 2, 0.01), RMD_S(SPEED, 2, 2, 1.0),
		     RMD_S(ENCODER, 4, 4, 1.0)) },
	/* §3.49: system reset; unlike V3, the V2 reply echoes. */
	{ 0x76, "reset", RMD_CMD_ECHO, { 0 }, { 0 }, RMD_SAY0("reset") },
	/* §3.50: brake released; echoes.  MOVES: the load may move the shaft. */
	{ 0x77,
	  "brake_release",
	  RMD_CMD_ECHO | RMD_CMD_MOVES,
	  { 0 },
	  { 0 },
	  RMD_SAY0("brake-release") },
	/* §3.51: brake closed; echoes.  (§3.51 says "open": a copy-paste typo.) */
	{ 0x78, "brake_lock", RMD_CMD_ECHO, { 0 }, { 0 }, RMD_SAY0("brake-lock") },
	/*
	 * §3.52: CAN ID set/read on 0x140 + ID: read flag (1 read, 0 write) at
	 * data[2], ID 1..32 at data[4..7] (called uint16, sent as 4 bytes).  A
	 * write is echoed, a read answers in the same layout.  Flagged ROM:
	 * a written ID survives power off.
	 */
	{ 0x79, "can_id", RMD_CMD_ROM,
	  RMD_LAYOUT(RMD_U(READ_FLAG, 2, 1, 1.0), RMD_U(CAN_ID, 4, 4, 1.0)),
	  RMD_LAYOUT(RMD_U(READ_FLAG, 2, 1, 1.0), RMD_U(CAN_ID, 4, 4, 1.0)) },
	/* §3.34: output off, state and commands cleared; echoes. */
	{ 0x80, "motor_off", RMD_CMD_ECHO, { 0 }, { 0 }, RMD_SAY0("off") },
	/* §3.35: stop, state kept; echoes. */
	{ 0x81, "motor_stop", RMD_CMD_ECHO, { 0 }, { 0 }, RMD_SAY0("stop") },
	/* §3.36: resume the mode held before 0x81; echoes. */
	{ 0x88, "motor_run", RMD_CMD_ECHO | RMD_CMD_MOVES, { 0 }, { 0 }, RMD_SAY0("run") },
	/*
	 * §3.26: single-turn encoder position, raw position and zero offset,
	 * 0..65535 each (the text calls the first int16_t; its range is
	 * 0..65535, so all three are uint16).
	 */
	{ 0x90,
	  "read_encoder",
	  0,
	  { 0 },
	  RMD_LAYOUT(RMD_U(ENCODER, 2, 2, 1.0), RMD_U(ENCODER_RAW, 4, 2, 1.0),
		     RMD_U(ENCODER_OFF, 6, 2, 1.0)) },
	/* §3.27: write a single-turn zero offset (uint16) to ROM; echoes. */
	{ 0x91,
	  "write_encoder_zero_rom",
	  RMD_CMD_ECHO | RMD_CMD_ROM,
	  RMD_LAYOUT(RMD_U(ENCODER_OFF, 6, 2, 1.0)),
	  { 0 } },
	/* §3.28: the current position becomes the single-turn zero, in ROM. */
	{ 0x19,
	  "write_current_zero_rom",
	  RMD_CMD_ROM,
	  { 0 },
	  RMD_LAYOUT(RMD_U(ENCODER_OFF, 6, 2, 1.0)) },
	/* §3.29: multi-turn angle, 0.01 deg, 48 bits and a sign byte (see the top of this file). */
	{ 0x92, "read_multi_turn_angle", 0, { 0 }, V2_MULTI(ANGLE, 0.01), RMD_SAY0("read-angle") },
	/*
	 * §3.30: single-turn angle 0..35999, 0.01 deg, at data[6..7].  The
	 * text says int16_t, but 35999 does not fit: uint16.
	 */
	{ 0x94, "read_single_turn_angle", 0, { 0 }, RMD_LAYOUT(RMD_U(ANGLE, 6, 2, 0.01)) },
	/*
	 * §3.31: temperature, voltage 0.1 V at data[4..5], error flags at
	 * data[6..7] (tables 1 and 2).  V2 has no brake byte.  (The formula
	 * column says DATA[3]/DATA[4] for the voltage; the field column and
	 * V3 say data[4..5].)
	 */
	{ 0x9A,
	  "read_status_1",
	  0,
	  { 0 },
	  RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_U(VOLTAGE, 4, 2, 0.1), RMD_U(ERROR, 6, 2, 1.0)),
	  RMD_SAY0("status1") },
	/* §3.32: temperature, iq (33 A / 2048), speed, encoder. */
	{ 0x9C, "read_status_2", 0, { 0 }, V2_STATUS2, RMD_SAY0("status2") },
	/* §3.33: temperature and phase currents, int16 1 A / 64 LSB. */
	{ 0x9D,
	  "read_status_3",
	  0,
	  { 0 },
	  RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_S(PHASE_A, 2, 2, V2_PHASE_A),
		     RMD_S(PHASE_B, 4, 2, V2_PHASE_A), RMD_S(PHASE_C, 6, 2, V2_PHASE_A)),
	  RMD_SAY0("status3") },
	/* §3.37: iqControl int16, -2000..2000 is -32..32 A. */
	{ 0xA1, "torque", RMD_CMD_MOVES, RMD_LAYOUT(RMD_S(CURRENT, 4, 2, V2_IQ_SET_A)), V2_STATUS2,
	  RMD_SAY1("torque", CURRENT),
	  RMD_RANGES(RMD_RANGE(CURRENT, -32, 32, "V2 §3.37: iqControl -2000..2000 is -32..32 A")) },
	/* §3.38: speedControl int32 0.01 dps. */
	{ 0xA2, "speed", RMD_CMD_MOVES, RMD_LAYOUT(RMD_S(SPEED, 4, 4, 0.01)), V2_STATUS2,
	  RMD_SAY1("speed", SPEED) },
	/* §3.39: multi-turn angleControl int32 0.01 deg. */
	{ 0xA3, "position_abs", RMD_CMD_MOVES, RMD_LAYOUT(RMD_S(ANGLE, 4, 4, 0.01)), V2_STATUS2,
	  RMD_SAY1("position position-track", ANGLE) },
	/* §3.40: maxSpeed uint16 1 dps, multi-turn angleControl int32 0.01 deg. */
	{ 0xA4, "position_abs_limited", RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_U(MAX_SPEED, 2, 2, 1.0), RMD_S(ANGLE, 4, 4, 0.01)), V2_STATUS2,
	  RMD_SAY2("position", ANGLE, MAX_SPEED) },
	/* §3.41: spinDirection (0 cw, 1 ccw), single-turn angle uint16 0.01 deg. */
	{ 0xA5, "position_single", RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_U(SPIN_DIR, 1, 1, 1.0), RMD_U(ANGLE, 4, 2, 0.01)), V2_STATUS2 },
	/* §3.42: spinDirection, maxSpeed uint16 1 dps, single-turn angle uint16. */
	{ 0xA6, "position_single_limited", RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_U(SPIN_DIR, 1, 1, 1.0), RMD_U(MAX_SPEED, 2, 2, 1.0),
		     RMD_U(ANGLE, 4, 2, 0.01)),
	  V2_STATUS2 },
	/* §3.43: incremental angle int32 0.01 deg. */
	{ 0xA7, "position_inc", RMD_CMD_MOVES, RMD_LAYOUT(RMD_S(ANGLE, 4, 4, 0.01)), V2_STATUS2,
	  RMD_SAY1("increment", ANGLE) },
	/* §3.44: maxSpeed uint16 1 dps, incremental angle int32 0.01 deg. */
	{ 0xA8, "position_inc_limited", RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_U(MAX_SPEED, 2, 2, 1.0), RMD_S(ANGLE, 4, 4, 0.01)), V2_STATUS2,
	  RMD_SAY2("increment", ANGLE, MAX_SPEED) },
	/*
	 * §4.1: four torque setpoints for motors 1..4, no command byte.  Each
	 * motor answers on its own 0x140 + ID; §4.2 gives the identifier only,
	 * no data layout, so the row has no reply layout.
	 */
	{ RMD_V2_CMD_MULTI_TORQUE,
	  "multi_torque",
	  RMD_CMD_NO_CMD_BYTE | RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_S(CURRENT_1, 0, 2, V2_IQ_SET_A), RMD_S(CURRENT_2, 2, 2, V2_IQ_SET_A),
		     RMD_S(CURRENT_3, 4, 2, V2_IQ_SET_A), RMD_S(CURRENT_4, 6, 2, V2_IQ_SET_A)),
	  { 0 },
	  RMD_SAY4("multi-torque", CURRENT_1, CURRENT_2, CURRENT_3, CURRENT_4),
	  RMD_RANGES(RMD_RANGE(CURRENT_1, -32, 32, V2_MULTI_CITE),
		     RMD_RANGE(CURRENT_2, -32, 32, V2_MULTI_CITE),
		     RMD_RANGE(CURRENT_3, -32, 32, V2_MULTI_CITE),
		     RMD_RANGE(CURRENT_4, -32, 32, V2_MULTI_CITE)) },
};
RMD_ROWS_END
const size_t rmd_v2_ncmds = sizeof(rmd_v2_cmds) / sizeof(rmd_v2_cmds[0]);
