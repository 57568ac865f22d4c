// SPDX-License-Identifier: MIT
/* A suite's main() (suite.h). */
#include "harness/suite.h"

void suite_fixture(struct CMUnitTest *tests, size_t n, CMFixtureFunction setup,
		   CMFixtureFunction teardown)
{
	for (size_t i = 0; i < n; i++) {
		tests[i].setup_func = setup;
		tests[i].teardown_func = teardown;
	}
}
