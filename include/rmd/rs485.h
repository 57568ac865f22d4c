/* SPDX-License-Identifier: MIT */
/*
 * RS485 framing (V3 §1.2.2): 0x3E | ID | LEN=8 | D0..D7 | CRC16 (Modbus
 * CRC-16, low byte first), 13 bytes.  ID 1..32, or 0xCD to address every
 * motor (V3 §6, and the RS485-ID setting 0x79 of V3 §7).  The data field is
 * exactly the CAN data field.  The CRC covers the 11 bytes before it, header
 * included: §1.2.2 does not say, Modbus RTU does so, and the manual's
 * examples print only CRC16L/CRC16H placeholders.
 *
 * Pure and rt-safe.
 */
#ifndef RMD_RS485_H
#define RMD_RS485_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <termios.h>

#include "rmd/frame.h"

#define RMD_RS485_HEADER 0x3Eu
#define RMD_RS485_BROADCAST 0xCDu
#define RMD_RS485_FRAME_LEN 13u
#define RMD_RS485_CMD_SET_ID 0x79u /* V3 §7: the broadcast that sets an RS485 id */

/* V3 §1.2.1: the bit rates an RMD RS485 port speaks, with their termios speeds. */
struct rmd_rs485_baud {
	uint32_t baud;
	speed_t speed;
};

#define RMD_RS485_N_BAUDS 5
extern const struct rmd_rs485_baud RMD_RS485_BAUDS[RMD_RS485_N_BAUDS];
/* The list, for messages. */
#define RMD_RS485_BAUD_LIST "115200, 500000, 1000000, 1500000 or 2000000"

/*
 * The termios speed of `baud` into *speed (when not NULL).  Returns 0, or
 * -EINVAL for a rate V3 §1.2.1 does not list.
 */
int rmd_rs485_baud_speed(uint32_t baud, speed_t *speed);

/*
 * Modbus CRC-16: polynomial 0x8005 reflected (0xA001), init 0xFFFF, no final
 * xor; "123456789" gives 0x4B37.  Frames carry it low byte first.
 */
uint16_t rmd_crc16_modbus(const uint8_t *buf, size_t len);

/*
 * Build a 13-byte frame for `id` around data[8] into out.
 * Returns RMD_RS485_FRAME_LEN, -EINVAL for an id that is neither 1..32
 * nor 0xCD, or -ENOBUFS when out_len is less than RMD_RS485_FRAME_LEN.
 */
int rmd_rs485_build(uint8_t id, const uint8_t data[RMD_FRAME_LEN], uint8_t *out, size_t out_len);

/*
 * Parse a frame from the start of buf (len bytes).  Returns the number of
 * bytes consumed (13) and fills *id and data; -EAGAIN when more bytes are
 * needed; -EPROTO for a header byte other than 0x3E or an id that is neither
 * 1..32 nor 0xCD; -EMSGSIZE for a length byte other than 8; -EBADMSG for a
 * CRC mismatch.  Header, id and length are judged as soon as they have
 * arrived, so a partial buffer fails early when its start is already wrong;
 * a receiver resynchronises by dropping one byte on any error but -EAGAIN.
 * Bytes after the first frame are left alone.  *id and data are written only
 * on success.
 */
int rmd_rs485_parse(const uint8_t *buf, size_t len, uint8_t *id, uint8_t data[RMD_FRAME_LEN]);

/*
 * Identifiers.  An RS485 frame carries a motor id (1..32) or 0xCD; the
 * layers above speak CAN identifiers, the same on both wires:
 *
 *   request  0x140 + ID <-> RS485 id ID                     (V3 §1.2.2)
 *            0x280      <-> 0xCD, every motor               (V3 §3, §6)
 *            0x300      <-> 0xCD, the 0x79 RS485-ID setting (V3 §4, §7)
 *   reply    0x240 + ID <-> RS485 id ID                     (V3 §1.1.2)
 *            0x300      <-> 0xCD: only the 0x79 reply comes from 0xCD
 *                           (V3 §7.3), as it comes on 0x300 on CAN (§4.3)
 *
 * A reply on 0x140 + ID (the V2 form) also goes out as id ID.  Every other
 * identifier (MIT 0x400 + ID, 0x500 + ID) has no RS485 form.
 */

/*
 * The RS485 id a frame on `can_id` travels as, in direction request (host
 * to motor) or reply: 1..32 or 0xCD, or -EINVAL when it has no RS485 form.
 */
int rmd_rs485_id_of_can(uint32_t can_id, bool request);

/*
 * The CAN identifier an RS485 frame from `id` stands for, in direction
 * request or reply; d0 is its command byte (a request to 0xCD is 0x79 on
 * 0x300, anything else on 0x280).  0 for an id that is neither 1..32 nor
 * 0xCD.
 */
uint32_t rmd_rs485_can_id(uint8_t id, bool request, uint8_t d0);

#endif /* RMD_RS485_H */
