/* SPDX-License-Identifier: MIT */
/*
 * Allocator calls counted (STYLE.md "Tests": the rt paths allocate
 * nothing).  Every suite is linked with
 * -Wl,--wrap=malloc,--wrap=calloc,--wrap=realloc,--wrap=free (the
 * Makefile's rule for tests), so each such call from rmdd's code or the
 * suite's goes through alloc_count.c, which counts it while counting is on
 * and forwards it to the C library.  Calls from inside other shared
 * libraries (libc itself, cmocka) are not seen.
 *
 * AddressSanitizer owns malloc itself: under SANITIZE=1 nothing is counted
 * and alloc_count_available() is false, so a suite skips its checks.
 */
#ifndef RMD_TESTS_ALLOC_COUNT_H
#define RMD_TESTS_ALLOC_COUNT_H

#include <stdbool.h>

/* False under AddressSanitizer: the counter then stays 0. */
bool alloc_count_available(void);

/* Count from now on (the count is kept: alloc_count_reset() clears it). */
void alloc_count_start(void);

/* Stop counting; returns the count. */
unsigned long alloc_count_stop(void);

/* Calls counted so far. */
unsigned long alloc_count(void);

void alloc_count_reset(void);

#endif /* RMD_TESTS_ALLOC_COUNT_H */
