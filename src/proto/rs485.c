// SPDX-License-Identifier: MIT
/*
 * RS485 framing of V3 §1.2.2 around the CAN data field, with the Modbus
 * CRC-16.  libmodbus does not export its CRC, hence the short one here.
 * Everything here is pure and rt-safe.
 */
#include <errno.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "rmd/rs485.h"

/* V3 §1.2.2: header, id, length, data, CRC low, CRC high. */
#define OFF_HEADER 0
#define OFF_ID 1
#define OFF_LEN 2
#define OFF_DATA 3
#define OFF_CRC (OFF_DATA + RMD_FRAME_LEN)

const struct rmd_rs485_baud RMD_RS485_BAUDS[RMD_RS485_N_BAUDS] = {
	{ 115200, B115200 },   { 500000, B500000 },   { 1000000, B1000000 },
	{ 1500000, B1500000 }, { 2000000, B2000000 },
};

int rmd_rs485_baud_speed(uint32_t baud, speed_t *speed)
{
	for (size_t i = 0; i < RMD_RS485_N_BAUDS; i++) {
		if (RMD_RS485_BAUDS[i].baud == baud) {
			if (speed)
				*speed = RMD_RS485_BAUDS[i].speed;
			return 0;
		}
	}
	return -EINVAL;
}

uint16_t rmd_crc16_modbus(const uint8_t *buf, size_t len)
{
	uint16_t crc = 0xFFFF;

	for (size_t i = 0; i < len; i++) {
		crc ^= buf[i];
		for (int bit = 0; bit < 8; bit++)
			crc = (crc & 1u) ? (uint16_t)(crc >> 1 ^ 0xA001u) : (uint16_t)(crc >> 1);
	}
	return crc;
}

/* V3 §1.2.2: motor ids 1..32; V3 §6: 0xCD reaches every motor. */
static bool id_ok(uint8_t id)
{
	return (id >= 1 && id <= RMD_MAX_MOTORS) || id == RMD_RS485_BROADCAST;
}

int rmd_rs485_build(uint8_t id, const uint8_t data[RMD_FRAME_LEN], uint8_t *out, size_t out_len)
{
	uint16_t crc;

	if (!id_ok(id))
		return -EINVAL;
	if (out_len < RMD_RS485_FRAME_LEN)
		return -ENOBUFS;

	out[OFF_HEADER] = RMD_RS485_HEADER;
	out[OFF_ID] = id;
	out[OFF_LEN] = RMD_FRAME_LEN;
	memcpy(&out[OFF_DATA], data, RMD_FRAME_LEN);
	crc = rmd_crc16_modbus(out, OFF_CRC);
	out[OFF_CRC] = (uint8_t)crc;
	out[OFF_CRC + 1] = (uint8_t)(crc >> 8);
	return (int)RMD_RS485_FRAME_LEN;
}

int rmd_rs485_parse(const uint8_t *buf, size_t len, uint8_t *id, uint8_t data[RMD_FRAME_LEN])
{
	uint16_t crc;

	if (len > OFF_HEADER && buf[OFF_HEADER] != RMD_RS485_HEADER)
		return -EPROTO;
	if (len > OFF_ID && !id_ok(buf[OFF_ID]))
		return -EPROTO;
	if (len > OFF_LEN && buf[OFF_LEN] != RMD_FRAME_LEN)
		return -EMSGSIZE;
	if (len < RMD_RS485_FRAME_LEN)
		return -EAGAIN;

	crc = rmd_crc16_modbus(buf, OFF_CRC);
	if (buf[OFF_CRC] != (uint8_t)crc || buf[OFF_CRC + 1] != (uint8_t)(crc >> 8))
		return -EBADMSG;

	*id = buf[OFF_ID];
	memcpy(data, &buf[OFF_DATA], RMD_FRAME_LEN);
	return (int)RMD_RS485_FRAME_LEN;
}

/* ID when can_id is base + ID (ID 1..32), else 0. */
static unsigned id_above(uint32_t can_id, uint32_t base)
{
	return can_id > base && can_id <= base + RMD_MAX_MOTORS ? can_id - base : 0;
}

int rmd_rs485_id_of_can(uint32_t can_id, bool request)
{
	unsigned id = id_above(can_id, RMD_CAN_REQ_BASE);

	if (!request && !id)
		id = id_above(can_id, RMD_CAN_V3_REPLY_BASE);
	if (id)
		return (int)id;
	if (can_id == RMD_CAN_SET_ID || (request && can_id == RMD_CAN_MULTI))
		return RMD_RS485_BROADCAST;
	return -EINVAL;
}

uint32_t rmd_rs485_can_id(uint8_t id, bool request, uint8_t d0)
{
	if (id == RMD_RS485_BROADCAST) {
		/* V3 §7: 0x79 sets the RS485 id; every other broadcast is §6's 0x280. */
		if (!request || d0 == RMD_RS485_CMD_SET_ID)
			return RMD_CAN_SET_ID;
		return RMD_CAN_MULTI;
	}
	if (id < 1 || id > RMD_MAX_MOTORS)
		return 0;
	return (request ? RMD_CAN_REQ_BASE : RMD_CAN_V3_REPLY_BASE) + id;
}
