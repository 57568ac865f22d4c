// SPDX-License-Identifier: MIT
/*
 * The identify procedure (rmd/proc_ident.h), as tables: which firmware
 * dates a dialect's motor may answer with (the one rule bring-up and the
 * loop hold a date to); what a motor missing at bring-up asks and in
 * which order (the model first in MIT mode, then the date; nothing on
 * V2, which has no date); how its answers settle it; the MIT refusal
 * reported once.  The loop's use is judged on the wire by test_bringup
 * and test_mit_mode (motors found late on another dialect's firmware).
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include <cmocka.h>

#include "rmd/dialect.h"
#include "rmd/proc_ident.h"
#include "harness/suite.h"

static void test_other(void **state)
{
	static const struct {
		enum rmd_proto proto;
		uint32_t version;
		bool other;
		enum rmd_proto fw;
	} cases[] = {
		{ RMD_PROTO_V3, 20220206, false, RMD_PROTO_V3 },
		{ RMD_PROTO_V3, 2025070202, true, RMD_PROTO_V4 }, /* V4 firmware, a v3 entry */
		{ RMD_PROTO_V4, 2025070202, false, RMD_PROTO_V4 },
		{ RMD_PROTO_V4, 20220206, true, RMD_PROTO_V3 },
		{ RMD_PROTO_MIT, 20220206, false, RMD_PROTO_V3 }, /* mit: V3 firmware */
		{ RMD_PROTO_MIT, 2025070202, true, RMD_PROTO_V4 },
		{ RMD_PROTO_V3, 0, false, RMD_PROTO_V3 },     /* no date: nothing certain */
		{ RMD_PROTO_V4, 12345, false, RMD_PROTO_V3 }, /* no plausible date */
	};

	(void)state;
	for (size_t k = 0; k < sizeof(cases) / sizeof(cases[0]); k++) {
		const struct rmd_dialect *fw = NULL;
		bool other = rmd_dialect_other_firmware(rmd_dialect(cases[k].proto),
							cases[k].version, &fw);

		if (other != cases[k].other || !fw || fw->proto != cases[k].fw)
			fail_msg("case %zu: %s, version %u: other %d (fw %s); want %d (%s)", k,
				 rmd_dialect(cases[k].proto)->key, cases[k].version, other,
				 fw ? fw->key : "-", cases[k].other, rmd_dialect(cases[k].fw)->key);
	}
}

static void test_asks(void **state)
{
	struct rmd_ident id = { 0 };
	uint8_t cmds[2];

	(void)state;
	rmd_ident_open(&id, rmd_dialect(RMD_PROTO_V2));
	assert_false(id.open);
	assert_int_equal(rmd_ident_asks(&id, false, cmds), 0);
	rmd_ident_open(&id, rmd_dialect(RMD_PROTO_V4));
	assert_true(id.open);
	assert_int_equal(rmd_ident_asks(&id, false, cmds), 1);
	assert_int_equal(cmds[0], 0xB2);
	assert_int_equal(rmd_ident_asks(&id, true, cmds), 2);
	assert_int_equal(cmds[0], 0xB5);
	assert_int_equal(cmds[1], 0xB2);
}

static void test_answers(void **state)
{
	const struct rmd_dialect *v3 = rmd_dialect(RMD_PROTO_V3), *fw;
	struct rmd_motor_reply model = { .have = RMD_MOTOR_HAVE_MODEL }, date = { 0 };
	struct rmd_ident id = { 0 };

	(void)state;
	snprintf(model.model, sizeof(model.model), "X6S2V3");
	rmd_ident_open(&id, v3);
	/* the model: kept, asked again */
	assert_int_equal(rmd_ident_answer(&id, v3, &model, &fw), RMD_IDENT_WAIT);
	assert_true(id.open);
	assert_string_equal(id.model, "X6S2V3");
	/* a V3 date: settled, the same firmware */
	date.have = RMD_MOTOR_HAVE_VERSION;
	date.version_date = 20220206;
	assert_int_equal(rmd_ident_answer(&id, v3, &date, &fw), RMD_IDENT_SAME);
	assert_false(id.open);
	assert_int_equal(id.version, 20220206);
	/* a V4 date on a v3 entry: another firmware */
	rmd_ident_open(&id, v3);
	date.version_date = 2026042402;
	assert_int_equal(rmd_ident_answer(&id, v3, &date, &fw), RMD_IDENT_OTHER);
	assert_non_null(fw);
	assert_int_equal(fw->proto, RMD_PROTO_V4);
	assert_false(id.open);
}

static void test_mit_warn_once(void **state)
{
	struct rmd_ident id = { 0 };

	(void)state;
	assert_true(rmd_ident_mit_warn_once(&id));
	assert_false(rmd_ident_mit_warn_once(&id));
}

SUITE_MAIN("proc_ident", NULL, NULL,
	   {
		   cmocka_unit_test(test_other),
		   cmocka_unit_test(test_asks),
		   cmocka_unit_test(test_answers),
		   cmocka_unit_test(test_mit_warn_once),
	   })
