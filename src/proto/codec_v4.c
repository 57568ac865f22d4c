// SPDX-License-Identifier: MIT
/*
 * Protocol V4.2 command table (rmd-servo-protocol-v4.2-en.txt, MyActuator
 * "Servo Motor Control Protocol V4.2", 2024.05).  Section numbers (§) are
 * that manual's.  Identifiers as in V3: requests on 0x140 + ID (0x280 for
 * every motor, §3), replies on 0x240 + ID, 0x79 on 0x300 (§4), MIT frames
 * on 0x400 + ID (§5).
 *
 * §9 lists what changed since V3.6, whose table is codec_v3.c: 0xA3
 * removed and 0xA5 merged into 0xA4 (V3.7); 0xA6, 0x90 and 0x94 added
 * (V3.7); an index in 0x42 and 0xB6 added (V3.9); 0x20 indexes 5, 6, 7
 * (V4.0); circleAngle uint16 (V4.1); 0x30 .. 0x32 one float gain by index
 * (V4.2).  V4.2 prints no 0x71 (motor power): it is left out.  The rows
 * both manuals print alike are codec_v3x_rows.h.
 *
 * Fields and rows marked "V4.3" or "unverified" come from public code
 * that cites a V4.3 or V4.4 manual, or from a vendor tool read back, no
 * motor here has confirmed (docs/protocol-v4.md, "What is verified and
 * what is one report", names each source): decoded and named when they
 * come, never sent by rmdd, never depended on.  V4.2 firmware sends zero
 * in such fields.
 *
 * Every row is checked against the manual's worked examples in
 * tests/unit/test_codec.c.  Where the text contradicts itself, the row
 * takes what real firmware may send, and says so.
 */
#include "codec_tables.h"
#include "codec_v3x_rows.h"

/*
 * §2.1.3, §2.2.2, §2.3.2: one gain a frame, its index at data[1] (§2.1.4:
 * 1 current KP, 2 current KI, 4 speed KP, 5 speed KI, 7 position KP,
 * 8 position KI, 9 position KD) and the gain a float at data[4..7]
 * (0x3F800000 = 1.0, §2.1.5).
 */
#define V4_PID RMD_LAYOUT(RMD_U(INDEX, 1, 1, 1.0), RMD_F(GAIN, 4))

/*
 * 0xC0, a parameter of the vendor setup software (unverified, one source:
 * almond-bot/axol almond_axol/motor/myactuator.py, recovered from that
 * software; in no manual): data[1] 0, the parameter's index at data[2],
 * 1 read / 0 write at data[3], the value a little-endian float32 in the
 * parameter's unit at data[4..7] (a write's, or 0 for a read).  The reply
 * has the same layout, a read's with the stored value.
 */
#define V4_PARAM RMD_LAYOUT(RMD_U(INDEX, 2, 1, 1.0), RMD_U(READ_FLAG, 3, 1, 1.0), RMD_F(PARAM, 4))

/*
 * §2.22.3: 0xA6 answers temperature, iq, speed and the single-turn
 * encoder (uint16 counts) where the other control replies have the angle.
 */
#define V4_STATUS2_ENCODER                                                                      \
	RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_S(CURRENT, 2, 2, 0.01), RMD_S(SPEED, 4, 2, 1.0), \
		   RMD_U(ENCODER, 6, 2, 1.0))

RMD_ROWS_BEGIN
const struct rmd_cmd_spec rmd_v4_cmds[] = {
	/* §2.1: read the gain of an index; the reply carries both. */
	{ 0x30, "read_pid", 0, RMD_LAYOUT(RMD_U(INDEX, 1, 1, 1.0)), V4_PID, RMD_SAY_NONE,
	  RMD_RANGES(RMD_RANGE(INDEX, 1, 9, "V4.2 §2.1.4: index 1..9")) },
	/* §2.2: one gain to RAM, lost at power off; the reply echoes. */
	{ 0x31,
	  "write_pid_ram",
	  RMD_CMD_ECHO,
	  V4_PID,
	  { 0 },
	  RMD_SAY_NONE,
	  RMD_RANGES(RMD_RANGE(INDEX, 1, 9, "V4.2 §2.2.4: index 1..9")) },
	/* §2.3: one gain to ROM, kept at power off; the reply echoes. */
	{ 0x32,
	  "write_pid_rom",
	  RMD_CMD_ECHO | RMD_CMD_ROM,
	  V4_PID,
	  { 0 },
	  RMD_SAY_NONE,
	  RMD_RANGES(RMD_RANGE(INDEX, 1, 9, "V4.2 §2.3.4: index 1..9")) },
	/*
	 * §2.4: the index (as 0x43's, §2.4.4) at data[1] of the request and
	 * of the reply; accel int32 1 dps/s.  Firmware before V3.9 answers
	 * without an index (data[1] 0, read as index 0).
	 */
	{ 0x42, "read_accel", 0, RMD_LAYOUT(RMD_U(INDEX, 1, 1, 1.0)),
	  RMD_LAYOUT(RMD_U(INDEX, 1, 1, 1.0), RMD_S(ACCEL, 4, 4, 1.0)),
	  RMD_SAY1("accel-read", INDEX),
	  RMD_RANGES(RMD_RANGE(INDEX, 0, 3, "V4.2 §2.4.4: index 0..3")) },
	V3X_ROW_43("V4.2"),
	V3X_ROWS_60_70,
	V3X_ROWS_76_81,
	/*
	 * §2.11: single-turn encoder: position (raw minus offset), raw
	 * position and zero offset, uint16 counts at data[2..7].  (§2.11.3's
	 * "Data" column names data[1..6] for bytes 2..7: a typo, the example
	 * 2099 = 0x0833 sits at data[2..3].)
	 */
	{ 0x90,
	  "read_encoder_single",
	  0,
	  { 0 },
	  RMD_LAYOUT(RMD_U(ENCODER, 2, 2, 1.0), RMD_U(ENCODER_RAW, 4, 2, 1.0),
		     RMD_U(ENCODER_OFF, 6, 2, 1.0)),
	  RMD_SAY0("read-encoder-single") },
	V3X_ROW_92,
	/*
	 * §2.13: single-turn angle circleAngle at data[6..7], 0.01 deg,
	 * 0..35999.  §2.13.3 still calls it int16_t, which cannot hold 35999;
	 * §9 V4.1 made it uint16_t: read as uint16, as firmware sends it.
	 */
	{ 0x94,
	  "read_angle_single",
	  0,
	  { 0 },
	  RMD_LAYOUT(RMD_U(ANGLE, 6, 2, 0.01)),
	  RMD_SAY0("read-angle-single") },
	/*
	 * §2.14: temperature, brake, voltage 0.1 V, error flags (§2.14 table
	 * 1; dialect.c).  data[2], NULL in V4.2, is the MOS temperature in
	 * V4.3 (int8 1 degC; unverified, one source: Nitish05/myactuator
	 * myactuator_rmd/src/protocol/responses.cpp).
	 */
	{ 0x9A,
	  "read_status_1",
	  0,
	  { 0 },
	  RMD_LAYOUT(RMD_S(TEMP, 1, 1, 1.0), RMD_S(MOS_TEMP, 2, 1, 1.0), RMD_U(BRAKE, 3, 1, 1.0),
		     RMD_U(VOLTAGE, 4, 2, 0.1), RMD_U(ERROR, 6, 2, 1.0)),
	  RMD_SAY0("status1") },
	V3X_ROW_9C,
	V3X_ROW_9D,
	V3X_ROW_A1,
	/*
	 * §2.20: speedControl int32 0.01 dps.  data[1], NULL in V4.2, is the
	 * maximum torque in % of the rated current in V4.3 (uint8; unverified,
	 * one source: Nitish05/myactuator, as 0xA9's); 0 there is what a V4.2
	 * host sends, and "no limit" in that source.
	 */
	{ 0xA2, "speed", RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_U(MAX_TORQUE, 1, 1, 1.0), RMD_S(SPEED, 4, 4, 0.01)), V3X_STATUS2,
	  RMD_SAY1("speed", SPEED) },
	V3X_ROW_A4,
	/*
	 * §2.22: single-turn position: spinDirection at data[1] (0 clockwise,
	 * 1 counterclockwise), maxSpeed uint16 1 dps, angleControl uint16
	 * 0.01 deg at data[4..5].  §2.22.1 gives 0..35999, yet the §2.22.4
	 * example sends 36000 (0x8CA0, "360 and 0 degrees coincide"): the
	 * whole uint16 is taken.  §2.22.2 leaves data[6..7] NULL although the
	 * example's text speaks of "Data[4] to data[7]".
	 */
	{ 0xA6, "position_single", RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_U(SPIN_DIR, 1, 1, 1.0), RMD_U(MAX_SPEED, 2, 2, 1.0),
		     RMD_U(ANGLE, 4, 2, 0.01)),
	  V4_STATUS2_ENCODER, RMD_SAY3("position-single", ANGLE, MAX_SPEED, SPIN_DIR),
	  RMD_RANGES(RMD_RANGE(ANGLE, 0, 360,
			       "V4.2 §2.22: 0..359.99 deg, and 360 as its example sends"),
		     RMD_RANGE(SPIN_DIR, 0, 1, "V4.2 §2.22.1: 0 clockwise, 1 counterclockwise")) },
	V3X_ROW_A8,
	/*
	 * 0xA9, force position (V4.3, unverified, one source: Nitish05/myactuator
	 * myactuator_rmd/src/protocol/requests.cpp): as 0xA4, with the maximum
	 * torque in % of the rated current at data[1] (uint8, as 0xA2's; the same
	 * project's Python wrapper scales it as 255 = 100 %).  The reply is taken
	 * to be 0xA4's.  No words: rmdctl decodes and names it, and offers no
	 * command that sends it.
	 */
	{ 0xA9, "position_force", RMD_CMD_MOVES,
	  RMD_LAYOUT(RMD_U(MAX_TORQUE, 1, 1, 1.0), RMD_U(MAX_SPEED, 2, 2, 1.0),
		     RMD_S(ANGLE, 4, 4, 0.01)),
	  V3X_STATUS2 },
	V3X_ROWS_B1_B5,
	/*
	 * §2.33: active reply, CAN only.  data[1] the command whose reply
	 * the motor pushes (0x60 0x61 0x62 0x92 0x9A 0x9C 0x9D 0x9E), data[2]
	 * 1 on / 0 off, data[3..4] uint16 interval in 10 ms.  §2.33.3: no
	 * reply once on; for off the manual says nothing, so no answer is
	 * awaited (an echo, should one come, reads as the request).  The
	 * §2.33.4 example (interval 0x0001) says both "20ms" and "10ms": one
	 * step is 10 ms, as §2.33.2 defines it.
	 */
	{ 0xB6,
	  "active_reply",
	  RMD_CMD_NO_REPLY,
	  RMD_LAYOUT(RMD_U(REPORT_CMD, 1, 1, 1.0), RMD_U(REPORT_ON, 2, 1, 1.0),
		     RMD_U(REPORT_MS, 3, 2, 10.0)),
	  { 0 },
	  RMD_SAY_NONE,
	  RMD_RANGES(RMD_RANGE(REPORT_ON, 0, 1, "V4.2 §2.33.2: 1 on, 0 off")) },
	/*
	 * §2.34: function index (§2.34.4: 1 clear multi-turn and save, 2 CAN
	 * ID filter, saved in flash, 3 0x9A error reports, 4 save multi-turn
	 * at power off, 5 set the CAN ID, to ROM, effective after a reset,
	 * 6/7 maximum positive/negative angle of position control, to ROM,
	 * effective at once; the manual gives no unit for 6/7) and an int32
	 * value; the reply echoes.  Flagged ROM because indexes 1, 2, 5, 6, 7
	 * write flash.
	 */
	V3X_ROW_20(7, "V4.2 §2.34.4: index 1..7"),
	/*
	 * 0xC0 and 0xC1, the setup software's parameter access (unverified, one
	 * source, above V4_PARAM).  A 0xC0 write changes a setting in RAM (motor
	 * direction, pole pairs, voltage limits among them); 0xC1, no data, writes
	 * every one written since to ROM.  Its reply's layout is not given.  No
	 * words, and rmdd sends neither: rmdctl decodes and names them.
	 */
	{ 0xC0, "param_access", 0, V4_PARAM, V4_PARAM },
	{ 0xC1, "param_save_rom", RMD_CMD_ROM },
};
RMD_ROWS_END
const size_t rmd_v4_ncmds = sizeof(rmd_v4_cmds) / sizeof(rmd_v4_cmds[0]);
