// SPDX-License-Identifier: MIT
/* A suite's main() (suite.h). */
#include <stdio.h>
#include <stdlib.h>

#include "harness/suite.h"

/*
 * tests/run-tests.sh reads a suite's output from a file, where stdout would
 * be fully buffered and stderr not: cmocka's "[ RUN      ]" lines (stdout)
 * would land after the reasons the tests print to stderr.  Line-buffered,
 * each line lands where it was written, so the runner finds a skipped test's
 * reason between its RUN and SKIPPED lines.  Every suite links this file.
 *
 * RMD_TEST_FILTER=PATTERN runs only the tests whose names match it
 * (cmocka's pattern: * and ?), in every suite.
 */
__attribute__((constructor)) static void suite_start(void)
{
	setvbuf(stdout, NULL, _IOLBF, 0);
	cmocka_set_test_filter(getenv("RMD_TEST_FILTER"));
}

void suite_fixture(struct CMUnitTest *tests, size_t n, CMFixtureFunction setup,
		   CMFixtureFunction teardown)
{
	for (size_t i = 0; i < n; i++) {
		tests[i].setup_func = setup;
		tests[i].teardown_func = teardown;
	}
}

int suite_run(const char *name, const struct CMUnitTest *tests, size_t n,
	      CMFixtureFunction group_setup, CMFixtureFunction group_teardown)
{
	return _cmocka_run_group_tests(name, tests, n, group_setup, group_teardown);
}
