// SPDX-License-Identifier: MIT
/* The V2 0x280 frame seen by a motor it was not meant for: see v2_batch.h. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "rmd/frame.h"
#include "rmd/motor.h"
#include "harness/v2_batch.h"

double v2_batch_torque_for(const struct rmd_motor *const ms[4], uint8_t cmd)
{
	double t[4] = { 0 };
	struct rmd_frame f;

	for (t[0] = 0.0; t[0] < 10.0; t[0] += 0.0005)
		if (rmd_motor_encode_v2_batch(ms, t, &f, NULL, NULL) == 0 && f.data[0] == cmd &&
		    f.data[1] == 0)
			return t[0];
	fail_msg("no torque makes a 0x280 frame begin %02X 00", cmd);
	return 0.0;
}
