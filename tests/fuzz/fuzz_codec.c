// SPDX-License-Identifier: MIT
/*
 * CAN frame decode, V2 and V3 (and MIT's V3 table), both directions:
 * rmd_decode(), rmd_decode_as() and what tools do with a decoded message
 * (error names, run mode, model string), then the round trip: a frame that
 * decodes re-encodes (rmd_encode()) into a frame that decodes to the same
 * message.
 *
 * Input: [0] proto (% 3), direction (>> 2 % 3), decode_as (bit 4);
 * [1] the command byte for decode_as; [2..3] CAN identifier, little
 * endian; [4] DLC; [5..12] data.  Missing bytes are zero.
 */
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rmd/codec.h"
#include "rmd/frame.h"

#include "fuzz.h"

static void use_msg(enum rmd_proto proto, const struct rmd_msg *msg)
{
	const char *names[16];
	char model[8];
	size_t n;

	if (rmd_msg_has(msg, RMD_FLD_ERROR)) {
		n = rmd_error_names(proto, (uint16_t)msg->v[RMD_FLD_ERROR], names, 16);
		for (size_t i = 0; i < n && i < 16; i++)
			FUZZ_CHECK(names[i] != NULL);
	}
	if (rmd_msg_has(msg, RMD_FLD_MODE))
		(void)rmd_run_mode_name(proto, (uint8_t)msg->v[RMD_FLD_MODE]);
	if (rmd_msg_has(msg, RMD_FLD_MODEL)) {
		rmd_model_string(msg->v[RMD_FLD_MODEL], model);
		FUZZ_CHECK(memchr(model, 0, sizeof(model)) != NULL);
		(void)rmd_model_raw(model);
	}
	if (rmd_msg_has(msg, RMD_FLD_VERSION))
		(void)rmd_version_date_valid((uint32_t)msg->v[RMD_FLD_VERSION]);
	for (int f = 0; f < RMD_FLD_COUNT; f++)
		if (rmd_msg_has(msg, (enum rmd_field)f))
			FUZZ_CHECK(rmd_field_key((enum rmd_field)f) != NULL);
}

/* decode(encode(m)) == m for a message that came out of decode. */
static void round_trip(enum rmd_proto proto, enum rmd_dir dir, uint32_t can_id,
		       const struct rmd_msg *msg)
{
	struct rmd_addr addr;
	struct rmd_frame f2;
	struct rmd_msg m2;
	int r;

	if (rmd_addr_from_id(proto, can_id, &addr) < 0)
		return;
	r = rmd_encode(proto, dir, addr.motor_id, msg, &f2);
	if (r < 0)
		return; /* e.g. a reply row sent to 0x280: not every frame has an encodable twin */
	FUZZ_CHECK(f2.len == RMD_FRAME_LEN);
	r = rmd_decode_as(proto, dir, msg->cmd, &f2, &m2);
	FUZZ_CHECK(r == 0);
	FUZZ_CHECK(m2.cmd == msg->cmd);
	FUZZ_CHECK(m2.present == msg->present);
	for (int i = 0; i < RMD_FLD_COUNT; i++)
		if (msg->present & (UINT64_C(1) << i))
			FUZZ_CHECK(m2.v[i] == msg->v[i]);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	uint8_t in[13] = { 0 };
	struct rmd_frame f = { 0 };
	struct rmd_msg msg;
	enum rmd_proto proto;
	enum rmd_dir dir, dir_out = RMD_DIR_UNKNOWN;
	int r;

	memcpy(in, data, size < sizeof(in) ? size : sizeof(in));
	proto = (enum rmd_proto)(in[0] % RMD_PROTO_COUNT);
	dir = (enum rmd_dir)((in[0] >> 2) % 3);
	f.can_id = (uint32_t)in[2] | (uint32_t)in[3] << 8;
	f.len = in[4];
	memcpy(f.data, in + 5, RMD_FRAME_LEN);

	memset(&msg, 0xA5, sizeof(msg));
	if (in[0] & 0x10) {
		if (dir == RMD_DIR_UNKNOWN)
			dir = RMD_DIR_REPLY;
		r = rmd_decode_as(proto, dir, in[1], &f, &msg);
		dir_out = dir;
	} else {
		r = rmd_decode(proto, dir, &f, &msg, &dir_out);
	}
	FUZZ_CHECK(r == 0 || r == -EBADMSG || r == -EINVAL || r == -ENOENT);
	if (r == -ENOENT)
		FUZZ_CHECK(msg.present == 0);
	if (r != 0)
		return 0;
	FUZZ_CHECK(dir_out == RMD_DIR_REQUEST || dir_out == RMD_DIR_REPLY);
	use_msg(proto, &msg);
	if (!(in[0] & 0x10))
		round_trip(proto, dir_out, f.can_id, &msg);
	return 0;
}
