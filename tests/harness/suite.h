/* SPDX-License-Identifier: MIT */
/*
 * What a suite's main() shares: a suite whose every test runs between the
 * same setup and teardown lists its tests with cmocka's plain test macro
 * and says which fixture once, instead of on every line.  Every suite
 * (this file's suite.c is linked into each) runs only the tests
 * RMD_TEST_FILTER names, when it is set.
 */
#ifndef RMD_TESTS_SUITE_H
#define RMD_TESTS_SUITE_H

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>

#include <cmocka.h>

/* Each of tests[0..n-1] runs after setup and before teardown (either may be NULL). */
void suite_fixture(struct CMUnitTest *tests, size_t n, CMFixtureFunction setup,
		   CMFixtureFunction teardown);

/*
 * Runs tests[0..n-1] as the group name, group_setup before the first and
 * group_teardown after the last (either may be NULL), only those
 * RMD_TEST_FILTER names when it is set; returns how many failed.
 */
int suite_run(const char *name, const struct CMUnitTest *tests, size_t n,
	      CMFixtureFunction group_setup, CMFixtureFunction group_teardown);

#define SUITE_N(tests) (sizeof(tests) / sizeof((tests)[0]))

/* suite_run() over an array, its length counted. */
#define SUITE_RUN(name, tests, group_setup, group_teardown) \
	suite_run(name, tests, SUITE_N(tests), group_setup, group_teardown)

/* A test named test_name that runs func with *state its table row (a table-driven suite). */
#define SUITE_ROW(test_name, func, row) \
	((struct CMUnitTest){           \
		.name = (test_name), .test_func = (func), .initial_state = (void *)(row) })

/*
 * A suite's whole main(): runs the braced list of CMUnitTest entries that
 * follows, e.g. SUITE_MAIN("x", NULL, NULL, { cmocka_unit_test(test_x), }),
 * as the group name, between the group fixtures (either may be NULL).
 */
#define SUITE_MAIN(name, group_setup, group_teardown, ...)                        \
	int main(void)                                                            \
	{                                                                         \
		static const struct CMUnitTest suite_tests[] = __VA_ARGS__;       \
                                                                                  \
		return SUITE_RUN(name, suite_tests, group_setup, group_teardown); \
	}

/* SUITE_MAIN() whose every test runs between setup and teardown (suite_fixture()). */
#define SUITE_MAIN_FIXTURE(name, setup, teardown, group_setup, group_teardown, ...) \
	int main(void)                                                              \
	{                                                                           \
		static struct CMUnitTest suite_tests[] = __VA_ARGS__;               \
                                                                                    \
		suite_fixture(suite_tests, SUITE_N(suite_tests), setup, teardown);  \
		return SUITE_RUN(name, suite_tests, group_setup, group_teardown);   \
	}

#endif /* RMD_TESTS_SUITE_H */
