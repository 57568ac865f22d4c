// SPDX-License-Identifier: MIT
/*
 * MIT motion mode (V3 §5), both directions: rmd_mit_decode_cmd() and
 * rmd_mit_decode_reply() on any frame, with the manual's ranges or with
 * ranges from the input (any doubles, NaN and infinities included); the
 * encoders on any doubles; the quantiser on any value, range and width;
 * rmd_mit_ranges_parse() on any text.  Under the default ranges a decoded
 * frame re-encodes to the same codes.
 *
 * Input: [0] selector; [1..2] CAN identifier; [3] DLC; [4..11] data; then
 * with bit 0 of the selector ten range doubles; then five command doubles,
 * a width byte and the rest as a ranges string.
 */
#include <float.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "rmd/frame.h"
#include "rmd/mit.h"

#include "fuzz.h"

static void check_cmd(const struct rmd_mit_ranges *r, const struct rmd_frame *f)
{
	struct rmd_mit_cmd c;
	struct rmd_frame f2;
	uint8_t id;
	int ret = rmd_mit_decode_cmd(r, f, &id, &c);

	FUZZ_CHECK(ret == 0 || ret == -EINVAL || ret == -EBADMSG);
	if (ret < 0)
		return;
	FUZZ_CHECK(id >= 1 && id <= RMD_MAX_MOTORS);
	FUZZ_CHECK(isfinite(c.p_des_rad) && isfinite(c.v_des_rad_s) && isfinite(c.kp) &&
		   isfinite(c.kd) && isfinite(c.t_ff_nm));
	ret = rmd_mit_encode_cmd(r, id, &c, &f2);
	FUZZ_CHECK(ret == 0);
	if (r == &rmd_mit_default_ranges) {
		FUZZ_CHECK(f2.can_id == f->can_id && f2.len == RMD_FRAME_LEN);
		FUZZ_CHECK(memcmp(f2.data, f->data, RMD_FRAME_LEN) == 0);
	}
}

static void check_reply(const struct rmd_mit_ranges *r, const struct rmd_frame *f)
{
	struct rmd_mit_reply rep;
	struct rmd_frame f2;
	int ret = rmd_mit_decode_reply(r, f, &rep);

	FUZZ_CHECK(ret == 0 || ret == -EINVAL || ret == -EBADMSG);
	if (ret < 0)
		return;
	FUZZ_CHECK(rep.motor_id >= 1 && rep.motor_id <= RMD_MAX_MOTORS);
	FUZZ_CHECK(isfinite(rep.pos_rad) && isfinite(rep.vel_rad_s) && isfinite(rep.torque_nm));
	ret = rmd_mit_encode_reply(r, &rep, &f2);
	FUZZ_CHECK(ret == 0);
	if (r == &rmd_mit_default_ranges) {
		FUZZ_CHECK(f2.can_id == f->can_id);
		/* D6, D7 are unused: ignored when decoded, 0 when encoded */
		FUZZ_CHECK(memcmp(f2.data, f->data, 6) == 0);
	}
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	struct fuzz_in in = { data, size };
	struct rmd_mit_ranges fr, parsed;
	const struct rmd_mit_ranges *r = &rmd_mit_default_ranges;
	struct rmd_frame f = { 0 }, out;
	struct rmd_mit_cmd c;
	struct rmd_mit_reply rep;
	char text[128];
	uint8_t sel = fuzz_u8(&in);
	unsigned bits;
	uint32_t u;
	double x;

	f.can_id = fuzz_u16(&in);
	f.len = fuzz_u8(&in);
	fuzz_take(&in, f.data, RMD_FRAME_LEN);
	if (sel & 1) {
		fuzz_take(&in, &fr, sizeof(fr));
		r = &fr;
	}
	check_cmd(r, &f);
	check_reply(r, &f);

	/* The encoders and the quantiser on any doubles. */
	fuzz_take(&in, &c, sizeof(c));
	if (rmd_mit_encode_cmd(r, (uint8_t)(sel >> 3), &c, &out) == 0)
		check_cmd(r, &out);
	rep.motor_id = (uint8_t)(sel >> 3);
	rep.pos_rad = c.p_des_rad;
	rep.vel_rad_s = c.v_des_rad_s;
	rep.torque_nm = c.t_ff_nm;
	if (rmd_mit_encode_reply(r, &rep, &out) == 0)
		check_reply(r, &out);
	bits = fuzz_u8(&in);
	u = rmd_mit_to_uint(c.kp, c.p_des_rad, c.v_des_rad_s, bits);
	if (bits >= 1 && bits < 32)
		FUZZ_CHECK(u <= (UINT32_C(1) << bits) - 1);
	x = rmd_mit_from_uint(u, c.p_des_rad, c.v_des_rad_s, bits);
	(void)x;

	/* The ranges option ("P,V,T,KP,KD"). */
	fuzz_take(&in, text, sizeof(text) - 1);
	text[sizeof(text) - 1] = '\0';
	if (rmd_mit_ranges_parse(text, &parsed) == 0)
		FUZZ_CHECK(rmd_mit_ranges_valid(&parsed));
	return 0;
}
