// SPDX-License-Identifier: MIT
/* The injected clock (clock.h). */
#include <stdint.h>

#include "harness/clock.h"

int64_t t_now;

int64_t fake_now(void *ctx)
{
	(void)ctx;
	return t_now;
}

void fake_sleep(void *ctx, int64_t ns)
{
	(void)ctx;
	t_now += ns;
}
