// SPDX-License-Identifier: MIT
/*
 * The command table of the test's own dialect "V5" (dialect_v5.h): rows
 * laid out unlike V2, V3 and V4 (other offsets, scales and ranges), and one
 * command no other dialect has, so that what rmdctl encodes and decodes
 * can only have come from here.  "V5 §n" are this file's own sections.
 */
#include "proto/codec_tables.h"

/* V5 §1: iq int16 at data[2..3], 1 mA; ±20 A. */
#define V5_IQ RMD_S(CURRENT, 2, 2, 0.001)

RMD_ROWS_BEGIN
const struct rmd_cmd_spec rmd_v5_cmds[] = {
	/* V5 §1: torque; the reply the temperature and iq */
	{ 0xA1, "torque", RMD_CMD_MOVES, RMD_LAYOUT(V5_IQ),
	  RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), V5_IQ), RMD_SAY1("torque", CURRENT),
	  RMD_RANGES(RMD_RANGE(CURRENT, -20, 20, "V5 §1: -20..20 A")) },
	/* V5 §2: stop, echoed */
	{ 0x81, "motor_stop", RMD_CMD_ECHO, RMD_LAYOUT_NONE, RMD_LAYOUT_NONE, RMD_SAY0("stop") },
	/* V5 §3: temperature, voltage 0.01 V at data[2..3], error flags at data[4..5] */
	{ 0x9A, "read_status_1", 0, RMD_LAYOUT_NONE,
	  RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_U(VOLTAGE, 2, 2, 0.01), RMD_U(ERROR, 4, 2, 1.0)),
	  RMD_SAY0("status1") },
	/* V5 §4: the board's temperature, a command of V5 alone */
	{ 0xC1, "read_board_temperature", 0, RMD_LAYOUT_NONE, RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0)),
	  RMD_SAY0("board-temp") },
	/* V5 §5: the current limit, uint16 0.1 A at data[6..7], 0..50 A */
	{ 0xC2, "current_limit", RMD_CMD_ECHO | RMD_CMD_ROM, RMD_LAYOUT(RMD_U(CURRENT, 6, 2, 0.1)),
	  RMD_LAYOUT_NONE, RMD_SAY1("current-limit", CURRENT),
	  RMD_RANGES(RMD_RANGE(CURRENT, 0, 50, "V5 §5: 0..50 A")) },
};
RMD_ROWS_END
const size_t rmd_v5_ncmds = sizeof(rmd_v5_cmds) / sizeof(rmd_v5_cmds[0]);

/* V5 §3: the error flags of 0x9A. */
const struct rmd_flag_name rmd_v5_error_bits[RMD_V5_N_ERROR_BITS] = {
	{ 0x0001, "board_over_temperature" },
	{ 0x0100, "supply_low" },
};
