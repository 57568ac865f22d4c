// SPDX-License-Identifier: MIT
/*
 * Protocol V3.x command table (rmd-can-rs485-protocol-v3.6-zh.txt).
 * Section numbers (§) are the manual's.  Requests on 0x140 + ID (or 0x280
 * for every motor, §3), replies on 0x240 + ID; 0x79 on 0x300 both ways (§4).
 * The MIT motion mode (§5) is not a command byte: see rmd/mit.h.
 *
 * The rows V4.2 prints alike are in codec_v3x_rows.h, written once for
 * both tables; the rows here are V3's own.
 *
 * Every row is checked against the manual's worked examples in
 * tests/unit/test_codec.c.  Where the text and an example disagree the example
 * bytes decided, and the row says so.
 */
#include "codec_tables.h"
#include "codec_v3x_rows.h"

/* §2.1.3, §2.2.2, §2.3.2: six uint8 gains, 1/256 of a model-dependent maximum. */
#define V3_PID                                                                                     \
	RMD_LAYOUT(RMD_U(CURR_KP, 2, 1, 1.0), RMD_U(CURR_KI, 3, 1, 1.0), RMD_U(SPD_KP, 4, 1, 1.0), \
		   RMD_U(SPD_KI, 5, 1, 1.0), RMD_U(POS_KP, 6, 1, 1.0), RMD_U(POS_KI, 7, 1, 1.0))

RMD_ROWS_BEGIN
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
	{ 0x42, "read_accel", 0, { 0 }, RMD_LAYOUT(RMD_S(ACCEL, 4, 4, 1.0)), RMD_SAY0("accel-read") },
	V3X_ROW_43("V3"),
	V3X_ROWS_60_70,
	/* §2.24: motor power, uint16 0.1 W. */
	{ 0x71, "read_power", 0, { 0 }, RMD_LAYOUT(RMD_U(POWER, 6, 2, 0.1)), RMD_SAY0("power") },
	V3X_ROWS_76_81,
	V3X_ROW_92,
	/* §2.12: temperature, brake, voltage 0.1 V, error flags (table 1). */
	{ 0x9A,
	  "read_status_1",
	  0,
	  { 0 },
	  RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_U(BRAKE, 3, 1, 1.0), RMD_U(VOLTAGE, 4, 2, 0.1),
		     RMD_U(ERROR, 6, 2, 1.0)),
	  RMD_SAY0("status1") },
	V3X_ROW_9C,
	V3X_ROW_9D,
	V3X_ROW_A1,
	/* §2.18: speedControl int32 0.01 dps. */
	{ 0xA2, "speed", RMD_CMD_MOVES, RMD_LAYOUT(RMD_S(SPEED, 4, 4, 0.01)), V3X_STATUS2,
	  RMD_SAY1("speed", SPEED) },
	/* §2.19: position tracking, angleControl int32 0.01 deg, no speed limit. */
	{ 0xA3, "position_track", RMD_CMD_MOVES, RMD_LAYOUT(RMD_S(ANGLE, 4, 4, 0.01)), V3X_STATUS2,
	  RMD_SAY1("position-track", ANGLE) },
	V3X_ROW_A4,
	/*
	 * §2.21: position tracking with a speed limit.  Here maxSpeed is
	 * uint16 0.01 dps, unlike 0xA4/0xA8: §2.21.1 says 0.01dps/LSB and the
	 * §2.21.4 example agrees (0x1388 = 5000 * 0.01 = 50 dps).
	 */
	{ 0xA5, "position_track_limited", RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_U(MAX_SPEED, 2, 2, 0.01), RMD_S(ANGLE, 4, 4, 0.01)), V3X_STATUS2,
	  RMD_SAY2("position-track-limited", ANGLE, MAX_SPEED) },
	V3X_ROW_A8,
	V3X_ROWS_B1_B5,
	/*
	 * §2.33: function index (§2.33.4: 1 clear multi-turn and save, 2 CAN ID
	 * filter, saved in flash, 3 0x9A error reports, 4 save multi-turn at
	 * power off) and an int32 value; the reply echoes.
	 */
	V3X_ROW_20(4, "V3 §2.33.4: index 1..4"),
};
RMD_ROWS_END
const size_t rmd_v3_ncmds = sizeof(rmd_v3_cmds) / sizeof(rmd_v3_cmds[0]);
