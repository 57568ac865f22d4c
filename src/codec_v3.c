// SPDX-License-Identifier: MIT
/*
 * Protocol V3.x command table (rmd-can-rs485-protocol-v3.6-zh.txt).
 * Section numbers (§) are the manual's.  Replies on 0x240 + ID.
 */
#include "codec_tables.h"

/* V3 §2.17.3 and the replies of 0xA2..0xA8: temperature, iq, speed, angle. */
#define V3_STATUS2                                                                              \
	RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_S(CURRENT, 2, 2, 0.01), RMD_S(SPEED, 4, 2, 1.0), \
		   RMD_S(ANGLE, 6, 2, 1.0))

const struct rmd_cmd_spec rmd_v3_cmds[] = {
	/* §2.12: temperature, brake, voltage 0.1 V, error flags (table 1). */
	{ 0x9A,
	  "read_status_1",
	  0,
	  { 0 },
	  RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_U(BRAKE, 3, 1, 1.0), RMD_U(VOLTAGE, 4, 2, 0.1),
		     RMD_U(ERROR, 6, 2, 1.0)) },
	/* §2.17: iqControl 0.01 A. */
	{ 0xA1, "torque", RMD_CMD_MOVES, RMD_LAYOUT(RMD_S(CURRENT, 4, 2, 0.01)), V3_STATUS2 },
	/* §2.15: output off, state cleared; the reply echoes. */
	{ 0x80, "motor_off", RMD_CMD_ECHO, { 0 }, { 0 } },
};
const size_t rmd_v3_ncmds = sizeof(rmd_v3_cmds) / sizeof(rmd_v3_cmds[0]);
