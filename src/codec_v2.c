// SPDX-License-Identifier: MIT
/*
 * Protocol V2.0 command table (rmd-can-protocol-v2.0-en.txt).
 * Section numbers (§) are the manual's.  Requests and replies on 0x140 + ID.
 */
#include "codec_tables.h"

/* V2 §3.37: iq range -2048..2048 is -33..33 A. */
#define V2_IQ_A (33.0 / 2048.0)
/* V2 §3.37, §4.1: iqControl -2000..2000 is -32..32 A. */
#define V2_IQ_SET_A (32.0 / 2000.0)

const struct rmd_cmd_spec rmd_v2_cmds[] = {
	/* §4.1: four torque setpoints for motors 1..4, no command byte. */
	{ RMD_V2_CMD_MULTI_TORQUE,
	  "multi_torque",
	  RMD_CMD_NO_CMD_BYTE | RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_S(CURRENT_1, 0, 2, V2_IQ_SET_A), RMD_S(CURRENT_2, 2, 2, V2_IQ_SET_A),
		     RMD_S(CURRENT_3, 4, 2, V2_IQ_SET_A), RMD_S(CURRENT_4, 6, 2, V2_IQ_SET_A)),
	  { 0 } },
};
const size_t rmd_v2_ncmds = sizeof(rmd_v2_cmds) / sizeof(rmd_v2_cmds[0]);
