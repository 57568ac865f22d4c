// SPDX-License-Identifier: MIT
/* The --wrap'ed allocator and its counter (alloc_count.h). */
#include <stdbool.h>
#include <stddef.h>

#include "harness/alloc_count.h"

#if defined(__SANITIZE_ADDRESS__)
#define UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define UNDER_ASAN 1
#endif
#endif
#ifndef UNDER_ASAN
#define UNDER_ASAN 0
#endif

static volatile bool counting;
static volatile unsigned long n_calls;

void *__real_malloc(size_t size);
void *__real_calloc(size_t n, size_t size);
void *__real_realloc(void *p, size_t size);
void __real_free(void *p);
void *__wrap_malloc(size_t size);
void *__wrap_calloc(size_t n, size_t size);
void *__wrap_realloc(void *p, size_t size);
void __wrap_free(void *p);

static void count(void)
{
	if (counting && !UNDER_ASAN)
		n_calls++;
}

void *__wrap_malloc(size_t size)
{
	count();
	return __real_malloc(size);
}

void *__wrap_calloc(size_t n, size_t size)
{
	count();
	return __real_calloc(n, size);
}

void *__wrap_realloc(void *p, size_t size)
{
	count();
	return __real_realloc(p, size);
}

void __wrap_free(void *p)
{
	count();
	__real_free(p);
}

bool alloc_count_available(void)
{
	return !UNDER_ASAN;
}

void alloc_count_start(void)
{
	counting = true;
}

unsigned long alloc_count_stop(void)
{
	counting = false;
	return n_calls;
}

unsigned long alloc_count(void)
{
	return n_calls;
}

void alloc_count_reset(void)
{
	n_calls = 0;
}
