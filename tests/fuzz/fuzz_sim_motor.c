// SPDX-License-Identifier: MIT
/*
 * The simulated motor's frame interface (rmd/sim.h): a V3, V2 or MIT motor
 * sees a sequence of frames of any identifier, length and data, with time
 * moving between them, and may be faulted or power-cycled.  It must never
 * fail: every reply is an 8-byte frame on an identifier of the protocols,
 * never more than asked for, and the shaft state stays finite.
 *
 * Input: [0] protocol (% 3), motor id (>> 2 % 32 + 1); then records of
 * 13 bytes: [0] action (low 2 bits: 0-1 frame, 2 error bits, 3 power
 * cycle), [1] time step (x 100 us), [2..3] CAN identifier, [4] DLC,
 * [5..12] data (or the error bits).
 */
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "rmd/frame.h"
#include "rmd/sim.h"

#include "fuzz.h"

#define MAXREP 4

static void check_out(const struct rmd_frame *out, int n, int max)
{
	FUZZ_CHECK(n >= 0 && n <= max);
	for (int i = 0; i < n; i++) {
		uint32_t id = out[i].can_id;

		FUZZ_CHECK(out[i].len == RMD_FRAME_LEN);
		FUZZ_CHECK((id > RMD_CAN_REQ_BASE && id <= RMD_CAN_REQ_BASE + RMD_MAX_MOTORS) ||
			   (id > RMD_CAN_V3_REPLY_BASE &&
			    id <= RMD_CAN_V3_REPLY_BASE + RMD_MAX_MOTORS) ||
			   (id > RMD_CAN_MIT_REPLY_BASE &&
			    id <= RMD_CAN_MIT_REPLY_BASE + RMD_MAX_MOTORS) ||
			   id == RMD_CAN_SET_ID);
	}
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
	static struct rmd_sim_motor m;
	struct fuzz_in in = { data, size };
	struct rmd_sim_motor_params p;
	struct rmd_frame f, out[MAXREP];
	uint8_t head = fuzz_u8(&in);
	int64_t now = 1000000000;
	int n;

	rmd_sim_motor_params_default(&p, (uint8_t)((head >> 2) % RMD_MAX_MOTORS + 1),
				     (enum rmd_proto)(head % RMD_PROTO_COUNT));
	rmd_sim_motor_init(&m, &p, now);
	while (in.n > 0) {
		uint8_t act = fuzz_u8(&in);

		now += (int64_t)fuzz_u8(&in) * 100000;
		f.can_id = fuzz_u16(&in);
		f.len = fuzz_u8(&in);
		fuzz_take(&in, f.data, RMD_FRAME_LEN);
		switch (act & 3) {
		case 2:
			rmd_sim_motor_set_error(&m, (uint16_t)(f.data[0] | f.data[1] << 8));
			break;
		case 3:
			rmd_sim_motor_power_cycle(&m, now);
			break;
		default:
			rmd_sim_motor_step(&m, now);
			n = rmd_sim_motor_receive(&m, now, &f, out, 1 + (act >> 6));
			check_out(out, n, 1 + (act >> 6));
			break;
		}
		n = rmd_sim_motor_poll(&m, now, out, MAXREP);
		check_out(out, n, MAXREP);
		FUZZ_CHECK(rmd_sim_motor_next_event_ns(&m) >= 0);
		FUZZ_CHECK(isfinite(m.pos_rad) && isfinite(m.vel_rad_s) && isfinite(m.iq_a) &&
			   isfinite(m.temp_c));
	}
	return 0;
}
