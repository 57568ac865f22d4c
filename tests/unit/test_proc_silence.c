// SPDX-License-Identifier: MIT
/*
 * The silence procedure (rmd/proc_silence.h), over the dialect list:
 * what a motor found or back turns off (every reply its dialect can push,
 * nothing where it has no active reply), in which order, that each is
 * sent once, what a lost motor keeps, which replies count as pushed, and
 * the request's bytes (V4.2 §2.33.2: B6 CMD 00 00 00 00 00 00 for off).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <cmocka.h>

#include "rmd/codec.h"
#include "rmd/dialect.h"
#include "rmd/proc_silence.h"
#include "harness/suite.h"

static void test_every_dialect(void **state)
{
	size_t nd;
	const struct rmd_dialect *list = rmd_dialect_list(&nd);
	unsigned with = 0;

	(void)state;
	for (size_t k = 0; k < nd; k++) {
		const struct rmd_dialect *d = &list[k];
		struct rmd_silence s = { 0 };
		unsigned sent = 0;
		int prev = -1, n;

		rmd_silence_begin(&s, d);
		if (!rmd_dialect_has(d, RMD_DIALECT_ACTIVE_REPLY)) {
			if (rmd_silence_next(&s) != -1)
				fail_msg("%s: no active reply, yet something to turn off", d->key);
			continue;
		}
		with++;
		while ((n = rmd_silence_next(&s)) >= 0) {
			struct rmd_msg msg;
			struct rmd_frame f;

			if (n <= prev)
				fail_msg("%s: off %d after %d: lowest first, each once", d->key, n,
					 prev);
			prev = n;
			sent++;
			rmd_silence_request(d, (unsigned)n, &msg);
			assert_int_equal(rmd_encode(d->proto, RMD_DIR_REQUEST, 1, &msg, &f), 0);
			assert_int_equal(f.data[0], 0xB6);
			assert_int_equal(f.data[1], d->report_cmds[n]);
			for (unsigned b = 2; b < 8; b++)
				if (f.data[b])
					fail_msg("%s: the off of 0x%02X has byte %u = 0x%02X",
						 d->key, d->report_cmds[n], b, f.data[b]);
			assert_int_equal(rmd_silence_pushable(d, d->report_cmds[n]), n);
		}
		assert_int_equal(sent, d->n_report_cmds);
		/* lost before they all went: none are sent until it is back */
		rmd_silence_begin(&s, d);
		rmd_silence_forget(&s);
		assert_int_equal(rmd_silence_next(&s), -1);
	}
	assert_true(with >= 1); /* V4 has an active reply (V4.2 §2.33) */
}

static void test_pushable(void **state)
{
	const struct rmd_dialect *v4 = rmd_dialect(RMD_PROTO_V4), *v3 = rmd_dialect(RMD_PROTO_V3);

	(void)state;
	assert_true(rmd_silence_pushable(v4, 0x9C) >= 0);
	assert_int_equal(rmd_silence_pushable(v4, 0xB3), -1);
	assert_int_equal(rmd_silence_pushable(v3, 0x9C), -1);
}

SUITE_MAIN("proc_silence", NULL, NULL,
	   {
		   cmocka_unit_test(test_every_dialect),
		   cmocka_unit_test(test_pushable),
	   })
