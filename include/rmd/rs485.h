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

#include <stddef.h>
#include <stdint.h>
#include <termios.h>

#include "rmd/frame.h"

#define RMD_RS485_HEADER 0x3Eu
#define RMD_RS485_BROADCAST 0xCDu
#define RMD_RS485_FRAME_LEN 13u

/* V3 §1.2.1: the bit rates an RMD RS485 port speaks, with their termios speeds. */
struct rmd_rs485_baud {
	uint32_t baud;
	speed_t speed;
};

#define RMD_RS485_N_BAUDS 5
extern const struct rmd_rs485_baud RMD_RS485_BAUDS[RMD_RS485_N_BAUDS];

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

#endif /* RMD_RS485_H */
