// SPDX-License-Identifier: MIT
/*
 * Protocol V3.x command table (rmd-can-rs485-protocol-v3.6-zh.txt).
 * Section numbers (§) are the manual's.  Requests on 0x140 + ID (or 0x280
 * for every motor, §3), replies on 0x240 + ID; 0x79 on 0x300 both ways (§4).
 * The MIT motion mode (§5) is not a command byte: see rmd/mit.h.
 *
 * Every row is checked against the manual's worked examples in
 * tests/unit/test_codec.c.  Where the text and an example disagree the example
 * bytes decided, and the row says so.
 */
#include "codec_tables.h"

/*
 * §2.17.3 (and §2.13.3, §2.18.3 .. §2.22.3): temperature 1 degC, iq 0.01 A,
 * output shaft speed 1 dps, output shaft angle 1 deg (int16, +-32767 deg).
 */
#define V3_STATUS2                                                                              \
	RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_S(CURRENT, 2, 2, 0.01), RMD_S(SPEED, 4, 2, 1.0), \
		   RMD_S(ANGLE, 6, 2, 1.0))

/* §2.1.3, §2.2.2, §2.3.2: six uint8 gains, 1/256 of a model-dependent maximum. */
#define V3_PID                                                                                     \
	RMD_LAYOUT(RMD_U(CURR_KP, 2, 1, 1.0), RMD_U(CURR_KI, 3, 1, 1.0), RMD_U(SPD_KP, 4, 1, 1.0), \
		   RMD_U(SPD_KI, 5, 1, 1.0), RMD_U(POS_KP, 6, 1, 1.0), RMD_U(POS_KI, 7, 1, 1.0))

const struct rmd_cmd_spec rmd_v3_cmds[] = {
	/* §2.1: read the six PI gains. */
	{ 0x30, "read_pid", 0, { 0 }, V3_PID },
	/* §2.2: gains to RAM, lost at power off; the reply echoes. */
	{ 0x31, "write_pid_ram", RMD_CMD_ECHO, V3_PID, { 0 } },
	/* §2.3: gains to ROM, kept at power off; the reply echoes. */
	{ 0x32, "write_pid_rom", RMD_CMD_ECHO | RMD_CMD_ROM, V3_PID, { 0 } },
	/*
	 * §2.4: the request carries no index (data[1] is NULL) and the reply
	 * none either; accel is int32, 1 dps/s.
	 */
	{ 0x42, "read_accel", 0, { 0 }, RMD_LAYOUT(RMD_S(ACCEL, 4, 4, 1.0)) },
	/*
	 * §2.5: index (§2.5.4: 0 position accel, 1 position decel, 2 speed
	 * accel, 3 speed decel) and uint32 1 dps/s, to RAM and ROM; echoes.
	 */
	{ 0x43,
	  "write_accel",
	  RMD_CMD_ECHO | RMD_CMD_ROM,
	  RMD_LAYOUT(RMD_U(INDEX, 1, 1, 1.0), RMD_U(ACCEL, 4, 4, 1.0)),
	  { 0 } },
	/* §2.6: multi-turn encoder position, int32 counts (raw minus zero offset). */
	{ 0x60, "read_encoder_multi", 0, { 0 }, RMD_LAYOUT(RMD_S(ENCODER, 4, 4, 1.0)) },
	/* §2.7: multi-turn encoder position without the zero offset, int32. */
	{ 0x61, "read_encoder_multi_raw", 0, { 0 }, RMD_LAYOUT(RMD_S(ENCODER_RAW, 4, 4, 1.0)) },
	/* §2.8: multi-turn encoder zero offset, int32. */
	{ 0x62, "read_encoder_multi_offset", 0, { 0 }, RMD_LAYOUT(RMD_S(ENCODER_OFF, 4, 4, 1.0)) },
	/*
	 * §2.9: write a zero offset (int32) to ROM; effective after a restart;
	 * the reply echoes.  (§2.9.2 prints ">>8" for bytes 6 and 7: a typo,
	 * the example and every sibling command use >>16 and >>24.)
	 */
	{ 0x63,
	  "write_encoder_multi_zero_rom",
	  RMD_CMD_ECHO | RMD_CMD_ROM,
	  RMD_LAYOUT(RMD_S(ENCODER_OFF, 4, 4, 1.0)),
	  { 0 } },
	/* §2.10: the current position becomes the zero, in ROM; replies the offset. */
	{ 0x64,
	  "write_current_multi_zero_rom",
	  RMD_CMD_ROM,
	  { 0 },
	  RMD_LAYOUT(RMD_S(ENCODER_OFF, 4, 4, 1.0)) },
	/* §2.23: run mode, uint8 at data[7] (1 current, 2 speed, 3 position). */
	{ 0x70, "read_run_mode", 0, { 0 }, RMD_LAYOUT(RMD_U(MODE, 7, 1, 1.0)) },
	/* §2.24: motor power, uint16 0.1 W. */
	{ 0x71, "read_power", 0, { 0 }, RMD_LAYOUT(RMD_U(POWER, 6, 2, 0.1)) },
	/* §2.25: the motor resets and does not answer. */
	{ 0x76, "reset", RMD_CMD_NO_REPLY, { 0 }, { 0 } },
	/*
	 * §2.26: brake released, the reply echoes.  Flagged MOVES: a released
	 * brake lets gravity or the load move the shaft.
	 */
	{ 0x77, "brake_release", RMD_CMD_ECHO | RMD_CMD_MOVES, { 0 }, { 0 } },
	/* §2.27: brake locked; the reply echoes. */
	{ 0x78, "brake_lock", RMD_CMD_ECHO, { 0 }, { 0 } },
	/*
	 * §4: CAN ID set/read on 0x300 (codec.c routes it).  Request: read
	 * flag (1 read, 0 write) at data[2], ID 1..32 at data[7].  The reply
	 * layout is that of a read: the motor's reply identifier 0x240 + ID as
	 * uint16 at data[6..7] (§4.4 example 2: 0x0242).  A write's reply is
	 * the request itself (§4.3), so it reads right only with the request
	 * layout: decode 0x300 with RMD_DIR_UNKNOWN, which picks the request
	 * layout for an echo (data[6] = 0) and the reply layout for a read
	 * (data[6] = 0x41..0x60).  Flagged ROM: a written ID survives power
	 * off.  (§4.4 example 1 says "Data[7] = 1" for the byte 0x02: a typo.)
	 */
	{ 0x79, "can_id", RMD_CMD_ROM,
	  RMD_LAYOUT(RMD_U(READ_FLAG, 2, 1, 1.0), RMD_U(CAN_ID, 7, 1, 1.0)),
	  RMD_LAYOUT(RMD_U(READ_FLAG, 2, 1, 1.0), RMD_U(CAN_ID, 6, 2, 1.0)) },
	/* §2.15: output off, state cleared; the reply echoes. */
	{ 0x80, "motor_off", RMD_CMD_ECHO, { 0 }, { 0 } },
	/* §2.16: stop and hold position; the reply echoes. */
	{ 0x81, "motor_stop", RMD_CMD_ECHO, { 0 }, { 0 } },
	/* §2.11: output shaft multi-turn angle, int32 0.01 deg. */
	{ 0x92, "read_multi_turn_angle", 0, { 0 }, RMD_LAYOUT(RMD_S(ANGLE, 4, 4, 0.01)) },
	/* §2.12: temperature, brake, voltage 0.1 V, error flags (table 1). */
	{ 0x9A,
	  "read_status_1",
	  0,
	  { 0 },
	  RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_U(BRAKE, 3, 1, 1.0), RMD_U(VOLTAGE, 4, 2, 0.1),
		     RMD_U(ERROR, 6, 2, 1.0)) },
	/* §2.13: temperature, iq, speed, angle. */
	{ 0x9C, "read_status_2", 0, { 0 }, V3_STATUS2 },
	/* §2.14: temperature and phase currents, int16 0.01 A. */
	{ 0x9D,
	  "read_status_3",
	  0,
	  { 0 },
	  RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_S(PHASE_A, 2, 2, 0.01), RMD_S(PHASE_B, 4, 2, 0.01),
		     RMD_S(PHASE_C, 6, 2, 0.01)) },
	/* §2.17: iqControl int16 0.01 A. */
	{ 0xA1, "torque", RMD_CMD_MOVES, RMD_LAYOUT(RMD_S(CURRENT, 4, 2, 0.01)), V3_STATUS2 },
	/* §2.18: speedControl int32 0.01 dps. */
	{ 0xA2, "speed", RMD_CMD_MOVES, RMD_LAYOUT(RMD_S(SPEED, 4, 4, 0.01)), V3_STATUS2 },
	/* §2.19: position tracking, angleControl int32 0.01 deg, no speed limit. */
	{ 0xA3, "position_track", RMD_CMD_MOVES, RMD_LAYOUT(RMD_S(ANGLE, 4, 4, 0.01)), V3_STATUS2 },
	/* §2.20: absolute position, maxSpeed uint16 1 dps, angleControl int32 0.01 deg. */
	{ 0xA4, "position_abs_limited", RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_U(MAX_SPEED, 2, 2, 1.0), RMD_S(ANGLE, 4, 4, 0.01)), V3_STATUS2 },
	/*
	 * §2.21: position tracking with a speed limit.  Here maxSpeed is
	 * uint16 0.01 dps, unlike 0xA4/0xA8: §2.21.1 says 0.01dps/LSB and the
	 * §2.21.4 example agrees (0x1388 = 5000 * 0.01 = 50 dps).
	 */
	{ 0xA5, "position_track_limited", RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_U(MAX_SPEED, 2, 2, 0.01), RMD_S(ANGLE, 4, 4, 0.01)), V3_STATUS2 },
	/* §2.22: incremental position, maxSpeed uint16 1 dps, int32 0.01 deg. */
	{ 0xA8, "position_inc_limited", RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_U(MAX_SPEED, 2, 2, 1.0), RMD_S(ANGLE, 4, 4, 0.01)), V3_STATUS2 },
	/* §2.28: time since power-on or reset, uint32 ms. */
	{ 0xB1, "read_runtime", 0, { 0 }, RMD_LAYOUT(RMD_U(RUNTIME, 4, 4, 1.0)) },
	/* §2.29: software version date, uint32 yyyymmdd. */
	{ 0xB2, "read_version", 0, { 0 }, RMD_LAYOUT(RMD_U(VERSION, 4, 4, 1.0)) },
	/*
	 * §2.30: comm-loss protection time, uint32 ms, 0 disables; stored in
	 * ROM (§2.30.4 example 2); the reply echoes (§2.30.3).  The reply
	 * printed in example 2 is example 1's all-zero frame: a manual typo.
	 */
	{ 0xB3,
	  "comm_timeout",
	  RMD_CMD_ECHO | RMD_CMD_ROM,
	  RMD_LAYOUT(RMD_U(TIMEOUT, 4, 4, 1.0)),
	  { 0 } },
	/*
	 * §2.31: baud code at data[7] (0: CAN 500k / RS485 115200, 1: CAN 1M /
	 * RS485 500k, 2: RS485 1M), stored in ROM; the reply is noise.
	 */
	{ 0xB4,
	  "baud_rate",
	  RMD_CMD_RANDOM_REPLY | RMD_CMD_ROM,
	  RMD_LAYOUT(RMD_U(BAUD, 7, 1, 1.0)),
	  { 0 } },
	/* §2.32: seven ASCII bytes at data[1..7], first in the LSB. */
	{ 0xB5, "read_model", 0, { 0 }, RMD_LAYOUT(RMD_U(MODEL, 1, 7, 1.0)) },
	/*
	 * §2.33: function index (§2.33.4: 1 clear multi-turn and save, 2 CAN ID
	 * filter, saved in flash, 3 0x9A error reports, 4 save multi-turn at
	 * power off) and an int32 value; the reply echoes.  Flagged ROM
	 * because indexes 1 and 2 write flash.
	 */
	{ 0x20,
	  "function_control",
	  RMD_CMD_ECHO | RMD_CMD_ROM,
	  RMD_LAYOUT(RMD_U(INDEX, 1, 1, 1.0), RMD_S(VALUE, 4, 4, 1.0)),
	  { 0 } },
};
const size_t rmd_v3_ncmds = sizeof(rmd_v3_cmds) / sizeof(rmd_v3_cmds[0]);
