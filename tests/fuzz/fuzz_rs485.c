// SPDX-License-Identifier: MIT
/*
 * RS485 framing (rmd/rs485.h) on a byte stream: rmd_rs485_parse() from every
 * offset a receiver would try (one byte dropped on an error, a frame's
 * length on success, as the bus does), every prefix of the buffer too.  A
 * frame that parses rebuilds (rmd_rs485_build()) byte for byte, and its id
 * maps to a CAN identifier and back.
 *
 * Input: the bytes on the line.
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "rmd/frame.h"
#include "rmd/rs485.h"

#include "fuzz.h"

static void check_ids(uint8_t id, const uint8_t data[RMD_FRAME_LEN])
{
	for (int request = 0; request < 2; request++) {
		uint32_t can_id = rmd_rs485_can_id(id, request, data[0]);
		int back;

		FUZZ_CHECK(can_id != 0);
		back = rmd_rs485_id_of_can(can_id, request);
		FUZZ_CHECK(back == id);
	}
}

int LLVMFuzzerTestOneInput(const uint8_t *buf, size_t len)
{
	size_t off = 0;

	(void)rmd_crc16_modbus(buf, len);
	while (off < len) {
		uint8_t id = 0xEE, data[RMD_FRAME_LEN], wire[RMD_RS485_FRAME_LEN];
		int r;

		memset(data, 0xEE, sizeof(data));
		/* A short read first: the answer may be "more" or an early error, never a frame. */
		r = rmd_rs485_parse(buf + off, (len - off) % RMD_RS485_FRAME_LEN, &id, data);
		FUZZ_CHECK(r == -EAGAIN || r == -EPROTO || r == -EMSGSIZE);
		FUZZ_CHECK(id == 0xEE);

		r = rmd_rs485_parse(buf + off, len - off, &id, data);
		FUZZ_CHECK(r == RMD_RS485_FRAME_LEN || r == -EAGAIN || r == -EPROTO ||
			   r == -EMSGSIZE || r == -EBADMSG);
		if (r == -EAGAIN)
			break;
		if (r < 0) {
			off++;
			continue;
		}
		FUZZ_CHECK((id >= 1 && id <= RMD_MAX_MOTORS) || id == RMD_RS485_BROADCAST);
		FUZZ_CHECK(rmd_rs485_build(id, data, wire, sizeof(wire)) == RMD_RS485_FRAME_LEN);
		FUZZ_CHECK(memcmp(wire, buf + off, RMD_RS485_FRAME_LEN) == 0);
		check_ids(id, data);
		off += (size_t)r;
	}
	return 0;
}
