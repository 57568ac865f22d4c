/* SPDX-License-Identifier: MIT */
/*
 * The suites' one pseudo-random generator: splitmix64, the same sequence
 * from the same seed on every libc, so a failing seed (printed by the
 * suite, repeated with RMD_TEST_SEED=n) replays the failure.
 */
#ifndef RMD_TESTS_RNG_H
#define RMD_TESTS_RNG_H

#include <stdint.h>

/* The next 64 random bits; advances *state. */
uint64_t splitmix64(uint64_t *state);

#endif /* RMD_TESTS_RNG_H */
