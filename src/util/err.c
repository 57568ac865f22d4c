// SPDX-License-Identifier: MIT
#include <stdarg.h>
#include <stdio.h>

#include "rmd/err.h"

int rmd_errf(char *err, size_t len, int ret, const char *fmt, ...)
{
	va_list ap;

	if (err && len) {
		va_start(ap, fmt);
		vsnprintf(err, len, fmt, ap);
		va_end(ap);
	}
	return ret;
}
