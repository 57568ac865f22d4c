/* SPDX-License-Identifier: MIT */
/*
 * Internal: the command rows that V3.6 (rmd-can-rs485-protocol-v3.6-zh.txt,
 * "V3 §") and V4.2 (rmd-servo-protocol-v4.2-en.txt, "V4.2 §") print byte
 * for byte alike, written once for both tables (codec_v3.c, codec_v4.c).
 * Each row names its section in both manuals; a row that differs in either
 * is written in its own table, not here.  A row's words for tools
 * (RMD_SAY*) and ranges (RMD_RANGES) are part of it.
 */
#ifndef RMD_CODEC_V3X_ROWS_H
#define RMD_CODEC_V3X_ROWS_H

#include "codec_tables.h"

/*
 * V3 §2.17.3, V4.2 §2.19.3 (and the other control replies): temperature
 * 1 degC, iq 0.01 A, output shaft speed 1 dps, output shaft angle 1 deg
 * (int16, +-32767 deg).
 */
#define V3X_STATUS2                                                                             \
	RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_S(CURRENT, 2, 2, 0.01), RMD_S(SPEED, 4, 2, 1.0), \
		   RMD_S(ANGLE, 6, 2, 1.0))

/*
 * V3 §2.5, V4.2 §2.5: index (0 position accel, 1 position decel, 2 speed
 * accel, 3 speed decel) and uint32 1 dps/s, to RAM and ROM; echoes.  The
 * manuals' ranges are cited from `man` ("V3", "V4.2"): the same sections.
 */
#define V3X_ROW_43(man)                                                                           \
	{                                                                                         \
		0x43, "write_accel", RMD_CMD_ECHO | RMD_CMD_ROM,                                  \
			RMD_LAYOUT(RMD_U(INDEX, 1, 1, 1.0), RMD_U(ACCEL, 4, 4, 1.0)),             \
			RMD_LAYOUT_NONE, RMD_SAY2("accel", INDEX, ACCEL),                         \
			RMD_RANGES(RMD_RANGE(ACCEL, 100, 60000, man " §2.5.1: 100..60000 dps/s"), \
				   RMD_RANGE(INDEX, 0, 3, man " §2.5.4: index 0..3"))             \
	}
/* V3 §2.6, V4.2 §2.6: multi-turn encoder position, int32 counts (raw minus zero offset). */
#define V3X_ROW_60                                              \
	{                                                       \
		0x60, "read_encoder_multi", 0, RMD_LAYOUT_NONE, \
			RMD_LAYOUT(RMD_S(ENCODER, 4, 4, 1.0))   \
	}
/* V3 §2.7, V4.2 §2.7: multi-turn encoder position without the zero offset, int32. */
#define V3X_ROW_61                                                  \
	{                                                           \
		0x61, "read_encoder_multi_raw", 0, RMD_LAYOUT_NONE, \
			RMD_LAYOUT(RMD_S(ENCODER_RAW, 4, 4, 1.0))   \
	}
/* V3 §2.8, V4.2 §2.8: multi-turn encoder zero offset, int32. */
#define V3X_ROW_62                                                     \
	{                                                              \
		0x62, "read_encoder_multi_offset", 0, RMD_LAYOUT_NONE, \
			RMD_LAYOUT(RMD_S(ENCODER_OFF, 4, 4, 1.0))      \
	}
/*
 * V3 §2.9, V4.2 §2.9: write a zero offset (int32) to ROM; effective after
 * a restart; the reply echoes.  (V3 §2.9.2 prints ">>8" for bytes 6 and 7:
 * a typo, the example and every sibling command use >>16 and >>24.)
 */
#define V3X_ROW_63                                                                 \
	{                                                                          \
		0x63, "write_encoder_multi_zero_rom", RMD_CMD_ECHO | RMD_CMD_ROM,  \
			RMD_LAYOUT(RMD_S(ENCODER_OFF, 4, 4, 1.0)), RMD_LAYOUT_NONE \
	}
/* V3 §2.10, V4.2 §2.10: the current position becomes the zero, in ROM; replies the offset. */
#define V3X_ROW_64                                                                  \
	{                                                                           \
		0x64, "write_current_multi_zero_rom", RMD_CMD_ROM, RMD_LAYOUT_NONE, \
			RMD_LAYOUT(RMD_S(ENCODER_OFF, 4, 4, 1.0))                   \
	}
/* V3 §2.23, V4.2 §2.24: run mode, uint8 at data[7] (1 current, 2 speed, 3 position). */
#define V3X_ROW_70                                                                             \
	{                                                                                      \
		0x70, "read_run_mode", 0, RMD_LAYOUT_NONE, RMD_LAYOUT(RMD_U(MODE, 7, 1, 1.0)), \
			RMD_SAY0("mode")                                                       \
	}
/* V3 §2.25, V4.2 §2.25: the motor resets and does not answer. */
#define V3X_ROW_76                                                                 \
	{                                                                          \
		0x76, "reset", RMD_CMD_NO_REPLY, RMD_LAYOUT_NONE, RMD_LAYOUT_NONE, \
			RMD_SAY0("reset")                                          \
	}
/*
 * V3 §2.26, V4.2 §2.26: brake released, the reply echoes.  Flagged MOVES:
 * a released brake lets gravity or the load move the shaft.
 */
#define V3X_ROW_77                                                                    \
	{                                                                             \
		0x77, "brake_release", RMD_CMD_ECHO | RMD_CMD_MOVES, RMD_LAYOUT_NONE, \
			RMD_LAYOUT_NONE, RMD_SAY0("brake-release")                    \
	}
/* V3 §2.27, V4.2 §2.27: brake locked; the reply echoes. */
#define V3X_ROW_78                                                                  \
	{                                                                           \
		0x78, "brake_lock", RMD_CMD_ECHO, RMD_LAYOUT_NONE, RMD_LAYOUT_NONE, \
			RMD_SAY0("brake-lock")                                      \
	}
/*
 * V3 §4, V4.2 §4: CAN ID set/read on 0x300 (codec.c routes it).  Request:
 * read flag (1 read, 0 write) at data[2], ID 1..32 at data[7].  The reply
 * layout is that of a read: the motor's reply identifier 0x240 + ID as
 * uint16 at data[6..7] (§4.4 example 2: 0x0242).  A write's reply is the
 * request itself (§4.3), so it reads right only with the request layout:
 * decode 0x300 with RMD_DIR_UNKNOWN, which picks the request layout for an
 * echo (data[6] = 0) and the reply layout for a read (data[6] = 0x41..0x60).
 * Flagged ROM: a written ID survives power off.  (§4.4 example 1 says
 * "Data[7] = 1" for the byte 0x02, in both manuals: a typo.)
 */
#define V3X_ROW_79                                                                         \
	{                                                                                  \
		0x79, "can_id", RMD_CMD_ROM,                                               \
			RMD_LAYOUT(RMD_U(READ_FLAG, 2, 1, 1.0), RMD_U(CAN_ID, 7, 1, 1.0)), \
			RMD_LAYOUT(RMD_U(READ_FLAG, 2, 1, 1.0), RMD_U(CAN_ID, 6, 2, 1.0))  \
	}
/* V3 §2.15, V4.2 §2.17: output off, state cleared; the reply echoes. */
#define V3X_ROW_80                                                                                 \
	{                                                                                          \
		0x80, "motor_off", RMD_CMD_ECHO, RMD_LAYOUT_NONE, RMD_LAYOUT_NONE, RMD_SAY0("off") \
	}
/* V3 §2.16, V4.2 §2.18: stop and hold position; the reply echoes. */
#define V3X_ROW_81                                                                  \
	{                                                                           \
		0x81, "motor_stop", RMD_CMD_ECHO, RMD_LAYOUT_NONE, RMD_LAYOUT_NONE, \
			RMD_SAY0("stop")                                            \
	}
/* V3 §2.11, V4.2 §2.12: output shaft multi-turn angle, int32 0.01 deg. */
#define V3X_ROW_92                                                                   \
	{                                                                            \
		0x92, "read_multi_turn_angle", 0, RMD_LAYOUT_NONE,                   \
			RMD_LAYOUT(RMD_S(ANGLE, 4, 4, 0.01)), RMD_SAY0("read-angle") \
	}
/* V3 §2.13, V4.2 §2.15: temperature, iq, speed, angle. */
#define V3X_ROW_9C                                                                          \
	{                                                                                   \
		0x9C, "read_status_2", 0, RMD_LAYOUT_NONE, V3X_STATUS2, RMD_SAY0("status2") \
	}
/* V3 §2.14, V4.2 §2.16: temperature and phase currents, int16 0.01 A. */
#define V3X_ROW_9D                                                                          \
	{                                                                                   \
		0x9D, "read_status_3", 0, RMD_LAYOUT_NONE,                                  \
			RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_S(PHASE_A, 2, 2, 0.01),      \
				   RMD_S(PHASE_B, 4, 2, 0.01), RMD_S(PHASE_C, 6, 2, 0.01)), \
			RMD_SAY0("status3")                                                 \
	}
/* V3 §2.17, V4.2 §2.19: iqControl int16 0.01 A. */
#define V3X_ROW_A1                                                                     \
	{                                                                              \
		0xA1, "torque", RMD_CMD_MOVES, RMD_LAYOUT(RMD_S(CURRENT, 4, 2, 0.01)), \
			V3X_STATUS2, RMD_SAY1("torque", CURRENT)                       \
	}
/*
 * V3 §2.20, V4.2 §2.21: absolute position, maxSpeed uint16 1 dps,
 * angleControl int32 0.01 deg.  (V4.2 §9, V3.7: 0xA5 merged into it.)
 */
#define V3X_ROW_A4                                                                         \
	{                                                                                  \
		0xA4, "position_abs_limited", RMD_CMD_MOVES,                               \
			RMD_LAYOUT(RMD_U(MAX_SPEED, 2, 2, 1.0), RMD_S(ANGLE, 4, 4, 0.01)), \
			V3X_STATUS2, RMD_SAY2("position", ANGLE, MAX_SPEED)                \
	}
/* V3 §2.22, V4.2 §2.23: incremental position, maxSpeed uint16 1 dps, int32 0.01 deg. */
#define V3X_ROW_A8                                                                         \
	{                                                                                  \
		0xA8, "position_inc_limited", RMD_CMD_MOVES,                               \
			RMD_LAYOUT(RMD_U(MAX_SPEED, 2, 2, 1.0), RMD_S(ANGLE, 4, 4, 0.01)), \
			V3X_STATUS2, RMD_SAY2("increment", ANGLE, MAX_SPEED)               \
	}
/* V3 §2.28, V4.2 §2.28: time since power-on or reset, uint32 ms. */
#define V3X_ROW_B1                                                                               \
	{                                                                                        \
		0xB1, "read_runtime", 0, RMD_LAYOUT_NONE, RMD_LAYOUT(RMD_U(RUNTIME, 4, 4, 1.0)), \
			RMD_SAY0("runtime")                                                      \
	}
/*
 * V3 §2.29, V4.2 §2.29: software version date, uint32 yyyymmdd (newer
 * firmware: yyyymmddNN, rmd_version_date()).
 */
#define V3X_ROW_B2                                                                               \
	{                                                                                        \
		0xB2, "read_version", 0, RMD_LAYOUT_NONE, RMD_LAYOUT(RMD_U(VERSION, 4, 4, 1.0)), \
			RMD_SAY0("version")                                                      \
	}
/*
 * V3 §2.30, V4.2 §2.30: comm-loss protection time, uint32 ms, 0 disables;
 * stored in ROM (V3 §2.30.4 example 2); the reply echoes (§2.30.3).  The
 * reply printed in example 2 is example 1's all-zero frame, in both
 * manuals: a typo.
 */
#define V3X_ROW_B3                                                              \
	{                                                                       \
		0xB3, "comm_timeout", RMD_CMD_ECHO | RMD_CMD_ROM,               \
			RMD_LAYOUT(RMD_U(TIMEOUT, 4, 4, 1.0)), RMD_LAYOUT_NONE, \
			RMD_SAY1("timeout", TIMEOUT)                            \
	}
/*
 * V3 §2.31, V4.2 §2.31: baud code at data[7] (0: CAN 500k / RS485 115200,
 * 1: CAN 1M / RS485 500k, 2: RS485 1M; V4.2 adds 3: RS485 1.5M, 4: RS485
 * 2.5M), stored in ROM; the reply is noise.
 */
#define V3X_ROW_B4                                                          \
	{                                                                   \
		0xB4, "baud_rate", RMD_CMD_RANDOM_REPLY | RMD_CMD_ROM,      \
			RMD_LAYOUT(RMD_U(BAUD, 7, 1, 1.0)), RMD_LAYOUT_NONE \
	}
/* V3 §2.32, V4.2 §2.32: seven ASCII bytes at data[1..7], first in the LSB. */
#define V3X_ROW_B5                                                                           \
	{                                                                                    \
		0xB5, "read_model", 0, RMD_LAYOUT_NONE, RMD_LAYOUT(RMD_U(MODEL, 1, 7, 1.0)), \
			RMD_SAY0("model")                                                    \
	}

/*
 * V3 §2.33, V4.2 §2.34: 0x20's function index and int32 value; the reply
 * echoes.  Flagged ROM because indexes 1 and 2 (V4.2 also 5, 6, 7) write
 * flash.  Its indexes run 1..last, as `cite` says (the tables list them).
 */
#define V3X_ROW_20(last, cite)                                                        \
	{                                                                             \
		0x20, "function_control", RMD_CMD_ECHO | RMD_CMD_ROM,                 \
			RMD_LAYOUT(RMD_U(INDEX, 1, 1, 1.0), RMD_S(VALUE, 4, 4, 1.0)), \
			RMD_LAYOUT_NONE, RMD_SAY2("function", INDEX, VALUE),          \
			RMD_RANGES(RMD_RANGE(INDEX, 1, last, cite))                   \
	}

/*
 * The runs of rows both tables hold in the same order, so that each table
 * says what it shares in one line a run.
 */
#define V3X_ROWS_60_70 V3X_ROW_60, V3X_ROW_61, V3X_ROW_62, V3X_ROW_63, V3X_ROW_64, V3X_ROW_70
#define V3X_ROWS_76_81 V3X_ROW_76, V3X_ROW_77, V3X_ROW_78, V3X_ROW_79, V3X_ROW_80, V3X_ROW_81
#define V3X_ROWS_B1_B5 V3X_ROW_B1, V3X_ROW_B2, V3X_ROW_B3, V3X_ROW_B4, V3X_ROW_B5

#endif /* RMD_CODEC_V3X_ROWS_H */
