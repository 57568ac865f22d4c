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

#endif /* RMD_TESTS_SUITE_H */
